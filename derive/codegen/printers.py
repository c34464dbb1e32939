"""Printers: SymPy's own printers, subclassed to map each symbol to its array slot.

A language is one printer here plus one folder under templates/.  The printer
turns a SymPy expression into a string; nothing else is language-specific in
the pipeline except the naming done by the language's context builder
(derive/codegen/backends/<language>/).
"""
from __future__ import annotations

import sympy as sp
from sympy.codegen.ast import float32, float64, float80, real
from sympy.printing.c import C99CodePrinter
from sympy.printing.codeprinter import PrintMethodNotImplementedError
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.precedence import precedence

import re
from collections import OrderedDict

from ..errors import PrintError


class SlotPrinting:
    """Symbols print as their slot (y[0], p[3]) or local name; integer powers as products.

    The mixin every backend's printer takes (C, NumPy, and a backend folder's own, such as
    JAX's): a new target language mixes it into SymPy's printer for that language."""

    def _slot(self, expr):
        slots = self._settings_slots
        if expr in slots:
            return slots[expr]
        return None

    def _print_Symbol(self, expr):
        slot = self._slot(expr)
        if slot is not None:
            return slot
        return expr.name

    def _product(self, base: str, n: int) -> str:
        return "*".join([base] * n)


class CPrinter(SlotPrinting, C99CodePrinter):
    """C99 for one floating type: `float` (sinf, 1.0F), `double`, `long double` (sinl, 1.0L)."""

    TYPES = {"float": float32, "double": float64, "long double": float80}

    def __init__(self, slots: dict, ctype: str = "double"):
        super().__init__({"type_aliases": {real: self.TYPES[ctype]}})
        self._settings_slots = slots
        self.ctype = ctype

    def _float_suffix(self) -> str:
        return {"float": "F", "double": "", "long double": "L"}[self.ctype]

    def _print_Pow(self, expr):
        b, e = expr.base, expr.exp
        if e.is_Integer and 2 <= abs(int(e)) <= 4:
            base = self.parenthesize(b, precedence(sp.Mul(2, 2, evaluate=False)))
            prod = self._product(base, abs(int(e)))
            if e > 0:
                return prod
            return f"{self._print(sp.Float(1))}/({prod})"
        return super()._print_Pow(expr)

    def _print_Pi(self, expr):
        # M_PI is not C99; print the constant to the type's precision.
        return f"3.14159265358979323846264338327950288{self._float_suffix()}"

    def doprint_checked(self, expr) -> str:
        try:
            text = self.doprint(expr)
        except PrintMethodNotImplementedError as exc:
            raise PrintError(f"no C translation for {type(expr).__name__} in: {expr} ({exc})") from None
        if self._not_supported:
            bad = sorted(str(e) for e in self._not_supported)
            self._not_supported.clear()
            raise PrintError(f"no C translation for: {bad[0]}")
        return text


# What CVariantPrinter writes where the floating type shows, before a variant names it.
_FUNC_SUFFIX = "\x01"         # a math function's suffix: sin -> sinf, sinl
_LITERAL_SUFFIX = "\x02"      # a literal's suffix: 1.0 -> 1.0F, 1.0L
_MACRO_SUFFIX = "\x04"        # a math macro's suffix (C99CodePrinter's math_macros)
_FLOAT_MARK = re.compile("\x03([0-9]+)\x03")   # a Float, by its index in the printer's table


class CVariantPrinter(CPrinter):
    """C for every floating type at once: each expression is printed once, with the places
    where the types differ (a math function's suffix, a literal's suffix, a Float's digits)
    left as marks, and `text(expr, ctype)` fills them in for one type.

    The float, double and long double variants of a kernel are the same expression tree
    printed three times, and printing is the generator's largest cost for a large model:
    this prints it once.  The text of a variant is byte for byte what CPrinter(slots,
    ctype) prints (a test compares them), as those three places are the only ones where
    SymPy's C99 printer consults the type."""

    memoised = True         # shared_printer keeps it as it is

    def __init__(self, slots: dict):
        super().__init__(slots, "double")
        self._floats: list = []
        self._float_index: dict = {}
        self._memo: dict = {}
        self._variants = {ctype: CPrinter(slots, ctype) for ctype in self.TYPES}

    def _get_func_suffix(self, type_):
        return _FUNC_SUFFIX

    def _get_literal_suffix(self, type_):
        return _LITERAL_SUFFIX

    def _get_math_macro_suffix(self, type_):
        return _MACRO_SUFFIX

    def _float_suffix(self) -> str:
        return _LITERAL_SUFFIX

    def _print_Float(self, flt):
        if flt not in self._float_index:
            self._float_index[flt] = len(self._floats)
            self._floats.append(flt)
        return f"\x03{self._float_index[flt]}\x03"

    def marked(self, expr) -> str:
        """The text of `expr` with its type marks (printed once per expression)."""
        if expr not in self._memo:
            self._memo[expr] = self.doprint_checked(expr)
        return self._memo[expr]

    def text(self, expr, ctype: str) -> str:
        """`expr` in C for the floating type `ctype` (float, double or long double)."""
        pr = self._variants[ctype]
        real_type = pr.type_aliases.get(real, real)
        marked = _FLOAT_MARK.sub(lambda m: pr._print_Float(self._floats[int(m.group(1))]), self.marked(expr))
        return (marked.replace(_FUNC_SUFFIX, pr._get_func_suffix(real))
                .replace(_LITERAL_SUFFIX, pr._get_literal_suffix(real))
                .replace(_MACRO_SUFFIX, pr._get_math_macro_suffix(real_type)))

    def typed(self, ctype: str) -> "TypedPrinter":
        """A printer for one floating type that shares this one's printed texts."""
        return TypedPrinter(self, ctype)


class TypedPrinter:
    """CVariantPrinter for one floating type: what a CPrinter(slots, ctype) is to its callers
    (doprint_checked), each expression printed once for all the types."""

    def __init__(self, shared: CVariantPrinter, ctype: str):
        self.shared, self.ctype = shared, ctype

    def doprint_checked(self, expr) -> str:
        return self.shared.text(expr, self.ctype)


_SHARED: "OrderedDict[tuple, object]" = OrderedDict()
_SHARED_MAX = 64        # printers kept (a few per model: its kernels' argument layouts)


def shared_printer(cls: type, slots: dict, *args):
    """The printer `cls(slots, *args)`, one per distinct (cls, slots, args) of this process,
    memoising what it prints: a model's files print the same expressions with the same
    slots more than once (<model>_linearize's A is the kernel file's jacobian, line for
    line), and each is printed once.  Its output is exactly a fresh printer's."""
    key = (cls, frozenset(slots.items()), *(frozenset(a) if isinstance(a, (set, frozenset)) else a for a in args))
    if key in _SHARED:
        _SHARED.move_to_end(key)
        return _SHARED[key]
    printer = cls(slots, *args)
    printer = _SHARED[key] = printer if getattr(printer, "memoised", False) else _Memo(printer)
    if len(_SHARED) > _SHARED_MAX:
        _SHARED.popitem(last=False)
    return printer


class _Memo:
    """A printer whose doprint_checked remembers each expression's text (and passes every
    other attribute through)."""

    def __init__(self, printer):
        self.printer, self.texts = printer, {}

    def doprint_checked(self, expr) -> str:
        if expr not in self.texts:
            self.texts[expr] = self.printer.doprint_checked(expr)
        return self.texts[expr]

    def __getattr__(self, name):
        return getattr(self.printer, name)


class PyNumPyPrinter(SlotPrinting, NumPyPrinter):
    """NumPy with the module imported as `numpy`; x**-1 as 1/x, x**2 as x*x.

    `varying` are the symbols that hold one value per state (arrays over a
    batch); everything else is constant over a batch.  Products and sums put
    their constant part first, in parentheses, so Python's left-to-right
    evaluation does the constant arithmetic once on scalars; sums write their
    positive terms first so no array is negated just to be added.
    """

    def __init__(self, slots: dict, varying: set | None = None):
        super().__init__({"fully_qualified_modules": True})
        self._settings_slots = slots
        self._varying = varying or set()

    def _varies(self, expr) -> bool:
        return bool(expr.free_symbols & self._varying)

    def _print_Mul(self, expr):
        if not self._varying or not self._varies(expr):
            return super()._print_Mul(expr)
        const = [f for f in expr.args if not self._varies(f)]
        var = [f for f in expr.args if self._varies(f)]
        if not const or (len(const) == 1 and const[0] in (sp.S.NegativeOne, sp.S.One)):
            return super()._print_Mul(expr)
        c = sp.Mul(*const)
        text = self._print(c) if c.is_Atom and not c.could_extract_minus_sign() else f"({self._print(c)})"
        v = sp.Mul(*var)
        return f"{text}*{self.parenthesize(v, precedence(expr))}"

    def _print_Add(self, expr, order=None):
        if not self._varying or not self._varies(expr):
            return super()._print_Add(expr, order=order)
        terms = self._as_ordered_terms(expr, order=order)
        const = [t for t in terms if not self._varies(t)]
        pos = [t for t in terms if self._varies(t) and not t.could_extract_minus_sign()]
        neg = [t for t in terms if self._varies(t) and t.could_extract_minus_sign()]
        parts = []
        if const:
            c = sp.Add(*const)
            parts.append(self._print(c) if c.is_Atom else f"({self._print(c)})")
        for t in pos:
            parts.append(self.parenthesize(t, precedence(expr)))
        text = " + ".join(parts)
        for t in neg:
            body = self.parenthesize(-t, precedence(expr) + 1 if (-t).is_Add else precedence(expr))
            text = f"{text} - {body}" if text else f"-{body}"
        return text

    def _print_Pow(self, expr, rational=False):
        b, e = expr.base, expr.exp
        if e.is_Integer and 1 <= abs(int(e)) <= 3:
            base = self.parenthesize(b, precedence(sp.Mul(2, 2, evaluate=False)))
            prod = self._product(base, abs(int(e)))
            return prod if e > 0 else f"1.0/({prod})" if abs(int(e)) > 1 else f"1.0/{base}"
        if e == sp.S.Half:
            return f"numpy.sqrt({self._print(b)})"
        return super()._print_Pow(expr, rational=rational)

    def doprint_checked(self, expr) -> str:
        try:
            text = self.doprint(expr)
        except PrintMethodNotImplementedError as exc:
            raise PrintError(f"no NumPy translation for {type(expr).__name__} in: {expr} ({exc})") from None
        if self._not_supported:
            bad = sorted(str(e) for e in self._not_supported)
            self._not_supported.clear()
            raise PrintError(f"no NumPy translation for: {bad[0]}")
        return text
