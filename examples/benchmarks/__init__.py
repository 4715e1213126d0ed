"""flexure's speed benchmarks against a peer code (Exudyn): `compare` prints the table of the
speed targets, `peer_exudyn` is the Exudyn side. Exudyn is an optional extra:
``pip install ".[bench]"``.

The modules import each other relatively (``from .measure import log``). The two scripts,
compare.py and peer_exudyn.py, also run by their paths (``python
examples/benchmarks/compare.py``); such a file has no package, so each first joins this one,
found from the repository's root, in four lines at its top (PEP 366). Nothing else touches
``sys.path``."""
