"""Fixtures shared by the FMU test modules: the scene FMUs, each built once per session.

The imports are inside the fixtures, so that a run of tests that use none of them does not
load flexure.fmu or fmpy."""

import pytest


@pytest.fixture(scope="session")
def scene_fmus(tmp_path_factory):
    """{scene name: FMU path}, each built once, on first use."""
    from flexure.fmu import build_scene_fmu

    folder = tmp_path_factory.mktemp("fmus")
    cache = {}

    def get(name):
        if name not in cache:
            cache[name] = build_scene_fmu(name, folder / f"{name}.fmu")
        return cache[name]

    return get

