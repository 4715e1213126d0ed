#!/bin/sh
# Build flexure's corrected pythonfmu 0.7.0 binary (fmu/native/pythonfmu-export, see its
# README) for this platform and write it, with a manifest the FMU builder checks, to
# fmu/native/<platform>/:
#
#   libpythonfmu-export.so     the shared library every FMU carries as binaries/<platform>/
#   libpythonfmu-export.json   what it was built from and with, and its SHA-256
#
# Usage: fmu/native/build.sh [PYTHON]   (default: python3 on PATH; its headers are used)
#
# Built as pythonfmu builds its own (build_unix.sh: CMake, Release, the machine's compiler)
# against the stable ABI (Py_LIMITED_API): like the stock binary it links no libpython and
# takes the Python symbols from the process that loads it, so one build serves every CPython
# 3 host. Only linux64 can be built here; on another platform FMUs keep the stock binary.
set -eu

here=$(cd "$(dirname "$0")" && pwd)
python=${1:-python3}
case "$(uname -s)-$(uname -m)" in
    Linux-x86_64) platform=linux64 ;;
    *) echo "build.sh: $(uname -s) $(uname -m) is not a platform this script builds" \
            "(only Linux x86_64); FMUs keep pythonfmu's stock binary there" >&2; exit 1 ;;
esac
include=$("$python" -c "import sysconfig; print(sysconfig.get_paths()['include'])") || {
    echo "build.sh: $python cannot say where its headers are: give a Python 3" >&2; exit 1; }
[ -f "$include/Python.h" ] || {
    echo "build.sh: no Python.h in $include: install the Python headers (python3-dev)" >&2
    exit 1
}

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# pythonfmu's CMake writes the library to <source>/../resources/binaries/<platform>: build a
# copy of the sources in a temporary folder, so nothing lands in the repository but the result.
cp -R "$here/pythonfmu-export" "$work/pythonfmu-export"
# the headers named directly: CMake 3.25's FindPython does not find a pyenv or venv Python's
cmake -S "$work/pythonfmu-export" -B "$work/build" -DCMAKE_BUILD_TYPE=Release \
      -DPython3_INCLUDE_DIR="$include" >/dev/null 2>"$work/cmake.log" || {
    cat "$work/cmake.log" >&2; exit 1; }
cmake --build "$work/build" -j 2 >/dev/null
built="$work/resources/binaries/$platform/libpythonfmu-export.so"

# Like the stock binary (not stripped either), it must take libpython's symbols from the host
# process: linked to one libpython, it would load a second interpreter into a host whose own
# Python is another build (a venv's, a conda one), or fail where that library is not installed.
if readelf -d "$built" | grep -q 'NEEDED.*libpython'; then
    echo "build.sh: the library links libpython; the stock binary does not" >&2; exit 1
fi

mkdir -p "$here/$platform"
cp "$built" "$here/$platform/libpythonfmu-export.so"
"$python" - "$here/$platform" "$include" <<'EOF'
import hashlib, json, platform, re, subprocess, sys
from pathlib import Path

folder, include = Path(sys.argv[1]), sys.argv[2]
library = folder / "libpythonfmu-export.so"
symbols = subprocess.run(["objdump", "-T", str(library)], capture_output=True, text=True,
                         check=True).stdout
def newest(prefix):
    found = {tuple(map(int, v.split("."))) for v in re.findall(prefix + r"_([0-9.]+)\)?\s", symbols)}
    return ".".join(map(str, max(found))) if found else None
compiler = subprocess.run(["c++", "--version"], capture_output=True, text=True).stdout
manifest = {
    "what": "pythonfmu 0.7.0's binary with flexure's patch (fmu/native/pythonfmu-export/README.md)",
    "pythonfmu": "0.7.0",
    "upstream": "https://github.com/NTNU-IHB/PythonFMU/tree/f301adc2e654a5dc2619a7dda675e78ab5f79d8b",
    "patch": 1,
    "python_abi": "abi3",
    "python_headers": f"{include} (Python {platform.python_version()})",
    "compiler": compiler.splitlines()[0] if compiler else "unknown",
    "glibc": newest("GLIBC"),
    "glibcxx": newest("GLIBCXX"),
    "sha256": hashlib.sha256(library.read_bytes()).hexdigest(),
}
(folder / "libpythonfmu-export.json").write_text(json.dumps(manifest, indent=2) + "\n")
print(f"{library}: sha256 {manifest['sha256']}, needs glibc {manifest['glibc']}, "
      f"libstdc++ GLIBCXX {manifest['glibcxx']}")
EOF
