"""Scenes, tutorials, benchmarks and reports a user runs as scripts; the tests import them as
`examples.NAME` (pytest puts the repository root on the path, pyproject.toml)."""
