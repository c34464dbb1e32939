"""An independent formulation of the double spherical pendulum, for tests only.

No charts and nothing from derive/: two point masses in Cartesian space with
rigid links enforced by constraint forces (tensions).  With pivot at the
origin, d = x2 - x1 and gravity -g e_z,
    m1 a1 = -m1 g e_z - T1 x1/l1 + T2 d/l2
    m2 a2 = -m2 g e_z - T2 d/l2
and the tensions follow from the second derivatives of the constraints
|x1|^2 = l1^2 and |d|^2 = l2^2:
    x1.a1 + |v1|^2 = 0,    d.(a2 - a1) + |v2 - v1|^2 = 0,
a 2x2 linear system in (T1, T2).  Integrated with SciPy's DOP853 at tight
tolerance, with the state projected back onto the constraints at output.
"""
import numpy as np
from scipy.integrate import solve_ivp


def accelerations(x1, x2, v1, v2, m1, m2, l1, l2, g):
    d, w = x2 - x1, v2 - v1
    e1, e2 = x1 / l1, d / l2
    gz = np.array([0.0, 0.0, -g])
    # a1 = gz - T1 e1/m1 + T2 e2/m1 ;  a2 - a1 = -T2 e2/m2 + T1 e1/m1 - T2 e2/m1
    A = np.array([[-x1 @ e1 / m1, x1 @ e2 / m1],
                  [d @ e1 / m1, -d @ e2 * (1 / m1 + 1 / m2)]])
    b = np.array([-(v1 @ v1) - x1 @ gz, -(w @ w)])
    T1, T2 = np.linalg.solve(A, b)
    a1 = gz - T1 * e1 / m1 + T2 * e2 / m1
    a2 = gz - T2 * e2 / m2
    return a1, a2


def rhs(_t, y, m1, m2, l1, l2, g):
    x1, x2, v1, v2 = y[0:3], y[3:6], y[6:9], y[9:12]
    a1, a2 = accelerations(x1, x2, v1, v2, m1, m2, l1, l2, g)
    return np.concatenate([v1, v2, a1, a2])


def simulate(y0, t_eval, m1, m2, l1, l2, g, rtol=1e-13, atol=1e-13):
    """Positions and velocities (len(t), 12) of the Cartesian reference."""
    sol = solve_ivp(rhs, (t_eval[0], t_eval[-1]), np.asarray(y0, float), method="DOP853",
                    t_eval=t_eval, rtol=rtol, atol=atol, args=(m1, m2, l1, l2, g))
    assert sol.success, sol.message
    return sol.y.T


def energy(y, m1, m2, g):
    x1, x2, v1, v2 = y[..., 0:3], y[..., 3:6], y[..., 6:9], y[..., 9:12]
    return (0.5 * m1 * (v1 * v1).sum(-1) + 0.5 * m2 * (v2 * v2).sum(-1)
            + g * (m1 * x1[..., 2] + m2 * x2[..., 2]))
