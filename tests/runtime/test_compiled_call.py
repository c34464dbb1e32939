"""simulate's compiled call path (derive/runtime/compiled_call.py, issue 25 item 1): a
repeated plain call runs in one C call, with the same result as the general path, field by
field, for every method and precision; and bad input still gets the general path's line."""
from __future__ import annotations

import importlib

import numpy as np
import pytest

import derive
from derive.codegen.contract import RUN_METHODS
from derive.errors import SimulationInputError
from derive.runtime import compiled_call
from tests.runtime.test_fast_path import BAD, CASES, PLANAR, Y0, _kw, _same, _same_result

simulate_module = importlib.import_module("derive.runtime.simulate")



def test_the_extension_builds_where_python_has_its_headers():
    """Built with the compiler derive uses, against this Python's headers (where they are
    missing, simulate runs its Python fast path: no test here would pass)."""
    assert compiled_call.available()


def _compiled(model, y0, t, params, **kw):
    """The third run of a call (the second registers its compiled call), and that call."""
    for _ in range(2):
        derive.simulate(model, y0, t, params, **kw)
    key = compiled_call.call_key(model, kw.get("method"), kw.get("dtype", "float64"), kw.get("rtol"),
                                 kw.get("atol"), kw.get("step"), kw.get("hmax"), kw.get("max_steps"),
                                 None, None, None)
    call = compiled_call.lookup(key)
    return derive.simulate(model, y0, t, params, **kw), call


def _general(monkeypatch, *args, **kw):
    with monkeypatch.context() as m:
        m.setattr(simulate_module, "FAST_PATH", False)
        return derive.simulate(*args, **kw)


# test_fast_path's cases but the chart model's (it has no compiled call: its results name
# their chart), and a long double run with the default budget (the one there has its own)
CASES = CASES + [("planar", Y0, [0.0, 0.25, 0.5], PLANAR, {"dtype": "longdouble"})]
PLANAR_CASES = [c for c, case in enumerate(CASES) if case[0] in ("planar", "compound")]


@pytest.mark.parametrize("method", RUN_METHODS)
@pytest.mark.parametrize("case", PLANAR_CASES)
def test_the_compiled_call_returns_the_general_paths_result(method, case, monkeypatch):
    model, y0, t, params, kw = CASES[case]
    kw = {**_kw(method), **kw}
    ours, call = _compiled(model, y0, t, params, **kw)
    # compiled: a repeated call with several plain output times, run directly (not a run
    # with a step budget beyond the pilot's: that one is cancellable, in Python)
    if 1 < np.size(t) <= 64 and kw.get("max_steps", 0) <= simulate_module.PILOT_STEPS["c"]:
        assert call is not None, "a repeated plain call has no compiled call"
        assert call(y0, t, params) is not None, "the compiled call declined a plain call"
    _same_result(ours, _general(monkeypatch, model, y0, t, params, **kw))


def test_the_compiled_call_is_the_one_a_repeated_call_takes(monkeypatch):
    """With the Python fast path and the general path replaced by failures, a repeated
    plain call still runs; a first call with new option arguments does not."""
    derive.simulate("planar", Y0, [0.0, 0.1], PLANAR, rtol=1e-7)
    derive.simulate("planar", Y0, [0.0, 0.1], PLANAR, rtol=1e-7)

    def python(*args, **kw):
        raise AssertionError("Python ran the call")
    monkeypatch.setattr(simulate_module, "_fast_simulate", python)
    monkeypatch.setattr(simulate_module, "_run_single", python)
    assert derive.simulate("planar", (0.3, 0.2, 0.0, 0.0), [0.0, 0.5, 1.0], PLANAR, rtol=1e-7).ok
    with pytest.raises(AssertionError, match="Python ran"):
        derive.simulate("planar", Y0, [0.0, 0.1], PLANAR, rtol=1e-6)


def test_a_pilot_stopped_at_its_budget_goes_on_as_before(monkeypatch):
    """A compiled adaptive run that needs more than the pilot's steps: the rest runs as the
    Python paths run it, with their result."""
    monkeypatch.setitem(simulate_module.PILOT_STEPS, "c", 40)
    rtol = 1.25e-10                   # options of their own: settings made with the pilot of 40 steps
    _, call = _compiled("planar", Y0, [0.0, 0.01], PLANAR, rtol=rtol)
    assert call is not None and call.pilot
    assert call(Y0, [0.0, 20.0], PLANAR).status == simulate_module.MAX_STEPS_STATUS
    ours = derive.simulate("planar", Y0, [0.0, 20.0], PLANAR, rtol=rtol)
    _same_result(ours, _general(monkeypatch, "planar", Y0, [0.0, 20.0], PLANAR, rtol=rtol))
    assert ours.ok and ours.nsteps > 40


@pytest.mark.parametrize("bad", range(len(BAD)))
def test_bad_input_after_a_compiled_call_is_refused_with_the_general_paths_line(bad, monkeypatch):
    args = dict(y0=Y0, t=[0.0, 1.0], params=PLANAR)
    args.update(BAD[bad])
    call = dict(args)
    y0, t, params = call.pop("y0"), call.pop("t"), call.pop("params")
    options = {k: v for k, v in call.items() if k in ("method", "step", "rtol", "max_steps", "hmax", "dtype")}
    try:
        _compiled("planar", Y0, [0.0, 1.0], PLANAR, **options)        # the same options, plain arguments
    except SimulationInputError:
        pass                                                          # the options are the bad input
    messages = []
    for fast in (True, False):
        with monkeypatch.context() as m:
            m.setattr(simulate_module, "FAST_PATH", fast)
            with pytest.raises(SimulationInputError) as info:
                derive.simulate("planar", y0, t, params, **call)
        messages.append(str(info.value))
    assert messages[0] == messages[1] and "\n" not in messages[0], messages
