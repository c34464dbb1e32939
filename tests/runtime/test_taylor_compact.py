"""The Taylor jet's two forms: unrolled (one statement per operation, unrolled by the
compiler at a fixed order) and compact (one loop per segment of alike operations over
index tables).  They compute each node by the same expression of the same operands, so
their coefficients, runs, lanes and extended-precision builds agree bit for bit."""
from __future__ import annotations

from bisect import bisect_right
from pathlib import Path

import numpy as np
import pytest

import derive
from derive.codegen.contract import STATUS, taylor_order
from derive.codegen.taylor import (UNROLL_COST, compact_statements, jet_cost, jet_levels, operation,
                                   rhs_decomposition, unroll_max)
from derive.codegen.taylor_lanes import compact_lane_statements
from derive.errors import SimulationInputError
from derive.runtime.simulate import run_options
from derive.runtime.taylor_lanes_library import taylor_lanes_library
from derive.runtime.taylor_library import JET_ENV, jet_form, size_flags, taylor_library, taylor_options
from tests.parameters import UNIT_VECTOR as PLANAR

ROOT = Path(__file__).resolve().parents[2]
EXOTIC = str(ROOT / "tests" / "data" / "taylor_exotic.toml")          # sqrt, exp and a quotient
FORCED = str(ROOT / "examples" / "models" / "forced_pendulum.toml")    # explicit time


@pytest.fixture(scope="module")
def chain3(tmp_path_factory) -> str:
    """A planar chain of three point masses (a model file)."""
    lines = ['name = "compact_chain3"', "dimension = 2",
             'parameters = ["m1", "m2", "m3", "l1", "l2", "l3", "g"]']
    for i in (1, 2, 3):
        lines += ["[[links]]", 'chart = "planar"', f'length = "l{i}"', f'body = {{ kind = "point", mass = "m{i}" }}']
    path = tmp_path_factory.mktemp("chain") / "compact_chain3.toml"
    path.write_text("\n".join(lines) + "\n")
    return str(path)


CASES = {      # model -> (state, parameters)
    "planar": ([0.7, -0.4, 0.3, 0.9], PLANAR),
    "compound": ([0.5, 1.9, -0.6, 0.4], [1.1, 0.7, 1.3, 0.8, 0.2, 0.05, 9.81]),
    EXOTIC: ([0.6, -0.8], [1.1, 0.9, 9.81, 0.7]),
    FORCED: ([0.4, -0.3], [1.0, 1.2, 9.81, 0.1, 0.5, 1.3]),
    "chain3": ([0.3, -0.5, 0.8, 0.2, -0.4, 0.1], [1.0, 1.2, 0.8, 1.0, 0.9, 1.1, 9.81]),
}


def _model(case: str, chain3: str) -> str:
    return derive.load_model(chain3 if case == "chain3" else case).name


def _states_and_params(case: str, dt) -> tuple[np.ndarray, np.ndarray]:
    y, p = CASES[case]
    return np.array(y, dt), np.array(p, dt)


# -- the C: segments in dependency order ---------------------------------------------------

@pytest.mark.parametrize("case", ["planar", EXOTIC, FORCED, "chain3"])
def test_a_segment_reads_only_what_earlier_segments_computed(case, chain3):
    """Every operand a node reads at the order being computed (the arguments made before
    it) is a state or a node of an earlier segment, in the scalar and the lanes' compact
    jets; every node but the states has one row; a segment's nodes share one level."""
    d = rhs_decomposition(_model(case, chain3))
    level = jet_levels(d)
    scalar = compact_statements(d)
    firsts = [first for first, _, _ in scalar["segments"]]
    assert firsts[0] == d.n and sorted(scalar["row"].values()) == list(range(len(d.ops)))

    def segment(i):           # a node another's statement writes (cos: its sin's) is that one's
        if operation(d.ops[i]).with_previous:
            i -= 1
        return bisect_right(firsts, scalar["row"][i]) - 1

    lanes = compact_lane_statements(d)
    lane_segment = {}
    for s, (first, end, text) in enumerate(lanes["segments"]):
        where = "H" if text.split("(")[1].startswith("H") else "T"
        lane_segment.update(((where, r), s) for r in range(first, end))

    def lane_seg(i):          # a node another's statement writes (cos: its sin's) is that one's
        if operation(d.ops[i]).with_previous:
            i -= 1
        return lane_segment[(lanes["space"][i], lanes["row"][i])]

    for i, op in enumerate(d.ops):
        if op.kind == "var" or operation(op).with_previous:     # cos: written with its sin
            continue
        members = [j for j in scalar["row"] if segment(j) == segment(i)
                   and not operation(d.ops[j]).with_previous]
        assert {level[j] for j in members} == {level[i]}
        for j in op.args[:len(op.args) - operation(op).consts]:
            if j is not None and j < i and d.ops[j].kind != "var":
                assert segment(j) < segment(i), (i, j)
                assert lane_seg(j) < lane_seg(i), (i, j)


def test_the_size_rule(monkeypatch):
    """Unrolled up to the order whose jet costs UNROLL_COST, compact past it and in the
    generic build; the lanes' unrolled through double's orders for a two-link model."""
    monkeypatch.delenv(JET_ENV, raising=False)
    d = rhs_decomposition("planar")
    top = unroll_max(d)
    assert jet_cost(d, top) <= UNROLL_COST < jet_cost(d, top + 1)
    assert jet_form("planar", top) == "unrolled" and jet_form("planar", top + 1) == "compact"
    assert jet_form("planar", None) == "compact"                 # the generic build
    assert jet_form("planar", taylor_order(1e-14), lanes=True) == "unrolled"


def test_the_size_rule_follows_the_model(chain3):
    """The bigger the model, the lower the last unrolled order."""
    assert unroll_max(rhs_decomposition(_model("chain3", chain3))) < unroll_max(rhs_decomposition("planar"))


def test_the_environment_forces_a_form(monkeypatch):
    """$DERIVE_TAYLOR_JET forces a form whatever the size; a bad value is refused in one line."""
    for form in ("compact", "unrolled"):
        monkeypatch.setenv(JET_ENV, form)
        assert jet_form("planar", 4) == jet_form("planar", 30) == jet_form("planar", None) == form
    monkeypatch.setenv(JET_ENV, "auto")
    assert jet_form("planar", 4) == "unrolled"
    monkeypatch.setenv(JET_ENV, "fast")
    with pytest.raises(SimulationInputError, match="DERIVE_TAYLOR_JET must be unrolled, compact or auto") as info:
        jet_form("planar", 4)
    assert "\n" not in str(info.value)


# -- the numbers: the same bits --------------------------------------------------------------

@pytest.mark.parametrize("case", list(CASES))
def test_the_coefficients_are_the_same_bits(case, chain3):
    """Both forms' normalised Taylor coefficients at a fixed order, in float, double and
    long double (a time-dependent model's at a time of its own)."""
    model = _model(case, chain3)
    order = 12
    for dtype, dt in (("float64", np.float64), ("float32", np.float32), ("longdouble", np.longdouble)):
        if case not in ("planar", "chain3") and dtype != "float64":
            continue                   # one model per type beyond double: each is a build of its own
        y, p = _states_and_params(case, dt)
        got = [taylor_library(model, order, dtype, form).coefficients(y, p, t=0.3) for form in ("unrolled", "compact")]
        (status_u, unrolled), (status_c, compact) = got
        assert status_u == status_c == 0
        assert np.all(np.isfinite(unrolled)) and np.any(unrolled[:, order] != 0)
        assert np.array_equal(unrolled, compact), (dtype, np.max(np.abs(unrolled - compact)))


@pytest.mark.parametrize("case", ["planar", "chain3", FORCED])
def test_the_runs_are_the_same_bits(case, chain3):
    """A whole run at a high order (dense output at several times): every output, every
    counter."""
    model = _model(case, chain3)
    y, p = _states_and_params(case, np.float64)
    t = np.linspace(0.0, 2.0, 7)
    opt = taylor_options().options(run_options("taylor", np.float64, t, rtol=1e-14))
    order = taylor_order(1e-14)
    (yu, iu), (yc, ic) = (taylor_library(model, order, "float64", form).run(y[None], p, t, opt)
                          for form in ("unrolled", "compact"))
    assert iu[0].status == ic[0].status == 0 and iu[0].nsteps > 5
    assert np.array_equal(yu, yc)
    assert (iu[0].nsteps, iu[0].nfev, iu[0].local_error) == (ic[0].nsteps, ic[0].nfev, ic[0].local_error)


def _lane_case(chain3):
    """Six trajectories of the 3-link chain, each with its own parameters."""
    model = _model("chain3", chain3)
    rng = np.random.default_rng(3)
    y0 = np.array(CASES["chain3"][0]) + rng.uniform(-0.2, 0.2, (6, 6))
    params = np.array(CASES["chain3"][1]) * rng.uniform(0.9, 1.1, (6, 7))
    return model, y0, params, np.linspace(0.0, 1.5, 4)


def test_the_compact_lanes_are_the_scalar_runs(chain3):
    """The lanes' compact jet, a trajectory per lane with its own parameters, against the
    scalar integrator's unrolled and compact runs of each."""
    model, y0, params, t = _lane_case(chain3)
    opt = taylor_options().options(run_options("taylor", np.float64, t, rtol=1e-12))
    order = taylor_order(1e-12)
    lanes, infos = taylor_lanes_library(model, order, form="compact").run(y0, params, t, opt)
    assert all(i.status == 0 for i in infos)
    for form in ("unrolled", "compact"):
        scalar, _ = taylor_library(model, order, "float64", form).run(y0, params, t, opt)
        assert np.array_equal(lanes, scalar), form


@pytest.mark.slow         # the forced unrolled lanes' build at order 18: about 12 s at -O1
def test_a_forced_unrolled_lanes_build_at_O1_is_the_compact_run(chain3):
    """Past LANES_O2_COST a forced unrolled lanes' jet is built at -O1, and runs the
    compact lanes' numbers, bit for bit."""
    model, y0, params, t = _lane_case(chain3)
    opt = taylor_options().options(run_options("taylor", np.float64, t, rtol=1e-14))
    order = taylor_order(1e-14)
    lanes, _ = taylor_lanes_library(model, order, form="compact").run(y0, params, t, opt)
    forced = taylor_lanes_library(model, order, form="unrolled")
    assert "-O1" in forced.flags
    assert np.array_equal(forced.run(y0, params, t, opt)[0], lanes)


def test_huge_unrolled_jets_compile_at_O1(chain3):
    """A forced unrolled jet past the cost GCC's -O2 handles in seconds and under a
    gigabyte is built at -O1; the compact jet and the jets the rule unrolls at -O2."""
    model = _model("chain3", chain3)
    assert size_flags(model, 18, "unrolled") == () and size_flags(model, 18, "unrolled", lanes=True) == ("-O1",)
    assert size_flags(model, 30, "unrolled") == ("-O1",) and size_flags(model, 60, "compact", lanes=True) == ()
    assert size_flags("planar", taylor_order(1e-14), "unrolled", lanes=True) == ()


def test_a_chart_guard_in_both_forms():
    """A spherical state on its chart's pole: CHART_SINGULAR from both scalar forms and from
    the compact lanes, in that trajectory's lane alone (its neighbours run on, equal to
    the scalar runs)."""
    model = "spherical_std"
    order = 6
    p = np.array([1.0, 1.0, 1.0, 1.0, 9.81])
    y0 = np.array([[1.3, 0.3, 1.6, 0.2, 0.1, 2.0, 0.0, 2.0],
                   [0.0, 0.3, 1.6, 0.2, 0.1, 2.0, 0.0, 2.0],       # sin(theta1) = 0
                   [1.5, -0.2, 1.4, 0.4, -0.1, 2.0, 0.1, 2.0]])
    for form in ("unrolled", "compact"):
        status, _ = taylor_library(model, order, "float64", form).coefficients(y0[1], p, sine_min=0.05)
        assert status == STATUS["CHART_SINGULAR"], form
    t = [0.0, 0.25, 0.5]
    opt = taylor_options().options(run_options("taylor", np.float64, np.array(t), rtol=1e-6))
    lanes, infos = taylor_lanes_library(model, taylor_order(1e-6), form="compact").run(y0, p, np.array(t), opt)
    scalar, sinfos = taylor_library(model, taylor_order(1e-6), "float64", "unrolled").run(y0, p, np.array(t), opt)
    assert [i.status for i in infos] == [i.status for i in sinfos] == [0, STATUS["CHART_SINGULAR"], 0]
    assert np.array_equal(lanes, scalar, equal_nan=True)


@pytest.mark.parametrize("precision", ["double-double", "quad"])
def test_the_extended_builds_are_the_same_bits(precision):
    """Double-double and binary128, compiled without a fixed order in each form."""
    from derive.runtime import extended
    y, p = CASES["planar"]
    got = [extended.ExtendedTaylor("planar", precision, 20, form).coefficients(
        [extended.exact(v, "y") for v in y], [extended.exact(v, "p") for v in p]) for form in ("unrolled", "compact")]
    (status_u, unrolled), (status_c, compact) = got
    assert status_u == status_c == 0 and unrolled == compact


@pytest.mark.parametrize("compiler, flags", [
    ("gcc", ["-std=c99", "-Wshadow", "-Wconversion", "-Wdouble-promotion"]),
    ("clang", ["-std=c99"]),
    ("g++", ["-x", "c++", "-std=c++11"]),
])
def test_the_exotic_jets_compile_warning_free(compiler, flags, tmp_path):
    """The square root, exponential and quotient's statements in both forms (the catalogue's
    jets have none: tests/codegen compiles those), every precision of the file, at a fixed
    order, warnings as errors."""
    import shutil
    import subprocess
    from derive.codegen.sources import c_source
    if shutil.which(compiler) is None:
        pytest.fail(f"{compiler} is required here (tests/run.sh installs it)")
    model = derive.load_model(EXOTIC).name
    source = c_source(model, f"{model}_taylor.c")
    for compact in (0, 1):
        cmd = [compiler, *flags, "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wfloat-equal", "-O2",
               f"-D{model.upper()}_TAYLOR_ORDER=8", f"-D{model.upper()}_TAYLOR_COMPACT={compact}",
               "-c", str(source), "-o", str(tmp_path / f"jet{compact}.o")]
        run = subprocess.run(cmd, capture_output=True, text=True)
        assert run.returncode == 0 and run.stderr == "", f"{' '.join(cmd)}\n{run.stderr}"
