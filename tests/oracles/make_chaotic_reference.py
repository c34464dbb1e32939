"""High-precision reference trajectory of the chaotic planar double pendulum.

Independent of derive (nothing from derive/ is imported): the equations of motion are
written here from the Lagrangian, and the trajectory is integrated with mpmath by a Taylor
series method whose coefficients come from automatic-differentiation recurrences in mpf.

Problem (derive's catalogue model `planar`): two point masses m1, m2 on massless rods of
lengths l1, l2, angles theta1, theta2 from the downward vertical (bob i at
sum_{j<=i} l_j (sin theta_j, -cos theta_j)), state (theta1, theta2, omega1, omega2),
m1 = m2 = l1 = l2 = 1, g = 9.81, y0 = (2.5, 2, 0, 0).  The motion is chaotic: a
perturbation grows by about 10^16 between t = 0 and t = 20 (measured: the stored run's
errors, 1e-58 at t = 0.5, are 7e-42 at t = 20), so float64 (and long double)
runs lose the trajectory long before t = 20.

g is the IEEE double nearest 9.81 (exactly 9.8100000000000004973799150320701301097869873046875),
not the decimal 9.81: derive receives g as that Python float.  The two differ by 5e-17
relative; with zero initial rates a change of g only rescales time (theta(t) depends on
t sqrt(g)), so it is not amplified chaotically, but it still moves the t = 20 state by
about 1e-14 (measured), far more than this reference's own error.

Equations (Lagrange's equations of L = T - V, as in any mechanics text, e.g. Goldstein,
Classical Mechanics, ch. 1-2; with Delta = theta1 - theta2):
    T = (m1+m2) l1^2 omega1^2 / 2 + m2 l2^2 omega2^2 / 2 + m2 l1 l2 omega1 omega2 cos Delta
    V = -(m1+m2) g l1 cos theta1 - m2 g l2 cos theta2
    M(q) (alpha1, alpha2) = r with
    M = [[(m1+m2) l1^2, m2 l1 l2 cos Delta], [m2 l1 l2 cos Delta, m2 l2^2]]
    r = (-m2 l1 l2 omega2^2 sin Delta - (m1+m2) g l1 sin theta1,
          m2 l1 l2 omega1^2 sin Delta - m2 g l2 sin theta2)
solved by Cramer's rule, det M = m2 l1^2 l2^2 (m1 + m2 sin^2 Delta).
tests/measurement/test_chaotic_reference.py checks these accelerations against an mpmath LU solve
of M and against the closed form of myphysicslab.com ("Double Pendulum", E. Neumann).

Method: Taylor series of order N about each step's start, its coefficients by the
standard recurrences (sin/cos pair, products, quotient; e.g. Jorba & Zou, Experiment.
Math. 14 (2005) 99-117), the step by the Jorba-Zou rule
    h = min over k in {N-1, N} of (tol * max(1, |y|_inf) / |y_[k]|_inf)^(1/k),
shortened to land exactly on each output time, the polynomial summed by Horner's rule.

The script makes two runs: the stored one (--digits, default 60 significant digits of
working precision) and a check run 15 digits more precise, tighter tolerance and higher
order; their largest difference at each output time is the stored run's measured error.

    python3 tests/oracles/make_chaotic_reference.py                 # writes tests/data/chaotic_planar_reference.json
    python3 tests/oracles/make_chaotic_reference.py --t-end 2 --out /tmp/ref.json
"""
from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from pathlib import Path

import mpmath
from mpmath import mp, mpf

STATE_NAMES = ("theta1", "theta2", "omega1", "omega2")
PARAMETER_NAMES = ("m1", "m2", "l1", "l2", "g")
# Values as derive receives them (Python floats); every one is read into mpf exactly.
PARAMETERS = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}
Y0 = (2.5, 2.0, 0.0, 0.0)
OUTPUT_STEP = 0.5
STORED_DIGITS = 40          # significant digits of the stored decimal strings
CHECK_EXTRA_DIGITS = 15     # the check run's extra working precision
DEFAULT_OUT = Path(__file__).resolve().parents[1] / "data" / "chaotic_planar_reference.json"


# -- the problem -------------------------------------------------------------------------

def mp_params(params=PARAMETERS) -> dict:
    """The parameters as mpf (floats are converted exactly, never via decimal)."""
    return {name: mpf(params[name]) for name in PARAMETER_NAMES}


def accelerations(state, p) -> tuple:
    """(alpha1, alpha2) at one state: Lagrange's equations solved by Cramer's rule."""
    th1, th2, w1, w2 = state
    m1, m2, l1, l2, g = (p[n] for n in PARAMETER_NAMES)
    s, c = mpmath.sin(th1 - th2), mpmath.cos(th1 - th2)
    r1 = -m2 * l1 * l2 * w2 ** 2 * s - (m1 + m2) * g * l1 * mpmath.sin(th1)
    r2 = m2 * l1 * l2 * w1 ** 2 * s - m2 * g * l2 * mpmath.sin(th2)
    det = m2 * l1 ** 2 * l2 ** 2 * (m1 + m2 * s ** 2)
    alpha1 = (m2 * l2 ** 2 * r1 - m2 * l1 * l2 * c * r2) / det
    alpha2 = ((m1 + m2) * l1 ** 2 * r2 - m2 * l1 * l2 * c * r1) / det
    return alpha1, alpha2


def energy(state, p):
    """T + V (V = 0 with both rods horizontal at the pivot's height)."""
    th1, th2, w1, w2 = state
    m1, m2, l1, l2, g = (p[n] for n in PARAMETER_NAMES)
    kinetic = ((m1 + m2) * l1 ** 2 * w1 ** 2 / 2 + m2 * l2 ** 2 * w2 ** 2 / 2
               + m2 * l1 * l2 * w1 * w2 * mpmath.cos(th1 - th2))
    potential = -(m1 + m2) * g * l1 * mpmath.cos(th1) - m2 * g * l2 * mpmath.cos(th2)
    return kinetic + potential


# -- Taylor coefficients by automatic differentiation ------------------------------------

def convolution(a, b, k):
    """Coefficient k of the product of two series: sum_{j=0..k} a_j b_{k-j}."""
    return mpmath.fdot(a[:k + 1], b[k::-1])


def sincos_step(du, s, c, k):
    """Append coefficient k (k >= 1) of sin u and cos u, given du_j = coefficient j of u'.

    From (sin u)' = u' cos u and (cos u)' = -u' sin u:
        k s_k = sum_{j=0..k-1} du_j c_{k-1-j},   k c_k = -sum_{j=0..k-1} du_j s_{k-1-j}.
    """
    s.append(convolution(du, c, k - 1) / k)
    c.append(-convolution(du, s, k - 1) / k)


def quotient_step(num, den, q, k):
    """Append coefficient k of q = num / den: q_k = (num_k - sum_{j=1..k} den_j q_{k-j}) / den_0."""
    if k == 0:
        q.append(num[0] / den[0])
    else:
        q.append((num[k] - mpmath.fdot(den[1:k + 1], q[k - 1::-1])) / den[0])


def taylor_coefficients(state, p, order: int) -> list:
    """The Taylor coefficients 0..order of (theta1, theta2, omega1, omega2) at `state`.

    Every intermediate of the acceleration (sines, squares, products, the quotient by
    det M) is a series built one coefficient at a time; coefficient k of the accelerations
    gives coefficient k+1 of the rates, and coefficient k of the rates coefficient k+1 of
    the angles.
    """
    m1, m2, l1, l2, g = (p[n] for n in PARAMETER_NAMES)
    k12 = m2 * l1 * l2
    gl1 = (m1 + m2) * g * l1
    gl2 = m2 * g * l2
    a11, a22 = (m1 + m2) * l1 ** 2, m2 * l2 ** 2
    kdet = m2 * l1 ** 2 * l2 ** 2

    th1, th2, w1, w2 = ([mpf(x)] for x in state)
    dd = []                                   # coefficients of Delta' = omega1 - omega2
    sd, cd = [mpmath.sin(th1[0] - th2[0])], [mpmath.cos(th1[0] - th2[0])]
    s1, c1 = [mpmath.sin(th1[0])], [mpmath.cos(th1[0])]
    s2, c2 = [mpmath.sin(th2[0])], [mpmath.cos(th2[0])]
    w1sq, w2sq, sdsq = [], [], []
    w2sq_sd, w1sq_sd = [], []
    r1, r2, cd_r1, cd_r2 = [], [], [], []
    num1, num2, det = [], [], []
    alpha1, alpha2 = [], []
    for k in range(order):
        dd.append(w1[k] - w2[k])
        if k > 0:
            sincos_step(dd, sd, cd, k)
            sincos_step(w1, s1, c1, k)
            sincos_step(w2, s2, c2, k)
        w1sq.append(convolution(w1, w1, k))
        w2sq.append(convolution(w2, w2, k))
        sdsq.append(convolution(sd, sd, k))
        w2sq_sd.append(convolution(w2sq, sd, k))
        w1sq_sd.append(convolution(w1sq, sd, k))
        r1.append(-k12 * w2sq_sd[k] - gl1 * s1[k])
        r2.append(k12 * w1sq_sd[k] - gl2 * s2[k])
        cd_r1.append(convolution(cd, r1, k))
        cd_r2.append(convolution(cd, r2, k))
        num1.append(a22 * r1[k] - k12 * cd_r2[k])
        num2.append(a11 * r2[k] - k12 * cd_r1[k])
        det.append(kdet * (m2 * sdsq[k] + (m1 if k == 0 else 0)))
        quotient_step(num1, det, alpha1, k)
        quotient_step(num2, det, alpha2, k)
        th1.append(w1[k] / (k + 1))
        th2.append(w2[k] / (k + 1))
        w1.append(alpha1[k] / (k + 1))
        w2.append(alpha2[k] / (k + 1))
    return [th1, th2, w1, w2]


# -- the integrator ----------------------------------------------------------------------

def default_order(tol) -> int:
    """Jorba & Zou's order for tolerance tol: the cost per unit time is least near -ln(tol)/2."""
    return int(math.ceil(-float(mpmath.log(tol)) / 2)) + 1


def step_size(coefficients, scale, tol):
    """The Jorba-Zou step: the last two terms of the series each about tol * scale."""
    order = len(coefficients[0]) - 1
    h = mpmath.inf
    for k in (order - 1, order):
        size = max(abs(series[k]) for series in coefficients)
        if size > 0:
            h = min(h, (tol * scale / size) ** (mpf(1) / k))
    return h


def horner(series, h):
    value = series[-1]
    for a in reversed(series[:-1]):
        value = value * h + a
    return value


def integrate(y0, params, t_out, digits: int, order: int | None = None, tol=None,
              progress=None) -> dict:
    """Integrate from t = 0 to each time of t_out (increasing, > 0 after a leading 0).

    digits: working precision (mp.dps); tol: the step rule's tolerance (default
    10^-(digits - 3)); order: default_order(tol).  progress(t, steps, seconds) is
    called at each output time.  -> {"states": [[mpf] * 4 per output time], "steps",
    "h_min", "h_max", "order", "tol"}.
    """
    with mp.workdps(digits):
        tol = mpf(10) ** (-(digits - 3)) if tol is None else mpf(tol)
        order = default_order(tol) if order is None else order
        p = mp_params(params)
        y = [mpf(v) for v in y0]
        t = mpf(0)
        states, steps = [], 0
        h_min, h_max = mpmath.inf, mpf(0)
        start = time.perf_counter()
        for t_next in (mpf(v) for v in t_out):
            while t < t_next:
                coefficients = taylor_coefficients(y, p, order)
                h = step_size(coefficients, max(1, max(abs(v) for v in y)), tol)
                landing = h >= t_next - t
                if landing:
                    h = t_next - t
                else:
                    h_min, h_max = min(h_min, h), max(h_max, h)
                y = [horner(series, h) for series in coefficients]
                t = t_next if landing else t + h
                steps += 1
            states.append(list(y))
            if progress is not None:
                progress(float(t), steps, time.perf_counter() - start)
        return {"states": states, "steps": steps, "order": order, "tol": tol,
                "h_min": h_min, "h_max": h_max}


# -- the reference file ------------------------------------------------------------------

def output_times(t_end: float) -> list:
    n = int(round(t_end / OUTPUT_STEP))
    return [k * OUTPUT_STEP for k in range(n + 1)]


def decimal(x, digits: int = STORED_DIGITS) -> str:
    return mpmath.nstr(x, digits, strip_zeros=False, min_fixed=-mpmath.inf, max_fixed=mpmath.inf) \
        if x != 0 else "0"


def exact_decimal(x: float) -> str:
    """A float's exact binary value in decimal (every float is a finite decimal)."""
    with mp.workdps(80):
        return mpmath.nstr(mpf(x), 80, strip_zeros=True, min_fixed=-mpmath.inf, max_fixed=mpmath.inf)


def printer(label: str):
    def report(t, steps, seconds):
        print(f"{label}: t = {t:5.2f}  steps {steps:6d}  {seconds:7.1f} s", file=sys.stderr, flush=True)
    return report


def make_reference(digits: int, t_end: float, command: str) -> dict:
    times = output_times(t_end)
    start = time.perf_counter()
    stored = integrate(Y0, PARAMETERS, times, digits, progress=printer(f"{digits} digits"))
    stored_seconds = time.perf_counter() - start
    check_digits = digits + CHECK_EXTRA_DIGITS
    start = time.perf_counter()
    check = integrate(Y0, PARAMETERS, times, check_digits, progress=printer(f"{check_digits} digits"))
    check_seconds = time.perf_counter() - start

    with mp.workdps(check_digits):
        p = mp_params()
        e0 = energy([mpf(v) for v in Y0], p)
        self_difference = [max(abs(a - b) for a, b in zip(sa, sb))
                           for sa, sb in zip(stored["states"], check["states"])]
        energy_error = [abs(energy(s, p) - e0) / abs(e0) for s in stored["states"]]

    def run_record(run, run_digits, seconds):
        return {"digits": run_digits, "order": run["order"], "tolerance": mpmath.nstr(run["tol"], 3),
                "steps": run["steps"], "h_min": mpmath.nstr(run["h_min"], 6),
                "h_max": mpmath.nstr(run["h_max"], 6), "seconds": round(seconds, 1)}

    return {
        "description": "Planar double pendulum (derive's catalogue model `planar`), chaotic "
                       "initial condition; high-precision reference made by "
                       "tests/oracles/make_chaotic_reference.py (independent of derive).",
        "model": "planar",
        "state_names": list(STATE_NAMES),
        "angle_convention": "angles from the downward vertical; bob i at "
                            "sum_{j<=i} l_j (sin theta_j, -cos theta_j)",
        "parameter_names": list(PARAMETER_NAMES),
        "parameters": dict(PARAMETERS),
        "parameters_exact": {n: exact_decimal(v) for n, v in PARAMETERS.items()},
        "y0": list(Y0),
        "equations": "Lagrange's equations of L = T - V for two point masses on massless "
                     "rods, M(q) alpha = r solved by Cramer's rule (see the script's docstring)",
        "method": "Taylor series, coefficients by automatic-differentiation recurrences in "
                  "mpmath mpf (sin/cos pair, products, quotient)",
        "step_rule": "h = min_{k in {N-1, N}} (tol * max(1, |y|_inf) / |y_[k]|_inf)^(1/k) "
                     "(Jorba & Zou 2005), shortened to land on each output time; "
                     "order N = ceil(-ln(tol)/2) + 1, tol = 10^-(digits-3)",
        "digits": digits,
        "order": stored["order"],
        "tolerance": mpmath.nstr(stored["tol"], 3),
        "stored_significant_digits": STORED_DIGITS,
        "stored_run": run_record(stored, digits, stored_seconds),
        "check_run": run_record(check, check_digits, check_seconds),
        "mpmath_version": mpmath.__version__,
        "mpmath_backend": mpmath.libmp.BACKEND,
        "python_version": platform.python_version(),
        "command": command,
        "energy_t0": decimal(e0),
        "times": times,
        "states": [[decimal(v) for v in s] for s in stored["states"]],
        "self_difference": [mpmath.nstr(d, 3) for d in self_difference],
        "self_difference_note": f"max over the state of |stored run - check run| at each time; "
                                f"the check run has {CHECK_EXTRA_DIGITS} more digits, a tighter "
                                f"tolerance and a higher order",
        "relative_energy_error": [mpmath.nstr(e, 3) for e in energy_error],
        "relative_energy_error_note": f"|E(t) - E(0)| / |E(0)| of the stored run's states at its "
                                      f"working precision; the stored {STORED_DIGITS}-digit strings "
                                      f"add their rounding (about 1e-39)",
    }


def to_json(reference: dict) -> str:
    """One key a line, each state one line (readable diffs when the reference is remade)."""
    lines = []
    for key, value in reference.items():
        if key == "states":
            rows = ",\n  ".join(json.dumps(state) for state in value)
            lines.append(f' "{key}": [\n  {rows}\n ]')
        else:
            lines.append(f" {json.dumps(key)}: {json.dumps(value)}")
    return "{\n" + ",\n".join(lines) + "\n}\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--digits", type=int, default=60,
                        help="working precision of the stored run (mp.dps; default 60)")
    parser.add_argument("--t-end", type=float, default=20.0, help="last output time (default 20)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="the JSON file to write")
    args = parser.parse_args(argv)
    if args.digits < STORED_DIGITS:
        parser.error(f"--digits must be at least {STORED_DIGITS} (the stored significant digits)")
    if not (args.t_end > 0 and (args.t_end / OUTPUT_STEP).is_integer()):
        parser.error(f"--t-end must be a positive multiple of {OUTPUT_STEP} (the output step)")
    command = "python3 tests/oracles/make_chaotic_reference.py " + " ".join(
        sys.argv[1:] if argv is None else argv)
    start = time.perf_counter()
    reference = make_reference(args.digits, args.t_end, command.strip())
    reference["runtime_seconds"] = round(time.perf_counter() - start, 1)
    args.out.write_text(to_json(reference))
    print(f"wrote {args.out} ({reference['runtime_seconds']} s; self-difference at "
          f"t = {reference['times'][-1]:g}: {reference['self_difference'][-1]})", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
