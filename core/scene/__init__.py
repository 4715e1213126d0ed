"""Scenes: reading and checking a scene (TOML or a dictionary) into a Model, with overrides,
meshing and section properties, and writing scenes back."""
