"""A model's equations as SymPy objects, typeset for a notebook.

`Equations` is the derivation's content a Python user reads: M and F of M q'' = F, T, V,
the Lagrangian and the energy, the Hamiltonian where the model has it, and the symbols
they are written in.  Its `_repr_latex_` sets them with the symbols of the LaTeX document
(derive latex), so a Jupyter notebook shows them typeset.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..derivation import Derivation, HamiltonianForm
from . import typeset as ts
from .latex import symbol_names


@dataclass(frozen=True)
class Equations:
    """The equations of motion of one model, M(q) q'' = F(q, q'), as SymPy objects.

    Parameters
    ----------
    model : str
        The model's name.
    title : str
        Its one-line description.
    coordinates, rates, parameters, inputs, momenta : tuple of sympy.Symbol
        The generalized coordinates q, their rates q', the parameters (in the model's
        order), the run-time inputs, and the canonical momenta p (named even where the
        model has no Hamiltonian form).  The symbols carry SymPy assumptions (coordinates
        and rates real; lengths, masses, inertias and the other parameters positive, g
        real), so an expression built with plain ``sp.symbols("m1 l1")`` is not equal to
        one of these: build with these symbols (``m1, m2, l1, l2, g = eq.parameters``).
    M : sympy.Matrix
        The mass matrix.
    F : sympy.Matrix
        The forcing (with damping and applied forces where the model has them).
    T, V : sympy.Expr
        The kinetic and the potential energy.
    hamiltonian : HamiltonianForm or None
        The Hamiltonian form (closed forms up to two coordinates), if the model asks for it.

    Examples
    --------
    >>> import sympy as sp
    >>> q, qd, m, g = sp.symbols("q q_dot m g")
    >>> eq = Equations("bead", "a falling bead", (q,), (qd,), (m, g), (), (sp.Symbol("p_q"),),
    ...                sp.Matrix([[m]]), sp.Matrix([-m * g]), m * qd**2 / 2, m * g * q)
    >>> eq.L
    -g*m*q + m*q_dot**2/2
    >>> eq.H is None
    True
    >>> "M &=" in eq._repr_latex_()
    True
    """
    model: str
    title: str
    coordinates: tuple
    rates: tuple
    parameters: tuple
    inputs: tuple
    momenta: tuple
    M: sp.Matrix
    F: sp.Matrix
    T: sp.Expr
    V: sp.Expr
    hamiltonian: HamiltonianForm | None = None
    names: dict | None = None           # symbol -> LaTeX (the document's); None: SymPy's own

    @property
    def L(self) -> sp.Expr:
        """The Lagrangian T - V."""
        return self.T - self.V

    @property
    def energy(self) -> sp.Expr:
        """The energy T + V."""
        return self.T + self.V

    @property
    def H(self) -> sp.Expr | None:
        """The Hamiltonian in (q, p) where its closed form is written out, else None."""
        return None if self.hamiltonian is None else self.hamiltonian.H

    def _tex(self, expr) -> str:
        return ts.tex(expr, self.names or {})

    def _repr_latex_(self) -> str:
        """The equations as one LaTeX display (Jupyter typesets it)."""
        q = r",\ ".join(self._tex(s) for s in self.coordinates)
        # no model name in the display: an underscore in \text is an error in LaTeX
        rows = [rf"&\text{{coordinates }} {q}",
                rf"M &= {self._tex(self.M)}", rf"F &= {self._tex(self.F)}",
                rf"T &= {self._tex(self.T)}", rf"V &= {self._tex(self.V)}",
                r"L &= T - V, \quad E = T + V"]
        if self.H is not None:
            rows.append(rf"H &= {self._tex(self.H)}")
        return r"$$\begin{aligned}" + r" \\ ".join(rows) + r"\end{aligned}$$"

    def __repr__(self) -> str:
        return (f"<Equations of {self.model}: {len(self.coordinates)} coordinates "
                f"({', '.join(s.name for s in self.coordinates)}), M q'' = F>")


def equations_of(d: Derivation) -> Equations:
    """The equations of a derivation (derive/derivation/), with the document's symbols.

    Parameters
    ----------
    d : Derivation
        A model's derivation, as derive.derivation.derive returns it.

    Returns
    -------
    Equations
        Its M, F, T, V, Hamiltonian form and symbols.

    Examples
    --------
    >>> from derive.derivation import derive
    >>> eq = equations_of(derive("planar"))
    >>> [s.name for s in eq.coordinates]
    ['theta1', 'theta2']
    >>> eq.M.shape
    (2, 2)
    """
    s = d.symbols
    return Equations(d.name, d.model.title, s.q, s.qd, s.params, s.u, s.p, d.M, d.F, d.T, d.V,
                     d.hamiltonian, dict(symbol_names(d)))
