"""FMU state in a versioned, typed, checksummed format that can hold only data (never pickle).

An FMU's state - its parameter and port values and its library model with every filter, buffer
and random generator - is encoded as a tree of typed nodes and written as JSON; the bytes are
``MAGIC``, a format version, the payload's length and SHA-256, then the zlib-compressed JSON.
:func:`loads` checks all of that before it decodes, and decoding can only build:

* ``None``, booleans, integers, floats (NaN and infinities tagged), strings;
* lists, tuples, dicts, sets, deques;
* NumPy arrays of numeric or Boolean dtypes (shape checked against the data) and NumPy scalars;
* NumPy generators with a PCG64 bit generator (their state set, as ``numpy.random`` does);
* instances of classes defined in this package (created with ``object.__new__``, their attributes
  set directly: no constructor, no ``__setstate__`` runs), its named tuples, and references to
  its module-level functions and to ``functools.partial`` of them.

What is not data - a closure a maneuver plan holds, a bound method - is not written: it is
marked, and :func:`loads` takes it from a *template*, the same model freshly built from the
same parameters (the FMU builds one before restoring), at the same place in the object tree.

A reference to anything else (another package's class or function, an attribute that is not a
class or a function) is refused, as are nesting deeper than :data:`MAX_DEPTH` and payloads larger
than :data:`MAX_BYTES`: a state is data, so a hostile or damaged one cannot run code, and the
error names what was wrong.  Objects referenced twice are encoded once and referenced by number,
so a restored model shares what the saved one shared.
"""
from __future__ import annotations

import base64
import collections
import enum
import functools
import hashlib
import importlib
import json
import math
import struct
import types
import zlib

import numpy as np

__all__ = ["StateError", "dumps", "loads", "MAGIC", "VERSION", "MAX_BYTES", "MAX_DEPTH"]

MAGIC = b"SIDESLIP-FMU-STATE"
VERSION = 1
MAX_BYTES = 64 * 1024 * 1024
"""Largest decompressed payload accepted [bytes]."""
MAX_DEPTH = 64
"""Deepest nesting accepted."""

_HEADER = struct.Struct(">HQ32s")          # version, payload length, SHA-256 of the compressed payload
_DTYPES = {"<f8", "<f4", "<i8", "<i4", "<i2", "<i1", "<u8", "<u4", "<u2", "|u1", "|b1", "|i1"}
_ROOT = __name__.split(".")[0]             # this package's top-level name (renamed inside an FMU)


class StateError(ValueError):
    """A state that cannot be written or read, with the reason."""


# ---------------------------------------------------------------------------------------- references
def _ref_of(obj) -> str:
    module, qualname = getattr(obj, "__module__", None), getattr(obj, "__qualname__", "")
    if not module or not (module == _ROOT or module.startswith(_ROOT + ".")) or "<" in qualname:
        raise StateError(f"{obj!r} is not a module-level definition of this package")
    return f"{module}:{qualname}"


def _resolve(ref, kind: str):
    """The class or function ``module:qualname`` of this package (nothing else)."""
    if not isinstance(ref, str) or ":" not in ref:
        raise StateError(f"{kind} reference {ref!r} is not 'module:name'")
    module, _, qualname = ref.partition(":")
    if not (module == _ROOT or module.startswith(_ROOT + ".")):
        raise StateError(f"{kind} {ref!r} is outside this package")
    try:
        obj = importlib.import_module(module)
        for part in qualname.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as exc:
        raise StateError(f"{kind} {ref!r} does not exist ({exc})") from None
    if kind == "class" and not isinstance(obj, type):
        raise StateError(f"{ref!r} is not a class")
    if kind == "function" and not isinstance(obj, types.FunctionType):
        raise StateError(f"{ref!r} is not a function")
    return obj


def _slots(cls) -> list[str]:
    names = []
    for klass in cls.__mro__:
        for name in getattr(klass, "__slots__", ()):
            if name not in ("__dict__", "__weakref__") and name not in names:
                names.append(name)
    return names


# ---------------------------------------------------------------------------------------- encoding
class _Encoder:
    def __init__(self):
        self.ids: dict[int, int] = {}
        self.keep: list = []                       # keep encoded objects alive: their ids stay unique

    def float(self, x: float):
        return x if math.isfinite(x) else {"f": repr(x)}

    def shared(self, obj, build):
        """Encode a mutable object once; later occurrences become references."""
        key = id(obj)
        if key in self.ids:
            return {"r": self.ids[key]}
        self.ids[key] = n = len(self.ids)
        self.keep.append(obj)
        node = build()
        node["#"] = n
        return node

    def __call__(self, obj, depth: int = 0):
        if depth > MAX_DEPTH:
            raise StateError(f"nesting deeper than {MAX_DEPTH}")
        d = depth + 1
        if obj is None or isinstance(obj, (bool, str)):
            return obj
        if isinstance(obj, enum.Enum):             # IntEnum members index arrays: their value is enough
            return self(obj.value, d)
        if isinstance(obj, int):
            return int(obj)
        if isinstance(obj, float):
            return self.float(float(obj))
        if isinstance(obj, np.generic):
            return {"n": obj.dtype.str, "v": self(obj.item(), d)}
        if isinstance(obj, np.ndarray):
            if obj.dtype.str not in _DTYPES:
                raise StateError(f"array dtype {obj.dtype} is not a state type")
            arr = np.ascontiguousarray(obj)
            return self.shared(obj, lambda: {"a": arr.dtype.str, "s": list(arr.shape),
                                             "b": base64.b64encode(arr.tobytes()).decode("ascii")})
        if isinstance(obj, np.random.Generator):
            state = obj.bit_generator.state
            if state.get("bit_generator") != "PCG64":
                raise StateError(f"random generator {state.get('bit_generator')} is not a state type")
            return self.shared(obj, lambda: {"g": self(state, d)})
        if isinstance(obj, tuple) and hasattr(type(obj), "_fields"):
            return {"nt": _ref_of(type(obj)), "v": [self(x, d) for x in obj]}
        if isinstance(obj, tuple):
            return {"t": [self(x, d) for x in obj]}
        if isinstance(obj, list):
            return self.shared(obj, lambda: {"l": [self(x, d) for x in obj]})
        if isinstance(obj, collections.deque):
            return self.shared(obj, lambda: {"q": [self(x, d) for x in obj], "m": obj.maxlen})
        if isinstance(obj, (set, frozenset)):
            return {"set": [self(x, d) for x in obj], "frozen": isinstance(obj, frozenset)}
        if isinstance(obj, dict):
            if all(isinstance(k, str) for k in obj):
                return self.shared(obj, lambda: {"d": {k: self(v, d) for k, v in obj.items()}})
            return self.shared(obj, lambda: {"dk": [[self(k, d), self(v, d)] for k, v in obj.items()]})
        if isinstance(obj, types.FunctionType):
            if "<locals>" in obj.__qualname__:
                return {"x": 1}                    # a closure: rebuilt with the template
            return {"fn": _ref_of(obj)}
        if isinstance(obj, (types.MethodType, types.BuiltinFunctionType)):
            return {"x": 1}
        if isinstance(obj, functools.partial):
            return {"p": self(obj.func, d), "args": [self(x, d) for x in obj.args],
                    "kw": {k: self(v, d) for k, v in obj.keywords.items()}}
        if isinstance(obj, type):
            return {"c": _ref_of(obj)}
        ref = _ref_of(type(obj))                   # an instance of a class of this package

        def build():
            attrs = {}
            for name in _slots(type(obj)):
                if hasattr(obj, name):
                    attrs[name] = self(getattr(obj, name), d)
            for name, value in getattr(obj, "__dict__", {}).items():
                attrs[name] = self(value, d)
            return {"o": ref, "d": attrs}
        return self.shared(obj, build)


# ---------------------------------------------------------------------------------------- decoding
def _item(container, i: int, kind: type):
    """``container[i]`` of a template container of the same kind, else None."""
    return container[i] if isinstance(container, kind) and i < len(container) else None


class _Decoder:
    def __init__(self):
        self.made: dict[int, object] = {}

    def register(self, node, obj):
        n = node.get("#")
        if n is not None:
            if not isinstance(n, int) or n in self.made:
                raise StateError(f"bad object number {n!r}")
            self.made[n] = obj
        return obj

    def __call__(self, node, depth: int = 0, tmpl=None):
        """Decode ``node``; ``tmpl`` is the template's object at the same place (or None)."""
        if depth > MAX_DEPTH:
            raise StateError(f"nesting deeper than {MAX_DEPTH}")
        d = depth + 1
        if node is None or isinstance(node, (bool, int, str)):
            return node
        if isinstance(node, float):
            return node
        if not isinstance(node, dict) or not node:
            raise StateError(f"unexpected node {type(node).__name__}")
        if "x" in node:
            if not callable(tmpl):
                raise StateError("a function that is not data, and no template to take it from")
            return tmpl
        if "r" in node:
            n = node["r"]
            if not isinstance(n, int) or n not in self.made:
                raise StateError(f"reference {n!r} to an object not defined before")
            return self.made[n]
        if "f" in node:
            text = node["f"]
            if text not in ("nan", "inf", "-inf"):
                raise StateError(f"bad float {text!r}")
            return float(text)
        if "n" in node:
            if node["n"] not in _DTYPES:
                raise StateError(f"scalar dtype {node['n']!r} is not a state type")
            return np.dtype(node["n"]).type(self(node["v"], d))
        if "a" in node:
            dtype, shape = node["a"], node.get("s")
            if dtype not in _DTYPES or not isinstance(shape, list) or not all(
                    isinstance(x, int) and 0 <= x for x in shape):
                raise StateError(f"bad array {dtype!r} {shape!r}")
            try:
                raw = base64.b64decode(node["b"], validate=True)
            except (ValueError, TypeError) as exc:
                raise StateError(f"bad array data ({exc})") from None
            size = np.dtype(dtype).itemsize * math.prod(shape)
            if len(raw) != size:
                raise StateError(f"array data of {len(raw)} bytes for shape {shape} of {dtype}")
            return self.register(node, np.frombuffer(raw, dtype=dtype).reshape(shape).copy())
        if "g" in node:
            state = self(node["g"], d)
            if not isinstance(state, dict) or state.get("bit_generator") != "PCG64":
                raise StateError("random generator state is not PCG64")
            rng = np.random.default_rng()
            try:
                rng.bit_generator.state = state
            except (ValueError, TypeError, KeyError) as exc:
                raise StateError(f"bad random generator state ({exc})") from None
            return self.register(node, rng)
        if "nt" in node:
            cls = _resolve(node["nt"], "class")
            if not (issubclass(cls, tuple) and hasattr(cls, "_fields")):
                raise StateError(f"{node['nt']!r} is not a named tuple")
            values = node.get("v")
            if not isinstance(values, list) or len(values) != len(cls._fields):
                raise StateError(f"{node['nt']!r} needs {len(cls._fields)} values")
            return cls(*(self(x, d) for x in values))
        if "t" in node:
            items = self.list(node["t"])
            return tuple(self(x, d, _item(tmpl, i, tuple)) for i, x in enumerate(items))
        if "l" in node:
            out = self.register(node, [])
            out.extend(self(x, d, _item(tmpl, i, list)) for i, x in enumerate(self.list(node["l"])))
            return out
        if "q" in node:
            m = node.get("m")
            if m is not None and not (isinstance(m, int) and m >= 0):
                raise StateError(f"bad deque length {m!r}")
            out = self.register(node, collections.deque(maxlen=m))
            out.extend(self(x, d) for x in self.list(node["q"]))
            return out
        if "set" in node:
            items = [self(x, d) for x in self.list(node["set"])]
            try:
                return frozenset(items) if node.get("frozen") else set(items)
            except TypeError as exc:
                raise StateError(f"bad set ({exc})") from None
        if "d" in node and "o" not in node:
            if not isinstance(node["d"], dict):
                raise StateError("bad dict")
            out = self.register(node, {})
            out.update((k, self(v, d, tmpl.get(k) if isinstance(tmpl, dict) else None))
                       for k, v in node["d"].items())
            return out
        if "dk" in node:
            out = self.register(node, {})
            for pair in self.list(node["dk"]):
                if not isinstance(pair, list) or len(pair) != 2:
                    raise StateError("bad dict item")
                key = self(pair[0], d)
                try:
                    out[key] = self(pair[1], d)
                except TypeError as exc:
                    raise StateError(f"bad dict key ({exc})") from None
            return out
        if "fn" in node:
            return _resolve(node["fn"], "function")
        if "p" in node:
            func = self(node["p"], d)
            if not isinstance(func, (types.FunctionType, functools.partial)):
                raise StateError("partial of something that is not a function")
            kw = node.get("kw", {})
            if not isinstance(kw, dict):
                raise StateError("bad partial keywords")
            t_args = tmpl.args if isinstance(tmpl, functools.partial) else None
            return functools.partial(func, *(self(x, d, _item(t_args, i, tuple))
                                             for i, x in enumerate(self.list(node.get("args", [])))),
                                     **{k: self(v, d) for k, v in kw.items()})
        if "c" in node:
            return _resolve(node["c"], "class")
        if "o" in node:
            cls = _resolve(node["o"], "class")
            if issubclass(cls, (tuple, enum.Enum, type)) or not isinstance(node.get("d"), dict):
                raise StateError(f"{node['o']!r} cannot be rebuilt from attributes")
            obj = self.register(node, object.__new__(cls))
            slots, has_dict = set(_slots(cls)), cls.__dictoffset__ != 0
            same = type(tmpl) is cls
            for name, value in node["d"].items():
                if not isinstance(name, str) or name.startswith("__") or (name not in slots and not has_dict):
                    raise StateError(f"{node['o']!r} has no attribute {name!r}")
                object.__setattr__(obj, name, self(value, d, getattr(tmpl, name, None) if same else None))
            return obj
        raise StateError(f"unknown node with keys {sorted(node)[:4]}")

    @staticmethod
    def list(value) -> list:
        if not isinstance(value, list):
            raise StateError("expected a list")
        return value


# ---------------------------------------------------------------------------------------- bytes
def dumps(obj) -> bytes:
    """``obj`` as state bytes (see module docstring).

    Raises
    ------
    StateError
        When ``obj`` holds something that is not state (a foreign class, a closure).
    """
    payload = zlib.compress(json.dumps(_Encoder()(obj), separators=(",", ":"), allow_nan=False).encode(), 6)
    return MAGIC + _HEADER.pack(VERSION, len(payload), hashlib.sha256(payload).digest()) + payload


def loads(data: bytes, template=None):
    """The object of state bytes written by :func:`dumps`; what was not data comes from ``template``
    (the same model built anew from the same parameters).

    Raises
    ------
    StateError
        For anything else: wrong magic or version, a length or checksum that does not match,
        a payload that is not the format, or a reference outside this package.
    """
    data = bytes(data)
    head = len(MAGIC) + _HEADER.size
    if len(data) < head or not data.startswith(MAGIC):
        raise StateError("not a sideslip-fmu FMU state (wrong header)")
    version, length, digest = _HEADER.unpack_from(data, len(MAGIC))
    if version != VERSION:
        raise StateError(f"FMU state format version {version}, this FMU reads version {VERSION}")
    payload = data[head:]
    if len(payload) != length:
        raise StateError(f"FMU state of {len(payload)} payload bytes, its header says {length} (truncated?)")
    if hashlib.sha256(payload).digest() != digest:
        raise StateError("FMU state checksum does not match (damaged)")
    try:
        d = zlib.decompressobj()
        text = d.decompress(payload, MAX_BYTES)
        if d.unconsumed_tail or not d.eof:
            raise StateError(f"FMU state payload larger than {MAX_BYTES} bytes or incomplete")
        tree = json.loads(text)
    except (zlib.error, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise StateError(f"FMU state payload is not the format ({exc})") from None
    try:
        return _Decoder()(tree, 0, template)
    except RecursionError:
        raise StateError("FMU state nested too deeply") from None
