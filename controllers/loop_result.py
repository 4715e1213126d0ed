"""The result of a closed-loop run: its samples, the summary `flexure loop` prints, its plot.

The error reported is max_k |e_k| over the samples, during the move and a settling time after
it, against the target `TARGET` (0.1 % of the stroke). A loop that holds its position while
another moves (a stroke of zero) is judged on its absolute error against the target of the
moving stroke in its own unit (`LoopResult.loop_bounds`); the run passes when every loop does.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from os import PathLike

import numpy as np

TARGET = 1e-3  # the tracking target: max |error| / stroke
HELD_BELOW = 1e-9  # a loop whose stroke is below this times the run's holds its position


@dataclass
class LoopResult:
    """The samples of a closed-loop run and its summary.

    t (N+1,) s; reference, position, error (N+1, n_loops) m; force, feedforward
    (N+1, n_loops) N, the force held from t_k (the last row repeats the one before). A loop on
    a planar angle has rad and N m instead (`units`). `disturbance` (N+1, n_loops) N: the
    sinusoidal force added at the actuators (disturbances.py), None without one.
    `wall_time_s` and `cpu_time_s` (s): the loop's samples alone, the process's CPU (user +
    system, every thread) for the latter.
    """

    t: np.ndarray
    reference: np.ndarray
    position: np.ndarray
    force: np.ndarray
    feedforward: np.ndarray
    stroke: float
    design: dict
    settings: dict = field(default_factory=dict)
    wall_time_s: float = 0.0
    disturbance: np.ndarray | None = None
    cpu_time_s: float = 0.0

    @property
    def units(self) -> dict:
        """{"position": "m" or "rad", "force": "N" or "N m"}: the moving loop's units."""
        return self.settings.get("units", {"position": "m", "force": "N"})

    @property
    def loop_units(self) -> list[dict]:
        """Each loop's {"position": ..., "force": ...} units: as the run recorded them, the
        moving loop's (`units`) for a loop it did not record."""
        recorded = self.settings.get("loop_units", [])
        return [*recorded, *[self.units] * (self.reference.shape[1] - len(recorded))]

    @property
    def error(self) -> np.ndarray:
        """r - y (m), (N+1, n_loops)."""
        return self.reference - self.position

    @property
    def max_abs_error(self) -> float:
        """The largest |r - y| over the samples and the loops in the moving loop's unit (m, or
        rad on an angle: `units`); a loop in another unit is in `per_loop`."""
        unit = self.units["position"]
        same = [k for k, u in enumerate(self.loop_units) if u["position"] == unit]
        return float(np.max(np.abs(self.error[:, same])))

    @property
    def loop_strokes(self) -> np.ndarray:
        """Each loop's stroke (m): the largest |r_k - r_0| of its reference, (n_loops,)."""
        return np.max(np.abs(self.reference - self.reference[0]), axis=0)

    @property
    def feedback_force(self) -> np.ndarray:
        """The part of the force (N) the feedback computed: force - feedforward - disturbance,
        (N+1, n_loops)."""
        open_loop = self.feedforward if self.disturbance is None else (
            self.feedforward + self.disturbance)
        return self.force - open_loop

    @property
    def held_loops(self) -> np.ndarray:
        """Which loops hold their position (n_loops,) bool: a stroke below HELD_BELOW times
        the largest stroke of the run, an angle's through the mechanism's size (a move's
        path puts round-off, 1e-17 m, into the strokes of the coordinates it holds)."""
        run = self.units["position"]
        converted = np.array([self._converted(stroke, u["position"], run) for stroke, u
                              in zip(self.loop_strokes, self.loop_units, strict=True)])
        return converted <= HELD_BELOW * np.max(converted, initial=0.0)

    def _converted(self, value, unit, to):
        """`value` in `unit` ("m" or "rad") in the unit `to`: an angle theta as theta L, a
        length l as l / L (L: the mechanism's size, settings "size", m; 0 without one)."""
        if unit == to:
            return value
        size = self.settings.get("size", 0.0)
        if size <= 0:
            return 0.0
        return value * size if unit == "rad" else value / size

    @property
    def loop_scales(self) -> np.ndarray:
        """The stroke each loop's error is measured against (m, rad), (n_loops,): a moving
        loop's own stroke; a held loop's (`held_loops`), the largest stroke of the moving
        loops in its unit, or, where none moves in its unit, the largest moving stroke
        converted through the mechanism's size L (settings "size", m): an angle theta moves
        a point at L by theta L. Zero where nothing moves."""
        strokes = self.loop_strokes
        units = [u["position"] for u in self.loop_units]
        held = self.held_loops
        moving = np.flatnonzero(~held)
        scales = np.where(held, 0.0, strokes)
        for k in np.flatnonzero(held):
            same = [strokes[j] for j in moving if units[j] == units[k]]
            converted = [self._converted(strokes[j], units[j], units[k]) for j in moving]
            scales[k] = max(same) if same else max(converted, default=0.0)
        return scales

    @property
    def loop_bounds(self) -> np.ndarray:
        """Each loop's largest allowed |error| (m, rad): TARGET times `loop_scales`."""
        return TARGET * self.loop_scales

    def per_loop(self) -> list[dict]:
        """Each loop's stroke, largest |error| and their ratio against the target.

        Returns
        -------
        list of dict
            Per loop: "loop" (its name), "stroke" and "max_abs_error" (m, rad on an angle),
            "held" (`held_loops`: judged against the moving stroke, `loop_scales`),
            "error_ratio" (unitless: the error over `loop_scales`, inf where nothing moves),
            "passed", and "units" ("m" and "N", or "rad" and "N m") where the run recorded
            them.
        """
        names = self.design.get("loops", [])
        units = self.settings.get("loop_units", [])
        rows = []
        for k, (stroke, held, scale, error) in enumerate(zip(
                self.loop_strokes, self.held_loops, self.loop_scales,
                np.max(np.abs(self.error), axis=0), strict=True)):
            ratio = float(error / scale) if scale > 0 else float("inf")
            rows.append({"loop": names[k] if k < len(names) else str(k),
                         "stroke": float(stroke), "held": bool(held),
                         "max_abs_error": float(error),
                         "error_ratio": ratio, "passed": bool(ratio <= TARGET)})
            if k < len(units):
                rows[-1]["units"] = units[k]
        return rows

    def summary(self) -> dict:
        """The dictionary `flexure loop --json` prints.

        Returns
        -------
        dict
            SI units: errors, strokes and positions m (rad), forces N (N m), margins as
            `FeedbackDesign.summary`, "wall_time_s" and "cpu_time_s" s; "units" names the
            moving loop's; "path" the move path's kind and targets (m, rad), or None;
            "kinematic_inputs" (a scene with them) each one's start and value (m, rad),
            motion_duration (s) and effort_end (N, N m) at the last sample.
        """
        loops = self.per_loop()
        ratio = max(row["error_ratio"] for row in loops)  # the worst loop's
        axis = self.settings.get("axis", 0)
        return {
            "scene": self.settings.get("scene"), "plant": self.settings.get("plant"),
            "feedforward": self.settings.get("feedforward"),
            "feedforward_kind": self.settings.get("feedforward_kind"),
            "max_abs_error": self.max_abs_error, "stroke": self.stroke,
            "error_ratio": ratio, "target": TARGET,
            "passed": all(row["passed"] for row in loops),
            "max_abs_error_during_move": float(np.max(np.abs(
                self.error[self.t <= self.settings.get("move_end", np.inf), axis]))),
            "final_error": float(np.max(np.abs(self.error[-1]))),
            "max_abs_force": float(np.max(np.abs(self.force))),
            "max_abs_feedback_force": float(np.max(np.abs(self.feedback_force))),
            "phase_margin_deg": self.design["phase_margin_deg"],
            "gain_margin": self.design["gain_margin"],
            "modulus_margin": self.design["modulus_margin"],
            "crossover_rad_s": self.design["crossover_rad_s"],
            "sample_rate_hz": self.design["sample_rate_hz"],
            "closed_loop_spectral_radius": self.design["closed_loop_spectral_radius"],
            "loops": self.design["loops"],
            **{key: self.design[key] for key in (
                "phase_margin_others_closed_deg", "gain_margin_others_closed",
                "modulus_margin_others_closed", "sensitivity_peak") if key in self.design},
            "duration": self.settings.get("duration"), "settle": self.settings.get("settle"),
            "rtol": self.settings.get("rtol"), "wall_time_s": self.wall_time_s,
            "cpu_time_s": self.cpu_time_s,
            "units": self.units,
            "per_loop": loops,
            "controller_kind": self.design.get("controller_kind", "designed"),
            "robustness_checked": self.design.get("robustness_checked", True),
            "reference_kind": self.settings.get("reference", "profile"),
            "path": self.settings.get("path"),
            "warnings": list(self.settings.get("warnings", [])),
            **{key: self.settings[key] for key in ("quantum", "disturbance",
                                                   "kinematic_inputs")
               if key in self.settings},
        }

    def plot(self, path: str | PathLike, *, title: str | None = None) -> str | PathLike:
        """Reference, position, error and force against time (s), saved as a PNG.

        Parameters
        ----------
        path : str or path-like
            The image file.
        title : str, optional
            The figure's title (default: the scene, plant and error ratio).

        Returns
        -------
        str or path-like
            `path`.
        """
        if self.reference.shape[1] > 1:  # every loop, the held ones too
            return self._plot_loops(path, title=title)
        axis = self.settings.get("axis", 0)
        length, force_unit = self.units["position"], self.units["force"]
        what = "angle" if length == "rad" else "position"
        fig, axes = _figure(8)
        axes[0].plot(self.t, self.reference[:, axis] * 1e3, label="reference")
        axes[0].plot(self.t, self.position[:, axis] * 1e3, "--", label=what)
        axes[0].set_ylabel(f"{what} (m{length})")
        axes[0].legend(loc="lower right")
        band = TARGET * abs(self.stroke) * 1e6
        error = self.error[:, axis] * 1e6
        axes[1].plot(self.t, error, label="error r - y")
        if np.max(np.abs(error)) > 0.05 * band:  # the target band would flatten the error
            axes[1].axhline(band, color="r", lw=0.8, ls=":",
                            label=f"target +-{band:.3g} u{length}")
            axes[1].axhline(-band, color="r", lw=0.8, ls=":")
        else:
            axes[1].text(0.01, 0.04, f"target +-{band:.3g} u{length}: far off this scale",
                         transform=axes[1].transAxes, va="bottom", fontsize=9, color="r")
        axes[1].set_ylabel(f"error (u{length})")
        axes[1].legend(loc="upper right")
        axes[2].step(self.t, self.force[:, axis], where="post",
                     label=f"total {effort_name(force_unit)}")
        axes[2].step(self.t, self.feedforward[:, axis], where="post", ls="--",
                     label="feedforward")
        if self.disturbance is not None:
            axes[2].step(self.t, self.disturbance[:, axis], where="post", ls=":", lw=0.8,
                         label="disturbance")
        axes[2].set_ylabel(f"{effort_name(force_unit)} ({force_unit})")
        axes[2].set_xlabel("time (s)")
        axes[2].legend(loc="upper right")
        s = self.summary()
        return _save(fig, path, title or (
            f"{s['scene']} ({s['plant']}): stroke {self.stroke * 1e3:g} m{length}, "
            f"max |e| = {s['max_abs_error'] * 1e6:.3g} u{length} = "
            f"{100 * s['error_ratio']:.3g} % "
            f"(target 0.1 %), {'passed' if s['passed'] else 'FAILED'}{self._noise_note()}"))

    def _plot_loops(self, path, *, title=None):
        """Every loop's reference, error (against 0.1 % of its stroke, a held loop's against
        that of the moving stroke: `loop_scales`) and force."""
        names = self.design.get("loops", [])
        units = self.loop_units
        lengths = sorted({u["position"] for u in units})
        forces = sorted({u["force"] for u in units})
        fig, axes = _figure(9)
        for k in range(self.reference.shape[1]):
            name = names[k].split(" -> ")[-1] if k < len(names) else str(k)
            held = ", held" if self.held_loops[k] else ""
            label = f"{name} ({units[k]['position']}{held})" if len(lengths) > 1 or held \
                else name
            axes[0].plot(self.t, (self.reference[:, k] - self.reference[0, k]) * 1e3,
                         label=label)
            bound = self.loop_bounds[k]
            axes[1].plot(self.t, self.error[:, k] / bound if bound > 0 else 0 * self.t)
            axes[2].step(self.t, self.force[:, k], where="post")
        axes[0].set_ylabel(f"reference - start (m{', m'.join(lengths)})")
        axes[0].legend(loc="upper left", ncol=3, fontsize=8)
        axes[1].axhline(1.0, color="r", lw=0.8, ls=":")
        axes[1].axhline(-1.0, color="r", lw=0.8, ls=":", label="target")
        axes[1].set_ylabel("error / (0.1 % of the stroke)")
        names = ", ".join(dict.fromkeys(effort_name(unit) for unit in forces))
        axes[2].set_ylabel(f"{names} ({', '.join(forces)})")
        axes[2].set_xlabel("time (s)")
        worst = max(self.per_loop(), key=lambda row: row["error_ratio"])
        return _save(fig, path, title or (
            f"{self.settings.get('scene')} ({self.settings.get('plant')}): every loop along "
            f"the move;\nworst {worst['loop']}: {100 * worst['error_ratio']:.3g} % of its "
            f"stroke (target 0.1 %){self._noise_note()}"))

    def _noise_note(self) -> str:
        """The disturbances for a plot's title: '' without any; quantum and force as the
        first loop has them."""
        length = self.units["position"]
        parts = []
        if "quantum" in self.settings:
            parts.append(f"encoders of {self.settings['quantum'][0]:g} {length}")
        if "disturbance" in self.settings:
            d = self.settings["disturbance"]
            force = "N m" if length == "rad" else "N"
            parts.append(f"{d['amplitude'][0]:g} {force} at {d['frequency_hz']:g} Hz")
        return "\nwith " + " and ".join(parts) if parts else ""


def _figure(height):
    """A figure 8 in wide and `height` in high with three axes sharing time, drawn by Agg.

    matplotlib's object API rather than pyplot: no figure registered in pyplot's global
    state (a library's plots need not be closed), and a little less to import and draw
    (0.47 s against 0.49 s of CPU for the loop's plot, docs/benchmarks.md)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg  # 0.3 s: only where used
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, height))
    FigureCanvasAgg(fig)
    return fig, fig.subplots(3, 1, sharex=True)


def _save(fig, path, title):
    """Title, lay out and write a figure (PNG, or the format of the path's suffix); returns
    path."""
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path


def effort_name(unit: str) -> str:
    """What a loop's input is, by its unit: a force (N), a moment (N m) or a voice coil's
    drive signal (V)."""
    return {"N m": "moment", "V": "drive signal"}.get(unit, "force")
