"""The first time a coordinate reaches a level: |q(t)| = c, located to rounding of the run.

Self-contained on purpose (general events for `derive.simulate` may replace it):
it needs only a batch integrator `run(y0, t) -> (y, status)` of an autonomous
system (derive's kernels take no t, and held inputs are constants) whose state is
(coordinates, rates), so q' is in the state beside q.

Method, and why it is accurate:
1. Bracket.  The batch run samples every trajectory at spacing dt.  On each sample
   interval q is interpolated by the cubic Hermite polynomial H through q and q' at
   both ends; |q - H| <= dt^4 / 384 max|q''''| (the classical Hermite remainder).
   An interval is a candidate when max |H| >= c - MARGIN (tested on the bound of H's
   Bernstein control points, which is never below it): a true crossing inside an
   interval that is not a candidate would need an interpolation error above MARGIN.
   Every refined interval measures that error (the coarse H against the fine
   samples of step 2) and a sweep stops with an error if it exceeds MARGIN / 2,
   so the margin is checked on the very motion it guards, not assumed.  (For the
   flip map, dt = 0.04, the largest error measured on 6000 random starts is 8e-5,
   60 times below MARGIN / 2; it implies max|q| of about 1e4.)
2. Refine.  Each candidate interval is integrated again, from the sample at its
   start, with FINE outputs inside it (a second batch run of all candidates at
   once).  On the fine intervals (h = dt / FINE) the Hermite remainder is FINE^4 =
   10^6 times smaller: about 1e-13 for the flip map, so the fine cubic's first
   crossing is the run's crossing to about 1e-13 / |q'| (a graze, q' -> 0, is the
   one case where this grows: like the square root of it over |q''|).
3. Root.  The first root of sigma H(s) - c (sigma = +1, -1 for the two signs of q)
   on the first fine interval where it has one: the interval is cut at the cubic's
   critical points into monotone pieces, and the first piece whose end reaches c
   holds the root, found by bisection to the last bit.
What remains is the error of the trajectory itself (the integrator's tolerance grown
by the motion), divided by |q'| at the crossing: the method and tolerance decide it,
which is why the flip-map benchmark measures it against an independent integrator.

A start with |q(t0)| >= c is an event at t0.  A candidate that does not cross is
dropped and the search goes on after it.
"""
from __future__ import annotations

import numpy as np

from ..errors import SimulationError

MARGIN = 1e-2          # candidate intervals: max |H| within this of the level (units of q)
FINE = 32              # fine outputs per refined interval
BISECTIONS = 64        # halvings of a monotone piece: past the resolution of a double
SAME_SPACING = 1e-12   # relative: sample spacings this close are one (a grid's rounding)
largest_error = [0.0]  # the largest coarse interpolation error met in this process (bench/sweep.py)


def hermite(q0, v0, q1, v1, h):
    """Coefficients (a0, a1, a2, a3) of H(s) = sum a_k s^k, s in [0, 1], through q and q' = v."""
    d = q1 - q0
    return q0, h * v0, 3 * d - h * (2 * v0 + v1), -2 * d + h * (v0 + v1)


def _value(a, s):
    return a[0] + s * (a[1] + s * (a[2] + s * a[3]))


def _critical(a):
    """The two critical points of H (roots of H'), clipped into [0, 1] (NaN-free)."""
    A, B, C = 3 * a[3], 2 * a[2], a[1]
    disc = B * B - 4 * A * C
    root = np.sqrt(np.maximum(disc, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        linear = np.where(B != 0, -C / np.where(B != 0, B, 1.0), 0.0)
        s1 = np.where(A != 0, (-B - root) / (2 * np.where(A != 0, A, 1.0)), linear)
        s2 = np.where(A != 0, (-B + root) / (2 * np.where(A != 0, A, 1.0)), linear)
    real = (disc >= 0) | (A == 0)
    s1 = np.where(real, s1, 0.0)
    s2 = np.where(real, s2, 0.0)
    s1, s2 = np.clip(np.minimum(s1, s2), 0, 1), np.clip(np.maximum(s1, s2), 0, 1)
    return s1, s2


def max_abs(a) -> np.ndarray:
    """max over s in [0, 1] of |H(s)|, exactly (ends and critical points)."""
    s1, s2 = _critical(a)
    return np.max(np.abs(np.stack([_value(a, 0.0), _value(a, 1.0), _value(a, s1), _value(a, s2)])), axis=0)


def hull_max_abs(q: np.ndarray, v: np.ndarray, dt: np.ndarray) -> np.ndarray:
    """An upper bound of max |H| on each sample interval, cheaply: H's Bernstein control
    points (q0, q0 + dt v0 / 3, q1 - dt v1 / 3, q1) hold it in their convex hull."""
    third = dt[None, :] / 3
    return np.maximum(np.maximum(np.abs(q[:, :-1]), np.abs(q[:, 1:])),
                      np.maximum(np.abs(q[:, :-1] + third * v[:, :-1]), np.abs(q[:, 1:] - third * v[:, 1:])))


def first_reach(a, level: float) -> np.ndarray:
    """The first s in [0, 1] where |H(s)| reaches `level` (|H(0)| < level), NaN where it does not."""
    s1, s2 = _critical(a)
    cuts = np.stack([np.zeros_like(s1), s1, s2, np.ones_like(s1)])
    ends = np.abs(_value(a, cuts[1:]))                       # |H| at each monotone piece's end
    reached = (ends >= level) & (cuts[1:] > cuts[:-1])
    best = np.full(np.shape(s1), np.nan)
    rows = np.flatnonzero(reached.any(axis=0))
    if rows.size == 0:
        return best
    # the first piece whose end reaches the level holds the first root (the pieces before it
    # stay inside (-level, level)), and of the sign H has there: one bisection per root
    piece = reached[:, rows].argmax(axis=0)
    l, r = cuts[piece, rows], cuts[piece + 1, rows]
    c = tuple(k[rows] for k in a)
    sigma = np.sign(_value(c, r))
    for _ in range(BISECTIONS):                              # sigma H(l) < level <= sigma H(r)
        m = 0.5 * (l + r)
        up = sigma * _value(c, m) - level >= 0
        r = np.where(up, m, r)
        l = np.where(up, l, m)
    best[rows] = r
    return best


def locate(run, y: np.ndarray, t: np.ndarray, index: int, level: float,
           search: np.ndarray | None = None) -> np.ndarray:
    """First times |y[:, :, index]| reaches `level` on the samples y (B, K+1, n) at t (K+1,),
    NaN where it does not within them.
    run(rows, y0, t_local) -> (y, status) integrates trajectories `rows` (indices into B) from y0.
    search: only these trajectories (bool, B)."""
    B, K1, n = y.shape
    rate = index + n // 2
    out = np.full(B, np.nan)
    rows = np.arange(B) if search is None else np.flatnonzero(search)
    if K1 < 2 or rows.size == 0:
        return out
    dt = np.diff(t)
    q, v = y[rows, :, index], y[rows, :, rate]
    started = np.abs(q[:, 0]) >= level
    out[rows[started]] = t[0]
    candidate = (hull_max_abs(q, v, dt) >= level - MARGIN) & ~started[:, None]
    candidate &= np.isfinite(q[:, 1:]) & np.isfinite(q[:, :-1])
    start = np.zeros(rows.size, int)
    while True:
        masked = candidate & (np.arange(K1 - 1)[None, :] >= start[:, None])
        has = masked.any(axis=1)
        if not has.any():
            return out
        which = np.flatnonzero(has)
        j = masked[which].argmax(axis=1)                    # the first candidate interval
        coarse = hermite(q[which, j], v[which, j], q[which, j + 1], v[which, j + 1], dt[j])
        times = _refine(run, rows[which], y[rows[which], j], dt[j], index, level, coarse)
        hit = np.isfinite(times)
        out[rows[which[hit]]] = t[j[hit]] + times[hit]
        candidate[which[hit]] = False                        # found: no further search
        start[which[~hit]] = j[~hit] + 1                      # no crossing: search after it


def _refine(run, rows, y0: np.ndarray, dt: np.ndarray, index: int, level: float, coarse) -> np.ndarray:
    """Time after each start y0 (C, n) at which |q| first reaches level within dt (C,), or NaN.
    The starts have different dt where the sample grid is not uniform: one run per distinct
    dt (the rounding of a uniform grid's spacings, a few ulp, is one: the fine grid then
    misses its end by those ulp, which moves no time found by more than they are)."""
    out = np.full(len(y0), np.nan)
    for h, sel in _spacings(dt):
        local = np.linspace(0.0, h, FINE + 1)
        yf, status = run(rows[sel], y0[sel], local)
        n = yf.shape[2]
        q, v = yf[:, :, index], yf[:, :, index + n // 2]
        _check_margin(tuple(c[sel] for c in coarse), q, local / h)
        a = hermite(q[:, :-1], v[:, :-1], q[:, 1:], v[:, 1:], h / FINE)
        reached = max_abs(a) >= level                                  # (C, FINE): a root inside
        found = reached.any(axis=1) & (status == 0)
        m = reached.argmax(axis=1)[found]                              # the first such interval
        rows_found = np.flatnonzero(found)
        s = first_reach(tuple(c[rows_found, m] for c in a), level)
        times = np.full(sel.sum(), np.nan)
        times[rows_found] = (m + s) * (h / FINE)
        out[sel] = times
    return out


def _spacings(dt: np.ndarray):
    """(h, rows with that dt) for each distinct spacing, those within SAME_SPACING of one another one."""
    values = np.unique(dt)
    firsts = [values[0]]
    for h in values[1:]:
        if h - firsts[-1] > SAME_SPACING * firsts[-1]:
            firsts.append(h)
    group = np.searchsorted(np.array(firsts), dt, side="right") - 1
    return [(h, group == k) for k, h in enumerate(firsts)]


def _check_margin(coarse, q_fine: np.ndarray, s: np.ndarray) -> None:
    """The coarse interpolant against the fine samples: its error must stay below MARGIN / 2."""
    predicted = _value(tuple(c[:, None] for c in coarse), s[None, :])
    error = np.nanmax(np.abs(predicted - q_fine)) if q_fine.size else 0.0
    largest_error[0] = max(largest_error[0], float(error))
    if error > MARGIN / 2:
        raise SimulationError(f"event location: the samples are too far apart for this motion "
                              f"(interpolation error {error:.2g} between samples, more than "
                              f"{MARGIN / 2:g}); give more time.outputs")
