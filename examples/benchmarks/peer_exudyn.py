"""The peer side of flexure's speed benchmark: the planar leaf-spring stage in Exudyn.

The same work as flexure on stage_planar_3dof (a 1 N step for 1 s, `step_response`,
`work_precision`) and stage_planar_1dof (`flexure loop` with its defaults, `closed_loop`),
modelled with Exudyn's ANCF cable elements and integrated by its generalized-alpha solver.

The model
---------
The stage of examples/scenes/stage_planar_{1,3}dof.toml, its sections read from the scene:
a bar from (0, 0.1) to (0.1, 0.1) m on two vertical leaf springs of 0.1 m clamped at (0, 0)
and (0.1, 0). The input F (N) acts in x on the bar's left end (flexure's node 3); the output
is the x position (m) of that point.

- Each leaf spring: `n` ObjectANCFCable2D elements (cubic planar ANCF cable, nodes
  NodePoint2DSlope1 with position and slope), EA = E w h = 1.89e6 N, EI = E w h^3 / 12 =
  0.039375 N m^2, rho A = rho w h = 0.07065 kg/m, consistent mass. The clamp fixes x, y and
  the x slope of the bottom node (the y slope, which carries the axial strain, stays free).
- The bar: a rigid body (NodeRigidBody2D, ObjectRigidBody2D) at its centre (0.05, 0.1) m
  with the mass 0.206 kg (rho A = 2.06 kg/m over 0.1 m) and the rotational inertia of a
  uniform bar about its centre, m L^2 / 12 = 1.717e-4 kg m^2: what flexure's rigid PLBEAM
  with its consistent mass carries. A rigid body rather than a stiff cable: a cable's slope
  nodes cannot be shared with the vertical leaves at a right angle, and a stiff element
  would only add a stiff mode.
- Each leaf top is welded to its bar end by an ObjectJointGeneric (x, y and the rotation
  about z) between MarkerBodyRigid markers on the cable end and on the bar.
- Damping: the cable's bendingDamping and axialDamping are the scene's EdI (N m^2 s) and EdA
  (N s), viscous in the rates of curvature and axial strain: the same stiffness-proportional
  deformation-rate damping as the scene's PLBEAMs (Ed / E times the stiffness of the
  deformations). The rigid bar is undamped on both sides.
- Solver: generalized-alpha (Exudyn's default implicit solver; spectral radius 0.9), fixed
  step h, Exudyn's modified Newton (Jacobian kept over steps), no solution file; the
  position is stored every step by a sensor.

Checks (Exudyn 1.13.6). First natural frequency from ComputeODE2Eigenvalues (joints
projected out), flexure 10.645 Hz; static stiffness F / x at F = 1 N (SolveStatic), the
linear 24 EI / l^3 = 945 N/m:

    n    f1 (Hz)    f2, f3 (Hz)           F / x at 1 N (N/m)
    1    10.64472   2131.6, 3598.0        1000.6  (945.17 with reduced_integration)
    2    10.64462    270.1,  271.7         959.9  (959.7)
    4    10.64461    266.2,  267.7         945.56
    8    10.64461    265.9,  267.4         945.09
    16   10.64461    265.8,  267.4         945.08

For n = 1 the modes above are flexure's 3-DOF ones (vertical 2129 Hz, rotation 3585 Hz);
from n = 2 on the leaves' own bending modes (266 Hz, as a clamped-clamped leaf) appear,
which flexure's one PLBEAM per spring does not have (its 4-element model would).

What is not flexure's model
---------------------------
- Membrane locking: with its full Gauss integration one cable per spring is 6 % too stiff
  at 1 mm of deflection (the cubic element cannot bend without stretching), 1.6 % with two;
  its first frequency, taken at rest, does not show it. `reduced_integration=True`
  (useReducedOrderIntegration) cures n = 1, not n = 2; n >= 4 is converged. flexure's
  PLBEAM carries no such error.
- The cable always has its axial compliance EA: stage_planar_3dof (elongations released).
  stage_planar_1dof has inextensible leaves, so the closed loop runs on the 3-DOF
  mechanics (its extra modes, at 2.1 and 3.6 kHz, are barely driven by an x force).
- Geometric nonlinearity: at 1 N (about 1 mm) the converged cables give 945.08 N/m, flexure
  945.000 N/m on stage_planar_1dof and 944.976 N/m on stage_planar_3dof (its static
  equilibrium): a 1e-4 difference of the two beam theories at a deflection of l / 100.
  This model difference, not the integrator (more steps per sample do not lower it), sets
  the closed-loop error: a few nm, against 4e-11 m for flexure on its own model.
- The damping acts on the axial strain and curvature rates at the cable's Gauss points,
  flexure's on the rates of the element's generalised deformations (e1, e2, e3); both are
  Ed / E times the corresponding stiffness, so they agree as far as the stiffnesses do.
- Integration: a fixed step with no error control (flexure's CVODE controls its error);
  generalized-alpha at spectral radius 0.9 damps the modes above ~1 / h a little.
- In the loop the load u_k, set in the PreStepUserFunction, is the load of the step's
  equilibrium at its end (generalized-alpha solves the equations at t_(k+1)); the previous
  step's load reaches it through the algorithmic accelerations. flexure holds u_k exactly
  over [t_k, t_(k+1)); the difference is of the integrator's O(h^2).

Usage
-----
    python examples/benchmarks/peer_exudyn.py [--n 1,4] [--repeat 3]

prints the frequencies, the work-precision rows for n = 1 and 4, and the closed loop.
Requires exudyn (``pip install flexure[bench]``); `closed_loop` also flexure.controllers.
"""

import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import exudyn as exu
import exudyn.itemInterface as ei
import numpy as np

SCENES = Path(__file__).resolve().parents[1] / "scenes"  # examples/scenes
LEAF_LENGTH = 0.1  # m, the leaf springs and the bar
BAR_LENGTH = 0.1
STEPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5, 3.125e-5)  # s, fixed steps of work_precision
REFERENCE_STEP = 1e-3 / 128  # s, the step of `converged_reference`


@dataclass(frozen=True)
class Stage:
    """The sections of the stage (SI units), as in the scene file.

    Parameters
    ----------
    E : float
        Young's modulus of the leaves (Pa).
    rho : float
        Density of the leaves (kg/m^3).
    width, height : float
        Out-of-plane width and bending thickness of a leaf (m).
    EdA, EdI : float
        Axial (N s) and bending (N m^2 s) damping coefficients of a leaf.
    bar_rho_A : float
        Mass per length of the bar (kg/m).
    """

    E: float
    rho: float
    width: float
    height: float
    EdA: float
    EdI: float
    bar_rho_A: float

    @classmethod
    def from_scene(cls, scene="stage_planar_3dof"):
        """The sections of a scene: a name in examples/scenes or a scene file."""
        path = Path(scene)
        path = path if path.suffix == ".toml" else SCENES / f"{scene}.toml"
        with open(path, "rb") as handle:
            data = tomllib.load(handle)
        leaf, bar = data["sections"]["leaf"], data["sections"]["bar"]
        return cls(E=leaf["E"], rho=leaf["rho"], width=leaf["width"], height=leaf["height"],
                   EdA=leaf["EdA"], EdI=leaf["EdI"], bar_rho_A=bar["rho_A"])

    @property
    def EA(self):
        """Axial stiffness of a leaf (N)."""
        return self.E * self.width * self.height

    @property
    def EI(self):
        """Bending stiffness of a leaf (N m^2)."""
        return self.E * self.width * self.height**3 / 12

    @property
    def rho_A(self):
        """Mass per length of a leaf (kg/m)."""
        return self.rho * self.width * self.height

    @property
    def bar_mass(self):
        """Mass of the bar (kg)."""
        return self.bar_rho_A * BAR_LENGTH

    @property
    def bar_inertia(self):
        """Rotational inertia of the bar about its centre, a uniform bar (kg m^2)."""
        return self.bar_mass * BAR_LENGTH**2 / 12

    @property
    def stiffness(self):
        """Linear stiffness in x of the two clamped-guided leaves, 24 EI / l^3 (N/m)."""
        return 24 * self.EI / LEAF_LENGTH**3


@dataclass
class StageModel:
    """An assembled Exudyn model of the stage and the handles a run needs."""

    SC: object  # the SystemContainer, kept alive with its system
    mbs: object
    output_node: int  # the leaf top at the bar's left end (flexure's node 3)
    load: int  # the force in x on that node
    sensor: int  # the position of that node, stored every step


def build(n=1, stage=None, *, force=0.0, reduced_integration=False):
    """Build and assemble the stage with `n` ANCF cable elements per leaf spring.

    Parameters
    ----------
    n : int
        Elements per leaf spring.
    stage : Stage, optional
        The sections (default: those of stage_planar_3dof).
    force : float
        The constant force (N) in x on the bar's left end.
    reduced_integration : bool
        The cable's useReducedOrderIntegration (Gauss order 7 for the axial and 3 for the
        bending virtual work instead of 9 and 5): removes the membrane locking of n = 1.

    Returns
    -------
    StageModel
    """
    stage = stage or Stage.from_scene()
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddMarker(ei.MarkerNodeCoordinate(nodeNumber=mbs.AddNode(
        ei.NodePointGround()), coordinate=0))
    bar = mbs.AddObject(ei.ObjectRigidBody2D(
        mass=stage.bar_mass, inertia=stage.bar_inertia, nodeNumber=mbs.AddNode(
            ei.NodeRigidBody2D(referenceCoordinates=[BAR_LENGTH / 2, LEAF_LENGTH, 0.0]))))
    le = LEAF_LENGTH / n
    tops = []
    for x0 in (0.0, BAR_LENGTH):
        nodes = [mbs.AddNode(ei.NodePoint2DSlope1(referenceCoordinates=[x0, i * le, 0.0, 1.0]))
                 for i in range(n + 1)]
        cables = [mbs.AddObject(ei.ObjectANCFCable2D(
            length=le, massPerLength=stage.rho_A, bendingStiffness=stage.EI,
            axialStiffness=stage.EA, bendingDamping=stage.EdI, axialDamping=stage.EdA,
            useReducedOrderIntegration=int(reduced_integration),
            nodeNumbers=[nodes[i], nodes[i + 1]])) for i in range(n)]
        for coordinate in (0, 1, 2):  # the clamp: x, y and the x slope of the bottom node
            marker = mbs.AddMarker(ei.MarkerNodeCoordinate(nodeNumber=nodes[0],
                                                           coordinate=coordinate))
            mbs.AddObject(ei.CoordinateConstraint(markerNumbers=[ground, marker]))
        # the weld of the leaf top to the bar end: x, y and the rotation; the marker frame
        # on the bar is turned by 90 degrees to the cable end's (its x axis along the leaf)
        weld = [mbs.AddMarker(ei.MarkerBodyRigid(bodyNumber=bar, localHT=exu.HT(
                    rotation=_rotation_z(np.pi / 2), translation=[x0 - BAR_LENGTH / 2, 0, 0]))),
                mbs.AddMarker(ei.MarkerBodyRigid(bodyNumber=cables[-1],
                                                 localPosition=[le, 0, 0]))]
        mbs.AddObject(ei.ObjectJointGeneric(markerNumbers=weld,
                                            constrainedAxes=[1, 1, 0, 0, 0, 1]))
        tops.append(nodes[-1])
    load = mbs.AddLoad(ei.LoadForceVector(
        markerNumber=mbs.AddMarker(ei.MarkerNodePosition(nodeNumber=tops[0])),
        loadVector=[force, 0.0, 0.0]))
    sensor = mbs.AddSensor(ei.SensorNode(nodeNumber=tops[0], storeInternal=True,
                                         outputVariableType=exu.OutputVariableType.Position))
    mbs.Assemble()
    return StageModel(SC, mbs, tops[0], load, sensor)


def _rotation_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]


def simulation_settings(h, t_end, *, n=1, newton_tolerance=1e-8, newton_absolute=None):
    """Generalized-alpha at the fixed step `h` (s) up to `t_end` (s), no output files.

    `newton_tolerance` is Newton's relative tolerance on the residual (Exudyn's default
    1e-8); `newton_absolute` its absolute tolerance on the residual (N), by default
    1e-8 n^2 for `n` elements per spring: Exudyn's default 1e-10 lies below the round-off of
    the residual, which grows with the axial stiffness EA n / l of the elements (measured
    at zero load: 2e-10 N for n = 1, 3e-9 N for n = 4, 4e-8 N for n = 16), so that a step
    from zero load never converges.
    """
    if newton_absolute is None:
        newton_absolute = 1e-8 * n**2
    settings = exu.SimulationSettings()
    ti = settings.timeIntegration
    ti.numberOfSteps = int(round(t_end / h))
    ti.endTime = ti.numberOfSteps * h
    ti.adaptiveStep = False
    ti.verboseMode = 0
    ti.newton.relativeTolerance = newton_tolerance
    ti.newton.absoluteTolerance = newton_absolute
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = 0.5 * h  # every step
    settings.show.computationTime = False
    settings.show.statistics = False
    return settings


def natural_frequencies(n=1, count=3, **options):
    """The lowest natural frequencies (Hz) of the undamped stage at rest.

    Parameters
    ----------
    n : int
        Elements per leaf spring.
    count : int
        How many frequencies.
    **options
        stage, reduced_integration: passed to `build`.

    Returns
    -------
    array (count,)
        Hz; from ComputeODE2Eigenvalues, the joints projected out by its SVD.
    """
    model = build(n, **options)
    values, _ = model.mbs.ComputeODE2Eigenvalues(convert2Frequencies=True)
    values = np.sort(np.asarray(values))
    return values[values > 1e-3][:count]


def step_response(n, h, t_end=1.0, force=1.0, *, newton_tolerance=1e-8, newton_absolute=None,
                  **options):
    """A step of `force` (N) from rest on the bar's left end, in x.

    Parameters
    ----------
    n : int
        Elements per leaf spring.
    h : float
        Fixed step (s).
    t_end : float
        Simulated time (s).
    force : float
        The step (N), on from t = 0.
    newton_tolerance, newton_absolute : float
        Newton's relative and absolute (N) tolerances, see `simulation_settings`.
    **options
        stage, reduced_integration: passed to `build`.

    Returns
    -------
    t : array
        Times of the steps (s), from 0.
    x : array
        x position of the bar's left end (m) at those times (0 at rest).
    wall : float
        Wall time (s) of SolveDynamic alone (the model is built before).
    """
    model = build(n, force=force, **options)
    settings = simulation_settings(h, t_end, n=n, newton_tolerance=newton_tolerance,
                                   newton_absolute=newton_absolute)
    start = time.perf_counter()
    model.mbs.SolveDynamic(settings)
    wall = time.perf_counter() - start
    data = model.mbs.GetSensorStoredData(model.sensor)
    return data[:, 0], data[:, 1], wall


def converged_reference(n, t_end=1.0, force=1.0, *, h=REFERENCE_STEP, **options):
    """The step response at a small fixed step, Richardson-checked.

    Runs `h`, 2 `h` and 4 `h` with Newton at a tight tolerance (relative 1e-10, absolute
    1e-9 n^2 N). Generalized-alpha is of second order, so the error of the `h` run is about
    (x_h - x_2h) / 3 (`estimate`), and `observed_order`, log2 of the ratio of the largest
    differences (x_2h - x_4h) / (x_h - x_2h), confirms the order (2 when the runs are in
    the asymptotic range). The default h = 1/128 ms divides every one of `STEPS`, so their
    times are reference times.

    Parameters
    ----------
    n : int
        Elements per leaf spring.
    t_end, force : float
        Simulated time (s) and step (N).
    h : float
        The reference step (s).
    **options
        stage, reduced_integration: passed to `build`.

    Returns
    -------
    dict
        t (s), x (m): the `h` run; estimate (m): max |x_h - x_2h| / 3; observed_order;
        h (s); wall_time_s (s) of the three runs.
    """
    tight = {"newton_tolerance": 1e-10, "newton_absolute": 1e-9 * n**2}
    runs = [step_response(n, h * 2**j, t_end, force, **tight, **options) for j in range(3)]
    (t, x, _), (t2, x2, _), (t4, x4, _) = runs
    d1 = np.max(np.abs(np.interp(t4, t, x) - np.interp(t4, t2, x2)))
    d2 = np.max(np.abs(np.interp(t4, t2, x2) - x4))
    return {"t": t, "x": x, "estimate": float(np.max(np.abs(np.interp(t2, t, x) - x2)) / 3),
            "observed_order": float(np.log2(d2 / d1)), "h": h,
            "wall_time_s": sum(r[2] for r in runs)}


def work_precision(n, steps=STEPS, t_end=1.0, force=1.0, *, reference=None, repeat=3,
                   **options):
    """Error against the converged reference and wall time, per fixed step.

    Parameters
    ----------
    n : int
        Elements per leaf spring.
    steps : sequence of float
        The fixed steps (s).
    t_end, force : float
        Simulated time (s) and step (N).
    reference : dict, optional
        `converged_reference(n, t_end, force)`, computed when not given.
    repeat : int
        Runs per step; the wall time is the shortest (the machine is shared).
    **options
        stage, reduced_integration: passed to `build`.

    Returns
    -------
    list of tuple
        (h, error / stroke, wall time) per step: h (s); the largest |x - x_ref| over the
        run's step times divided by the stroke, the static deflection F l^3 / (24 EI)
        (1/945 m for 1 N); the wall time of SolveDynamic (s), the best of `repeat`.
    """
    stage = options.get("stage") or Stage.from_scene()
    reference = reference or converged_reference(n, t_end, force, **options)
    stroke = abs(force) / stage.stiffness
    rows = []
    for h in steps:
        runs = [step_response(n, h, t_end, force, **options) for _ in range(repeat)]
        (t, x, _), wall = runs[0], min(r[2] for r in runs)
        error = np.max(np.abs(x - np.interp(t, reference["t"], reference["x"])))
        rows.append((float(h), float(error / stroke), wall))
    return rows


def closed_loop(n=4, *, scene="stage_planar_1dof", stroke=1e-3, duration=1.0, fs=4000.0,
                crossover=300.0, settle=0.25, substeps=1, repeat=1, **options):
    """`flexure loop` with its defaults, on the Exudyn stage: the same controller, sampled.

    flexure designs the loop (`flexure.controllers.build_loop` on the scene's linear model:
    the PID-like feedback for `crossover` at `fs`, the modal feedforward m a + c v + k x of
    the third-order move, the reference per sample); its `LoopController` is then stepped in
    Exudyn's PreStepUserFunction with flexure's timing (controllers/runner.py): at t_k the
    force u_k, computed at t_(k-1), is applied over [t_k, t_(k+1)), y_k is measured and
    u_(k+1) = C(z) e_k + u_ff,(k+1) computed; u_0 = u_ff,0. Exudyn calls the function with
    t = the end of the step, the state still at its start.

    Parameters
    ----------
    n : int
        Elements per leaf spring.
    scene : str
        The scene whose linear model flexure designs the controller on.
    stroke, duration : float
        The move (m, s).
    fs : float
        Sample rate (Hz) of the controller.
    crossover : float
        The cross-over of the feedback (rad/s).
    settle : float
        Time simulated after the move (s).
    substeps : int
        Generalized-alpha steps per sample (h = 1 / (substeps fs)); 1 is the benchmark.
    repeat : int
        Runs (each on a new model, the same results); the wall time is the shortest.
    **options
        stage (default: the sections of `scene`), reduced_integration: passed to `build`.

    Returns
    -------
    dict
        max_abs_error (m): max_k |r_k - y_k| over the N + 1 samples, as `flexure loop`;
        max_abs_error_during_move (m): the same for t_k <= duration; error_ratio: the first
        over the stroke; wall_time_s (s): SolveDynamic alone; samples: N; t (s),
        reference (m), position (m), force (N): arrays over the samples.
    """
    from flexure.controllers import build_loop
    from flexure.core import load_scene

    controller, _ = build_loop(load_scene(scene), stroke=stroke, duration=duration, fs=fs,
                               crossover=crossover, feedforward=True, settle=settle)
    options.setdefault("stage", Stage.from_scene(scene))
    runs = [_run_loop(controller, n, substeps, **options) for _ in range(max(1, repeat))]
    t, position, force, _ = runs[0]
    error = np.abs(controller.reference[: t.size, 0] - position)
    return {"max_abs_error": float(error.max()), "error_ratio": float(error.max() / abs(stroke)),
            "max_abs_error_during_move": float(error[t <= duration].max()),
            "wall_time_s": min(r[3] for r in runs), "samples": t.size - 1, "t": t,
            "reference": controller.reference[: t.size, 0].copy(), "position": position,
            "force": force}


def _run_loop(controller, n, substeps, **options):
    """One closed-loop run: t (s), position (m), force (N) per sample and the wall time."""
    controller.reset()
    fs = controller.fs
    model = build(n, **options)
    mbs, node, load = model.mbs, model.output_node, model.load
    N, rate = controller.samples, fs * substeps
    position, force = np.empty(N + 1), np.empty(N + 1)
    pending = [float(controller.initial_output()[0])]  # u_k, the force of the next sample
    position_type = exu.OutputVariableType.Position

    def pre_step(mbs, t):
        k, sub = divmod(int(round(t * rate)) - 1, substeps)  # the step starts at t_k + sub h
        if sub == 0:
            y = mbs.GetNodeOutput(node, position_type)[0]
            u = pending[0]
            mbs.SetLoadParameter(load, "loadVector", [u, 0.0, 0.0])
            position[k], force[k] = y, u
            pending[0] = float(controller.step(k, [y])[0][0])
        return True

    mbs.SetPreStepUserFunction(pre_step)
    settings = simulation_settings(1.0 / rate, N / fs, n=n)
    settings.solution.sensors.writePeriod = 1e3  # no sensor output needed
    start = time.perf_counter()
    mbs.SolveDynamic(settings)
    wall = time.perf_counter() - start
    position[N] = mbs.GetNodeOutput(node, position_type)[0]
    force[N] = force[N - 1]
    return np.arange(N + 1) / fs, position, force, wall


def _table(headers, rows):
    widths = [max(len(str(c)) for c in column) for column in zip(headers, *rows, strict=True)]
    lines = ["  ".join(f"{c:>{w}}" for c, w in zip(row, widths, strict=True))
             for row in (headers, *rows)]
    return "\n".join([lines[0], "  ".join("-" * w for w in widths), *lines[1:]])


def main(argv=None):
    """Print the natural frequencies, the step-response work-precision and the loop."""
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", default="1,4", help="elements per spring of the work-precision "
                        "study, comma separated (default 1,4)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per timing (best taken)")
    args = parser.parse_args(argv)
    ns = [int(v) for v in args.n.split(",")]
    print(f"Exudyn {exu.__version__}: planar leaf-spring stage, ANCF cables, generalized-alpha")
    rows = [(n, *(f"{f:.4f}" for f in natural_frequencies(n, 3))) for n in (1, 2, 4, 8, 16)]
    print("\nnatural frequencies (Hz), flexure stage_planar_3dof: 10.645, 2129, 3585")
    print(_table(["n", "f1", "f2", "f3"], rows))
    for n in ns:
        reference = converged_reference(n)
        print(f"\nstep of 1 N for 1 s, n = {n}: reference h = {reference['h']:.3g} s, "
              f"Richardson error estimate {reference['estimate']:.2g} m, observed order "
              f"{reference['observed_order']:.2f}")
        rows = [(f"{h:.4g}", f"{e:.3e}", f"{w:.3f}")
                for h, e, w in work_precision(n, reference=reference, repeat=args.repeat)]
        print(_table(["h (s)", "max |x - x_ref| / stroke", "wall (s)"], rows))
    print("\nclosed loop, flexure loop's defaults (1 mm in 1 s + 0.25 s, 4 kHz, one step per "
          "sample)")
    rows = []
    for n, reduced in ((1, False), (1, True), (4, False)):
        r = closed_loop(n, reduced_integration=reduced, repeat=args.repeat)
        rows.append((n, "reduced" if reduced else "full", f"{r['max_abs_error']:.3e}",
                     f"{r['error_ratio']:.3e}", f"{r['wall_time_s']:.3f}"))
    print(_table(["n", "integration", "max |error| (m)", "error / stroke", "wall (s)"], rows))


if __name__ == "__main__":
    main()
