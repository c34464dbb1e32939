"""The vector instructions of this machine for a build of the Taylor integrators: the
SIMD lanes (taylor_lanes_library.py) run as many trajectories as a vector holds, and the
scalar integrator (taylor_library.py) is built with the same instructions, as scalar code
(three-operand instructions and twice the registers for its unrolled jet), both without
contraction, so that each lane stays bit for bit the scalar run.
"""
from __future__ import annotations

import platform
from functools import lru_cache
from pathlib import Path

# (CPU flag, compiler flags, lanes by scalar type), best first.  The lanes of each level
# are the count that ran a trajectory in the least CPU time (planar, order 12 in double,
# order 7 in float).
SIMD_LEVELS = (
    ("avx512f", ("-mavx2", "-mavx512f"), {"float64": 8, "float32": 8}),
    ("avx2", ("-mavx2",), {"float64": 4, "float32": 8}),
)
PORTABLE_LANES = {"float64": 4, "float32": 4}   # SSE2 pairs on x86-64, else plain loops
EXACT_FLAGS = ("-ffp-contract=off",)            # a fused multiply-add rounds otherwise


@lru_cache(maxsize=1)
def cpu_flags() -> frozenset[str]:
    """The CPU's feature flags (Linux /proc/cpuinfo; elsewhere none known)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("flags"):
                return frozenset(line.split(":", 1)[1].split())
    except OSError:
        pass
    return frozenset()


def simd_build(dtype: str = "float64") -> tuple[tuple[str, ...], int]:
    """(compiler flags, lanes) for this machine and scalar type: the widest vector unit it
    has.  The flags name the instructions (never -march=native), so the build cache, keyed
    by the flags, never hands a library for one CPU to another.

    Parameters
    ----------
    dtype : str
        "float64" or "float32": the lanes' scalar type.

    Returns
    -------
    tuple
        (the compiler flags, the lanes a vector holds); ((), the portable lanes) where no
        level is known.

    Examples
    --------
    >>> flags, lanes = simd_build("float64")
    >>> lanes in (4, 8)
    True
    """
    if platform.machine() in ("x86_64", "AMD64"):
        have = cpu_flags()
        for flag, flags, lanes in SIMD_LEVELS:
            if flag in have:
                return flags, lanes[dtype]
    return (), PORTABLE_LANES[dtype]
