"""The same scene at any size gives the same answers: frequencies, static deflection over the
size, step response over the size, buckling factors, for every element type and integrator.

The scaling. Lengths times s, time kept, density kept (a geometrically similar device of the
same material: masses times s^3). A quantity of dimension m^a kg^b s^c then scales by
s^a (s^3)^b: a force (kg m / s^2) by s^4, a stiffness E (N/m^2) by s^2, EA (N) by s^4, EI
(N m^2) by s^6, rho_A (kg/m) by s^2, a spring's k (N/m) by s^3, a damping EdA (N s) by s^4,
beta (s) not at all. Why E must scale: a beam's tip stiffness EI/l^3 goes as E s^4 / s^3 =
E s and its mass as s^3, so omega^2 goes as E / s^2; E times s^2 keeps every frequency,
and with it every dimensionless group of the equations of motion
M(q) qddot + C qdot + K-terms = f: positions over s, forces over s^4, times and frequencies
are the same numbers at every s. Buckling load factors (of the scaled reference load) too.

The floating-point computation is not the same at every s (1e-3 and 1e3 are not powers of
two), so the comparison is to 1e-9 relative: far above round-off (about 1e-13 here), far below
what a tolerance in absolute units would leave (one in m, say 1e-12 m, is a relative 1e-7 at
s = 1e-3 and 1e-17, below round-off, at s = 1e3). The integrators' default absolute tolerances
are per unit (`simulation.tolerances.default_atol`: rtol 1e-3 L on lengths, rtol 1e-3 on
rotations, times a frequency on velocities) and rtol is the same number, so their weighted
error norms are the same at every s up to round-off.

The bound of the step responses, honestly: an adaptive integrator amplifies round-off into
differences of the order of its tolerance, because its discrete decisions (accept or reject a
step, change the order) flip on round-off. Measured on truss_1dof_x at one size (s = 1), rtol
1e-8: changing the input force by one ulp (4e-16 relative) turns CVODE BDF's 227 steps into 244
and moves its outputs by 6.6e-8 of the motion, as much as the sizes differ (3.4e-8). So the
responses are compared where that amplification stays below 1e-9: at fixed output times and
rtol 1e-12 for SUNDIALS' multistep methods (sizes within 1.5e-10 measured: tripod, BDF), and
rtol 1e-11 for the one-step ESDIRKs, whose steps are the same at every size (within 1.5e-13
measured) but could flip one step at a looser rtol (esdirk3 at 1e-8: 750 against 749 steps,
2e-9). The simulated times hold one to three periods of the fastest mode, as the error, and its
amplification, grow with the periods.
"""

import numpy as np
import pytest

from flexure.core import (
    buckling_load_factors,
    build_model,
    load_scene,
    natural_frequencies,
    simulate,
    static_equilibrium,
)
from flexure.core.elements import ELEMENT_TYPES
from flexure.core.simulation.methods import METHODS, SUNDIALS_METHODS

SCALES = (1e-3, 1e3)
RELATIVE = 1e-9

# (length power, mass power) of each unit symbol: time is kept, so s and Hz do not scale
_BASE = {"m": (1, 0), "kg": (0, 1), "N": (1, 1), "Pa": (-1, 1), "s": (0, 0), "rad": (0, 0)}
# the unit of every numeric scene key the scenes below use; a key not here fails the test,
# so that nothing is left unscaled silently
SECTION_UNITS = {"E": "Pa", "G": "Pa", "nu": "1", "rho": "kg/m3", "width": "m", "height": "m",
                 "diameter": "m", "beta": "s", "EA": "N", "EI": "N.m2", "EIy": "N.m2",
                 "EIz": "N.m2", "GIt": "N.m2", "EdA": "N.s", "EdI": "N.m2.s",
                 "EdIy": "N.m2.s", "EdIz": "N.m2.s", "GdIt": "N.m2.s", "rho_A": "kg/m",
                 "rho_Iy": "kg.m", "rho_Iz": "kg.m", "kx": "N/m", "ky": "N/m", "kz": "N/m",
                 "cx": "N.s/m", "cy": "N.s/m", "cz": "N.s/m"}
NODE_UNITS = {"position": "m", "rotation": "rad", "angle": "rad", "mass": "kg",
              "inertia": "kg.m2", "force": "N", "moment": "N.m"}


def factor(unit, s):
    """The factor of a quantity in `unit` ("N.m2.s", "kg/m3") when lengths scale by s and
    masses by s^3."""
    length = mass = 0
    for sign, part in zip((1, -1), unit.split("/"), strict=False):
        for symbol in part.split("."):
            if symbol == "1":  # dimensionless
                continue
            name = symbol.rstrip("0123456789")
            power = int(symbol[len(name):] or 1)
            a, b = _BASE[name]
            length, mass = length + sign * power * a, mass + sign * power * b
    return s ** length * (s ** 3) ** mass


def scaled(scene, s):
    """A copy of the scene dictionary with every quantity scaled (module docstring)."""
    out = {key: dict(value) if isinstance(value, dict) else value
           for key, value in scene.items()}
    out["scene"] = dict(scene["scene"], name=f"{scene['scene']['name']}_scaled")
    out["scene"].pop("tunable", None)
    if "gravity" in scene["scene"]:
        out["scene"]["gravity"] = [g * s for g in scene["scene"]["gravity"]]
    assert "actuators" not in scene, "the scaling has no electrical units"
    out["sections"] = {name: {key: value * factor(SECTION_UNITS[key], s)
                              for key, value in section.items()}
                       for name, section in scene["sections"].items()}
    nodes = {}
    for name, node in scene["nodes"].items():
        nodes[name] = {key: (value if key in ("fixed", "dof") else
                             np.multiply(value, factor(NODE_UNITS[key], s)).tolist())
                       for key, value in node.items()}
    out["nodes"] = nodes
    if "buckling" in scene:
        out["buckling"] = {"forces": [
            {**load, **{key: np.multiply(load[key], factor(NODE_UNITS[key], s)).tolist()
                        for key in ("force", "moment") if key in load}}
            for load in scene["buckling"]["forces"]]}
    return out


def _planar_springs():
    """A mass on a PLTRUSS and a PLSPRING at an angle: the spring's global-axis stiffness
    against the truss's rotating one, 2 DOFs (flexure chooses them)."""
    return {"scene": {"name": "planar_springs", "dimension": 2},
            "sections": {"bar": {"EA": 400.0, "EdA": 0.01, "rho_A": 0.2},
                         "mount": {"kx": 1500.0, "ky": 900.0, "cx": 0.05, "cy": 0.05}},
            "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                      "2": {"position": [0.08, 0.06], "mass": 0.3},
                      "3": {"position": [0.08, 0.0], "fixed": ["x", "y"]}},
            "elements": {"bar": {"type": "PLTRUSS", "nodes": ["1", "2"], "section": "bar",
                                 "released": ["e1"]},
                         "mount": {"type": "PLSPRING", "nodes": ["3", "2"],
                                   "section": "mount", "released": ["e1", "e2"]}},
            "inputs": {"F": {"node": "2", "coordinate": "x"}},
            "outputs": {"x": {"node": "2", "coordinate": "x", "quantity": "position"},
                        "y": {"node": "2", "coordinate": "y", "quantity": "position"}}}


def _tripod():
    """A mass hung from three TRUSSes (a tripod upside down) and held sideways by a SPRING
    to the ground: 3 DOFs, the trusses' stiffness turning with them."""
    trusses = {f"leg{i}": {"type": "TRUSS", "nodes": [str(i), "4"], "section": "leg",
                           "released": ["e1"]} for i in (1, 2, 3)}
    feet = {str(i + 1): {"position": [0.05 * np.cos(a), 0.05 * np.sin(a), 0.1],
                         "fixed": ["x", "y", "z"]}
            for i, a in enumerate(2 * np.pi * np.arange(3) / 3)}
    return {"scene": {"name": "tripod", "dimension": 3, "gravity": [0.0, 0.0, -9.81]},
            "sections": {"leg": {"EA": 2000.0, "EdA": 0.02, "rho_A": 0.05},
                         "ground": {"kx": 300.0, "ky": 500.0, "kz": 100.0, "cx": 0.01,
                                    "cy": 0.01, "cz": 0.01}},
            "nodes": {**feet, "4": {"position": [0.0, 0.0, 0.0], "mass": 0.2},
                      "5": {"position": [0.0, 0.0, 0.0], "fixed": ["x", "y", "z"]}},
            "elements": {**trusses, "ground": {"type": "SPRING", "nodes": ["5", "4"],
                                               "section": "ground",
                                               "released": ["e1", "e2", "e3"]}},
            "inputs": {"F": {"node": "4", "coordinate": "x"}},
            "outputs": {"x": {"node": "4", "coordinate": "x", "quantity": "position"},
                        "z": {"node": "4", "coordinate": "z", "quantity": "position"}}}


# scene -> (dictionary, step input N at s = 1, simulated time s)
SCENES = {
    "truss_1dof_x": (lambda: load_scene("truss_1dof_x").scene, 1.0, 0.1),
    "stage_planar_1dof": (lambda: load_scene("stage_planar_1dof").scene, 1.0, 0.05),
    "stage_spatial_1dof": (lambda: load_scene("stage_spatial_1dof").scene, 1.0, 0.05),
    "planar_springs": (_planar_springs, 1.0, 0.1),
    "tripod": (_tripod, 0.5, 0.04),
}


def models(name):
    """{s: the model at size s} for s = 1 and SCALES."""
    scene = SCENES[name][0]()
    return {s: build_model(scene if s == 1.0 else scaled(scene, s)) for s in (1.0, *SCALES)}


@pytest.fixture(scope="module")
def built():
    return {name: models(name) for name in SCENES}


def close(actual, expected, what):
    """max |actual - expected| <= RELATIVE max |expected|."""
    error = np.max(np.abs(np.asarray(actual) - expected))
    size = np.max(np.abs(expected))
    assert error <= RELATIVE * size, f"{what}: {error:.3e} > {RELATIVE:g} x {size:.3e}"


def test_the_scenes_hold_every_element_type(built):
    """The element list of tests/test_elements.py (the registry), all in the scenes here."""
    types = {group.kind.type_name for group_models in built.values()
             for group in group_models[1.0].groups}
    assert set(ELEMENT_TYPES) <= types


def test_the_unit_factors():
    """A force scales by s^4, E by s^2, EI by s^6, rho_A by s^2, a spring by s^3."""
    s = 10.0
    assert factor("N", s) == pytest.approx(s ** 4)
    assert factor("Pa", s) == pytest.approx(s ** 2)
    assert factor("N.m2", s) == pytest.approx(s ** 6)
    assert factor("kg/m", s) == pytest.approx(s ** 2)
    assert factor("N/m", s) == pytest.approx(s ** 3)
    assert factor("kg/m3", s) == pytest.approx(1.0)


@pytest.mark.parametrize("name", sorted(SCENES))
def test_frequencies_deflection_and_buckling_do_not_depend_on_size(built, name):
    """Natural frequencies (Hz), the static deflection under the step's force over the size,
    and the buckling load factors where the scene has a reference load."""
    force = SCENES[name][1]
    reference = built[name][1.0]
    f1 = natural_frequencies(reference).frequencies_hz
    x0 = reference.initial_coordinates
    moved = static_equilibrium(reference, inputs={"F": force}).x - x0
    for s in SCALES:
        model = built[name][s]
        close(natural_frequencies(model).frequencies_hz, f1, f"{name} x{s:g} frequencies")
        deflection = static_equilibrium(model, inputs={"F": force * s ** 4}).x
        translations = model.translations
        scaled_moved = (deflection - model.initial_coordinates)
        scaled_moved[translations] /= s
        close(scaled_moved, moved, f"{name} x{s:g} static deflection over the size")
        if reference.buckling_loads is not None:
            close(buckling_load_factors(model), buckling_load_factors(reference),
                  f"{name} x{s:g} buckling load factors")


# sdirk2 is the ESDIRK kernel with another tableau (esdirk, esdirk3 and esdirk2 check that
# kernel here); its first-order error estimate takes thousands of steps at rtol 1e-11, tens
# of seconds a scene, so its cases run in the slow tier
STEP_METHODS = [pytest.param(m, marks=pytest.mark.slow) if m == "sdirk2" else m
                for m in METHODS]


@pytest.mark.parametrize("method", STEP_METHODS)
@pytest.mark.parametrize("name", sorted(SCENES))
def test_step_response_does_not_depend_on_size(built, name, method):
    """The outputs' motion (m) over the size at fixed output times after a step of the
    input, with the default (per-unit) absolute tolerances and the rtol of the module
    docstring."""
    force, t_end = SCENES[name][1:]
    times = np.linspace(0.0, t_end, 21)
    rtol = 1e-12 if method in SUNDIALS_METHODS else 1e-11
    results = {s: simulate(built[name][s], t_end, inputs={"F": force * s ** 4}, method=method,
                           rtol=rtol, output_times=times)
               for s in (1.0, *SCALES)}
    def motion(result):  # the outputs' motion from the start, m
        outputs = np.array([result.outputs[key] for key in result.output_names])
        return outputs - outputs[:, :1]

    reference = motion(results[1.0])
    for s in SCALES:
        close(motion(results[s]) / s, reference,
              f"{name} x{s:g} {method} step response over the size")


@pytest.mark.parametrize("s", SCALES)
def test_the_exact_constraint_check_and_the_dof_choice_do_not_depend_on_size(s):
    """A planar scene and a spatial one with their DOFs removed, so that flexure chooses
    them: the same DOFs and the same verdict at every size (the rank decisions' rotation
    columns are per metre of motion: constraints.column_scale)."""
    from flexure.core import check_exact_constraint

    for name in ("stage_planar_1dof", "stage_spatial_1dof"):
        scene = load_scene(name).scene
        scene = {**scene, "nodes": {node: {k: v for k, v in values.items() if k != "dof"}
                                    for node, values in scene["nodes"].items()}}
        reference, resized = build_model(scene), build_model(scaled(scene, s))
        assert resized.dof_names == reference.dof_names
        keys = ("nx", "nxo", "neo", "ndof")
        assert ([check_exact_constraint(resized)[k] for k in keys]
                == [check_exact_constraint(reference)[k] for k in keys])
