// The page of `flexure view` (flexure/core/reporting/html_view.py writes it): plotly.io runs
// this once the plot is drawn, with {plot_id} the plot's div and __DATA__ the payload.
// Every shape is drawn as points = base + magnification * amplitude * D[frame].
const DATA = __DATA__;
const gd = document.getElementById('{plot_id}');
function decode(text) {
  const bytes = Uint8Array.from(atob(text), c => c.charCodeAt(0));
  return new Float32Array(bytes.buffer);
}
for (const c of Object.values(DATA.configurations)) {
  c.lines = decode(c.lines); c.nodes = decode(c.nodes);
}
for (const s of DATA.shapes) { s.lines = decode(s.lines); s.nodes = decode(s.nodes); }
const d = DATA.dimension, AXES = ['x', 'y', 'z'].slice(0, d);
const state = {shape: -1, magnification: 1, frame: 0, playing: false, busy: false,
               pending: false, done: Promise.resolve()};

function amplitude(shape, frame) {
  return shape.kind === 'mode' ? Math.sin(2 * Math.PI * frame / DATA.phases) : 1;
}
// base + m a D of the points at `offset` frames into a field: one array per axis
function columns(base, field, count, factor, offset, pick) {
  const out = AXES.map(() => []);
  const rows = pick || [...Array(count).keys()];
  for (const i of rows) {
    for (let k = 0; k < d; k++) {
      const b = base[i * d + k];
      out[k].push(Number.isNaN(b) ? null : b + factor * (field ? field[offset + i * d + k] : 0));
    }
  }
  return out;
}
function current() {
  const s = DATA.shapes[state.shape];
  const c = DATA.configurations[s ? s.base : 'initial'];
  const factor = s ? state.magnification * amplitude(s, state.frame) : 0;
  const frame = s && s.kind === 'simulation' ? state.frame : 0;
  return {
    lines: columns(c.lines, s && s.lines, c.lineCount, factor, frame * c.lineCount * d),
    nodes: columns(c.nodes, s && s.nodes, c.nodeCount, factor, frame * c.nodeCount * d),
    fixed: columns(c.nodes, s && s.nodes, c.nodeCount, factor, frame * c.nodeCount * d,
                   DATA.fixedNodes),
  };
}
// one restyle at a time: a change asked for meanwhile is drawn once it is done, so a heavy
// model drops frames instead of queueing them; the promise resolves when the page shows it
function draw() {
  if (state.busy) { state.pending = true; return state.done; }
  state.busy = true;
  state.done = (async () => {
    do {
      state.pending = false;
      const p = current(), update = {}, t = DATA.traces;
      AXES.forEach((axis, k) => { update[axis] = [p.lines[k], p.nodes[k], p.fixed[k]]; });
      await Plotly.restyle(gd, update, [t.deformed, t.nodes, t.fixed]);
    } while (state.pending);
    state.busy = false;
    label();
  })();
  return state.done;
}

// -- the controls --------------------------------------------------------------------------
const bar = document.createElement('div');
bar.id = 'flexure-controls';
bar.style.cssText = 'font: 14px sans-serif; padding: 6px; display: flex; gap: 14px; ' +
                    'flex-wrap: wrap; align-items: center';
bar.innerHTML = '<label>show <select id="fv-shape"></select></label>' +
  '<button id="fv-play" type="button">pause</button>' +
  '<label>magnification <input id="fv-magnification" type="range" step="0.01"></label>' +
  '<span id="fv-magnification-text"></span>' +
  '<label id="fv-frame-label">frame <input id="fv-frame" type="range" min="0" step="1"></label>' +
  '<span id="fv-frame-text"></span>';
gd.parentNode.insertBefore(bar, gd);
const $ = id => document.getElementById(id);
const menu = $('fv-shape');
menu.add(new Option('the undeformed model', '-1'));
DATA.shapes.forEach((s, i) => menu.add(new Option(s.label, String(i))));

function frameCount(s) { return !s ? 1 : s.kind === 'mode' ? DATA.phases : s.frames; }
function label() {
  const s = DATA.shapes[state.shape];
  const m = state.magnification;
  $('fv-magnification-text').textContent = !s ? '' : `displacements x ${m.toPrecision(3)}` +
    ` (largest ${(100 * m * s.largest / DATA.size).toPrecision(3)} % of the model's size)`;
  $('fv-frame-text').textContent = !s ? '' : s.kind === 'simulation' ?
    `t = ${s.times[state.frame].toPrecision(5)} s` : s.kind === 'mode' ?
    `phase ${Math.round(360 * state.frame / DATA.phases)} deg ` +
    `(${s.frequency.toPrecision(4)} Hz)` : '';
  $('fv-play').textContent = state.playing ? 'pause' : 'play';
}
function show(index) {
  state.shape = index;
  const s = DATA.shapes[index];
  menu.value = String(index);
  const m0 = s ? s.magnification : 1;
  const slider = $('fv-magnification');
  slider.min = Math.min(Math.log10(m0) - 3, 0); slider.max = Math.max(Math.log10(m0) + 1, 0);
  state.magnification = m0; slider.value = Math.log10(m0);
  slider.disabled = !s;
  const frames = frameCount(s);
  $('fv-frame').max = frames - 1;
  $('fv-frame-label').style.display = frames > 1 ? '' : 'none';
  $('fv-play').style.display = frames > 1 ? '' : 'none';
  state.frame = s && s.kind === 'mode' ? DATA.phases / 4 : 0;  // a mode at its full swing
  $('fv-frame').value = state.frame;
  state.playing = frames > 1;
  Plotly.relayout(gd, {'title.text': s ? s.title : `${DATA.name}: the undeformed model`});
  return draw();
}
function setMagnification(m) {
  state.magnification = m; $('fv-magnification').value = Math.log10(m); return draw();
}
function setFrame(k) { state.frame = k; $('fv-frame').value = k; return draw(); }
menu.addEventListener('change', () => show(Number(menu.value)));
$('fv-magnification').addEventListener('input', e => {
  state.magnification = Math.pow(10, Number(e.target.value)); draw(); });
$('fv-frame').addEventListener('input', e => {
  state.playing = false; setFrame(Number(e.target.value)); });
$('fv-play').addEventListener('click', () => { state.playing = !state.playing; label(); });

let last = 0;
function tick(now) {
  const s = DATA.shapes[state.shape];
  if (state.playing && s && !state.busy && now - last >= 1000 / DATA.fps) {
    last = now;
    setFrame((state.frame + 1) % frameCount(s));
  }
  requestAnimationFrame(tick);
}
window.flexureView = {data: DATA, state, show, setMagnification, setFrame, current,
                      pause: () => { state.playing = false; label(); },
                      ready: show(DATA.shapes.length ? 0 : -1)};
requestAnimationFrame(tick);
