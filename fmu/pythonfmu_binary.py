"""Which pythonfmu binary an FMU carries: flexure's corrected build, or pythonfmu's own.

pythonfmu 0.7.0's binary crashes the host on a NULL state handle, on a call with a freed
instance, and after any fmi2Fatal, and reports a stale fmi2LastSuccessfulTime after
fmi2SetFMUstate: nothing in Python can prevent that. flexure ships a corrected build of it
(`fmu/native/pythonfmu-export`, its README lists each change; `fmu/native/build.sh` builds
it) in `fmu/native/<platform>/`, with a manifest of what it was built from. The FMU builder
puts it into an FMU in place of the stock binary when it fits, and otherwise keeps the stock
one (the fallback; docs/fmu.md's datasheet says what still crashes with it). Either way the
FMU records which one in resources/pythonfmu-binary.json, and the slave logs it.

The corrected binary fits when its manifest matches the library (SHA-256), it was built from
the pythonfmu version installed here (its C++ half calls the Python half's methods), and this
Python can load it: a stable-ABI ("abi3") build in any CPython 3, another only in the CPython
whose cache tag it names.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
from dataclasses import dataclass
from pathlib import Path

NATIVE = Path(__file__).with_name("native")
LIBRARY = "libpythonfmu-export.so"  # the name pythonfmu's resources give the linux64 binary
MANIFEST = "libpythonfmu-export.json"
RECORD = "pythonfmu-binary.json"  # in the FMU's resources/
CHOICES = ("auto", "corrected", "stock")
ENVIRONMENT = "FLEXURE_FMU_BINARY"  # auto (default), corrected or stock


@dataclass(frozen=True)
class Binary:
    """The binary an FMU carries for one platform.

    Attributes
    ----------
    kind : str
        "corrected" (flexure's build) or "stock" (pythonfmu's own).
    data : bytes or None
        The corrected library's bytes; None keeps the binary pythonfmu put into the FMU.
    reason : str
        Why this one: for the stock binary, why the corrected one was not used.
    manifest : dict
        The corrected build's manifest ({} for the stock binary).
    """

    kind: str
    data: bytes | None
    reason: str
    manifest: dict


def choose_binary(platform: str, wanted: str | None = None) -> Binary:
    """The binary an FMU built here carries for `platform`.

    Parameters
    ----------
    platform : str
        An FMI platform ("linux64", "win64").
    wanted : str, optional
        "auto" (the corrected build where it fits, else the stock one), "corrected" (refuse
        to fall back) or "stock"; default: the environment variable FLEXURE_FMU_BINARY, else
        "auto".

    Returns
    -------
    Binary

    Raises
    ------
    ValueError
        An unknown `wanted`, or "corrected" where the corrected build does not fit (the
        reason is in the message).
    """
    if wanted is None:
        wanted = os.environ.get(ENVIRONMENT, "").strip() or "auto"
    if wanted not in CHOICES:
        raise ValueError(f"pythonfmu binary {wanted!r}: expected one of {', '.join(CHOICES)}")
    if wanted == "stock":
        return Binary("stock", None, "the stock binary was asked for", {})
    data, manifest, problem = _corrected(platform)
    if problem is None:
        return Binary("corrected", data, "it fits this Python and pythonfmu", manifest)
    if wanted == "corrected":
        raise ValueError(f"the corrected pythonfmu binary for {platform} cannot be used: "
                         f"{problem}")
    return Binary("stock", None, problem, {})


def _corrected(platform):
    """(bytes, manifest, None) of the corrected build for `platform`, or (None, {}, why not)."""
    import pythonfmu

    folder = NATIVE / platform
    library, manifest_path = folder / LIBRARY, folder / MANIFEST
    if not library.is_file() or not manifest_path.is_file():
        return None, {}, (f"flexure has no corrected build for {platform} "
                          "(fmu/native/build.sh makes one on Linux x86_64)")
    try:
        manifest = json.loads(manifest_path.read_text())
        expected = (manifest["sha256"], manifest["pythonfmu"], manifest["python_abi"])
    except (ValueError, KeyError, TypeError) as error:
        return None, {}, f"{manifest_path}: not a manifest of the build ({error})"
    data = library.read_bytes()
    digest = hashlib.sha256(data).hexdigest()
    sha256, version, abi = expected
    if digest != sha256:
        return None, {}, (f"{library} has SHA-256 {digest[:12]}, its manifest says "
                          f"{str(sha256)[:12]}: rebuild it with fmu/native/build.sh")
    if version != pythonfmu.__version__:
        return None, {}, (f"it is pythonfmu {version}'s binary, and pythonfmu "
                          f"{pythonfmu.__version__} is installed: its C++ half must match "
                          "the Python half")
    implementation = sys.implementation
    fits = (implementation.name == "cpython" if abi == "abi3"
            else implementation.cache_tag == abi)
    if not fits:
        return None, {}, (f"it is built for the Python ABI {abi!r}; this Python is "
                          f"{implementation.name} ({implementation.cache_tag})")
    return data, manifest, None


def record(binaries: dict[str, Binary], stock_sha256: dict[str, str]) -> bytes:
    """resources/pythonfmu-binary.json: for each platform, which binary the FMU carries.

    Parameters
    ----------
    binaries : dict
        {platform: Binary}.
    stock_sha256 : dict
        {platform: SHA-256 of the stock binary pythonfmu put into the FMU}.

    Returns
    -------
    bytes
    """
    entries = {}
    for platform, binary in binaries.items():
        if binary.kind == "corrected":
            entries[platform] = {"binary": "corrected", "what": binary.manifest["what"],
                                 "pythonfmu": binary.manifest["pythonfmu"],
                                 "patch": binary.manifest.get("patch"),
                                 "sha256": binary.manifest["sha256"]}
        else:
            entries[platform] = {"binary": "stock", "why": binary.reason,
                                 "sha256": stock_sha256.get(platform)}
    return (json.dumps(entries, indent=2) + "\n").encode()
