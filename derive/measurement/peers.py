"""The tools a user would otherwise pick, run on the same problems.

Each peer integrates the planar double pendulum from y0 to t_end and returns
the final state; the benchmark times it and measures its error against the
same reference as the toolkit's methods.
- SciPy `solve_ivp` (RK45, DOP853) with a `sympy.lambdify` rhs of the derived
  equations -- twice: as plain `sympy.lambdify` gives it (its default, cse=False: every
  expression printed in full, what a user gets without asking) and with cse=True
  (common subexpressions computed once, the stronger peer) -- and with a hand-written
  NumPy rhs;
- SciPy `odeint` (LSODA), with the hand-written NumPy rhs and with a
  numba-jitted rhs (where numba is installed);
- a numba-compiled RK4 loop, where numba is installed;
- a hand-written C RK4 loop (derive/measurement/c/peers/planar_rk4_hand.c), compiled here.

Throughput peers (many trajectories, fixed-step RK4): a vectorised NumPy RK4
written by hand, a numba `parallel=True` RK4 over the batch, and the
hand-written C RK4 loop run over the batch (derive/measurement/c/peers/planar_rk4_batch_hand.c).
Every numba peer returns None when numba does not import; the benchmark says so.

The hand-written equations are written once a language: planar_accelerations in Python
(called with math's, NumPy's or heyoka's sin and cos, and compiled by numba) and
derive/measurement/c/planar_hand.c in C.
"""
from __future__ import annotations

import ctypes
import importlib
import math
from functools import cache

import numpy as np
import sympy as sp

from ..derivation import derive
from ..paths import bench_c_dir
from ..runtime.loader import build
from ..runtime.shared_library import SharedLibrary


def planar_accelerations(sin, cos):
    """The planar double pendulum's accelerations written by hand, seed 000 (1.34)-(1.35).

    Parameters
    ----------
    sin, cos : callable
        math's for one state, NumPy's for arrays of states, heyoka's for its expressions;
        numba compiles the function made with math's.

    Returns
    -------
    callable
        accelerations(th1, th2, w1, w2, m1, m2, l1, l2, g) -> (th1'', th2'').
    """
    def accelerations(th1, th2, w1, w2, m1, m2, l1, l2, g):
        mu = 1.0 + m1 / m2
        d = th1 - th2
        s, c = sin(d), cos(d)
        a, b, e = mu * l1 * l1, l1 * l2 * c, l2 * l2
        f1 = -w2 * w2 * l1 * l2 * s - mu * g * l1 * sin(th1)
        f2 = w1 * w1 * l1 * l2 * s - g * l2 * sin(th2)
        det = a * e - b * b
        return (e * f1 - b * f2) / det, (a * f2 - b * f1) / det
    return accelerations


_scalar_accelerations = planar_accelerations(math.sin, math.cos)
_array_accelerations = planar_accelerations(np.sin, np.cos)


def have_numba() -> bool:
    """Whether numba imports (its peers run only then)."""
    try:
        importlib.import_module("numba")
    except ImportError:
        return False
    return True


@cache
def _numba_accelerations():
    """planar_accelerations compiled by numba (for the numba peers, which check that it imports)."""
    import numba    # the bench extra: a peer
    return numba.njit(cache=False)(_scalar_accelerations)


def hand_numpy_rhs(t, y, m1, m2, l1, l2, g):
    """Seed 000 (1.34)-(1.35) by hand, scalar state, as a SciPy user writes it."""
    a1, a2 = _scalar_accelerations(y[0], y[1], y[2], y[3], m1, m2, l1, l2, g)
    return np.array([y[2], y[3], a1, a2])


@cache
def derivation_rhs(model: str):
    """(args, exprs) of y' = (q', M^-1 F) from the derivation: `sympy.lambdify(args, exprs, ...)`
    gives f(y, p).  Solved once per model (both lambdify peers and the mpmath check use it)."""
    d = derive(model)
    qdd = d.M.LUsolve(d.F)
    return [d.symbols.state, d.symbols.params], list(d.symbols.qd) + list(qdd)


@cache
def lambdified_rhs(model: str = "planar", cse: bool = True):
    """y' = (q', M^-1 F) lambdified from the derivation, the usual SymPy route.

    cse=False is `sympy.lambdify`'s default (what a user gets from the plain call);
    cse=True eliminates common subexpressions first, a stronger peer (fewer operations
    per evaluation)."""
    f = sp.lambdify(*derivation_rhs(model), "numpy", cse=cse)
    return lambda t, y, *p: np.array(f(y, p))


def solve_ivp_final(rhs, y0, t_end, params, method: str, rtol: float, atol: float):
    from scipy.integrate import solve_ivp    # the bench extra: a peer
    sol = solve_ivp(rhs, (0.0, t_end), y0, method=method, rtol=rtol, atol=atol, args=tuple(params))
    return sol.y[:, -1], sol.nfev


def odeint_final(rhs, y0, t_end, params, rtol: float, atol: float):
    from scipy.integrate import odeint    # the bench extra: a peer
    y, info = odeint(rhs, y0, [0.0, t_end], args=tuple(params), rtol=rtol, atol=atol,
                     tfirst=True, full_output=True, mxstep=10**7)
    return y[-1], int(info["nfe"][-1])


@cache
def numba_rk4():
    """A numba-compiled RK4 loop over the hand-written rhs, or None without numba."""
    try:
        import numba    # the bench extra: a peer
    except ImportError:
        return None
    acc = _numba_accelerations()

    @numba.njit(cache=False, fastmath=False)
    def rhs(y, m1, m2, l1, l2, g, out):
        out[0], out[1] = y[2], y[3]
        out[2], out[3] = acc(y[0], y[1], y[2], y[3], m1, m2, l1, l2, g)

    @numba.njit(cache=False)
    def rk4(y0, p, h, n):
        y = y0.copy()
        k1, k2, k3, k4, tmp = np.empty(4), np.empty(4), np.empty(4), np.empty(4), np.empty(4)
        m1, m2, l1, l2, g = p[0], p[1], p[2], p[3], p[4]
        for _ in range(n):
            rhs(y, m1, m2, l1, l2, g, k1)
            tmp[:] = y + 0.5 * h * k1
            rhs(tmp, m1, m2, l1, l2, g, k2)
            tmp[:] = y + 0.5 * h * k2
            rhs(tmp, m1, m2, l1, l2, g, k3)
            tmp[:] = y + h * k3
            rhs(tmp, m1, m2, l1, l2, g, k4)
            y += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        return y

    rk4(np.zeros(4), np.ones(5), 0.01, 1)    # compile now, not inside a timing
    return rk4


def _hand_c(source: str, symbol: str, *argtypes):
    """A function of a hand-written C peer (derive/measurement/c/peers/<source>), compiled into the build cache."""
    fn = SharedLibrary(build(bench_c_dir() / "peers" / source)).lib[symbol]
    fn.restype = None
    fn.argtypes = list(argtypes)
    return fn


_DPTR = np.ctypeslib.ndpointer(np.float64, flags="C_CONTIGUOUS")


@cache
def hand_c_rk4():
    """The hand-written C RK4 loop, compiled into the build cache."""
    fn = _hand_c("planar_rk4_hand.c", "hand_planar_rk4", _DPTR, _DPTR, ctypes.c_double, ctypes.c_long)

    def run(y0, p, h, n):
        y = np.array(y0, dtype=np.float64)
        fn(y, np.asarray(p, dtype=np.float64), h, n)
        return y
    return run


@cache
def numba_rhs():
    """The hand-written rhs jitted by numba, called by odeint like a Python function
    (the LSODA peer of the quoted figures, analysis.QUOTED_FIGURES); None without numba."""
    try:
        import numba    # the bench extra: a peer
    except ImportError:
        return None
    acc = _numba_accelerations()

    @numba.njit(cache=False)
    def rhs(t, y, m1, m2, l1, l2, g):
        out = np.empty(4)
        out[0], out[1] = y[2], y[3]
        out[2], out[3] = acc(y[0], y[1], y[2], y[3], m1, m2, l1, l2, g)
        return out

    rhs(0.0, np.zeros(4), 1.0, 1.0, 1.0, 1.0, 9.81)     # compile now
    return rhs


# -- throughput peers: many trajectories, fixed-step RK4 ---------------------------

def hand_numpy_rhs_batch(y, m1, m2, l1, l2, g):
    """Seed 000 (1.34)-(1.35) by hand on arrays y (B, 4), as a NumPy user writes it."""
    th1, th2, w1, w2 = y[:, 0], y[:, 1], y[:, 2], y[:, 3]
    a1, a2 = _array_accelerations(th1, th2, w1, w2, m1, m2, l1, l2, g)
    return np.stack([w1, w2, a1, a2], axis=1)


def numpy_rk4_batch(y0, p, h: float, n: int) -> np.ndarray:
    """Vectorised RK4 over the batch y0 (B, 4), written by hand."""
    y = np.array(y0, dtype=np.float64)
    args = tuple(float(v) for v in p)
    for _ in range(n):
        k1 = hand_numpy_rhs_batch(y, *args)
        k2 = hand_numpy_rhs_batch(y + 0.5 * h * k1, *args)
        k3 = hand_numpy_rhs_batch(y + 0.5 * h * k2, *args)
        k4 = hand_numpy_rhs_batch(y + h * k3, *args)
        y = y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return y


@cache
def numba_rk4_parallel():
    """RK4 over a batch y0 (B, 4) with numba prange (all cores); None without numba."""
    try:
        import numba    # the bench extra: a peer
    except ImportError:
        return None
    acc = _numba_accelerations()

    @numba.njit(parallel=True, cache=False)
    def rk4_batch(y0, p, h, n):
        y = y0.copy()
        m1, m2, l1, l2, g = p[0], p[1], p[2], p[3], p[4]
        for i in numba.prange(y.shape[0]):
            a0, a1, a2, a3 = y[i, 0], y[i, 1], y[i, 2], y[i, 3]
            k = np.empty((4, 4))
            for _ in range(n):
                for st in range(4):
                    if st == 0:
                        s0, s1, s2, s3 = a0, a1, a2, a3
                    else:
                        f = 0.5 * h if st < 3 else h
                        s0 = a0 + f * k[st - 1, 0]
                        s1 = a1 + f * k[st - 1, 1]
                        s2 = a2 + f * k[st - 1, 2]
                        s3 = a3 + f * k[st - 1, 3]
                    k[st, 0], k[st, 1] = s2, s3
                    k[st, 2], k[st, 3] = acc(s0, s1, s2, s3, m1, m2, l1, l2, g)
                a0 += h / 6.0 * (k[0, 0] + 2.0 * k[1, 0] + 2.0 * k[2, 0] + k[3, 0])
                a1 += h / 6.0 * (k[0, 1] + 2.0 * k[1, 1] + 2.0 * k[2, 1] + k[3, 1])
                a2 += h / 6.0 * (k[0, 2] + 2.0 * k[1, 2] + 2.0 * k[2, 2] + k[3, 2])
                a3 += h / 6.0 * (k[0, 3] + 2.0 * k[1, 3] + 2.0 * k[2, 3] + k[3, 3])
            y[i, 0], y[i, 1], y[i, 2], y[i, 3] = a0, a1, a2, a3
        return y

    rk4_batch(np.zeros((2, 4)), np.ones(5), 0.01, 1)     # compile now
    return rk4_batch


@cache
def hand_c_rk4_batch():
    """The hand-written C RK4 loop over a batch (B, 4), one trajectory after another."""
    fn = _hand_c("planar_rk4_batch_hand.c", "hand_planar_rk4_batch",
                 ctypes.c_long, _DPTR, _DPTR, ctypes.c_double, ctypes.c_long)

    def run(y0, p, h, n):
        y = np.array(y0, dtype=np.float64).reshape(-1, 4)
        fn(len(y), y, np.asarray(p, dtype=np.float64), h, n)
        return y
    return run
