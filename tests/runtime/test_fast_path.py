"""simulate's fast path (derive/runtime/fast_path.py, issue 15 item 1): the same result as
the general path, field by field, for every method; the same one-line refusal of bad
input; and it is the path a plain call takes."""
from __future__ import annotations

import importlib
from dataclasses import fields

import numpy as np
import pytest

import derive
from derive.errors import SimulationInputError
from derive.codegen.contract import RUN_METHODS, TOLERANCE_METHODS
from derive.runtime.result import SimulationResult

simulate_module = importlib.import_module("derive.runtime.simulate")

from tests.parameters import UNIT_PARAMS as PLANAR
Y0 = [1.0, 0.5, 0.0, 0.0]


def _kw(method: str) -> dict:
    return {"method": method} if method in TOLERANCE_METHODS else {"method": method, "step": 1e-3}


def _both(monkeypatch, *args, **kw) -> tuple[SimulationResult, SimulationResult]:
    fast = derive.simulate(*args, **kw)
    with monkeypatch.context() as m:
        m.setattr(simulate_module, "FAST_PATH", False)
        general = derive.simulate(*args, **kw)
    return fast, general


def _same(a, b, where: str) -> None:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        assert a.dtype == b.dtype and a.shape == b.shape, (where, a.dtype, b.dtype, a.shape, b.shape)
        if a.dtype == object:
            assert a.tolist() == b.tolist(), where
        else:
            assert np.array_equal(a, b, equal_nan=True), (where, a, b)
    else:
        assert type(a) is type(b) and (a == b or (a != a and b != b)), (where, a, b)


def _same_result(fast: SimulationResult, general: SimulationResult) -> None:
    for f in fields(SimulationResult):
        if f.name in ("observe", "sol"):
            continue
        _same(getattr(fast, f.name), getattr(general, f.name), f.name)
    assert (fast.sol is None) == (general.sol is None)
    if fast.sol is not None:
        mid = (fast.t[0] + fast.t[-1]) / 2
        _same(fast.sol(mid), general.sol(mid), "sol")


CASES = [
    ("planar", Y0, [0.0, 1e-6], PLANAR, {}),
    ("planar", np.array(Y0), np.linspace(0.0, 2.0, 11), [1.0, 1.0, 1.0, 1.0, 9.81], {}),
    ("planar", Y0, np.linspace(0.0, 1.0, 201), PLANAR, {}),                    # a long t array
    ("planar", (1, 0, 0, 2), (0, -0.5, -1), PLANAR, {}),                      # ints, backwards
    ("planar", Y0, [0.0, 0.5], PLANAR, {"dtype": "float32"}),
    ("planar", Y0, [0.0, 0.5], PLANAR, {"dtype": "longdouble", "max_steps": 10 ** 6}),
    ("planar", Y0, [0.0], PLANAR, {}),                                        # the start alone
    ("compound", [0.4, -0.3, 0.0, 0.1], [0.0, 0.3, 0.7],
     {"m1": 1.0, "m2": 2.0, "l1": 1.0, "l2": 0.5, "L1": 1.0, "L2": 1.0, "g": 9.81}, {}),
    ("spherical_std", [1.0, 0.2, 1.2, 0.5, 0.1, 0.3, 0.0, 0.2], [0.0, 0.4], PLANAR, {}),  # a chart model
]


def _cases():
    """Every method on every case; spherical_std's Taylor integrator (about a minute and a
    half of compiling) in the slow tier."""
    for case in range(len(CASES)):
        for method in RUN_METHODS:
            slow = method == "taylor" and CASES[case][0] == "spherical_std"
            yield pytest.param(method, case, id=f"{case}-{method}", marks=[pytest.mark.slow] if slow else [])


@pytest.mark.parametrize("method, case", list(_cases()))
def test_the_fast_path_returns_the_general_paths_result(method, case, monkeypatch):
    model, y0, t, params, kw = CASES[case]
    fast, general = _both(monkeypatch, model, y0, t, params, **_kw(method), **kw)
    _same_result(fast, general)
    taken = simulate_module._fast_simulate(model, y0, t, params, method, None, None, _kw(method).get("step"),
                                           kw.get("dtype", "float64"), kw.get("max_steps"), None, None, None, None)
    assert taken is not None, "the fast path declined a plain call"
    _same(fast.energy, general.energy, "energy")       # the lazy observables, after the fields


def test_a_plain_call_takes_the_fast_path(monkeypatch):
    """With the general path's run replaced by a failure, plain calls still run (each
    method, a mapping and a sequence of parameters, a long t); a call with events does not."""
    def general(*args, **kw):
        raise AssertionError("the general path ran")
    monkeypatch.setattr(simulate_module, "_run_single", general)
    for method in RUN_METHODS:
        assert derive.simulate("planar", Y0, [0.0, 0.1], PLANAR, **_kw(method)).ok
    assert derive.simulate("planar", Y0, np.linspace(0, 1, 101), list(PLANAR.values())).ok
    with pytest.raises(AssertionError, match="general path"):
        derive.simulate("planar", Y0, [0.0, 0.1], PLANAR, events={"e": "theta1"})


BAD = [
    dict(y0=[1.0, float("nan"), 0.0, 0.0]),
    dict(y0=[1.0, 0.5, 0.0]),
    dict(y0=[1e300, 0.5, 0.0, 0.0]),
    dict(params={**PLANAR, "l3": 1.0}),
    dict(params={k: v for k, v in PLANAR.items() if k != "g"}),
    dict(params={**PLANAR, "l1": -1.0}),
    dict(params={**PLANAR, "m2": 0.0}),
    dict(params=[1.0, 1.0, 1.0, 1.0]),
    dict(t=[0.0, 1.0, 1.0]),
    dict(t=[0.0, float("inf")]),
    dict(t=[]),
    dict(t=[-1e308, 1e308]),
    dict(rtol=-1e-9),
    dict(rtol=1e-30),
    dict(rtol=float("nan")),
    dict(max_steps=0),
    dict(hmax=1e-12),
    dict(method="rk4"),                        # a fixed step without step=
    dict(method="rk4", step=-0.1),
    dict(method="rk4", step=1e-12),
    dict(method="nope"),
    dict(dtype="float16"),
    dict(error_estimate="maybe"),
]


@pytest.mark.parametrize("bad", range(len(BAD)))
def test_bad_input_is_refused_with_the_general_paths_line(bad, monkeypatch):
    """Every refusal is one SimulationInputError line, the same with and without the fast
    path (the second call of each: after a first that may have filled the plan's caches)."""
    args = dict(y0=Y0, t=[0.0, 1.0], params=PLANAR)
    args.update(BAD[bad])
    call = dict(args)
    y0, t, params = call.pop("y0"), call.pop("t"), call.pop("params")
    messages = []
    for fast in (True, False, True):
        with monkeypatch.context() as m:
            m.setattr(simulate_module, "FAST_PATH", fast)
            with pytest.raises(SimulationInputError) as info:
                derive.simulate("planar", y0, t, params, **call)
        messages.append(str(info.value))
    assert messages[0] == messages[1] == messages[2] and "\n" not in messages[0], messages


def test_a_parameter_vector_is_checked_once_and_still_refused_after(monkeypatch):
    """The plan remembers vectors that passed the model's checks, never one that failed."""
    good = derive.simulate("planar", Y0, [0.0, 0.1], PLANAR)
    bad = {**PLANAR, "l2": -2.0}
    for _ in range(2):
        with pytest.raises(SimulationInputError, match="l2"):
            derive.simulate("planar", Y0, [0.0, 0.1], bad)
    assert good.ok and derive.simulate("planar", Y0, [0.0, 0.1], PLANAR).ok
