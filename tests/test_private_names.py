"""No module reads another module's private names (the developers' guide: "no module reads
another's private names"), not even a test: whatever another file needs of a module is
public, with a docstring. Checked on the source text of every Python file of the project:
a `from M import _name`, and `alias._name` where alias is a module of the project imported
by `import M as alias` or `from P import module as alias`. Dunder names (`__version__`) are
not private."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FOLDERS = ("core", "fmu", "controllers", "examples", "tests")


def private(name):
    """Whether a name is a module's private one: one leading underscore, not a dunder."""
    return name.startswith("_") and not name.startswith("__")


def module_file(path, level, module):
    """The project's file of `module` imported from the file `path` at relative `level`
    (0: absolute), or None when the module is not the project's own."""
    if level == 0:
        parts = module.split(".")
        if parts[0] != "flexure" and parts[0] not in FOLDERS:
            return None
        base, parts = ROOT, parts[1:] if parts[0] == "flexure" else parts
    else:
        base = path.parent
        for _ in range(level - 1):
            base = base.parent
        parts = module.split(".") if module else []
    target = base.joinpath(*parts)
    for candidate in (target.with_suffix(".py"), target / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def private_reads(path, text):
    """[(line, what)] of the private names of other modules that the source `text` of the
    file `path` reads."""
    found, modules = [], set()
    tree = ast.parse(text, str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module != "__future__":
            for alias in node.names:
                if private(alias.name):
                    found.append((node.lineno, f"from {'.' * node.level}{node.module or ''} "
                                               f"import {alias.name}"))
                inner = f"{node.module}.{alias.name}" if node.module else alias.name
                if module_file(path, node.level, inner) is not None:
                    modules.add(alias.asname or alias.name)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.asname and module_file(path, 0, alias.name) is not None:
                    modules.add(alias.asname)
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and private(node.attr)
                and isinstance(node.value, ast.Name) and node.value.id in modules):
            found.append((node.lineno, f"{node.value.id}.{node.attr}"))
    return found


def project_files():
    for folder in FOLDERS:
        for path in sorted((ROOT / folder).rglob("*.py")):
            if "native" not in path.parts:
                yield path


def test_no_module_reads_another_modules_private_names():
    reads = [f"{path.relative_to(ROOT)}:{line}: {what}"
             for path in project_files()
             for line, what in private_reads(path, path.read_text())]
    assert not reads, "private names read across modules:\n" + "\n".join(reads)


def test_the_check_finds_a_private_import_and_a_private_attribute():
    path = ROOT / "core" / "engine" / "example.py"
    text = ("from .kinematics import _hidden, solve_kinematics\n"
            "from . import slots as slot\n"
            "import numpy as np\n"
            "value = slot._inner + np._private_but_not_ours + slot.X\n")
    assert private_reads(path, text) == [(1, "from .kinematics import _hidden"),
                                         (4, "slot._inner")]


def test_the_walk_reads_every_folder():
    files = list(project_files())
    assert {path.relative_to(ROOT).parts[0] for path in files} == set(FOLDERS)
    assert ROOT / "tests" / "test_private_names.py" in files
