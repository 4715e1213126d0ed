"""The distribution ships every package of the source tree.

pyproject.toml lists flexure's packages explicitly (the top-level folders are renamed into
`flexure.*` through package-dir), and the tests run on an editable install, which finds any
folder on disk: a package folder missing from the list would pass every other test and be
absent from `pip install .`, where `flexure` loads every subcommand's module.
"""

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def listed_packages():
    """{dotted package name: its folder} as pyproject.toml's setuptools table ships them."""
    table = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    folders = table["package-dir"]
    found = {}
    for name in table["packages"]:
        base = max((p for p in folders if name == p or name.startswith(p + ".")), key=len)
        found[name] = ROOT / folders[base] / Path(*name[len(base):].split(".")[1:])
    return found


def test_every_package_folder_is_shipped():
    listed = set(listed_packages().values())
    folders = {init.parent for top in ("core", "fmu", "controllers")
               for init in (ROOT / top).rglob("__init__.py")}
    assert folders, "no package folder found"
    missing = sorted(str(folder.relative_to(ROOT)) for folder in folders - listed)
    assert not missing, f"package folders not in pyproject.toml's packages: {missing}"


def test_every_listed_package_exists():
    for name, folder in listed_packages().items():
        assert folder.is_dir(), f"{name}: no folder {folder.relative_to(ROOT)}"


def test_the_corrected_pythonfmu_binary_is_package_data():
    """The FMU builder puts fmu/native/linux64's library into FMUs (flexure.fmu.
    pythonfmu_binary): an installed flexure must carry it, its manifest and pythonfmu's
    license, so that no compiler is needed."""
    table = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    patterns = table["package-data"]["flexure.fmu"]
    shipped = {path.relative_to(ROOT / "fmu").as_posix() for pattern in patterns
               for path in (ROOT / "fmu").glob(pattern)}
    assert {"native/linux64/libpythonfmu-export.so", "native/linux64/libpythonfmu-export.json",
            "native/pythonfmu-export/LICENSE"} <= shipped
