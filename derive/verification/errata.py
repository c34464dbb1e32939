"""The seeds' errata: printed formulas that differ from the derivation.

Each :class:`Erratum` names a claim of :mod:`seed_formulas` by its key (seed,
equation, description) and pins
  * ``discrepancy(c)``: printed - derived, written out exactly (an expression
    or matrix; a :class:`ShapeMismatch` for a dimension mismatch; a
    :class:`QuadrantError` -- the exact factor whose sign flips the quadrant --
    for an atan2 form),
  * ``corrected(c)``: the corrected formula, which must equal the derivation,
  * ``origin``: whether the defect may be a PDF-extraction artefact (a lost
    dot or prime, a garbled subscript or grouping) or is a real error.
The runner (:func:`claims.judge`) accepts a differing formula only when its
discrepancy is exactly the pinned one and the correction holds, so a
transcription mistake cannot pass as an erratum and an erratum cannot vanish
unnoticed.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import Any, Callable

import sympy as sp
from sympy import Matrix, cos, sin, atan2

from . import seed_formulas as sf
from .claims import SEED0, AtanForm, Context, QuadrantError, ShapeMismatch

REAL = "real error"
ARTEFACT = "possibly a PDF-extraction artefact"
MIXED = "real error, part possibly a PDF-extraction artefact"


@dataclass(frozen=True)
class Erratum:
    equation: str
    what: str                     # the claim's description, as in seed_formulas
    summary: str                  # what is wrong and the correction, one line
    discrepancy: Callable[[Context], Any]
    corrected: Callable[[Context], Any]
    origin: str
    seed: str = SEED0

    @property
    def key(self) -> tuple[str, str, str]:
        return (self.seed, self.equation, self.what)


def _planar_lagrange_lhs(c, i):
    """d/dt dL/dtheta_i' - dL/dtheta_i of the planar pendulum, written out (for pins)."""
    d12 = c.theta1 - c.theta2
    if i == 1:
        return ((c.m1 + c.m2) * c.l1**2 * c.theta1_ddot
                + c.m2 * c.l1 * c.l2 * (c.theta2_ddot * cos(d12) + c.theta2_dot**2 * sin(d12))
                + (c.m1 + c.m2) * c.g * c.l1 * sin(c.theta1))
    return (c.m2 * c.l2**2 * c.theta2_ddot
            + c.m2 * c.l1 * c.l2 * (c.theta1_ddot * cos(d12) - c.theta1_dot**2 * sin(d12))
            + c.m2 * c.g * c.l2 * sin(c.theta2))


def _reduced_x(c, phi_rates):
    """(th1'', ph1 sin th1, th2'', ph2 sin th2) with the given phi entries (3.27)."""
    return Matrix([c.theta1_ddot, phi_rates[0] * sin(c.theta1),
                   c.theta2_ddot, phi_rates[1] * sin(c.theta2)])


def _quadrant(equation, what, target_angle, rho, fix, summary):
    """An atan2 form right up to the sign of rho; ``fix`` is the corrected form."""
    target = _target(target_angle)
    return Erratum(equation, what, summary,
                   discrepancy=lambda c: QuadrantError(getattr(c.other(target), target_angle),
                                                       rho(c)),
                   corrected=lambda c: AtanForm(target, fix(c, c.other(target))),
                   origin=REAL)


def _target(angle_name):
    return sf.ALT if angle_name.startswith("var") else sf.STD


def _vp(c):
    """The target varphi (second chart) of a standard-chart source context."""
    return c.other(sf.ALT).varphi1


def _ph(c):
    return c.other(sf.STD).phi1


ERRATA: list[Erratum] = [
    # -- section 1 -------------------------------------------------------------
    Erratum("1.14", "dL/dq_1 = (0, (m1 + m2) g)",
            "sign of the gravity term: printed +(m1+m2) g, derived -(m1+m2) g "
            "(L contains -(m1+m2) g q_1 by (1.13)); corrected dL/dq_1 = (0, -(m1+m2) g)",
            lambda c: Matrix([0, 2 * (c.m1 + c.m2) * c.g]),
            lambda c: Matrix([0, -(c.m1 + c.m2) * c.g]), REAL),
    Erratum("1.15", "dL/dq_2 = (0, m2 g)",
            "sign of the gravity term: printed +m2 g, derived -m2 g; corrected (0, -m2 g)",
            lambda c: Matrix([0, 2 * c.m2 * c.g]),
            lambda c: Matrix([0, -c.m2 * c.g]), REAL),
    Erratum("1.20", "dL/dq_1 . dq_1/dtheta_1 = (m1 + m2) g l1 sin theta1",
            "sign carried over from (1.14): printed +(m1+m2) g l1 sin θ1, derived "
            "-(m1+m2) g l1 sin θ1",
            lambda c: 2 * (c.m1 + c.m2) * c.g * c.l1 * sin(c.theta1),
            lambda c: -(c.m1 + c.m2) * c.g * c.l1 * sin(c.theta1), REAL),
    Erratum("1.24", "dL/dq_2 . dq_2/dtheta_2 = m2 g l2 sin theta2",
            "sign carried over from (1.15): printed +m2 g l2 sin θ2, derived -m2 g l2 sin θ2",
            lambda c: 2 * c.m2 * c.g * c.l2 * sin(c.theta2),
            lambda c: -c.m2 * c.g * c.l2 * sin(c.theta2), REAL),
    Erratum("1.27", "first form vs the quantity as labelled, d/dt dq_2'/dtheta_2",
            "label: printed dL/dq̇2 · d/dt(∂q̇2/∂θ2), but the value (and its use in (1.33)) is "
            "dL/dq̇2 · d/dt(∂q̇2/∂θ̇2), as in (1.23); corrected label ∂θ̇2 (a lost dot)",
            lambda c: c.m2 * c.l1 * c.l2 * (
                c.theta1_dot * c.theta2_dot * sin(c.theta1 - c.theta2)
                - c.theta1_dot * c.theta2_ddot * sin(c.theta1 - c.theta2)
                + c.theta1_dot * c.theta2_dot**2 * cos(c.theta1 - c.theta2))
            + c.m2 * c.l2**2 * c.theta2_dot**3,
            # the labelled quantity's value: m2 (th1' J q1 + th2' J q2) . (-th2'' q2 - th2'^2 J q2)
            lambda c: (c.m2 * c.theta1_dot * c.theta2_ddot * sf.q1_J_q2(c)
                       - c.m2 * c.theta1_dot * c.theta2_dot**2 * sf.q1_q2(c)
                       - c.m2 * c.theta2_dot**3 * c.l2**2), ARTEFACT),
    Erratum("1.29", "q . J q' = (J q) . J^2 q (middle form)",
            "missing prime: printed (Jq)·J²q (which is 0), meant (Jq)·J²q' = q·Jq'",
            lambda c: sf.VEC_Q[0] * sf.VEC_QP[1] - sf.VEC_Q[1] * sf.VEC_QP[0],
            lambda c: sf.dot(sf.J * sf.VEC_Q, sf.J**2 * sf.VEC_QP), ARTEFACT),
    Erratum("1.30", "q_1 . q_2 = l1 l2 (sin theta1 sin theta1 + cos theta1 cos theta2)",
            "subscript: printed sin θ1 sin θ1, derived sin θ1 sin θ2 (the final form "
            "l1 l2 cos Δθ is right)",
            lambda c: c.l1 * c.l2 * sin(c.theta1) * (sin(c.theta1) - sin(c.theta2)),
            lambda c: c.l1 * c.l2 * (sin(c.theta1) * sin(c.theta2)
                                     + cos(c.theta1) * cos(c.theta2)), ARTEFACT),
    Erratum("1.32", "d/dt dL/dtheta1' - dL/dtheta1, result",
            "sign of the gravity term (from (1.20)): printed -(m1+m2) g l1 sin θ1, derived "
            "+(m1+m2) g l1 sin θ1; (1.34) has the right sign again",
            lambda c: -2 * (c.m1 + c.m2) * c.g * c.l1 * sin(c.theta1),
            lambda c: ((c.m1 + c.m2) * c.theta1_ddot * c.l1**2
                       + c.m2 * c.theta2_ddot * sf.q1_q2(c)
                       + c.m2 * c.theta2_dot**2 * sf.q1_J_q2(c)
                       + (c.m1 + c.m2) * c.g * c.l1 * sin(c.theta1)), REAL),
    Erratum("1.33", "left side as printed (theta1) vs what the right side expands",
            "label: the left side reads d/dt ∂L/∂θ̇1 - ∂L/∂θ1 but the equation is the one "
            "for θ2; corrected d/dt ∂L/∂θ̇2 - ∂L/∂θ2",
            lambda c: _planar_lagrange_lhs(c, 1) - _planar_lagrange_lhs(c, 2),
            lambda c: c.lagrange_lhs(c.theta2), REAL),
    Erratum("1.33", "d/dt dL/dtheta2' - dL/dtheta2, result",
            "printed m2 θ̇2² l2² where m2 θ̈2 l2² (a dot lost?) and gravity sign: printed "
            "-m2 g l2 sin θ2, derived +m2 g l2 sin θ2",
            lambda c: (c.m2 * c.l2**2 * (c.theta2_dot**2 - c.theta2_ddot)
                       - 2 * c.m2 * c.g * c.l2 * sin(c.theta2)),
            lambda c: (c.m2 * c.theta1_ddot * sf.q1_q2(c) + c.m2 * c.theta2_ddot * c.l2**2
                       - c.m2 * c.theta1_dot**2 * sf.q1_J_q2(c)
                       + c.m2 * c.g * c.l2 * sin(c.theta2)), MIXED),
    # -- section 2 -------------------------------------------------------------
    Erratum("2.14", "(0, 0, -mu g) as labelled, dL/dq_1'",
            "label: printed ∂L/∂q̇1, but (0, 0, -μg) is ∂L/∂q1 (∂L/∂q̇1 = μq̇1 + q̇2 is (2.16)); "
            "corrected label ∂L/∂q1 (a spurious dot)",
            lambda c: Matrix([0, 0, -c.mu * c.g]) - c.mu * c.cart_dot(1) - c.cart_dot(2),
            lambda c: c.mu * c.cart_dot(1) + c.cart_dot(2), ARTEFACT),
    Erratum("2.15", "(0, 0, -g) as labelled, dL/dq_2'",
            "label: printed ∂L/∂q̇2, but (0, 0, -g) is ∂L/∂q2; corrected label ∂L/∂q2",
            lambda c: Matrix([0, 0, -c.g]) - c.cart_dot(1) - c.cart_dot(2),
            lambda c: c.cart_dot(1) + c.cart_dot(2), ARTEFACT),
    # -- section 3 -------------------------------------------------------------
    Erratum("3.17", "rate vector (th1'^2, 2 th1' ph1', ph1'^2, 2 th2' ph2')",
            "dimension mismatch: the rate vector has 4 entries but B has 6 columns; "
            "θ̇2² and ϕ̇2² are missing: (θ̇1², 2θ̇1ϕ̇1, ϕ̇1², θ̇2², 2θ̇2ϕ̇2, ϕ̇2²)",
            lambda c: ShapeMismatch((4, 1), (6, 1), ((3, c.theta2_dot**2), (5, c.phi2_dot**2))),
            sf.w_std, REAL),
    Erratum("3.27", "reduced equation A~ x + B~ w + G = 0 (x with phi_i' sin theta_i)",
            "the unknown vector has ϕ̇_i sin θ_i where ϕ̈_i sin θ_i (a lost dot)",
            lambda c: c.A_red_lagrange * Matrix([0, (c.phi1_dot - c.phi1_ddot) * sin(c.theta1),
                                                 0, (c.phi2_dot - c.phi2_ddot) * sin(c.theta2)]),
            lambda c: (sf.A_red_328(c) * _reduced_x(c, (c.phi1_ddot, c.phi2_ddot))
                       + sf.B_red_330(c) * sf.w_std(c) + sf.G_317(c)), ARTEFACT),
    Erratum("3.40", "x = -D^ A^ w + (mu g l1 sin th1, 0, g l2 sin th2, 0)",
            "omits B~: -D^A^ (4x4) is applied to the 6-entry rate vector, and gravity is added "
            "outside the inverse with the wrong sign; corrected x = -D^A^ (B~ w + G~)",
            lambda c: ShapeMismatch(((4, 4), (6, 1)), (4, 1)),
            lambda c: -sf.D_hat_338(c) * sf.A_hat_336(c)
            * (sf.B_red_330(c) * sf.w_std(c) + sf.G_317(c)), REAL),
    Erratum("3.40", "at rest (w = 0): x = (mu g l1 sin th1, 0, g l2 sin th2, 0)",
            "gravity term: printed +G~ added after the inverse, derived -D^A^ G~ "
            "(= -A~^-1 G~); corrected x = -D^A^ G~ at rest",
            lambda c: (sp.eye(4) + c.d.paper.block_inverse()) * Matrix(
                [c.mu * c.g * c.l1 * sin(c.theta1), 0, c.g * c.l2 * sin(c.theta2), 0]),
            lambda c: -sf.D_hat_338(c) * sf.A_hat_336(c) * sf.G_317(c), REAL),
    # -- section 4 -------------------------------------------------------------
    Erratum("4.6", "standard chart (sin th sin ph, sin th cos ph, cos th) orients the sphere "
            "like the (4.1) chart",
            "the first alternative orients the sphere like (2.1), i.e. it does not respect "
            "orientations: (∂θv × ∂ϕv)·v = -sin θ; e.g. (sin θ sin ϕ, -sin θ cos ϕ, cos θ) does",
            lambda c: -2 * sin(c.vartheta1),
            lambda c: sf.orientation(Matrix([sin(c.vartheta1) * sin(c.varphi1),
                                             -sin(c.vartheta1) * cos(c.varphi1),
                                             cos(c.vartheta1)]), c.vartheta1, c.varphi1), REAL),
    # -- section 5 -------------------------------------------------------------
    Erratum("5.1", "(theta', phi') = (pi/2 - theta, phi) for q' = (q, p, r)",
            "garbled '(θ′, ϕ′ = π/2 − θ, ϕ)': swapping x and y maps (θ, ϕ) to (θ, π/2 − ϕ), "
            "not (π/2 − θ, ϕ)",
            lambda c: Matrix([cos(c.theta1) * cos(c.phi1) - sin(c.theta1) * sin(c.phi1),
                              cos(c.theta1) * sin(c.phi1) - sin(c.theta1) * cos(c.phi1),
                              cos(c.theta1) - sin(c.theta1)]),
            lambda c: sf.std_unit_at(c, c.theta1, sp.pi / 2 - c.phi1), ARTEFACT),
    _quadrant("5.3", "vartheta = atan2(r, p sin varphi)", "vartheta1",
              lambda c: c.l1 * sin(_vp(c)),
              lambda c, t: {t.vartheta1: atan2(sf.pqr(c)[2] / sin(t.varphi1), sf.pqr(c)[0])},
              "wrong quadrant when sin φ < 0 (both arguments carry the factor sin φ): "
              "corrected ϑ = atan2(r / sin φ, p)"),
    _quadrant("5.3", "vartheta = atan2(-cos th, sin th cos ph sin varphi)", "vartheta1",
              lambda c: sin(_vp(c)),
              lambda c, t: {t.vartheta1: atan2(-cos(c.theta1) / sin(t.varphi1),
                                               sin(c.theta1) * cos(c.phi1))},
              "wrong quadrant when sin φ < 0: corrected ϑ = atan2(-cos θ / sin φ, sin θ cos ϕ)"),
    _quadrant("5.3", "vartheta = atan2(q, p cos varphi)", "vartheta1",
              lambda c: c.l1 * cos(_vp(c)),
              lambda c, t: {t.vartheta1: atan2(sf.pqr(c)[1] / cos(t.varphi1), sf.pqr(c)[0])},
              "wrong quadrant when cos φ < 0: corrected ϑ = atan2(q / cos φ, p)"),
    _quadrant("5.3", "vartheta = atan2(sin th sin ph, sin th cos ph cos varphi)", "vartheta1",
              lambda c: cos(_vp(c)),
              lambda c, t: {t.vartheta1: atan2(sin(c.theta1) * sin(c.phi1) / cos(t.varphi1),
                                               sin(c.theta1) * cos(c.phi1))},
              "wrong quadrant when cos φ < 0: corrected ϑ = atan2(sin θ sin ϕ / cos φ, "
              "sin θ cos ϕ)"),
    _quadrant("5.5", "theta = atan2(p, -r cos phi)", "theta1",
              lambda c: c.l1 * cos(_ph(c)),
              lambda c, t: {t.theta1: atan2(sf.pqr(c)[0] / cos(t.phi1), -sf.pqr(c)[2])},
              "wrong quadrant when cos ϕ < 0: corrected θ = atan2(p / cos ϕ, -r)"),
    _quadrant("5.5", "theta = atan2(cos vt, -sin vt sin vp cos phi)", "theta1",
              lambda c: cos(_ph(c)),
              lambda c, t: {t.theta1: atan2(cos(c.vartheta1) / cos(t.phi1),
                                            -sin(c.vartheta1) * sin(c.varphi1))},
              "wrong quadrant when cos ϕ < 0: corrected θ = atan2(cos ϑ / cos ϕ, -sin ϑ sin φ)"),
    _quadrant("5.5", "theta = atan2(q, -r sin phi)", "theta1",
              lambda c: c.l1 * sin(_ph(c)),
              lambda c, t: {t.theta1: atan2(sf.pqr(c)[1] / sin(t.phi1), -sf.pqr(c)[2])},
              "wrong quadrant when sin ϕ < 0: corrected θ = atan2(q / sin ϕ, -r)"),
    _quadrant("5.5", "theta = atan2(sin vt cos vp, -sin vt sin vp sin phi)", "theta1",
              lambda c: sin(_ph(c)),
              lambda c, t: {t.theta1: atan2(sin(c.vartheta1) * cos(c.varphi1) / sin(t.phi1),
                                            -sin(c.vartheta1) * sin(c.varphi1))},
              "wrong quadrant when sin ϕ < 0: corrected θ = atan2(sin ϑ cos φ / sin ϕ, "
              "-sin ϑ sin φ)"),
    Erratum("5.12", "phi' = 1/l^2 q' . dq/dphi (first equality)",
            "missing factor: printed ϕ̇ = q̇·∂q/∂ϕ / l², which is ϕ̇ sin²θ by (5.8); corrected "
            "ϕ̇ = q̇·∂q/∂ϕ / (l² sin²θ) (as in the second equality)",
            lambda c: -c.phi1_dot * cos(c.theta1)**2,
            lambda c: sf.dot(c.qdot(1), c.dq(1, c.phi1)) / (c.l1**2 * sin(c.theta1)**2), REAL),
    Erratum("5.14", "varphi' = 1/l^2 q' . dq/dvarphi (first equality)",
            "missing factor: printed φ̇ = q̇·∂q/∂φ / l², which is φ̇ sin²ϑ by (5.10); corrected "
            "φ̇ = q̇·∂q/∂φ / (l² sin²ϑ)",
            lambda c: -c.varphi1_dot * cos(c.vartheta1)**2,
            lambda c: sf.dot(c.qdot(1), c.dq(1, c.varphi1)) / (c.l1**2 * sin(c.vartheta1)**2),
            REAL),
]


@cache
def errata_by_key() -> dict:
    table = {}
    for e in ERRATA:
        if e.key in table:
            raise ValueError(f"erratum recorded twice: {e.key}")
        table[e.key] = e
    return table


def errata_markdown() -> str:
    """The errata as a Markdown table (equation, what, summary, origin) for docs/errata.md."""
    lines = ["| Seed | Eq. | What | Erratum | Origin |", "|---|---|---|---|---|"]
    for e in ERRATA:
        seed = e.seed.split("_")[0]
        cells = [seed, f"({e.equation})", e.what, e.summary, e.origin]
        lines.append("| " + " | ".join(x.replace("|", "\\|") for x in cells) + " |")
    return "\n".join(lines) + "\n"
