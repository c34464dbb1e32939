"""Cache entries as data: JSON with a checksum, SymPy objects as srepr text read back by a
grammar of SymPy constructors, written atomically.  Loading one can never run code (no
pickle): a damaged, truncated or foreign entry fails its checksum or the grammar, and the
caller recomputes it.

    store(path, value)        value: None, bool, int, float, str, lists, tuples, dicts with
                              string keys, SymPy expressions and matrices, registered
                              dataclasses, and models (kept as their description's text)
    load(path) -> value | MISSING
"""
from __future__ import annotations

import ast
import dataclasses
import hashlib
import json
import os
import sys
from pathlib import Path
from typing import Callable

import sympy as sp

from .paths import replace_file

MISSING = object()               # load(): no usable entry (absent, damaged, foreign)
FORMAT = "derive-cache-1"

# the SymPy constructors an entry may name (srepr of derivations, verdicts, checks)
_SYMPY = {name: getattr(sp, name) for name in (
    "Symbol", "Integer", "Rational", "Float", "Add", "Mul", "Pow", "sin", "cos", "tan", "asin",
    "acos", "atan", "atan2", "sinh", "cosh", "tanh", "exp", "log", "Abs", "sign", "sqrt",
    "MutableDenseMatrix", "ImmutableDenseMatrix", "Tuple", "Eq", "Piecewise",
    "StrictGreaterThan", "StrictLessThan", "GreaterThan", "LessThan", "true", "false")}
_SYMPY_NAMES = {"pi": sp.pi, "E": sp.E, "oo": sp.oo, "zoo": sp.zoo, "nan": sp.nan, "I": sp.I,
                "true": sp.true, "false": sp.false}
_DATACLASSES: dict[str, type] = {}
# tag -> (class, encode, decode): values a stage above stores in its own form (the model
# stage registers its Model), so this bottom-layer module knows no stage's classes.
_CODECS: dict[str, tuple[type, Callable, Callable]] = {}


def register(cls: type) -> type:
    """Let entries hold instances of this dataclass (by its qualified name)."""
    _DATACLASSES[f"{cls.__module__}.{cls.__qualname__}"] = cls
    return cls


def register_codec(tag: str, cls: type, encode: Callable, decode: Callable) -> None:
    """Store instances of `cls` as {tag: encode(value), ...}: `encode` returns the entry's
    fields (the tag's own value under `tag`), `decode` takes them back to an instance."""
    _CODECS[tag] = (cls, encode, decode)


# -- writing --------------------------------------------------------------------------

_COMPOUND = (sp.Add, sp.Mul, sp.Pow)


def _srepr(value, memo: dict) -> str:
    """sp.srepr(value) up to the order of a sum's terms and a product's factors: the
    arguments in the expression's own order, where srepr sorts them for display (most of
    the time of storing a large derivation).  Read back, the constructors put them in the
    canonical order again, so the entry loads as the same expression."""
    if not isinstance(value, sp.Basic):         # a matrix: its rows as lists
        if 0 in value.shape:
            return sp.srepr(value)
        rows = ", ".join("[" + ", ".join(_srepr(e, memo) for e in value.row(i)) + "]" for i in range(value.rows))
        return f"{type(value).__name__}([{rows}])"
    known = memo.get(value)
    if known is not None:
        return known
    if isinstance(value, _COMPOUND) or (value.args and not value.is_Atom and _SYMPY.get(type(value).__name__) is type(value)):
        text = f"{type(value).__name__}({', '.join(_srepr(a, memo) for a in value.args)})"
    else:
        text = sp.srepr(value)
    memo[value] = text
    return text


def _encode(value):
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    for cls, encode, _ in _CODECS.values():
        if isinstance(value, cls):
            return encode(value)
    if isinstance(value, (sp.Basic, sp.MatrixBase)):
        return {"__sympy__": _srepr(value, {})}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        name = f"{type(value).__module__}.{type(value).__qualname__}"
        if name not in _DATACLASSES:
            raise TypeError(f"cachefile: {name} is not registered")
        return {"__dataclass__": name,
                "fields": {f.name: _encode(getattr(value, f.name)) for f in dataclasses.fields(value)}}
    if isinstance(value, tuple):
        return {"__tuple__": [_encode(v) for v in value]}
    if isinstance(value, list):
        return [_encode(v) for v in value]
    if isinstance(value, dict):
        if all(isinstance(k, str) for k in value):
            return {"__dict__": {k: _encode(v) for k, v in value.items()}}
        return {"__pairs__": [[_encode(k), _encode(v)] for k, v in value.items()]}
    raise TypeError(f"cachefile: cannot store {type(value).__name__}")


def store(path: Path, value) -> None:
    """Write `value` to `path` atomically (a temporary file in the same folder, renamed)."""
    payload = json.dumps(_encode(value), sort_keys=True, separators=(",", ":"))
    text = json.dumps({"format": FORMAT, "sha256": hashlib.sha256(payload.encode()).hexdigest(),
                       "payload": payload})
    replace_file(path, lambda tmp: tmp.write_text(text))


# -- reading --------------------------------------------------------------------------

class _Refused(ValueError):
    pass


def _sympy(text: str):
    """srepr text as SymPy, through the grammar: constructor calls, numbers, strings, lists."""
    def build(node):
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float, str, bool)):
            return node.value
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            return -build(node.operand)
        if isinstance(node, (ast.List, ast.Tuple)):
            return [build(e) for e in node.elts]
        if isinstance(node, ast.Name) and node.id in _SYMPY_NAMES:
            return _SYMPY_NAMES[node.id]
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _SYMPY:
            args = [build(a) for a in node.args]
            kwargs = {k.arg: build(k.value) for k in node.keywords}
            if not all(isinstance(v, (bool, int, str)) for v in kwargs.values()):
                raise _Refused("a keyword that is no constant")
            return _SYMPY[node.func.id](*args, **kwargs)
        raise _Refused(f"{type(node).__name__} is not in the cache grammar")
    return build(ast.parse(text, mode="eval").body)


def _decode(value):
    if isinstance(value, list):
        return [_decode(v) for v in value]
    if not isinstance(value, dict):
        return value
    if "__sympy__" in value:
        return _sympy(value["__sympy__"])
    for tag, (_, _, decode) in _CODECS.items():
        if tag in value:
            return decode(value)
    if "__tuple__" in value:
        return tuple(_decode(v) for v in value["__tuple__"])
    if "__dict__" in value:
        return {k: _decode(v) for k, v in value["__dict__"].items()}
    if "__pairs__" in value:
        return {_decode(k): _decode(v) for k, v in value["__pairs__"]}
    if "__dataclass__" in value:
        cls = _DATACLASSES.get(value["__dataclass__"])
        if cls is None:
            raise _Refused(f"unknown class {value['__dataclass__']}")
        return cls(**{k: _decode(v) for k, v in value["fields"].items()})
    raise _Refused("an untagged table")


def load(path: Path):
    """The value stored at `path`, or MISSING when there is none or it does not check out
    (damaged, of another version, or a file of another user: then with a one-line note,
    and the caller computes it again)."""
    path = Path(path)
    try:
        st = path.stat()
    except FileNotFoundError:
        return MISSING
    except (OSError, ValueError):
        st = None
    why = "is damaged"
    try:
        if st is not None and hasattr(os, "getuid") and st.st_uid != os.getuid():
            why = "belongs to another user"
            raise _Refused(why)
        outer = json.loads(path.read_text())
        if outer.get("format") != FORMAT:
            why = "is of another format"
            raise _Refused(why)
        payload = outer["payload"]
        if hashlib.sha256(payload.encode()).hexdigest() != outer["sha256"]:
            why = "does not match its checksum"
            raise _Refused(why)
        return _decode(json.loads(payload))
    except (OSError, ValueError, KeyError, TypeError, SyntaxError, RecursionError, AttributeError,
            sp.SympifyError):
        print(f"derive: note: the cache entry {path} {why}; computing it again", file=sys.stderr)
        return MISSING
