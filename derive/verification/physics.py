"""Independent physics checks of the derivation (issue: derivation core, item 5).

These do not look at the seeds at all: they test the derived equations against
facts any correct double pendulum must satisfy.  Each check returns a
``Check`` with a one-line detail; ``run_all`` runs them all.
"""
from __future__ import annotations

import random
from dataclasses import dataclass, field

import mpmath
import sympy as sp

from ..derivation import derive
from ..derivation.charts import chart_change
from ..model import load_model, model_names
from .zero import DIGITS, matrix_is_zero, random_point, trig_is_zero

SPHERICAL_PAIRS = [("spherical_std", "spherical_alt"), ("spherical_alt", "spherical_std"),
                   ("spherical_std", "spherical_rot"), ("spherical_rot", "spherical_alt")]


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


def _system(d) -> tuple:
    """M and F of a derivation compiled once: functions of (state, params)."""
    if d.name not in _system_functions:
        args = d.symbols.state + d.symbols.params
        _system_functions[d.name] = (_numeric(d.M, args), _numeric(d.F, args))
    return _system_functions[d.name]


def accelerations(d, point: dict) -> mpmath.matrix:
    """q'' at a point by solving M q'' = F in 40-digit arithmetic."""
    M_of, F_of = _system(d)
    values = [point[s] for s in d.symbols.state + d.symbols.params]
    with mpmath.workdps(DIGITS):
        return mpmath.lu_solve(mpmath.matrix(M_of(*values).tolist()),
                               mpmath.matrix(F_of(*values).tolist()))


def mass_matrix_spd(name: str, n_points: int = 20) -> Check:
    """M is symmetric (exactly) and positive definite (Cholesky succeeds) at random states."""
    d = derive(name)
    symmetric = matrix_is_zero(d.M - d.M.T, d.symbols.q)
    M_of = _system(d)[0]
    rng, smallest = random.Random(7), mpmath.inf
    with mpmath.workdps(DIGITS):
        for _ in range(n_points):
            pt = random_point(d.symbols.state + d.symbols.params, rng)
            M = mpmath.matrix(M_of(*[pt[s] for s in d.symbols.state + d.symbols.params]).tolist())
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
    planar's, the theta-phi blocks of M must vanish and the phi rows of F too
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
                 f"M equal: {same_M}, F equal: {same_F}, theta-phi blocks zero: {decoupled}, "
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
    c, p = derive("compound"), derive("planar")
    m1, m2, l1, l2, L1, L2, g = c.symbols.params
    M1, M2, a, b = sp.symbols("M1 M2 a b", positive=True)
    planar = dict(zip(p.symbols.params, (M1, M2, a, b, g)))
    rename = dict(zip(p.symbols.state, c.symbols.state))
    lag_p = sp.expand(p.L.xreplace(planar).xreplace(rename))
    th1, th2 = c.symbols.q
    diff = sp.expand(sp.expand_trig(sp.expand(c.L) - lag_p))
    terms = sp.Poly(diff, *c.symbols.qd, sp.sin(th1), sp.cos(th1), sp.sin(th2), sp.cos(th2)).coeffs()
    solutions = sp.solve(terms, [M1, M2, a, L1, b], dict=True)
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
    f = _numeric(acc, list(d.symbols.state + d.symbols.params) + list(qdd))

    def at(pt):
        qdd_val = accelerations(d, pt)
        return list(f(*([pt[s] for s in d.symbols.state + d.symbols.params] + list(qdd_val))))
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
            q2 = list(f_q(*y[:4]))
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
    """dE/dt = dE/dq . q' + dE/dq' . q'' vanishes along the equations of motion
    (q'' solving M q'' = F) at random states, relative to the size of its terms."""
    d = derive(name)
    s = d.symbols
    args = list(s.state + s.params)
    E = d.energy
    grad_q = _numeric(sp.Matrix([E.diff(x) for x in s.q]), args)
    grad_qd = _numeric(sp.Matrix([E.diff(x) for x in s.qd]), args)
    rng, worst = random.Random(13), mpmath.mpf(0)
    with mpmath.workdps(DIGITS):
        for _ in range(n_points):
            pt = random_point(s.state + s.params, rng)
            vals = [pt[x] for x in args]
            acc = accelerations(d, pt)
            terms = ([a * pt[x] for a, x in zip(grad_q(*vals), s.qd)]
                     + [b * acc[k] for k, b in enumerate(grad_qd(*vals))])
            scale = sum(abs(t) for t in terms) or 1
            worst = max(worst, abs(sum(terms)) / scale)
    ok = worst < mpmath.mpf(10) ** -30
    return Check(f"{d.name}: energy conserved", ok,
                 f"largest relative dE/dt over {n_points} states: {mpmath.nstr(worst, 3)}",
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
    if d.hamiltonian is not None:
        checks.append(hamiltonian_consistency(name))
    catalogue = (d.name in model_names()
                 and load_model(d.name).content_hash == d.model.content_hash)
    if not catalogue:
        return checks
    if d.name in ("planar", "spherical_std"):
        checks.append(planar_is_vertical_plane_of_spherical())
    if d.name == "compound":
        checks.append(compound_point_mass_equivalence()[0])
    checks += [charts_agree_on_accelerations(a, b) for a, b in SPHERICAL_PAIRS if d.name in (a, b)]
    checks += [chart_round_trip(a, b) for a, b in SPHERICAL_PAIRS if d.name in (a, b)]
    return checks


def run_all() -> list[Check]:
    checks = [mass_matrix_spd(name) for name in model_names()]
    checks += [energy_conservation(name) for name in model_names()]
    checks += [hamiltonian_consistency(name) for name in model_names() if derive(name).hamiltonian]
    checks.append(planar_is_vertical_plane_of_spherical())
    checks.append(compound_point_mass_equivalence()[0])
    checks += [charts_agree_on_accelerations(a, b) for a, b in SPHERICAL_PAIRS]
    checks += [chart_round_trip(a, b) for a, b in SPHERICAL_PAIRS]
    return checks
