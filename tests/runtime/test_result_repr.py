"""The repr of a run's result and of an ensemble: one line that says what ran and how it
ended, the arrays by shape, without computing the lazy observables."""
from __future__ import annotations

import numpy as np

import derive

PARAMS = {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81}


def test_a_result_prints_in_one_line_without_computing_its_observables():
    r = derive.simulate("planar", [1.0, 0.5, 0, 0], np.linspace(0, 2, 101), PARAMS, rtol=1e-8)
    calls = []
    observe = r.observe
    r.observe = lambda *a, **k: calls.append(1) or observe(*a, **k)
    text = repr(r)
    assert "\n" not in text and len(text) < 300, text
    assert text.startswith("<SimulationResult planar: dop853 c float64, rtol 1e-08; ok; 101 outputs t = 0..2")
    assert "y (101, 4)" in text and f"nfev {r.nfev}," in text
    assert not calls
    r.energy                    # the wrapper sees the observables computed on first access
    assert calls == [1]


def test_a_stopped_run_and_an_ensemble_name_how_they_ended():
    r = derive.simulate("planar", [2.5, 2.0, 0, 0], [0.0, 100.0], PARAMS, method="rk4", step=0.5)
    assert not r.ok and f"; {r.status_name};" in repr(r) and "step 0.5" in repr(r)
    runs = derive.ensemble("planar", np.array([[1.0, 0.5, 0, 0], [2.5, 2.0, 0, 0]]), [0.0, 1.0, 100.0],
                           PARAMS, method="rk4", step=0.5)
    text = repr(runs)
    assert "\n" not in text and text.startswith("<EnsembleResult planar: rk4 float64, step 0.5; 1 of 2 ok")
    assert f"stopped {{'{runs.status_names[1]}': 1}}" in text and "y (2, 3, 4)" in text
