"""The benchmark's problems, sweeps and options, as data, and each problem's prepared state.

A problem is a model, a start and a span; a configuration (Config) is one way of running
it (a toolkit method or a peer, at one tolerance or step), with the callable that
prepares the run.  Fixed steps are rounded to t_end / N with N a multiple of
OBSERVATIONS - 1, so that the observation run (energies) takes the very same steps.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ...runtime.energy_error import relative_change, scale_of
from ...runtime.simulate import normalise_params, normalise_y0

TARGET = 1e-8
RESOLVE = 1e-2            # decorrelation level (times the state's size): never compare beyond
OBSERVATIONS = 41         # output times of the energy run
G = 9.81


@dataclass(frozen=True)
class Problem:
    name: str
    model: str
    y0: tuple            # state, or ("cartesian", 12 numbers) for the spherical atlas
    t_end: float
    params: tuple
    title: str
    base_step: float = 0.02       # largest fixed step of the sweep

    def y0_input(self):
        if self.y0 and self.y0[0] == "cartesian":
            return {"cartesian": list(self.y0[1])}
        return list(self.y0)


PROBLEMS = (
    Problem("regular", "planar", (1.0, 0.5, 0.0, 0.0), 20.0, (1.0, 1.0, 1.0, 1.0, G),
            "planar, regular: y0 = (1.0, 0.5, 0, 0) to t = 20"),
    Problem("chaotic", "planar", (2.5, 2.0, 0.0, 0.0), 5.0, (1.0, 1.0, 1.0, 1.0, G),
            "planar, chaotic: y0 = (2.5, 2.0, 0, 0) to t = 5"),
    Problem("compound", "compound", (1.5, 0.0, 0.0, 0.0), 10.0,
            (1.0, 1.0, 1.0, 1.0, 1.0 / 12.0, 1.0 / 12.0, G),
            "compound, seed 001's setting (uniform rods, L = m l^2/12): theta1 = 1.5 to t = 10"),
    Problem("spherical_pole", "spherical",
            ("cartesian", (0.0, 0.0, -1.0, 0.6, 0.0, -1.8, 1.5, 0.8, 0.0, 3.1, 1.8, 1.2)), 10.0,
            (1.0, 1.0, 1.0, 1.0, G),
            "spherical atlas through the pole: x1 = (0, 0, -1) hanging straight down, to t = 10"),
)

# tolerance and step sweeps of the toolkit's integrators
ADAPTIVE_RTOLS = {"float32": (1e-3, 1e-4, 1e-5),
                  "float64": (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13),
                  "longdouble": (1e-8, 1e-10, 1e-12, 1e-14, 1e-16)}
FIXED_DIVISORS = {"rk4": (1, 2, 4, 8, 16, 32), "midpoint": (1, 2, 4, 8), "gauss2": (1, 2, 4, 8, 16)}
NUMPY_KNOBS = {"dop853": (1e-6, 1e-8, 1e-10), "dopri5": (1e-5, 1e-7), "rk4": (2, 4),
               "midpoint": (2,), "gauss2": (2,)}
QUICK_KNOBS = {"dop853": (1e-9, 1e-12), "rk4": (4, 16)}
# the generated single-trajectory loops (derive/codegen/loops.py, <model>_fixed.c):
# step = base_step / divisor, rounded to the observation grid
LOOP_DIVISORS = {"rk8": (0.25, 0.35, 0.45, 0.6, 0.8, 1.0, 1.5, 2.0, 3.0, 4.0), "rk4": (1, 2, 4, 8, 16, 32, 64)}
# abm12 runs as derive.simulate runs it: the generated integrator with its stability guard
# (Milne's estimate against atol + rtol |y| at simulate's default rtol, which stops a step
# too large); its loop has no guard, so it is not what a user of simulate gets
GUARDED_DIVISORS = {"abm12": (1.5, 2, 2.5, 3, 4, 5, 6, 8, 12)}
QUICK_LOOP_DIVISORS = {"rk8": (0.35, 0.6)}
METHOD_ORDER = {"rk4": 4, "midpoint": 2, "gauss2": 4, "rk8": 8, "abm12": 12}
DTYPE_EPS = {"float32": float(np.finfo(np.float32).eps), "float64": float(np.finfo(np.float64).eps),
             "longdouble": float(np.finfo(np.longdouble).eps)}

PEER_RTOLS = {"RK45": (1e-4, 1e-6, 1e-8, 1e-10), "DOP853": (1e-6, 1e-8, 1e-10, 1e-12, 1e-13),
              "LSODA": (1e-6, 1e-8, 1e-10, 1e-12)}
PEER_DIVISORS = (1, 2, 4, 8, 16, 32, 64)


@dataclass
class BenchOptions:
    problems: tuple[str, ...] | None = None    # names; None: all
    quick: bool = False                        # a small subset, seconds
    repeats: int = 5
    target: float = TARGET
    resolve: float = RESOLVE
    peers: bool = True
    throughput: bool = True
    mpmath: bool = True                        # the reference's mpmath spot check
    progress: Callable | None = None           # progress(done, total, label)


@dataclass
class Config:
    problem: Problem
    kind: str                 # toolkit | peer
    series: str
    method: str
    backend: str
    dtype: str
    rtol: float | None
    step: float | None
    make: Callable            # () -> run; run() -> (final vector, nfev, ok, message)
    observe: Callable | None = None     # () -> relative energy error (untimed)
    note: str = ""


def selected_problems(opts: BenchOptions) -> list[Problem]:
    """The problems a run measures: those named in `opts`, else the quick pair or all.

    Raises
    ------
    ValueError
        A name that is not one of PROBLEMS.
    """
    names = opts.problems or (("regular", "chaotic") if opts.quick else tuple(p.name for p in PROBLEMS))
    known = {p.name: p for p in PROBLEMS}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f"unknown problem '{unknown[0]}' (known: {', '.join(known)})")
    return [known[n] for n in names]


def fixed_step(problem: Problem, divisor: int) -> float:
    """The fixed step base_step / divisor, rounded so that t_end takes a multiple of
    OBSERVATIONS - 1 steps.

    Parameters
    ----------
    problem : Problem
    divisor : int or float
        How many steps of the result fit in one of `problem.base_step`, about.

    Returns
    -------
    float
        t_end / N, N a multiple of OBSERVATIONS - 1.
    """
    per = OBSERVATIONS - 1
    n = per * max(1, round(problem.t_end / (problem.base_step / divisor) / per))
    return problem.t_end / n


def np_dtype(dtype: str):
    """The NumPy scalar type of a precision name (float32, float64, longdouble)."""
    return {"float32": np.float32, "float64": np.float64, "longdouble": np.longdouble}[dtype]


def prepared(problem: Problem):
    """(state, chart) of y0 and the parameters, normalised as derive.simulate does."""
    p = normalise_params(problem.model, list(problem.params))
    state, chart, _ = normalise_y0(problem.model, problem.y0_input(), p)
    return np.asarray(state), chart, p


def energy_scale(problem: Problem, e0: float) -> float:
    """max(|E0|, m g l): what the benchmark's energy errors are relative to, as derive's
    (derive/runtime/energy_error.py)."""
    return float(scale_of(problem.model, problem.params, e0))


def relative_energy_error(E: np.ndarray, problem: Problem) -> float:
    """The largest |E - E[0]| / max(|E[0]|, m g l) of a run's energies; inf when one is not finite."""
    E = np.asarray(E, dtype=np.float64)
    if not np.all(np.isfinite(E)):
        return math.inf
    return float(np.max(relative_change(E, E[0], energy_scale(problem, float(E[0])))))


def knob(r: dict) -> str:
    """A row's or configuration's tolerance or step, as the reports print it."""
    if r.get("rtol") is not None:
        return f"rtol {r['rtol']:.0e}"
    return f"h {r['step']:.3g}" if r.get("step") is not None else ""
