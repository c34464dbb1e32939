"""A closed loop's run time: the start on the constraints, the drift controlled and reported.

A model with `constraints` (derive/derivation/loop_closure.py) runs as the index-1 system
[M J^T; J 0] [q''; lambda] = [F; gamma], which keeps Phi'' = 0 exactly but lets the
truncation and roundoff errors of a run move it off Phi = 0, J q' = 0 (the drift,
growing linearly in J q' and quadratically in Phi at worst).  What derive does about it:

* a run starts only from a state on the constraints (|Phi| and |J q'| within the
  contract's CONSTRAINT_START_TOLERANCE): another is refused in one line naming the
  largest residual; `derive.consistent_state` (loop_state.py) projects a state onto
  them, on request only (a projection moves the state the user gave, which nobody
  should get without asking);
* `simulate(..., project=True)` projects onto Phi = 0, J q' = 0 after every step
  (`project`: Gauss-Newton on the coordinates, then the rates orthogonally), stepped in
  Python over the compiled rhs (derive/runtime/continuous_inputs.py); by default the
  generated loops integrate the exact index-1 equations, with the tolerance as the control;
* every run reports its drift, the largest |Phi| and |J q'| over its outputs
  (`SimulationResult.constraint_drift`), and its message says so where the drift exceeds
  the contract's CONSTRAINT_DRIFT_BOUND.

Projection rather than a Baumgarte term in the kernels: Baumgarte's two gains are
problem- and step-dependent and change the equations a demanding user integrates (the
energy of a conservative loop is no longer exact, the constraint is only attracted, never
met), while a projection puts the state back exactly on the constraints by the smallest
correction and leaves the equations as derived; a drift figure with every run is what
lets the user see which of the two runs they need.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..codegen.contract import CONSTRAINT_DRIFT_BOUND, CONSTRAINT_START_TOLERANCE
from ..errors import SimulationInputError
from ..model import load_model
from ..model.atlas import find_atlas
from .loader import numpy_module


PROJECTION_ITERATIONS = 50    # Gauss-Newton on Phi(q) = 0 converges quadratically: a handful suffice
PROJECTION_STEP = 1e-15       # ... and stops at a correction this small relative to |q| (roundoff)


@dataclass(frozen=True)
class ConstraintDrift:
    """How far a closed loop's run left its constraints, over its outputs.

    Attributes
    ----------
    phi : float
        The largest |Phi(q)| (position level).
    phi_dot : float
        The largest |J q'| (velocity level).
    bound : float
        The bound above which the run's message reports the drift (the contract's
        CONSTRAINT_DRIFT_BOUND).
    """
    phi: float
    phi_dot: float
    bound: float = CONSTRAINT_DRIFT_BOUND

    @property
    def exceeded(self) -> bool:
        """Whether either residual exceeds the bound (a NaN residual does)."""
        return not (self.phi <= self.bound and self.phi_dot <= self.bound)

    def __str__(self) -> str:
        return f"max |Phi| = {self.phi:.3g}, max |J q'| = {self.phi_dot:.3g}"


# a start whose constraint Jacobian has a singular value this small (relative to its
# largest) is a toggle position: the augmented system is singular there
SINGULAR_START = 1e-10


def is_constrained(model: str) -> bool:
    """Whether the model (a resolved name) closes a loop; False for a chart atlas.

    Parameters
    ----------
    model : str
        A model's name.

    Returns
    -------
    bool
    """
    if find_atlas(model) is not None:       # an atlas' name is no model's: it has no constraints
        return False
    return load_model(model).is_constrained


def residuals(model: str, y, p) -> tuple[np.ndarray, np.ndarray]:
    """Phi(q) and J q' at states y (..., n), by the generated NumPy kernel, in double.

    Parameters
    ----------
    model : str
        A closed loop's name.
    y : array_like, shape (..., n)
        States.
    p : array_like, shape (..., n_params)
        The parameters (any inputs after them are dropped), broadcasting against y.

    Returns
    -------
    phi, phi_dot : ndarray, shape (..., m)
    """
    y = np.asarray(y, dtype=np.float64)
    p = np.asarray(p, dtype=np.float64)[..., :len(load_model(model).parameters)]   # without the inputs
    with np.errstate(all="ignore"):
        phi, phi_dot = numpy_module(model).constraints(y, p)
    return np.asarray(phi, dtype=np.float64), np.asarray(phi_dot, dtype=np.float64)


def project(model: str, y, p) -> np.ndarray:
    """The state on the constraints nearest y: the coordinates by Gauss-Newton on
    Phi(q) = 0 (each correction the least-squares one, -J^+ Phi), then the rates projected
    orthogonally onto J q' = 0.

    Parameters
    ----------
    model : str
        A closed loop's name.
    y : array_like, shape (n,)
        A state.
    p : array_like
        The parameters (then any inputs), in double.

    Returns
    -------
    ndarray, shape (n,)
        The projected state, |Phi| and |J q'| at roundoff.

    Raises
    ------
    SimulationInputError
        No closed configuration near y (the iteration leaves |Phi| above the start tolerance).
    """
    kernels = numpy_module(model)
    p = np.asarray(p, dtype=np.float64)[:len(load_model(model).parameters)]
    y = np.array(y, dtype=np.float64)
    nq = len(y) // 2
    for _ in range(PROJECTION_ITERATIONS):
        J = np.asarray(kernels.constraint_jacobian(y, p), dtype=np.float64)
        phi, _ = residuals(model, y, p)
        step = np.linalg.lstsq(J, phi, rcond=None)[0]
        y[:nq] -= step
        if np.abs(step).max() <= PROJECTION_STEP * max(1.0, np.abs(y[:nq]).max()):
            break
    phi, _ = residuals(model, y, p)
    if not np.abs(phi).max() <= CONSTRAINT_START_TOLERANCE:
        raise SimulationInputError(f"{model}: no closed configuration found near the state (|Phi| = "
                                   f"{np.abs(phi).max():.3g} after {PROJECTION_ITERATIONS} "
                                   f"Gauss-Newton steps): start nearer a closed loop")
    J = np.asarray(kernels.constraint_jacobian(y, p), dtype=np.float64)
    y[nq:] -= np.linalg.lstsq(J, J @ y[nq:], rcond=None)[0]
    return y


def check_initial_state(model: str, y0, p) -> None:
    """Refuse, in one line naming the largest residual, a start off the constraints.

    Parameters
    ----------
    model : str
        A closed loop's name.
    y0 : array_like, shape (n,)
        The initial state.
    p : array_like
        The parameters (then any inputs).

    Raises
    ------
    SimulationInputError
        |Phi(q0)| or |J q0'| above the contract's CONSTRAINT_START_TOLERANCE.
    """
    phi, phi_dot = residuals(model, y0, p)
    for level, values in (("Phi", phi), ("J q'", phi_dot)):
        worst = int(np.argmax(np.abs(values)))
        value = float(np.abs(values[worst]))
        if not value <= CONSTRAINT_START_TOLERANCE:
            raise SimulationInputError(
                f"{model}: the initial state is off the loop's constraints: |{level}| = {value:.3g} "
                f"(constraint {worst + 1}) exceeds {CONSTRAINT_START_TOLERANCE:g}; "
                f"derive.consistent_state(model, y0, params) projects it onto them")
    J = np.asarray(numpy_module(model).constraint_jacobian(np.asarray(y0, np.float64),
                                                           np.asarray(p, np.float64)[:len(load_model(model).parameters)]),
                   dtype=np.float64)
    singular = np.linalg.svd(J, compute_uv=False)
    if singular.min() <= SINGULAR_START * max(1.0, singular.max()):
        raise SimulationInputError(
            f"{model}: the initial state is a singular configuration of the loop (dPhi/dq has rank "
            f"{int(np.sum(singular > SINGULAR_START * max(1.0, singular.max())))} of {len(singular)} there, "
            f"e.g. a linkage stretched straight: its multipliers are undetermined); start away from it")


def check_initial_states(model: str, ys, ps) -> None:
    """check_initial_state for each row of an ensemble, the trajectory named.

    Parameters
    ----------
    model : str
        A closed loop's name.
    ys : array_like, shape (B, n)
        The initial states.
    ps : array_like, shape (B, n_params + n_inputs)
        Their parameters.

    Raises
    ------
    SimulationInputError
        The first trajectory that starts off the constraints.
    """
    for b, (y, p) in enumerate(zip(np.asarray(ys), np.asarray(ps))):
        try:
            check_initial_state(model, y, p)
        except SimulationInputError as exc:
            raise SimulationInputError(f"trajectory {b}: {exc}") from None


def drift(model: str, y, p) -> ConstraintDrift:
    """The largest |Phi| and |J q'| over a run's output rows (rows after a stop, NaN, are
    left out).

    Parameters
    ----------
    model : str
        A closed loop's name.
    y : array_like, shape (rows, n)
        The run's states.
    p : array_like
        The parameters.

    Returns
    -------
    ConstraintDrift
    """
    y = np.asarray(y, dtype=np.float64)
    y = y[np.isfinite(y).all(axis=1)] if y.ndim == 2 else y
    if len(y) == 0:
        return ConstraintDrift(0.0, 0.0)
    phi, phi_dot = residuals(model, y, p)
    return ConstraintDrift(float(np.abs(phi).max()), float(np.abs(phi_dot).max()))


def report_drift(result, model: str, p):
    """`result` with its constraint_drift set (a closed loop's run), returned."""
    result.constraint_drift = drift(model, result.y, p)
    return result


def free_indices(model: str, independent) -> list[int]:
    """The indices of the coordinates `independent` names (a name or a sequence of names):
    the coordinates a closed loop leaves free, as many as the coordinates less the
    constraints, each named once.

    Parameters
    ----------
    model : str
        A closed loop's name.
    independent : str or sequence of str
        Coordinate names.

    Returns
    -------
    list of int

    Raises
    ------
    SimulationInputError
        An unknown name, a name given twice, or not as many names as the loop leaves free.
    """
    d = load_model(model)
    names = list(d.coordinate_names)
    chosen = [independent] if isinstance(independent, str) else list(independent)
    unknown = [c for c in chosen if c not in names]
    if unknown:
        raise SimulationInputError(f"independent: '{unknown[0]}' is no coordinate of model '{model}' "
                                   f"(its coordinates: {', '.join(names)})")
    if len(set(chosen)) != len(chosen):
        raise SimulationInputError(f"independent: a coordinate named twice: {chosen}")
    free = len(names) - len(d.constraints)
    if len(chosen) != free:
        raise SimulationInputError(f"independent: model '{model}' has {len(names)} coordinates and "
                                   f"{len(d.constraints)} constraints, so {free} free coordinate"
                                   f"{'s' * (free != 1)}; got {len(chosen)} ({', '.join(chosen) or 'none'})")
    return [names.index(c) for c in chosen]


def close_from_free(model: str, ys, ps, free: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """States on the loop from their free coordinates: each row's free coordinates and
    their rates are kept; the other coordinates, from the row's values as the first guess
    (which picks the loop's branch), by Newton on Phi(q) = 0 in them alone; their rates
    from J q' = 0, i.e. J_d q_d' = -J_z z'.  Vectorised over rows (a sweep's chunk).

    Parameters
    ----------
    model : str
        A closed loop's name.
    ys : array_like, shape (B, n)
        States: the free coordinates and rates as wanted, the others guesses.
    ps : array_like, shape (B, n_params) or (n_params,)
        The parameters (then any inputs) of each row.
    free : list of int
        The free coordinates' indices (`free_indices`).

    Returns
    -------
    closed : ndarray, shape (B, n)
        The states; a row that did not close keeps its values.
    ok : ndarray of bool, shape (B,)
        Whether the row closed: |Phi| and |J q'| within the contract's
        CONSTRAINT_START_TOLERANCE, with J_d (dPhi/dq in the other coordinates)
        well conditioned there.  Not: the loop cannot close at these free coordinates
        (a crank angle the linkage cannot reach), Newton left the guess's basin, or the
        free coordinates do not determine the others there (a singular configuration).
    """
    kernels = numpy_module(model)
    y = np.array(ys, dtype=np.float64, ndmin=2)
    B, n = y.shape
    nq = n // 2
    p = np.broadcast_to(np.asarray(ps, dtype=np.float64)[..., :len(load_model(model).parameters)],
                        (B, len(load_model(model).parameters)))
    dep = [i for i in range(nq) if i not in free]
    ok = np.all(np.isfinite(y), axis=1) & np.all(np.isfinite(p), axis=1)
    y[~ok] = 0.0
    with np.errstate(all="ignore"):
        for _ in range(PROJECTION_ITERATIONS):
            J = np.asarray(kernels.constraint_jacobian(y, p), dtype=np.float64).reshape(B, -1, nq)
            Jd = J[:, :, dep]
            usable = ok & _well_conditioned(Jd)
            phi, _ = residuals(model, y, p)
            step = np.zeros((B, len(dep)))
            if usable.any():
                step[usable] = np.linalg.solve(Jd[usable], phi[usable][..., None])[..., 0]
            y[:, dep] -= np.where(usable[:, None], step, 0.0)
            scale = np.maximum(1.0, np.abs(y[:, :nq]).max(axis=1))
            if np.all(~usable | (np.abs(step).max(axis=1) <= PROJECTION_STEP * scale)):
                break
        J = np.asarray(kernels.constraint_jacobian(y, p), dtype=np.float64).reshape(B, -1, nq)
        Jd, Jz = J[:, :, dep], J[:, :, free]
        ok &= _well_conditioned(Jd)
        rates = np.zeros((B, len(dep)))
        zdot = y[:, [nq + i for i in free]]
        if ok.any():
            rates[ok] = -np.linalg.solve(Jd[ok], (Jz[ok] @ zdot[ok][..., None]))[..., 0]
        y[:, [nq + i for i in dep]] = np.where(ok[:, None], rates, y[:, [nq + i for i in dep]])
        phi, phi_dot = residuals(model, y, p)
        ok &= (np.abs(phi).max(axis=1) <= CONSTRAINT_START_TOLERANCE) \
            & (np.abs(phi_dot).max(axis=1) <= CONSTRAINT_START_TOLERANCE)
    y[~ok] = np.asarray(ys, dtype=np.float64).reshape(B, n)[~ok]
    return y, ok


def _well_conditioned(Jd: np.ndarray) -> np.ndarray:
    """Rows whose J_d may be solved with: finite, and its smallest singular value above
    the contract's singular-start threshold relative to its largest (as check_initial_state)."""
    finite = np.all(np.isfinite(Jd), axis=(1, 2))
    s = np.linalg.svd(np.where(finite[:, None, None], Jd, 0.0), compute_uv=False)
    return finite & (s[:, -1] > SINGULAR_START * np.maximum(1.0, s[:, 0]))
