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
