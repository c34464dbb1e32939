"""Every transcribed seed formula is either equal to the derivation or a recorded erratum.

The verdicts come from one cached ``run_all()``; the sanity tests at the end
check that the comparison machinery does catch a wrong formula.
"""
import dataclasses

import pytest
import sympy as sp

from derive.verification import zero
from derive.verification.claims import N_POINTS, SEED0, SEED1, TOLERANCE, ChartRule, Claim, compare, context
from derive.verification.judge import all_claims, claims_by_key, judge, run_all
from derive.verification.errata import errata_by_key
from derive.verification.seed_formulas import STD, atan2, planar_rhs, pqr, sqrt

CLAIMS = all_claims()


def claim_id(claim: Claim) -> str:
    return f"{claim.seed[:3]}-({claim.equation})-{claim.what}"


@pytest.fixture(scope="module")
def results():
    return {r.key: r for r in run_all()}


def claim(equation, what_starts):
    found = [c for c in CLAIMS if c.equation == equation and c.what.startswith(what_starts)]
    assert len(found) == 1, (equation, what_starts, found)
    return found[0]


@pytest.mark.parametrize("claim", CLAIMS, ids=claim_id)
def test_claim_is_a_match_or_a_recorded_erratum(claim, results):
    result = results[claim.key]
    assert result.verdict in ("match", "erratum"), result.summary
    assert (result.verdict == "erratum") == (claim.key in errata_by_key())
    assert result.summary and "\n" not in result.summary


def test_every_claim_is_transcribed_once():
    assert len(claims_by_key()) == len(CLAIMS)


def _numbers(prefix, first, last, skip=()):
    return {f"{prefix}.{k}" for k in range(first, last + 1)} - {f"{prefix}.{k}" for k in skip}


def test_required_equations_are_covered():
    covered = {c.equation for c in CLAIMS if c.seed == SEED0}
    required = (_numbers("1", 14, 35) | _numbers("2", 13, 24)
                | _numbers("3", 1, 42, skip=(22, 34))   # (3.22), (3.34) are empty on the page
                | _numbers("4", 1, 8) | _numbers("5", 1, 5) | _numbers("5", 11, 14))
    assert required <= covered, sorted(required - covered)
    seed1 = {c.equation for c in CLAIMS if c.seed == SEED1}
    assert {"T", "U", "(1)", "(2)", "(3)", "H", "A^-1"} <= seed1


def test_every_printed_form_of_the_chart_changes_is_a_claim():
    counts = {eq: sum(c.equation == eq for c in CLAIMS) for eq in ("5.2", "5.3", "5.4", "5.5")}
    assert counts == {"5.2": 2, "5.3": 6, "5.4": 2, "5.5": 6}


def test_numeric_comparison_settings():
    assert N_POINTS >= 20
    assert TOLERANCE <= 1e-30
    assert zero.DIGITS >= 40


def test_results_carry_their_claim(results):
    for c in CLAIMS:
        r = results[c.key]
        assert (r.seed, r.equation, r.what, r.model) == (c.seed, c.equation, c.what, c.model)


# -- the machinery catches wrong formulas -----------------------------------------

def test_an_injected_sign_flip_is_caught():
    good = claim("1.34", "right side")

    def flipped(c):
        rhs = planar_rhs(c)
        rhs[0] = rhs[0] + 2 * c.mu * c.g * c.l1 * sp.sin(c.theta1)   # -mu g ... -> +mu g ...
        return rhs
    bad = dataclasses.replace(good, printed=flipped)
    cmp = compare(bad)
    assert not cmp.holds and cmp.exact is False and cmp.numeric_error > 1e-3
    assert judge(bad).verdict == "FAIL"
    assert judge(good).verdict == "match"


def test_a_sign_flip_inside_a_matrix_is_caught():
    good = claim("3.20", "A_12")
    bad = dataclasses.replace(good, printed=lambda c: good.printed(c).subs(
        sp.sin(c.phi1 - c.phi2), -sp.sin(c.phi1 - c.phi2)))
    assert judge(bad).verdict == "FAIL"


def test_a_wrong_quadrant_is_caught():
    good = claim("5.3", "vartheta = atan2(sqrt(q^2 + r^2), p)")

    def wrong(c):
        form = good.printed(c)
        (x, value), = form.values.items()
        return dataclasses.replace(form, values={x: atan2(value.args[0], -value.args[1])})
    bad = dataclasses.replace(good, printed=wrong)
    assert not compare(bad).holds
    assert judge(bad).verdict == "FAIL"


def test_a_transcription_mistake_cannot_pass_as_the_recorded_erratum():
    recorded = claim("1.14", "dL/dq_1")
    mistyped = dataclasses.replace(recorded, printed=lambda c: sp.Matrix([0, 3 * (c.m1 + c.m2) * c.g]))
    result = judge(mistyped)
    assert result.verdict == "FAIL" and "no longer reproduces" in result.summary


def test_a_broken_chart_rule_is_caught():
    rule = claim("5.1", "chart rule")
    always_standard = dataclasses.replace(rule, printed=lambda c: ChartRule(lambda *s: STD, 0.5))
    assert not compare(always_standard).holds


def test_the_chart_rule_bound_is_attained():
    """With 0.5 thresholds the printed rule keeps every chosen polar sine >= 0.5,
    and the bound is sharp (states on the thresholds come within 1e-6)."""
    cmp = compare(claim("5.1", "chart rule"))
    assert cmp.holds
    smallest = float(cmp.note.split("chart ")[1].split()[0])
    assert 0.5 <= smallest < 0.5 + 1e-6


def test_atan2_forms_are_checked_in_every_quadrant():
    """The correct sqrt form holds at every state; states cover all four
    quadrants of the source azimuth and both halves of the polar angle."""
    from derive.verification.claims import _angle_points
    c = context(STD)
    points = _angle_points(c)
    quadrants = {int((p[c.phi1] + sp.pi.evalf()) // (sp.pi.evalf() / 2)) for p in points}
    halves = {int(p[c.theta1] // (sp.pi.evalf() / 2)) for p in points}
    assert quadrants == {0, 1, 2, 3} and halves == {0, 1} and len(points) >= 20
    form = claim("5.3", "vartheta = atan2(sqrt(q^2 + r^2), p)").printed(c)
    # the printed side is written in the point's components p, q, r
    assert list(form.values.values())[0] == atan2(sqrt(pqr(c)[1]**2 + pqr(c)[2]**2), pqr(c)[0])


def test_the_fast_exact_test_agrees_with_trig_is_zero():
    """circle_is_zero (ring reduction) decides the same as trig_is_zero (half angles)."""
    checked = 0
    for c_ in CLAIMS:
        if c_.kind != "identity" or c_.model != "planar" or c_.point_map:
            continue
        ctx = context(c_.model)
        derived = c_.derived(ctx)
        if not isinstance(derived, (sp.Expr, sp.MatrixBase)):
            continue
        printed = ctx.with_mu(sp.Matrix(c_.printed(ctx)) if isinstance(
            c_.printed(ctx), sp.MatrixBase) else sp.Matrix([c_.printed(ctx)]))
        diff = printed - (derived if isinstance(derived, sp.MatrixBase) else sp.Matrix([derived]))
        angles = zero.trig_angles(diff)
        assert zero.circle_matrix_is_zero(diff, angles) == zero.matrix_is_zero(diff, angles), c_.key
        checked += 1
    assert checked >= 30
    th, ph = sp.symbols("th ph", real=True)
    assert zero.circle_is_zero(sp.sin(th)**2 + sp.cos(th)**2 - 1, [th])
    assert not zero.circle_is_zero(sp.sin(th)**2 - sp.cos(th)**2, [th])
    R = sp.Symbol("R", positive=True)
    f = sp.cos(th)**2 + sp.sin(th)**2 * sp.cos(ph)**2
    assert zero.circle_is_zero((R**3 - R * f) / (1 + R), [th, ph], [(R, f)])
    assert not zero.circle_is_zero(R - f, [th, ph], [(R, f)])


def test_the_tree_walk_gives_lambdify_s_values():
    """zero.mp_values (the claims' numeric side) against zero.mp_function (lambdify) on
    an expression with every kind of node it walks, shared subtrees and a matrix."""
    import random

    from derive.verification import zero

    x, y = sp.symbols("x y", real=True)
    a = sp.Symbol("a", positive=True)
    shared = sp.cos(x - y) * a**2
    m = sp.Matrix([[shared + sp.sin(x)**3 / shared, sp.atan2(y, x) - sp.pi * a**-3],
                   [sp.sqrt(a) * sp.Rational(3, 7) + sp.exp(-x) * sp.Float("0.1", 40),
                    sp.acos(sp.cos(x) / 2) + sp.Abs(y) ** sp.Rational(3, 2)]])
    rng = random.Random(7)
    points = [zero.random_point([x, y, a], rng) for _ in range(6)]
    f = zero.mp_function(m, [x, y, a])
    walked = zero.mp_values(m, points)
    assert len(walked) == len(points) and all(len(v) == 4 for v in walked)
    assert max(zero.relative_error(f(pt), v) for pt, v in zip(points, walked)) < 1e-38
    with pytest.raises(zero.Unsupported):
        zero.mp_values(sp.gamma(x), points)
