"""The tools a user would otherwise pick, run on the same problems.

Each peer integrates the planar double pendulum from y0 to t_end and returns
the final state; the benchmark times it and measures its error against the
same reference as the toolkit's methods.
- SciPy `solve_ivp` (RK45, DOP853) with a `sympy.lambdify` rhs of the derived
  equations, and with a hand-written NumPy rhs;
- SciPy `odeint` (LSODA);
- a numba-compiled RK4 loop, where numba is installed;
- a hand-written C RK4 loop (bench/peers/planar_rk4_hand.c), compiled here.
"""
from __future__ import annotations

import ctypes
import math
from functools import cache
from pathlib import Path

import numpy as np
import sympy as sp

from ..derivation import derive

BENCH = Path(__file__).resolve().parents[2] / "bench"


def hand_numpy_rhs(t, y, m1, m2, l1, l2, g):
    """Seed 000 (1.34)-(1.35) by hand, scalar state, as a SciPy user writes it."""
    mu = 1.0 + m1 / m2
    d = y[0] - y[1]
    s, c = math.sin(d), math.cos(d)
    a, b, e = mu * l1 * l1, l1 * l2 * c, l2 * l2
    f1 = -y[3] * y[3] * l1 * l2 * s - mu * g * l1 * math.sin(y[0])
    f2 = y[2] * y[2] * l1 * l2 * s - g * l2 * math.sin(y[1])
    det = a * e - b * b
    return np.array([y[2], y[3], (e * f1 - b * f2) / det, (a * f2 - b * f1) / det])


@cache
def lambdified_rhs(model: str = "planar"):
    """y' = (q', M^-1 F) lambdified from the derivation, the usual SymPy route."""
    d = derive(model)
    qdd = d.M.LUsolve(d.F)
    f = sp.lambdify([d.symbols.state, d.symbols.params], list(d.symbols.qd) + list(qdd), "numpy",
                    cse=True)
    return lambda t, y, *p: np.array(f(y, p))


def solve_ivp_final(rhs, y0, t_end, params, method: str, rtol: float, atol: float):
    from scipy.integrate import solve_ivp
    sol = solve_ivp(rhs, (0.0, t_end), y0, method=method, rtol=rtol, atol=atol, args=tuple(params))
    return sol.y[:, -1], sol.nfev


def odeint_final(rhs, y0, t_end, params, rtol: float, atol: float):
    from scipy.integrate import odeint
    y, info = odeint(rhs, y0, [0.0, t_end], args=tuple(params), rtol=rtol, atol=atol,
                     tfirst=True, full_output=True, mxstep=10**7)
    return y[-1], int(info["nfe"][-1])


@cache
def numba_rk4():
    """A numba-compiled RK4 loop over the hand-written rhs, or None without numba."""
    try:
        import numba
    except ImportError:
        return None

    @numba.njit(cache=False, fastmath=False)
    def rhs(y, m1, m2, l1, l2, g, out):
        mu = 1.0 + m1 / m2
        d = y[0] - y[1]
        s, c = math.sin(d), math.cos(d)
        a, b, e = mu * l1 * l1, l1 * l2 * c, l2 * l2
        f1 = -y[3] * y[3] * l1 * l2 * s - mu * g * l1 * math.sin(y[0])
        f2 = y[2] * y[2] * l1 * l2 * s - g * l2 * math.sin(y[1])
        det = a * e - b * b
        out[0], out[1] = y[2], y[3]
        out[2], out[3] = (e * f1 - b * f2) / det, (a * f2 - b * f1) / det

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


@cache
def hand_c_rk4():
    """The hand-written C RK4 loop, compiled into the build cache."""
    from ..codegen.loader import build
    lib = ctypes.CDLL(str(build(BENCH / "peers" / "planar_rk4_hand.c")))
    fn = lib.hand_planar_rk4
    fn.restype = None
    dptr = np.ctypeslib.ndpointer(np.float64, flags="C_CONTIGUOUS")
    fn.argtypes = [dptr, dptr, ctypes.c_double, ctypes.c_long]

    def run(y0, p, h, n):
        y = np.array(y0, dtype=np.float64)
        fn(y, np.asarray(p, dtype=np.float64), h, n)
        return y
    return run
