"""The batched throughput RK4 (generated/c/<model>_throughput.c, generated/numpy/<model>_throughput.py)
equals the scalar generated RK4 (derive.simulate's C path) to 1e-12, handles NaN and
infinity as the scalar path does, and uses glibc's vector sin/cos where it can."""
import platform
from pathlib import Path

import numpy as np
import pytest

from derive.runtime.build import integrator_library
from derive.codegen.integrators import METHODS
from derive.codegen.loops import BLOCK, throughput_models
from derive.runtime.throughput import throughput_library, throughput_numpy

PARAMS = {"planar": np.array([1.0, 1.3, 0.9, 1.1, 9.81]),
          "compound": np.array([1.0, 1.2, 1.0, 0.8, 1.0 / 12, 0.8 ** 2 * 1.2 / 12, 9.81])}
H, NSTEPS = 0.01, 100          # t = 1: inside the trust horizon of these states (lambda < 10)


def _states(n, seed=0):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-np.pi, np.pi, (n, 2)), rng.uniform(-3, 3, (n, 2))])


def _scalar(model, y0, p, h=H, nsteps=NSTEPS):
    lib = integrator_library(model)
    o = lib.defaults()
    o.h = h
    y, infos = lib.run(METHODS.index("rk4"), y0, p, np.array([0.0, h * nsteps]), o)
    return y[:, -1], infos


def test_every_unguarded_model_has_a_throughput_kernel():
    assert throughput_models() == ["compound", "planar"]


@pytest.mark.parametrize("model", ["planar", "compound"])
@pytest.mark.parametrize("threads", [1, 2])
def test_c_batch_equals_the_scalar_path(model, threads):
    y0 = _states(3 * BLOCK + 17, seed=threads)          # a partial block at the end
    ref, infos = _scalar(model, y0, PARAMS[model])
    assert all(inf.status == 0 and inf.nsteps == NSTEPS for inf in infos)
    y, status, steps = throughput_library(model).rk4(y0, PARAMS[model], H, NSTEPS, threads=threads)
    assert (status == 0).all() and (steps == NSTEPS).all()
    assert np.abs(y - ref).max() <= 1e-12


@pytest.mark.parametrize("model", ["planar", "compound"])
def test_numpy_batch_equals_the_scalar_path(model):
    y0 = _states(500, seed=3)
    ref, _ = _scalar(model, y0, PARAMS[model])
    y, status, steps = throughput_numpy(model).rk4(y0.T, PARAMS[model], H, NSTEPS)
    assert (status == 0).all() and (steps == NSTEPS).all()
    assert np.abs(y.T - ref).max() <= 1e-12


def test_nonfinite_trajectories_stop_as_in_the_scalar_path():
    y0 = _states(BLOCK + 3, seed=4)
    y0[1, 0] = np.nan                       # bad input
    y0[5, 2] = 1e200                        # squares overflow: non-finite derivative at once
    p = PARAMS["planar"]
    for y, status, steps in (throughput_library("planar").rk4(y0, p, H, 10),
                             (lambda r: (r[0].T, r[1], r[2]))(throughput_numpy("planar").rk4(y0.T, p, H, 10))):
        assert status[1] == 6 and steps[1] == 0
        assert status[5] == 4 and steps[5] == 0 and np.array_equal(y[5], y0[5])
        good = np.ones(len(y0), bool)
        good[[1, 5]] = False
        assert (status[good] == 0).all() and (steps[good] == 10).all()
    _, infos = _scalar("planar", y0[[5]], p, nsteps=10)
    assert infos[0].status == 4 and infos[0].t == 0.0


def test_vector_math_is_used_on_glibc_x86_64():
    tp = throughput_library("planar")
    libmvec = any(Path(d, "libmvec.so.1").exists() for d in ("/lib/x86_64-linux-gnu", "/usr/lib/x86_64-linux-gnu",
                                                             "/lib64", "/usr/lib64"))
    if platform.system() == "Linux" and platform.machine() == "x86_64" and libmvec:
        assert tp.vector_math, "glibc x86-64 with libmvec: the vector build should have worked"
    else:
        print(f"throughput kernel built without vector math on {platform.system()} {platform.machine()}")


# -- the single-trajectory fixed-step loops (generated/c/<model>_fixed.c) -----------------

@pytest.mark.parametrize("model", ["planar", "compound"])
def test_rk4_loop_equals_the_scalar_integrator(model):
    from derive.runtime.throughput import fixed_library
    y0 = _states(5, seed=7)
    ref, _ = _scalar(model, y0, PARAMS[model])
    for i in range(len(y0)):
        y, done = fixed_library(model).run("rk4", y0[i], PARAMS[model], H, NSTEPS)
        assert done == NSTEPS and np.abs(y - ref[i]).max() <= 1e-12


@pytest.mark.parametrize("model", ["planar", "compound"])
def test_rk8_loop_equals_dop853_steps_at_a_fixed_step(model):
    """rk8 is DOP853's 8th-order formula at a fixed step: the generated NumPy integrator's
    dop853 step, called with the same h, gives the same states."""
    from derive.runtime.simulate import numpy_module
    from derive.runtime.throughput import fixed_library
    mod = numpy_module(f"{model}_integrate")
    p = PARAMS[model]
    opt = dict(mod.DEFAULTS)
    for y0 in _states(3, seed=8):
        y, info, K = np.array(y0), mod.new_info(), [None] * 16
        for _ in range(50):
            _, K[0] = mod.system.eval(y, p, opt, info)
            _, y, _ = mod.library.explicit_step(mod.system, "dop853", y, 0.02, p, K, opt, info)
        got, done = fixed_library(model).run("rk8", y0, p, 0.02, 50)
        assert done == 50 and np.abs(got - y).max() <= 1e-12


def test_loops_stop_before_a_nonfinite_step():
    from derive.runtime.throughput import fixed_library
    y0 = np.array([0.3, 0.2, 1e200, 0.0])
    for method in ("rk4", "rk8", "abm12"):
        y, done = fixed_library("planar").run(method, y0, PARAMS["planar"], H, 10)
        assert done == 0 and np.array_equal(y, y0)


def test_adams_weights_are_exact_for_polynomials():
    """tableau.adams(k): the k-step Adams-Bashforth weights integrate polynomials of degree
    k-1 through s = 0, -1, ..., -(k-1) exactly over [0, 1], the Adams-Moulton ones through
    s = 1, 0, ..., -(k-2); and k = 4 gives the textbook (55, -59, 37, -9)/24, (9, 19, -5, 1)/24."""
    import sympy as sp
    from derive.codegen.tableau import adams
    ab, am = adams(4)
    assert [w * 24 for w in ab] == [55, -59, 37, -9] and [w * 24 for w in am] == [9, 19, -5, 1]
    ab, am = adams(12)
    for m in range(12):
        exact = sp.Rational(1, m + 1)
        assert sum(w * sp.Integer(-j) ** m for j, w in enumerate(ab)) == exact
        assert sum(w * sp.Integer(1 - j) ** m for j, w in enumerate(am)) == exact
    assert sum(w * sp.Integer(-j) ** 12 for j, w in enumerate(ab)) != sp.Rational(1, 13)


def test_abm12_loop_converges_at_its_order_and_starts_with_rk8():
    """abm12 (PECE, 2 evaluations a step): the error against a long double DOP853 reference
    falls by at least 2^9.5 per halving of h on the regular problem's first 5 time units
    (measured 2^10.8 from h = 5/350 to 5/700); its first 11 steps are rk8 steps; and too
    large a step is unstable (12-step Adams has a small stability region), which the loop
    reports by stopping early rather than returning a non-finite state."""
    from derive.runtime.simulate import simulate
    from derive.codegen.loops import evaluations
    from derive.runtime.throughput import fixed_library
    lib, p, y0, T = fixed_library("planar"), np.array([1.0, 1.0, 1.0, 1.0, 9.81]), [1.0, 0.5, 0.0, 0.0], 5.0
    ref = simulate("planar", y0, [0, T], list(p), method="dop853", rtol=2e-18, atol=1e-21,
                   dtype="longdouble").y[-1].astype(float)
    errors = []
    for n in (350, 700):
        y, done = lib.run("abm12", y0, p, T / n, n)
        assert done == n
        errors.append(np.abs(y - ref).max())
    assert errors[1] < 1e-9 and np.log2(errors[0] / errors[1]) > 9.5, errors
    short, done = lib.run("abm12", y0, p, 0.01, 5)
    assert done == 5 and np.array_equal(short, lib.run("rk8", y0, p, 0.01, 5)[0])
    y, done = lib.run("abm12", y0, p, 0.02, 250)
    assert done < 250 and np.isfinite(y).all()
    assert evaluations("abm12", 100) == 1 + 12 * 11 + 2 * 89 and evaluations("rk8", 10) == 120


def test_generated_c_includes_only_math_h_and_generated_headers():
    """The project's rule for generated C: standalone C99 that includes <math.h> and
    nothing else but the project's own generated headers (no <stdint.h>, <string.h>);
    the binary128 Taylor integrator (<model>_taylor_quad.c) <quadmath.h> too."""
    import re
    root = Path(__file__).resolve().parents[2] / "generated" / "c"
    sources = sorted(root.glob("*.c")) + sorted(root.glob("*.h"))
    assert any(f.name.endswith("_throughput.c") for f in sources)
    assert any(f.name.endswith("_fixed.c") for f in sources)
    generated = {f.name for f in sources if f.suffix == ".h"}
    bad = []
    for f in sources:
        for line in f.read_text().splitlines():
            m = re.match(r"\s*#\s*include\s*(\S+)", line)
            if not m:
                continue
            what = m.group(1)
            if what == "<math.h>" or (what.startswith('"') and what.strip('"') in generated):
                continue
            if what == "<quadmath.h>" and f.name.endswith("_quad.c"):      # the binary128 variant's
                continue
            bad.append(f"{f.name}: {line.strip()}")
    assert not bad, "generated C includes more than <math.h> and generated headers:\n" + "\n".join(bad)
