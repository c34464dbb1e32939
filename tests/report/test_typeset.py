"""The descriptions of the documents typeset as a reader expects: words and hyphens as text,
derivatives as fractions, the two phis kept apart, names and titles upright."""
import pytest

from derive.report import typeset as ts


@pytest.mark.parametrize("ascii_, latex", [
    ("possibly a PDF-extraction artefact", "possibly a PDF-extraction artefact"),
    ("chain-rule expansion", "chain-rule expansion"),
    ("applied to the 6-entry rate vector", "applied to the $6$-entry rate vector"),
    ("x - y", "$x - y$"),                                       # a spaced minus stays a minus
])
def test_a_hyphen_in_a_word_is_a_hyphen(ascii_, latex):
    assert ts.prose(ascii_) == latex


def test_derivatives_are_fractions_in_a_heading_and_slashed_in_a_sentence():
    heading = ts.prose("d/dt dq_i'/dtheta_i' = J q_i'", display=True)
    assert heading == r"$\dfrac{d}{dt} \dfrac{\partial q_{i}'}{\partial \theta_{i}'} = J q_{i}'$"
    assert ts.prose("d2q_i/dtheta_i dphi_i", display=True) == \
        r"$\dfrac{\partial^{2} q_{i}}{\partial \theta_{i}\,\partial \phi_{i}}$"
    assert ts.prose("power balance dE/dt = q' . Q") == r"power balance $dE/dt = q' \cdot  Q$"
    assert ts.prose("l1 l2 cos(dtheta)") == r"$l_{1} l_{2} \cos(\Delta \theta)$"     # a difference


def test_the_two_phis_stay_apart():
    """phi (U+03D5) is the standard chart's angle, varphi (U+03C6) the second chart's."""
    assert ts.prose("θ = atan2(cos ϑ / cos ϕ, -sin ϑ sin φ)").count(r"\varphi") == 1


def test_model_names_and_titles_are_upright_text():
    assert ts.prose("sph2: M symmetric positive definite", literal=["sph2"]) == \
        r"\texttt{sph2}: $M$ symmetric positive definite"
    assert ts.text("My double pendulum") == "My double pendulum"
    assert ts.text("Four-link chain, 50% damped (theta, varphi)") == \
        r"Four-link chain, 50\% damped ($\theta$, $\varphi$)"


def test_a_long_product_leaves_no_line_of_one_small_factor():
    """A product a little wider than its line (the spherical atlas's claims) is not broken
    to leave its last factor, sin(vartheta1), alone on a line; a much wider one is still
    broken into lines that fit."""
    import sympy as sp
    th, ph, vt, vp, w, l = sp.symbols("theta1 phi1 vartheta1 varphi1 w1 l1")
    term = -w * l * sp.cos(th) ** 2 * sp.sin(ph) ** 4 * sp.sin(vp) * sp.sin(vt)
    lines = ts.expr_lines(term, ts.Names(), budget=36)
    assert len(lines) == 1 and ts.width(lines[0]) <= 1.25 * 36, lines
    wide = ts.expr_lines(term * sp.cos(vp) ** 3 * sp.cos(ph) * sp.sin(th) ** 2, ts.Names(), budget=36)
    assert len(wide) == 2 and all(ts.width(ln) <= 1.25 * 36 for ln in wide), wide
    assert ts.width(wide[-1]) >= ts.ORPHAN * 36, wide
