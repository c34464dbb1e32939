"""A state put onto a closed loop's constraints, on request: `derive.consistent_state`.

Its own module, above simulate (it resolves a model and its parameters as simulate does)
and the constraint checks (derive/runtime/constraints.py, which simulate imports).
"""
from __future__ import annotations

import numpy as np

from ..errors import SimulationInputError
from ..model import load_model
from . import constraints
from .simulate import normalise_params, resolve_model


def consistent_state(model, y0, params, independent=None) -> np.ndarray:
    """A state on a closed loop's constraints, from y0.

    Without `independent`: the state closest to y0, the coordinates by Gauss-Newton on
    Phi(q) = 0 (each correction the least-squares one, -J^+ Phi), then the rates
    projected orthogonally onto J q' = 0.  With `independent` (the coordinates the loop
    leaves free, e.g. a four-bar's crank angle): those coordinates and their rates are
    kept exactly as y0 gives them, and the others are solved for, by Newton on
    Phi(q) = 0 from y0's values (the guess picks the loop's branch), their rates from
    J q' = 0.  This is how a start of a linkage is usually given: "the crank at 0.3,
    turning at 1 rad/s".

    Parameters
    ----------
    model : str or path
        A model with `constraints` (a name or the path of its file).
    y0 : sequence
        A state, coordinates then rates.
    params : mapping or sequence
        The parameters, by name or in order.
    independent : str or sequence of str, optional
        The free coordinates, held at y0's values (as many as the coordinates less the
        constraints).

    Returns
    -------
    ndarray, shape (n,)
        A state whose residuals ``|Phi|`` and ``|J q'|`` are at roundoff.

    Raises
    ------
    SimulationInputError
        The model has no constraints, the state has the wrong size, or the iteration does
        not converge (no closed configuration near y0, or J loses rank there); with
        `independent`: a name that is no coordinate, or the loop cannot close at those
        free coordinates from this guess.

    Examples
    --------
    >>> import derive
    >>> p = dict(m1=1, m2=2, m3=1.5, l1=0.5, l2=2, l3=1.5, d=2, g=9.81)
    >>> y = derive.consistent_state("examples/models/four_bar.toml", [0.3, 2.6, 0.6, 1, 0, 0], p)
    >>> bool(abs(y[0] - 0.3) < 0.01)
    True
    >>> y = derive.consistent_state("examples/models/four_bar.toml", [0.3, 2.6, 0.6, 1, 0, 0], p,
    ...                             independent=["theta1"])
    >>> float(y[0]), float(y[3])           # the crank's angle and rate, as given
    (0.3, 1.0)
    """
    name = resolve_model(model)
    if not load_model(name).is_constrained:
        raise SimulationInputError(f"{name}: the model has no constraints (no 'constraints' key): "
                                   f"every state is consistent")
    p = np.asarray(normalise_params(name, params), dtype=np.float64)
    y = np.array(y0, dtype=np.float64)
    nq = len(load_model(name).coordinate_names)
    if y.shape != (2 * nq,):
        raise SimulationInputError(f"{name}: y0 has shape {y.shape}, the state has {2 * nq} entries")
    if independent is None:
        return constraints.project(name, y, p)
    free = constraints.free_indices(name, independent)
    closed, ok = constraints.close_from_free(name, y[None, :], p, free)
    if not ok[0]:
        names = [load_model(name).coordinate_names[i] for i in free]
        raise SimulationInputError(
            f"{name}: the loop does not close at {', '.join(f'{c} = {y[i]:.6g}' for c, i in zip(names, free))} "
            f"from this guess of the other coordinates (out of the linkage's reach, or a singular "
            f"configuration where they are not determined): change the free coordinates or the guess")
    return closed[0]
