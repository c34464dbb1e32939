"""`derive.linearize` and `derive.equilibria`: the linear model of a pendulum at a point.

With the state x = (q, q') and the inputs u, the model is x' = f(x, u) = (q', q''),
M(q) q'' = F(q, q', u).  Its linearisation at (x, u) is

    A = df/dx  (n_states x n_states),   B = df/du  (n_states x n_inputs),

and the rows of q'' come from differentiating M q'' = F implicitly,

    d q''/d z = M^-1 (dF/dz - (dM/dz) q''),

with dF/dz and dM/dz symbolic (the derivation's), evaluated at the point, and the
solve numerical.  M^-1 F is never formed symbolically, not even for the small models:
measured, its Jacobian and lambdify cost the planar double pendulum about 18 times the
implicit pieces and the triple chain about 26 times (the commit that added this module
has the figures), and the implicit form is the one the generated `<model>_linearize`
kernels compute too (derive/codegen/spec.py).
"""
from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import sympy as sp

from ..derivation import derive
from ..derivation.lagrange import link_blocks
from ..derivation.symbols import t as TIME
from ..errors import ModelError, SimulationInputError
from ..model import load_model
from ..model.description import PRISMATIC, forget_on_model_change
from ..model.expressions import parse_expression
from . import constraints
from .loader import numpy_module
from .simulate import _input_values, model_ref, normalise_params, resolve_model

# A real part of an eigenvalue of A within this (relative to the largest magnitude) is
# taken as zero: the conservative pendulum's hanging modes are exactly imaginary, and
# the rounding of the solve leaves a real part of order 1e-16 of the spectrum.
MARGINAL = 1e-9
LOOP_SEED = 0              # a loop's rests: the random coordinates projected to find its branches ...
LOOP_STARTS = 24           # ... this many of them
LOOP_GRID = 48             # starts per branch over the free coordinates (a grid of about this many)
LOOP_NEWTON = 60           # Newton steps on z'' = 0 from each start
LOOP_MAX_STEP = 0.5        # ... each at most this long (radians), so a start stays on its branch
LOOP_SAME = 1e-7           # two closed configurations closer than this are one
LOOP_DIFFERENCE = 1e-6     # the central differences of z''(z), relative to max(1, |z|)
LOOP_STEP_TOLERANCE = 1e-12   # Newton stops at a correction this small (relative to max(1, |q|))
POLAR_SINE_MIN = 1e-6      # the generated kernels' default chart-singularity threshold


class ChartSingular(SimulationInputError):
    """The state is a singular point of the model's chart (or its mass matrix is singular)."""


@dataclass(frozen=True)
class Pieces:
    """A model's M, F and their derivatives as NumPy functions of (q, q', p, u, [t]) (t:
    the time, which only a time-dependent model's use)."""
    nq: int
    n_inputs: int
    mass: object          # M(q, p)
    forcing: object       # F(q, q', p, u)
    dF_dx: object         # dF/d(q, q'), nq x 2 nq
    dF_du: object         # dF/du, nq x n_inputs
    dM_dq: object         # [dM/dq_k for k], nq matrices nq x nq
    polar_sines: object   # the chart's polar sines (one per spherical link), or None
    # a closed loop (a model with constraints), else None: Phi, J = dPhi/dq, [dJ/dq_k for k]
    phi: object = None
    J: object = None
    dJ_dq: object = None


@forget_on_model_change
@lru_cache(maxsize=64)
def _pieces(name: str) -> Pieces:
    """The lambdified pieces of the implicit Jacobian of model `name` (a resolved name)."""
    d = derive(name)
    s = d.symbols
    args = [list(s.q), list(s.qd), list(s.params), list(s.u), [TIME]]
    x = sp.Matrix(s.state)

    def numeric(expr):
        return sp.lambdify(args, expr, "numpy")

    dF_du = d.F.jacobian(sp.Matrix(s.u)) if s.u else sp.zeros(len(s.q), 0)
    loop = {}
    if d.constraints is not None:
        c = d.constraints
        loop = dict(phi=numeric(c.Phi), J=numeric(c.J), dJ_dq=numeric([c.J.diff(qk) for qk in s.q]))
    return Pieces(len(s.q), len(s.u), numeric(d.M), numeric(d.F), numeric(d.F.jacobian(x)),
                  numeric(dF_du), numeric([d.M.diff(qk) for qk in s.q]),
                  numeric(list(d.polar_sines)) if d.polar_sines else None, **loop)


def state_values(ref, state) -> np.ndarray:
    """The state as floats in the model's order: a sequence, or a mapping by name where
    a coordinate or rate left out is 0 and a value may be an expression such as 'pi/2'.

    Parameters
    ----------
    ref : ModelRef
        The resolved model (derive.runtime.simulate.model_ref).
    state : mapping or sequence

    Returns
    -------
    ndarray, shape (n_states,)
    """
    return _state_values(ref, state)


def _state_values(ref, state) -> np.ndarray:
    """state_values's work."""
    names = list(ref.info.state_names)
    if isinstance(state, Mapping):
        unknown = sorted(set(state) - set(names))
        if unknown:
            raise SimulationInputError(f"unknown state name '{unknown[0]}' of model '{ref}' "
                                       f"(state: {', '.join(names)})")
        return np.array([_number(state.get(n, 0.0), f"state {n}") for n in names], np.float64)
    values = np.asarray(state, dtype=object).reshape(-1)
    if len(values) != len(names):
        raise SimulationInputError(f"model '{ref}' has {len(names)} state values ({', '.join(names)}), "
                                   f"got {len(values)}")
    return np.array([_number(v, f"state {n}") for n, v in zip(names, values)], np.float64)


def parse_value(value, what: str) -> float:
    """A finite float from a number or an expression of numbers and pi ('pi', '3*pi/4').

    Parameters
    ----------
    value : str or number
    what : str
        What the value is, for the message of a bad one.

    Returns
    -------
    float

    Raises
    ------
    SimulationInputError
        Not a number, or not finite.
    """
    return _number(value, what)


def _number(value, what: str) -> float:
    """A finite float from a number or an expression of numbers and pi ('pi', '3*pi/4')."""
    if isinstance(value, str):
        try:
            value = float(parse_expression(value, {}, what).evalf())
        except (ModelError, TypeError, ValueError):
            raise SimulationInputError(f"{what}: {value!r} is no number (a number or an expression such as 3*pi/4)") from None
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
        raise SimulationInputError(f"{what} must be a number, got {value!r}")
    if not np.isfinite(float(value)):
        raise SimulationInputError(f"{what} is not finite: {value!r}")
    return float(value)


def _inputs_values(ref, inputs) -> np.ndarray:
    names = ref.description.inputs
    if not names:
        if inputs is not None and len(inputs):
            raise SimulationInputError(f"model '{ref}' has no inputs; got inputs={inputs!r}")
        return np.zeros(0)
    if inputs is None:
        return np.zeros(len(names))               # u = 0: the unforced model
    if isinstance(inputs, Mapping):
        inputs = {n: inputs.get(n, 0.0) for n in names} if not set(inputs) - set(names) else inputs
    return np.asarray(_input_values(ref, names, inputs), np.float64)


def _resolve(model, explicit_time: bool = False, stage: str | None = None, loops: bool = False):
    ref = model_ref(resolve_model(model, explicit_time=explicit_time, stage=stage))
    if ref.atlas is not None:
        raise SimulationInputError(f"'{ref}' is a chart atlas: linearize one of its charts "
                                   f"({', '.join(ref.atlas.charts)})")
    if not loops and load_model(str(ref)).is_constrained:
        raise SimulationInputError(f"model '{ref}' has constraints (a closed loop): the rests of an open "
                                   f"chain are not the loop's; derive.linearize takes its rest points with "
                                   f"independent= (the coordinates the loop leaves free)")
    return ref


def linearize(model, state, params, inputs=None, t=None, independent=None) -> tuple[np.ndarray, np.ndarray]:
    """The linearisation x' ~ A (x - x0) + B (u - u0) of a model at a state and inputs (and,
    for a time-dependent model, at a time t).

    A closed loop (a model with constraints Phi(q) = 0) is linearized in the coordinates
    it leaves free: `independent` names them (as many as the coordinates less the
    constraints), x = (z, z') with z those coordinates, and the others follow from the
    loop (q = g(z) near the state).  Its state must be on the loop and at rest (q' = 0:
    its equilibria, and the rest points a controller starts from).

    Parameters
    ----------
    model : str or path
        A catalogue name or the path of a model file (not a chart atlas).
    state : mapping or sequence
        The state x0 = (q, q'): a sequence in the model's state order, or a mapping by
        name in which a value left out is 0 and a value may be an expression ("pi").
    params : mapping or sequence
        The parameters, as `derive.simulate` takes them.
    inputs : mapping or sequence, optional
        The inputs u0 (default 0; a mapping may leave some out, they are 0).
    t : float or str, optional
        The time of the linearisation: required for a time-dependent model (t in its
        forces, dissipation or pivot), whose A and B depend on it; any other model's do not.
    independent : sequence of str, optional
        A closed loop's free coordinates, in the order of the reduced state (required for
        a closed loop, refused for an open chain).

    Returns
    -------
    A : ndarray, shape (n_states, n_states)
        df/dx at (x0, u0), x = (q, q'); a closed loop's x = (z, z'), 2 len(independent).
    B : ndarray, shape (n_states, n_inputs)
        df/du at (x0, u0); zero columns for a model without inputs.

    Raises
    ------
    SimulationInputError
        An unknown model, name or value, a singular mass matrix at the state, or a
        time-dependent model without t; for a closed loop, a state off the loop or not at
        rest, or independent coordinates the loop does not leave free there.

    Examples
    --------
    >>> import numpy as np
    >>> import derive
    >>> params = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}
    >>> A, B = derive.linearize("planar", {"theta1": 0.0, "theta2": 0.0}, params)
    >>> A.shape, B.shape                       # planar has no inputs: B has no columns
    ((4, 4), (4, 0))
    >>> omega = np.sort(np.abs(np.linalg.eigvals(A).imag))[::2]     # hanging: two normal modes
    >>> np.round(omega ** 2 / 9.81, 4)        # 2 -+ sqrt(2) for unit masses and lengths
    array([0.5858, 3.4142])
    >>> A, _ = derive.linearize("planar", {"theta1": "pi", "theta2": "pi"}, params)
    >>> bool(np.linalg.eigvals(A).real.max() > 0)     # upright: unstable
    True
    """
    ref = _resolve(model, explicit_time=True, loops=True)
    x = _state_values(ref, state)
    p = np.asarray(normalise_params(ref, params), np.float64)
    u = _inputs_values(ref, inputs)
    pc = _pieces(ref.name)
    if pc.J is None:
        if independent is not None:
            raise SimulationInputError(f"model '{ref}' has no constraints: independent= is for a closed "
                                       f"loop's free coordinates (all of an open chain's are)")
        return _jacobians(pc, x, p, u, ref, _time(ref, t))
    return _loop_jacobians(pc, x, p, u, ref, _time(ref, t), _free_coordinates(ref, pc, independent))


def _time(ref, t) -> float:
    """The time of a linearisation: a time-dependent model's must be given."""
    if t is None:
        if ref.description.is_time_dependent:
            raise SimulationInputError(f"{ref}: explicit time in the model (t in its forces, dissipation or "
                                       f"pivot): its A and B depend on t; give t= (the time to linearize at)")
        return 0.0
    return _number(t, "t")


def _jacobians(pc: Pieces, x: np.ndarray, p: np.ndarray, u: np.ndarray, where,
               t: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A and B at one point (at the time t) from the implicit form (module docstring)."""
    nq = pc.nq
    q, qd, at = x[:nq], x[nq:], [t]
    if pc.polar_sines is not None and \
            np.min(np.abs(np.asarray(pc.polar_sines(q, qd, p, u, at), np.float64))) < POLAR_SINE_MIN:
        raise ChartSingular(f"model '{where}': the chart is singular at state {x.tolist()} (a polar "
                            f"sine below {POLAR_SINE_MIN:g}): linearize in another chart of the link")
    M = np.asarray(pc.mass(q, qd, p, u, at), np.float64)
    F = np.asarray(pc.forcing(q, qd, p, u, at), np.float64).reshape(nq)
    try:
        qdd = np.linalg.solve(M, F)
        dM = np.asarray(pc.dM_dq(q, qd, p, u, at), np.float64).reshape(nq, nq, nq)
        rhs = np.asarray(pc.dF_dx(q, qd, p, u, at), np.float64).reshape(nq, 2 * nq)
        rhs[:, :nq] -= np.einsum("kij,j->ik", dM, qdd)
        dqdd_dx = np.linalg.solve(M, rhs)
        dqdd_du = np.linalg.solve(M, np.asarray(pc.dF_du(q, qd, p, u, at), np.float64).reshape(nq, pc.n_inputs))
    except np.linalg.LinAlgError:
        raise ChartSingular(f"model '{where}': the mass matrix is singular at state "
                                   f"{x.tolist()} (a chart singularity?)") from None
    A = np.zeros((2 * nq, 2 * nq))
    A[:nq, nq:] = np.eye(nq)
    A[nq:, :] = dqdd_dx
    B = np.zeros((2 * nq, pc.n_inputs))
    B[nq:, :] = dqdd_du
    return A, B


# -- closed loops --------------------------------------------------------------------
#
# On the loop the coordinates are q = g(z), z the free ones, and q' = G z' with
# G = dg/dz = [I; D] (rows of z: I; the others: D = -J_d^-1 J_z, J_z and J_d the columns
# of J = dPhi/dq of z and of the others).  J G = 0, so G^T removes the multipliers from
# M q'' + J^T lambda = F, and with q'' = G z'' + G' z' the loop's equations in z are
#
#     M_r z'' = G^T (F - M G' z'),    M_r = G^T M G.
#
# At rest (z' = 0) the term G' z' is of second order in z': it drops out of the
# derivatives, and with z'' = M_r^-1 G^T F at the point,
#
#     dz''/dz_k  = M_r^-1 (dG_k^T F + G^T (dF/dq) G_k - (dM_r/dz_k) z''),
#     dz''/dz'   = M_r^-1 G^T (dF/dq') G,      dz''/du = M_r^-1 G^T dF/du,
#
# where G_k is G's column k, dG_k = dG/dz_k, and dD/dz_k = -J_d^-1 (dJ/dz_k) G (the
# derivative of J G = 0 along z_k, dJ/dz_k = sum_j dJ/dq_j G_jk) gives dG's other rows.
# dG_k^T F does not vanish: at rest F = J^T lambda holds the loop (its constraint forces),
# and the curvature of the loop turns them into stiffness.

LOOP_CLOSED = 1e-9          # |Phi| and |J q'| (relative to the lengths' scale) taken as zero


def _free_coordinates(ref, pc: Pieces, independent) -> list[int]:
    """The indices of a closed loop's free coordinates, from `independent` (their names)."""
    names = list(ref.info.state_names[:pc.nq])
    if independent is None:
        raise SimulationInputError(f"model '{ref}' has constraints (a closed loop): give independent= (--independent: the "
                                   f"coordinates it leaves free, of {', '.join(names)}), e.g. "
                                   f"independent={names[:1]!r}")
    chosen = [independent] if isinstance(independent, str) else list(independent)
    unknown = [c for c in chosen if c not in names]
    if unknown:
        raise SimulationInputError(f"independent: '{unknown[0]}' is no coordinate of model '{ref}' "
                                   f"(coordinates: {', '.join(names)})")
    if len(set(chosen)) != len(chosen):
        raise SimulationInputError(f"independent: a coordinate named twice: {chosen}")
    return [names.index(c) for c in chosen]


def _loop_jacobians(pc: Pieces, x: np.ndarray, p: np.ndarray, u: np.ndarray, where, t: float,
                    free: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """A and B of a closed loop at a rest point on the loop, in its free coordinates
    (the section's comment)."""
    nq = pc.nq
    q, qd, at = x[:nq], x[nq:], [t]
    args = (q, qd, p, u, at)
    J = np.atleast_2d(np.asarray(pc.J(*args), np.float64))
    m = J.shape[0]
    names = list(where.info.state_names)
    if len(free) != nq - m:
        raise SimulationInputError(f"model '{where}': its {m} constraints leave {nq - m} of its {nq} coordinates "
                                   f"free; independent= names {len(free)}")
    phi = np.abs(np.asarray(pc.phi(*args), np.float64)).max()
    scale = max(1.0, float(np.abs(p).max()))
    if phi > LOOP_CLOSED * scale:
        raise SimulationInputError(f"model '{where}': the state is off the loop (|Phi| = {phi:.3g}); "
                                   f"derive.consistent_state (the command line: --project) puts it on")
    if np.abs(qd).max() > 0:
        moving = [n for n, v in zip(names[nq:], qd) if v]
        raise SimulationInputError(f"model '{where}': a closed loop is linearized at rest (q' = 0), got "
                                   f"{moving[0]} = {qd[names[nq:].index(moving[0])]:g}")
    dep = [i for i in range(nq) if i not in free]
    Jd, Jz = J[:, dep], J[:, free]
    if np.linalg.cond(Jd) > 1e12:
        raise SimulationInputError(f"model '{where}': the loop does not leave "
                                   f"{', '.join(names[i] for i in free)} free at this state (the others' "
                                   f"columns of dPhi/dq are singular there): choose other independent=")
    k = nq - m
    G = np.zeros((nq, k))
    G[free, :] = np.eye(k)
    G[dep, :] = -np.linalg.solve(Jd, Jz)
    M = np.asarray(pc.mass(*args), np.float64)
    F = np.asarray(pc.forcing(*args), np.float64).reshape(nq)
    dF = np.asarray(pc.dF_dx(*args), np.float64).reshape(nq, 2 * nq)
    dM = np.asarray(pc.dM_dq(*args), np.float64).reshape(nq, nq, nq)
    dJ = np.asarray(pc.dJ_dq(*args), np.float64).reshape(nq, m, nq)
    Mr = G.T @ M @ G
    try:
        zdd = np.linalg.solve(Mr, G.T @ F)
    except np.linalg.LinAlgError:
        raise ChartSingular(f"model '{where}': the loop's mass matrix is singular at state {x.tolist()}") from None
    K = np.empty((k, k))
    for c in range(k):
        dJc = np.einsum("jab,j->ab", dJ, G[:, c])          # dJ/dz_c
        dG = np.zeros((nq, k))
        dG[dep, :] = -np.linalg.solve(Jd, dJc @ G)
        dMc = np.einsum("jab,j->ab", dM, G[:, c])          # dM/dz_c
        dMr = dG.T @ M @ G + G.T @ dMc @ G + G.T @ M @ dG
        K[:, c] = dG.T @ F + G.T @ dF[:, :nq] @ G[:, c] - dMr @ zdd
    C = G.T @ dF[:, nq:] @ G
    Bu = G.T @ np.asarray(pc.dF_du(*args), np.float64).reshape(nq, pc.n_inputs)
    A = np.zeros((2 * k, 2 * k))
    A[:k, k:] = np.eye(k)
    A[k:, :k] = np.linalg.solve(Mr, K)
    A[k:, k:] = np.linalg.solve(Mr, C)
    B = np.zeros((2 * k, pc.n_inputs))
    B[k:, :] = np.linalg.solve(Mr, Bu)
    return A, B


# -- equilibria --------------------------------------------------------------------


def stability(A: np.ndarray) -> str:
    """'unstable' (an eigenvalue with a positive real part), 'stable' (all negative), or
    'marginal' (the largest real part is zero: a conservative centre).

    Parameters
    ----------
    A : ndarray
        The state matrix of a linearisation (finite).

    Returns
    -------
    str
    """
    eig = np.linalg.eigvals(A)
    scale = max(float(np.max(np.abs(eig), initial=0.0)), 1.0)
    top = float(eig.real.max())
    if top > MARGINAL * scale:
        return "unstable"
    return "marginal" if top >= -MARGINAL * scale else "stable"


def _wrapped(angle: sp.Expr) -> float:
    """An exact angle as the float of its value in (-pi, pi] (pi stays the double nearest pi)."""
    turns = sp.floor((angle + sp.pi) / (2 * sp.pi))
    angle = angle - 2 * sp.pi * turns
    return float(sp.pi if angle == -sp.pi else angle)


def _link_rests(d) -> list[list[dict]]:
    """For each link, its coordinate values hanging and upright (the height of its
    direction stationary, d e[-1] / d q_link = 0, with e vertical: a chart's own
    singular points, where the gradient vanishes with e slanted, are left out), one
    point for each, angles in (-pi, pi]; a coordinate the height does not depend on
    (an azimuth at the pole) is 0."""
    s = d.symbols
    rests = []
    for block in link_blocks(d.model, s):
        coords = list(s.q[block.rows])
        eqs = [e for e in (sp.expand_trig(block.e[-1].diff(c)) for c in coords) if e != 0]
        found = sp.solve(eqs, coords, dict=True) if eqs else [{}]
        by_side: dict[int, dict] = {}
        for sol in found:
            at = {c: sp.sympify(sol.get(c, 0)).subs({o: 0 for o in coords}) for c in coords}
            if not all(v.is_number for v in at.values()):
                continue
            height = float(block.e[-1].subs(at))
            if abs(abs(height) - 1) > 1e-12:
                continue
            by_side.setdefault(int(np.sign(height)), {c.name: _wrapped(v) for c, v in at.items()})
        rests.append([by_side[k] for k in sorted(by_side)])          # hanging (-1) first
    return rests


def _check_rests_are_a_chains(model, where: str) -> None:
    """equilibria() enumerates a chain's rests under gravity (each link hanging or upright);
    a model with more in it has other rests, which that list would miss or get wrong."""
    what = ("a slider, a branch, an offset or a massless link" if not model.is_chain
            else "springs" if model.springs else "a potential of its own" if model.potential is not None
            else "loads at points" if model.loads else None)
    if what is not None:
        raise SimulationInputError(f"{where}: equilibria lists the rests of a chain under gravity alone "
                                   f"(each link hanging or upright); this model has {what}, whose rests "
                                   f"are elsewhere: linearize at a state you choose, "
                                   f"derive.linearize(model, state, params)")


def _angles(model) -> np.ndarray:
    """Which coordinates are angles (wrapped to (-pi, pi]): all but a slider's length."""
    return np.array([link.joint != PRISMATIC for link in model.links for _ in link.coordinates], bool)


def _wrap(q: np.ndarray, angles: np.ndarray) -> np.ndarray:
    return np.where(angles, np.angle(np.exp(1j * q)), q)


def _loop_branches(ref, p: np.ndarray, pc: Pieces) -> list[np.ndarray]:
    """The loop's distinct closed configurations reached from random coordinates (its
    branches: a four-bar closes in two mirror images), each a guess for the others."""
    rng = np.random.default_rng(LOOP_SEED)
    nq = pc.nq
    angles = _angles(ref.description)
    found: list[np.ndarray] = []
    for _ in range(LOOP_STARTS):
        y = np.zeros(2 * nq)
        y[:nq] = np.where(angles, rng.uniform(-np.pi, np.pi, nq), rng.normal(0.0, 1.0, nq))
        try:
            q = _wrap(constraints.project(ref.name, y, p)[:nq], angles)
        except SimulationInputError:
            continue
        if not any(np.abs(_wrap(q - other, angles)).max() < LOOP_SAME for other in found):
            found.append(q)
    return found


def _loop_equilibria(ref, p: np.ndarray, free: list[int]) -> list[dict]:
    """A closed loop's rests, q' = 0 and u = 0 with z'' = 0 in its free coordinates z:
    Newton on z''(z) from a grid of z on every branch found, all starts at once (the
    NumPy kernels are vectorised), the others closed from the current state at every
    step (continuation keeps the branch); each rest once, its stability from A."""
    pc = _pieces(ref.name)
    nq, names = pc.nq, list(ref.info.state_names)
    k = len(free)
    angles = _angles(ref.description)
    u = np.zeros(pc.n_inputs)
    grid = np.linspace(-np.pi, np.pi, max(2, round(LOOP_GRID ** (1 / k))), endpoint=False)
    starts = []
    for guess in _loop_branches(ref, p, pc):
        for z in itertools.product(grid, repeat=k):
            y = np.r_[guess, np.zeros(nq)]
            y[free] = z
            starts.append(y)
    rests: list[tuple[np.ndarray, np.ndarray]] = []
    if not starts:
        return []
    for y in _newton_rests(ref, np.array(starts), p, free):
        y[:nq] = _wrap(y[:nq], angles)
        y[:nq][np.abs(y[:nq]) < LOOP_SAME * 1e-6] = 0.0       # roundoff about an exact zero (hanging straight)
        if any(np.abs(_wrap(y[:nq] - other[:nq], angles)).max() < LOOP_SAME for other, _ in rests):
            continue
        try:
            A, _ = _loop_jacobians(pc, y, p, u, ref, 0.0, free)
        except SimulationInputError:           # the free coordinates are not free there
            continue
        rests.append((y, A))
    rests.sort(key=lambda r: tuple(np.round(r[0][:nq], 9)))
    return [{"state": dict(zip(names, map(float, y))), "stability": stability(A),
             "eigenvalues": np.linalg.eigvals(A)} for y, A in rests]


def _newton_rests(ref, Y: np.ndarray, p: np.ndarray, free: list[int]) -> np.ndarray:
    """The rests Newton reaches from the starts Y (S, n): rows of z''(z) = 0 on the loop,
    the Jacobian by central differences (each side closed too); rows that leave the loop,
    lose their free coordinates or do not converge are dropped."""
    name, nq, k = ref.name, Y.shape[1] // 2, len(free)
    kernels = numpy_module(name)
    n_inputs = len(ref.info.input_names)
    extra = (np.zeros(n_inputs),) if n_inputs else ()

    def accelerations(y):
        closed, ok = constraints.close_from_free(name, y, p, free)
        with np.errstate(all="ignore"):
            f = np.asarray(kernels.rhs(closed, p, *extra), np.float64)[:, [nq + i for i in free]]
        return closed, ok & np.all(np.isfinite(f), axis=1), f

    active = np.ones(len(Y), bool)
    done = np.zeros(len(Y), bool)
    for _ in range(LOOP_NEWTON):
        rows = np.flatnonzero(active & ~done)
        if not len(rows):
            break
        Y[rows], ok, f = accelerations(Y[rows])
        D = np.empty((len(rows), k, k))
        for c in range(k):
            h = LOOP_DIFFERENCE * np.maximum(1.0, np.abs(Y[rows, free[c]]))
            plus, minus = Y[rows].copy(), Y[rows].copy()
            plus[:, free[c]] += h
            minus[:, free[c]] -= h
            _, ok_p, fp = accelerations(plus)
            _, ok_m, fm = accelerations(minus)
            ok &= ok_p & ok_m
            D[:, :, c] = (fp - fm) / (2 * h[:, None])
        ok &= np.all(np.isfinite(D), axis=(1, 2)) & (np.abs(np.linalg.det(np.where(ok[:, None, None], D, 1.0))) > 0)
        active[rows[~ok]] = False
        rows, f, D = rows[ok], f[ok], D[ok]
        step = np.clip(np.linalg.solve(D, f[..., None])[..., 0], -LOOP_MAX_STEP, LOOP_MAX_STEP)
        Y[np.ix_(rows, free)] -= step
        scale = np.maximum(1.0, np.abs(Y[rows, :nq]).max(axis=1))
        done[rows[np.abs(step).max(axis=1) <= LOOP_STEP_TOLERANCE * scale]] = True
    rows = np.flatnonzero(active & done)
    closed, ok = constraints.close_from_free(name, Y[rows], p, free)
    return closed[ok]


def equilibria(model, params, independent=None) -> list[dict]:
    """The equilibria of a model with q' = 0 and u = 0 (dV/dq = 0), with their stability.

    For a chain each link rests hanging or upright, so a chain of N links has 2^N of
    them (a spherical link in a chart whose pole is there has its azimuth set to 0).
    A closed loop's rests are found numerically in the coordinates it leaves free
    (`independent`): Newton on their accelerations at rest from a grid of starts on every
    branch of the loop, each rest listed once with its stability in those coordinates.

    Parameters
    ----------
    model : str or path
        A catalogue name or the path of a model file (not a chart atlas).
    params : mapping or sequence
        The parameters, as `derive.simulate` takes them.
    independent : sequence of str, optional
        A closed loop's free coordinates (as `derive.linearize` takes them); only for a loop.

    Returns
    -------
    list of dict
        One per equilibrium: ``state`` (a dict by state name, rates 0), ``stability``
        ('stable', 'marginal', 'unstable': see `stability`; 'chart singular' where the
        model's chart is, e.g. spherical_std at a pole, with NaN eigenvalues) and
        ``eigenvalues`` (of A there, a complex ndarray).

    Raises
    ------
    SimulationInputError
        An unknown model, the chart atlas, parameters that do not fit the model, a
        time-dependent model, a closed loop without `independent`.

    Examples
    --------
    >>> import derive
    >>> params = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}
    >>> for rest in derive.equilibria("planar", params):
    ...     print(round(rest["state"]["theta1"], 4), round(rest["state"]["theta2"], 4), rest["stability"])
    0.0 0.0 marginal
    0.0 3.1416 unstable
    3.1416 0.0 unstable
    3.1416 3.1416 unstable
    """
    ref = _resolve(model, explicit_time=True, loops=True)
    if ref.description.is_time_dependent:
        raise SimulationInputError(f"{ref}: explicit time in the model (t in its forces, dissipation or pivot): "
                                   f"a rest state of q'' = f(q, q', t) need not exist; linearize at a time "
                                   f"instead, derive.linearize(model, state, params, t=...)")
    if ref.description.is_constrained:
        free = _free_coordinates(ref, _pieces(ref.name), independent)
        return _loop_equilibria(ref, np.asarray(normalise_params(ref, params), np.float64), free)
    if independent is not None:
        raise SimulationInputError(f"model '{ref}' has no constraints: independent= is for a closed loop")
    _check_rests_are_a_chains(ref.description, str(ref))
    p = np.asarray(normalise_params(ref, params), np.float64)
    d = derive(ref.name)
    pc = _pieces(ref.name)
    u = np.zeros(pc.n_inputs)
    names = list(ref.info.state_names)
    out = []
    for combo in itertools.product(*_link_rests(d)):
        state = dict.fromkeys(names, 0.0)
        for part in combo:
            state.update(part)
        x = np.array([state[n] for n in names])
        try:
            A, _ = _jacobians(pc, x, p, u, ref)
        except ChartSingular:
            out.append({"state": state, "stability": "chart singular",
                        "eigenvalues": np.full(len(names), np.nan + 0j)})
            continue
        out.append({"state": state, "stability": stability(A), "eigenvalues": np.linalg.eigvals(A)})
    return out
