"""The table the benchmark prints: one `Row` per target, the line on the machine and the
versions in its title, written as text or as markdown."""

import os
import platform
from dataclasses import dataclass

import numpy as np

HEADERS = ["target", "flexure", "peer / limit", "ratio", "met"]


@dataclass
class Row:
    """One line of the table; `ratio` and `met` are None where they do not apply."""

    target: str
    flexure: str
    peer: str
    ratio: float | None = None
    met: bool | None = None

    def cells(self):
        ratio = "" if self.ratio is None else f"{self.ratio:.3g}"
        met = "" if self.met is None else ("yes" if self.met else "NO")
        return [self.target, self.flexure, self.peer, ratio, met]


def environment():
    """One line on the machine and the versions."""
    import numba

    import flexure.core

    parts = [f"flexure {flexure.core.__version__}", f"Python {platform.python_version()}",
             f"numpy {np.__version__}", f"numba {numba.__version__}"]
    try:
        import exudyn

        parts.append(f"Exudyn {exudyn.__version__}")
    except ImportError:
        parts.append("Exudyn not installed")
    parts.append(f"{platform.machine()} {os.cpu_count()} CPUs")
    if hasattr(os, "getloadavg"):
        parts.append(f"load average {os.getloadavg()[0]:.2f}")
    return ", ".join(parts)


def text_table(rows, title):
    from flexure.core.reporting.tables import format_table

    return format_table(HEADERS, [r.cells() for r in rows], title=title)


def markdown(rows, title):
    from flexure.core.reporting.tables import markdown_table

    return f"{title}\n\n" + markdown_table(HEADERS, [[c.replace("|", "\\|") for c in r.cells()]
                                                     for r in rows]) + "\n"
