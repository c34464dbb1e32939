"""Specialised models: a model's derivation with parameter values folded in as numbers.

A run whose parameters are fixed (a scene's, `simulate(..., specialise=True)`) can use
kernels in which the values are constants of the code instead of loads of p: SymPy folds
them where they meet (l1 l2 m2 becomes one number, a unit mass or length disappears from
its products, g = 0 removes gravity's terms), then the normal pipeline runs on the result
(CSE again, the printers, the integrators, the Taylor jet, the compiler), so the compiler
sees the numbers as well.

`specialise(name, values)` makes such a model: its description is the model's, under the
name ``<name>_s<digest>`` (the digest of the model's content and the exact values), with
the same parameters in the same order (a run passes p as before; the kernels no longer
read the folded ones), and its derivation is the model's with each folded parameter
replaced by its exact value.  It is registered (derive/model/description.py) and its
derivation put in the derivation cache, so that everything downstream, which knows a
model by its name, renders, compiles and caches it as any model: one set of files and
libraries per model and value set, in the cache only (never in generated/).

Exactness: a value is taken as the binary number it is (a float as given, a long double
with all its bits): 0 and +-1 as SymPy Integers (so that 1 * x is x), any other value as
a Float of FOLD_BITS bits holding it exactly.  SymPy folds products and sums of them
at that precision (exact for the few factors a derivation multiplies), and each folded
constant is printed rounded to the generated type's precision (the C printer's digits),
so a specialised kernel computes the general kernel's function with constants rounded
once instead of after each operation: the two agree to rounding.
"""
from __future__ import annotations

import dataclasses
import hashlib
from numbers import Integral
import tomllib
from collections.abc import Mapping
from functools import cache
from pathlib import Path

import sympy as sp

from .. import cachefile
from ..derivation import derive
from ..derivation.derivation import Derivation, cache_path
from ..errors import SpecError
from ..model import load_model
from ..model.atlas import description_text
from ..model.description import MAX_NAME, Model, parse_model, register_derived_model

FOLD_BITS = 256          # a folded value's precision: exact for any double or long double
DIGEST_LENGTH = 12       # hex digits of the value set in a specialised model's name
SUFFIX = "_s"            # <model>_s<digest>
# the derivation's fields that are no expressions of the parameters
_KEPT = ("model", "symbols", "seconds")


def exact_value(value) -> tuple[int, int]:
    """A parameter value as the exact fraction it holds (numerator, denominator in lowest
    terms): a Python or NumPy float (any width) or an integer."""
    if isinstance(value, bool):
        raise SpecError(f"a parameter value must be a number, got {value!r}")
    if isinstance(value, Integral):            # int, NumPy's integers
        return int(value), 1
    try:
        n, d = value.as_integer_ratio()
    except (AttributeError, OverflowError, ValueError):
        raise SpecError(f"a parameter value must be a finite number, got {value!r}") from None
    return int(n), int(d)


def folded_number(ratio: tuple[int, int]) -> sp.Number:
    """The SymPy number a value is folded in as: 0, 1 and -1 as Integers (the terms they
    remove and the factors they drop are most of what folding gains), any other value as a
    Float of FOLD_BITS bits holding it exactly, so that a folded expression keeps the
    general one's shape (a frequency w = 2 folded as the Integer 2 would turn sin(w t)
    into 2 sin t cos t: spec._multiple_angles)."""
    n, d = ratio
    if d == 1 and abs(n) <= 1:
        return sp.Integer(n)
    return sp.Float(sp.Rational(n, d), precision=FOLD_BITS)


@cache
def _code_hash() -> str:
    """This module's text: how values are folded is part of what a specialised model is
    (its derivation is cached under its name's digest)."""
    return hashlib.sha256(Path(__file__).read_bytes()).hexdigest()


def specialised_name(model: Model, exact: Mapping[str, tuple[int, int]]) -> str:
    """`<name>_s<digest>`: the digest of the model's content, the exact values and the
    folding code (so an edit of the model or of this module, or another value set, is
    another model)."""
    h = hashlib.sha256(f"{model.content_hash}\0{_code_hash()}".encode())
    for name in model.parameters:
        if name in exact:
            n, d = exact[name]
            h.update(f"\0{name}={n}/{d}".encode())
    return f"{model.name[:MAX_NAME]}{SUFFIX}{h.hexdigest()[:DIGEST_LENGTH]}"


def specialise(name: str, values: Mapping[str, object]) -> str:
    """The name of model `name` with `values` folded in, made (registered, its derivation
    cached) on first use.

    Parameters
    ----------
    name : str
        A model's name (a catalogue model or a model file read before; not an atlas).
    values : mapping
        Parameter name -> value (float, NumPy float or int), for some or all of the
        model's parameters; the others stay run-time parameters (read from p).

    Returns
    -------
    str
        The specialised model's name, which every stage downstream takes as a model's.

    Raises
    ------
    SpecError
        A name that is not a parameter of the model, a value that is not a finite number,
        or values that leave an expression of the derivation undefined (a division by a
        parameter folded in as zero).
    """
    model = load_model(name)
    unknown = sorted(set(values) - set(model.parameters))
    if unknown:
        raise SpecError(f"model '{name}' has no parameter '{unknown[0]}' to specialise "
                        f"(parameters: {', '.join(model.parameters)})")
    if not values:
        return name
    exact = {k: exact_value(v) for k, v in values.items()}
    description = specialised_description(model, exact)
    path = cache_path(description)
    # derive() reads the specialised derivation from its cache entry (it could not derive
    # it from the description, which is the model's): an entry that is absent, damaged or
    # not the folded one is written now, before anything derives the name
    if not _is_folded(cachefile.load(path), description, exact):
        cachefile.store(path, folded_derivation(derive(name), description, exact))
    register_derived_model(description)
    return description.name


def _is_folded(entry, description: Model, exact: Mapping[str, tuple[int, int]]) -> bool:
    """Whether a derivation cache entry is the specialised model's: its text, and none of
    the folded parameters left in its equations."""
    if not isinstance(entry, Derivation) or entry.model.text != description.text:
        return False
    folded = {s for s in entry.symbols.params if s.name in exact}
    return not ((entry.M.free_symbols | entry.F.free_symbols) & folded)


def specialised_description(model: Model, exact: Mapping[str, tuple[int, int]]) -> Model:
    """The description of the specialised model: the model's, renamed, its title saying
    which values it folds in (its text is TOML: hashed and cached as any model's)."""
    table = tomllib.loads(model.text)
    table["name"] = specialised_name(model, exact)
    folded = ", ".join(f"{k} = {_shown(exact[k])}" for k in model.parameters if k in exact)
    table["title"] = f"{table.get('title') or model.name}; specialised: {folded} folded in"
    return parse_model(description_text(table), f"{model.origin or model.name} (specialised '{table['name']}')")


def _shown(ratio: tuple[int, int]) -> str:
    n, d = ratio
    return str(n) if d == 1 else repr(n / d)


def folded_derivation(d: Derivation, description: Model, exact: Mapping[str, tuple[int, int]]) -> Derivation:
    """The derivation `d` with the parameters in `exact` replaced by their values, as the
    derivation of the specialised model `description` (its symbols keep every parameter:
    the kernels' argument p is unchanged).

    Raises
    ------
    SpecError
        Where the values leave an expression undefined (NaN or an infinity).
    """
    subs = {s: folded_number(exact[s.name]) for s in d.symbols.params if s.name in exact}
    fields = {f.name: _substituted(getattr(d, f.name), subs) for f in dataclasses.fields(d)
              if f.name not in _KEPT}
    for field, value in fields.items():
        if _undefined(value):
            raise SpecError(f"model '{d.model.name}': the values folded in leave its {field} undefined "
                            f"(a division by a parameter that is zero); run it with p at run time")
    return Derivation(model=description, symbols=d.symbols, seconds=0.0, **fields)


def _substituted(value, subs: dict):
    """`value` (expressions, matrices, lists, tuples and dataclasses of them) with `subs`."""
    if isinstance(value, (sp.Basic, sp.MatrixBase)):
        return value.xreplace(subs)
    if isinstance(value, list):
        return [_substituted(v, subs) for v in value]
    if isinstance(value, tuple):
        return tuple(_substituted(v, subs) for v in value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.replace(value, **{f.name: _substituted(getattr(value, f.name), subs)
                                             for f in dataclasses.fields(value) if f.init})
    return value


def _undefined(value) -> bool:
    if isinstance(value, (sp.Basic, sp.MatrixBase)):
        return any(value.has(bad) for bad in (sp.nan, sp.zoo, sp.oo, -sp.oo))
    if isinstance(value, (list, tuple)):
        return any(_undefined(v) for v in value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return any(_undefined(getattr(value, f.name)) for f in dataclasses.fields(value))
    return False
