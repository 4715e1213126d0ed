"""`flexure analyze SCENE`: DOF count, static equilibrium, modes, buckling, state space,
compliance at nodes."""

import argparse
import sys

import numpy as np

from ..errors import SceneError, UsageError
from ..reporting.tables import format_table, jsonable, print_json
from . import PLOT_SUFFIXES, add_scene_arguments, atomic_output, count, output_file
from .analyze_motion import motion_space_result, render_motion_space


def register(subparsers):
    """Add the `analyze` subcommand."""
    parser = subparsers.add_parser(
        "analyze", help="static, modal, buckling and state-space analyses of a scene",
        description="Analyse a scene (a TOML file or the name of a built-in scene). Without an "
                    "analysis option, --static and --modes are run.")
    add_scene_arguments(parser)
    parser.add_argument("--static", action="store_true", help="static equilibrium under the loads")
    parser.add_argument("--modes", nargs="?", type=count, const=-1, metavar="N",
                        help="the lowest N (default all) natural frequencies")
    parser.add_argument("--buckling", nargs="?", type=count, const=-1, metavar="N",
                        help="the lowest N (default all) buckling load factors")
    parser.add_argument("--state-space", action="store_true",
                        help="state-space matrices of the declared inputs and outputs")
    parser.add_argument("--compliance", action="append", metavar="NODE", type=node_list,
                        help="the compliance matrix (m/N, rad/(N m), ...) and support "
                             "stiffness of this node at the static equilibrium (repeatable, "
                             "or comma-separated: 3,5)")
    parser.add_argument("--sensitivity", nargs="+", metavar="KEY",
                        help="the derivatives of the analyses' results (the lowest "
                             f"{SENSITIVITY_MODES} frequencies or the N of --modes, buckling "
                             "factors, outputs, the largest von Mises stress, compliances, DC "
                             "gains) with respect to these scene keys (sections.leaf.height, "
                             "nodes.3.mass, nodes.3.position[1]): analytic where the "
                             "matrices are linear in the key, else central differences with "
                             "an error estimate")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--sigma-range", type=frequency_band, metavar="FMIN:FMAX",
                        help="the frequencies of --sigma, Hz (default: a tenth of the lowest "
                             "to ten times the highest natural frequency)")
    for option, draws in {**RESULT_PICTURES, **MODEL_PICTURES}.items():
        parser.add_argument(option, metavar="PNG", type=output_file(PLOT_SUFFIXES), help=draws)
    parser.set_defaults(run=run_with_pictures)


# The units of `static`: every stress resultant is in N, as every deformation is a length; a
# bending (and the BEAM's torsion) resultant is the moment over l0, where SPACAR's are N m
STATIC_UNITS = {
    "coordinates": "m (translations), rad (planar angles), 1 (Euler parameters)",
    "stress_resultants": "N: e1 the normal force; bending (PLBEAM e2, e3; BEAM e3 to e6) and "
                         "torsion (BEAM e2) the moment in N m divided by l0",
    "von_mises_pa": "Pa"}


SENSITIVITY_MODES = 6  # the frequencies --sensitivity differentiates when --modes gives no N


def frequency_band(text):
    """An argparse type: "FMIN:FMAX" in Hz, 0 < FMIN < FMAX, as a tuple of floats."""
    low, sep, high = text.partition(":")
    try:
        band = (float(low), float(high)) if sep else None
    except ValueError:
        band = None
    if band is None or not (np.all(np.isfinite(band)) and 0.0 < band[0] < band[1]):
        raise argparse.ArgumentTypeError(f"expected FMIN:FMAX in Hz with 0 < FMIN < FMAX, got "
                                         f"{text!r}")
    return band


def node_list(text):
    """An argparse type: "3" or "3,5" as a list of node names."""
    names = [name.strip() for name in text.split(",")]
    if not all(names):
        raise argparse.ArgumentTypeError(f"expected node names separated by commas, got "
                                         f"{text!r}")
    return names


def analyze(model, *, static=False, modes=None, buckling=None, with_state_space=False,
            with_gains=False, compliance_nodes=(), gains_band=None):
    """Run the requested analyses; returns the dict that `--json` prints (SI units).

    compliance_nodes: the nodes whose compliance (m/N, rad/(N m), ...) to give; gains_band:
    (f_min, f_max) Hz of the principal gains (default: around the natural frequencies).
    """
    from ..analysis.compliance import compliance, node_coordinates
    from ..analysis.linearization import linearize
    from ..analysis.modal import buckling_load_factors, describe_mode, natural_frequencies
    from ..analysis.statespace import state_space
    from ..analysis.statics import static_equilibrium
    from ..analysis.stresses import beam_stresses
    from ..mechanics.mechanics import Mechanics
    from ..mechanics.ports import output_value

    result = {"scene": model.name, "dof_count": model.dof_count(),
              "dofs": model.free_dof_names, "dofs_chosen": bool(model.chosen_dofs)}
    if model.kinematic_inputs:  # prescribed, in q but no DOF of the motion
        result["kinematic_inputs"] = [port.name for port in model.kinematic_inputs]
    for node in compliance_nodes:  # an unknown node is refused before any computation
        node_coordinates(model, node)
    mech = Mechanics(model)
    needs_linear = modes is not None or with_state_space or with_gains or bool(compliance_nodes)
    needs_equilibrium = static or needs_linear
    solution = static_equilibrium(model, mechanics=mech) if needs_equilibrium else None
    if static:
        # the multipliers of the Euler-parameter normalisation ("NODE.norm") are no output
        resultants = {name: value for name, value in solution.stresses().items()
                      if not name.endswith(".norm")}
        result["static"] = {"coordinates": solution.coordinates(),
                            "stress_resultants": resultants, "units": STATIC_UNITS,
                            **_shown_coordinates(model),
                            "outputs": {port.name: output_value(model, port, solution.x)
                                        for port in model.outputs
                                        if port.quantity == "position"}}
        if model.element_outputs:  # SPACAR's OUTE, OUTF: m or N
            result["static"]["element_outputs"] = solution.element_outputs()
        if model.kinematic_inputs:  # the held values, where each move starts, their forces
            starts = solution.motions if model.motion_starts is None else model.motion_starts
            result["static"]["kinematic_inputs"] = {
                port.name: {"value": float(value), "start": float(start), "effort": float(effort)}
                for port, value, start, effort in zip(model.kinematic_inputs, solution.motions,
                                                      starts, solution.input_efforts, strict=True)}
        stresses = beam_stresses(model, solution.x, solution.stress_resultants)
        if stresses.names:
            result["static"]["von_mises_pa"] = stresses.as_dict()
        beyond_yield = stresses.beyond_yield()
    lin = linearize(model, solution, mechanics=mech) if needs_linear else None
    if modes is not None:
        found = natural_frequencies(model, None if modes < 0 else modes, linear_model=lin)
        result["modes"] = {"frequencies_hz": found.frequencies_hz,
                           "descriptions": [describe_mode(model, shape, solution.x)
                                            for shape in found.coordinate_shapes.T],
                           "mass_matrix": lin.M0, "stiffness_matrix": lin.K,
                           "damping_matrix": lin.C0,
                           "shapes": found.shapes}
    if compliance_nodes:
        result["compliance"] = {node: compliance(model, node, linear_model=lin).as_dict()
                                for node in dict.fromkeys(compliance_nodes)}
    if solution is not None:
        result["warnings"] = equilibrium_warnings(model, solution, mech, lin,
                                                  result.get("modes"))
        if static:
            result["warnings"] += beyond_yield
    if buckling is not None:
        factors = buckling_load_factors(model, None if buckling < 0 else buckling)
        result["buckling"] = {"load_factors": factors}
    if with_state_space and model.kinematic_inputs:  # their positions as inputs
        result["state_space_from_positions"] = motion_space_result(model, solution)
    if with_state_space and (model.inputs or not model.kinematic_inputs):
        sys = state_space(model, linear_model=lin)
        result["state_space"] = {"A": sys.A, "B": sys.B, "C": sys.C, "D": sys.D,
                                 "inputs": [p.name for p in model.inputs],
                                 "outputs": [p.name for p in model.outputs],
                                 "states": list(sys.state_labels)}
    if with_gains:
        from ..analysis.statespace import frequency_grid, principal_gains

        every_mode = result.get("modes") if modes is not None and modes < 0 else None
        natural = (every_mode["frequencies_hz"] if every_mode is not None
                   else natural_frequencies(model, linear_model=lin).frequencies_hz)
        grid = frequency_grid(natural, band=gains_band)
        result["principal_gains"] = {
            "frequencies_hz": grid, "natural_hz": natural,
            "singular_values": principal_gains(model, grid, linear_model=lin),
            "inputs": [p.name for p in model.inputs],
            "outputs": [p.name for p in model.outputs]}
    return jsonable(result)


def equilibrium_warnings(model, solution, mech, lin, modes):
    """What is wrong with a static equilibrium that Newton's method found all the same: it is
    unstable (`analysis.stability`: past a buckling or snap-through load), or it lies beyond
    the model's range of validity (`simulation.plausibility`: the strain or the distance
    that `flexure simulate` and the FMU warn about too). A list of messages, empty when
    neither."""
    from ..analysis.stability import instability_warnings, tangent_stiffness
    from ..simulation.plausibility import RangeCheck

    K = lin.K if lin is not None else tangent_stiffness(model, solution, mech)
    found = instability_warnings(
        K, frequencies_hz=None if modes is None else modes["frequencies_hz"],
        descriptions=None if modes is None else modes["descriptions"])
    found += list(RangeCheck(model).warnings(solution.x, solution.config.e).values())
    return found


def run(args, model=None):
    """Run `flexure analyze` on `args`; `model` is the scene's, when the caller loaded it."""
    from ..scene.building import load_scene

    if args.sigma_range and not args.sigma:
        raise UsageError("--sigma-range: it sets the frequencies of --sigma, which is not given")
    if model is None:
        model = load_scene(args.scene, overrides=args.set)
    static, modes = args.static, args.modes
    nodes = [name for names in args.compliance or [] for name in names]
    if not (static or modes is not None or args.buckling is not None or args.state_space
            or args.sigma or args.plot or nodes):
        # a kinematic model (SPACAR's mode 1) has no equilibrium to find and no modes: the
        # exact-constraint check that loading it passed is the analysis
        static, modes = (False, None) if is_kinematic(model) else (True, -1)
    keys = args.sensitivity or []
    if keys:  # every key checked before any analysis: a mistake costs no run
        from ..analysis.sensitivity import resolve_key

        for key in keys:
            resolve_key(model, key)
    result = analyze(model, static=static or bool(args.plot), modes=modes,
                     buckling=args.buckling, with_state_space=args.state_space,
                     with_gains=bool(args.sigma), compliance_nodes=nodes,
                     gains_band=args.sigma_range)
    if keys:
        result["sensitivity"] = sensitivity(model, keys, static=static, modes=modes,
                                            buckling=args.buckling, nodes=nodes,
                                            with_state_space=args.state_space)
    if args.plot:
        plot_stresses(model, args.plot)
    if args.sigma:
        from ..analysis.statespace import plot_principal_gains

        gains = result["principal_gains"]
        with atomic_output(args.sigma, "--sigma") as temporary:
            plot_principal_gains(model, np.array(gains["frequencies_hz"]),
                                 np.array(gains["singular_values"]), temporary,
                                 natural_hz=gains["natural_hz"])
        wrote(args.sigma, "the principal gains")
    if args.json:
        print_json(result, command="flexure analyze")
    else:
        print(render(result))
    for message in result.get("warnings", []):  # also where --json goes to a file or a pipe
        print(f"flexure analyze: warning: {message}", file=sys.stderr)
    return 0


def sensitivity(model, keys, *, static, modes, buckling, nodes, with_state_space):
    """The `sensitivity` entry of `--json`: the derivatives of the results of the analyses
    asked for (`analysis.sensitivity`), SI units."""
    from ..analysis.sensitivity import sensitivities

    found = sensitivities(
        model, keys, modes=0 if modes is None else (modes if modes > 0 else SENSITIVITY_MODES),
        buckling=0 if buckling is None else (buckling if buckling > 0 else 1),
        outputs=static, stress=static, compliance_nodes=tuple(dict.fromkeys(nodes)),
        dc_gains=with_state_space)
    return jsonable(found.as_dict())


def wrote(path, what):
    """Say on stderr that a picture was written (stdout may be the JSON)."""
    print(f"flexure analyze: wrote {path} ({what})", file=sys.stderr)


def is_kinematic(model):
    """Whether `model` carries neither mass nor load: a kinematic model, which the
    exact-constraint check describes completely."""
    massive = np.any(model.lumped_mass) or bool(model.node_inertias) or any(
        np.any(group.properties.get("rho_A", 0.0)) for group in model.groups)
    loaded = np.any(model.loads) or np.any(model.gravity)
    return not (massive or loaded)


def plot_stresses(model, path):
    """Plot the von Mises stresses at the static equilibrium to `path` (PNG)."""
    from ..analysis.statics import static_equilibrium
    from ..analysis.stresses import beam_stresses, plot_beam_stresses

    solution = static_equilibrium(model)
    stresses = beam_stresses(model, solution.x, solution.stress_resultants)
    if not stresses.names:
        raise SceneError(f"{model.source}: --plot: no beam or truss with section dimensions "
                         f"(width and height, or diameter) in {model.name!r}, so no stresses "
                         "to plot")
    with atomic_output(path, "--plot") as temporary:
        plot_beam_stresses(model, stresses, temporary)
    wrote(path, "the von Mises stresses along the beams")


def _shown_coordinates(model):
    """{"free_coordinates": the names of the coordinates a person reads in the text, neither
    fixed nor Euler parameters (a 3-D node's rotation reads better as an output about an
    axis); "left_out": how many of the others are {"fixed": ..., "Euler parameters": ...}}."""
    euler = np.char.startswith(model.coordinate_axis.astype(str), "lambda")
    fixed = (model.coordinate_status == "fixed") & ~euler
    shown = ~euler & ~fixed
    return {"free_coordinates": [model.coordinate_names[i] for i in np.flatnonzero(shown)],
            "left_out": {"fixed": int(fixed.sum()), "Euler parameters": int(euler.sum())}}


def render(result):
    """The analyses of `analyze` as readable tables."""
    count = result["dof_count"]
    nki = ("- NKI ", f" - {count['nki']}") if "nki" in count else ("", "")
    kinematic = result.get("kinematic_inputs")
    parts = [f"scene {result['scene']}: NDOF = NX - NXO - NEO {nki[0]}= {count['nx']} - "
             f"{count['nxo']} - {count['neo']}{nki[1]} = {count['ndof']}   (DOFs: "
             f"{', '.join(result['dofs']) or 'none'}"
             + (f"; kinematic inputs: {', '.join(kinematic)}" if kinematic else "")
             + ("; chosen by flexure, the scene lists none)" if result.get("dofs_chosen")
                else ")")]
    if not {"static", "modes", "buckling", "state_space", "state_space_from_positions",
            "principal_gains",
            "compliance"} & result.keys():
        parts.append("exactly constrained; a kinematic model (no mass, no load), so there is "
                     "no equilibrium or mode to compute")
    if "static" in result:
        static = result["static"]
        free = static.get("free_coordinates", list(static["coordinates"]))
        left_out = " and ".join(f"{n} {what}" for what, n in static.get("left_out", {}).items()
                                if n)
        parts.append(format_table(
            ["coordinate", "value (m, rad)"],
            [(name, static["coordinates"][name]) for name in free],
            title="\nstatic equilibrium: coordinates" + (
                f" (the free ones; {left_out} left out: --json lists every coordinate)"
                if left_out else "")))
        if static.get("kinematic_inputs"):
            parts.append(format_table(
                ["kinematic input", "value (m, rad)", "effort (N, N m)"],
                [(name, v["value"], v["effort"]) for name, v in
                 static["kinematic_inputs"].items()],
                title="\nstatic equilibrium: kinematic inputs and the force that realises each"))
        if static.get("element_outputs"):
            parts.append(format_table(
                ["output", "value (m or N)"], list(static["element_outputs"].items()),
                title="\nstatic equilibrium: outputs on elements (a deformation in m, a stress "
                      "resultant in N)"))
        if static.get("outputs"):
            parts.append(format_table(["output", "value (m, rad)"],
                                      list(static["outputs"].items()),
                                      title="\nstatic equilibrium: outputs"))
        parts.append(format_table(["deformation", "stress resultant (N)"],
                                  list(static["stress_resultants"].items()),
                                  title="\nstatic equilibrium: stress resultants (a "
                                        "bending or torsion resultant is the moment over l0)"))
        if "von_mises_pa" in static:
            parts.append(format_table(
                ["element", "von Mises at p (MPa)", "von Mises at q (MPa)"],
                [(name, p / 1e6, q / 1e6) for name, (p, q) in static["von_mises_pa"].items()],
                title="\nstatic equilibrium: von Mises stresses (largest over the section)"))
    if "modes" in result:
        freqs = result["modes"]["frequencies_hz"]
        descriptions = result["modes"]["descriptions"]
        parts.append(format_table(["mode", "frequency (Hz)", "what moves most"],
                                  [(i + 1, f, d) for i, (f, d) in enumerate(
                                      zip(freqs, descriptions, strict=True))],
                                  title="\nnatural frequencies (at the static equilibrium)"))
    for node, found in result.get("compliance", {}).items():
        parts.append(render_compliance(node, found))
    if "buckling" in result:
        factors = result["buckling"]["load_factors"]
        parts.append(format_table(["mode", "load factor"],
                                  [(i + 1, f) for i, f in enumerate(factors)],
                                  title="\nbuckling load factors eig(-K0, G0)"))
    if "state_space" in result:
        ss = result["state_space"]
        with np.printoptions(precision=6, linewidth=100):
            for key in "ABCD":
                parts.append(f"\n{key} =\n{np.array(ss[key])}")
        parts.append(f"\ninputs: {', '.join(ss['inputs'])}   outputs: {', '.join(ss['outputs'])}"
                     f"   states: {', '.join(ss['states'])}")
    if "state_space_from_positions" in result:
        parts.append(render_motion_space(result["state_space_from_positions"]))
    if "principal_gains" in result:
        gains = result["principal_gains"]
        f, sigma = np.array(gains["frequencies_hz"]), np.array(gains["singular_values"])
        rows = []
        inside = [n for n in gains["natural_hz"] if f.min() <= n <= f.max()]
        for natural in inside[:10]:  # the largest gain at each natural frequency of the band
            k = int(np.argmin(np.abs(f - natural)))
            rows.append((f"{natural:.6g}", f"{sigma[k, 0]:.4g}"))
        parts.append(format_table(["natural frequency (Hz)", "largest singular value"], rows,
                                  title=f"\nprincipal gains from {', '.join(gains['inputs'])} to "
                                        f"{', '.join(gains['outputs'])} ({f.size} frequencies, "
                                        f"{f.min():.3g} to {f.max():.3g} Hz)"))
    if "sensitivity" in result:
        parts.append(render_sensitivity(result["sensitivity"]))
    return "\n".join(parts)


def render_sensitivity(found):
    """The `sensitivity` entry as a table: per quantity its value and, per key, the derivative
    with its unit and the method (with the difference scheme's error estimate)."""
    headers = ["quantity", "value"]
    for key, unit in zip(found["keys"], found["key_units"], strict=True):
        headers += [f"d/d{key} (per {unit})", "method"]
    rows = []
    for i, (name, unit) in enumerate(zip(found["quantities"], found["units"], strict=True)):
        row = [f"{name} ({unit})", found["values"][i]]
        for j in range(len(found["keys"])):
            method = found["methods"][i][j]
            if method != "analytic":
                method = f"{method} ± {found['errors'][i][j]:.2g}"
            row += [found["derivatives"][i][j], method]
        rows.append(row)
    return format_table(headers, rows, title="\ndesign sensitivities (SI units; a derivative's "
                                             "unit is the quantity's per the key's)")


def render_compliance(node, found):
    """The compliance of one node (the `compliance` entry of `analyze`) as tables: rows the
    displacements, columns the loads, each with its unit; then the stiffness or why none."""
    names, units = found["coordinates"], found["units"]
    load_units = [unit.split("/", 1)[1].strip("()") for unit in units[0]]
    coordinate_units = [row[0].split("/", 1)[0] for row in units]
    headers = ["displacement per load"] + [f"on {name} ({unit})"
                                           for name, unit in zip(names, load_units, strict=True)]
    rows = [[f"{name} ({unit})", *values]
            for name, unit, values in zip(names, coordinate_units, found["matrix"], strict=True)]
    text = [format_table(headers, rows, title=f"\ncompliance of node {node} (m/N, m/(N m), "
                                              "rad/N, rad/(N m); at the static equilibrium)")]
    if found["stiffness"] is None:
        text.append(f"no support stiffness: {found['note']}")
    else:
        headers = ["load per displacement"] + [
            f"of {name} ({unit})" for name, unit in zip(names, coordinate_units, strict=True)]
        rows = [[f"{name} ({unit})", *values] for name, unit, values in
                zip(names, load_units, found["stiffness"], strict=True)]
        text.append(format_table(headers, rows, title=f"\nsupport stiffness of node {node} "
                                                      "(N/m, N/rad, N m/m, N m/rad)"))
    return "\n".join(text)


# -- pictures: of the results (drawn by `run`) and of the model (around it) ------------------

MODE_PANELS = 6  # the mode shapes drawn when --modes gives no count

# The pictures, each to a PNG (or .pdf, .svg) file: option -> what it draws. `run` draws those
# of its results; `run_with_pictures` draws the model's around it.
RESULT_PICTURES = {
    "--plot": "plot the von Mises stresses along the beams at the static equilibrium to this "
              "PNG file (beams and trusses whose section has dimensions)",
    "--sigma": "plot the singular values (principal gains) of the transfer matrix from the "
               "inputs to the outputs against frequency",
}
MODEL_PICTURES = {
    "--plot-shape": "draw the static equilibrium's deformed shape over the undeformed model to "
                    "this PNG (or .pdf, .svg) file, magnified so that the largest displacement "
                    "is 10 %% of the model's size",
    "--plot-modes": "draw the mode shapes, one panel each (the N of --modes, else the lowest "
                    f"{MODE_PANELS}), to this PNG (or .pdf, .svg) file",
}


def picture_files(args, options):
    """[(option, path or None)] of picture options, read from argparse's namespace (where a
    long option --plot-shape is the attribute plot_shape)."""
    return [(option, getattr(args, option[2:].replace("-", "_"))) for option in options]


def run_with_pictures(args):
    """`run`, then the pictures asked for. Whether the scene has anything to draw and whether
    the picture files are distinct is checked before the analyses, so a mistake costs no run."""
    from ..analysis.pictures import require_drawable
    from ..scene.building import load_scene
    from . import distinct_outputs

    distinct_outputs(*picture_files(args, {**RESULT_PICTURES, **MODEL_PICTURES}))
    wanted = picture_files(args, MODEL_PICTURES)
    if not any(path for _, path in wanted):
        return run(args)
    model = load_scene(args.scene, overrides=args.set)
    for option, path in wanted:
        if path:
            require_drawable(model, option)
    code = run(args, model)  # the model loaded once, for the checks above and the analyses
    if code:
        return code
    draw_pictures(model, args)
    return 0


def draw_pictures(model, args):
    """Draw --plot-shape and --plot-modes. The equilibrium and modes are computed here again
    rather than taken from `analyze`, whose result holds the shapes on the DOFs only; for the
    models of flexure that costs a fraction of a second."""
    from ..analysis.linearization import linearize
    from ..analysis.modal import natural_frequencies
    from ..analysis.pictures import plot_modes, plot_shape
    from ..analysis.statics import static_equilibrium

    solution = static_equilibrium(model)
    if args.plot_shape:
        with atomic_output(args.plot_shape, "--plot-shape") as temporary:
            plot_shape(model, solution.x, temporary)
        wrote(args.plot_shape, "the static equilibrium's deformed shape")
    if args.plot_modes:
        panels = args.modes if args.modes is not None and args.modes > 0 else MODE_PANELS
        modes = natural_frequencies(model, panels, linear_model=linearize(model, solution))
        with atomic_output(args.plot_modes, "--plot-modes") as temporary:
            plot_modes(model, modes, temporary, count=panels)
        drawn = min(panels, len(modes.frequencies_hz))
        wrote(args.plot_modes, f"the {drawn} lowest mode shape{'s' * (drawn > 1)}")
