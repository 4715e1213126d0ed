"""The result of a closed-loop run: its samples, the summary `flexure loop` prints, its plot.

The error reported is max_k |e_k| over the samples, during the move and a settling time after
it, against the target `TARGET` (0.1 % of the stroke).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from os import PathLike

import numpy as np

TARGET = 1e-3  # the tracking target: max |error| / stroke


@dataclass
class LoopResult:
    """The samples of a closed-loop run and its summary.

    t (N+1,) s; reference, position, error (N+1, n_loops) m; force, feedforward
    (N+1, n_loops) N, the force held from t_k (the last row repeats the one before). A loop on
    a planar angle has rad and N m instead (`units`). `disturbance` (N+1, n_loops) N: the
    sinusoidal force added at the actuators (disturbances.py), None without one.
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

    @property
    def units(self) -> dict:
        """{"position": "m" or "rad", "force": "N" or "N m"}: the moving loop's units."""
        return self.settings.get("units", {"position": "m", "force": "N"})

    @property
    def error(self) -> np.ndarray:
        """r - y (m), (N+1, n_loops)."""
        return self.reference - self.position

    @property
    def max_abs_error(self) -> float:
        """The largest |r - y| (m) over the samples and the loops."""
        return float(np.max(np.abs(self.error)))

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

    def per_loop(self) -> list[dict]:
        """Each loop's stroke, largest |error| and their ratio against the target.

        Returns
        -------
        list of dict
            Per loop: "loop" (its name), "stroke" and "max_abs_error" (m, rad on an angle),
            "error_ratio" (unitless), "passed", and "units" ("m" and "N", or "rad" and
            "N m") where the run recorded them.
        """
        names = self.design.get("loops", [])
        units = self.settings.get("loop_units", [])
        rows = []
        for k, (stroke, error) in enumerate(zip(self.loop_strokes,
                                                np.max(np.abs(self.error), axis=0),
                                                strict=True)):
            ratio = float(error / stroke) if stroke > 0 else float("inf")
            rows.append({"loop": names[k] if k < len(names) else str(k),
                         "stroke": float(stroke), "max_abs_error": float(error),
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
            `FeedbackDesign.summary`, "wall_time_s" s; "units" names the moving loop's;
            "path" the move path's kind and targets (m, rad), or None.
        """
        ratio = self.max_abs_error / abs(self.stroke)
        axis = self.settings.get("axis", 0)
        return {
            "scene": self.settings.get("scene"), "plant": self.settings.get("plant"),
            "feedforward": self.settings.get("feedforward"),
            "feedforward_kind": self.settings.get("feedforward_kind"),
            "max_abs_error": self.max_abs_error, "stroke": self.stroke,
            "error_ratio": ratio, "target": TARGET, "passed": bool(ratio <= TARGET),
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
            "units": self.units,
            "per_loop": self.per_loop(),
            "controller_kind": self.design.get("controller_kind", "designed"),
            "robustness_checked": self.design.get("robustness_checked", True),
            "reference_kind": self.settings.get("reference", "profile"),
            "path": self.settings.get("path"),
            **{key: self.settings[key] for key in ("quantum", "disturbance")
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
        given = self.settings.get("reference") in ("samples", "callable")
        if self.settings.get("path") or (given and self.reference.shape[1] > 1):
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
                     label="total moment" if force_unit == "N m" else "total force")
        axes[2].step(self.t, self.feedforward[:, axis], where="post", ls="--",
                     label="feedforward")
        if self.disturbance is not None:
            axes[2].step(self.t, self.disturbance[:, axis], where="post", ls=":", lw=0.8,
                         label="disturbance")
        axes[2].set_ylabel(f"{'moment' if force_unit == 'N m' else 'force'} ({force_unit})")
        axes[2].set_xlabel("time (s)")
        axes[2].legend(loc="upper right")
        s = self.summary()
        return _save(fig, path, title or (
            f"{s['scene']} ({s['plant']}): stroke {self.stroke * 1e3:g} m{length}, "
            f"max |e| = {s['max_abs_error'] * 1e6:.3g} u{length} = "
            f"{100 * s['error_ratio']:.3g} % "
            f"(target 0.1 %), {'passed' if s['passed'] else 'FAILED'}{self._noise_note()}"))

    def _plot_loops(self, path, *, title=None):
        """Every loop's reference, error (against 0.1 % of its stroke) and force."""
        length, force_unit = self.units["position"], self.units["force"]
        names = self.design.get("loops", [])
        fig, axes = _figure(9)
        for k in range(self.reference.shape[1]):
            label = names[k].split(" -> ")[-1] if k < len(names) else str(k)
            axes[0].plot(self.t, (self.reference[:, k] - self.reference[0, k]) * 1e3,
                         label=label)
            stroke = self.loop_strokes[k]
            axes[1].plot(self.t, self.error[:, k] / (TARGET * stroke) if stroke > 0
                         else 0 * self.t, label=label)
            axes[2].step(self.t, self.force[:, k], where="post", label=label)
        axes[0].set_ylabel(f"reference - start (m{length})")
        axes[0].legend(loc="upper left", ncol=3, fontsize=8)
        axes[1].axhline(1.0, color="r", lw=0.8, ls=":")
        axes[1].axhline(-1.0, color="r", lw=0.8, ls=":", label="target")
        axes[1].set_ylabel("error / (0.1 % of its stroke)")
        axes[2].set_ylabel(f"force ({force_unit})")
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
