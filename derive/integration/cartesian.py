"""Cartesian states of the double spherical pendulum and the three charts.

Each spherical chart is the standard spherical chart about its own axis: with an
orthonormal frame (a, b, c) of the chart, a link's unit vector is
    u = sin(th) cos(ph) a + sin(th) sin(ph) b + cos(th) c,
so th = atan2(sqrt((u.a)^2 + (u.b)^2), u.c), ph = atan2(u.b, u.a) (the robust
forms of seed 000 (5.2)-(5.5)), and the rates follow (5.7)-(5.14):
    th' = u'.du/dth,   ph' = u'.du/dph / sin^2(th).
standard: c = -z (u = (sin th cos ph, sin th sin ph, -cos th)), a = x, b = y;
second:   c = x, a = y, b = z;     rotated: c = y, a = x, b = z   (derive/model/catalog/charts.toml).
The chart rule of seed 000 section 5.1 is here too (`choose_chart`).
"""
from __future__ import annotations

import numpy as np

CHARTS = ("spherical_std", "spherical_alt", "spherical_rot")
_E = np.eye(3)
FRAMES = {   # (a, b, c)
    "spherical_std": (_E[0], _E[1], -_E[2]),
    "spherical_alt": (_E[1], _E[2], _E[0]),
    "spherical_rot": (_E[0], _E[2], _E[1]),
}


def unit_to_chart(chart: str, u: np.ndarray, ud: np.ndarray) -> tuple[float, float, float, float]:
    """(th, ph, th', ph') of a unit vector u and its rate ud in the chart."""
    a, b, c = FRAMES[chart]
    ua, ub, uc = u @ a, u @ b, u @ c
    rho = np.hypot(ua, ub)
    th = np.arctan2(rho, uc)
    ph = np.arctan2(ub, ua)
    dth = np.cos(th) * np.cos(ph) * a + np.cos(th) * np.sin(ph) * b - np.sin(th) * c
    dph = -np.sin(ph) * a + np.cos(ph) * b              # du/dph / sin(th)
    thd = ud @ dth
    phd = (ud @ dph) / rho if rho > 0 else 0.0           # rho = sin(th) >= 0
    return float(th), float(ph), float(thd), float(phd)


def chart_to_unit(chart: str, th, ph, thd, phd) -> tuple[np.ndarray, np.ndarray]:
    a, b, c = FRAMES[chart]
    st, ct, sp_, cp = np.sin(th), np.cos(th), np.sin(ph), np.cos(ph)
    u = st * cp * a + st * sp_ * b + ct * c
    ud = thd * (ct * cp * a + ct * sp_ * b - st * c) + phd * st * (-sp_ * a + cp * b)
    return u, ud


def state_to_cartesian(chart: str, y, l1: float, l2: float) -> np.ndarray:
    """12 numbers (x1, x2, v1, v2) of a chart state (th1, ph1, th2, ph2, rates)."""
    y = np.asarray(y, float)
    u1, u1d = chart_to_unit(chart, y[0], y[1], y[4], y[5])
    u2, u2d = chart_to_unit(chart, y[2], y[3], y[6], y[7])
    x1, v1 = l1 * u1, l1 * u1d
    return np.concatenate([x1, x1 + l2 * u2, v1, v1 + l2 * u2d])


def cartesian_to_state(chart: str, c12, l1: float, l2: float) -> np.ndarray:
    c12 = np.asarray(c12, float)
    x1, x2, v1, v2 = c12[0:3], c12[3:6], c12[6:9], c12[9:12]
    u1, u1d = x1 / l1, v1 / l1
    u2, u2d = (x2 - x1) / l2, (v2 - v1) / l2
    a = unit_to_chart(chart, u1, u1d)
    b = unit_to_chart(chart, u2, u2d)
    return np.array([a[0], a[1], b[0], b[1], a[2], a[3], b[2], b[3]])


def std_sines(c12, l1: float, l2: float) -> tuple[list[float], list[float]]:
    """|sin theta_i| and |sin phi_i| of the standard chart, from a Cartesian state."""
    c12 = np.asarray(c12, float)
    units = [c12[0:3] / l1, (c12[3:6] - c12[0:3]) / l2]
    st = [float(np.hypot(u[0], u[1])) for u in units]
    sp_ = [float(abs(u[1]) / np.hypot(u[0], u[1])) if np.hypot(u[0], u[1]) > 0 else 0.0 for u in units]
    return st, sp_


def choose_chart(c12, l1: float, l2: float, small: float = 0.5) -> str:
    """Seed 000 section 5.1: the standard chart when both |sin theta_i| >= small; else
    the rotated chart when a link with |sin theta_i| >= small has |sin phi_i| < small;
    else the second chart.  Every polar sine of the chosen chart is then >= 0.5."""
    st, sp_ = std_sines(c12, l1, l2)
    if all(s >= small for s in st):
        return "spherical_std"
    if any(st[i] >= small and sp_[i] < small for i in range(2)):
        return "spherical_rot"
    return "spherical_alt"


def polar_sines(chart: str, c12, l1: float, l2: float) -> list[float]:
    """sin of each link's polar angle in the chart (the distance from its singular axis)."""
    c12 = np.asarray(c12, float)
    c = FRAMES[chart][2]
    units = [c12[0:3] / l1, (c12[3:6] - c12[0:3]) / l2]
    return [float(np.sqrt(max(0.0, 1 - (u @ c) ** 2))) for u in units]
