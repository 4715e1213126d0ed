"""The serialized FMU state: data, never code. A versioned, self-describing binary format.

Layout (little endian):

    offset  size  field
    0       8     magic b"FLXSTATE"
    8       2     format version (uint16), FORMAT_VERSION
    10      2     reserved, 0
    12      4     identity length I (uint32)
    16      8     payload length P (uint64)
    24      32    SHA-256 over bytes [0, 24) and [56, 56 + I + P)
    56      I     identity, UTF-8: "<model identifier> <digest of what the FMU was built from>"
    56 + I  P     payload: one value, encoded as below

A value is one tag byte and its body:

    b"N"                                  None
    b"T" / b"F"                           True / False
    b"i" int64                            int
    b"f" float64                          float
    b"s" uint32 n, n bytes UTF-8          str
    b"a" dtype code (1), ndim (1), ndim x uint64 shape, data (C order)
                                          numpy array; dtype code b"f" float64, b"i" int64,
                                          b"b" bool
    b"d" uint32 n, n x (key str body, value)   dict with str keys (insertion order kept)
    b"l" / b"t" uint32 n, n x value       list / tuple

`decode` parses with `struct` and `numpy.frombuffer` only, checks every length against the
bytes that are there before reading them, and raises `StateFormatError` naming the first
thing that is wrong: not a flexure state (magic), another format version, truncated or
trailing bytes, a checksum mismatch (a flipped byte), another FMU (identity), an unknown tag,
nesting deeper than MAX_DEPTH. The checksum guards against corruption, not forgery: a
hand-made state with a valid checksum is still only numbers and strings of the allowed
types, which the slave then checks like any other input.
"""

import hashlib
import struct

import numpy as np

MAGIC = b"FLXSTATE"
FORMAT_VERSION = 1
MAX_DEPTH = 32

_HEAD = struct.Struct("<8sHHIQ32s")  # magic, version, reserved, identity length, payload, sha
_DTYPES = {b"f": np.dtype("<f8"), b"i": np.dtype("<i8"), b"b": np.dtype("?")}
_CODES = {dtype: code for code, dtype in _DTYPES.items()}


class StateFormatError(ValueError):
    """Bytes that are not a valid flexure FMU state of this FMU; the message says why."""


# -- encoding ---------------------------------------------------------------------------------


def encode(identity, value):
    """The bytes of `value` (None, bool, int, float, str, numpy array of float/int/bool, and
    dicts with str keys, lists and tuples of those) for the FMU `identity`."""
    payload = bytearray()
    _encode_value(payload, value, 0)
    ident = identity.encode()
    head = struct.pack("<8sHHIQ", MAGIC, FORMAT_VERSION, 0, len(ident), len(payload))
    digest = hashlib.sha256(head + ident + payload).digest()
    return head + digest + ident + bytes(payload)


def _encode_str(out, text):
    data = text.encode()
    out += struct.pack("<I", len(data))
    out += data


def _encode_value(out, value, depth):
    if depth > MAX_DEPTH:
        raise StateFormatError(f"the state nests deeper than {MAX_DEPTH} levels")
    if value is None:
        out += b"N"
    elif value is True or value is False or isinstance(value, np.bool_):
        out += b"T" if value else b"F"
    elif isinstance(value, (int, np.integer)):
        out += b"i" + struct.pack("<q", int(value))
    elif isinstance(value, (float, np.floating)):
        out += b"f" + struct.pack("<d", float(value))
    elif isinstance(value, str):
        out += b"s"
        _encode_str(out, value)
    elif isinstance(value, np.ndarray):
        kind = value.dtype.kind
        dtype = np.dtype("<f8") if kind == "f" else np.dtype("<i8") if kind in "iu" else \
            np.dtype("?") if kind == "b" else None
        if dtype is None or value.ndim > 255:
            raise StateFormatError(f"cannot store an array of dtype {value.dtype} "
                                   f"(expected float, int or bool)")
        out += b"a" + _CODES[dtype] + struct.pack("<B", value.ndim)
        out += struct.pack(f"<{value.ndim}Q", *value.shape)
        out += np.ascontiguousarray(value, dtype=dtype).tobytes()
    elif isinstance(value, dict):
        out += b"d" + struct.pack("<I", len(value))
        for key, item in value.items():
            if not isinstance(key, str):
                raise StateFormatError(f"cannot store a dict key {key!r} (expected str)")
            _encode_str(out, key)
            _encode_value(out, item, depth + 1)
    elif isinstance(value, (list, tuple)):
        out += (b"l" if isinstance(value, list) else b"t") + struct.pack("<I", len(value))
        for item in value:
            _encode_value(out, item, depth + 1)
    else:
        raise StateFormatError(f"cannot store a value of type {type(value).__name__}")


# -- decoding ---------------------------------------------------------------------------------


def read_identity(data):
    """(format version, identity) of state bytes, after the magic and length checks only."""
    data = _as_bytes(data)
    if len(data) < _HEAD.size:
        if not data:
            raise StateFormatError("empty: no bytes given")
        if not MAGIC.startswith(data[:8]):
            raise StateFormatError(f"not a flexure FMU state (it does not start with "
                                   f"{MAGIC!r}; {len(data)} bytes)")
        raise StateFormatError(f"truncated: {len(data)} bytes, shorter than the "
                               f"{_HEAD.size}-byte header")
    magic, version, _, n_ident, n_payload, _ = _HEAD.unpack_from(data)
    if magic != MAGIC:
        raise StateFormatError(f"not a flexure FMU state (it starts with {magic!r}, "
                               f"expected {MAGIC!r})")
    if version != FORMAT_VERSION:
        raise StateFormatError(f"state format version {version}; this FMU reads version "
                               f"{FORMAT_VERSION}")
    expected = _HEAD.size + n_ident + n_payload
    if len(data) < expected:
        raise StateFormatError(f"truncated: {len(data)} bytes, the header announces "
                               f"{expected}")
    if len(data) > expected:
        raise StateFormatError(f"{len(data) - expected} trailing bytes after the "
                               f"{expected} the header announces")
    try:
        identity = data[_HEAD.size:_HEAD.size + n_ident].decode()
    except UnicodeDecodeError:
        identity = None
    return version, identity


def decode(data, identity):
    """The value stored in state bytes of the FMU `identity`; StateFormatError if invalid."""
    data = _as_bytes(data)
    _, found = read_identity(data)
    digest = _HEAD.unpack_from(data)[5]
    if hashlib.sha256(data[:24] + data[_HEAD.size:]).digest() != digest:
        raise StateFormatError("checksum mismatch: the bytes were changed after they were "
                               "written (SHA-256 of header and payload differs)")
    if found != identity:
        raise StateFormatError(f"the state is of {_describe(found)}; this FMU is "
                               f"{_describe(identity)}")
    n_ident = struct.unpack_from("<I", data, 12)[0]
    reader = _Reader(data, _HEAD.size + n_ident)
    value = reader.value(0)
    if reader.pos != len(data):
        raise StateFormatError(f"{len(data) - reader.pos} unread bytes after the payload")
    return value


def _describe(identity):
    if identity is None:
        return "an unreadable identity"
    name, _, digest = identity.partition(" ")
    return f"{name!r} (build {digest or '?'})"


def _as_bytes(data):
    if isinstance(data, (bytes, bytearray, memoryview)):
        return bytes(data)
    raise StateFormatError(f"expected bytes, got {type(data).__name__}")


class _Reader:
    def __init__(self, data, pos):
        self.data, self.pos = data, pos

    def take(self, n, what):
        if n < 0 or self.pos + n > len(self.data):
            raise StateFormatError(f"payload truncated at byte {self.pos}: {what} needs {n} "
                                   f"bytes, {len(self.data) - self.pos} left")
        chunk = self.data[self.pos:self.pos + n]
        self.pos += n
        return chunk

    def unpack(self, fmt, what):
        size = struct.calcsize(fmt)
        return struct.unpack(fmt, self.take(size, what))

    def text(self, what):
        (n,) = self.unpack("<I", what)
        try:
            return self.take(n, what).decode()
        except UnicodeDecodeError:
            raise StateFormatError(f"{what} at byte {self.pos - n} is not UTF-8") from None

    def value(self, depth):
        if depth > MAX_DEPTH:
            raise StateFormatError(f"the payload nests deeper than {MAX_DEPTH} levels")
        tag = self.take(1, "a tag")
        if tag == b"N":
            return None
        if tag in (b"T", b"F"):
            return tag == b"T"
        if tag == b"i":
            return self.unpack("<q", "an int")[0]
        if tag == b"f":
            return self.unpack("<d", "a float")[0]
        if tag == b"s":
            return self.text("a string")
        if tag == b"a":
            code = self.take(1, "an array dtype")
            if code not in _DTYPES:
                raise StateFormatError(f"unknown array dtype code {code!r} at byte "
                                       f"{self.pos - 1}")
            dtype = _DTYPES[code]
            (ndim,) = self.unpack("<B", "an array rank")
            shape = self.unpack(f"<{ndim}Q", "an array shape")
            count = 1
            for n in shape:
                count *= n
            raw = self.take(count * dtype.itemsize, f"an array of shape {shape}")
            return np.frombuffer(raw, dtype=dtype).reshape(shape).copy()
        if tag == b"d":
            (n,) = self.unpack("<I", "a dict size")
            result = {}
            for _ in range(n):
                key = self.text("a dict key")
                result[key] = self.value(depth + 1)
            return result
        if tag in (b"l", b"t"):
            (n,) = self.unpack("<I", "a sequence size")
            items = [self.value(depth + 1) for _ in range(min(n, len(self.data)))]
            if len(items) != n:
                raise StateFormatError(f"a sequence of {n} items cannot fit in the payload")
            return items if tag == b"l" else tuple(items)
        raise StateFormatError(f"unknown tag {tag!r} at byte {self.pos - 1}")
