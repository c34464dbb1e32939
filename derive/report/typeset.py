"""Typesetting for the LaTeX documents: symbols, expressions split over lines, the
objects a seed claim compares (matrices, Solve, atan2 forms, pinned discrepancies), and
the ASCII descriptions of the verification code turned into text with inline math.

Everything returns LaTeX; ``lines`` gives display lines for an ``align*`` (each at most
about WIDTH characters wide as printed), never one overlong line.
"""
from __future__ import annotations

import re

import sympy as sp
from ..verification.claims import (AtanForm, ChartRule, IllFormed, QuadrantError, ShapeMismatch,
                                   Solve)

WIDTH = 66          # printed characters per display line, roughly (portrait A4, 10pt)
CAP = 5000          # LaTeX characters of one formula in a document before it is abridged

_GREEK = {"theta", "vartheta", "phi", "varphi", "mu", "pi", "rho", "alpha", "beta", "gamma",
          "delta", "omega", "psi", "lambda", "sigma", "tau", "epsilon", "Delta", "Omega"}
_ABBREV = {"th": r"\theta", "ph": r"\phi", "vt": r"\vartheta", "vp": r"\varphi"}


# -- symbols ------------------------------------------------------------------------------

def symbol_tex(name: str) -> str:
    """theta1_ddot -> {\\ddot{\\theta}_{1}}, p1_dot -> {\\dot{p}_{1}}, mu -> \\mu."""
    m = re.fullmatch(r"([A-Za-z]+?)(\d*)((?:_dot|_ddot)?)(_new)?", name)
    if not m:
        return sp.latex(sp.Symbol(name))
    base, digits, accent, new = m.groups()
    tex = f"\\{base}" if base in _GREEK else base
    if accent:
        tex = f"\\{accent[1:]}{{{tex}}}"
    if digits:
        tex += f"_{{{digits}}}"
    return "{" + tex + "}"


def names_for(d) -> dict:
    """LaTeX names of every symbol a derivation or its seed claims use: coordinates with
    the chart's own letters (primes for the rotated chart), rates, accelerations, momenta,
    the seed's Cartesian link components.  Braced, so a power never doubles a prime."""
    names, s = {}, d.symbols
    for i, link in enumerate(d.model.links, 1):
        at = d.model.link_coordinates(link)
        own = [f"{c}{i}" for c in link.chart.coordinates]
        if list(link.coordinates) != own:       # named by the model (x, theta): its own letters
            for j in at:
                for x in (s.q[j], s.qd[j], sp.Symbol(f"{s.q[j].name}_ddot", real=True)):
                    names[x] = symbol_tex(x.name)
                names[s.p[j]] = "{p_{" + symbol_tex(s.q[j].name) + "}}"
            continue
        for tex, j in zip(link.chart.latex, at):
            q, qd, p = s.q[j], s.qd[j], s.p[j]
            base = tex.rstrip("'")
            prime = "^{" + r"\prime" * (len(tex) - len(base)) + "}" if tex != base else ""
            names[q] = f"{{{base}{prime}_{{{i}}}}}"
            names[qd] = f"{{\\dot{{{base}}}{prime}_{{{i}}}}}"
            names[sp.Symbol(f"{q.name}_ddot", real=True)] = f"{{\\ddot{{{base}}}{prime}_{{{i}}}}}"
            names[p] = f"{{p_{{{base}{prime}_{{{i}}}}}}}"
    for x in d.symbols.params:
        names[x] = symbol_tex(x.name)
    return names


class Names(dict):
    """symbol -> LaTeX, falling back to :func:`symbol_tex` for any other symbol."""

    def __missing__(self, key):
        return symbol_tex(key.name) if isinstance(key, sp.Symbol) else sp.latex(key)


def _complete(expr, names) -> dict:
    out = dict(names)
    for s in getattr(expr, "free_symbols", ()):
        if s not in out and isinstance(s, sp.Symbol) and not isinstance(s, sp.Dummy):
            out[s] = symbol_tex(s.name)
    return out


def tex(expr, names) -> str:
    expr = sp.sympify(expr)
    text = sp.latex(expr, symbol_names=_complete(expr, names))
    return text.replace(r"\operatorname{atan}_{2}", r"\operatorname{atan2}")


def full_size(tex_: str) -> str:
    """Fractions at the size of the display around them: a matrix entry is set in text
    style, where a plain fraction shrinks to script size."""
    return tex_.replace(r"\frac{", r"\dfrac{")


# -- widths and splitting ---------------------------------------------------------------

def width(t: str) -> float:
    """Rough printed width of LaTeX math in characters."""
    t = re.sub(r"\\(left|right|bigl|bigr|Bigl|Bigr)\b", "", t)
    t = re.sub(r"\\(operatorname|mathbf|text|mathrm)\{([^{}]*)\}", r"\2", t)
    t = re.sub(r"\\(dot|ddot|tilde|hat)\b", "", t)
    sub = sum(len(s) for s in re.findall(r"[_^]\{([^{}]*)\}", t))
    t = re.sub(r"[_^]\{([^{}]*)\}", "", t)
    t = re.sub(r"\\(sin|cos|tan)\b", "xxx", t)
    t = re.sub(r"\\[A-Za-z]+", "x", t)
    t = re.sub(r"[{}\s]", "", t)
    ops = len(re.findall(r"[-+=&]", t))
    return 1.15 * len(t) + 2 * ops + 0.7 * sub


def state_symbols(expr) -> set:
    """Symbols that are not parameters: coordinates, rates, accelerations, momenta."""
    return {s for s in getattr(expr, "free_symbols", ()) if not _is_parameter(s)}


def _is_parameter(s) -> bool:
    return bool(re.fullmatch(r"(m|l|L|g|mu|M|a|b)\d*", s.name))


def collected_terms(expr) -> list[sp.Expr]:
    """The terms of expr with like terms collected: terms with the same dependence on the
    state share one factored coefficient in the parameters (g l1 (m1 + m2) sin theta1)."""
    expr = sp.expand(expr)
    state = state_symbols(expr)
    groups: dict = {}
    for term in sp.Add.make_args(expr):
        coeff, part = term.as_independent(*state, as_Add=False) if state else (term, sp.S.One)
        groups[part] = groups.get(part, sp.S.Zero) + coeff
    terms = [sp.factor(c) * part for part, c in groups.items() if c != 0]
    if not terms:
        return [sp.S.Zero]
    return list(sp.Add(*terms).as_ordered_terms()) if len(terms) > 1 else terms


def _pieces(terms, names, budget) -> list[str]:
    """LaTeX of each term; a product wider than the budget broken into factor groups."""
    out = []
    for t in terms:
        piece = tex(t, names)
        if width(piece) <= budget or not isinstance(t, sp.Mul):
            out.append(piece)
            continue
        coeff, factors = t.as_coeff_mul()
        group = tex(coeff, names) if coeff not in (1, -1) else ("-" if coeff == -1 else "")
        groups = []
        for f in factors:
            ft = tex(f, names)
            if f.is_Add:
                ft = rf"\left({ft}\right)"
            if group.strip("-") and width(group) + width(ft) > budget:
                groups.append(group)
                group = r"\cdot " + ft
            else:
                group = f"{group} {ft}".strip()
        out += _no_orphan(groups, group, budget)
    return out


ORPHAN = 0.3        # a product's last line narrower than this part of the budget joins the one before


def _no_orphan(groups: list[str], last: str, budget: float) -> list[str]:
    """A product's lines, its last one (a lone factor, "\\cdot \\sin(x)") put back on the line
    before when it is short and the two overrun the budget by at most a quarter (the
    budget is an estimate well on the safe side): no line of one small factor."""
    if groups and width(last) < ORPHAN * budget and width(groups[-1]) + width(last) <= 1.25 * budget:
        return groups[:-1] + [groups[-1] + " " + last.removeprefix(r"\cdot ")]
    return groups + [last]


def _split(pieces: list[str], budget: float) -> list[str]:
    lines, current = [], ""
    for piece in pieces:
        if current and not piece.lstrip().startswith(("-", r"\cdot")):
            piece = "+ " + piece
        if current and width(current) + width(piece) > budget:
            lines.append(current)
            current = piece
        else:
            current = f"{current} {piece}".strip()
    lines.append(current)
    return lines


def expr_lines(expr, names, budget: float = WIDTH) -> list[str]:
    """An expression as display lines: like terms collected, a long sum split, a fraction
    with a state-dependent denominator written 1/den times its (split) numerator."""
    expr = sp.sympify(expr)
    if isinstance(expr, (sp.MatrixBase,)):
        return matrix_lines(expr, names, budget)
    if expr.has(sp.atan2, sp.acos, sp.asin) or expr.is_Atom:
        return _split_plain(expr, names, budget)
    num, den = sp.fraction(sp.together(expr)) if _state_denominator(expr) else (expr, sp.S.One)
    terms = collected_terms(num)
    whole = tex(sp.Add(*terms) if den == 1 else expr, names)
    if den == 1 and width(whole) <= budget:
        return [whole]
    if den != 1:
        inner = _split(_pieces(terms, names, budget - 10), budget - 10)
        if len(inner) == 1 and width(whole) <= budget:
            return [whole]
        if width(tex(den, names)) > budget / 3:
            below = _split(_pieces(collected_terms(den), names, budget - 10), budget - 10)
            inner[0], inner[-1] = r"\Bigl(" + inner[0], inner[-1] + r"\Bigr)"
            below[0], below[-1] = r"\Big/ \Bigl(" + below[0], below[-1] + r"\Bigr)"
            return inner + below
        lead = rf"\frac{{1}}{{{tex(den, names)}}}"
        if len(inner) == 1:
            return [rf"{lead} \left({inner[0]}\right)"]
        return ([rf"{lead} \Bigl({inner[0]}"] + inner[1:-1] + [rf"{inner[-1]}\Bigr)"])
    return _split(_pieces(terms, names, budget), budget)


def _split_plain(expr, names, budget):
    if isinstance(expr, sp.Add):
        return _split(_pieces(expr.as_ordered_terms(), names, budget), budget)
    return _split(_pieces([expr], names, budget), budget)


def _state_denominator(expr) -> bool:
    den = sp.fraction(sp.together(expr))[1] if expr.is_Add or expr.is_Mul or expr.is_Pow else 1
    return den != 1 and bool(state_symbols(den))


def matrix_lines(m: sp.Matrix, names, budget: float = WIDTH, label: str = "") -> list[str]:
    """A matrix inline when it fits, else entry by entry (zero entries said once)."""
    entries = [[tex(m[i, j], names) for j in range(m.cols)] for i in range(m.rows)]
    row_w = max(sum(width(e) + 2 for e in row) for row in entries) if m.rows else 0
    if row_w <= budget and m.rows <= 8:
        body = r" \\ ".join(" & ".join(row) for row in entries)
        return [full_size(rf"\begin{{pmatrix}} {body} \end{{pmatrix}}")]
    lines, zeros = [], 0
    for i in range(m.rows):
        for j in range(m.cols):
            if m[i, j] == 0:
                zeros += 1
                continue
            idx = f"{i + 1}" if m.cols == 1 else f"{i + 1}{j + 1}"
            sub = expr_lines(m[i, j], names, budget - 8)
            mark = label or r"\,\cdot\,"
            lines.append(rf"[{mark}]_{{{idx}}} = {sub[0]}")
            lines += [rf"\qquad {s}" for s in sub[1:]]
    if zeros:
        lines.append(rf"\text{{a {m.rows}$\times${m.cols} matrix; the other {zeros} "
                     rf"entr{'y is' if zeros == 1 else 'ies are'} zero}}")
    return lines


# -- the objects of a claim ---------------------------------------------------------------

def object_lines(obj, names, budget: float = WIDTH) -> list[str]:
    """Display lines of anything a claim's printed or derived side, or an erratum's
    discrepancy or correction, may be."""
    if isinstance(obj, Solve):
        return ([r"x \text{ solving } P x = r, \text{ where}"]
                + _labelled("P", matrix_lines(obj.P, names, budget - 6))
                + _labelled("r", matrix_lines(obj.r, names, budget - 6)))
    if isinstance(obj, IllFormed):
        shapes = r" \cdot ".join(rf"({a}\times {b})" for a, b in obj.operands)
        return [rf"\text{{ill-formed: a product of shapes }} {shapes}"]
    if isinstance(obj, ShapeMismatch):
        shape = lambda s: (r" \cdot ".join(rf"({a}\times {b})" for a, b in s)
                           if s and isinstance(s[0], tuple) else rf"{s[0]}\times {s[1]}")
        out = [rf"\text{{shape }} {shape(obj.printed)} \text{{ printed, }} "
               rf"{shape(obj.derived)} \text{{ derived}}"]
        for idx, entry in obj.missing:
            out.append(rf"\text{{entry {idx + 1} missing: }} {tex(entry, names)}")
        return out
    if isinstance(obj, QuadrantError):
        rho = expr_lines(obj.rho, names, budget - 20)
        return ([rf"{tex(obj.angle, names)} \text{{ off by }} \pi \text{{ where }} \rho < 0, "
                 rf"\quad \rho = {rho[0]}"] + [rf"\qquad {s}" for s in rho[1:]])
    if isinstance(obj, AtanForm):
        out = []
        for x, form in obj.values.items():
            sub = expr_lines(form, names, budget - 6)
            out.append(rf"{tex(x, names)} = {sub[0]}")
            out += [rf"\qquad {s}" for s in sub[1:]]
        return out
    if isinstance(obj, ChartRule):
        return [rule_tex(obj.bound)]
    if callable(obj):
        return [r"\text{the polar sines of the chosen chart at 3400 standard-chart states}"]
    if isinstance(obj, sp.MatrixBase):
        return matrix_lines(obj, names, budget)
    return expr_lines(obj, names, budget)


def _labelled(label: str, lines: list[str]) -> list[str]:
    if len(lines) == 1:
        return [f"{label} = {lines[0]}"]
    return [rf"\text{{{label}:}}"] + [rf"\quad {s}" for s in lines]


def rule_tex(bound) -> str:
    b = f"{float(bound):g}"
    return (rf"\text{{standard if all }} |\sin\theta_i| \ge {b}; \text{{ else rotated if some "
            rf"}} |\sin\theta_i| \ge {b} \text{{ has }} |\sin\phi_i| < {b}; \text{{ else second}}")


def abridge(lines: list[str], cap: int = CAP) -> list[str]:
    """At most about ``cap`` LaTeX characters of a formula; what is left out is said."""
    out, total = [], 0
    for k, line in enumerate(lines):
        if total + len(line) > cap and out:
            rest = len(lines) - k
            # -{}- : two hyphens, as typed (typewriter T1 fonts ligature -- into an en dash)
            out.append(rf"\qquad \dots \text{{ ({rest} more line{'s' if rest > 1 else ''}; "
                       rf"in full in \texttt{{derive verify -{{}}-json}})}}")
            return out
        out.append(line)
        total += len(line)
    return out


def sympy_text(obj) -> str:
    """A SymPy-readable text of a claim object (for JSON)."""
    if isinstance(obj, Solve):
        return f"Solve(P={sp.sstr(obj.P)}, r={sp.sstr(obj.r)})"
    if isinstance(obj, AtanForm):
        return "{" + ", ".join(f"{x}: {sp.sstr(v)}" for x, v in obj.values.items()) + "}"
    if isinstance(obj, QuadrantError):
        return f"QuadrantError(angle={obj.angle}, rho={sp.sstr(obj.rho)})"
    if isinstance(obj, ChartRule):
        return f"ChartRule(bound={obj.bound})"
    if isinstance(obj, (sp.Basic, sp.MatrixBase)):
        return sp.sstr(obj)
    if callable(obj):
        return getattr(obj, "__name__", "function")
    return repr(obj)


def latex_text(obj, names) -> str:
    """One LaTeX string of a claim object (for JSON): its display lines joined."""
    return r" \\ ".join(object_lines(obj, names))


# -- prose: the ASCII descriptions as text with inline math -------------------------------

_TEXT2 = {"of", "at", "is", "in", "as", "by", "to", "an", "or", "be", "on", "if", "no", "vs", "so",
          "it", "we", "up", "and"}
_FUNCS = {"sin": r"\sin", "cos": r"\cos", "tan": r"\tan", "atan2": r"\operatorname{atan2}",
          "sqrt": r"\sqrt", "diag": r"\operatorname{diag}", "det": r"\det", "exp": r"\exp",
          "acos": r"\arccos", "atan": r"\arctan"}
# φ (U+03C6) is the second chart's \varphi, ϕ (U+03D5) the standard chart's \phi
_UNI = {"θ": r"\theta", "ϑ": r"\vartheta", "φ": r"\varphi", "ϕ": r"\phi", "μ": r"\mu", "π": r"\pi",
        "Δ": r"\Delta", "∂": r"\partial", "·": r"\cdot", "×": r"\times", "ρ": r"\rho",
        "≥": r"\ge", "≤": r"\le", "→": r"\to", "∓": r"\mp", "±": r"\pm", "²": "^{2}", "′": "'",
        "−": "-", "≠": r"\ne", "≈": r"\approx", "ω": r"\omega", "λ": r"\lambda", "√": r"\surd"}
_UNI = {k: (v + " " if v.startswith("\\") else v) for k, v in _UNI.items()}
_SPECIAL = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#",
            "_": r"\_", "{": r"\{", "}": r"\}", "^": r"\^{}", "~": r"\~{}", "<": r"\textless{}",
            ">": r"\textgreater{}", "|": r"\textbar{}"}

_TOKEN = re.compile(r"""
    (?P<held>[\ue000-\ue1ff])
  | (?P<abbr>\b(?:i\.e|e\.g)\.)
  | (?P<ref>\(\d+\.\d+\)(?:-\(\d+\.\d+\))?|\d+\.\d+-\d+\.\d+|§\s?\d+(?:\.\d+)*)
  | (?P<dims>\d+x\d+\b)
  | (?P<num>\d+(?:\.\d+)?(?:e-?\d+)?)
  | (?P<apos>\u2019s\b)
  | (?P<ident>(?:[A-Za-z]+|[\u0370-\u03ff])[\u0307\u0308]?~?\d*(?:_[A-Za-z0-9]+)?~?'*(?:\^(?:-?\d+|[tT]\b)|\^(?=[A-Z]\^|[^\w(-]|$))?'*)
  | (?P<power>\^(?:-?\d+|[tT]\b))
  | (?P<op><=|>=|!=|[=+\-*/<>|^'~]|[\u00b7\u00d7\u2202\u2265\u2264\u2192\u00b1\u2213\u2260\u2248\u221a\u00b2\u2032\u2212])
  | (?P<space>\s+)
  | (?P<punct>[(),;:.\[\]])
  | (?P<other>.)
""", re.X)


def _ident_tex(tok: str) -> str:
    m = re.fullmatch(r"((?:[A-Za-z]|[\u0370-\u03ff])+)([\u0307\u0308]?)(~?)(\d*)(?:_([A-Za-z0-9]+))?(~?)('*)"
                     r"(?:\^(-?\d+|[a-zA-Z])|(\^))?('*)", tok)
    if not m:
        return tok
    base, accent, tilde1, digits, sub, tilde, primes, power, hat, primes2 = m.groups()
    primes = (primes or "") + (primes2 or "")
    tilde = tilde or tilde1
    if base + digits in _FUNCS and not sub:
        out, digits = _FUNCS[base + digits], ""
    elif base.startswith("d") and len(base) > 1 and not _is_word(base):
        # a d not in a quotient (those are held as fractions): d theta is a difference
        inner = _ident_tex(base[1:] + accent)
        inner = inner[1:-1] if inner.startswith("{") else inner
        out = (r"\Delta " if base[1:] in _GREEK or base[1:] in _ABBREV else "d") + inner
        accent = ""
    elif re.fullmatch(r"t[A-Z]", base):
        out = "{" + base[1] + "}^{T}"          # tQ: the transpose of Q
    elif re.fullmatch(r"[A-Za-z]{3,}", base) and base not in _GREEK and base not in _ABBREV:
        out = rf"\mathrm{{{base}}}"             # a word inside a formula (matrix^-1)
    elif base in _GREEK:
        out = "\\" + base
    elif base in _ABBREV:
        out = _ABBREV[base]
    elif re.fullmatch(r"d\d?[A-Za-z]+", base) or re.fullmatch(r"d\d[A-Za-z]+", base + digits):
        out = base
    elif len(base) == 1 and base in _UNI:
        out = _UNI[base]
    else:
        out = "".join(_UNI.get(ch, ch) for ch in base)
    if accent:
        out = rf"\{'dot' if accent == chr(0x307) else 'ddot'}{{{out}}}"
    if tilde:
        out = rf"\tilde{{{out}}}"
    if hat:
        out = rf"\hat{{{out}}}"
    if digits and sub:
        out += f"{digits}_{{{sub}}}"
    elif digits or sub:
        out += f"_{{{digits or sub}}}"
    out += primes
    if power:
        out = "{" + out + "}" + f"^{{{'T' if power == 't' else power}}}"
    return out


def _symbol_a(toks, i: int) -> bool:
    """The letter a as a symbol, not the article: right before a comma or a bracket, as
    in (c, a) or (a, c)."""
    return toks[i][1] == "a" and i + 1 < len(toks) and toks[i + 1][1] in ",;)"


def _is_word(tok: str) -> bool:
    """An English word (text), not a symbol, function or derivative name (math)."""
    if not re.fullmatch(r"[A-Za-z]+", tok):
        return False
    if tok in _GREEK or tok in _ABBREV or tok in _FUNCS:
        return False
    if tok.lower() in _TEXT2 or tok == "a":
        return True
    rest = tok[1:]
    if tok.startswith("d") and (rest in _GREEK or rest in _ABBREV or len(rest) <= 1
                                or re.fullmatch(r"\d?[a-zA-Z]", rest)):
        return False
    return len(tok) >= 3


_GREEK_WORD = re.compile(r"(?<![A-Za-z])(%s)(\d*)(?![A-Za-z])" % "|".join(sorted(_GREEK, key=len, reverse=True)))


def text(words: str) -> str:
    """Plain text (a title) as LaTeX text: upright words, hyphens as hyphens, LaTeX's special
    characters escaped; only Greek letters, by name (theta) or Unicode, set as math.

    Parameters
    ----------
    words : str
        The text.

    Returns
    -------
    str
        LaTeX paragraph text.
    """
    out, at = [], 0
    for m in _GREEK_WORD.finditer(words):
        out.append(_plain_text(words[at:m.start()]))
        out.append(f"$\\{m.group(1)}" + (f"_{{{m.group(2)}}}" if m.group(2) else "") + "$")
        at = m.end()
    out.append(_plain_text(words[at:]))
    return "".join(out)


def _plain_text(words: str) -> str:
    return "".join(f"${_UNI[ch].strip()}$" if ch in _UNI and "\u0370" <= ch <= "\u03ff"
                   else _SPECIAL.get(ch, ch) for ch in words)


# a symbol a derivative is taken of or by: q_i', theta_i^2, th1, L, t
_SYM = r"(?:[A-Za-z]+|[\u0370-\u03ff])[\u0307\u0308]?~?\d*(?:_[A-Za-z0-9]+)?'*(?:\^\d+)?"
_QUOTIENT = re.compile(rf"(?<![\w'\\])d(2?)({_SYM})/d({_SYM})(?:(\s+)d({_SYM}))?")
_TIME = re.compile(r"(?<![\w'\\])d/dt\b")
_HELD = 0xE000          # private-use characters stand for pieces set before tokenizing


def _symbolic(sym: str) -> bool:
    """A derivative's numerator or denominator is one symbol, not a word (dark/dim)."""
    base = re.match(r"[A-Za-z]+|[\u0370-\u03ff]", sym).group()
    return len(base) == 1 or base in _GREEK or base in _ABBREV


def _quotient(m: re.Match, display: bool) -> tuple[str, str]:
    """A derivative dN/dD (d2N/dD1 dD2) as LaTeX, and the text it leaves unconsumed: a
    partial derivative, except d/dt of a time derivative."""
    order, num, den, gap, den2 = m.groups()
    if not (_symbolic(num) and _symbolic(den) and (den2 is None or _symbolic(den2))):
        return "", m.group()
    rest = ""
    if den2 is not None and not order:
        rest, den2 = gap + "d" + den2, None
    d = "d" if den == "t" and not order else r"\partial "
    top = (d.strip() + "^{2} " if order else d) + _ident_tex(num)
    bottom = d + _ident_tex(den) + (rf"\,\partial {_ident_tex(den2)}" if den2 else "")
    tex = rf"\dfrac{{{top}}}{{{bottom}}}" if display else f"{top}/{bottom}"
    return tex, rest


def prose(text: str, display: bool = False, literal=()) -> str:
    """An ASCII description ("dq_i/dtheta_i . J q_i = l_i^2 (standard chart)") as LaTeX
    text with the mathematical runs in math mode; everything else escaped.

    Parameters
    ----------
    text : str
        The description.
    display : bool
        Set derivatives as full-size fractions (a heading of its own); otherwise
        slashed, d/dt and dL/dq as d/dt and the partial derivative.
    literal : iterable of str
        Names set as typewriter text wherever they stand as a word (model names).

    Returns
    -------
    str
        LaTeX paragraph text.
    """
    held: list[str] = []
    text_held: set[int] = set()

    def hold(tex: str, as_text: bool = False) -> str:
        held.append(tex)
        if as_text:
            text_held.add(len(held) - 1)
        return chr(_HELD + len(held) - 1)

    text = re.sub(r"(?<=[A-Za-z]{2})'s\b", "\u2019s", text).replace("->", "\u2192")
    text = re.sub(r"(?<!\S)'(\([^']*\))'", "\u2018\\1\u2019", text)     # '(a quotation)'
    for name in sorted(set(literal), key=len, reverse=True):
        text = re.sub(rf"(?<![\w]){re.escape(name)}(?![\w])",
                      lambda m: hold(r"\texttt{" + m.group().replace("_", r"\_") + "}", True), text)
    text = _TIME.sub(lambda m: hold(r"\dfrac{d}{dt}" if display else r"d/dt\,{}"), text)

    def quotient(m):
        tex, rest = _quotient(m, display)
        return hold(tex) + rest if tex else rest
    text = _QUOTIENT.sub(quotient, text)
    text = re.sub(r"\bd2(?=[A-Za-z])", "d\u00b2", text)
    toks = [(m.lastgroup, m.group()) for m in _TOKEN.finditer(text)]
    kinds = []
    for kind, tok in toks:
        if kind == "held":
            kinds.append("text" if ord(tok) - _HELD in text_held else "math")
        elif kind == "ident" and re.fullmatch(r"[A-Za-z]+_[a-z]{3,}", tok):
            kinds.append("name")
        elif kind == "ident":
            kinds.append("text" if _is_word(tok) and not _symbol_a(toks, len(kinds)) else "math")
        elif kind in ("num", "op", "power", "dims"):
            kinds.append("math")
        elif kind == "other" and tok in _UNI:
            kinds.append("math")
        elif kind in ("ref", "apos", "abbr") or tok in "\u2018\u2019":
            kinds.append("text")
        else:
            kinds.append("neutral")
    # a hyphen inside a word (PDF-extraction, 6-entry, x-axis) is text, not a minus
    for i, (kind, tok) in enumerate(toks):
        if (tok == "-" and 0 < i < len(toks) - 1 and "space" not in (toks[i - 1][0], toks[i + 1][0])
                and "text" in (kinds[i - 1], kinds[i + 1])):
            kinds[i] = "hyphen"
    # a neutral token is math when math lies on both sides of it (before any text)
    n = len(toks)
    math_at = [k == "math" for k in kinds]
    for i in range(n):
        if kinds[i] != "neutral":
            continue
        left = next((kinds[j] for j in range(i - 1, -1, -1) if kinds[j] != "neutral"), None)
        right = next((kinds[j] for j in range(i + 1, n) if kinds[j] != "neutral"), None)
        math_at[i] = left == "math" and right == "math"
        if toks[i][1] in ")]" and i and math_at[i - 1]:
            math_at[i] = True
    for i in range(n - 2, -1, -1):
        if kinds[i] == "neutral" and toks[i][1] in "([" and math_at[i + 1]:
            math_at[i] = True
    out, run = [], []

    def flush():
        if run:
            body = "".join(run).strip()
            body = _big_parens(_sqrt_braces(body).replace(", ", r",\allowbreak "))
            out.append(f"${body}$")
            trailing = "".join(run)[len("".join(run).rstrip()):]
            if trailing:
                out.append(" ")
            run.clear()
    for i, ((kind, tok), is_math) in enumerate(zip(toks, math_at)):
        if kind == "held":
            tok = held[ord(tok) - _HELD]
        if (is_math and kind == "space" and i >= 3 and toks[i - 2][1] == "/"
                and toks[i - 1][0] == toks[i - 3][0] == "num"):
            kind, tok = "held", r"\,{}"      # 1/2 m1: the number apart from its factor
        elif (is_math and kind == "space" and 0 < i < n - 1 and toks[i - 1][0] == "num"
                and toks[i + 1][1] == "("):
            kind, tok = "held", r"\;"        # 0.5 (>= 0.5): a number apart from a remark
        if is_math:
            run.append(tok if kind == "held" else _math_token(kind, tok))
        else:
            flush()
            out.append(tok if kind == "held" else _text_token(kind, tok))
    flush()
    return "".join(out)


def _math_token(kind, tok):
    if kind == "ident":
        return _ident_tex(tok)
    if kind == "op":
        return {"<=": r"\le ", ">=": r"\ge ", "!=": r"\ne ", "*": r"\,", "|": r"\lvert ",
                "~": r"\sim ", "^": r"\hat{}"}.get(tok, _UNI.get(tok, tok))
    if kind == "power":
        return f"^{{{'T' if tok[1:] == 't' else tok[1:]}}}"
    if kind == "punct" and tok == ".":
        return r"\cdot "
    if kind == "other":
        return _UNI.get(tok, "")
    if kind == "dims":
        return tok.replace("x", r"\times ")
    if kind == "num" and "e" in tok:
        mant, exp = tok.split("e")
        return rf"{mant}\times 10^{{{int(exp)}}}"
    return tok


def _text_token(kind, tok):
    if kind == "ident" and "_" in tok:
        return r"\texttt{" + tok.replace("_", r"\_") + "}"
    if kind == "ref":
        return tok.replace("-", "--") if "§" not in tok else tok.replace("§", r"\S{}")
    if tok == "§":
        return r"\S{}"
    return "".join(_SPECIAL.get(ch, ch) for ch in tok.replace("\u2019", "'").replace("\u2018", "`")
                   if ord(ch) < 0x300 or ch in _SPECIAL)


def _big_parens(body: str) -> str:
    """Parentheses around a full-size fraction grow with it (\\left( ... \\right))."""
    if r"\dfrac" not in body:
        return body
    chars, stack = list(body), []
    for k, ch in enumerate(chars):
        if ch == "(" and (k == 0 or body[k - 1] != "\\"):
            stack.append(k)
        elif ch == ")" and stack and body[k - 1] != "\\":
            start = stack.pop()
            if r"\dfrac" in body[start:k]:
                chars[start], chars[k] = r"\left(", r"\right)"
    return "".join(chars)


def _sqrt_braces(body: str) -> str:
    """\\sqrt(...) -> \\sqrt{...} with balanced parentheses; |x| pairs as \\lvert\\rvert."""
    while r"\sqrt(" in body:
        start = body.index(r"\sqrt(")
        depth, k = 0, start + 5
        for k in range(start + 5, len(body)):
            depth += {"(": 1, ")": -1}.get(body[k], 0)
            if depth == 0:
                break
        body = body[:start] + r"\sqrt{" + body[start + 6:k] + "}" + body[k + 1:]
    parts = body.split(r"\lvert ")
    if len(parts) > 1:
        body = parts[0] + "".join((r"\lvert " if i % 2 else r"\rvert ") + p
                                  for i, p in enumerate(parts[1:], 1))
    return body
