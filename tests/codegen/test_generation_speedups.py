"""The generator's shortcuts give what the long way gives: the C types printed once
(CVariantPrinter), shared printers, SymEngine's derivatives (derive/derivation/symbolic.py), the
linearize file's A taken from the jacobian kernel, and the languages rendered side by side."""
from __future__ import annotations

import json
import threading

import numpy as np
import pytest
import sympy as sp

from derive.codegen import sources, taylor
from derive.codegen.printers import CPrinter, CVariantPrinter, PyNumPyPrinter, shared_printer
from derive.derivation.derivation import derive
from derive.model import model_names
from derive.codegen import emit
from derive.codegen.solve import ImplicitDerivative
from derive.codegen.spec import dynamics
from derive.derivation.symbolic import Derivatives, MatrixDerivatives, engine_cse

x, y, z = sp.symbols("x y z", real=True)
EXPRESSIONS = [
    sp.Rational(1, 2) * x + 2 * y * sp.sin(x) - sp.Float(1.25) * sp.cos(y) ** 2 / x,
    sp.sqrt(x) + sp.pi * x ** 5 + 1 / x ** 2 + x ** sp.Rational(3, 2) + sp.exp(-x) + sp.Abs(x),
    sp.Integer(3) / 7, 1 / (x + y), sp.sqrt(2) * x, sp.E * x, sp.log(x) + sp.atan2(x, y),
    sp.Float("9.81") * x + sp.Float(0.1) * x ** 2 + sp.Float("1e-20") + sp.Float(123456789.123),
    sp.tanh(z) ** 3 - sp.asin(y / 2) + sp.sign(x) * sp.Rational(-7, 3),
]


@pytest.mark.parametrize("ctype", ["float", "double", "long double"])
def test_the_types_printed_once_read_as_each_printed_alone(ctype):
    """Byte for byte CPrinter's text, for every type, whichever type asked first."""
    slots = {x: "y[0]", y: "p[1]"}
    shared = CVariantPrinter(slots)
    for e in reversed(EXPRESSIONS):             # fill the memo in another order
        shared.text(e, "float")
    for e in EXPRESSIONS:
        assert shared.text(e, ctype) == CPrinter(slots, ctype).doprint(e)


def test_a_shared_printer_prints_as_a_fresh_one():
    slots, varying = {x: "x", y: "y"}, {x}
    a = shared_printer(PyNumPyPrinter, slots, varying)
    assert shared_printer(PyNumPyPrinter, dict(slots), set(varying)) is a
    assert shared_printer(PyNumPyPrinter, slots, {y}) is not a
    for e in EXPRESSIONS:
        assert a.doprint_checked(e) == PyNumPyPrinter(slots, varying).doprint_checked(e)
        assert a.doprint_checked(e) == a.doprint_checked(e)


def _models():
    return [*model_names(), "examples/models/triple.toml", "examples/models/cart_pole.toml",
            "examples/models/elastic_pendulum.toml", "examples/models/four_bar.toml",
            "examples/models/driven_gyroscope.toml"]


@pytest.mark.parametrize("model", _models())
def test_symengine_derivatives_are_sympys(model):
    """Every derivative the generator takes (of F and M, by every state) is the expression
    SymPy's diff gives, symbol for symbol (assumptions and all)."""
    d = derive(model)
    s = d.symbols
    dF, dM = Derivatives(list(d.F)), MatrixDerivatives(d.M)
    for v in s.state:
        for i, f in enumerate(d.F):
            assert dF.diff(i, v) == f.diff(v)
        assert dM.diff(v) == d.M.diff(v)


def test_what_symengine_leaves_unevaluated_is_sympys():
    """abs and sign: SymEngine keeps d|x|/dx unevaluated; the result is SymPy's, but for
    sign's derivative, 2*DiracDelta(x), taken as zero (almost_everywhere)."""
    e = [sp.Abs(x) * y + sp.sign(x), sp.Dummy("k") * sp.sin(x) ** 2]
    d = Derivatives(e)
    assert e[0].diff(x) == y * sp.sign(x) + 2 * sp.DiracDelta(x)
    assert d.diff(0, x) == y * sp.sign(x) and not d.diff(0, x).has(sp.Derivative)
    assert d.diff(1, x) == e[1].diff(x)          # a Dummy comes back as itself
    assert d.diff(0, z) == 0


@pytest.mark.parametrize("model", ["examples/models/triple.toml", "examples/models/triple_spherical.toml",
                                   "examples/models/four_bar.toml"])
def test_the_jacobian_summed_in_symengine_is_summed_in_sympy(model):
    """ImplicitDerivative: dq''/dy_k and its stages, summed and solved in SymEngine, are the
    expressions SymPy's arithmetic gives, symbol for symbol (a loop's augmented system too)."""
    d = derive(model)
    dyn = dynamics(d)
    x = getattr(dyn, "unknowns", None) or dyn.qdd
    engine = ImplicitDerivative(dyn.M, dyn.F, dyn.mass)
    sympy_only = ImplicitDerivative(dyn.M, dyn.F, dyn.mass, engine=False)
    assert engine.names is not None and sympy_only.names is None
    for yk in d.symbols.state:
        assert engine.solve(yk, x) == sympy_only.solve(yk, x)


@pytest.mark.parametrize("model", ["planar", "spherical_std", "examples/models/triple.toml",
                                   "examples/models/driven_pivot.toml", "examples/models/pendulum_tree.toml"])
def test_the_velocities_kernel_is_sympys_jacobian_times_the_rates(model):
    """The velocities kernel's expressions (SymEngine's, symbolic.by_engine) are
    expand((d pos / dq) q' + d pos / dt) written with SymPy's matrices."""
    from derive.codegen.spec import model_spec
    from derive.derivation.symbols import t
    d = derive(model)
    s = d.symbols
    q, qd = sp.Matrix(s.q), sp.Matrix(s.qd)
    expected = [sp.expand(c) for tip in d.tips for c in tip.jacobian(q) * qd + tip.diff(t)]
    (kernel,) = [k for k in model_spec(d).kernels if k.name == "velocities"]
    assert list(kernel.outputs[0].exprs) == expected


@pytest.mark.parametrize("model", ["planar", "spherical_std", "examples/models/triple.toml",
                                   "examples/models/four_bar.toml"])
def test_symengines_cse_gives_back_the_roots(model, monkeypatch):
    """The one CSE pass of a model's files (SymEngine's): the replacements substituted back
    into the reduced expressions give every root again; each replacement uses only those
    before it, and they are numbered in order."""
    seen = []

    def keep(roots, symbols):
        roots = list(roots)
        found = engine_cse(roots, symbols)
        seen.append((roots, found))
        return found

    monkeypatch.setattr(emit, "engine_cse", keep)
    sources._both_files.cache_clear()
    try:
        sources.kernels(model)
    finally:
        sources._both_files.cache_clear()
    (roots, found), = seen
    assert found is not None
    replacements, reduced = found
    assert [s.name for s, _ in replacements] == [f"_cse{i}" for i in range(len(replacements))]
    full: dict = {}
    for s, e in replacements:
        assert e.free_symbols & {t for t, _ in replacements} <= full.keys()
        full[s] = e.xreplace(full)
    for root, r in zip(roots, reduced, strict=True):
        assert sp.expand(root - r.xreplace(full)) == 0


@pytest.mark.parametrize("model", _models())
def test_symengines_results_come_back_as_sympys_evaluation_builds_them(model):
    """The converter's shortcut (a flat sum or product: its terms sorted, not evaluated)
    gives the expression SymPy's evaluation gives, argument for argument, for what the
    generator brings back: the CSE of every kernel's roots, and their expansions."""
    import symengine as se
    from derive.derivation.symbolic import EngineNames, _from_engine
    spec, _ = sources.kernels(model)
    roots = [sp.sympify(e) for k in spec.kernels for e in [e for _, e in k.stages] + list(k.guards)
             + [e for out in k.outputs for e in out.exprs]]
    names = EngineNames()
    engine = names.engine(roots)
    replacements, reduced = se.cse(engine)
    back = dict(names.back)
    back.update((t, sp.Symbol(f"_cse{i}")) for i, (t, _) in enumerate(replacements))
    exprs = [e for _, e in replacements] + list(reduced) + [se.expand(r) for r in engine] + engine
    fast, evaluated = _from_engine(exprs, back, {}), _from_engine(exprs, back, {}, evaluate=True)
    assert fast == evaluated
    # the roots themselves, back (a derivation's -(a + b) from factor_terms comes back as -a - b)
    assert all(a == b or sp.expand(a - b) == 0 for a, b in zip(fast[-len(roots):], roots, strict=True))


@pytest.mark.parametrize("model", ["planar", "spherical_std", "examples/models/triple.toml",
                                   "examples/models/four_bar.toml"])
def test_a_renaming_is_sympys_xreplace_argument_for_argument(model):
    """emit.renamed, which sorts a renamed sum or product instead of evaluating it, gives
    xreplace's expression for every assignment of the model's kernels, with the temporaries
    renamed in reverse order (every sum and product re-sorted)."""
    _, bodies = sources.kernels(model)
    assignments = [e for body in bodies for _, e in body.assignments]
    temporaries = sorted({s for e in assignments for s in e.free_symbols
                          if s.name[0] == "t" and s.name[1:].isdigit()}, key=lambda s: int(s.name[1:]))
    names = dict(zip(temporaries, reversed(temporaries)))
    memo: dict = {}
    for e in assignments:
        assert emit.renamed(e, names, memo) == e.xreplace(names)


def test_what_symengines_cse_cannot_take_goes_to_sympy():
    """A root with a node the converters do not take (abs, a Float of 30 digits): no
    SymEngine CSE (None), and cse_file's fallback, sympy.cse, is used."""
    t = (sp.Symbol(f"t{i}") for i in range(9))
    assert engine_cse([sp.Abs(x + y) * sp.sin(x + y)], t) is None
    assert engine_cse([sp.Float("0.1", 30) * sp.sin(x + y)], t) is None
    replacements, reduced = engine_cse([sp.Float(0.1) * sp.sin(x + y) + sp.atan2(y, x)], t)
    assert reduced[0].xreplace(dict(replacements)).xreplace(dict(replacements)) == \
        sp.Float(0.1) * sp.sin(x + y) + sp.atan2(y, x)


@pytest.mark.parametrize("model", ["planar", "examples/models/cart_pole.toml"])
def test_the_linearize_file_reads_the_jacobian_kernel(model):
    """Its A has the jacobian kernel's expressions (not differentiated again), and the CSE
    bodies of both give the same numbers at a random state."""
    from derive.runtime.simulate import resolve_model
    name = resolve_model(model)
    spec, bodies = sources.kernels(name)
    lin, (lbody,) = sources.linearize_kernels(name)
    jac = next(k for k in spec.kernels if k.name == "jacobian")
    assert lin.kernels[0].outputs[0].exprs == jac.outputs[0].exprs
    jbody = next(b for b in bodies if b.kernel.name == "jacobian")
    rng = np.random.default_rng(3)
    values = {}
    for inp in jbody.kernel.inputs:
        for sym in inp.vector.symbols:
            values[sym] = sp.Float(rng.uniform(0.5, 1.5))

    def evaluate(body, output):
        env = dict(values)
        for sym, e in body.assignments:
            env[sym] = e.xreplace(env).evalf(30)
        return [sp.sympify(e).xreplace(env).evalf(30) for e in body.outputs[output]]

    a, j = evaluate(lbody, 0), evaluate(jbody, 0)
    assert max(abs(u - v) for u, v in zip(a, j)) < 1e-25


def test_languages_rendered_side_by_side_are_the_same_files(monkeypatch):
    """A model large enough to render its languages in worker processes gets the files it
    gets rendered in one process."""
    from derive.runtime.simulate import resolve_model
    name = resolve_model("examples/models/triple.toml")
    monkeypatch.setattr(sources, "PARALLEL_OPS", 0)
    monkeypatch.setattr(sources, "EARLY_STATES", 0)       # the C backend's early work too
    monkeypatch.setattr(sources, "may_fork", lambda: True)
    monkeypatch.setattr(sources, "job_count", lambda: 2)
    asked, early = [], []
    real, real_early = sources.run_all, sources._start_early_work
    pool_threads = []           # the early work's pool threads alive when the backends' workers fork

    def run_all(calls, jobs=None):
        pool_threads.extend(t.name for t in threading.enumerate() if "_handle_" in t.name)
        asked.append(jobs)
        return real(calls, 2)
    monkeypatch.setattr(sources, "run_all", run_all)
    monkeypatch.setattr(sources, "_start_early_work", lambda *a: early.append(real_early(*a)) or early[-1])
    side_by_side = sources.render_fresh(name)
    assert asked == [None]                      # the worker path was taken
    assert [len(e) for e in early] == [1]       # and the Taylor jet's early work
    assert pool_threads == []                   # whose pool had ended (else may_fork says no)
    assert sources._EARLY_POOL == [] and "triple" not in taylor._WHOLE_ANGLES      # forgotten after
    monkeypatch.setattr(sources, "PARALLEL_OPS", 10 ** 9)
    monkeypatch.setattr(sources, "EARLY_STATES", 10 ** 9)
    taylor.rhs_decomposition.cache_clear()
    taylor.whole_angles_decomposition.cache_clear()
    assert sources.render_fresh(name) == side_by_side
    assert early[-1] == {}


def test_only_the_double_angle_is_expanded():
    """sin(2u) becomes 2 sin u cos u (one call fewer); cos(20 t) stays one call (its
    degree-20 polynomial in sin t, cos t cancels to about 1e-9)."""
    from derive.codegen.spec import _multiple_angles
    t = sp.Symbol("t", real=True)
    assert _multiple_angles(sp.sin(2 * t)) == 2 * sp.sin(t) * sp.cos(t)
    assert _multiple_angles(sp.cos(20 * t)) == sp.cos(20 * t)
    assert _multiple_angles(sp.sin(3 * x) + sp.cos(y)) == sp.sin(3 * x) + sp.cos(y)


@pytest.mark.parametrize("model", ["planar", "spherical_std", "examples/models/cart_pole.toml"])
def test_a_kernel_at_one_point_is_the_batch_call(model):
    """CKernel.at_point (what scipy_rhs's fun and jac call for one state) gives the batch
    entry point's numbers, NaN included (a chart's singular state)."""
    from derive.runtime.loader import load
    from derive.runtime.simulate import resolve_model
    name = resolve_model(model)
    kernels = load(name)
    from derive.model import load_model
    info = load_model(name)
    rng = np.random.default_rng(5)
    p = rng.uniform(0.5, 1.5, len(info.parameters))
    fixed = (p,) if not info.inputs else (p, rng.uniform(-1, 1, len(info.inputs)))
    rhs, jac = kernels.rhs.at_point(*fixed), kernels.jacobian.at_point(*fixed)
    n = 2 * len(info.coordinate_names)
    states = [rng.uniform(-1, 1, n) for _ in range(5)]
    if model == "spherical_std":
        states.append(np.zeros(n))              # theta = 0: the standard chart's pole
    for y in states:
        np.testing.assert_array_equal(rhs(y), kernels.rhs(y, *fixed))
        np.testing.assert_array_equal(jac(y), kernels.jacobian(y, *fixed))
    with pytest.raises(ValueError, match="must have"):
        rhs(np.zeros(n + 1))


@pytest.mark.parametrize("model", ["planar", "spherical_std", "examples/models/triple.toml"])
def test_inline_max_is_the_largest_order_within_the_budget(model):
    """inline_max sums the jet's cost order by order: the largest p with jet_cost <= budget."""
    from derive.codegen.contract import TAYLOR_ORDER_MAX
    from derive.codegen.taylor import INLINE_BUDGET, inline_max, jet_cost, rhs_decomposition
    from derive.runtime.simulate import resolve_model
    d = rhs_decomposition(resolve_model(model))
    expected = max((p for p in range(2, TAYLOR_ORDER_MAX + 1) if jet_cost(d, p) <= INLINE_BUDGET), default=0)
    assert inline_max(d) == expected


def test_the_compiled_templates_are_what_jinja2_makes_of_the_templates_now():
    """templates/compiled/ (shipped, so a fresh process compiles no template) is, file for
    file, what the Jinja2 in use compiles from today's templates; made by another Jinja2,
    none of it is used."""
    import jinja2
    from derive import paths
    from derive.codegen.emit import COMPILED, MANIFEST, _Precompiled, compiled_templates
    folder = paths.templates_dir() / COMPILED
    shipped = {p.name: p.read_text() for p in folder.iterdir() if p.is_file()}
    manifest = json.loads(shipped[MANIFEST])
    loader = _Precompiled(folder, paths.templates_dir())
    if manifest["jinja2"] == jinja2.__version__:
        assert shipped == compiled_templates(), "run `derive generate` to compile the templates anew"
        assert set(loader.digests) == {n for n in manifest["templates"]} and len(loader.digests) > 20
    else:
        assert loader.digests == {}


def test_a_template_changed_since_it_was_compiled_is_compiled_from_its_text(tmp_path):
    """A compiled template whose text has changed since is not used: the environment
    compiles the template's present text (and uses the compiled form of the others)."""
    import shutil
    from derive import paths
    from derive.codegen.emit import COMPILED, _environment, _Precompiled
    folder = tmp_path / "templates"
    shutil.copytree(paths.templates_dir(), folder, ignore=shutil.ignore_patterns("__pycache__"))
    name = "numpy/tableaus.py.jinja"
    (folder / name).write_text("changed {{ 1 + 1 }}\n")
    env = _environment(str(folder))
    assert isinstance(env.loader.loaders[0], _Precompiled)
    assert env.get_template(name).render() == "changed 2\n"
    fresh = env.get_template("numpy/module.py.jinja")
    assert fresh.filename is None or fresh.filename.endswith(".py")     # loaded from its module
    (folder / COMPILED / "manifest.json").unlink()                         # nothing compiled: all from text
    assert _environment(str(folder) + "/").get_template(name).render() == "changed 2\n"
