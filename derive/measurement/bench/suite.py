"""The whole benchmark: every configuration of every selected problem, timed and measured,
the rhs cost the overhead is measured in, and the throughput runs, into one BenchResult."""
from __future__ import annotations

import datetime as _dt
import importlib.util
import os
import platform
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

from .. import peers as P, reference as R
from .accuracy import ProblemInfo, measure, problem_info
from .batch_rates import numpy_trig_costs, run_throughput, throughput_agreement
from .peer_series import peer_configs
from .problems import BenchOptions, Config, Problem, knob, selected_problems
from .timing import rhs_cost_ns, timed_rounds
from .toolkit_series import toolkit_configs


@dataclass
class BenchResult:
    rows: list[dict]
    infos: dict[str, ProblemInfo]
    rhs_ns: dict[str, float]                            # chained (rhs_cost_ns)
    rhs_ns_independent: dict[str, float] = field(default_factory=dict)
    throughput: list[dict] = field(default_factory=list)
    agreement: dict | None = None
    numpy_trig: dict = field(default_factory=dict)      # ns per element of numpy.sin/cos/tan
    machine: dict = field(default_factory=dict)
    options: BenchOptions | None = None
    seconds: float = 0.0
    notes: list[str] = field(default_factory=list)


def _module_ok(name: str) -> bool:
    return importlib.util.find_spec(name) is not None


def _missing_extras(opts: BenchOptions) -> list[str]:
    notes = []
    if opts.peers and not _module_ok("scipy"):
        notes.append("scipy not installed: the solve_ivp and odeint peers were not run")
    if opts.peers and not P.have_numba():
        notes.append("numba not installed: the numba peers were not run")
    return notes


def _configs(prob: Problem, opts: BenchOptions) -> list[Config]:
    """The toolkit's configurations of a problem, then the peers' that can run here."""
    cfgs = toolkit_configs(prob, opts)
    if opts.peers and _module_ok("scipy"):
        cfgs += peer_configs(prob, opts)
    elif opts.peers and prob.model == "planar":
        cfgs += [c for c in peer_configs(prob, opts) if "solve_ivp" not in c.series
                 and "odeint" not in c.series]
    return cfgs


def run_bench(opts: BenchOptions) -> BenchResult:
    """Run the benchmark.

    Parameters
    ----------
    opts : BenchOptions
        The problems, the sweep (quick or full), repeats, peers and throughput.

    Returns
    -------
    BenchResult
        One row a configuration, each problem's reference and horizon, the rhs costs,
        the throughput rows and the machine.

    Raises
    ------
    ValueError
        An unknown problem name.
    """
    start = time.perf_counter()
    problems = selected_problems(opts)
    notes = _missing_extras(opts)
    plans = [(prob, _configs(prob, opts)) for prob in problems]
    total = len(problems) + 2 * sum(len(c) for _, c in plans) + (2 if opts.throughput else 0)
    done = 0

    def tick(label=""):
        nonlocal done
        done += 1
        if opts.progress:
            opts.progress(done, total, label)

    machine = machine_info()
    rhs_ns = {p.name: rhs_cost_ns(p, chained=True) for p in problems}
    rhs_ns_independent = {p.name: rhs_cost_ns(p, chained=False) for p in problems}
    infos, rows = {}, []
    for prob, cfgs in plans:
        info = problem_info(prob, opts)
        if opts.mpmath and not opts.quick and prob.name == "chaotic":
            info.mpmath_t = 0.5
            info.mpmath_error = R.mpmath_check(prob, info.mpmath_t)
        infos[prob.name] = info
        tick(f"{prob.name} reference")
        cache: dict = {}
        timings = timed_rounds(cfgs, opts.repeats, tick)
        for c, t in zip(cfgs, timings):
            rows.append(measure(c, info, opts, cache, rhs_ns, t))
            tick(f"{prob.name} {c.series} {knob(rows[-1])}")
    result = BenchResult(rows, infos, rhs_ns, rhs_ns_independent, machine=machine, options=opts, notes=notes)
    if opts.throughput:
        result.agreement = throughput_agreement(2_000 if opts.quick else 10_000)
        tick("throughput agreement")
        result.throughput = run_throughput(opts)
        result.numpy_trig = numpy_trig_costs()
        tick("throughput")
    result.seconds = time.perf_counter() - start
    return result


def _cpu_name() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return cpu


def _versions() -> dict[str, str]:
    versions = {}
    for mod in ("numpy", "scipy", "numba", "sympy", "matplotlib"):
        try:
            versions[mod] = __import__(mod).__version__
        except ImportError:
            versions[mod] = "not installed"
    return versions


def machine_info() -> dict:
    """Where and when the benchmark ran: date, CPU, cores, platform, Python, the compiler,
    the load average and the versions of the numerical packages."""
    try:
        cc = subprocess.run([os.environ.get("CC", "cc"), "--version"], capture_output=True,
                            text=True).stdout.splitlines()[0]
    except (OSError, IndexError):
        cc = "unknown"
    try:
        load = " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        load = "unknown"
    return {"date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "cpu": _cpu_name(), "nproc": os.cpu_count() or 1, "platform": platform.platform(),
            "python": platform.python_version(), "compiler": cc, "loadavg": load, **_versions()}
