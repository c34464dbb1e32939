"""The checked-in generated kernels against the derivation at 30 digits.

C (double, float, long double, through the loader) and NumPy are evaluated at
the same random states and compared with the SymPy derivation evaluated by
mpmath (tests/oracles/kernel_reference.py): M q'' = F solved by mpmath's LU, the
Jacobian by central differences at 60 digits.

States are drawn as float32 values, so every precision sees exactly the same
inputs.  Angles cover the whole circle (the spherical charts come near their
poles in a few samples), rates are in [-3, 3], parameters in [0.3, 3].

Tolerance: 1e-12 relative (norm-wise per state) for double, scaled by
max(1, cond(M) / 1e3) where the solve with M matters; float and long double
get the same allowance in units of their own machine epsilon
(1e-12 / eps_double ~ 4500 eps).
"""
from __future__ import annotations

import importlib.util
from functools import lru_cache
from pathlib import Path

import mpmath
import numpy as np
import pytest
import sympy as sp

from derive.runtime.loader import load
from tests.oracles.kernel_reference import Reference
from derive.derivation import derive
from derive.model import load_model, model_names

ROOT = Path(__file__).resolve().parents[2]
# one pytest-xdist worker runs the file: each model's 30-digit reference (reference() below,
# memoised in the process) is computed once, not once on each worker that draws a test of it
pytestmark = pytest.mark.xdist_group("kernels_against_derivation")
MODELS = model_names()
N = 1000                    # random states per model
N_JAC_SPHERICAL = 200       # the 60-digit finite-difference Jacobian costs 24 ms per state
TOL = 1e-12
SLACK = TOL / np.finfo(np.float64).eps
VARIANTS = {"": np.float64, "_f": np.float32, "_l": np.longdouble}


# What the parametrisations below need of a model, read from its description: the derivation
# itself (seconds of SymPy per model with a cold cache) would be made on every pytest-xdist
# worker at once while the tests are collected.
def has_hamiltonian_form(name: str) -> bool:
    """Whether the derivation has a Hamiltonian form (derive(name).hamiltonian is not None)."""
    return "hamiltonian" in load_model(name).forms


def has_poles(name: str) -> bool:
    """Whether a link's chart has a polar sine (derive(name).polar_sines is not empty)."""
    return any(link.chart.polar_sine is not None for link in load_model(name).links)



def numpy_module(name: str):
    spec = importlib.util.spec_from_file_location(f"generated_numpy_{name}",
                                                  ROOT / "generated" / "numpy" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _ld(values) -> np.ndarray:
    """mpmath numbers to long double, through 25-digit strings (no float64 rounding)."""
    if isinstance(values, mpmath.matrix):
        values = values.tolist()
    arr = np.array(values, dtype=object)
    return np.vectorize(lambda v: np.longdouble(mpmath.nstr(v, 25, strip_zeros=False)),
                        otypes=[np.longdouble])(arr)


def sample(name: str, n: int, seed: int = 12345):
    d = derive(name)
    nq, P = len(d.symbols.q), len(d.symbols.params)
    rng = np.random.default_rng(seed + sum(map(ord, name)))
    y = np.concatenate([rng.uniform(-np.pi, np.pi, (n, nq)), rng.uniform(-3, 3, (n, nq))], axis=1)
    p = rng.uniform(0.3, 3.0, (n, P))
    return y.astype(np.float32).astype(np.float64), p.astype(np.float32).astype(np.float64)


@lru_cache(maxsize=None)
def reference(name: str):
    d = derive(name)
    R = Reference(d, dps=30)
    y, p = sample(name, N)
    out = {"y": y, "p": p,
           "rhs": np.array([_ld(R.rhs(a, b)) for a, b in zip(y, p)]),
           "mass_matrix": np.array([_ld(R.mass_matrix(a, b)) for a, b in zip(y, p)]),
           "forcing": np.array([_ld(R.forcing(a, b)).reshape(-1) for a, b in zip(y, p)]),
           "energy": np.array([_ld(R.energy(a, b)) for a, b in zip(y, p)]),
           "energy_scale": np.array([float(R.energy_scale(a, b)) for a, b in zip(y, p)]),
           "positions": np.array([_ld(R.positions(a, b)) for a, b in zip(y, p)])}
    out["kappa"] = np.linalg.cond(out["mass_matrix"].astype(np.float64))
    if d.polar_sines:
        out["polar_sines"] = np.array([_ld(R.polar_sines(a, b)) for a, b in zip(y, p)])
    return out


def rel_err(got, ref, scale=None) -> np.ndarray:
    """Norm-wise relative error per state (leading axis)."""
    got = np.asarray(got, dtype=np.longdouble).reshape(len(ref), -1)
    ref = np.asarray(ref, dtype=np.longdouble).reshape(len(ref), -1)
    if scale is None:
        scale = np.abs(ref).max(axis=1)
    return (np.abs(got - ref).max(axis=1) / np.asarray(scale, dtype=np.longdouble)).astype(np.float64)


def allowed(dtype, kappa=None) -> np.ndarray | float:
    tol = SLACK * float(np.finfo(dtype).eps)
    if kappa is None:
        return tol
    return tol * np.maximum(1.0, kappa / 1e3)


def assert_close(what, err, tol):
    bad = np.nonzero(err > tol)[0]
    assert bad.size == 0, (f"{what}: {bad.size} states over tolerance; worst relative error "
                           f"{err.max():.3g} (allowed there {np.broadcast_to(tol, err.shape)[err.argmax()]:.3g})")


# -- C (all three precisions) and NumPy against the 30-digit derivation --------

@pytest.mark.parametrize("name", MODELS)
@pytest.mark.parametrize("kernel", ["rhs", "mass_matrix", "forcing", "energy", "positions"])
def test_kernels_match_derivation(name, kernel):
    ref = reference(name)
    y, p = ref["y"], ref["p"]
    lib, mod = load(name), numpy_module(name)
    kappa = ref["kappa"] if kernel == "rhs" else None
    scale = ref["energy_scale"] if kernel == "energy" else None
    expected = ref[kernel]
    for suffix, dtype in VARIANTS.items():
        got, status = getattr(lib, kernel + suffix)(y, p, status=True)
        assert got.dtype == dtype
        assert_close(f"C {name}_{kernel}{suffix}", rel_err(got, expected, scale), allowed(dtype, kappa))
    got_np = getattr(mod, kernel)(y, p)
    assert_close(f"NumPy {name}.{kernel}", rel_err(got_np, expected, scale), allowed(np.float64, kappa))
    # C double and NumPy run the same printed expressions: agreement to a few ulps
    got_c = getattr(lib, kernel)(y, p)
    assert np.allclose(got_c, got_np, rtol=1e-14, atol=1e-14 * np.abs(got_np).max())


@pytest.mark.parametrize("name", MODELS)
def test_rhs_consistent_with_mass_matrix_and_forcing(name):
    """M (from one kernel) times q'' (from rhs) equals F (from a third), in long double."""
    ref = reference(name)
    lib = load(name)
    y, p = ref["y"], ref["p"]
    nq = y.shape[1] // 2
    qdd = lib.rhs_l(y, p)[:, nq:]
    residual = np.einsum("nij,nj->ni", lib.mass_matrix_l(y, p), qdd) - lib.forcing_l(y, p)
    scale = np.abs(lib.mass_matrix_l(y, p)).max(axis=(1, 2)) * np.abs(qdd).max(axis=1) + \
        np.abs(lib.forcing_l(y, p)).max(axis=1)
    assert_close(f"{name}: M q'' - F", rel_err(residual, np.zeros_like(residual), scale),
                 allowed(np.longdouble))


# The three spherical charts share one code path; the second and third chart's 60-digit
# finite differences (3 s each) are in the slow tier.
@pytest.mark.parametrize("name", [
    pytest.param(m, marks=pytest.mark.slow) if m in ("spherical_alt", "spherical_rot") else m
    for m in MODELS])
def test_jacobian_matches_high_precision_differences(name):
    d = derive(name)
    ref = reference(name)
    n = N_JAC_SPHERICAL if d.paper is not None else N
    y, p = ref["y"][:n], ref["p"][:n]
    R = Reference(d, dps=30)
    expected = np.array([_ld(R.jacobian(a, b)) for a, b in zip(y, p)])
    kappa = ref["kappa"][:n]
    lib, mod = load(name), numpy_module(name)
    for suffix, dtype in VARIANTS.items():
        got = getattr(lib, "jacobian" + suffix)(y, p)
        assert got.shape == (n, y.shape[1], y.shape[1])
        assert_close(f"C {name}_jacobian{suffix}", rel_err(got, expected), allowed(dtype, kappa ** 2))
    assert_close(f"NumPy {name}.jacobian", rel_err(mod.jacobian(y, p), expected),
                 allowed(np.float64, kappa ** 2))


@pytest.mark.parametrize("name", [m for m in MODELS if has_hamiltonian_form(m)])
def test_hamiltonian_form(name):
    d = derive(name)
    ref = reference(name)
    R = Reference(d, dps=30)
    lib, mod = load(name), numpy_module(name)
    y, p = ref["y"], ref["p"]
    x = lib.to_canonical(y, p)
    # p = M q', checked against the reference mass matrix
    mom = np.einsum("nij,nj->ni", ref["mass_matrix"], y[:, 2:].astype(np.longdouble))
    assert_close(f"{name}_to_canonical", rel_err(x[:, 2:], mom), allowed(np.float64))
    back = lib.from_canonical(x, p)
    assert_close(f"{name}_from_canonical", rel_err(back, y), allowed(np.float64, ref["kappa"]))
    expected = np.array([_ld(R.hamiltonian_rhs(a, b)) for a, b in zip(x, p)])
    for suffix, dtype in VARIANTS.items():
        got = getattr(lib, "hamiltonian_rhs" + suffix)(x, p)
        assert_close(f"C {name}_hamiltonian_rhs{suffix}", rel_err(got, expected),
                     allowed(dtype, ref["kappa"]))
    assert_close(f"NumPy {name}.hamiltonian_rhs", rel_err(mod.hamiltonian_rhs(x, p), expected),
                 allowed(np.float64, ref["kappa"]))
    # the Jacobian of Hamilton's equations against 60-digit differences
    expected = np.array([_ld(R.hamiltonian_jacobian(a, b)) for a, b in zip(x, p)])
    for suffix, dtype in VARIANTS.items():
        got = getattr(lib, "hamiltonian_jacobian" + suffix)(x, p)
        assert_close(f"C {name}_hamiltonian_jacobian{suffix}", rel_err(got, expected),
                     allowed(dtype, ref["kappa"] ** 2))
    assert_close(f"NumPy {name}.hamiltonian_jacobian", rel_err(mod.hamiltonian_jacobian(x, p), expected),
                 allowed(np.float64, ref["kappa"] ** 2))
    # Hamilton's q' is the state's q'
    assert_close(f"{name}: q' of both forms", rel_err(lib.hamiltonian_rhs(x, p)[:, :2], y[:, 2:]),
                 allowed(np.float64, ref["kappa"]))


# -- spherical charts: polar sines, conversions, status ------------------------

SPHERICAL = [m for m in MODELS if has_poles(m)]


@pytest.mark.parametrize("name", SPHERICAL)
def test_polar_sines(name):
    ref = reference(name)
    lib, mod = load(name), numpy_module(name)
    for suffix, dtype in VARIANTS.items():
        got = getattr(lib, "polar_sines" + suffix)(ref["y"])
        assert np.all(np.abs(got - ref["polar_sines"]) <= 4 * np.finfo(dtype).eps)
    assert np.all(np.abs(mod.polar_sines(ref["y"]) - ref["polar_sines"]) <= 4e-16)


def _unit_and_velocity(chart, y: np.ndarray, links: int):
    """Unit vectors e and their rates e' of each link, in long double, from the chart formula."""
    u, v, du, dv = sp.symbols("u v du dv", real=True)
    out_e, out_de = [], []
    for i in range(links):
        ch = chart[i]
        e = ch.unit_vector([u, v])
        de = e.jacobian([u, v]) * sp.Matrix([du, dv])
        fe = sp.lambdify([u, v], list(e), "numpy")
        fde = sp.lambdify([u, v, du, dv], list(de), "numpy")
        a = y.astype(np.longdouble)
        U, V, dU, dV = a[:, 2 * i], a[:, 2 * i + 1], a[:, 2 * links + 2 * i], a[:, 2 * links + 2 * i + 1]
        out_e.append(np.stack(np.broadcast_arrays(*fe(U, V)), axis=1))
        out_de.append(np.stack(np.broadcast_arrays(*fde(U, V, dU, dV)), axis=1))
    return out_e, out_de


@pytest.mark.parametrize("name", SPHERICAL)
def test_chart_conversions(name):
    """Converted states describe the same unit vectors and the same velocities (5.1), (5.6)."""
    ref = reference(name)
    src = load_model(name)
    lib, mod = load(name), numpy_module(name)
    y = ref["y"]
    targets = sorted(k[3:] for k in lib.kernels if k.startswith("to_") and not k.endswith(("_f", "_l")))
    assert targets, f"{name}: no chart conversions generated"
    e_src, de_src = _unit_and_velocity([l.chart for l in src.links], y, len(src.links))
    for target in targets:
        tgt = load_model(target)
        other = load(target)
        for suffix, dtype in VARIANTS.items():
            out, status = getattr(lib, f"to_{target}{suffix}")(y, status=True)
            e_t, de_t = _unit_and_velocity([l.chart for l in tgt.links], out, len(tgt.links))
            sines = np.abs(other.polar_sines(out.astype(np.float64)))
            for i in range(len(src.links)):
                pos_err = np.abs(e_t[i] - e_src[i]).max(axis=1).astype(float)
                assert pos_err.max() <= 64 * np.finfo(dtype).eps, (name, target, suffix, pos_err.max())
                vel_scale = np.abs(de_src[i]).max(axis=1).astype(float) / sines[:, i]
                vel_err = np.abs(de_t[i] - de_src[i]).max(axis=1).astype(float)
                assert_close(f"{name}_to_{target}{suffix} rates, link {i + 1}",
                             vel_err / np.maximum(vel_scale, 1e-300), allowed(dtype))
        # NumPy gives the same numbers
        assert np.allclose(mod.__dict__[f"to_{target}"](y), getattr(lib, f"to_{target}")(y),
                           rtol=1e-13, atol=1e-13)
        # the round trip returns the state where the polar angles are in (0, pi)
        yy = y.copy()
        nq = y.shape[1] // 2
        yy[:, 0:nq:2] = np.abs(yy[:, 0:nq:2])
        back = getattr(other, f"to_{name}")(getattr(lib, f"to_{target}")(yy))
        dq = np.angle(np.exp(1j * (back[:, :nq] - yy[:, :nq])))
        # (away from both charts' poles, where rates are ill-conditioned by 1/sin)
        ok = np.all(np.abs(other.polar_sines(getattr(lib, f"to_{target}")(yy))) > 0.05, axis=1) & \
            np.all(np.abs(lib.polar_sines(yy)) > 0.05, axis=1)
        assert ok.sum() > N // 2
        assert np.abs(dq[ok]).max() < 1e-12
        assert rel_err(back[ok, nq:], yy[ok, nq:]).max() < TOL


@pytest.mark.parametrize("name", SPHERICAL)
def test_status_codes(name):
    lib = load(name)
    ref = reference(name)
    y, p = ref["y"][:50].copy(), ref["p"][:50]
    regular = np.all(np.abs(ref["polar_sines"][:50]) > 1e-3, axis=1)
    _, status = lib.rhs(y, p, status=True)
    assert np.all(status[regular] == 0)
    # exactly on the pole of link 1: singular, and the rhs is not finite
    pole = y.copy()
    pole[:, 0] = 0.0
    out, status = lib.rhs(pole, p, status=True)
    assert np.all(status & 2) and np.all(lib.polar_sines(pole)[:, 0] == 0)
    # near the pole: singular, still finite, the output written
    near = y.copy()
    near[:, 2] = 1e-9                      # link 2's polar angle; its sine is below 1e-6
    out, status = lib.rhs(near, p, status=True)
    assert np.all(status == 2) and np.all(np.isfinite(out))
    # a NaN input: not finite
    bad = y.copy()
    bad[:, -1] = np.nan
    _, status = lib.rhs(bad, p, status=True)
    assert np.all(status & 1)
    # the energy needs no regular chart
    _, status = lib.energy(pole, p, status=True)
    assert np.all(status == 0)


@pytest.mark.parametrize("name", [m for m in MODELS if not has_poles(m)])
def test_status_codes_planar(name):
    lib = load(name)
    y, p = sample(name, 20)
    _, status = lib.rhs(y, p, status=True)
    assert np.all(status == 0)
    y[:, 0] = np.inf
    _, status = lib.rhs(y, p, status=True)
    assert np.all(status == 1)


# -- NumPy broadcasting ----------------------------------------------------------

@pytest.mark.parametrize("name", MODELS)
def test_numpy_broadcasting(name):
    mod = numpy_module(name)
    n, P = len(mod.STATE_NAMES), len(mod.PARAM_NAMES)
    assert mod.STATE_NAMES == tuple(load_model(name).state_names)
    assert mod.PARAM_NAMES == tuple(load_model(name).parameters)
    y, p = sample(name, 24)
    y = y.reshape(2, 3, 4, n)
    one = p[0]
    nq = n // 2
    for kernel, shape in [("rhs", (n,)), ("energy", ()), ("jacobian", (n, n)), ("mass_matrix", (nq, nq)),
                          ("positions", (2, load_model(name).dimension))]:
        f = getattr(mod, kernel)
        full = f(y, one)
        assert full.shape == (2, 3, 4) + shape
        # constants broadcast: p per leading index, p with singleton axes, one state
        assert np.array_equal(f(y, np.broadcast_to(one, (2, 3, 4, P))), full)
        assert np.array_equal(f(y, one.reshape(1, 1, 1, P)), full)
        assert np.array_equal(f(y[1, 2, 3], one), full[1, 2, 3])
        # many parameter sets for one state
        assert f(y[0, 0, 0], p[:5]).shape == (5,) + shape
    with pytest.raises(ValueError, match="shape"):
        mod.rhs(np.zeros(n + 1), one)


def test_a_million_states_in_one_call():
    """NumPy and the C batch entry point each take 10^6 planar states at once."""
    mod, lib = numpy_module("planar"), load("planar")
    rng = np.random.default_rng(7)
    y = rng.uniform(-3, 3, (1_000_000, 4))
    p = np.array([1.0, 1.3, 0.9, 1.1, 9.81])
    a, b = mod.rhs(y, p), lib.rhs(y, p)
    assert a.shape == b.shape == (1_000_000, 4)
    assert np.allclose(a, b, rtol=1e-13, atol=1e-12)


# -- trigonometry: compound angles expanded, NumPy's sin/cos from half-angle tangents ---

def test_planar_rhs_takes_sin_and_cos_of_the_coordinates_only():
    """emit.compound_angle_rewrites: the planar rhs needs sin/cos of theta1 - theta2 and of
    theta1, theta2; the compound angle is expanded, so C takes sin/cos of y[0] and y[1] only
    (two lanes of one loop: emit.trig_lanes) and NumPy takes one tangent per coordinate.  The
    spherical standard chart's rhs takes no sin/cos of phi1 or phi2 alone, so phi1 - phi2
    stays whole there (expanding it would add calls)."""
    import re
    c = (ROOT / "generated" / "c" / "planar.c").read_text()
    rhs = c[c.index("int planar_rhs("):c.index("int planar_rhs_batch(")]
    assert re.findall(r"lane_angle\[\d\] = \{ (.*) \};", rhs) == ["y[0], y[1]"]
    assert sorted(re.findall(r"\b(sin|cos)\(([^()]*)\)", rhs)) == [("cos", "lane_angle[lane]"),
                                                                  ("sin", "lane_angle[lane]")]
    rhs_f = c[c.index("int planar_rhs_f("):c.index("int planar_rhs_batch_f(")]   # float: scalar calls
    assert sorted(set(re.findall(r"\b(sinf|cosf)\(([^()]*)\)", rhs_f))) == \
        [("cosf", "y[0]"), ("cosf", "y[1]"), ("sinf", "y[0]"), ("sinf", "y[1]")]
    py = (ROOT / "generated" / "numpy" / "planar.py").read_text()
    rhs_py = py[py.index("def rhs("):py.index("def mass_matrix(")]
    assert re.findall(r"numpy\.tan\(([^()]*)\)", rhs_py) == ["0.5*theta1", "0.5*theta2"]
    std = (ROOT / "generated" / "c" / "spherical_std.c").read_text()
    rhs_std = std[std.index("int spherical_std_rhs("):std.index("int spherical_std_rhs_batch(")]
    assert re.findall(r"lane_angle\[\d\] = \{ (.*) \};", rhs_std) == ["y[0], y[2], y[1] - y[3]"]


def test_generated_numpy_calls_no_sin_or_cos():
    for path in sorted((ROOT / "generated" / "numpy").glob("*.py")):
        text = path.read_text()
        assert "numpy.sin(" not in text and "numpy.cos(" not in text, path.name


def test_half_angle_sine_and_cosine_at_extreme_angles():
    """The NumPy positions (l sin theta, -l cos theta) at angles where a half-angle formula
    could go wrong -- 0, -0, tiny, multiples of pi/2 and pi (tan(x/2) near its poles), the
    doubles next to pi, and large angles a long spinning run reaches -- agree with mpmath's
    sin/cos of the same doubles to 4 ulp of 1 (absolute), as libm does."""
    mod = numpy_module("planar")
    k = np.arange(-8, 9)
    angles = np.concatenate([[0.0, -0.0, 1e-300, -1e-300, 1e-8, np.pi, -np.pi,
                              np.nextafter(np.pi, 0), np.nextafter(np.pi, 4), 1e3, -1e3, 12345.678, 1e6],
                             k * np.pi / 2, k * np.pi / 2 + 1e-12, 2 * np.pi * k + np.pi])
    y = np.column_stack([angles, angles[::-1], np.zeros_like(angles), np.zeros_like(angles)])
    p = np.array([1.0, 1.0, 1.0, 1.0, 9.81])
    got = mod.positions(y, p)
    with mpmath.workdps(40):
        for i, a in enumerate(angles):
            b = angles[::-1][i]
            s1, c1 = mpmath.sin(mpmath.mpf(float(a))), mpmath.cos(mpmath.mpf(float(a)))
            s2, c2 = mpmath.sin(mpmath.mpf(float(b))), mpmath.cos(mpmath.mpf(float(b)))
            want = [s1, -c1, s1 + s2, -c1 - c2]
            err = max(abs(mpmath.mpf(float(g)) - w) for g, w in zip(got[i].reshape(-1), want))
            assert err <= 4 * np.finfo(np.float64).eps, (a, b, float(err))
    with np.errstate(invalid="ignore"):
        assert np.isnan(mod.positions(np.array([np.nan, np.inf, 0.0, 0.0]), p)).sum() == 4
