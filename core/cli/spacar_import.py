"""`flexure import FILE.dat [-o SCENE.toml]`: a SPACAR input file written as a scene file."""

from pathlib import Path

from . import output_file, refuse_overwriting_inputs, write_outputs


def register(subparsers):
    """Add the `import` subcommand."""
    parser = subparsers.add_parser(
        "import", help="write a SPACAR input file (.dat) as a scene file (TOML)",
        description="Read a SPACAR input file (X, PLTRUSS, PLBEAM, TRUSS, BEAM, FIX, INPUTX, "
                    "DYNX, DYNE, RLSE, ESTIFF, EDAMP, EM, XM, XF, GRAVITY, INPUTF, OUTX, "
                    "OUTXP; docs/scene-format.md) and write it as a scene file. Every command "
                    "also reads a .dat file directly.")
    parser.add_argument("file", help="the SPACAR input file (.dat)")
    parser.add_argument("-o", "--out", type=output_file((".toml",)), metavar="TOML",
                        help="the scene file to write (default: FILE's name with .toml, here)")
    parser.set_defaults(run=run)


def run(args):
    from ..errors import SceneError
    from ..scene.building import build_model
    from ..scene.scene_writer import scene_toml
    from ..scene.spacar_input import read_spacar

    path = Path(args.file)
    if path.suffix.lower() != ".dat":
        raise SceneError(f"{path}: expected a SPACAR input file ending in .dat")
    data = read_spacar(path)
    # the scene must build; whether it is exactly constrained is `flexure analyze`'s report,
    # and a scene that is not is worth importing to edit
    model = build_model(data, source=str(path), check=False)
    out = args.out or output_file((".toml",))(f"{path.stem}.toml")
    refuse_overwriting_inputs([("--out", out)], [path])
    text = scene_toml(data, f"Imported by `flexure import` from the SPACAR input file "
                            f"{path.name}:\nnodes and elements keep SPACAR's numbers, input k is "
                            "uk (INPUTF), output k is yk (OUTX, OUTXP).")
    code = write_outputs("flexure import", [("--out", Path(out), lambda t: Path(t).write_text(
        text))])
    count = model.dof_count()
    print(f"{len(data['nodes'])} nodes, {len(data['elements'])} elements; NDOF = NX - NXO - "
          f"NEO = {count['nx']} - {count['nxo']} - {count['neo']} = {count['ndof']}")
    return code
