"""The public API keeps its documentation standard (STYLE.md: types in annotations, numpydoc
docstrings with units).

Every function that flexure.core, flexure.controllers and flexure.fmu export (their
`__all__`), and every public method and property of a class they export (its own and those
it inherits from flexure's classes; a constructor through the class docstring), must have:

- an annotation on every parameter and on the return;
- a docstring whose first line is a summary;
- a numpydoc "Parameters" section naming every parameter (besides self and cls; a
  parameter whose name starts with "_" is private and may stay unnamed);
- a "Returns" (or "Yields") section when the return annotation is not None.

Properties need the return annotation and a summary only (numpydoc documents them as
attributes). Units cannot be checked mechanically; the sections are where they are written.
"""

import dataclasses
import importlib
import inspect
import re

import pytest

PACKAGES = ("flexure.core", "flexure.controllers", "flexure.fmu")

# A numpydoc section header: a title line followed by a line of dashes.
SECTION = re.compile(r"^[ \t]*(\w[\w ]*)\n[ \t]*-{3,}[ \t]*$", re.MULTILINE)


def sections(doc):
    """{section title: its text} of a cleaned docstring (`inspect.cleandoc`)."""
    found = list(SECTION.finditer(doc))
    return {m.group(1): doc[m.end(): found[k + 1].start() if k + 1 < len(found) else len(doc)]
            for k, m in enumerate(found)}


def documented_names(parameters_text):
    """The names a Parameters section documents: each entry line at the section's own
    indentation, "name : type", "a, b : float", "*args" or "**kwargs"."""
    lines = [line for line in parameters_text.splitlines() if line.strip()]
    if not lines:
        return set()
    indent = min(len(line) - len(line.lstrip()) for line in lines)
    names = set()
    for line in lines:
        if len(line) - len(line.lstrip()) == indent:
            head = line.strip().split(" : ")[0]
            names |= {name.strip().lstrip("*") for name in head.split(",")}
    return names


def problems_of(function, *, method=False, docstring=None, is_property=False):
    """What `function` lacks of the standard (an empty list when it has it all).

    method: its first parameter is self or cls. docstring: where its parameters are
    documented, when that is not its own docstring (a constructor's class docstring)."""
    function = inspect.unwrap(function)
    signature = inspect.signature(function)
    parameters = list(signature.parameters.values())[1 if method else 0:]
    found = [f"parameter {p.name!r} has no annotation" for p in parameters
             if p.annotation is inspect.Parameter.empty]
    if signature.return_annotation is inspect.Signature.empty:
        found.append("no return annotation")
    doc = inspect.getdoc(function) if docstring is None else inspect.cleandoc(docstring)
    if not doc or not doc.strip().splitlines()[0].strip():
        return [*found, "no docstring with a summary line"]
    if is_property:
        return found
    parts = sections(doc)
    public = [p.name for p in parameters if not p.name.startswith("_")]
    if public:
        if "Parameters" not in parts:
            found.append("no Parameters section")
        else:
            missing = set(public) - documented_names(parts["Parameters"])
            found += [f"parameter {name!r} is not in the Parameters section"
                      for name in sorted(missing)]
    if signature.return_annotation not in (None, "None", inspect.Signature.empty) and not (
            {"Returns", "Yields"} & set(parts)):
        found.append("no Returns section")
    return found


def generated(function):
    """Whether a method was written by dataclasses (its fields are annotated instead)."""
    return getattr(getattr(function, "__code__", None), "co_filename", "") == "<string>"


def class_problems(cls, qualified):
    """{"Class.member": problems} of the public methods and properties of `cls`, its own and
    those inherited from flexure's classes (the most derived definition of each name)."""
    found, seen = {}, set()
    for klass in cls.__mro__:
        if not klass.__module__.startswith("flexure."):
            continue
        for name, member in vars(klass).items():
            if name in seen or (name.startswith("_") and name != "__init__"):
                continue
            seen.add(name)
            label = f"{qualified}.{name}"
            if isinstance(member, property):
                found[label] = problems_of(member.fget, method=True, is_property=True)
            elif isinstance(member, staticmethod):
                found[label] = problems_of(member.__func__)
            elif isinstance(member, classmethod):
                found[label] = problems_of(member.__func__, method=True)
            elif name == "__init__":
                if inspect.isfunction(member) and not generated(member):
                    # numpydoc documents a constructor's parameters in the class docstring
                    own = inspect.getdoc(member) or ""
                    docstring = own if "Parameters" in sections(own) else cls.__doc__
                    found[label] = problems_of(member, method=True, docstring=docstring)
            elif inspect.isfunction(member):
                found[label] = problems_of(member, method=True)
    return found


def package_problems(package):
    """{"package.name[.member]": problems} over a package's `__all__`."""
    module = importlib.import_module(package)
    found = {}
    for name in module.__all__:
        value = getattr(module, name)
        qualified = f"{package}.{name}"
        if inspect.isclass(value):
            found |= class_problems(value, qualified)
        elif callable(value):
            found[qualified] = problems_of(value)
    return {name: problems for name, problems in found.items() if problems}


@pytest.mark.parametrize("package", PACKAGES)
def test_public_functions_are_typed_and_documented(package):
    problems = package_problems(package)
    report = "\n".join(f"{name}: {'; '.join(p)}" for name, p in sorted(problems.items()))
    assert not problems, f"{len(problems)} public callables miss the standard:\n{report}"


def test_public_api_is_walked():
    # the walk reaches functions, methods, class-docstring constructors, inherited mixin
    # methods and properties (a walk that found nothing would pass vacuously)
    core = importlib.import_module("flexure.core")
    walked = class_problems(core.Simulator, "Simulator")
    assert {"Simulator.__init__", "Simulator.advance", "Simulator.outputs_along",
            "Simulator.get_state", "Simulator.derivative", "Simulator.time"} <= set(walked)
    # a dataclass's generated constructor is left to its annotated fields
    assert dataclasses.is_dataclass(core.StaticSolution)
    assert "StaticSolution.__init__" not in class_problems(core.StaticSolution,
                                                           "StaticSolution")
    assert "StaticSolution.coordinates" in class_problems(core.StaticSolution,
                                                          "StaticSolution")


def test_the_check_finds_what_is_missing():
    def bare(model, x=None):
        return x

    def half(model: object, *, rtol: float = 1e-8) -> float:
        """The summary.

        Parameters
        ----------
        model : Model
        """
        return rtol

    def whole(model: object, *values: float, _private: int = 0, **keys: str) -> None:
        """The summary.

        Parameters
        ----------
        model : Model
        *values : float
            m.
        **keys : str
        """

    assert problems_of(bare) == ["parameter 'model' has no annotation",
                                 "parameter 'x' has no annotation", "no return annotation",
                                 "no docstring with a summary line"]
    assert problems_of(half) == ["parameter 'rtol' is not in the Parameters section",
                                 "no Returns section"]
    assert problems_of(whole) == []


def test_documented_names_reads_numpydoc_entries():
    text = inspect.cleandoc("""
        stroke, duration : float
            The move (m, s).
        fs : float
            Sample rate, Hz: not an entry, indented.
        **design_options
            Passed on.
        """)
    assert documented_names(text) == {"stroke", "duration", "fs", "design_options"}
