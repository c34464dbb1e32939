"""The chart atlas: rule, thresholds, switches, and agreement with an independent
Cartesian formulation (tests/oracles/cartesian_reference.py) through the poles."""
from __future__ import annotations

import ctypes

import numpy as np
import pytest

from tests.oracles.cartesian_reference import simulate as reference  # noqa: E402

from derive.derivation import cartesian
from derive.runtime import simulate  # noqa: E402
from derive.runtime.atlas_runner import atlas_library, numpy_atlas  # noqa: E402
from derive.codegen.integrators import ATLAS_CHARTS  # noqa: E402

# One worker runs this file (--dist loadgroup, tests/run.sh): the spherical atlas is built once
# with a cold cache, not by two workers at the same time.
pytestmark = pytest.mark.xdist_group("spherical_atlas")

M1, M2, L1, L2, G = 1.0, 1.5, 1.0, 0.8, 9.81
P = [M1, M2, L1, L2, G]


def cart(u1, v1, u2, w, l1=L1, l2=L2):
    """12 numbers from link directions and angular-ish velocities (made tangent)."""
    u1, u2 = np.asarray(u1, float), np.asarray(u2, float)
    u1, u2 = u1 / np.linalg.norm(u1), u2 / np.linalg.norm(u2)
    v1, w = np.asarray(v1, float), np.asarray(w, float)
    v1, w = v1 - (v1 @ u1) * u1, w - (w @ u2) * u2
    x1, vv1 = l1 * u1, l1 * v1
    return np.concatenate([x1, x1 + l2 * u2, vv1, vv1 + l2 * w])


def lz_and_energy(r, p=P):
    """Vertical angular momentum and energy at each output, from the chart rows."""
    m1, m2, l1, l2, g = p
    out = []
    for y, ch in zip(r.y, r.chart):
        c = cartesian.state_to_cartesian(ch, y.astype(float), (l1, l2))
        x1, x2, v1, v2 = c[0:3], c[3:6], c[6:9], c[9:12]
        lz = m1 * (x1[0] * v1[1] - x1[1] * v1[0]) + m2 * (x2[0] * v2[1] - x2[1] * v2[0])
        out.append(lz)
    return np.array(out), np.asarray(r.energy, float)


# Through the poles: energetic 3-D motions that pass close to (or exactly through) the
# vertical, where the standard chart is singular.
STARTS = {
    "energetic": cart([0.3, 0.2, -1], [-3.0, 1.0, 0], [0.5, -0.4, -0.7], [2.0, 3.0, 1.0]),
    "through_bottom": cart([0.6, 0.0, -0.8], [-0.8, 0.05, -0.6], [0.0, 0.0, -1.0], [3.0, 0.1, 0.0]),
    "over_the_top": cart([0.2, 0.1, 1.0], [2.0, -1.0, 0.0], [-0.3, 0.2, 1.0], [-2.0, 2.5, 0.5]),
}


@pytest.fixture(scope="module")
def references():
    t = np.linspace(0.0, 10.0, 401)
    return t, {k: reference(c, t, M1, M2, L1, L2, G) for k, c in STARTS.items()}


def test_rule_picks_a_chart_with_every_polar_sine_at_least_one_half():
    """The derived fact behind hysteresis: after the rule of section 5.1, all sines >= 0.5."""
    rng = np.random.default_rng(5)
    worst = 1.0
    units = list(rng.normal(size=(4000, 3)))
    # the hard cases: poles, the x and y axes, and the rule's boundaries
    for a in ([0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0.5, 0, np.sqrt(0.75)],
              [np.sqrt(0.75) * 0.5, np.sqrt(0.75) * np.sqrt(0.75), 0.5]):
        units.append(np.asarray(a, float))
    units = [u / np.linalg.norm(u) for u in units]
    for k in range(0, len(units) - 1):
        c = np.concatenate([units[k], units[k] + units[k + 1], np.zeros(6)])
        chart = cartesian.choose_chart(c, (1.0, 1.0))
        worst = min(worst, min(cartesian.polar_sines(chart, c, (1.0, 1.0))))
    assert worst >= 0.5 - 1e-12, worst


def test_rule_is_the_same_in_c_numpy_and_python():
    lib = atlas_library()
    fn = lib.lib.spherical_atlas_choose_chart
    fn.restype = ctypes.c_int
    fn.argtypes = [ctypes.c_int, ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_double), ctypes.c_double]
    mod = numpy_atlas()
    rng = np.random.default_rng(9)
    p = np.array(P)
    for _ in range(300):
        c = cart(rng.normal(size=3), rng.normal(size=3), rng.normal(size=3), rng.normal(size=3))
        py = cartesian.choose_chart(c, (L1, L2))
        for k, ch in enumerate(ATLAS_CHARTS):
            if min(cartesian.polar_sines(ch, c, (L1, L2))) < 1e-3:
                continue
            y = np.ascontiguousarray(cartesian.cartesian_to_state(ch, c, (L1, L2)))
            cc = fn(k, y.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
                    p.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), 0.5)
            assert ATLAS_CHARTS[cc] == py == ATLAS_CHARTS[mod.choose_chart(k, y, p)]


@pytest.mark.slow      # 50 random states x 3 charts, each through simulate()
def test_cartesian_conversions_round_trip():
    rng = np.random.default_rng(2)
    for _ in range(50):
        c = cart(rng.normal(size=3), rng.normal(size=3), rng.normal(size=3), rng.normal(size=3))
        for ch in ATLAS_CHARTS:
            if min(cartesian.polar_sines(ch, c, (L1, L2))) < 1e-2:
                continue
            y = cartesian.cartesian_to_state(ch, c, (L1, L2))
            assert np.allclose(cartesian.state_to_cartesian(ch, y, (L1, L2)), c, atol=1e-12)
            r = simulate(ch, y, [0.0], P)        # the generated positions agree with the frames
            assert np.allclose(r.positions.reshape(6), c[:6], atol=1e-12)


def test_cartesian_conversions_come_from_the_chart_data():
    """cartesian.py holds no frames: each chart's conversions are built from charts.toml.
    The polar sine is exactly 0 on the chart's singular_axis (data) and 1 across it; the
    Cartesian route agrees with the generated chart-change kernels (1e-12)."""
    from derive.model import load_model
    for ch in ATLAS_CHARTS:
        for link, lc in zip(load_model(ch).links, cartesian.model_charts(ch)):
            assert lc.name == link.chart.name
            axis = np.array([float(c == link.chart.singular_axis) for c in "xyz"])
            assert lc.polar_sine(axis) == 0.0 and lc.polar_sine(-axis) == 0.0
            assert abs(lc.polar_sine(np.roll(axis, 1)) - 1.0) < 1e-15
    assert not hasattr(cartesian, "FRAMES")
    mod = numpy_atlas()
    rng = np.random.default_rng(4)
    for _ in range(20):
        c = cart(rng.normal(size=3), rng.normal(size=3), rng.normal(size=3), rng.normal(size=3))
        for a, src in enumerate(ATLAS_CHARTS):
            y = cartesian.cartesian_to_state(src, c, (L1, L2))
            for b, dst in enumerate(ATLAS_CHARTS):
                if a == b or min(cartesian.polar_sines(dst, c, (L1, L2))) < 0.1:
                    continue
                st, k = mod.convert(a, b, y)
                assert st == 0 and np.allclose(k, cartesian.cartesian_to_state(dst, c, (L1, L2)),
                                               rtol=0, atol=1e-12), (src, dst)


@pytest.mark.parametrize("chart", ATLAS_CHARTS)
def test_cartesian_conversions_exactly_at_a_pole(chart):
    """A link exactly on its chart's singular axis (polar angle 0 or pi): state_to_cartesian
    puts it there (1e-15, finite); back from Cartesian the polar angle and rate are exact,
    the azimuth is atan2(0, 0) = 0 and its rate 0 (undefined there: the rate formula divides
    by the polar sine; the atlas never converts into a chart at its pole), the other link
    is untouched, and the state maps to the same Cartesian state."""
    from derive.model import load_chart
    lc = cartesian.model_charts(chart)[0]
    axis = np.array([float(c == load_chart(lc.name).singular_axis) for c in "xyz"])
    for polar in (0.0, np.pi):
        y = np.array([polar, 0.0, 1.0, 0.4, 0.7, 0.0, 0.2, -0.3])
        c = cartesian.state_to_cartesian(chart, y, (L1, L2))
        assert np.all(np.isfinite(c)) and min(np.max(np.abs(c[0:3] - s * L1 * axis)) for s in (1, -1)) < 1e-15
        assert cartesian.polar_sines(chart, c, (L1, L2))[0] < 1e-15
        back = cartesian.cartesian_to_state(chart, c, (L1, L2))
        assert np.all(np.isfinite(back)) and abs(back[0] - polar) < 1e-15 and back[1] == 0.0
        assert abs(back[4] - 0.7) < 1e-15 and back[5] == 0.0
        assert np.allclose(back[[2, 3, 6, 7]], y[[2, 3, 6, 7]], rtol=0, atol=1e-12)
        assert np.allclose(cartesian.state_to_cartesian(chart, back, (L1, L2)), c, rtol=0, atol=1e-15)


@pytest.mark.parametrize("start", sorted(STARTS))
@pytest.mark.parametrize("method, kw", [("dop853", dict(rtol=1e-12, atol=1e-14)),
                                        ("dopri5", dict(rtol=1e-12, atol=1e-14)),
                                        ("rk4", dict(step=1e-4)),
                                        ("gauss2", dict(step=2e-4))])
def test_through_the_poles_agrees_with_cartesian_reference(start, method, kw, references):
    """Positions within 1e-8 of the constraint-force Cartesian reference over t = 10
    (over_the_top is chaotic: the reference itself moves by 3e-5 at t = 10 between rtol 1e-12
    and 1e-13, so it is compared up to t = 4, through its first ~6 switches)."""
    t, refs = references
    n = len(t) if start != "over_the_top" else 161
    r = simulate("spherical", {"cartesian": STARTS[start]}, t[:n], P, method=method, **kw)
    assert r.ok, r.message
    err = float(np.max(np.abs(r.positions.reshape(-1, 6) - refs[start][:n, :6])))
    assert err < 1e-8, f"{start} {method}: max position error {err:.3g}, {r.switches} switches"
    # energy and the vertical angular momentum stay continuous (conserved) across switches
    lz, E = lz_and_energy(r)
    assert np.max(np.abs(E - E[0])) < 1e-8 and np.max(np.abs(lz - lz[0])) < 1e-8, \
        (np.max(np.abs(E - E[0])), np.max(np.abs(lz - lz[0])))


def test_switches_happen_and_do_not_chatter(references):
    t, _ = references
    total = 0
    for name, c in STARTS.items():
        r = simulate("spherical", {"cartesian": c}, t, P, method="dop853", rtol=1e-12, atol=1e-14)
        changes = int(np.sum(r.chart[1:] != r.chart[:-1]))
        assert changes <= r.switches < 40, (name, changes, r.switches)
        total += r.switches
        # every output is in a chart where all polar sines are >= the switch threshold or
        # at worst the hard threshold
        for y, ch in zip(r.y, r.chart):
            s = cartesian.polar_sines(ch, cartesian.state_to_cartesian(ch, y, (L1, L2)), (L1, L2))
            assert min(s) >= 0.1
    assert total >= 3, total


def test_energy_and_lz_continuous_at_each_switch():
    """Dense outputs every 1e-3 around the switches: no jump in E or Lz larger than 1e-9."""
    t = np.linspace(0.0, 3.0, 3001)
    r = simulate("spherical", {"cartesian": STARTS["over_the_top"]}, t, P, method="dop853",
                 rtol=1e-12, atol=1e-14)
    assert r.ok and r.switches >= 1
    lz, E = lz_and_energy(r)
    at = np.flatnonzero(r.chart[1:] != r.chart[:-1])
    assert at.size >= 1
    for k in at:
        assert abs(E[k + 1] - E[k]) < 1e-9 and abs(lz[k + 1] - lz[k]) < 1e-9


def test_c_and_numpy_atlas_agree(references):
    t, _ = references
    t = t[:81]
    for method, kw in (("dop853", dict(rtol=1e-10)), ("rk4", dict(step=1e-3))):
        rc = simulate("spherical", {"cartesian": STARTS["energetic"]}, t, P, method=method, **kw)
        rn = simulate("spherical", {"cartesian": STARTS["energetic"]}, t, P, method=method,
                      backend="numpy", **kw)
        assert rc.ok and rn.ok
        assert list(rc.chart) == list(rn.chart) and rc.switches == rn.switches
        assert np.max(np.abs(rc.y - rn.y)) < 1e-9 and rc.nfev == rn.nfev


def test_no_kernel_is_evaluated_below_the_hard_threshold(monkeypatch):
    """Every rhs / jacobian evaluation of the NumPy atlas is at polar sines >= 0.1."""
    mod = numpy_atlas()
    seen = []
    for k in mod._KERNELS:
        for name in ("rhs", "jacobian"):
            orig = getattr(k, name)

            def wrapped(y, p, orig=orig, k=k):
                seen.append(float(np.min(np.abs(k.polar_sines(y)))))
                return orig(y, p)
            monkeypatch.setattr(k, name, wrapped)
    t = np.linspace(0, 2.0, 21)
    for method, kw in (("dop853", dict(rtol=1e-8)), ("rk4", dict(step=0.01)), ("gauss2", dict(step=0.01))):
        r = simulate("spherical", {"cartesian": STARTS["energetic"]}, t, P, method=method, backend="numpy", **kw)
        assert r.ok, r.message
    assert len(seen) > 1000 and min(seen) >= 0.1, (len(seen), min(seen))


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_single_chart_stops_at_its_singularity(backend):
    """spherical_std heading for a pole: stops with 'chart singular', says where and in which
    state; from exactly at the pole it refuses at t = 0; the atlas goes through both."""
    c0 = STARTS["through_bottom"]
    r0 = simulate("spherical_std", cartesian.cartesian_to_state("spherical_std", c0, (L1, L2)),
                  [0.0, 1.0], P, backend=backend)
    assert r0.status == 5 and r0.t_stop == 0.0 and np.isnan(r0.y[1]).all()
    c = STARTS["over_the_top"]
    y0 = cartesian.cartesian_to_state("spherical_std", c, (L1, L2))
    r = simulate("spherical_std", y0, np.linspace(0, 5, 51), P, method="dop853", backend=backend)
    assert r.status == 5 and r.status_name.startswith("chart singular"), r.message
    assert 0 < r.t_stop < 5 and "spherical_std" in r.message
    # the message names the way out, and taking it runs through
    assert r.message.endswith("; the motion meets a pole of spherical_std's chart: simulate(..., atlas=True) "
                              "runs it on the chain's chart atlas, which switches charts there"), r.message
    assert "atlas=True" not in r.stop_description       # a scene names its own key instead
    through = simulate("spherical_std", y0, np.linspace(0, 5, 51), P, method="dop853", backend=backend, atlas=True)
    assert through.ok and through.t_stop == 5.0 and through.energy_error < 1e-6, through.message
    s = cartesian.polar_sines("spherical_std", cartesian.state_to_cartesian("spherical_std", r.y_stop, (L1, L2)), (L1, L2))
    assert 0.1 <= min(s) < 0.2, s
    done = r.t <= r.t_stop
    assert not np.isnan(r.y[done]).any() and np.isnan(r.y[~done]).all()
    rf = simulate("spherical_std", y0, np.linspace(0, 5, 51), P, method="rk4", step=0.01, backend=backend)
    assert rf.status == 5 and 0 < rf.t_stop < 5
    # and the atlas goes through
    for start in (c, c0):
        ra = simulate("spherical", {"cartesian": start}, np.linspace(0, 5, 51), P, method="dop853",
                      backend=backend)
        assert ra.ok, ra.message


def test_atlas_starts_from_any_chart_state_and_from_standard_states():
    c = STARTS["energetic"]
    t = np.linspace(0, 1, 11)
    base = simulate("spherical", {"cartesian": c}, t, P, rtol=1e-12, atol=1e-14)
    for ch in ATLAS_CHARTS:
        y = cartesian.cartesian_to_state(ch, c, (L1, L2))
        r = simulate("spherical", {"chart": ch, "state": y}, t, P, rtol=1e-12, atol=1e-14)
        assert np.max(np.abs(r.positions - base.positions)) < 1e-10
    y = cartesian.cartesian_to_state("spherical_std", c, (L1, L2))
    r = simulate("spherical", y, t, P, rtol=1e-12, atol=1e-14)
    assert np.max(np.abs(r.positions - base.positions)) < 1e-10


def test_cartesian_y0_is_checked():
    c = STARTS["energetic"].copy()
    c[0] += 0.1
    with pytest.raises(ValueError, match=r"\|x1\|"):
        simulate("spherical", {"cartesian": c}, [0, 1], P)
    c = STARTS["energetic"].copy()
    c[6:9] += c[0:3]
    with pytest.raises(ValueError, match="tangent"):
        simulate("spherical", {"cartesian": c}, [0, 1], P)
    with pytest.raises(ValueError, match="12 numbers"):
        simulate("spherical", {"cartesian": [1, 2, 3]}, [0, 1], P)
    with pytest.raises(ValueError, match="sequence"):
        simulate("planar", {"cartesian": [1, 2, 3]}, [0, 1], [1, 1, 1, 1, 9.81])
