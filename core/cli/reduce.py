"""`flexure reduce SCENE --keep N [--tol P]`: which released deformations to prescribe zero
while the lowest N frequencies move by less than P %; writes the reduced scene."""

import argparse
import textwrap
from pathlib import Path

from ..reporting.tables import format_table, print_json
from . import (
    add_scene_arguments,
    count,
    number,
    output_file,
    refuse_overwriting_inputs,
    write_outputs,
)

DEFAULT_TOLERANCE = 1.0  # %


def deformation_names(text):
    """An argparse type: comma-separated deformation names such as e1 or e1,e2."""
    names = tuple(name.strip() for name in text.split(","))
    if not all(len(n) >= 2 and n[0] == "e" and n[1:].isdigit() for n in names):
        raise argparse.ArgumentTypeError(f"expected deformation names such as e1 or e1,e2, "
                                         f"got {text!r}")
    return names


def register(subparsers):
    """Add the `reduce` subcommand."""
    parser = subparsers.add_parser(
        "reduce", help="propose released deformations to prescribe zero, keeping N modes",
        description="Rank the released deformations of a scene by their share of the strain "
                    "energy of its lowest N modes, prescribe zero as many of the smallest as "
                    "keep those N frequencies within the tolerance, and write the reduced "
                    "scene. Prints the frozen deformations and both sets of frequencies.")
    add_scene_arguments(parser)
    parser.add_argument("--keep", type=count, required=True, metavar="N",
                        help="the number of lowest natural frequencies to keep")
    parser.add_argument("--tol", type=number(0.0), default=DEFAULT_TOLERANCE, metavar="P",
                        help=f"largest change of any kept frequency, %% (default "
                             f"{DEFAULT_TOLERANCE:g})")
    parser.add_argument("--freeze", type=deformation_names, default=(), metavar="NAMES",
                        help="deformations to prescribe zero on every element first, "
                             "whatever the tolerance, e.g. e1 (every elongation) or e1,e2")
    parser.add_argument("--out", type=output_file((".toml",)), metavar="TOML",
                        help="the reduced scene (default: SCENE_reduced.toml here)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(run=run)


def run(args):
    from ..analysis.reduction import propose_reduction
    from ..reporting.progress import Progress
    from ..scene.building import build_model, parse_toml, scene_path
    from ..scene.overrides import apply_overrides, describe_overrides
    from ..scene.scene_writer import scene_toml

    path = scene_path(args.scene)
    data = parse_toml(path)
    if args.set:
        # checked here, where a mistake is named as the --set it came from; the reduction
        # then starts from the overridden scene, and so does the scene it writes
        build_model(data, overrides=args.set, source=str(path), default_name=path.stem,
                    check=False)
        data = apply_overrides(data, args.set, source=str(path))
    name = data.get("scene", {}).get("name", path.stem) if isinstance(data, dict) else path.stem
    out = args.out or output_file((".toml",))(f"{name}_reduced.toml")
    refuse_overwriting_inputs([("--out", out)], [path])
    reduction = propose_reduction(data, args.keep, args.tol, freeze=args.freeze,
                                  source=str(path),
                                  progress=Progress("flexure reduce", after=1.0))
    frozen = ", ".join(f"{e}.{d}" for e, d in reduction.frozen) or "nothing"
    header = (f"{name}, reduced by `flexure reduce --keep {args.keep} --tol {args.tol:g}` from "
              f"{path.name}" + (f" with {describe_overrides(args.set)}" if args.set else "")
              + ":\n" + textwrap.fill(f"prescribed zero: {frozen}", 95)
              + f"\nNDOF {reduction.ndof_full} -> {reduction.ndof_reduced}; the lowest "
              f"{args.keep} frequencies within {reduction.change_percent:.3g} %"
              + ("\nthe DOFs are chosen by flexure (the frozen released deformations changed "
                 "their count)" if reduction.dofs_chosen else ""))
    # the reduced scene is another model: it takes its file's name (which names its FMU)
    scene = reduction.scene.setdefault("scene", {})
    scene["name"] = Path(out).stem
    scene["description"] = f"{name} reduced to {reduction.ndof_reduced} DOFs" + (
        f": {scene['description']}" if isinstance(scene.get("description"), str) else "")
    text = scene_toml(reduction.scene, header)
    code = write_outputs("flexure reduce", [("--out", Path(out), lambda t: Path(t).write_text(
        text))], announce=not args.json)
    if args.json:
        print_json(summary(reduction, out), command="flexure reduce")
    else:
        print(render(reduction))
    return code


def summary(reduction, out):
    """The JSON of `--json`: frequencies in Hz, the change in %."""
    return {"keep": reduction.keep, "tolerance_percent": reduction.tolerance,
            "frozen": [f"{e}.{d}" for e, d in reduction.frozen],
            "ndof_full": reduction.ndof_full, "ndof_reduced": reduction.ndof_reduced,
            "full_hz": reduction.full_hz, "reduced_hz": reduction.reduced_hz,
            "change_percent": reduction.change_percent,
            "forced": [f"{e}.{d}" for e, d in reduction.forced],
            "ndof_forced": reduction.ndof_forced, "forced_hz": reduction.forced_hz,
            "dofs_chosen": reduction.dofs_chosen, "scene": str(out)}


def render(reduction):
    """The frozen deformations with their energy shares, then both sets of frequencies."""
    rows = [[f"{e}.{d}", f"{reduction.shares[(e, d)]:.3g}"] for e, d in reduction.frozen]
    parts = [f"NDOF {reduction.ndof_full} -> {reduction.ndof_reduced}: "
             f"{len(reduction.frozen)} deformation(s) prescribed zero"]
    if rows:
        parts.append(format_table(["prescribed zero", "largest share of a kept mode's "
                                                      "strain energy"], rows))
    forced = reduction.forced_hz is not None
    frequencies = []
    for i, (full, reduced) in enumerate(zip(reduction.full_hz, reduction.reduced_hz,
                                            strict=True)):
        row = [i + 1, f"{full:.6g}"]
        if forced:
            row.append(f"{reduction.forced_hz[i]:.6g}")
        frequencies.append(row + [f"{reduced:.6g}", f"{(reduced / full - 1.0) * 100.0:+.3g}"])
    names = sorted({d for _, d in reduction.forced})
    headers = ["mode", f"full, {reduction.ndof_full} DOFs (Hz)"]
    if forced:
        headers.append(f"{','.join(names)} frozen, {reduction.ndof_forced} DOFs (Hz)")
    headers += [f"reduced, {reduction.ndof_reduced} DOFs (Hz)", "change (%)"]
    parts.append(format_table(headers, frequencies))
    return "\n\n".join(parts)
