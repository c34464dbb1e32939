"""Independent physics checks (derive.verification.physics), each must pass."""
import pytest
import sympy as sp

from derive.derivation import derive
from derive.verification import physics
from derive.model import model_names


@pytest.mark.parametrize("name", model_names())
def test_mass_matrix_symmetric_positive_definite(name):
    check = physics.mass_matrix_spd(name)
    assert check.passed, check.detail


def test_planar_is_spherical_in_a_vertical_plane():
    check = physics.planar_is_vertical_plane_of_spherical()
    assert check.passed, check.detail


def test_compound_equivalence_is_derived_and_exact():
    check, solution = physics.compound_point_mass_equivalence()
    assert check.passed, check.detail
    c, p = derive("compound"), derive("planar")
    m1, m2, l1, l2, L1, L2, g = c.symbols.params
    # The seed's uniform rods (L = m l^2/12) are *not* point-mass pendulums:
    L1_solution = [v for k, v in solution.items() if k.name == "L1"][0]
    assert sp.simplify(L1_solution - m1 * l1**2 / 12) != 0
    # And with L2 = 0 the equivalent planar pendulum has point masses m1/2, m2 on l1, l2/2.
    at_zero = {k.name: sp.simplify(v.subs(L2, 0)) for k, v in solution.items()}
    assert at_zero["M1"] == m1 / 2 and at_zero["M2"] == m2
    assert at_zero["a"] == l1 and at_zero["b"] == l2 / 2


@pytest.mark.parametrize("source,target", physics.SPHERICAL_PAIRS)
def test_charts_give_same_cartesian_accelerations(source, target):
    check = physics.charts_agree_on_accelerations(source, target)
    assert check.passed, check.detail


@pytest.mark.parametrize("first,second", physics.SPHERICAL_PAIRS)
def test_chart_round_trip(first, second):
    check = physics.chart_round_trip(first, second)
    assert check.passed, check.detail


def test_acceleration_check_catches_a_wrong_model():
    """The comparison is sharp: perturbing one forcing term is detected."""
    d = derive("spherical_alt")
    broken = sp.Matrix(d.F)
    broken[0] = broken[0] * (1 + sp.Rational(1, 10**12))
    original = d.F
    d.F = broken
    physics._system_functions.pop((d.name, d.model.content_hash), None)
    try:
        check = physics.charts_agree_on_accelerations("spherical_std", "spherical_alt", n_points=3)
    finally:
        d.F = original
        physics._system_functions.pop((d.name, d.model.content_hash), None)
    assert not check.passed
