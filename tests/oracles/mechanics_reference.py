"""Independent references for serial pendulum chains, built with sympy.physics.mechanics.

For tests only.  Nothing here comes from derive/: no charts file, no model file, no
derivation code.  Each chain is described physically -- frames, points, particles,
rigid bodies, applied forces and torques -- and SymPy's LagrangesMethod forms the
equations of motion M(q) q'' = f(q, q', p, u).  The tests compare the toolkit's
generated kernels against these.

What makes the references independent of the toolkit's derivation:

* Gravity is an applied force  -m g e_up  at every mass centre (a forcelist entry),
  not a potential energy; the Lagrangian handed to LagrangesMethod is T alone.
* A rod is a RigidBody whose frame is rotated by the link's absolute angle, so its
  rotational energy comes from SymPy's angular velocity and inertia dyadic, not from
  |de/dt|^2.
* Joint damping and joint torques are torques on the link frames, with their
  reactions on the neighbouring link (Newton's third law); SymPy turns them into
  generalized forces through the frames' partial angular velocities.  No Rayleigh
  function and no hand-written Q appear here -- the tests write those for the
  toolkit's model file and the comparison checks that both say the same physics.
* The spherical chains use the link unit vectors written out below from their
  geometric definitions (seed 000 (2.1), (4.1)), with point velocities obtained by
  SymPy's time derivative in the inertial frame.

Conventions (those of the toolkit's model format, so states and parameters line up):
planar links hang from the origin with unit vector (sin th, -cos th), gravity along -y;
spherical links use the chart unit vectors below, gravity along -z.  The state is the
coordinates followed by their rates.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import sympy as sp
from sympy.core.function import AppliedUndef
from sympy.physics.mechanics import (LagrangesMethod, Particle, Point, ReferenceFrame,
                                     RigidBody, dynamicsymbols, inertia)


@dataclass(frozen=True)
class LinkSpec:
    """One link: its length and its body (parameter names, or numbers as strings)."""
    length: str
    mass: str
    kind: str = "point"        # "point": mass at the tip; "rod": rigid body
    com: str = "1"             # rod: mass centre at com * length along the link
    inertia: str = "0"         # rod: central moment of inertia (planar: about z)


@dataclass
class Reference:
    """Equations of motion of one chain, as NumPy functions of (state, params, inputs)."""
    coordinates: list[str]
    parameters: list[str]
    inputs: list[str]
    mass_matrix: sp.Matrix                  # in plain symbols (q, qd, p, u)
    forcing: sp.Matrix
    positions_expr: sp.Matrix               # tip positions of every link, stacked
    dimension: int                          # 2 (planar) or 3
    symbols: list[sp.Symbol] = field(repr=False, default_factory=list)

    def __post_init__(self):
        self._M = _matrix_function(self.symbols, self.mass_matrix)
        self._F = _matrix_function(self.symbols, self.forcing)
        self._X = _matrix_function(self.symbols, self.positions_expr)
        # Cartesian velocities and accelerations of the tips by the chain rule:
        # x' = J q',  x'' = J q'' + (dJ/dt) q'
        n = len(self.coordinates)
        q, qd = self.symbols[:n], self.symbols[n:2 * n]
        self._qdd = sp.symbols([f"{c}_ddot" for c in self.coordinates])
        X = self.positions_expr
        V = X.jacobian(q) * sp.Matrix(qd)
        A = V.jacobian(q) * sp.Matrix(qd) + V.jacobian(qd) * sp.Matrix(self._qdd)
        self._V = _matrix_function(self.symbols, V)
        self._J = _matrix_function(self.symbols, X.jacobian(q))
        self._A = _matrix_function([*self.symbols, *self._qdd], A)

    @property
    def n(self) -> int:
        return len(self.coordinates)

    def _args(self, y, p, u):
        y = np.asarray(y, float)
        batch = y.shape[:-1]
        p = np.broadcast_to(np.asarray(p, float), batch + (len(self.parameters),))
        u = np.zeros(batch + (0,)) if u is None else np.broadcast_to(
            np.asarray(u, float), batch + (len(self.inputs),))
        if u.shape[-1] != len(self.inputs):
            raise ValueError(f"{len(self.inputs)} inputs expected")
        cols = [y[..., i] for i in range(2 * self.n)] + [p[..., i] for i in range(p.shape[-1])] \
            + [u[..., i] for i in range(u.shape[-1])]
        return batch, cols

    def accelerations(self, y, p, u=None):
        """q'' (..., n): numpy.linalg.solve of M(q) q'' = f(q, q', p, u) at every state."""
        batch, cols = self._args(y, p, u)
        M = self._M(batch, cols)
        f = self._F(batch, cols)
        return np.linalg.solve(M, f)[..., 0]

    def accelerations_exact(self, y, p, u=None, dps: int = 40):
        """q'' (..., n) with every state evaluated and solved in mpmath at `dps` digits,
        then rounded to float64: the reference to compare float64 kernels against.
        (The float64 evaluation of SymPy's unsimplified M and f loses up to ~1e-13 near
        the spherical charts' poles; this one is correct to the last bit of a double.)"""
        import mpmath
        if not hasattr(self, "_mp"):
            self._mp = (sp.lambdify(self.symbols, self.mass_matrix, "mpmath", cse=True),
                        sp.lambdify(self.symbols, self.forcing, "mpmath", cse=True))
        batch, cols = self._args(y, p, u)
        flat = np.stack([np.broadcast_to(c, batch).reshape(-1) for c in cols], -1) if cols else None
        out = np.empty((flat.shape[0], self.n))
        with mpmath.workdps(dps):
            for k, row in enumerate(flat):
                args = [mpmath.mpf(float(v)) for v in row]
                x = mpmath.lu_solve(self._mp[0](*args), self._mp[1](*args))
                out[k] = [float(v) for v in x]
        return out.reshape(batch + (self.n,))

    def rhs_exact(self, y, p, u=None, dps: int = 40):
        """(q', q'') with q'' from accelerations_exact."""
        y = np.asarray(y, float)
        return np.concatenate([y[..., self.n:], self.accelerations_exact(y, p, u, dps)], axis=-1)

    def rhs(self, y, p, u=None):
        """(q', q'') for states y (..., 2n)."""
        y = np.asarray(y, float)
        return np.concatenate([y[..., self.n:], self.accelerations(y, p, u)], axis=-1)

    def positions(self, y, p):
        """Tip positions (..., links, dimension)."""
        batch, cols = self._args(y, p, None if not self.inputs else np.zeros(len(self.inputs)))
        X = self._X(batch, cols)[..., 0]
        return X.reshape(batch + (-1, self.dimension))


    def cartesian(self, y, p, qdd=None):
        """Tip positions, velocities (and accelerations, given q'') (..., links, dimension)."""
        batch, cols = self._args(y, p, None if not self.inputs else np.zeros(len(self.inputs)))
        shape = batch + (-1, self.dimension)
        out = [self._X(batch, cols)[..., 0].reshape(shape), self._V(batch, cols)[..., 0].reshape(shape)]
        if qdd is not None:
            qdd = np.broadcast_to(np.asarray(qdd, float), batch + (self.n,))
            cols = cols + [qdd[..., i] for i in range(self.n)]
            out.append(self._A(batch, cols)[..., 0].reshape(shape))
        return tuple(out)


    def state_from_cartesian(self, x, v, p, chart: str):
        """A spherical chain's state (2n,) in `chart` from tip positions and velocities
        (links, 3): angles by the chart's inverse, rates by least squares of x' = J q'
        (exact for a state on the constraints)."""
        x, v = np.asarray(x, float), np.asarray(v, float)
        d = x - np.vstack([np.zeros(3), x[:-1]])
        e = d / np.linalg.norm(d, axis=-1, keepdims=True)
        q = np.concatenate([SPHERICAL_INVERSE[chart](*ei) for ei in e])
        y = np.concatenate([q, np.zeros_like(q)])
        batch, cols = self._args(y, p, None)
        J = self._J(batch, cols)
        y[self.n:] = np.linalg.lstsq(J, v.ravel(), rcond=None)[0]
        return y


def _matrix_function(symbols, matrix: sp.Matrix):
    """f(batch, columns) -> array (..., rows, cols), one lambdified function per entry
    (a constant entry is broadcast to the batch)."""
    entries = [[sp.lambdify(symbols, matrix[i, j], "numpy") for j in range(matrix.cols)]
               for i in range(matrix.rows)]

    def evaluate(batch, cols):
        out = np.empty(batch + (matrix.rows, matrix.cols))
        for i, row in enumerate(entries):
            for j, fn in enumerate(row):
                out[..., i, j] = fn(*cols)
        return out
    return evaluate


def _value(text: str, symbols: dict[str, sp.Symbol]) -> sp.Expr:
    return sp.sympify(text, locals=symbols)


def _finish(lm: LagrangesMethod, q, params, inputs, tips, names, psyms, usyms,
            dimension: int) -> Reference:
    """Replace the dynamicsymbols by plain symbols and wrap the result."""
    lm.form_lagranges_equations()
    qd = [qi.diff(dynamicsymbols._t) for qi in q]
    qs = sp.symbols(names)
    qds = sp.symbols([f"{c}_dot" for c in names])
    # xreplace works top-down: the Derivative nodes are replaced before their arguments
    rule = {**dict(zip(qd, qds)), **dict(zip(q, qs))}
    M = lm.mass_matrix.xreplace(rule)
    F = lm.forcing.xreplace(rule)
    X = sp.Matrix(tips).xreplace(rule)
    for expr in (M, F, X):
        left = expr.atoms(AppliedUndef, sp.Derivative)
        assert not left, f"unreplaced time functions {left}"
    return Reference(coordinates=list(names), parameters=list(params), inputs=list(inputs),
                     mass_matrix=M, forcing=F, positions_expr=X, dimension=dimension,
                     symbols=[*qs, *qds, *[psyms[n] for n in params], *[usyms[n] for n in inputs]])


def planar_chain(links: list[LinkSpec], parameters: list[str], inputs: list[str] = (),
                 joint_torques: list[str | None] | None = None,
                 joint_dampers: list[str | None] | None = None) -> Reference:
    """A planar serial chain hanging from the origin, gravity along -y.

    Link i has frame A_i rotated by its absolute angle theta_i about N.z, so its
    direction is -A_i.y = (sin theta_i, -cos theta_i).  Joint i joins link i-1 (the
    ground for i = 1) to link i.  ``joint_torques[i]`` names an input (or expression)
    tau_i: a motor at joint i, acting +tau_i N.z on link i and -tau_i N.z on link i-1.
    ``joint_dampers[i]`` names a viscous coefficient c_i: the torque
    -c_i (theta_i' - theta_{i-1}') N.z on link i and its reaction on link i-1.
    """
    n = len(links)
    psyms = {name: sp.Symbol(name) for name in parameters}
    usyms = {name: sp.Symbol(name) for name in inputs}
    local = {**psyms, **usyms}
    g = psyms["g"]
    q = dynamicsymbols(f"theta1:{n + 1}")
    qd = [qi.diff(dynamicsymbols._t) for qi in q]

    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    frames, bodies, forces, tips = [], [], [], []
    joint = O
    for i, (link, qi) in enumerate(zip(links, q)):
        A = ReferenceFrame(f"A{i + 1}")
        A.orient_axis(N, N.z, qi)             # A.w.N = theta_i' N.z
        frames.append(A)
        length, mass = _value(link.length, local), _value(link.mass, local)
        down = -A.y                           # the link direction (sin th, -cos th)
        tip = joint.locatenew(f"P{i + 1}", length * down)
        tip.v2pt_theory(joint, N, A)
        if link.kind == "point":
            bodies.append(Particle(f"m{i + 1}", tip, mass))
            centre = tip
        elif link.kind == "rod":
            centre = joint.locatenew(f"G{i + 1}", _value(link.com, local) * length * down)
            centre.v2pt_theory(joint, N, A)
            # central inertia: L about z (the axis of rotation); x, y moments play no part
            I = inertia(A, 0, 0, _value(link.inertia, local))
            bodies.append(RigidBody(f"rod{i + 1}", centre, A, mass, (I, centre)))
        else:
            raise ValueError(link.kind)
        forces.append((centre, -mass * g * N.y))     # gravity at the mass centre
        tips.extend([tip.pos_from(O).dot(N.x), tip.pos_from(O).dot(N.y)])
        joint = tip

    # Joint torques and dampers, each with its reaction on the link before the joint.
    torque = [sp.S.Zero] * n                         # net z-torque on each link frame
    for i in range(n):
        tau = sp.S.Zero
        if joint_torques and joint_torques[i]:
            tau += _value(joint_torques[i], local)
        if joint_dampers and joint_dampers[i]:
            relative = qd[i] - (qd[i - 1] if i > 0 else 0)
            tau += -_value(joint_dampers[i], local) * relative
        torque[i] += tau
        if i > 0:
            torque[i - 1] -= tau                     # reaction on the previous link
    forces += [(A, t * N.z) for A, t in zip(frames, torque) if t != 0]

    T = sum(b.kinetic_energy(N) for b in bodies)     # gravity is in the forcelist
    lm = LagrangesMethod(T, q, forcelist=forces, frame=N)
    return _finish(lm, q, parameters, inputs, tips, [f"theta{i}" for i in range(1, n + 1)],
                   psyms, usyms, 2)


# Spherical charts, written from their geometric definitions: the direction of a link
# in terms of its two angles (seed 000 (2.1) and (4.1)).
def _standard(theta, phi):
    """Polar angle from the downward vertical -z, azimuth from x about z."""
    return (sp.sin(theta) * sp.cos(phi), sp.sin(theta) * sp.sin(phi), -sp.cos(theta))


def _second(vartheta, varphi):
    """Polar angle from +x, azimuth from y about x (singular along the x axis)."""
    return (sp.cos(vartheta), sp.sin(vartheta) * sp.cos(varphi), sp.sin(vartheta) * sp.sin(varphi))


def _standard_inverse(x, y, z):
    return np.array([np.arctan2(np.hypot(x, y), -z), np.arctan2(y, x)])


def _second_inverse(x, y, z):
    return np.array([np.arctan2(np.hypot(y, z), x), np.arctan2(z, y)])


SPHERICAL_INVERSE = {"standard": _standard_inverse, "second": _second_inverse}
SPHERICAL = {"standard": (("theta", "phi"), _standard), "second": (("vartheta", "varphi"), _second)}


def spherical_chain(links: list[LinkSpec], parameters: list[str], chart: str = "standard") -> Reference:
    """A spherical chain of point masses hanging from the origin, gravity along -z; every
    link in the same chart (``standard`` or ``second``)."""
    names, unit = SPHERICAL[chart]
    n = len(links)
    psyms = {name: sp.Symbol(name) for name in parameters}
    g = psyms["g"]
    coords = [f"{c}{i}" for i in range(1, n + 1) for c in names]
    q = dynamicsymbols(coords)
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    bodies, forces, tips = [], [], []
    joint = O
    for i, link in enumerate(links):
        if link.kind != "point":
            raise ValueError("spherical references are point masses")
        e = unit(q[2 * i], q[2 * i + 1])
        length, mass = _value(link.length, psyms), _value(link.mass, psyms)
        tip = joint.locatenew(f"P{i + 1}", length * (e[0] * N.x + e[1] * N.y + e[2] * N.z))
        tip.set_vel(N, tip.pos_from(O).dt(N))
        bodies.append(Particle(f"m{i + 1}", tip, mass))
        forces.append((tip, -mass * g * N.z))
        tips.extend([tip.pos_from(O).dot(v) for v in (N.x, N.y, N.z)])
        joint = tip
    T = sum(b.kinetic_energy(N) for b in bodies)
    lm = LagrangesMethod(T, q, forcelist=forces, frame=N)
    return _finish(lm, q, parameters, (), tips, coords, psyms, {}, 3)
