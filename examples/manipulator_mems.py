"""The six-DOF manipulator at the micromanipulator's scale, in silicon (issue 31).

    python examples/manipulator_mems.py            # writes examples/scenes/manipulator_mems.toml
    python examples/manipulator_mems.py --table    # prints its parameter table
    python examples/manipulator_mems.py --steps    # the frequencies from the macro design to it

The chapter's manipulator is "a scaled-up version of a micromanipulator originally designed to
be manufactured with MEMS technology ... not more than a few mm in size". This module takes
examples/manipulator.py's design (its table and its scene functions; no copy of either) down
by `SCALE` = 1/100: the 0.54 m mechanism becomes 5.4 mm across, 1.9 mm tall. Two tables:

- **Exactly scaled** (`scaled_parameters`): every length times s, the flexures' E and rho
  those of silicon, every other density (the bodies' masses) by the same ratio, Poisson's
  ratio and the damping's time constant scaled so that the design is similar in every
  dimensionless group. Each natural frequency is then the macro one times

      f_scaled / f_macro = sqrt((E_si / E_steel) / (rho_si / rho_steel)) / s = 164.7,

  (a beam's stiffness E I / l^3 goes as E s, every mass as rho s^3), up to the design's
  rounding of positions to 1e-12 m (`manipulator.design`).
- **As a MEMS process makes it** (`mems_parameters`, the scene `manipulator_mems`): the
  exactly scaled table changed where silicon and deep reactive-ion etching (DRIE) of a
  silicon-on-insulator wafer decide otherwise (`PROCESS`, docs/manipulator.md gives the
  reasoning). Each flexure's thin dimension is a lithographic line (3 to 4 um scaled, above the
  process's 2 um and within its 20:1 aspect ratio to the layer: kept); its wide dimension is
  the 50 um device layer (the design scaled asks 100 to 300 um: not made); the round 8 um
  wires become square 8 um beams; Poisson's ratio is silicon's (isotropic model, beams along
  <110> of a (100) wafer); the bodies are silicon blocks of the design's shapes (the macro
  ones are aluminium, so their masses scale with rho_si / rho_Al, not with the flexures'
  rho_si / rho_steel); and the damping is an assumed quality factor, not the steel's.

The scene is the control model's form (`manipulator.scene_control`: one beam per flexure,
every elongation prescribed zero, 75 DOFs, inputs F1 ... F6 in N on the carriages, outputs
x1 ... x6 in m and the end effector's angles in rad).
"""

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from examples.manipulator import (
    PARAMETERS,
    SCENES,
    parameter_table,
    scene_control,
    value,
)
from flexure.core.scene.scene_writer import scene_toml

SCALE = 0.01  # every length of the design times this: 0.54 m -> 5.4 mm

# Silicon, single crystal, the flexures along <110> of a (100) wafer (the usual alignment to
# the wafer flat): E = 169 GPa there (Hopcroft, Nix and Kenny, J. MEMS 19 (2010) 229). The
# model is isotropic, so Poisson's ratio only sets G = E / (2 (1 + nu)) = 66.0 GPa, between
# silicon's two shear moduli of such a beam (c44 = 79.6 and (c11 - c12) / 2 = 50.9 GPa).
SILICON = {
    "E": (169e9, "Pa", "Young's modulus of silicon along <110> of a (100) wafer"),
    "nu": (0.28, "-", "Poisson's ratio of silicon (isotropic model: G = 66.0 GPa)"),
    "rho": (2330.0, "kg/m^3", "density of silicon"),
}
RHO_ALUMINIUM = 2700.0  # kg/m^3, the macro design's bodies (docs/manipulator.md)

# What the process makes (DRIE of a silicon-on-insulator wafer): a flexure's wide dimension
# is the device layer, its thin one a line at least `min_line` wide and at most
# `aspect_ratio` times thinner than the layer.
PROCESS = {
    "device_layer": (50e-6, "m", "device layer thickness: every flexure's wide dimension"),
    "min_line": (2e-6, "m", "narrowest line the lithography and etch make"),
    "aspect_ratio": (20.0, "-", "largest layer thickness over line width DRIE makes"),
    "quality_factor": (100.0, "-", "assumed Q of the first mode (in air; in vacuum 1e4 and up)"),
}

# The table's entries by what they are, for the scaling
WIDE = ("leaf_width", "pivot_width", "push_height", "slant_width")
THIN = ("leaf_thickness", "pivot_thickness", "push_thickness", "slant_thickness")
MASSES = ("carriage_mass", "guidance_body_mass", "lever_mass", "body_mass", "effector_mass")


def _drawn(x):
    """A derived number as the table states it: 12 significant digits, so that 0.01 * 3e-4 is
    3e-06 and not 3.0000000000000005e-06 (the same on every machine either way)."""
    return float(f"{x:.12g}")


def frequency_factor(parameters=PARAMETERS, s=SCALE, *, E=SILICON["E"][0],
                     rho=SILICON["rho"][0]):
    """f_scaled / f_macro of an exactly scaled design: sqrt((E / E_macro) / (rho / rho_macro))
    / s (dimensionless; E in Pa, rho in kg/m^3)."""
    return math.sqrt((E / value("E", parameters)) / (rho / value("rho_steel", parameters))) / s


def scaled_parameters(parameters=PARAMETERS, s=SCALE, *, E=SILICON["E"][0],
                      rho=SILICON["rho"][0]):
    """The design exactly scaled: lengths times s (m), the flexures' E (Pa) and rho (kg/m^3)
    replaced, every mass times s^3 rho / rho_macro (kg), Poisson's ratio kept, the damping's
    time constant beta (s) over `frequency_factor`, so every dimensionless group is kept."""
    ratio = rho / value("rho_steel", parameters)
    factor = frequency_factor(parameters, s, E=E, rho=rho)
    table = {"scale": (s, "-", "every length of the design times this")}
    for name, (val, unit, what) in parameters.items():
        if name == "rho_steel":
            table["rho"] = (rho, unit, "density of the flexures")
        elif name == "E":
            table["E"] = (E, unit, "Young's modulus of the flexures")
        elif name == "beta":
            table["beta"] = (_drawn(val / factor), unit, what)
        elif unit == "m":
            table[name] = (_drawn(val * s), unit, what)
        elif unit == "kg":
            table[name] = (_drawn(val * s**3 * ratio), unit, what)
        else:
            table[name] = (val, unit, what)
    return table


def _silicon_nu(table, parameters, s, process):
    table["nu"] = SILICON["nu"]


def _device_layer(table, parameters, s, process):
    layer = value("device_layer", process)
    for name in THIN:
        thin = value(name, table)
        if not value("min_line", process) <= thin <= layer:
            raise ValueError(f"{name}: expected a line of {value('min_line', process)} to "
                             f"{layer} m, got {thin} m")
        if layer / thin > value("aspect_ratio", process):
            raise ValueError(f"{name}: expected at most {value('aspect_ratio', process)}:1 "
                             f"against the {layer} m layer, got {layer / thin:.3g}:1")
    for name in WIDE:
        val, unit, what = table[name]
        table[name] = (min(val, layer), unit, what + ", the device layer")


def _square_wires(table, parameters, s, process):
    side = table.pop("wire_diameter")
    table["wire_side"] = (side[0], "m", "wire flexures X and Z, square section, side")


def _silicon_bodies(table, parameters, s, process):
    silicon = value("rho", table) / RHO_ALUMINIUM
    for name in MASSES:
        val, unit, what = parameters[name]
        table[name] = (_drawn(val * s**3 * silicon), unit, what + ": its shape in silicon")


def _damping(table, parameters, s, process):
    # zeta = beta omega / 2 = 1 / (2 Q) at the first mode; beta does not move the undamped
    # frequencies FIRST_MODE_HZ is measured from
    beta = 1.0 / (value("quality_factor", process) * 2 * math.pi * FIRST_MODE_HZ)
    table["beta"] = (_drawn(beta), "s", "stiffness-proportional damping: Q of the first mode")


# What the process and the material change of the exactly scaled design, in order: (what, the
# change of the table in place)
PROCESS_STEPS = (
    ("silicon's Poisson's ratio 0.28 (0.3 scaled)", _silicon_nu),
    ("wide dimensions the 50 um device layer (100 to 300 um scaled)", _device_layer),
    ("square 8 um wires (round scaled)", _square_wires),
    ("silicon bodies (aluminium ones scaled)", _silicon_bodies),
    ("damping of Q = 100 at the first mode (the steel's scaled)", _damping),
)


def process_steps(parameters=PARAMETERS, s=SCALE, process=PROCESS):
    """[(what, table)]: the exactly scaled table (`scaled_parameters` in silicon), then each
    of `PROCESS_STEPS` applied on top of the ones before; the last is `mems_parameters`.
    Refuses a thin dimension the process cannot make (ValueError)."""
    table = scaled_parameters(parameters, s)
    steps = [("exactly scaled", dict(table))]
    for what, change in PROCESS_STEPS:
        change(table, parameters, s, process)
        steps.append((what, dict(table)))
    return steps


def mems_parameters(parameters=PARAMETERS, s=SCALE, process=PROCESS):
    """The MEMS design: `scaled_parameters` in silicon, then what the process makes (module
    docstring, `PROCESS_STEPS`)."""
    return process_steps(parameters, s, process)[-1][1]


# Hz, the first natural frequency of manipulator_mems (measured; the tests check it): the
# damping's beta is set from it.
FIRST_MODE_HZ = 827.55


def scene_mems(parameters=None):
    """The scene manipulator_mems: the control model's form of `mems_parameters`."""
    return scene_control(parameters or mems_parameters(), name="manipulator_mems",
                         description="the six-DOF flexure manipulator at the micromanipulator's "
                                     f"scale ({SCALE:g}), in silicon as a MEMS process makes it: "
                                     "dynamic, 1 beam per flexure, every elongation prescribed "
                                     "zero")


def scene_scaled(parameters=PARAMETERS, s=SCALE):
    """manipulator_control exactly scaled into silicon (`scaled_parameters`): the reference
    the MEMS design is compared with."""
    return scene_control(scaled_parameters(parameters, s), name="manipulator_scaled",
                         description=f"manipulator_control exactly scaled by {s:g} in silicon")


# The step of docs/manipulator.md: 10 uN on carriage 1 (a comb drive of about 50 fingers, 50 um
# tall with 3 um gaps, at 50 V), 0.82 um of its stroke, recorded every STEP_SAMPLE seconds.
STEP_INPUT, STEP_FORCE, STEP_SAMPLE = "F1", 1e-5, 2e-5  # -, N, s
SETTLE_BAND = 0.02  # the step has settled once within 2 % of its final value, and stays


def settle_time(times, y, final, band=SETTLE_BAND):
    """The first time (s) after which |y - final| stays within band |final| (the samples'
    times `times` in s, y and final in the output's unit)."""
    outside = np.flatnonzero(np.abs(np.asarray(y) - final) > band * abs(final))
    return float(times[0] if outside.size == 0 else times[min(outside[-1] + 1, len(times) - 1)])


def linear_step(model, t_end, *, output="x1", sample=STEP_SAMPLE, force=STEP_FORCE):
    """(times in s, `output` in its unit) of the model's linearisation under the step
    (`STEP_INPUT` held at `force` N from t = 0), advanced exactly (LinearSimulator) and
    sampled every `sample` s: the reference of the nonlinear step."""
    from flexure.core import LinearSimulator

    sim = LinearSimulator(model)
    inputs = np.zeros(len(sim.input_names))
    inputs[sim.input_names.index(STEP_INPUT)] = force
    sim.set_inputs(inputs)
    k = sim.output_names.index(output)
    times = np.arange(0.0, t_end + sample / 2, sample)
    values = [sim.outputs()[k]]
    for t in times[1:]:
        sim.advance_to(t)
        values.append(sim.outputs()[k])
    return times, np.array(values)


HEADER = ("Written by examples/manipulator_mems.py from examples/manipulator.py's design and its\n"
          "own MEMS table; edit those and run `python examples/manipulator_mems.py`.\n"
          "{description}")


def main(argv=None):
    """Write the scene (or print the table); returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--table", action="store_true", help="print the MEMS parameter table")
    parser.add_argument("--out", type=Path, default=SCENES, help="folder for the scene")
    args = parser.parse_args(argv)
    if args.table:
        sys.stdout.write(parameter_table(mems_parameters()))
        return 0
    scene = scene_mems()
    path = args.out / "manipulator_mems.toml"
    path.write_text(scene_toml(scene, HEADER.format(description=scene["scene"]["description"])))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
