"""derive bench: a quick run writes the CSV, plots and summary with plausible values; the
reference meets its stated accuracy; runs past their trust horizon are never compared;
the work-precision front and the time-to-target interpolation; the peers run.

No timing assertions (speed belongs in the benchmark itself)."""
import csv
import math
from dataclasses import replace

import numpy as np
import pytest

from derive.cli import main
from derive.measurement import bench as B
from derive.measurement import peers as P
from derive.measurement import reference as R

# one worker runs the file: the module's `derive bench --quick` (the fixture below) is run
# once, not once on each pytest-xdist worker that draws one of its tests
pytestmark = pytest.mark.xdist_group("bench_quick")


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    """`derive bench --quick` on the regular problem, without throughput (that is in
    test_bench_throughput.py), one repeat."""
    out = tmp_path_factory.mktemp("bench")
    code = main(["bench", "--quick", "--problems", "regular", "--no-throughput", "--repeats", "1",
                 "--quiet", "--out", str(out)])
    assert code == 0
    with (out / "bench.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    return out, rows


def test_quick_bench_writes_the_csv_with_the_expected_columns(quick):
    out, rows = quick
    assert tuple(rows[0].keys()) == B.CSV_COLUMNS
    series = {r["series"] for r in rows}
    assert {"dop853 C float64", "rk4 C float64", "dop853 NumPy float64",
            "solve_ivp DOP853 + lambdify (default)", "solve_ivp DOP853 + lambdify (cse=True)",
            "hand-written C RK4"} <= series
    for r in rows:
        assert r["problem"] == "regular" and r["model"] == "planar"
        assert r["status"] == "ok", r
        assert float(r["seconds"]) > 0 and float(r["cpu_seconds"]) > 0 and int(r["nfev"]) > 0
        assert 0 <= float(r["final_error"]) < 1e-3
        assert 0 <= float(r["energy_error"]) < 1e-3
        assert float(r["horizon_resolve"]) >= 20.0


def test_quick_bench_values_are_plausible(quick):
    _, rows = quick
    by = {(r["series"], r["rtol"] or r["step"]): r for r in rows}
    tight, loose = by[("dop853 C float64", "1e-12")], by[("dop853 C float64", "1e-09")]
    assert float(tight["final_error"]) < float(loose["final_error"]) < 1e-6
    assert int(tight["nfev"]) > int(loose["nfev"])
    # the same RK4 step from the generated C and the hand-written loop: the same trajectory
    h = [r for r in rows if r["series"] == "rk4 C float64"][0]["step"]
    gen, hand = by[("rk4 C float64", h)], by[("hand-written C RK4", h)]
    assert math.isclose(float(gen["final_error"]), float(hand["final_error"]), rel_tol=1e-3)
    assert float(gen["overhead"]) > 0.2          # CPU time / (nfev x one rhs): a sane ratio


def test_quick_bench_writes_summary_and_plot(quick):
    out, _ = quick
    md = (out / "summary.md").read_text()
    for text in ("Measured on", "cores", "Time to reach a final-state error of 1e-08", "| regular |",
                 "stated accuracy", "Targets", "dop853 C float64"):
        assert text in md, text
    targets = md.split("## Targets")[1].split("\n\n")[1]
    for peer in ("solve_ivp DOP853 + lambdify (default) -- plain sympy.lambdify, cse=False",
                 "solve_ivp DOP853 + lambdify (cse=True) -- stronger peer"):
        assert f"vs {peer}" in targets, peer
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        assert "matplotlib not installed" in md
        print("matplotlib not installed: the plot was not written (the summary says so)")
    else:
        png = out / "work_precision_regular.png"
        assert png.is_file() and png.read_bytes()[:4] == b"\x89PNG"


def test_reference_meets_its_stated_accuracy_against_mpmath():
    """The long double reference over a short span of the chaotic problem, against
    mpmath's Taylor solver at 24 digits."""
    chaotic = next(p for p in B.PROBLEMS if p.name == "chaotic")
    short = replace(chaotic, t_end=0.5)
    ref = R.compute(short)
    assert ref.accuracy < 1e-15
    err = R.mpmath_check(short, 0.5)
    assert err <= ref.accuracy, (err, ref.accuracy)


def test_chaotic_runs_past_their_trust_horizon_are_not_compared():
    chaotic = next(p for p in B.PROBLEMS if p.name == "chaotic")
    opts = B.BenchOptions(repeats=1, mpmath=False)
    info = B.problem_info(chaotic, opts)
    assert info.lyapunov.exponent > 1.0                       # chaotic
    assert info.reference_horizon >= chaotic.t_end            # the reference resolves 1e-10 there
    cache, rhs = {}, {}
    loose = B.Config(chaotic, "toolkit", "dop853 C float32", "dop853", "c", "float32", 1e-3, None,
                     B.toolkit_runner(chaotic, "dop853", "c", "float32", 1e-3, None),
                     B.toolkit_observer(chaotic, "dop853", "c", "float32", 1e-3, None))
    row = B.measure(loose, info, opts, cache, rhs)
    assert row["status"] == "beyond trust horizon" and "final_error" not in row
    assert row["horizon_resolve"] < chaotic.t_end and row["horizon_target"] == 0.0
    tight = B.Config(chaotic, "toolkit", "dop853 C float64", "dop853", "c", "float64", 1e-12, None,
                     B.toolkit_runner(chaotic, "dop853", "c", "float64", 1e-12, None),
                     B.toolkit_observer(chaotic, "dop853", "c", "float64", 1e-12, None))
    row = B.measure(tight, info, opts, cache, rhs)
    assert row["status"] == "ok" and row["final_error"] < 1e-7
    assert row["horizon_resolve"] > chaotic.t_end


def test_front_and_time_to_target():
    pts = [(1.0, 1e-4), (2.0, 1e-6), (1.5, 1e-3), (4.0, 1e-10), (3.0, 1e-5)]
    assert B.front(pts) == [(1.0, 1e-4), (2.0, 1e-6), (4.0, 1e-10)]
    t = B.time_to(pts, 1e-8)                      # halfway in log error between 1e-6 and 1e-10
    assert math.isclose(t, math.sqrt(2.0 * 4.0))
    assert B.time_to(pts, 1e-3) == 1.0            # the cheapest run is already better
    assert B.time_to(pts, 1e-12) is None          # never reached


def test_fixed_steps_land_on_the_observation_grid():
    for prob in B.PROBLEMS:
        for div in (1, 2, 4, 8, 16, 32, 64):
            n = prob.t_end / B.fixed_step(prob, div)
            assert abs(n - round(n)) < 1e-9 and round(n) % (B.OBSERVATIONS - 1) == 0


def test_peers_agree_with_the_generated_rk4():
    """The hand-written C loop and the numba loop integrate the same RK4 trajectory."""
    p = np.array([1.0, 1.0, 1.0, 1.0, 9.81])
    y0, h, n = [1.0, 0.5, 0.0, 0.0], 0.01, 200
    from derive import simulate
    ref = simulate("planar", y0, [0.0, h * n], p, method="rk4", step=h).y[-1]
    assert np.abs(P.hand_c_rk4()(y0, p, h, n) - ref).max() < 1e-12
    batch = P.hand_c_rk4_batch()(np.array([y0, y0]), p, h, n)
    assert np.abs(batch - ref).max() < 1e-12
    assert np.abs(P.numpy_rk4_batch(np.array([y0]), p, h, n)[0] - ref).max() < 1e-12
    try:
        import numba  # noqa: F401
    except ImportError:
        # Without numba the peers say so (None) rather than fail; the test extra installs numba.
        assert P.numba_rk4() is None and P.numba_rk4_parallel() is None
        return
    assert np.abs(P.numba_rk4()(np.array(y0), p, h, n) - ref).max() < 1e-12
    assert np.abs(P.numba_rk4_parallel()(np.array([y0, y0]), p, h, n) - ref).max() < 1e-12
    y, nfev = P.odeint_final(P.numba_rhs(), y0, 1.0, p, 1e-10, 1e-13)
    ok = simulate("planar", y0, [0.0, 1.0], p, method="dop853", rtol=1e-12).y[-1]
    assert np.abs(y - ok).max() < 1e-7 and nfev > 0


def test_bench_rejects_an_unknown_problem(capsys):
    assert main(["bench", "--quick", "--problems", "nope", "--quiet", "--no-throughput"]) == 2
    assert "unknown problem 'nope'" in capsys.readouterr().err


def test_the_two_lambdify_peers_compute_the_same_rhs():
    """Plain sympy.lambdify (cse=False, its default) and cse=True: the same derivative."""
    p = (1.0, 1.3, 0.9, 1.1, 9.81)
    y = np.array([0.3, -1.2, 0.7, 2.0])
    plain, cse = P.lambdified_rhs("planar", cse=False), P.lambdified_rhs("planar", cse=True)
    assert plain is not cse
    a, b = plain(0.0, y, *p), cse(0.0, y, *p)
    assert np.allclose(a, b, rtol=1e-13, atol=0)
    assert np.allclose(a, P.hand_numpy_rhs(0.0, y, *p), rtol=1e-12, atol=0)


def test_abm12_is_timed_as_simulate_runs_it():
    """The benchmark's abm12 is simulate's: the generated integrator with its stability
    guard at simulate's default rtol (not the guard-free loop).  At h = 0.01 on the regular
    problem it fails as simulate does, naming the guard; at h = 0.005 its final state and
    rhs evaluations are simulate's, bit for bit."""
    from derive import simulate
    from derive.measurement.bench.toolkit_series import toolkit_configs
    problem = next(p for p in B.PROBLEMS if p.name == "regular")
    configs = toolkit_configs(problem, B.BenchOptions())
    assert not [c for c in configs if c.method == "abm12" and c.backend == "c-loop"]
    abm12 = {round(c.step, 6): c for c in configs if c.series == "abm12 C float64"}
    final, nfev, ok, message = abm12[0.01].make()()
    assert not ok and message == ("multistep unstable (step too large for abm12): Milne's error estimate "
                                  "above atol + rtol |y| (rtol 1e-09, atol 1e-12, simulate's defaults)")
    for step in (0.01, 0.005):
        final, nfev, ok, message = abm12[step].make()()
        r = simulate(problem.model, problem.y0_input(), [0.0, problem.t_end], list(problem.params),
                     method="abm12", step=abm12[step].step)
        assert ok == r.ok and nfev == r.nfev
        if ok:
            assert np.array_equal(np.asarray(final, np.float64), r.y[-1])
