"""Throughput: trajectory-steps per second of batched fixed-step RK4 on planar states,
the generated C and NumPy batches against their peers, and the batches' agreement with
the scalar generated RK4."""
from __future__ import annotations

import math
import os
import statistics
import time

import numpy as np

from .. import peers as P
from . import toolkit
from .problems import G, BenchOptions

THROUGHPUT_BATCHES = (10_000, 100_000, 1_000_000)
THROUGHPUT_WORK = 20_000_000          # trajectory-steps per timed C run
THROUGHPUT_H = 0.01


def throughput_states(n: int, seed: int = 0) -> np.ndarray:
    """n random planar states (B, 4): angles uniform in [-pi, pi], rates in [-3, 3]."""
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-np.pi, np.pi, (n, 2)), rng.uniform(-3, 3, (n, 2))])


def _rate(fn, B: int, nsteps: int, repeats: int) -> tuple[float, int]:
    fn(1)                                  # warm-up (and numba compilation)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(nsteps)
        times.append(time.perf_counter() - t0)
    return B * nsteps / statistics.median(times), len(times)


def _row(path: str, batch: int, threads: int, steps: int, rate: float, repeats: int, note: str = "") -> dict:
    return {"path": path, "batch": batch, "threads": threads, "steps": steps, "rate": rate,
            "repeats": repeats, "note": note}


def _c_batch_rows(opts: BenchOptions, p, h, reps: int) -> list[dict]:
    rk4_soa = toolkit.c_batch_rk4("planar", soa=True)
    note = "libmvec vector sin/cos" if toolkit.c_batch_vector_math("planar") else "scalar libm (no libmvec)"
    batches = (10_000, 100_000) if opts.quick else THROUGHPUT_BATCHES
    work = THROUGHPUT_WORK // (10 if opts.quick else 1)
    rows = []
    for B in batches:
        Y = np.ascontiguousarray(throughput_states(B).T)
        nsteps = max(5, work // B)
        for threads in sorted({1, os.cpu_count() or 1}):
            def fn(k, threads=threads):
                rk4_soa(Y.copy(), p, h, k, threads=threads)
            rate, n = _rate(fn, B, nsteps, reps)
            rows.append(_row("generated C batch RK4 (SoA, vectorised)", B, threads, nsteps, rate, n, note))
    return rows


def _numpy_batch_rows(opts: BenchOptions, p, h, reps: int) -> list[dict]:
    gen_np = toolkit.numpy_batch_rk4("planar")
    rows = []
    for B in ((10_000,) if opts.quick else (10_000, 100_000)):
        y0 = throughput_states(B)
        Y = np.ascontiguousarray(y0.T)
        nsteps = max(2, 2_000_000 // B // (5 if opts.quick else 1))
        rate, n = _rate(lambda k: gen_np(Y, p, h, k), B, nsteps, reps)
        rows.append(_row("generated NumPy batch RK4 (SoA)", B, 1, nsteps, rate, n,
                         "sin/cos from half-angle tangents"))
        rate, n = _rate(lambda k: P.numpy_rk4_batch(y0, p, h, k), B, nsteps, reps)
        rows.append(_row("peer: hand-written vectorised NumPy RK4", B, 1, nsteps, rate, n))
    return rows


def _one_after_another_rows(opts: BenchOptions, p, h, reps: int) -> list[dict]:
    B = 10_000
    y0 = throughput_states(B)
    nsteps = 20 if opts.quick else 100
    hc = P.hand_c_rk4_batch()
    rate, n = _rate(lambda k: hc(y0, p, h, k), B, nsteps, reps)
    rows = [_row("peer: hand-written C RK4 loop over the batch", B, 1, nsteps, rate, n, "scalar, cc -O2")]
    scalar = toolkit.scalar_rk4("planar", h)
    rate, n = _rate(lambda k: scalar(y0, p, k), B, nsteps, reps)
    rows.append(_row("generated C scalar RK4 (planar_integrate_batch)", B, 1, nsteps, rate, n,
                     "one trajectory after another"))
    return rows


def _numba_rows(opts: BenchOptions, p, h, reps: int) -> list[dict]:
    if not P.have_numba():
        return [_row("peer: numba parallel RK4 (prange)", 0, 0, 0, float("nan"), 0, "numba not installed: not run")]
    if opts.quick:
        return []
    nb = P.numba_rk4_parallel()
    B2 = 100_000
    y2 = throughput_states(B2)
    rate, n = _rate(lambda k: nb(y2, p, h, k), B2, 20, reps)
    return [_row("peer: numba parallel RK4 (prange)", B2, os.cpu_count() or 1, 20, rate, n)]


def run_throughput(opts: BenchOptions) -> list[dict]:
    """trajectory-steps per second of batched fixed-step RK4 on planar states.

    Parameters
    ----------
    opts : BenchOptions
        `quick`: smaller batches and fewer steps, no numba peer.

    Returns
    -------
    list of dict
        One row a path and batch (path, batch, threads, steps, rate, repeats, note).
    """
    p = np.array([1.0, 1.0, 1.0, 1.0, G])
    h, reps = THROUGHPUT_H, 3
    return (_c_batch_rows(opts, p, h, reps) + _numpy_batch_rows(opts, p, h, reps)
            + _one_after_another_rows(opts, p, h, reps) + _numba_rows(opts, p, h, reps))


def numpy_trig_costs(n: int = 10_000, reps: int = 50) -> dict[str, float]:
    """ns per element of numpy.sin, numpy.cos and numpy.tan on float64 arrays of n angles:
    why the generated NumPy code takes sin and cos from half-angle tangents."""
    x = throughput_states(n)[:, 0].copy()
    out = {}
    for name in ("sin", "cos", "tan"):
        f = getattr(np, name)
        best = math.inf
        for _ in range(reps):
            t0 = time.perf_counter()
            f(x)
            best = min(best, time.perf_counter() - t0)
        out[name] = best / n * 1e9
    return out


def throughput_agreement(n: int = 10_000, nsteps: int = 100) -> dict:
    """Batched C and NumPy RK4 against the scalar generated RK4: max difference after
    nsteps steps of THROUGHPUT_H (t = 1, inside the trust horizon of these states)."""
    p = np.array([1.0, 1.0, 1.0, 1.0, G])
    y0 = throughput_states(n, seed=1)
    ref = toolkit.scalar_rk4("planar", THROUGHPUT_H)(y0, p, nsteps)
    yc, _, _ = toolkit.c_batch_rk4("planar")(y0, p, THROUGHPUT_H, nsteps, threads=2)
    yn, _, _ = toolkit.numpy_batch_rk4("planar")(y0.T, p, THROUGHPUT_H, nsteps)
    dc = np.max(np.abs(yc - ref), axis=1)
    dn = np.max(np.abs(yn.T - ref), axis=1)
    return {"n": n, "steps": nsteps, "t": THROUGHPUT_H * nsteps, "c_max": float(dc.max()),
            "numpy_max": float(dn.max()), "c_over": int((dc > 1e-12).sum()),
            "numpy_over": int((dn > 1e-12).sum())}
