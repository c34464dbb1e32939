"""`derive bench`: the speed/accuracy trade, per model, method, precision and backend,
raced against the tools users would otherwise pick.

For every problem (problems.PROBLEMS) and every configuration (method x tolerance or
step x scalar type x backend, toolkit_series.py; the peers of peers.py on the same
problem, peer_series.py) one row (accuracy.measure): the final-state error against a
long double reference that states its own accuracy (reference.py), the largest relative
energy error over 41 output times, the median wall time of repeated runs (timing.py),
the rhs evaluations, and the trust horizon of the run (trust.py).  From the rows
(analysis.py): the time each method and peer needs to reach a final-state error of
`target` (1e-8; interpolated on the work-precision front), the ratios against the peers
and the benchmark's targets, the integrator overhead (time / (rhs evaluations x cost of
one generated rhs)), and the throughput of the batched RK4 against its peers
(batch_rates.py).  writers.py and plots.py write them; toolkit.py is the one place that
calls derive's compiled code.

    result = run_bench(BenchOptions(quick=True))
    write_all(result, Path("derive-bench"))
"""
from .accuracy import ProblemInfo, local_error, measure, problem_info
from .analysis import best_toolkit, front, series_times, targets, time_to
from .problems import OBSERVATIONS, PROBLEMS, TARGET, BenchOptions, Config, Problem, fixed_step
from .suite import BenchResult, run_bench
from .toolkit_series import toolkit_observer, toolkit_runner
from .writers import CSV_COLUMNS, DEFAULT_OUT, console_report, summary_markdown, write_all

__all__ = ["BenchOptions", "BenchResult", "CSV_COLUMNS", "Config", "DEFAULT_OUT", "OBSERVATIONS", "PROBLEMS",
           "Problem", "ProblemInfo", "TARGET", "best_toolkit", "console_report", "fixed_step", "front",
           "local_error", "measure", "problem_info", "run_bench", "series_times", "summary_markdown", "targets",
           "time_to", "toolkit_observer", "toolkit_runner", "write_all"]
