"""The run contract (derive/codegen/contract.py) is stated once: the generated C
and NumPy files, the ctypes structs and the Python runtime all say what it says."""
import ast
import ctypes
import re
from pathlib import Path

import numpy as np
import pytest

import derive
from derive.codegen import contract
from derive.runtime.build import info_struct, options_struct

ROOT = Path(__file__).resolve().parents[2]
GEN = ROOT / "generated"
DERIVE = ROOT / "derive"
MODELS = ("planar", "compound", "spherical_std", "spherical_alt", "spherical_rot")


def _struct(text: str, name: str) -> list[tuple[str, str]]:
    """(ctype, field) of `typedef struct name { ... } name;` (grouped declarations split)."""
    body = re.search(r"typedef struct %s \{(.*?)\} %s;" % (name, name), text, re.S).group(1)
    body = re.sub(r"/\*.*?\*/", "", body, flags=re.S)
    out = []
    for decl in filter(None, (d.strip() for d in body.split(";"))):
        ctype, names = re.match(r"((?:const |volatile )*(?:long double|\w+)(?: \*)?)\s*(.+)$", decl, re.S).groups()
        out += [(ctype, re.sub(r"\[.*\]", "", n.strip())) for n in names.split(",")]
    return out


def _contract_fields(fields) -> list[tuple[str, str]]:
    return [(f.ctype, f.name) for f in fields]


def _defines(text: str, prefix: str) -> dict[str, int]:
    return {m.group(1): int(m.group(2)) for m in re.finditer(r"#define %s_(\w+) (\d+)\n" % prefix, text)}


@pytest.mark.parametrize("model", MODELS)
def test_c_header_states_the_contract(model):
    M = model.upper()
    h = (GEN / "c" / f"{model}_integrate.h").read_text()
    c = (GEN / "c" / f"{model}_integrate.c").read_text()
    assert _defines(h, f"{M}_METHOD") == {m.macro: m.index for m in contract.METHOD_TABLE}
    codes = _defines(h, f"{M}_INTEGRATE")
    assert {k: v for k, v in codes.items() if k != "MAX_STAGES"} == contract.STATUS
    assert _struct(h, f"{model}_integrate_options") == _contract_fields(contract.OPTIONS)
    assert _struct(h, f"{model}_integrate_info") == _contract_fields(contract.INFO)
    cases = dict(re.findall(r"case %s_INTEGRATE_(\w+): return \"([^\"]+)\";" % M, c))
    assert [cases[s.macro] for s in contract.STATUS_TABLE] == list(contract.STATUS_NAMES)
    defaults = dict(re.findall(r"    opt->(\w+) = ([^;]+);", c))
    assert list(defaults) == list(contract.OPTION_NAMES)
    for f in contract.OPTIONS:
        if f.name == "cancel":                  # a pointer: no flag unless the caller gives one
            assert defaults[f.name] == "0" and f.default is None
        elif f.default is None:
            assert defaults[f.name] == f"{M}_INTEGRATE_SINE_MIN"
        else:
            assert float(defaults[f.name].rstrip("L")) == f.default


def test_atlas_header_states_the_contract():
    h = (GEN / "c" / "spherical_atlas.h").read_text()
    assert _defines(h, "SPHERICAL_ATLAS_METHOD") == {m.macro: m.index for m in contract.METHOD_TABLE}
    codes = _defines(h, "SPHERICAL_ATLAS_INTEGRATE")
    assert {k: v for k, v in codes.items() if k != "MAX_STAGES"} == contract.STATUS
    assert _struct(h, "spherical_atlas_options") == _contract_fields(contract.OPTIONS + contract.ATLAS_OPTIONS)
    assert _struct(h, "spherical_atlas_info") == _contract_fields(contract.INFO + contract.ATLAS_INFO)


def _assignments(path: Path) -> dict:
    tree = ast.parse(path.read_text())
    out = {}
    for node in tree.body:
        if isinstance(node, ast.Assign):
            for t in node.targets:
                if isinstance(t, ast.Name):
                    out[t.id] = node.value
                elif isinstance(t, ast.Tuple):
                    out["(" + ", ".join(e.id for e in t.elts) + ")"] = node.value
    return out


def test_numpy_integrators_state_the_contract():
    """The NumPy library's data (derive_tableaus.py, rendered once) says what the contract
    says, and the library (derive_integrators.py) names the status codes in its order."""
    a = _assignments(GEN / "numpy" / "derive_tableaus.py")
    assert ast.literal_eval(a["STATUS_NAMES"]) == contract.STATUS_NAMES
    assert ast.literal_eval(a["METHODS"]) == contract.METHODS
    assert ast.literal_eval(a["STATUS_CODES"]) == contract.STATUS
    assert list(ast.literal_eval(a["STATUS_CODES"])) == [s.macro for s in contract.STATUS_TABLE]
    assert list(ast.literal_eval(a["INFO"])) == list(contract.INFO_NAMES)
    defaults = a["DEFAULTS"]
    keys = [k.value for k in defaults.keys]
    assert keys == list(contract.OPTION_NAMES)
    for k, v in zip(keys, defaults.values):
        if contract.OPTIONS[keys.index(k)].default is not None:
            assert ast.literal_eval(v) == contract.OPTIONS[keys.index(k)].default
    library = _assignments(DERIVE / "codegen" / "backends" / "numpy" / "library" / "derive_integrators.py")
    assert "(" + ", ".join(s.macro for s in contract.STATUS_TABLE) + ")" in library


def test_ctypes_structs_are_the_contract_fields():
    ct = {"double": ctypes.c_double, "long double": ctypes.c_longdouble, "long": ctypes.c_long, "int": ctypes.c_int,
          "const volatile int *": ctypes.POINTER(ctypes.c_int)}
    assert [(n, t) for n, t in options_struct()._fields_] == [(f.name, ct[f.ctype]) for f in contract.OPTIONS]
    info = info_struct(4)._fields_
    assert [n for n, _ in info] == list(contract.INFO_NAMES)
    assert dict(info)["y"] == ctypes.c_longdouble * 4
    assert [n for n, _ in info_struct(8, contract.ATLAS_INFO)._fields_][-2:] == ["nswitches", "chart"]


def test_the_runtime_reads_the_contract():
    import importlib
    atlas, codegen, simulate, scene = (importlib.import_module(f"derive.{m}") for m in
                                       ("runtime.atlas_runner", "codegen.integrators", "runtime.simulate",
                                        "scene.scene"))
    assert simulate.METHODS is contract.METHODS and codegen.METHODS is contract.METHODS
    assert scene.RUN_METHODS is contract.RUN_METHODS and atlas.METHODS is contract.METHODS
    assert contract.RUN_METHODS == contract.METHODS + (contract.TAYLOR,)
    assert simulate.STATUS_NAMES is contract.STATUS_NAMES and simulate.COUNTERS is contract.COUNTERS
    assert contract.ADAPTIVE == ("dopri5", "dop853") and contract.IMPLICIT == ("midpoint", "gauss2")
    assert contract.ORDER == {"rk4": 4, "dopri5": 5, "dop853": 8, "midpoint": 2, "gauss2": 4, "rk8": 8, "abm12": 12}
    assert contract.MULTISTEP == ("abm12",) and contract.ATLAS_METHODS == contract.METHODS[:5]


def test_no_restatement_of_the_contract_outside_it():
    """Status names and method lists appear in derive's Python and templates only in
    contract.py (the generated files render them from there)."""
    names = [s.name for s in contract.STATUS_TABLE if s.name != "ok"]
    offenders = []
    for path in list(DERIVE.rglob("*.py")) + list((DERIVE / "templates").rglob("*.jinja")):
        if path.name == "contract.py":
            continue
        text = path.read_text()
        if any(f'"{n}"' in text for n in names) or '"rk4", "dopri5"' in text or "METHOD_RK4 0" in text:
            offenders.append(str(path.relative_to(ROOT)))
    assert offenders == []


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_long_double_runs_stop_state_is_long_double(backend):
    """One info struct for the float, double and long double entry points: its y is long
    double (it holds every variant's state exactly), the header says so, and a long double
    run's y_stop keeps the bits a double would round away: at the end, where it stops, at a terminal event."""
    h = " ".join(re.sub(r"\n \*", " ", (GEN / "c" / "planar_integrate.h").read_text()).split())
    assert "One info struct serves every variant (_f, none, _l): its y is long double" in h
    assert "long double y[PLANAR_N_STATES]; /* state at t (long double in every variant" in h
    y0, p = [1.0, 0.5, 0.0, 0.0], [1, 1, 1, 1, 9.81]
    r = derive.simulate("planar", y0, [0.0, 0.5], p, dtype="longdouble", backend=backend)
    assert r.ok and r.y.dtype == np.longdouble and r.y_stop.dtype == np.longdouble
    assert np.array_equal(r.y_stop, r.y[-1])                        # every bit of the last row
    assert (r.y_stop != r.y_stop.astype(np.float64)).any()          # bits a double has not
    stopped = derive.simulate("planar", y0, [0.0, 0.5], p, dtype="longdouble", backend=backend, max_steps=3)
    assert stopped.status_name == "maximum number of steps reached" and 0 < stopped.t_stop < 0.5
    assert stopped.y_stop.dtype == np.longdouble and np.isfinite(stopped.y_stop).all()
    assert (stopped.y_stop != stopped.y_stop.astype(np.float64)).any()
    event = derive.simulate("planar", y0, [0.0, 1.0], p, dtype="longdouble", backend=backend,
                            events={"bottom": {"expression": "theta1", "terminal": True}})
    assert event.terminal_event == "bottom" and event.y_stop.dtype == np.longdouble
    assert np.array_equal(event.y_stop, event.events["bottom"].y[-1])
    d = derive.simulate("planar", y0, [0.0, 0.5], p, backend=backend)
    assert d.y_stop.dtype == np.float64 and np.array_equal(d.y_stop, d.y[-1])