"""The cart-pole balanced upright by LQR: derive's linearisation, SciPy's Riccati solver,
derive's simulation with the feedback evaluated at every stage.

    python examples/cart_pole_lqr.py [--plot cart_pole_lqr.png] [--t-end 8]

1. A, B = derive.linearize(...) at the upright equilibrium (theta = pi, x = 0, at rest, F = 0);
2. K from the continuous algebraic Riccati equation, F = -K (y - y_up) (scipy.linalg);
3. derive.simulate from 0.3 rad off upright with ``inputs=lambda t, y: ...``: the controller
   is a function of the state at every stage of the integrator, as a continuous controller
   is (``hold="zoh"`` would model a digital one, holding F between samples).

Exits 1 when the pole is not back upright and the cart home by the end (a controller that
fails says so).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.linalg import solve_continuous_are

import derive

MODEL = Path(__file__).resolve().parent / "models" / "cart_pole.toml"
PARAMS = {"M": 1.0, "m": 0.1, "l": 0.5, "g": 9.81}      # cart 1 kg, bob 100 g on 0.5 m
UPRIGHT = np.array([0.0, np.pi, 0.0, 0.0])               # x, theta, x_dot, theta_dot
Q = np.diag([1.0, 10.0, 1.0, 1.0])                       # weights: pole angle first
R = np.array([[0.1]])                                    # force's cost


def lqr_gain(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """K minimising the integral of x'Qx + u'Ru for x' = A x + B u: K = R^-1 B' P."""
    P = solve_continuous_are(A, B, Q, R)
    return np.linalg.solve(R, B.T @ P)


def balance(t_end: float = 8.0, offset: float = 0.3):
    """Linearise, design K, and run the closed loop from `offset` rad off upright."""
    A, B = derive.linearize(MODEL, dict(zip(["x", "theta", "x_dot", "theta_dot"], UPRIGHT)),
                            PARAMS, {"F": 0.0})
    K = lqr_gain(A, B)
    closed = np.linalg.eigvals(A - B @ K)

    def force(t, y):
        return {"F": float(-K[0] @ (y - UPRIGHT))}

    y0 = UPRIGHT + np.array([0.0, -offset, 0.0, 0.0])
    run = derive.simulate(MODEL, y0, np.linspace(0.0, t_end, 401), PARAMS, inputs=force,
                          method="dop853", rtol=1e-10)
    run.raise_for_status()
    F = np.array([force(t, y)["F"] for t, y in zip(run.t, run.y)])
    return A, B, K, closed, run, F


def plot(run, F, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(3, 1, figsize=(7, 6.5), sharex=True, constrained_layout=True)
    axes[0].plot(run.t, run.y[:, 1] - np.pi)
    axes[0].set_ylabel("θ − π (rad)")
    axes[0].set_title("Cart-pole balanced by LQR (derive.linearize + solve_continuous_are)")
    axes[1].plot(run.t, run.y[:, 0])
    axes[1].set_ylabel("cart x (m)")
    axes[2].plot(run.t, F)
    axes[2].set_ylabel("force F (N)")
    axes[2].set_xlabel("time t (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.axhline(0.0, color="0.5", lw=0.8)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", type=Path, help="write the run's plot (PNG) here")
    parser.add_argument("--t-end", type=float, default=8.0)
    args = parser.parse_args(argv)
    A, B, K, closed, run, F = balance(args.t_end)
    np.set_printoptions(precision=4, suppress=True)
    print("A =\n", A, "\nB =", B.ravel(), "\nK =", K.ravel())
    print("closed-loop eigenvalues:", np.sort_complex(closed))
    off = abs(run.y[-1, 1] - np.pi)
    print(f"at t = {run.t[-1]:g}: theta - pi = {run.y[-1, 1] - np.pi:.2e} rad, x = {run.y[-1, 0]:.2e} m, "
          f"largest force {np.abs(F).max():.2f} N")
    if args.plot:
        plot(run, F, args.plot)
        print(f"wrote {args.plot}")
    if not (closed.real.max() < 0 and off < 1e-3 and abs(run.y[-1, 0]) < 1e-2):
        print("cart_pole_lqr: the pole is not balanced by the end", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
