"""Printers: SymPy's own printers, subclassed to map each symbol to its array slot.

A language is one printer here plus one folder under templates/.  The printer
turns a SymPy expression into a string; nothing else is language-specific in
the pipeline except the naming done by the language's context builder
(languages.py).
"""
from __future__ import annotations

import sympy as sp
from sympy.codegen.ast import float32, float64, float80, real
from sympy.printing.c import C99CodePrinter
from sympy.printing.codeprinter import PrintMethodNotImplementedError
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.precedence import precedence


class PrintError(ValueError):
    pass


class _SlotMixin:
    """Symbols print as their slot (y[0], p[3]) or local name; integer powers as products."""

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


class CPrinter(_SlotMixin, C99CodePrinter):
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


class PyNumPyPrinter(_SlotMixin, NumPyPrinter):
    """NumPy with the module imported as `numpy`; x**-1 as 1/x, x**2 as x*x."""

    def __init__(self, slots: dict):
        super().__init__({"fully_qualified_modules": True})
        self._settings_slots = slots

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
