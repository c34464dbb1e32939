"""Stage 2, the derivation: positions -> T, V, L -> M(q) q'' = F(q, q').

With generalized coordinates q and rates q', the kinetic energy is the
quadratic form T = 1/2 q'^T M(q) q', so Lagrange's equation (seed 000 (1.1))
    d/dt dL/dq' - dL/dq = 0
becomes M q'' = F with
    F_j = 1/2 q'^T (dM/dq_j) q' - sum_k q'_k (dM/dq_k q')_j - dV/dq_j,
the Christoffel form.  It is exact and needs no time-dependent symbols.

A prescribed pivot motion r0(t) (a rheonomic constraint) moves every body by r0(t):
its velocity gains r0'(t), so T gains T_pivot = sum_k m_k r0'.(J_k q') + 1/2 sum_k m_k |r0'|^2
(linear in q', M unchanged) and V gains g sum_k m_k r0[-1](t).  Lagrange's equation with
explicit time, d/dt dT/dq' = d2T/dq'dq q' + d2T/dq'dq' q'' + d2T/dq'dt, then adds to F
    dT_pivot/dq_j - sum_k d2T_pivot/dq'_j dq_k q'_k - d2T_pivot/dq'_j dt.

A model that is not a serial chain (a kinematic tree: links naming their parent, joint
offsets, prismatic sliders, massless links; `Model.is_chain`) takes the general path,
`tree_form`: each body's centre r_k(q, t) from the tree (`tree_geometry`), its Jacobian
J_k = dr_k/dq, M = sum_k m_k J_k^T J_k + I_k E_k^T E_k (E_k = de_k/dq, a rod's turning)
+ W_k^T I_k W_k (a rigid body's tensor I_k in its frame; its angular velocity in its own
axes W_k q' by the recursion omega_k = turn_k^T omega_parent + axis_k q'_k, exact without
simplifying), each entry folded by one trigsimp; V = g sum_k m_k r_k[-1]; F by the same Christoffel
form (`forcing`), plus the explicit-time terms of T - 1/2 q'^T M q' (the velocity's
part dr_k/dt: a moving pivot) by the formula above (`explicit_time_forcing`).

A prescribed joint (`prescribed = "w*t"` on a link: its coordinate is f(t; p), not a
state) enters the tree's geometry as that expression: a centre's dr_k/dt and a turning
direction's de_k/dt|_q gain its rate f'(t), a rigid body's angular velocity W_k q' + w_k(t)
its axis times f'(t) (the recursion carries w_k), and T's explicit-time part collects the
cross and square terms.  Where the joint changes the bodies' geometry (a slider pulled in,
a turntable turning a rotor's axes) M depends on t too, and F gains -(dM/dt) q'
(`moving_mass_forcing`).
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..errors import ModelError
from ..model import Model
from ..model.description import PRISMATIC, REVOLUTE
from ..model.expressions import parse_expression
from .symbolic import by_engine
from .symbols import ModelSymbols, motion_names, names, parse_quantity, per_shape, t


def link_directions(model: Model, s: ModelSymbols) -> list[sp.Matrix]:
    """Unit vector of each link in its chart (seed 000 (2.1), (4.1); §1 for planar)."""
    dirs, k = [], 0
    for link in model.links:
        n = len(link.chart.coordinates)
        dirs.append(link.chart.unit_vector(list(s.q[k:k + n])))
        k += n
    return dirs


def link_vectors(model: Model, s: ModelSymbols) -> list[sp.Matrix]:
    """q_i = l_i e_i: the vector along each link, pivot to tip."""
    return [parse_quantity(link.length, s) * e
            for link, e in zip(model.links, link_directions(model, s))]


def joint_values(model: Model, s: ModelSymbols, link) -> list[sp.Expr]:
    """A link's joint coordinates: its symbols in q, or a prescribed joint's f(t; p)."""
    if link.prescribed:
        where = model.origin or model.name
        return [parse_expression(text, motion_names(s), f"{where}: prescribed") for text in link.prescribed]
    return [s.q[j] for j in model.link_coordinates(link)]


def pivot_position(model: Model, s: ModelSymbols) -> sp.Matrix:
    """r0(t; p): where the chain hangs from, the origin unless the model prescribes it."""
    if model.pivot is None:
        return sp.zeros(model.dimension, 1)
    where = model.origin or model.name
    return sp.Matrix([parse_expression(text, motion_names(s), f"{where}: pivot {axis}")
                      for axis, text in zip("xyz", model.pivot)])


def tip_positions(model: Model, s: ModelSymbols) -> list[sp.Matrix]:
    """x_1 = r0 + q_1, x_2 = r0 + q_1 + q_2 (seed 000 below (1.3)): each link's tip."""
    tips, x = [], pivot_position(model, s)
    for qi in link_vectors(model, s):
        x = x + qi
        tips.append(x)
    return tips


def mass_centres(model: Model, s: ModelSymbols, pivot: bool = True) -> list[sp.Matrix]:
    """Where each body's mass sits: the tip for a point, com*l along the link for a rod;
    from the pivot r0(t) (`pivot`), or from the origin (the chain's own shape)."""
    centres = []
    base = pivot_position(model, s) if pivot else sp.zeros(model.dimension, 1)
    for link, qi in zip(model.links, link_vectors(model, s)):
        centres.append(base + parse_quantity(link.body.com, s) * qi)
        base = base + qi
    return centres


@dataclass(frozen=True)
class LinkBlock:
    """One link's rows of the equations: where its coordinates sit in q, its unit vector e
    and D = de/du, the Jacobian of e in its own chart's coordinates."""
    index: int
    rows: slice
    e: sp.Matrix
    D: sp.Matrix


def link_blocks(model: Model, s: ModelSymbols) -> list[LinkBlock]:
    blocks, k = [], 0
    for i, (link, e) in enumerate(zip(model.links, link_directions(model, s))):
        n = len(link.chart.coordinates)
        blocks.append(LinkBlock(i, slice(k, k + n), e, e.jacobian(sp.Matrix(s.q[k:k + n]))))
        k += n
    return blocks


def _gram(a: LinkBlock, b: LinkBlock) -> sp.Matrix:
    """D_a^T D_b: the dot products of two links' direction derivatives, each a short
    trigonometric polynomial that trigsimp folds (sin^2 + cos^2, cos(a - b)) cheaply.
    These are the only simplifications the derivation needs: every other term of M, V
    and F is a product of them with parameters and rates."""
    return (a.D.T * b.D).applyfunc(lambda x: _folded(sp.expand(x)))


def _folded(x: sp.Expr) -> sp.Expr:
    """trigsimp(x), computed once per shape (symbols.per_shape): a chain's Gram entries are
    the same few polynomials (sin^2 + cos^2, sin a sin b + cos a cos b) in other angles, and
    trigsimp is the derivation's largest cost."""
    return per_shape(sp.trigsimp, x)


@dataclass
class ChainForm:
    """M and V of a chain written as parameter coefficients times functions of q:

        M[block i, block j] = K_ij G_ij(q),  G_ij = D_i^T D_j,
        K_ij = l_i l_j sum_{k >= max(i, j)} m_k w_ik w_jk  (+ I_i for i = j),
        V = sum_i nu_i e_i[-1](q),  nu_i = g l_i sum_{k >= i} m_k w_ik,

    with w_ik = 1 for a link before body k and the centre-of-mass fraction for its own
    link (body k sits at sum_{i<k} l_i e_i + com_k l_k e_k).  The coefficients are kept
    as placeholder symbols while M and V are differentiated and expanded, so the
    parameter sums are never multiplied out and equal terms of the Christoffel form
    cancel as they are collected."""
    M: sp.Matrix                  # in the placeholders
    V: sp.Expr                    # in the placeholders
    values: dict                  # placeholder -> its parameter expression

    def filled(self, expr):
        return expr.xreplace(self.values)


def chain_form(model: Model, s: ModelSymbols) -> ChainForm:
    """M and V of a chain of links (module docstring, ChainForm), built link pair by pair."""
    blocks, n = link_blocks(model, s), len(s.q)
    lengths = [parse_quantity(link.length, s) for link in model.links]
    masses = [parse_quantity(link.body.mass, s) for link in model.links]
    coms = [parse_quantity(link.body.com, s) for link in model.links]

    def weight(i: int, k: int) -> sp.Expr:
        """Where link i's vector enters body k's mass centre: whole before it, com on its own."""
        return sp.S.One if i < k else coms[k]

    M, values = sp.zeros(n, n), {}
    for a in blocks:
        for b in blocks[a.index:]:
            i, j = a.index, b.index
            K = lengths[i] * lengths[j] * sp.Add(*[masses[k] * weight(i, k) * weight(j, k)
                                                   for k in range(j, len(blocks))])
            if i == j:
                K += parse_quantity(model.links[i].body.inertia, s)
            if K == 0:
                continue
            kappa = sp.Dummy(f"K{i}_{j}")
            values[kappa] = K
            block = kappa * _gram(a, b)
            M[a.rows, b.rows] = block
            M[b.rows, a.rows] = block.T
    g, V = s.param("g"), sp.S.Zero
    for b in blocks:
        i = b.index
        nu = g * lengths[i] * sp.Add(*[masses[k] * weight(i, k) for k in range(i, len(blocks))])
        if nu != 0:
            symbol = sp.Dummy(f"nu{i}")
            values[symbol] = nu
            V += symbol * b.e[-1]
    return ChainForm(M, V, values)


def mass_matrix(form: ChainForm) -> sp.Matrix:
    """M = sum_k m_k J_k^T J_k + I_k E_k^T E_k, J_k = d(centre_k)/dq, E_k = d(e_k)/dq,
    assembled as K_ij G_ij (ChainForm).

    The rod term is the rotational energy 1/2 I |de/dt|^2 of a thin rod about
    its centre of mass (for a planar link |de/dt| = theta'), seed 001's T.
    """
    return form.M.applyfunc(form.filled)


def potential_energy(form: ChainForm) -> sp.Expr:
    """V = sum_k m_k g (height of centre k); gravity along the last axis, downwards."""
    return form.filled(form.V)


def kinetic_energy(M: sp.Matrix, s: ModelSymbols) -> sp.Expr:
    """T = 1/2 q'^T M q', expanded (by SymEngine: symbolic.by_engine)."""
    n = len(s.qd)

    def half_quadratic_form(expand, m, qd):
        return [expand(sum(qd[i] * m[i * n + j] * qd[j] for i in range(n) for j in range(n)) / 2)]

    return by_engine(half_quadratic_form, list(M), s.qd)[0]


def dissipation_function(model: Model, s: ModelSymbols) -> sp.Expr | None:
    """Rayleigh's dissipation function R(q', q; p) of the model, or None."""
    if model.dissipation is None:
        return None
    return parse_expression(model.dissipation, names(s), f"{model.origin or model.name}: dissipation")


def generalized_forces(model: Model, s: ModelSymbols, tips: list[sp.Matrix],
                       centres: list[sp.Matrix]) -> sp.Matrix | None:
    """The applied generalized forces Q (one per coordinate; zero where the model gives
    none): the model's [forces] on coordinates, plus each of its [[loads]] mapped through
    its point's Jacobian, Q_j += f . dr/dq_j (the virtual work f . dr = sum_j Q_j dq_j);
    None for a model with neither.

    Parameters
    ----------
    model : Model
    s : ModelSymbols
    tips, centres : list of sympy.Matrix
        Each link's tip and body centre (the derivation's), where the loads act.

    Returns
    -------
    sympy.Matrix or None
        Q, one entry per coordinate.
    """
    if not model.forces and not model.loads:
        return None
    given = dict(model.forces)
    where = model.origin or model.name
    Q = sp.Matrix([parse_expression(given[q.name], names(s), f"{where}: forces.{q.name}")
                   if q.name in given else sp.S.Zero for q in s.q])
    for i, load in enumerate(model.loads, 1):
        f = sp.Matrix([parse_expression(text, names(s), f"{where}: load {i} force {axis}")
                       for axis, text in zip("xyz", load.force)])
        r = named_point(model, s, tips, centres, load.point)
        Q += (r.jacobian(sp.Matrix(s.q)).T * f).applyfunc(sp.expand)
    return Q


def non_conservative(R: sp.Expr | None, Q: sp.Matrix | None, s: ModelSymbols) -> sp.Matrix:
    """Q - dR/dq': the right-hand side terms Lagrange's equation gains from applied
    forces and Rayleigh dissipation, d/dt dL/dq' - dL/dq = Q - dR/dq'."""
    out = sp.zeros(len(s.q), 1)
    if Q is not None:
        out += Q
    if R is not None:
        out -= sp.Matrix([R.diff(v) for v in s.qd])
    return out.applyfunc(sp.expand)


def forcing(form: ChainForm, s: ModelSymbols) -> sp.Matrix:
    """F of M q'' = F in the Christoffel form given in the module docstring, expanded
    in the placeholders of `form` (no simplification: the terms that cancel are equal
    term by term), then filled with the parameter coefficients."""
    n = len(s.q)

    def christoffel_form(expand, m, v, q, qd):
        """F_j = 1/2 q'^T (dM/dq_j) q' - ((dM/dt) q')_j - dV/dq_j, dM/dt = sum_k dM/dq_k q'_k."""
        dM = [[entry.diff(qk) for entry in m] for qk in q]          # dM[k][a n + b]
        return [expand(sum(qd[a] * dM[j][a * n + b] * qd[b] for a in range(n) for b in range(n)) / 2
                       - sum(dM[k][j * n + b] * qd[b] * qd[k] for k in range(n) for b in range(n))
                       - v[0].diff(q[j]))
                for j in range(n)]

    # summed, differentiated and expanded by SymEngine (symbolic.by_engine): the same expressions, faster
    F = by_engine(christoffel_form, list(form.M), [form.V], s.q, s.qd)
    return sp.Matrix([sp.factor_terms(form.filled(f)) for f in F])


@dataclass(frozen=True)
class PivotTerms:
    """What a prescribed pivot motion adds to T, V and F (module docstring)."""
    T: sp.Expr
    V: sp.Expr
    F: sp.Matrix


def pivot_terms(model: Model, s: ModelSymbols) -> PivotTerms | None:
    """T_pivot, V_pivot and F_pivot of a model whose pivot moves, None for a fixed pivot
    at the origin (the catalogue's: its equations stay exactly as they were)."""
    if model.pivot is None:
        return None
    r0 = pivot_position(model, s)
    r0_dot = r0.diff(t)
    qd = sp.Matrix(s.qd)
    masses = [parse_quantity(link.body.mass, s) for link in model.links]
    T = sp.S.Zero
    for m, c in zip(masses, mass_centres(model, s, pivot=False)):
        T += m * (r0_dot.T * (c.jacobian(s.q) * qd))[0, 0] + m * (r0_dot.T * r0_dot)[0, 0] / 2
    V = s.param("g") * sp.Add(*masses) * r0[-1]
    return PivotTerms(sp.expand(T), sp.expand(V), explicit_time_forcing(T, s))


def moving_mass_forcing(M: sp.Matrix, s: ModelSymbols) -> sp.Matrix:
    """-(dM/dt) q': what a mass matrix with explicit time adds to F (d/dt dT/dq' holds
    dM/dt|_q q' beside the Christoffel terms).  Zero unless a prescribed joint moves the
    bodies' geometry in time (a slider pulled in, a turntable turning a rotor's axes); a
    moving pivot translates every body and leaves M unchanged.

    Parameters
    ----------
    M : sympy.Matrix
    s : ModelSymbols

    Returns
    -------
    sympy.Matrix
    """
    if t not in M.free_symbols:     # no time in M (and no Matrix.diff: it imports sympy.tensor)
        return sp.zeros(M.shape[0], 1)
    dM = M.applyfunc(lambda m: m.diff(t))
    if dM == sp.zeros(*M.shape):
        return sp.zeros(M.shape[0], 1)
    return (-dM * sp.Matrix(s.qd)).applyfunc(lambda f: sp.factor_terms(sp.expand(f)))


def explicit_time_forcing(T: sp.Expr, s: ModelSymbols) -> sp.Matrix:
    """What the part T of the kinetic energy that is not 1/2 q'^T M q' (the terms linear in
    and free of q', from explicit time) adds to F (module docstring):
    dT/dq_j - sum_k d2T/dq'_j dq_k q'_k - d2T/dq'_j dt.

    Parameters
    ----------
    T : sympy.Expr
        The explicit-time part of the kinetic energy, in (q, q', p, t).
    s : ModelSymbols

    Returns
    -------
    sympy.Matrix
        Its terms of F, one per coordinate.
    """
    dT_dqd = [T.diff(v) for v in s.qd]
    F = sp.Matrix([T.diff(qj) - sum(dT_dqd[j].diff(qk) * vk for qk, vk in zip(s.q, s.qd))
                   - dT_dqd[j].diff(t) for j, qj in enumerate(s.q)])
    return F.applyfunc(lambda f: sp.factor_terms(sp.expand(f)))


def model_potential(model: Model, s: ModelSymbols) -> sp.Expr | None:
    """The model's own potential V(q, p, t) (added to gravity's), or None.

    Parameters
    ----------
    model : Model
    s : ModelSymbols

    Returns
    -------
    sympy.Expr or None
        The parsed `potential` of the model file; None without one.
    """
    if model.potential is None:
        return None
    return parse_expression(model.potential, names(s), f"{model.origin or model.name}: potential")


def named_point(model: Model, s: ModelSymbols, tips: list[sp.Matrix], centres: list[sp.Matrix],
                text: str) -> sp.Matrix:
    """Where a spring's end or a load's point is: "pivot", a link's name for its tip,
    "<link>.centre" for its body's centre of mass."""
    by_name = {link.name: i for i, link in enumerate(model.links) if link.name}
    if text == "pivot":
        return pivot_position(model, s)
    if text.endswith(".centre"):
        return centres[by_name[text[:-len(".centre")]]]
    return tips[by_name[text]]


def spring_potential(model: Model, s: ModelSymbols, tips: list[sp.Matrix],
                     centres: list[sp.Matrix]) -> sp.Expr | None:
    """The energy of the model's springs, or None: k/2 (|b - a| - rest)^2 for a linear
    spring between points a and b (k/2 |b - a|^2 at rest length 0: no square root), and
    k/2 (q - q_parent - rest)^2 for a torsional one at a hinge (the parent's angle where the
    parent is a one-angle hinge too: the spring twists with the joint's relative angle).

    Parameters
    ----------
    model : Model
    s : ModelSymbols
    tips, centres : list of sympy.Matrix
        Each link's tip and body centre (the derivation's), where the springs' ends are.

    Returns
    -------
    sympy.Expr or None
        The springs' energy; None for a model without [[springs]].
    """
    if not model.springs:
        return None
    def point(text: str) -> sp.Matrix:
        return named_point(model, s, tips, centres, text)

    V = sp.S.Zero
    for spring in model.springs:
        k, rest = parse_quantity(spring.stiffness, s), parse_quantity(spring.rest, s)
        if spring.between is not None:
            d = point(spring.between[1]) - point(spring.between[0])
            square = sp.trigsimp(sp.expand(sum(x**2 for x in d)))   # r^2 (sin^2 + cos^2) is r^2
            V += k * square / 2 if rest == 0 else k * (sp.sqrt(square) - rest)**2 / 2
        else:
            link = model.links[spring.joint]
            angle = joint_values(model, s, link)[0]
            parent = model.links[link.parent] if link.parent >= 0 else None
            if parent is not None and parent.joint != PRISMATIC and len(joint_values(model, s, parent)) == 1:
                angle -= joint_values(model, s, parent)[0]
            V += k * (angle - rest)**2 / 2
    return V


# -- the general path: a kinematic tree --------------------------------------

@dataclass
class TreeGeometry:
    """Where each link's joint, tip and body centre are (functions of q, p and t), each
    link's direction e (None for a slider: it does not turn) and its frame (the rotation
    from the link's axes to the world's; None where the link has none: a spherical link's
    direction does not fix its spin)."""
    joints: list[sp.Matrix]
    tips: list[sp.Matrix]
    centres: list[sp.Matrix]
    directions: list[sp.Matrix | None]
    frames: list[sp.Matrix | None]
    rates: list[sp.Matrix | None]        # W_k: the frame's angular velocity in its own axes is W_k q' + w_k
    spins: list[sp.Matrix | None] = None  # w_k(t): its part from prescribed joints (zero without them)


def _planar_frame(e: sp.Matrix) -> sp.Matrix:
    """The rotation R of a planar link with direction e: R (0, -1) = e (the link's axes turn
    with it: its own downward axis is along the link)."""
    return sp.Matrix([[-e[1], -e[0]], [e[0], -e[1]]])


def _turn(axis: sp.Matrix, angle: sp.Expr) -> sp.Matrix:
    """The rotation by `angle` about the unit vector `axis` (Rodrigues: counterclockwise
    seen from the axis's tip)."""
    cross = sp.Matrix([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return sp.cos(angle) * sp.eye(3) + sp.sin(angle) * cross + (1 - sp.cos(angle)) * axis * axis.T


def _unit_axis(link, s: ModelSymbols) -> sp.Matrix:
    axis = sp.Matrix([parse_quantity(a, s) for a in link.axis])
    return axis / sp.sqrt(sum(a**2 for a in axis))


def tree_geometry(model: Model, s: ModelSymbols) -> TreeGeometry:
    """The positions of a kinematic tree, link by link from its parent (module docstring).

    Parameters
    ----------
    model : Model
        A model that is not a chain (Model.is_chain is False); a chain works too.
    s : ModelSymbols

    Returns
    -------
    TreeGeometry
        Joints, tips, body centres, directions, frames and body rates, per link.

    Raises
    ------
    ModelError
        A link with an offset, a slider or a revolute joint on a spherical parent (whose
        direction fixes no frame).
    """
    where = model.origin or model.name
    r0, dim = pivot_position(model, s), model.dimension
    geo = TreeGeometry([], [], [], [], [], [], [])
    for i, link in enumerate(model.links, 1):
        if link.parent < 0:
            base, tip, frame, rates, spin_t = r0, r0, sp.eye(dim), sp.zeros(3, len(s.q)), sp.zeros(3, 1)
        else:
            base, tip, frame = geo.joints[link.parent], geo.tips[link.parent], geo.frames[link.parent]
            rates, spin_t = geo.rates[link.parent], geo.spins[link.parent]
        own_rates = rates if link.joint == PRISMATIC else None
        own_spin = spin_t if link.joint == PRISMATIC else None
        if frame is None and (link.offset is not None or link.joint in (PRISMATIC, REVOLUTE)):
            raise ModelError(f"{where}: link {i}: its parent (link {link.parent + 1}) is a spherical "
                             f"link, whose direction does not fix a frame for an offset or an axis")
        joint = tip if link.offset is None else base + frame * sp.Matrix(
            [parse_quantity(x, s) for x in link.offset])
        q = joint_values(model, s, link)
        if link.joint == PRISMATIC:
            end, e, own_frame = joint + q[0] * (frame * _unit_axis(link, s)), None, frame
            centre = end
        else:
            if link.joint == REVOLUTE:      # down the parent's -z, turned about the axis
                axis = _unit_axis(link, s)
                turn = _turn(axis, q[0])
                own_frame = frame * turn
                e = own_frame * sp.Matrix([0, 0, -1])
                if rates is not None:       # omega = turn^T omega_parent + axis q'_j, in own axes
                    spin = sp.zeros(3, len(s.q))
                    if link.prescribed:     # a driven joint turns at f'(t): omega's part in t
                        own_spin = (turn.T * spin_t + axis * q[0].diff(t)).applyfunc(sp.expand)
                    else:
                        spin[:, model.link_coordinates(link)[0]] = axis
                        own_spin = (turn.T * spin_t).applyfunc(sp.expand)
                    own_rates = (turn.T * rates + spin).applyfunc(sp.expand)
            else:
                e = link.chart.unit_vector(q)
                own_frame = _planar_frame(e) if dim == 2 and len(q) == 1 else None
            length = parse_quantity(link.length, s)
            end = joint + length * e
            com = parse_quantity(link.body.com, s) if link.body is not None else sp.S.One
            centre = joint + com * length * e
            if link.body is not None and link.body.centre is not None:     # a rigid body's
                centre = joint + own_frame * sp.Matrix([parse_quantity(c, s) for c in link.body.centre])
        geo.joints.append(joint)
        geo.tips.append(end)
        geo.centres.append(centre)
        geo.directions.append(e)
        geo.frames.append(own_frame)
        geo.rates.append(own_rates)
        geo.spins.append(own_spin)
    return geo


def _fold(x: sp.Expr) -> sp.Expr:
    """One entry of M, expanded and its sin^2 + cos^2 folded (an entry is a short
    trigonometric polynomial: the one simplification the general path makes)."""
    return sp.trigsimp(sp.expand(x))


def tree_form(model: Model, s: ModelSymbols, geo: TreeGeometry) -> tuple[ChainForm, sp.Expr]:
    """M and V of a kinematic tree (as a ChainForm without placeholders, so `forcing` takes
    it) and the explicit-time part of T (T - 1/2 q'^T M q'), module docstring.

    Parameters
    ----------
    model : Model
    s : ModelSymbols
    geo : TreeGeometry
        The tree's positions (tree_geometry).

    Returns
    -------
    (ChainForm, sympy.Expr)
        M and V (gravity's) with no placeholders, and T's explicit-time part.
    """
    n, qd = len(s.q), sp.Matrix(s.qd)
    q = sp.Matrix(s.q)
    M, V, T_time = sp.zeros(n, n), sp.S.Zero, sp.S.Zero
    g = s.param("g")
    for link, centre, e, W, w in zip(model.links, geo.centres, geo.directions, geo.rates, geo.spins):
        if link.body is None:
            continue
        m = parse_quantity(link.body.mass, s)
        J = centre.jacobian(q)
        M += m * J.T * J
        if link.body.tensor is not None:          # a rigid body turning with its link's frame
            tensor = sp.Matrix([[parse_quantity(x, s) for x in row] for row in link.body.tensor])
            M += W.T * tensor * W
            if w is not None and w != sp.zeros(3, 1):     # omega = W q' + w(t): a driven joint's spin
                T_time += (w.T * tensor * (W * qd))[0, 0] + (w.T * tensor * w)[0, 0] / 2
        inertia = parse_quantity(link.body.inertia, s)
        if e is not None and inertia != 0:
            E = e.jacobian(q)
            M += inertia * E.T * E
            turning = e.diff(t)                   # a rod turned by a driven joint: de/dt = E q' + de/dt|_q
            if turning != sp.zeros(*turning.shape):
                T_time += inertia * (turning.T * (E * qd))[0, 0] + inertia * (turning.T * turning)[0, 0] / 2
        moving = centre.diff(t)
        if moving != sp.zeros(*moving.shape):
            T_time += m * (moving.T * (J * qd))[0, 0] + m * (moving.T * moving)[0, 0] / 2
        V += m * g * centre[-1]
    M = M.applyfunc(_fold)
    return ChainForm(M, sp.expand(V), {}), sp.expand(T_time)
