"""Independent physics checks of the derivation.

These do not look at the seeds at all: they test the derived equations against
facts any correct double pendulum must satisfy.  Each check returns a
``Check`` with a one-line detail; ``run_all`` runs them all.
"""
from __future__ import annotations

import random
from dataclasses import dataclass, field

import mpmath
import sympy as sp

from .. import cachefile
from ..derivation import derive
from ..derivation.charts import chart_change
from ..derivation.loop_closure import augmented_system
from ..model import load_model, model_names
from .zero import DIGITS, matrix_is_zero, random_point, trig_is_zero
from ..derivation.symbols import parse_quantity, t as TIME
from ..errors import ModelError
from ..model.atlas import atlas_for
from ..model.reductions import reduction
from ..derivation.reduction_maps import parameter_match

SPHERICAL_PAIRS = [("spherical_std", "spherical_alt"), ("spherical_alt", "spherical_std"),
                   ("spherical_std", "spherical_rot"), ("spherical_rot", "spherical_alt")]


@cachefile.register
@dataclass
class Check:
    name: str
    passed: bool
    detail: str
    # What a document reports: the models concerned, the number of states the
    # check was evaluated at (0: exact only), the agreement demanded and reached,
    # and SymPy objects a document may typeset (e.g. the solved parameters).
    models: tuple = ()
    states: int = 0
    tolerance: str = ""
    worst: str = ""
    exprs: dict = field(default_factory=dict)


def _numeric(expr, symbols):
    """An mpmath function of the given symbols (40 digits when called under workdps)."""
    return sp.lambdify(symbols, expr, modules="mpmath")


_system_functions: dict[str, tuple] = {}


def _args(d) -> tuple:
    """What a model's expressions depend on: state, parameters, run-time inputs (and the
    time, for a time-dependent model: the random points are random times too)."""
    time = (TIME,) if d.model.is_time_dependent else ()
    return d.symbols.state + d.symbols.params + d.symbols.u + time


def _system(d) -> tuple:
    """M and F of a derivation compiled once: functions of (state, params, inputs)."""
    key = (d.name, d.model.content_hash)
    if key not in _system_functions:
        args = _args(d)
        _system_functions[key] = (_numeric(d.M, args), _numeric(d.F, args))
    return _system_functions[key]


def accelerations(d, point: dict) -> mpmath.matrix:
    """q'' at a point by solving M q'' = F in 40-digit arithmetic."""
    M_of, F_of = _system(d)
    values = [point[s] for s in _args(d)]
    with mpmath.workdps(DIGITS):
        return mpmath.lu_solve(mpmath.matrix(M_of(*values).tolist()),
                               mpmath.matrix(F_of(*values).tolist()))


def _loop_system(d) -> tuple:
    """A closed loop's [M J^T; J 0], [F; gamma] and J compiled once (functions of the
    state, parameters and inputs)."""
    key = (d.name, d.model.content_hash, "loop")
    if key not in _system_functions:
        args = _args(d)
        A, b = augmented_system(d.M, d.F, d.constraints)
        _system_functions[key] = (_numeric(A, args), _numeric(b, args), _numeric(d.constraints.J, args))
    return _system_functions[key]


def on_the_loop(d, point: dict) -> dict:
    """`point` with its rates projected onto J q' = 0 (q' - J^T (J J^T)^-1 J q'), in
    40-digit arithmetic: a state a closed loop's motion can pass through at these
    coordinates' rates (Phi(q) = 0 is not needed by the identities checked at it)."""
    J_of = _loop_system(d)[2]
    rates = d.symbols.qd
    with mpmath.workdps(DIGITS):
        J = mpmath.matrix(J_of(*[point[s] for s in _args(d)]).tolist())
        v = mpmath.matrix([point[r] for r in rates])
        v = v - J.T * mpmath.lu_solve(J * J.T, J * v)
    return {**point, **{r: v[k] for k, r in enumerate(rates)}}


def loop_accelerations(d, point: dict) -> mpmath.matrix:
    """A closed loop's q'' at a point, from its augmented system in 40-digit arithmetic."""
    A_of, b_of, _ = _loop_system(d)
    values = [point[s] for s in _args(d)]
    with mpmath.workdps(DIGITS):
        x = mpmath.lu_solve(mpmath.matrix(A_of(*values).tolist()), mpmath.matrix(b_of(*values).tolist()))
    return x[:len(d.symbols.q), 0] if len(d.symbols.q) > 1 else mpmath.matrix([x[0]])


def loop_stays_closed(name, n_points: int = 20) -> Check:
    """A closed loop's accelerations keep it closed: the second time derivative of each
    constraint, d2 Phi/dt2 = (dPhi/dq) q'' + q'^T (d2 Phi/dq2) q' (from Phi itself, not
    from the derivation's gamma), vanishes at random states with J q' = 0."""
    d = derive(name)
    s, args = d.symbols, list(_args(d))
    qd = sp.Matrix(s.qd)
    Phi = d.constraints.Phi
    grad = _numeric(Phi.jacobian(sp.Matrix(s.q)), args)
    curvature = _numeric(sp.Matrix([(qd.T * sp.hessian(c, s.q) * qd)[0, 0] for c in Phi]), args)
    rng, worst = random.Random(17), mpmath.mpf(0)
    with mpmath.workdps(DIGITS):
        for _ in range(n_points):
            pt = on_the_loop(d, random_point(_args(d), rng))
            vals = [pt[x] for x in args]
            acc = loop_accelerations(d, pt)
            G, C = mpmath.matrix(grad(*vals).tolist()), mpmath.matrix(curvature(*vals).tolist())
            for i in range(len(Phi)):
                terms = [G[i, j] * acc[j] for j in range(len(s.q))] + [C[i]]
                worst = max(worst, abs(sum(terms)) / (sum(abs(t) for t in terms) or 1))
    return Check(f"{d.name}: the loop stays closed (d2 Phi/dt2 = 0)", worst < mpmath.mpf(10) ** -30,
                 f"largest relative d2 Phi/dt2 over {n_points} states with J q' = 0: {mpmath.nstr(worst, 3)}",
                 (d.name,), n_points, "1e-30", mpmath.nstr(worst, 3))


def not_applicable(name) -> list[tuple[str, str]]:
    """(check, why) of the physics checks that do not apply to a model, so that none is left
    out silently: a closed loop's, and the Cartesian check where the model is no
    conservative chain of point masses (model_checks leaves it out there).

    Parameters
    ----------
    name : str or Model
        A model.

    Returns
    -------
    list of (str, str)
        Empty for a conservative open chain of point masses.
    """
    model = name if not isinstance(name, str) else load_model(name)
    if model.is_constrained:
        return [("Cartesian constraint forces", "for open chains of point masses: a closed loop's "
                                                "constraint forces are its multipliers' J^T lambda"),
                ("Hamiltonian form", "a closed loop has none here (its coordinates are not independent)")]
    cartesian = "Cartesian constraint forces"
    if not model.is_chain:
        return [(cartesian, "for serial chains of point masses: a slider, a branch, an offset or a "
                            "massless link is no constraint |x_k - x_k-1| = l_k (M positive definite "
                            "and the energy balance check this model)")]
    if any(link.body.kind != "point" for link in model.links):
        return [(cartesian, "for chains of point masses: a rod's or a rigid body's rotational inertia "
                            "is no point mass (M positive definite and the energy balance check it)")]
    if not model.is_conservative:
        return [(cartesian, "for conservative chains: applied forces, damping and explicit time have "
                            "no Cartesian form here (the power balance checks them)")]
    if model.springs or model.potential is not None:
        return [(cartesian, "for chains under gravity alone: the Cartesian formulation here has no "
                            "springs or potential of the model's own (the energy check covers them)")]
    return []


def mass_matrix_spd(name: str, n_points: int = 20) -> Check:
    """M is symmetric (exactly) and positive definite (Cholesky succeeds) at random states."""
    d = derive(name)
    symmetric = matrix_is_zero(d.M - d.M.T, d.symbols.q)
    M_of = _system(d)[0]
    rng, smallest = random.Random(7), mpmath.inf
    with mpmath.workdps(DIGITS):
        for _ in range(n_points):
            pt = random_point(_args(d), rng)
            M = mpmath.matrix(M_of(*[pt[s] for s in _args(d)]).tolist())
            eig = mpmath.eigsy(M)[0]
            smallest = min(smallest, min(eig))
    ok = symmetric and smallest > 0
    return Check(f"{d.name}: M symmetric positive definite", ok,
                 f"symmetric exactly: {symmetric}; smallest eigenvalue over {n_points} states "
                 f"{mpmath.nstr(smallest, 3)}", (d.name,), n_points, "> 0",
                 mpmath.nstr(smallest, 3))


def planar_is_vertical_plane_of_spherical() -> Check:
    """spherical_std with phi1 = phi2 = 0 and phi' = 0 is exactly `planar`.

    At phi = 0 the standard chart's link lies in the x-z plane as (sin t, 0, -cos t),
    the planar chart's (sin t, -cos t); so the theta rows of M and F must equal
    planar's, the blocks of M coupling theta and phi must vanish and the phi rows of F too
    (the motion stays in the plane).
    """
    s, p = derive("spherical_std"), derive("planar")
    th1, ph1, th2, ph2 = s.symbols.q
    rename = {th1: p.symbols.q[0], th2: p.symbols.q[1],
              s.symbols.qd[0]: p.symbols.qd[0], s.symbols.qd[2]: p.symbols.qd[1]}
    in_plane = {ph1: 0, ph2: 0, s.symbols.qd[1]: 0, s.symbols.qd[3]: 0}
    M = s.M.subs(in_plane).xreplace(rename)
    F = s.F.subs(in_plane).xreplace(rename)
    angles = list(p.symbols.q)
    same_M = matrix_is_zero(M.extract([0, 2], [0, 2]) - p.M, angles)
    same_F = matrix_is_zero(F.extract([0, 2], [0]) - p.F, angles)
    decoupled = matrix_is_zero(M.extract([0, 2], [1, 3]), angles)
    stays = matrix_is_zero(F.extract([1, 3], [0]), angles)
    ok = same_M and same_F and decoupled and stays
    return Check("planar = spherical_std in the plane phi = 0", ok,
                 f"M equal: {same_M}, F equal: {same_F}, blocks coupling theta and phi zero: {decoupled}, "
                 f"phi forcing zero: {stays}", ("planar", "spherical_std"), 0, "exact")


def compound_point_mass_equivalence() -> tuple[Check, dict]:
    """Derive when the compound pendulum *is* a point-mass double pendulum.

    Match compound's Lagrangian against planar's with unknown point masses and
    lengths (M1, M2, a, b), coefficient by coefficient in the rates and the
    sines and cosines, and solve for those and L1.  The derived answer:
        L1 = m1 l1^2 / 4                      (the only condition)
        a = l1,  b = l2/2 + 2 L2/(m2 l2),  M2 = m2 l2 / (2 b),  M1 = m1/2 + m2 - M2
    for every L2 >= 0 (b is link 2's length of equivalent simple pendulum).
    M1 >= m1/2 > 0 always, so the equivalent point-mass model is physical.
    """
    c = derive("compound")
    m1, m2, l1, l2, L1, L2, g = c.symbols.params
    match = parameter_match(reduction("compound", "planar"))      # the planner's derivation
    a, b = match.stand_ins["l1"], match.stand_ins["l2"]
    th1, th2 = c.symbols.q
    solutions, lag_p = match.solutions, match.target_lagrangian
    if len(solutions) != 1:
        return Check("compound -> point masses", False, f"{len(solutions)} solutions"), {}
    sol = solutions[0]
    expected = {L1: m1 * l1**2 / 4, a: l1, b: l2 / 2 + 2 * L2 / (m2 * l2)}
    as_expected = all(sp.simplify(sol[k] - v) == 0 for k, v in expected.items())
    residual = c.L.subs(sol) - lag_p.subs(sol)
    ok = as_expected and trig_is_zero(residual, [th1, th2])
    detail = ", ".join(f"{k} = {sp.factor(v)}" for k, v in sol.items())
    return Check("compound = planar point masses iff L1 = m1 l1^2/4", ok, detail,
                 ("compound", "planar"), 0, "exact",
                 exprs={str(k): sp.factor(v) for k, v in sol.items()}), sol


def charts_agree_on_accelerations(source: str, target: str, n_points: int = 20) -> Check:
    """Both charts give the same Cartesian accelerations of both bobs away from the poles.

    A random state of `source` is converted to `target` (charts.py); each model
    solves its own M q'' = F; the bobs' Cartesian accelerations
        x'' = J q'' + (d/dq (J q')) q'
    must agree to 30 digits.
    """
    ds, dt = derive(source), derive(target)
    change = chart_change(ds.model, dt.model)
    rng, worst = random.Random(11), 0
    acc_s, acc_t = _cartesian_acceleration(ds), _cartesian_acceleration(dt)
    to_target_q = _numeric(change.coordinates, ds.symbols.q)
    to_target_qd = _numeric(change.rates, ds.symbols.state + tuple(change.target_q))
    with mpmath.workdps(DIGITS):
        for _ in range(n_points):
            pt = random_point(ds.symbols.state + ds.symbols.params, rng)
            qs = [pt[s] for s in ds.symbols.q]
            qt = list(to_target_q(*qs))
            qdt = list(to_target_qd(*([pt[s] for s in ds.symbols.state] + qt)))
            pt_t = dict(zip(dt.symbols.state, qt + qdt)) | dict(zip(dt.symbols.params, [pt[s] for s in ds.symbols.params]))
            a_s, a_t = acc_s(pt), acc_t(pt_t)
            worst = max(worst, max(abs(x - y) for x, y in zip(a_s, a_t)))
    ok = worst < mpmath.mpf(10) ** -30
    return Check(f"{source} and {target}: same Cartesian accelerations", ok,
                 f"largest difference over {n_points} states: {mpmath.nstr(worst, 3)}",
                 (source, target), n_points, "1e-30", mpmath.nstr(worst, 3))


def _cartesian_acceleration(d):
    q, qd = sp.Matrix(d.symbols.q), sp.Matrix(d.symbols.qd)
    qdd = sp.Matrix(sp.symbols(f"qdd0:{len(q)}"))
    tips = sp.Matrix.vstack(*d.tips)
    J = tips.jacobian(q)
    acc = J * qdd + (J * qd).jacobian(q) * qd
    f = _numeric(acc, list(_args(d)) + list(qdd))

    def at(pt):
        qdd_val = accelerations(d, pt)
        return list(f(*([pt[s] for s in _args(d)] + list(qdd_val))))
    return at


def chart_round_trip(first: str, second: str, n_points: int = 20) -> Check:
    """first -> second -> first returns the same state (angles modulo 2 pi)."""
    d1, d2 = derive(first), derive(second)
    there, back = chart_change(d1.model, d2.model), chart_change(d2.model, d1.model)
    f_q, f_qd = _numeric(there.coordinates, d1.symbols.q), _numeric(there.rates, d1.symbols.state + tuple(there.target_q))
    b_q, b_qd = _numeric(back.coordinates, d2.symbols.q), _numeric(back.rates, d2.symbols.state + tuple(back.target_q))
    overrides = {s.name: (0.05, 3.09) for s in d1.symbols.q[0::2]}   # polar angles in (0, pi)
    rng, worst = random.Random(5), 0
    with mpmath.workdps(DIGITS):
        for _ in range(n_points):
            pt = random_point(d1.symbols.state, rng, overrides)
            y = [pt[s] for s in d1.symbols.state]
            q2 = list(f_q(*y[:len(d1.symbols.q)]))
            qd2 = list(f_qd(*(y + q2)))
            q1 = list(b_q(*q2))
            qd1 = list(b_qd(*(q2 + qd2 + q1)))
            for a, b in zip(y, q1 + qd1):
                diff = abs(a - b)
                worst = max(worst, min(diff, abs(diff - 2 * mpmath.pi)))
    ok = worst < mpmath.mpf(10) ** -30
    return Check(f"{first} -> {second} -> {first} round trip", ok,
                 f"largest difference over {n_points} states: {mpmath.nstr(worst, 3)}",
                 (first, second), n_points, "1e-30", mpmath.nstr(worst, 3))


def energy_conservation(name, n_points: int = 20) -> Check:
    """The power balance dE/dt = q' . Q - q' . dR/dq' along the equations of motion
    (q'' solving M q'' = F) at random states, relative to the size of its terms; for a
    conservative model (no Q, no R) that is dE/dt = 0."""
    d = derive(name)
    s = d.symbols
    args = list(_args(d))
    explicit = d.model.is_time_dependent
    E = jacobi_energy(d) if explicit else d.energy
    grad_q = _numeric(sp.Matrix([E.diff(x) for x in s.q]), args)
    grad_qd = _numeric(sp.Matrix([E.diff(x) for x in s.qd]), args)
    dE_dt = _numeric(E.diff(TIME), args)
    qd = sp.Matrix(s.qd)
    power = -d.L.diff(TIME)         # the work of the prescribed motion (zero without t in L)
    if d.forces is not None:
        power += (qd.T * d.forces)[0, 0]
    if d.dissipation is not None:
        power -= sum(v * d.dissipation.diff(v) for v in s.qd)
    power_of = _numeric(power, args)
    rng, worst = random.Random(13), mpmath.mpf(0)
    loop = d.constraints is not None      # on J q' = 0, where the constraint forces do no work
    with mpmath.workdps(DIGITS):
        for _ in range(n_points):
            pt = random_point(_args(d), rng)
            pt = on_the_loop(d, pt) if loop else pt
            vals = [pt[x] for x in args]
            acc = loop_accelerations(d, pt) if loop else accelerations(d, pt)
            terms = ([a * pt[x] for a, x in zip(grad_q(*vals), s.qd)]
                     + [b * acc[k] for k, b in enumerate(grad_qd(*vals))] + [dE_dt(*vals), -power_of(*vals)])
            scale = sum(abs(t) for t in terms) or 1
            worst = max(worst, abs(sum(terms)) / scale)
    ok = worst < mpmath.mpf(10) ** -30
    if d.model.is_conservative:
        title, what = "energy conserved", "dE/dt"
    elif explicit:      # with explicit time T + V is not conserved: Jacobi's h balances
        title = ("power balance dh/dt = q'.Q - q'.dR/dq' - dL/dt|explicit, h = q'.dL/dq' - L "
                 "(explicit time: energy not conserved)")
        what = "dh/dt - q'.Q + q'.dR/dq' + dL/dt|explicit"
    else:
        title, what = "power balance dE/dt = q'.Q - q'.dR/dq'", "dE/dt - q'.Q + q'.dR/dq'"
    where = " with J q' = 0 (q'' of the closed loop)" if loop else ""
    return Check(f"{d.name}: {title}", ok,
                 f"largest relative {what} over {n_points} states{where}: {mpmath.nstr(worst, 3)}",
                 (d.name,), n_points, "1e-30", mpmath.nstr(worst, 3))


def jacobi_energy(d) -> sp.Expr:
    """Jacobi's energy h = q'.dL/dq' - L: what balances the power of a time-dependent
    model (for a time-independent one it is T + V)."""
    return sp.expand(sum(v * d.L.diff(v) for v in d.symbols.qd) - d.L)


def cartesian_constraint_forces(name, n_points: int = 20) -> Check | None:
    """For a chain of point masses: the bobs' accelerations from the derivation equal those
    of the Cartesian formulation m_k a_k = m_k g + tension forces along the links, the
    tensions solved from the second derivatives of the constraints |x_k - x_{k-1}| = l_k.
    None for a chain with a rod (its rotational inertia is no point mass), and for a model
    that is not a serial chain (a slider, a branch or an offset is no constraint
    |x_k - x_{k-1}| = l_k; M positive definite and the energy balance check those)."""
    d = derive(name)
    if not_applicable(d.model):           # the Cartesian side knows gravity and point masses only
        return None
    s, dim = d.symbols, d.model.dimension
    args = list(_args(d))
    tips = [sp.Matrix(t) for t in d.tips]
    q, qd = sp.Matrix(s.q), sp.Matrix(s.qd)
    vel = [t.jacobian(q) * qd for t in tips]
    pos_of, vel_of = _numeric(sp.Matrix.hstack(*tips), args), _numeric(sp.Matrix.hstack(*vel), args)
    acc_of = _cartesian_acceleration(d)
    masses = _numeric(sp.Matrix([parse_quantity(link.body.mass, s) for link in d.model.links]), args)
    g_of = _numeric(s.param("g"), args)
    nb = len(tips)
    rng, worst = random.Random(23), mpmath.mpf(0)
    with mpmath.workdps(DIGITS):
        for _ in range(n_points):
            pt = random_point(_args(d), rng)
            vals = [pt[x] for x in args]
            X, V = mpmath.matrix(pos_of(*vals).tolist()), mpmath.matrix(vel_of(*vals).tolist())
            m, g = list(masses(*vals)), g_of(*vals)
            x = [X[:, k] for k in range(nb)]
            v = [V[:, k] for k in range(nb)]
            zero = mpmath.matrix(dim, 1)
            dk = [x[k] - (x[k - 1] if k else zero) for k in range(nb)]
            wk = [v[k] - (v[k - 1] if k else zero) for k in range(nb)]
            grav = mpmath.matrix(dim, 1)
            grav[dim - 1] = -g

            def accel(lam):     # a_k = g + (-lam_k d_k + lam_{k+1} d_{k+1}) / m_k
                out = []
                for k in range(nb):
                    f = -lam[k] * dk[k] + (lam[k + 1] * dk[k + 1] if k + 1 < nb else zero)
                    out.append(grav + f / m[k])
                return out

            def residual(lam):  # d_k . (a_k - a_{k-1}) + |w_k|^2 = 0 for every link
                a = accel(lam)
                return [sum(dk[k][i] * (a[k][i] - (a[k - 1][i] if k else 0)) for i in range(dim))
                        + sum(wk[k][i] ** 2 for i in range(dim)) for k in range(nb)]

            r0 = residual([0] * nb)     # linear in the tensions: columns by unit tensions
            A = mpmath.matrix(nb, nb)
            for j in range(nb):
                rj = residual([1 if i == j else 0 for i in range(nb)])
                for i in range(nb):
                    A[i, j] = rj[i] - r0[i]
            lam = mpmath.lu_solve(A, mpmath.matrix([-r for r in r0]))
            a_ref = accel(list(lam))
            a_der = acc_of(pt)
            scale = max([abs(c) for c in a_der] + [1])
            for k in range(nb):
                for i in range(dim):
                    worst = max(worst, abs(a_der[k * dim + i] - a_ref[k][i]) / scale)
    ok = worst < mpmath.mpf(10) ** -30
    return Check(f"{d.name}: bob accelerations = Cartesian constraint forces", ok,
                 f"largest relative difference over {n_points} states: {mpmath.nstr(worst, 3)}",
                 (d.name,), n_points, "1e-30", mpmath.nstr(worst, 3))


def hamiltonian_consistency(name, n_points: int = 20) -> Check:
    """With p = M q': H(q, p) = E(q, q'), dH/dp = q' and -dH/dq = dL/dq, at random states."""
    d = derive(name)
    s, h = d.symbols, d.hamiltonian
    args = list(s.state + s.params)
    p_of = _numeric(d.M * sp.Matrix(s.qd), args)
    qp = list(s.q) + list(s.p) + list(s.params)
    f_H, f_qd, f_pd = _numeric(h.H, qp), _numeric(h.qdot, qp), _numeric(h.pdot, qp)
    f_E, f_dL = _numeric(d.energy, args), _numeric(h.dL_dq, args)
    rng, worst = random.Random(17), mpmath.mpf(0)
    rel = lambda a, b: abs(a - b) / max(abs(a), abs(b), 1)
    with mpmath.workdps(DIGITS):
        for _ in range(n_points):
            pt = random_point(s.state + s.params, rng)
            vals = [pt[x] for x in args]
            p = list(p_of(*vals))
            at = [pt[x] for x in s.q] + p + [pt[x] for x in s.params]
            worst = max(worst, rel(f_H(*at), f_E(*vals)))
            worst = max([worst] + [rel(a, pt[x]) for a, x in zip(f_qd(*at), s.qd)])
            worst = max([worst] + [rel(a, b) for a, b in zip(f_pd(*at), f_dL(*vals))])
    ok = worst < mpmath.mpf(10) ** -30
    return Check(f"{d.name}: Hamiltonian form consistent with the Lagrangian", ok,
                 f"largest relative difference over {n_points} states: {mpmath.nstr(worst, 3)}",
                 (d.name,), n_points, "1e-30", mpmath.nstr(worst, 3))


def model_checks(name) -> list[Check]:
    """The checks that concern one model (a catalogue name or a Model): M symmetric
    positive definite, energy conservation, the Hamiltonian form where it has one, and
    the checks relating it to other catalogue models (chart agreement, round trips,
    the plane of the spherical pendulum, the compound pendulum's point masses)."""
    d = derive(name)
    checks = [mass_matrix_spd(name), energy_conservation(name)]
    if d.constraints is not None:        # a closed loop: not_applicable() names what is left out
        return checks + [loop_stays_closed(name)]
    if d.hamiltonian is not None and d.hamiltonian.H is not None:
        checks.append(hamiltonian_consistency(name))
    if d.model.is_conservative:          # (applied forces have no Cartesian form here)
        cartesian = cartesian_constraint_forces(name)
        if cartesian is not None:
            checks.append(cartesian)
    catalogue = (d.name in model_names()
                 and load_model(d.name).content_hash == d.model.content_hash)
    if not catalogue:
        return checks + chain_chart_checks(d)
    if d.name in ("planar", "spherical_std"):
        checks.append(planar_is_vertical_plane_of_spherical())
    if d.name == "compound":
        checks.append(compound_point_mass_equivalence()[0])
    checks += [charts_agree_on_accelerations(a, b) for a, b in SPHERICAL_PAIRS if d.name in (a, b)]
    checks += [chart_round_trip(a, b) for a, b in SPHERICAL_PAIRS if d.name in (a, b)]
    return checks


def chain_chart_checks(d) -> list[Check]:
    """For a user's chain of spherical links in the standard chart: the same chain in the
    second and the rotated chart (its atlas, derive/model/atlas.py) gives the same Cartesian
    accelerations of every bob, and the chart change there and back is the identity --
    the checks SPHERICAL_PAIRS makes for the catalogue's double pendulum."""
    try:
        charts = atlas_for(d.name).charts
    except ModelError:                 # not a spherical chain in the standard chart
        return []
    if d.name != charts[0]:
        return []
    return ([charts_agree_on_accelerations(charts[0], other) for other in charts[1:]]
            + [chart_round_trip(charts[0], charts[1])])


def _compound_check() -> Check:
    return compound_point_mass_equivalence()[0]


def check_calls() -> list[tuple]:
    """Every physics check of the catalogue as a call (function, arguments), in the order
    of :func:`run_all`'s checks: independent, so workers may make them side by side.

    Returns
    -------
    list of (callable, tuple)
    """
    calls = [(mass_matrix_spd, (name,)) for name in model_names()]
    calls += [(energy_conservation, (name,)) for name in model_names()]
    calls += [(hamiltonian_consistency, (name,)) for name in model_names() if derive(name).hamiltonian]
    calls += [(planar_is_vertical_plane_of_spherical, ()), (_compound_check, ())]
    calls += [(charts_agree_on_accelerations, pair) for pair in SPHERICAL_PAIRS]
    calls += [(chart_round_trip, pair) for pair in SPHERICAL_PAIRS]
    return calls


def run_all() -> list[Check]:
    """Every physics check of the catalogue, made here, in order."""
    return [f(*args) for f, args in check_calls()]
