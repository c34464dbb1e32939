"""Expressions in model and chart files, parsed as data: never evaluated as Python.

The grammar: numbers (integers and decimals, read exactly as rationals), declared
names, + - * / ** (^ is refused: it is XOR in Python and would mislead), unary
minus, parentheses, and calls of a fixed list of functions.  Python's own parser
reads the text into a syntax tree (parsing runs no code); this module walks the
tree and builds SymPy objects, refusing every other node (attributes, subscripts,
lambdas, comprehensions, strings, keywords, ...).  A refusal is a ModelError naming
the file, the key and what was refused.
"""
from __future__ import annotations

import ast
import keyword
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
    if "^" in text:
        raise ModelError(f"{where}: '^' is not a power here; write x**2")
    text = _KEYWORD.sub(lambda m: _RENAMED + m.group(1), text.strip())
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise ModelError(f"{where}: not an expression: {text.replace(_RENAMED, '')!r} ({exc.msg})") from None
    return _Builder(names, where, text).build(tree.body, 0)


class _Builder:
    def __init__(self, names: Mapping[str, sp.Expr], where: str, text: str):
        self.names, self.where, self.text = names, where, text

    def fail(self, what: str):
        shown = self.text.replace(_RENAMED, "")
        raise ModelError(f"{self.where}: {what} in {shown!r} (allowed: numbers, declared names, "
                         f"+ - * / **, parentheses, {', '.join(sorted(FUNCTIONS))})")

    def build(self, node: ast.AST, depth: int) -> sp.Expr:
        if depth > MAX_DEPTH:
            self.fail("nesting too deep")
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                self.fail(f"the constant {node.value!r}")
            text = ast.get_source_segment(self.text, node) or repr(node.value)
            return sp.Rational(text) if isinstance(node.value, float) else sp.Integer(node.value)
        if isinstance(node, ast.Name):
            name = node.id.removeprefix(_RENAMED)
            if name in self.names:
                return self.names[name]
            if node.id in CONSTANTS:
                return CONSTANTS[node.id]
            known = ", ".join(sorted(self.names)) or "none"
            self.fail(f"the name '{name}' is not declared (declared: {known})")
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            a, b = self.build(node.left, depth + 1), self.build(node.right, depth + 1)
            return _BINARY[type(node.op)](a, b)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            a = self.build(node.operand, depth + 1)
            return -a if isinstance(node.op, ast.USub) else a
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
            return FUNCTIONS[node.func.id](*args)
        self.fail(f"the construct '{type(node).__name__}'")
