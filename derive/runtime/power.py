"""The energy balance of a run: what changes E = T + V besides the run's error.

Along an exact motion Jacobi's energy h = q'.dL/dq' - L obeys dh/dt = q'.Q - q'.dR/dq'
- dL/dt|explicit (Q the applied forces, R the dissipation; dL/dt|explicit the partial in
t at fixed q, q': a prescribed pivot's).  E differs from h by a function of the state and
t (E - h = T1 + 2 T0, the parts of T linear in and free of q'; zero without explicit
time), so

    E(t) - E(t0) = W - D + M,   W = int q'.Q dt,   D = int q'.dR/dq' dt,
    M = int -dL/dt|explicit dt + [E - h] from t0 to t,

W the work of the applied forces (with t in them: the forced pendulum's drive), D the
energy dissipated, M the work of the prescribed motion (the moving pivot).  Every term is
a function of (t, y) or an integral of one, evaluated on the run's own states: what is
left of the balance is the run's energy error, not the work of its drives.

The integrals: 3-point Gauss on the run's continuous solution r.sol, each output interval
cut into 1, 2, 4, ... pieces until the running sums move by less than 1e-13 of the
energy scale (at most MAX_PIECES); without r.sol (a fixed-step run of an autonomous
model), the trapezoid rule with its end correction on the output rows.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import sympy as sp

from ..derivation import derive
from ..derivation.symbols import t as TIME
from ..model.description import forget_on_model_change
from ..verification.physics import jacobi_energy

GAUSS = np.polynomial.legendre.leggauss(3)      # nodes and weights on [-1, 1]
MAX_PIECES = 64                                  # sub-intervals per output interval, at most
CONVERGED = 1e-13                                # of the energy scale: the sums have converged


@dataclass
class EnergyBalance:
    """E - E0 = W - D + M at the output times (the module doc), each (len(t),), 0 at t0."""
    change: np.ndarray           # E - E0
    work: np.ndarray             # W: the applied forces' work
    dissipated: np.ndarray       # D: the energy dissipated
    motion: np.ndarray           # M: the prescribed motion's work
    how: str                     # the quadrature, in words

    @property
    def residual(self) -> np.ndarray:
        """|E - E0 - (W - D + M)|: the run's energy error."""
        return np.abs(self.change - (self.work - self.dissipated + self.motion))


@forget_on_model_change
@lru_cache(maxsize=64)
def _expressions(model: str):
    """(args, [q'.Q, q'.dR/dq', -dL/dt|explicit], E - h) of a model's derivation."""
    d = derive(model)
    s = d.symbols
    forces = sum((qd * Q for qd, Q in zip(s.qd, d.forces)), sp.S.Zero) if d.forces is not None else sp.S.Zero
    dissipated = (sum((qd * d.dissipation.diff(qd) for qd in s.qd), sp.S.Zero)
                  if d.dissipation is not None else sp.S.Zero)
    timed = d.model.is_time_dependent
    explicit = -d.L.diff(TIME) if timed else sp.S.Zero
    gap = sp.expand(d.energy - jacobi_energy(d)) if timed else sp.S.Zero
    args = (TIME, *s.q, *s.qd, *s.params, *s.u)
    return args, [sp.lambdify(args, e, "numpy") for e in (forces, dissipated, explicit, gap)], \
        (forces != 0, dissipated != 0, timed)


def power_functions(model: str, params, inputs=None):
    """The powers of a model at (t, y) rows, and E - h there.

    Parameters
    ----------
    model : str
        A resolved model name.
    params : array_like
        The parameters, in the model's order.
    inputs : array_like or callable, optional
        The inputs held over the run, in the model's order, or u(t, y) giving them at each
        row (None: none).

    Returns
    -------
    power : callable
        power(t, y) -> (q'.Q, q'.dR/dq', -dL/dt|explicit), each (len(t),).
    gap : callable
        gap(t, y) -> E - h, (len(t),).
    present : tuple of bool
        Whether the model has applied forces, dissipation, explicit time.
    """
    args, (forces, dissipated, explicit, gap), present = _expressions(model)
    p = [float(x) for x in np.ravel(params)]

    def inputs_at(t, y) -> list:
        if inputs is None:
            return []
        if not callable(inputs):
            return [float(x) for x in np.ravel(inputs)]
        rows = np.array([np.full(len(args) - 1 - len(p) - y.shape[1], np.nan) if not np.isfinite(r).all()
                         else inputs(a, r) for a, r in zip(t, y)], float)
        return list(rows.T)

    def at(g, t, y):
        t, y = np.asarray(t, float), np.asarray(y, float)
        with np.errstate(invalid="ignore"):          # NaN rows after a run's stop stay NaN
            return np.asarray(g(t, *y.T, *p, *inputs_at(t, y)), float) + np.zeros(len(y))

    return (lambda t, y: tuple(at(g, t, y) for g in (forces, dissipated, explicit)),
            lambda t, y: at(gap, t, y), present)


def energy_balance(result, inputs=None) -> EnergyBalance:
    """The energy balance of a run (the module doc) at its output times.

    Parameters
    ----------
    result : SimulationResult
        A run of a single model (its energy, states and, where it has one, r.sol).
    inputs : array_like or callable, optional
        The inputs it held over the run, or u(t, y) (None: none).

    Returns
    -------
    EnergyBalance
    """
    t = np.asarray(result.t, float)
    power, gap, _ = power_functions(result.model, result.params, inputs)
    if result.sol is not None and len(t) > 1:
        parts, pieces = gauss_converged(result, t, power)
        how = f"3-point Gauss on the continuous solution, {pieces} piece(s) per output interval"
    else:
        parts, how = trapezoid(t, power(t, result.y)), "the corrected trapezoid rule on the output rows"
    work, dissipated, explicit = (np.concatenate([[0.0], np.cumsum(part)]) for part in parts)
    g = gap(t, result.y)
    e = np.asarray(result.energy, float)
    return EnergyBalance(e - e[0], work, dissipated, explicit + (g - g[0]), how)


def trapezoid(t: np.ndarray, powers) -> list[np.ndarray]:
    """Each power's integral over each output interval: the trapezoid rule with its end
    correction (Euler-Maclaurin), derivatives by second-order differences (fourth order)."""
    h = np.diff(t)
    if len(t) < 3:
        return [h * (q[1:] + q[:-1]) / 2 for q in powers]
    return [h * (q[1:] + q[:-1]) / 2 - h ** 2 * (np.gradient(q, t, edge_order=2)[1:] -
                                                 np.gradient(q, t, edge_order=2)[:-1]) / 12 for q in powers]


def _gauss_on(sol, t: np.ndarray, power, pieces: int) -> list[np.ndarray]:
    """Each power's integral over each output interval by 3-point Gauss on `pieces` equal
    sub-intervals, on the continuous solution."""
    nodes, weights = GAUSS
    edges = t[:-1, None] + (t[1:] - t[:-1])[:, None] * np.linspace(0.0, 1.0, pieces + 1)[None, :]
    mid, half = (edges[:, 1:] + edges[:, :-1]) / 2, (edges[:, 1:] - edges[:, :-1]) / 2
    at = (mid[..., None] + half[..., None] * nodes).ravel()
    shape = mid.shape + (len(nodes),)
    return [((q.reshape(shape) * weights).sum(axis=2) * half).sum(axis=1) for q in power(at, sol(at))]


def gauss_converged(result, t: np.ndarray, power) -> tuple[list[np.ndarray], int]:
    """The Gauss sums, pieces doubled until the running sums move by less than CONVERGED
    of the energy scale: one rule per output interval is far from enough for a fast
    motion sampled coarsely."""
    tol = CONVERGED * float(result.energy_scale)
    pieces, parts = 1, _gauss_on(result.sol, t, power, 1)
    while pieces < MAX_PIECES:
        finer = _gauss_on(result.sol, t, power, 2 * pieces)
        change = max(float(np.nanmax(np.abs(np.cumsum(a) - np.cumsum(b)), initial=0.0))
                     for a, b in zip(parts, finer))
        pieces, parts = 2 * pieces, finer
        if change <= tol:
            break
    return parts, pieces
