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
from sympy.printing.precedence import PRECEDENCE, precedence

import re
from collections import OrderedDict

from ..errors import PrintError


_MUL = PRECEDENCE["Mul"]


def _negative(term) -> bool:
    """Whether a term of a sum prints with a leading minus (a negative number, or a
    product whose numeric coefficient, its first argument, is negative)."""
    if term.is_Number:
        return bool(term.is_extended_negative)
    if term.is_Mul:
        c = term.args[0]
        return c.is_Number and bool(c.is_extended_negative)
    return False


class SlotPrinting:
    """Symbols print as their slot (y[0], p[3]) or local name; integer powers as products;
    sums, products and powers printed straight from the expression's own argument order.

    The mixin every backend's printer takes (C, NumPy, and a backend folder's own, such as
    JAX's): a new target language mixes it into SymPy's printer for that language.

    Why its own sums and products: SymPy's printers put every sum's terms in display order
    first (`as_ordered_terms`, a sort with expensive keys) and weigh every operand's
    precedence on the way; for a large model that was most of the generator's time.  A
    sum's and a product's arguments are already in SymPy's canonical order (the same in
    every process), so the text is as reproducible printed in that order: positive terms
    first, then the negative ones subtracted; a product as its coefficient, its numerator
    factors, then `/` and its denominator.  Whatever else an expression holds (functions,
    Piecewise, ...) goes to SymPy's printer for the language, whose operands come back here.
    """

    # Integer powers up to this one print as products (x*x*x): a multiplication each,
    # where pow() is a library call.
    POWER_PRODUCT_MAX = 3

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

    # -- precedence: a power printed as a product binds like a product ------------------
    def _precedence(self, expr) -> int:
        if expr.is_Pow and expr.exp.is_Integer and (abs(int(expr.exp)) <= self.POWER_PRODUCT_MAX
                                                     or expr.exp < 0):
            return _MUL
        return precedence(expr)

    def parenthesize(self, item, level, strict=False):
        p = self._precedence(item)
        if p < level or (not strict and p <= level):
            return f"({self._print(item)})"
        return self._print(item)

    def _factor(self, expr) -> str:
        """A factor of a product: parenthesized when it binds looser than a product."""
        if expr.is_Symbol or expr.is_Function:
            return self._print(expr)
        if expr.is_Add or self._precedence(expr) < _MUL:
            return f"({self._print(expr)})"
        return self._print(expr)

    def _divisor(self, factors: list) -> str:
        """The text after `/` for a product's denominator factors."""
        if len(factors) == 1:
            f = factors[0]
            if f.is_Symbol or f.is_Function or (self._precedence(f) > _MUL and not f.is_Pow):
                return self._print(f)
            if f.is_Pow and not (f.exp.is_Integer and abs(int(f.exp)) <= self.POWER_PRODUCT_MAX):
                return self._print(f)       # sqrt(x), pow(x, y): a call binds tightest
            return f"({self._print(f)})"
        return "(" + "*".join(self._factor(f) for f in factors) + ")"

    def _coefficient(self, c) -> str:
        """A positive numeric coefficient as the first factor of a product."""
        if c.is_Integer or c.is_Float:
            return self._print(c)
        return f"({self._print(c)})"                # a fraction: 1.0/3.0, 1/3

    def _product_text(self, coeff, factors: list, negate: bool = False) -> str:
        """coeff*factors as text: the sign, the coefficient, the numerator, then `/` and the
        denominator (the factors with a negative rational exponent)."""
        if negate:
            coeff = -coeff
        sign = ""
        if coeff.is_extended_negative:
            sign, coeff = "-", -coeff
        num, den = [], []
        for f in factors:
            if f.is_Pow and f.exp.is_Rational and f.exp.is_extended_negative:
                den.append(f.base if f.exp == -1 else sp.Pow(f.base, -f.exp, evaluate=False))
            else:
                num.append(f)
        parts = [] if coeff == 1 else [self._coefficient(coeff)]
        parts += [self._factor(f) for f in num]
        text = "*".join(parts) or self._print(sp.S.One)
        if den:
            text += "/" + self._divisor(den)
        return sign + text

    @staticmethod
    def _split_coefficient(expr):
        args = expr.args
        if args[0].is_Number:
            return args[0], list(args[1:])
        return sp.S.One, list(args)

    def _print_Mul(self, expr):
        return self._product_text(*self._split_coefficient(expr))

    def _unsigned(self, term) -> str:
        """A negative term of a sum without its minus sign."""
        if term.is_Number:
            return self._print(-term)
        return self._product_text(*self._split_coefficient(term), negate=True)

    def _sum_text(self, terms: list) -> str:
        pos = [t for t in terms if not _negative(t)]
        text = " + ".join(self._print(t) for t in pos)
        for t in terms:
            if _negative(t):
                body = self._unsigned(t)
                text = f"{text} - {body}" if text else f"-{body}"
        return text

    def _print_Add(self, expr, order=None):
        return self._sum_text(list(expr.args))

    def _small_power(self, expr):
        """x**n for a small integer n as a product (x**-n as 1.0/(product)), x**(1/2) as
        the language's square root; None for any other power."""
        b, e = expr.base, expr.exp
        if e.is_Integer and 1 <= abs(int(e)) <= self.POWER_PRODUCT_MAX:
            base = self._factor(b) if not (b.is_Pow or b.is_Mul or (b.is_Number and b.is_extended_negative)) \
                else f"({self._print(b)})"
            prod = self._product(base, abs(int(e)))
            if e > 0:
                return prod
            one = self._print(sp.Float(1))
            return f"{one}/({prod})" if abs(int(e)) > 1 else f"{one}/{base}"
        return None

    def doprint_checked(self, expr) -> str:
        """`expr` in the printer's language, or a PrintError naming what has no translation."""
        self._not_supported = set()
        self._number_symbols = set()
        try:
            text = self._print(sp.sympify(expr))
            if self._number_symbols:          # constants SymPy's doprint declares first
                text = self.doprint(expr)
        except PrintMethodNotImplementedError as exc:
            raise PrintError(f"no {self.LANGUAGE_NAME} translation for {type(expr).__name__} in: {expr} ({exc})") \
                from None
        if self._not_supported:
            bad = sorted(str(e) for e in self._not_supported)
            self._not_supported.clear()
            raise PrintError(f"no {self.LANGUAGE_NAME} translation for: {bad[0]}")
        return text


class CPrinter(SlotPrinting, C99CodePrinter):
    """C99 for one floating type: `float` (sinf, 1.0F), `double`, `long double` (sinl, 1.0L)."""

    TYPES = {"float": float32, "double": float64, "long double": float80}

    def __init__(self, slots: dict, ctype: str = "double"):
        super().__init__({"type_aliases": {real: self.TYPES[ctype]}})
        self._settings_slots = slots
        self.ctype = ctype

    def _float_suffix(self) -> str:
        return {"float": "F", "double": "", "long double": "L"}[self.ctype]

    LANGUAGE_NAME = "C"
    POWER_PRODUCT_MAX = 4

    def _print_Pow(self, expr):
        small = self._small_power(expr)
        return small if small is not None else super()._print_Pow(expr)

    def _print_Pi(self, expr):
        # M_PI is not C99; print the constant to the type's precision.
        return f"3.14159265358979323846264338327950288{self._float_suffix()}"


# What CVariantPrinter writes where the floating type shows, before a variant names it.
_FUNC_SUFFIX = "\x01"         # a math function's suffix: sin -> sinf, sinl
_LITERAL_SUFFIX = "\x02"      # a literal's suffix: 1.0 -> 1.0F, 1.0L
_MACRO_SUFFIX = "\x04"        # a math macro's suffix (C99CodePrinter's math_macros)
_FLOAT_MARK = re.compile("\x03([0-9]+)\x03")   # a Float, by its index in the printer's table
_ANY_MARK = re.compile("[\x01-\x04]")


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
        marked = self.marked(expr)
        if not _ANY_MARK.search(marked):         # no function, literal or Float: every type's text
            return marked
        pr = self._variants[ctype]
        real_type = pr.type_aliases.get(real, real)
        marked = _FLOAT_MARK.sub(lambda m: pr._print_Float(self._floats[int(m.group(1))]), marked)
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

    LANGUAGE_NAME = "NumPy"

    def __init__(self, slots: dict, varying: set | None = None):
        super().__init__({"fully_qualified_modules": True})
        self._settings_slots = slots
        self._varying = varying or set()
        self._varies_memo: dict = {}

    def _varies(self, expr) -> bool:
        """Whether expr depends on a varying symbol (memoised: subtrees are shared)."""
        if expr in self._varying:
            return True
        if not expr.args:
            return False
        known = self._varies_memo.get(expr)
        if known is None:
            known = self._varies_memo[expr] = any(self._varies(a) for a in expr.args)
        return known

    def _print_Mul(self, expr):
        coeff, factors = self._split_coefficient(expr)
        if not self._varying or not self._varies(expr):
            return self._product_text(coeff, factors)
        const = [f for f in factors if not self._varies(f)]
        var = [f for f in factors if self._varies(f)]
        if not const and coeff in (sp.S.One, sp.S.NegativeOne):
            return self._product_text(coeff, var)
        if not const:                    # a number times arrays: the number first, as it is
            return self._product_text(coeff, var)
        c = self._product_text(coeff, const)
        text = c if (len(const) == 1 and coeff == 1 and const[0].is_Atom) else f"({c})"
        return f"{text}*{self._product_text(sp.S.One, var)}"

    def _print_Add(self, expr, order=None):
        if not self._varying or not self._varies(expr):
            return self._sum_text(list(expr.args))
        terms = list(expr.args)
        const = [t for t in terms if not self._varies(t)]
        parts = []
        if const:
            c = self._sum_text(const)
            parts.append(c if len(const) == 1 and const[0].is_Atom else f"({c})")
        parts += [self._print(t) for t in terms if self._varies(t) and not _negative(t)]
        text = " + ".join(parts)
        for t in terms:
            if self._varies(t) and _negative(t):
                body = self._unsigned(t)
                text = f"{text} - {body}" if text else f"-{body}"
        return text

    def _print_Pow(self, expr, rational=False):
        small = self._small_power(expr)
        if small is not None:
            return small
        if expr.exp == sp.S.Half:
            return f"numpy.sqrt({self._print(expr.base)})"
        return super()._print_Pow(expr, rational=rational)
