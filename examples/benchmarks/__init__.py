"""flexure's speed benchmarks against a peer code (Exudyn): `compare` prints the table of the
speed targets, `peer_exudyn` is the Exudyn side. Exudyn is an optional extra:
``pip install ".[bench]"``."""
