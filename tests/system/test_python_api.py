"""The Python face (derive/api.py): derive.load_model, derive.equations, a model's generate
and latex methods, and a run's HTML summary and xarray Dataset."""
from __future__ import annotations

import doctest
import importlib
import inspect
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from numpydoc.docscrape import ClassDoc, FunctionDoc

import derive
from derive import api
from derive.cli import main
from derive.derivation import derive as derivation_of
from derive.codegen import backends, generate
from derive.codegen.backends import default_names
from derive.codegen.backends import jax as jax_backend
from derive.codegen import emit, opcount
from derive.derivation import symbolic
from derive import errors as errors_module
from derive.measurement import trust as trust_module
from derive.report import document, equations as equations_module
from derive.runtime import result as result_module

ROOT = Path(__file__).resolve().parents[2]
# by import_module: derive.runtime's package namespace holds the functions of the same names
ensemble_module, linearize_module, loop_state_module, scipy_rhs_module, simulate_module, sweep_module = (
    importlib.import_module(f"derive.{name}")
    for name in ("runtime.ensemble", "runtime.linearize", "runtime.loop_state", "runtime.scipy_rhs",
                 "runtime.simulate", "sweep"))
PLANAR = {"m1": 1.0, "m2": 1.3, "l1": 0.9, "l2": 1.1, "g": 9.81}


# every module that defines a name of derive.__all__, and those with a new public function or
# class (issue 26, items 4 and 5); document's pdflatex example compiles a PDF twice: the slow tier
DOCTESTED = [api, equations_module, pytest.param(document, marks=pytest.mark.slow), result_module,
             backends, generate, jax_backend, errors_module, simulate_module, ensemble_module,
             scipy_rhs_module, trust_module, linearize_module, loop_state_module, sweep_module, opcount,
             emit, symbolic]


@pytest.mark.parametrize("module", DOCTESTED, ids=lambda m: m.__name__)
def test_the_examples_of_the_docstrings_run(module):
    failed, tried = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert tried > 0 and failed == 0


def _public_objects():
    """derive.__all__ as (name, object): derive.sweep, the stage that is callable, by its function."""
    for name in derive.__all__:
        if name == "__version__":
            continue
        value = getattr(derive, name)
        yield name, (value.sweep if inspect.ismodule(value) else value)


def _missing_sections(doc, wanted) -> list[str]:
    return [section for section in wanted if not doc[section]]


def test_the_module_list_of_the_doctests_holds_every_public_name():
    tested = {(m.values[0] if hasattr(m, "values") else m).__name__ for m in DOCTESTED}
    defining = {obj.__module__ for _, obj in _public_objects()}
    assert defining <= tested, sorted(defining - tested)


@pytest.mark.parametrize("name", [n for n in derive.__all__ if n != "__version__"])
def test_every_public_name_has_the_numpydoc_sections(name):
    """issue 26: a function has Parameters, Returns, Raises and Examples; a class a description
    and Examples (an exception: Examples); Pendulum's public methods Returns and Examples, and
    Parameters where they take any."""
    obj = dict(_public_objects())[name]
    if not inspect.isclass(obj):
        doc = FunctionDoc(obj)
        assert not _missing_sections(doc, ("Summary", "Parameters", "Returns", "Raises", "Examples"))
        return
    doc = ClassDoc(obj)
    if issubclass(obj, BaseException):
        assert not _missing_sections(doc, ("Summary", "Extended Summary", "Examples"))
        return
    assert not _missing_sections(doc, ("Summary", "Examples"))
    for method_name in doc.methods:
        method = getattr(obj, method_name)
        wanted = ("Summary", "Returns", "Examples")
        if len(inspect.signature(method).parameters) > 1:             # more than self
            wanted += ("Parameters",)
        assert not _missing_sections(FunctionDoc(method), wanted), method_name


def test_import_derive_stays_light_and_names_the_new_functions():
    code = ("import sys, derive; assert 'sympy' not in sys.modules, 'sympy imported'; "
            "assert {'load_model', 'equations', 'Pendulum'} <= set(derive.__all__); "
            "derive.load_model; assert 'sympy' in sys.modules")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert run.returncode == 0, run.stderr


def test_equations_are_the_derivations_sympy_objects():
    eq = derive.equations("planar")
    d = derivation_of("planar")
    assert eq.M == d.M and eq.F == d.F and eq.T == d.T and eq.V == d.V
    assert sp.simplify(eq.L - (d.T - d.V)) == 0 and sp.simplify(eq.energy - d.energy) == 0
    assert eq.coordinates == d.symbols.q and eq.parameters == d.symbols.params
    assert eq.H is not None and eq.H == d.hamiltonian.H         # planar has the closed form
    tex = eq._repr_latex_()
    assert tex.startswith("$$") and tex.endswith("$$") and r"\theta" in tex and "H &=" in tex
    assert derive.load_model("planar").equations().M == eq.M


def test_a_model_without_the_hamiltonian_form_has_none():
    """spherical_std does not ask for the Hamiltonian form: no H, none typeset."""
    eq = derive.equations("spherical_std")
    assert eq.hamiltonian is None and eq.H is None
    assert len(eq.coordinates) == 4 and eq.M.shape == (4, 4)
    assert "H &=" not in eq._repr_latex_() and "M &=" in eq._repr_latex_()


def test_a_model_file_loads_by_path(tmp_path):
    text = (ROOT / "derive" / "model" / "catalog" / "planar.toml").read_text()
    path = tmp_path / "my_pendulum.toml"
    path.write_text(text.replace('name = "planar"', 'name = "my_pendulum"'))
    model = derive.load_model(path)
    assert model.name == "my_pendulum"
    assert derive.equations(str(path)).M == derive.equations("planar").M


def test_an_unknown_model_is_a_model_error():
    with pytest.raises(derive.ModelError, match="planar"):       # the message lists the known ones
        derive.load_model("no_such_model")


def test_generate_writes_what_the_command_writes(tmp_path, capsys):
    mine, cli = tmp_path / "api", tmp_path / "cli"
    files = derive.load_model("planar").generate(mine, backends=("c", "numpy", "jax"))
    assert main(["generate", "planar", "--out", str(cli), "--backend", "c", "--backend", "numpy",
                 "--backend", "jax"]) == 0
    capsys.readouterr()
    assert sorted(p.relative_to(mine) for p in files) == sorted(p.relative_to(cli) for p in cli.rglob("*.*")
                                                              if p.name != "MANIFEST.toml")
    for p in files:
        assert p.read_text() == (cli / p.relative_to(mine)).read_text()
    assert derive.load_model("planar").generate(mine, backends=("c", "numpy", "jax"), check=True) == []
    with pytest.raises(derive.InputError, match="unknown backend 'rust'"):
        derive.load_model("planar").generate(mine, backends=("rust",))


def test_latex_writes_what_the_command_writes(tmp_path, capsys):
    tex = derive.load_model("planar").latex(tmp_path / "api.tex")
    assert main(["latex", "planar", "-o", str(tmp_path / "cli.tex")]) == 0
    capsys.readouterr()
    assert tex.read_text() == (tmp_path / "cli.tex").read_text()
    with pytest.raises(derive.InputError, match="cannot write"):
        derive.load_model("planar").latex(tmp_path / "no" / "such" / "folder.tex")


def _run():
    return derive.simulate("planar", [1.0, 0.5, 0.0, 0.0], np.linspace(0.0, 2.0, 21), PLANAR,
                           backend="numpy")


def test_a_runs_html_summary_says_what_it_was():
    r = _run()
    html = r._repr_html_()
    for fragment in ("planar", "dop853", "float64", "ok", f"{r.nsteps} (", "final time", "2</td>",
                     "energy error", "not measured"):
        assert fragment in html, fragment
    horizon = derive.trust_horizon(r, 1e-6)
    assert f"t = {horizon:.6g} to 1e-06" in r._repr_html_()


def test_a_damped_runs_summary_calls_its_energy_change_no_error():
    """A damped model loses energy by its physics: the table says so, it is no error."""
    r = derive.simulate(str(ROOT / "examples" / "models" / "driven.toml"), [1.0, 0.5, 0, 0], [0.0, 2.0],
                        {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81, "c1": 0.1, "c2": 0.1},
                        inputs={"tau1": 0, "tau2": 0}, backend="numpy")
    html = r._repr_html_()
    assert "energy change" in html and "not an error" in html and "energy error" not in html
    assert f"{r.energy_error:.3g}" in html and r.energy_error > 1e-3


def test_to_xarray_has_one_variable_per_state_along_t():
    r = _run()
    ds = r.to_xarray()
    assert list(ds.data_vars) == ["theta1", "theta2", "theta1_dot", "theta2_dot", "energy"]
    np.testing.assert_array_equal(ds["t"].values, r.t)
    np.testing.assert_array_equal(ds["theta2_dot"].values, r.y[:, 3])
    assert ds.attrs["method"] == "dop853" and ds.attrs["dtype"] == "float64" and ds.attrs["status"] == "ok"
    assert ds.attrs["param_m2"] == 1.3 and "l2=1.1" in ds.attrs["params"]


def test_to_xarray_without_xarray_is_one_line_naming_the_extra(monkeypatch):
    r = _run()
    monkeypatch.setitem(sys.modules, "xarray", None)        # import xarray now fails
    with pytest.raises(derive.ToolMissingError) as info:
        r.to_xarray()
    assert str(info.value) == result_module.XARRAY_MISSING and "derive[sweep]" in str(info.value)


@pytest.mark.parametrize("model", ["planar", "spherical_std"])
def test_the_notebook_display_is_valid_latex(model, tmp_path):
    """_repr_latex_ compiles with amsmath (pdflatex, required by tests/run.sh)."""
    display = derive.equations(model)._repr_latex_()
    body = r"\[" + display.removeprefix("$$").removesuffix("$$") + r"\]"
    tex = tmp_path / "display.tex"
    tex.write_text("\\documentclass{article}\n\\usepackage{amsmath}\n\\begin{document}\n"
                   f"{body}\n\\end{{document}}\n")
    assert document.pdflatex(tex).is_file()


def test_generate_by_default_writes_the_backends_the_command_writes_unasked(tmp_path):
    files = derive.load_model("planar").generate(tmp_path)
    assert {p.relative_to(tmp_path).parts[0] for p in files} == set(default_names()) == {"c", "numpy"}


@pytest.mark.parametrize("target", [0.0, -1e-6, float("nan"), "1e-6"])
def test_trust_horizon_of_a_target_that_is_no_error_bound_is_one_line(target):
    """A negative target gave t0 and NaN gave NaN, as if measured: now an InputError."""
    with pytest.raises(derive.InputError, match="target must be a positive number"):
        derive.trust_horizon(_run(), target)


def test_trust_horizon_of_something_else_than_a_run_is_one_line():
    with pytest.raises(derive.InputError, match="must be a run of derive.simulate, got str"):
        derive.trust_horizon("planar", 1e-6)
