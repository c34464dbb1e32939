"""Independent pieces of one command, run side by side in worker processes (one per core).

SymPy holds the interpreter, so threads do not overlap its work; processes do.  The
workers are forked from the command's process: they start at once, with everything it
has loaded (the models, the derivations in memory), and they hand their results back
pickled (values between processes of one run, never read from a file).  The caller
passes the longest pieces first, so that the last one to finish is short.

``DERIVE_JOBS`` sets how many processes run at once (1: everything in the command's
own process, in order).
"""
from __future__ import annotations

import multiprocessing
import os
from typing import Callable, Sequence

from ..errors import UsageError


def job_count() -> int:
    """How many worker processes a command may run at once: ``$DERIVE_JOBS``, else one per
    core this process may use.

    Returns
    -------
    int
        At least 1.
    """
    text = os.environ.get("DERIVE_JOBS", "").strip()
    if text:
        if not text.isdigit() or int(text) < 1:
            raise UsageError(f"DERIVE_JOBS must be a whole number >= 1, got {text!r}")
        return int(text)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:              # not Linux: the machine's count
        return os.cpu_count() or 1


def _can_fork() -> bool:
    return "fork" in multiprocessing.get_all_start_methods()


def run_all(calls: Sequence[tuple[Callable, tuple]], jobs: int | None = None) -> list:
    """``[f(*args) for f, args in calls]``, the calls shared among worker processes.

    Parameters
    ----------
    calls : sequence of (callable, tuple)
        Independent calls (module-level functions and picklable arguments and results);
        the longest first, for the best balance.
    jobs : int, optional
        Processes at once (default :func:`job_count`); with 1, or one call, or where a
        process cannot be forked, the calls run here, in order.

    Returns
    -------
    list
        The results, in the order of `calls`.  An exception in a call is raised here.
    """
    jobs = min(jobs or job_count(), len(calls))
    if jobs <= 1 or not _can_fork():
        return [f(*args) for f, args in calls]
    # a Pool, not a ProcessPoolExecutor: leaving its block on an exception (Ctrl-C in this
    # process, a call that raised) terminates the workers at once, where the executor
    # would wait for every running call to finish (minutes of derivations after Ctrl-C)
    with multiprocessing.get_context("fork").Pool(jobs) as pool:
        pending = [pool.apply_async(f, args) for f, args in calls]
        return [result.get() for result in pending]
