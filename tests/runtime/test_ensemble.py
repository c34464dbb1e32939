"""derive.ensemble: many trajectories in one call, each as simulate would run it."""
from __future__ import annotations

import numpy as np
import pytest

import derive
from derive.errors import SimulationInputError

PLANAR = ("m1", "m2", "l1", "l2", "g")


def _states(B, seed=3):
    rng = np.random.default_rng(seed)
    y0 = np.zeros((B, 4))
    y0[:, :2] = rng.uniform(-1.5, 1.5, (B, 2))
    y0[:, 2:] = rng.uniform(-1, 1, (B, 2))
    return y0


def test_each_trajectory_is_what_simulate_gives_with_its_own_parameters():
    B = 40
    y0 = _states(B)
    rng = np.random.default_rng(5)
    params = np.column_stack([rng.uniform(0.5, 2, B), rng.uniform(0.5, 2, B), rng.uniform(0.5, 2, B),
                              rng.uniform(0.5, 2, B), np.full(B, 9.81)])
    t = np.linspace(0, 3, 7)
    r = derive.ensemble("planar", y0, t, params, method="dop853", rtol=1e-10, threads=2)
    assert r.y.shape == (B, 7, 4) and r.all_ok and r.threads == 2
    for b in range(0, B, 7):
        s = derive.simulate("planar", y0[b], t, params[b], method="dop853", rtol=1e-10)
        assert np.array_equal(r.y[b], s.y)          # the same C code: bit for bit
        assert r.nfev[b] == s.nfev


def test_threads_do_not_change_results_and_fixed_steps_work():
    y0 = _states(64, seed=9)
    t = np.linspace(0, 2, 5)
    p = [1, 1, 1, 1, 9.81]
    one = derive.ensemble("planar", y0, t, p, method="rk4", step=1e-3, threads=1)
    two = derive.ensemble("planar", y0, t, p, method="rk4", step=1e-3, threads=2)
    assert np.array_equal(one.y, two.y) and one.step == 1e-3
    by_name = derive.ensemble("planar", y0, t, dict(zip(PLANAR, p)), method="rk4", step=1e-3)
    assert np.array_equal(one.y, by_name.y)


def test_a_user_model_file_with_inputs_per_trajectory(tmp_path):
    from pathlib import Path
    model = Path(__file__).parents[2] / "examples" / "models" / "driven.toml"
    info = derive.simulate(model, [0.1, 0.2, 0, 0], [0, 1e-3], _driven_params(), inputs=[0.5, 0.0])
    B = 20
    y0 = np.tile([0.1, 0.2, 0.0, 0.0], (B, 1))
    u = np.column_stack([np.linspace(-1, 1, B), np.zeros(B)])
    r = derive.ensemble(model, y0, [0, 1.0], _driven_params(), inputs=u, rtol=1e-10)
    assert r.all_ok and info.ok
    for b in (0, 7, 19):
        s = derive.simulate(model, y0[b], [0, 1.0], _driven_params(), inputs=u[b], rtol=1e-10)
        assert np.array_equal(r.y[b], s.y)
    assert not np.allclose(r.y[0, -1], r.y[-1, -1])        # the inputs differ, so do the runs


def _driven_params():
    from derive.model import load_model
    from pathlib import Path
    d = load_model(Path(__file__).parents[2] / "examples" / "models" / "driven.toml")
    return {n: (9.81 if n == "g" else 0.1 if n.startswith("c") else 1.0) for n in d.parameters}


@pytest.mark.parametrize("kwargs, message", [
    (dict(y0=np.zeros((3, 5))), r"y0 must have shape \(B, 4\)"),
    (dict(params=np.ones((2, 5))), r"parameters must have shape \(5,\) or \(3, 5\)"),
    (dict(params={"m1": 1}), r"missing parameter 'm2'"),
    (dict(params=[1, 1, -1, 1, 9.81]), r"parameter l1 = -1 must be positive"),
    (dict(threads=0), r"threads = 0 must be a positive integer"),
    (dict(method="euler"), r"unknown method 'euler'"),
    (dict(model="spherical"), r"ensemble runs single-chart models"),
])
def test_bad_input_is_one_line(kwargs, message):
    args = dict(model="planar", y0=np.zeros((3, 4)), t=[0, 1], params=[1, 1, 1, 1, 9.81])
    args.update(kwargs)
    with pytest.raises(SimulationInputError, match=message) as info:
        derive.ensemble(args.pop("model"), args.pop("y0"), args.pop("t"), args.pop("params"), **args)
    assert "\n" not in str(info.value)


def test_taylor_ensemble_is_simulate_trajectory_by_trajectory():
    y0 = _states(24, seed=2)
    t = np.linspace(0, 2, 5)
    r = derive.ensemble("planar", y0, t, [1, 1, 1, 1, 9.81], method="taylor", rtol=1e-12, threads=2)
    assert r.all_ok and r.rtol == 1e-12
    for b in (0, 11, 23):
        s = derive.simulate("planar", y0[b], t, [1, 1, 1, 1, 9.81], method="taylor", rtol=1e-12)
        assert np.array_equal(r.y[b], s.y)
