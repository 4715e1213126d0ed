"""`flexure import FILE.dat [-o SCENE.toml]`: a SPACAR input file written as a scene file."""

import sys
from pathlib import Path

from . import output_file, refuse_overwriting_inputs, write_outputs

# CPU seconds per element of reading, building and writing a large file (a chain of PLBEAMs:
# 80,000 in 9.9 s on the project's 2-core machine, 2026-11-29); linear in the element count
SECONDS_PER_ELEMENT = 1.2e-4
SAY_FROM_S = 5.0  # a file expected to take longer is announced with its estimate


def register(subparsers):
    """Add the `import` subcommand."""
    parser = subparsers.add_parser(
        "import", help="write a SPACAR input file (.dat) as a scene file (TOML)",
        description="Read a SPACAR input file (X, PLTRUSS, PLBEAM, TRUSS, BEAM, FIX, INPUTX, "
                    "INPUTE, DYNX, DYNE, RLSE, ESTIFF, EDAMP, EM, XM, XF, GRAVITY, DELINPX, "
                    "DELINPE, INPUTF, INX, OUTX, OUTXP, OUTE, OUTF; docs/scene-format.md) and "
                    "write it as a scene file; say what each INPUTX and INPUTE became (a "
                    "kinematic input, or held). Every command also reads a .dat file "
                    "directly.")
    parser.add_argument("file", help="the SPACAR input file (.dat)")
    parser.add_argument("-o", "--out", type=output_file((".toml",)), metavar="TOML",
                        help="the scene file to write (default: FILE's name with .toml, here)")
    parser.set_defaults(run=run)


def run(args):
    from ..errors import SceneError
    from ..scene.building import build_model
    from ..scene.scene_writer import scene_toml
    from ..scene.spacar_input import import_spacar

    path = Path(args.file)
    if path.suffix.lower() != ".dat":
        raise SceneError(f"{path}: expected a SPACAR input file ending in .dat")
    data, notes = import_spacar(path)
    expected = SECONDS_PER_ELEMENT * len(data["elements"])
    if expected > SAY_FROM_S:  # the building and writing take most of it: say so first
        print(f"flexure import: {len(data['elements'])} elements and {len(data['nodes'])} "
              f"nodes: about {expected:.0f} s to build and write", file=sys.stderr, flush=True)
    # the scene must build; whether it is exactly constrained is `flexure analyze`'s report,
    # and a scene that is not is worth importing to edit
    model = build_model(data, source=str(path), check=False)
    out = args.out or output_file((".toml",))(f"{path.stem}.toml")
    refuse_overwriting_inputs([("--out", out)], [path])
    text = scene_toml(data, f"Imported by `flexure import` from the SPACAR input file "
                            f"{path.name}:\nnodes and elements keep SPACAR's numbers, input k is "
                            "uk (INPUTF, INX),\noutput k is yk (OUTX, OUTXP, OUTE, OUTF); "
                            "a kinematic input moves from its start to its value (DELINPX, "
                            "DELINPE: value - start).")
    code = write_outputs("flexure import", [("--out", Path(out), lambda t: Path(t).write_text(
        text))])
    count = model.dof_count()
    nki = f" - {count['nki']}" if "nki" in count else ""
    print(f"{len(data['nodes'])} nodes, {len(data['elements'])} elements; NDOF = NX - NXO - "
          f"NEO{' - NKI' * ('nki' in count)} = {count['nx']} - {count['nxo']} - "
          f"{count['neo']}{nki} = {count['ndof']}")
    for note in notes:  # what each INPUTX and INPUTE became
        print(note)
    if model.kinematic_inputs:
        print(f"flexure import: warning: {path}: {len(model.kinematic_inputs)} kinematic "
              "input(s): static_equilibrium (`flexure analyze --static`, at each input's value), "
              "motion_state_space, inverse_dynamics, `flexure simulate` (its "
              "--motion-duration), `flexure loop` (its --motion-duration, on the in-process "
              "plant) and `flexure fmu build` (positions in, efforts out) take them",
              file=sys.stderr)
    return code
