"""simulate on the top of the precision ladder (double-double, quad): one trajectory of
Taylor's method from exact values, through the runner's extended-precision build
(derive/runtime/extended.py: the numbers and the library)."""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..codegen.contract import COUNTERS, STATUS_NAMES, TAYLOR
from .model_sizes import model_info
from ..errors import SimulationInputError
from .extended import DEFAULT_RTOL, UNIT_ROUNDOFF, as_longdouble, exact
from .result import LOCAL_SUM, SimulationResult
from .runner import runner_for
from .shared_library import info_state


def ordered_values(value, names: tuple[str, ...], what: str) -> list:
    """A mapping by name or a sequence in `names` order -> the exact values in that order
    (simulate's own checks have run: the names and the length are right)."""
    if isinstance(value, Mapping):
        raw = [value[n] for n in names]
    elif isinstance(value, np.ndarray):
        raw = list(value.reshape(-1))
    elif isinstance(value, Sequence) and not isinstance(value, str):
        raw = list(value)
    else:
        raise SimulationInputError(f"{what} must be a sequence (or a mapping by name) for the precision ladder")
    if len(raw) != len(names):
        raise SimulationInputError(f"{what} must have {len(names)} values ({', '.join(names)}), got {len(raw)}")
    return [exact(v, what) for v in raw]


def simulate_extended(model: str, precision: str, y0, t, params, rtol, hmax, max_steps, sine_min,
                      inputs):
    """simulate(..., dtype='double-double' | 'quad'): the Taylor integrator on one
    trajectory; the checks of simulate have run on the same arguments before."""
    info = model_info(model)
    tol = DEFAULT_RTOL[precision] if rtol is None else rtol
    floor = 10 * UNIT_ROUNDOFF[precision]
    if not isinstance(tol, (int, float, np.floating)) or not floor <= tol < 1:
        raise SimulationInputError(f"rtol = {tol!r} is outside [10 eps, 1) for {precision} "
                                   f"(10 eps = {floor:.3g})")
    ys = ordered_values(y0, info.state_names, "y0")
    ps = ordered_values(params, info.param_names, "params")
    if info.n_inputs:
        ps += ordered_values(inputs, info.input_names, "inputs")
    ts = [exact(v, "t") for v in (t.reshape(-1) if isinstance(t, np.ndarray) else list(t))]
    r = runner_for(model, TAYLOR, precision)
    values = {"rtol": float(tol), "hmax": float(hmax or 0.0), "sine_min": float(sine_min or 0.0)}
    if max_steps is not None:
        values["max_steps"] = int(max_steps)
    out, inf = r.exact_library(tol).run(ys, ps, ts, r.options(values))
    exact_y = np.empty((len(ts), info.n), object)
    exact_y.flat[:] = out
    y = as_longdouble(out).reshape(len(ts), info.n)
    counters = {k: int(getattr(inf, k)) for k in COUNTERS}
    status = int(inf.status)
    pm = as_longdouble(ps[:info.n_params])
    return SimulationResult(
        model=model, method="taylor", backend="c", dtype=precision, t=as_longdouble(ts), y=y,
        energy=None, positions=None, status=status, status_name=STATUS_NAMES[status],
        t_stop=float(inf.t), y_stop=info_state(inf, info.n, np.longdouble), params=pm, rtol=float(tol), y_exact=exact_y,
        error_estimate=float(inf.local_error), error_kind=LOCAL_SUM, **counters)
