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


# ---------------------------------------------------------------------------------------
# Any serial chain of point masses (the double pendulum above is the case N = 2, 3-D).
#
# Masses m_i at x_i (i = 1..N), pivot x_0 = 0 fixed, link vectors d_i = x_i - x_{i-1}
# of length l_i, gravity -g along the last axis (z in 3-D, y in 2-D).  Link i pulls
# mass i towards mass i-1 with tension T_i along e_i = d_i / l_i, and mass i-1 the
# other way:
#     m_i a_i = m_i g_vec - T_i e_i + T_{i+1} e_{i+1}          (T_{N+1} = 0)
# The tensions follow from the second derivative of each constraint |d_i|^2 = l_i^2,
#     d_i.(a_i - a_{i-1}) + |w_i|^2 = 0,       w_i = v_i - v_{i-1},  a_0 = 0,
# optionally Baumgarte-stabilised (alpha, beta: g'' + 2 alpha g' + beta^2 g = 0 for
# g_i = |d_i|^2 - l_i^2), a tridiagonal N x N linear system solved at every evaluation.
# ---------------------------------------------------------------------------------------

def chain_accelerations(x, v, masses, lengths, g, alpha=0.0, beta=0.0):
    """Accelerations (N, dim) of the chain at positions x and velocities v (N, dim)."""
    x, v = np.asarray(x, float), np.asarray(v, float)
    m, l = np.asarray(masses, float), np.asarray(lengths, float)
    n, dim = x.shape
    zero = np.zeros((1, dim))
    d = x - np.vstack([zero, x[:-1]])
    w = v - np.vstack([zero, v[:-1]])
    e = d / l[:, None]
    grav = np.zeros(dim)
    grav[-1] = -g
    # a_i = grav + sum_k B[i, :, k] T_k
    B = np.zeros((n, dim, n))
    for i in range(n):
        B[i, :, i] = -e[i] / m[i]
        if i + 1 < n:
            B[i, :, i + 1] = e[i + 1] / m[i]
    rel_B = B - np.concatenate([np.zeros((1, dim, n)), B[:-1]])     # a_i - a_{i-1}
    rel_grav = np.zeros((n, dim))
    rel_grav[0] = grav                                              # a_0 = 0
    A = np.einsum("id,idk->ik", d, rel_B)
    gval = (d * d).sum(-1) - l * l
    gdot = 2 * (d * w).sum(-1)
    b = -(w * w).sum(-1) - (d * rel_grav).sum(-1) - alpha * gdot - 0.5 * beta ** 2 * gval
    T = np.linalg.solve(A, b)
    return grav + np.einsum("idk,k->id", B, T)


def chain_rhs(_t, y, masses, lengths, g, dim, alpha=0.0, beta=0.0):
    n = len(masses)
    x, v = y[:n * dim].reshape(n, dim), y[n * dim:].reshape(n, dim)
    a = chain_accelerations(x, v, masses, lengths, g, alpha, beta)
    return np.concatenate([v.ravel(), a.ravel()])


def chain_simulate(y0, t_eval, masses, lengths, g, dim=3, rtol=1e-13, atol=1e-13,
                   alpha=0.0, beta=0.0):
    """States (len(t), 2 N dim): positions x_1..x_N then velocities v_1..v_N."""
    sol = solve_ivp(chain_rhs, (t_eval[0], t_eval[-1]), np.asarray(y0, float), method="DOP853",
                    t_eval=t_eval, rtol=rtol, atol=atol,
                    args=(tuple(masses), tuple(lengths), g, dim, alpha, beta))
    assert sol.success, sol.message
    return sol.y.T


def chain_constraints(y, lengths, dim=3):
    """Position and velocity constraint residuals |d_i| - l_i and d_i.w_i / l_i, (..., N) each."""
    n = len(lengths)
    y = np.asarray(y, float)
    x = y[..., :n * dim].reshape(y.shape[:-1] + (n, dim))
    v = y[..., n * dim:].reshape(y.shape[:-1] + (n, dim))
    pad = np.zeros(y.shape[:-1] + (1, dim))
    d = x - np.concatenate([pad, x[..., :-1, :]], -2)
    w = v - np.concatenate([pad, v[..., :-1, :]], -2)
    l = np.asarray(lengths, float)
    return np.linalg.norm(d, axis=-1) - l, (d * w).sum(-1) / l


def chain_energy(y, masses, g, dim=3):
    n = len(masses)
    y = np.asarray(y, float)
    x = y[..., :n * dim].reshape(y.shape[:-1] + (n, dim))
    v = y[..., n * dim:].reshape(y.shape[:-1] + (n, dim))
    m = np.asarray(masses, float)
    return (0.5 * m * (v * v).sum(-1)).sum(-1) + g * (m * x[..., -1]).sum(-1)
