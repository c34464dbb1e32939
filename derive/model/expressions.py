"""Expressions in model and chart files, parsed as data: never evaluated as Python.

The grammar: numbers (integers and decimals, read exactly as rationals), declared
names, + - * / ** (^ is refused: it is XOR in Python and would mislead), unary
minus, parentheses, and calls of a fixed list of functions.  Python's own parser
reads the text into a syntax tree (parsing runs no code); this module walks the
tree and builds SymPy objects, refusing every other node (attributes, subscripts,
lambdas, comprehensions, strings, keywords, ...).  A refusal is a ModelError naming
the file, the key and what was refused.

A number's size is bounded while the tree is read, before SymPy evaluates anything:
every constant (a literal, or a part of the expression without names) is computed in
floating point alongside, and refused when it is not a finite real number of magnitude
within 10**±MAX_DIGITS (so `10**10**10`, `2**100000000` or `1e9999999` are refused at
once instead of computed); a power of an expression with names has an exponent of at
most MAX_EXPONENT; a division by zero that is certain (`1/0`, `1/(l1 - l1)`) and a
constant that is not real (`sqrt(-1)`) are refused.  The text is ASCII: Python's parser
would silently fold look-alike letters (a full-width l) into ASCII names.
"""
from __future__ import annotations

import ast
import decimal
import keyword
import math
import re
from collections.abc import Mapping

import sympy as sp

from ..errors import ModelError

FUNCTIONS = {"sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "asin": sp.asin, "acos": sp.acos,
             "atan": sp.atan, "atan2": sp.atan2, "sinh": sp.sinh, "cosh": sp.cosh, "tanh": sp.tanh,
             "exp": sp.exp, "log": sp.log, "sqrt": sp.sqrt, "abs": sp.Abs, "sign": sp.sign}
CONSTANTS = {"pi": sp.pi}
MAX_LENGTH = 10_000          # characters: a model's expressions are short
MAX_DEPTH = 200              # nesting: deeper is no pendulum model
MAX_OPERATORS = 1000         # + - * / signs: more terms is no pendulum model either
MAX_DIGITS = 300             # a constant's magnitude: 0, or within 10**-300 .. 10**300
MAX_EXPONENT = 100           # |n| in x**n where x has names
_NOT_FINITE = (sp.zoo, sp.oo, -sp.oo, sp.nan)
# A model may name a parameter like a Python keyword (lambda is a natural name): such
# words are renamed before Python's parser reads the text, and mapped back after.
_KEYWORD = re.compile(r"\b(" + "|".join(keyword.kwlist) + r")\b")
_RENAMED = "_derive_kw_"

_BINARY = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b, ast.Mult: lambda a, b: a * b,
           ast.Div: lambda a, b: a / b, ast.Pow: lambda a, b: a ** b}


def parse_expression(text: object, names: Mapping[str, sp.Expr], where: str) -> sp.Expr:
    """The SymPy expression of `text`, whose free names must be keys of `names`."""
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise ModelError(f"{where}: must be an expression (a string or a number), got {type(text).__name__}")
    if isinstance(text, (int, float)):
        text = repr(text)
    if len(text) > MAX_LENGTH:
        raise ModelError(f"{where}: expression longer than {MAX_LENGTH} characters")
    if not text.isascii():
        bad = next(c for c in text if not c.isascii())
        raise ModelError(f"{where}: the character {bad!r} (U+{ord(bad):04X}) is not ASCII; "
                         f"expressions are written in ASCII")
    if "^" in text:
        raise ModelError(f"{where}: '^' is not a power here; write x**2")
    operators = sum(text.count(c) for c in "+-*/")
    if operators > MAX_OPERATORS:
        raise ModelError(f"{where}: expression with {operators} operators (at most {MAX_OPERATORS})")
    text = _KEYWORD.sub(lambda m: _RENAMED + m.group(1), text.strip())
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise ModelError(f"{where}: not an expression: {text.replace(_RENAMED, '')!r} ({exc.msg})") from None
    except (RecursionError, MemoryError):
        raise ModelError(f"{where}: expression nested too deeply") from None
    return _Builder(names, where, text).build(tree.body, 0)[0]


class _Builder:
    """Builds (SymPy expression, float value or None) bottom-up: the value is the
    constant's, None where the part has names."""

    def __init__(self, names: Mapping[str, sp.Expr], where: str, text: str):
        self.names, self.where, self.text = names, where, text

    def fail(self, what: str, grammar: bool = True):
        shown = self.text.replace(_RENAMED, "")
        if len(shown) > 80:
            shown = shown[:60] + " ... " + shown[-15:]
        allowed = (f" (allowed: numbers, declared names, + - * / **, parentheses, "
                   f"{', '.join(sorted(FUNCTIONS))})") if grammar else ""
        raise ModelError(f"{self.where}: {what} in {shown!r}{allowed}")

    def bounded(self, value, what: str):
        """`value` (a float, or a complex from a power) if it is a real number of bounded
        size, else a refusal naming `what`."""
        if isinstance(value, complex):
            if value.imag != 0:
                self.fail(f"{what}, which is not a real number", grammar=False)
            value = value.real
        if not math.isfinite(value) or (value != 0 and not 10.0 ** -MAX_DIGITS <= abs(value) <= 10.0 ** MAX_DIGITS):
            self.fail(f"{what}, a number too large or too small (magnitude beyond 1e{MAX_DIGITS} "
                      f"or below 1e-{MAX_DIGITS})", grammar=False)
        return value

    def checked(self, expr: sp.Expr, value, what: str):
        """The pair (expr, value), refusing a certain division by zero (SymPy's zoo, nan)
        and a constant made by cancellation (`l1 - l1`) that is not a bounded real."""
        if expr.has(*_NOT_FINITE):
            self.fail(f"{what}: a division by zero (or another undefined value)", grammar=False)
        if (expr.is_Pow and expr.exp.is_Number and expr.free_symbols
                and abs(expr.exp) > MAX_EXPONENT):                 # (x**50)**50 is x**2500
            self.fail(f"{what}: an exponent {expr.exp} (at most {MAX_EXPONENT} in absolute value)",
                      grammar=False)
        if value is None and not expr.free_symbols:
            if expr.has(sp.I):
                self.fail(f"{what}, which is not a real number", grammar=False)
            try:
                value = complex(expr)
            except (TypeError, ValueError, OverflowError):
                self.fail(f"{what}, which is not a number", grammar=False)
            value = self.bounded(value, what)
        return expr, value

    def constant(self, node: ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            self.fail(f"the constant {node.value!r}")
        text = ast.get_source_segment(self.text, node) or repr(node.value)
        if isinstance(node.value, int):
            if node.value.bit_length() > 4 * MAX_DIGITS:
                self.fail(f"the integer {text[:20]}..., a number too large", grammar=False)
            return self.checked(sp.Integer(node.value), self.bounded(float(node.value), f"the number {text}"), text)
        try:
            exact = decimal.Decimal(text)
        except decimal.InvalidOperation:
            self.fail(f"the number {text!r}")
        if exact and abs(exact.adjusted()) > MAX_DIGITS:
            self.fail(f"the number {text}, a number too large or too small (magnitude beyond "
                      f"1e{MAX_DIGITS} or below 1e-{MAX_DIGITS})", grammar=False)
        return sp.Rational(text), self.bounded(float(exact), f"the number {text}")

    def power(self, a, b, what: str):
        (x, xv), (n, nv) = a, b
        if nv is not None and xv is None and abs(nv) > MAX_EXPONENT:
            self.fail(f"{what}: an exponent {nv:g} (at most {MAX_EXPONENT} in absolute value)", grammar=False)
        if xv is None or nv is None:
            return None
        if xv == 0:
            if nv < 0:
                self.fail(f"{what}: a division by zero", grammar=False)
            return 0.0 if nv > 0 else 1.0
        magnitude = nv * math.log10(abs(xv))            # the power's size before computing it
        if abs(magnitude) > MAX_DIGITS:
            self.fail(f"{what}, a number too large or too small (about 10**{magnitude:.3g})", grammar=False)
        return self.bounded(complex(xv) ** nv if xv < 0 and nv != int(nv) else xv ** nv, what)

    def build(self, node: ast.AST, depth: int):
        if depth > MAX_DEPTH:
            self.fail("nesting too deep")
        what = ast.get_source_segment(self.text, node) or type(node).__name__
        what = what.replace(_RENAMED, "")
        if len(what) > 40:
            what = what[:30] + "..."
        if isinstance(node, ast.Constant):
            return self.constant(node)
        if isinstance(node, ast.Name):
            name = node.id.removeprefix(_RENAMED)
            if name in self.names:
                return self.names[name], None
            if node.id in CONSTANTS:
                return CONSTANTS[node.id], math.pi
            known = ", ".join(sorted(self.names)) or "none"
            self.fail(f"the name '{name}' is not declared (declared: {known})")
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            a, b = self.build(node.left, depth + 1), self.build(node.right, depth + 1)
            value = None
            if isinstance(node.op, ast.Pow):
                value = self.power(a, b, what)
            elif a[1] is not None and b[1] is not None:
                if isinstance(node.op, ast.Div) and b[1] == 0:
                    self.fail(f"{what}: a division by zero", grammar=False)
                value = _FLOAT[type(node.op)](a[1], b[1])
                if value == 0 and a[1] != 0 and isinstance(node.op, (ast.Mult, ast.Div)):
                    self.fail(f"{what}, a number too small (below 1e-{MAX_DIGITS})", grammar=False)
                value = self.bounded(value, what)
            return self.checked(_BINARY[type(node.op)](a[0], b[0]), value, what)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            a, v = self.build(node.operand, depth + 1)
            if isinstance(node.op, ast.USub):
                return -a, (None if v is None else -v)
            return a, v
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name):
                self.fail(f"the construct '{type(node.func).__name__}'")
            if node.func.id not in FUNCTIONS:
                self.fail(f"the function '{node.func.id}'")
            if node.keywords:
                self.fail("a keyword argument")
            args = [self.build(a, depth + 1) for a in node.args]
            arity = 2 if node.func.id == "atan2" else 1
            if len(args) != arity:
                self.fail(f"{node.func.id} with {len(args)} arguments")
            value = None
            if all(v is not None for _, v in args):
                try:
                    value = _MATH[node.func.id](*[v for _, v in args])
                except OverflowError:
                    self.fail(f"{what}, a number too large", grammar=False)
                except (ValueError, ZeroDivisionError):
                    self.fail(f"{what}, which is not a real number", grammar=False)
                value = self.bounded(value, what)
            return self.checked(FUNCTIONS[node.func.id](*[e for e, _ in args]), value, what)
        self.fail(f"the construct '{type(node).__name__}'")


_FLOAT = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b, ast.Mult: lambda a, b: a * b,
          ast.Div: lambda a, b: a / b}
_MATH = {"sin": math.sin, "cos": math.cos, "tan": math.tan, "asin": math.asin, "acos": math.acos,
         "atan": math.atan, "atan2": math.atan2, "sinh": math.sinh, "cosh": math.cosh,
         "tanh": math.tanh, "exp": math.exp, "log": math.log, "sqrt": math.sqrt, "abs": abs,
         "sign": lambda x: float((x > 0) - (x < 0))}
