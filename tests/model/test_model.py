"""Model descriptions: the catalogue loads, and bad descriptions are named errors."""
import re

import pytest

from derive.model import ModelError, load_model, model_names
from derive.model.description import parse_model

GOOD = """
name = "toy"
dimension = 2
parameters = ["m1", "l1", "g"]
[[links]]
chart = "planar"
length = "l1"
body = { kind = "point", mass = "m1" }
"""


def test_catalogue_has_the_seed_models():
    assert set(model_names()) >= {"planar", "compound", "spherical_std", "spherical_alt", "spherical_rot"}


@pytest.mark.parametrize("name,states,params", [
    ("planar", ["theta1", "theta2", "theta1_dot", "theta2_dot"], ["m1", "m2", "l1", "l2", "g"]),
    ("compound", ["theta1", "theta2", "theta1_dot", "theta2_dot"], ["m1", "m2", "l1", "l2", "L1", "L2", "g"]),
    ("spherical_std", ["theta1", "phi1", "theta2", "phi2", "theta1_dot", "phi1_dot", "theta2_dot", "phi2_dot"],
     ["m1", "m2", "l1", "l2", "g"]),
    ("spherical_alt", ["vartheta1", "varphi1", "vartheta2", "varphi2", "vartheta1_dot", "varphi1_dot",
                       "vartheta2_dot", "varphi2_dot"], ["m1", "m2", "l1", "l2", "g"]),
])
def test_state_and_parameter_order(name, states, params):
    model = load_model(name)
    assert model.state_names == states
    assert list(model.parameters) == params


def test_a_new_model_is_a_description():
    model = parse_model(GOOD, "toy.toml")
    assert model.state_names == ["theta1", "theta1_dot"]


@pytest.mark.parametrize("edit,message", [
    (lambda t: t.replace('chart = "planar"', 'chart = "hyperbolic"'), "unknown chart 'hyperbolic'"),
    (lambda t: t.replace('mass = "m1"', 'mass = "m9"'), "'m9' is not a declared parameter"),
    (lambda t: t.replace('dimension = 2', 'dimension = 3'), "is 2-D in a 3-D model"),
    (lambda t: t + "colour = 1\n", "unknown key 'colour'"),
    (lambda t: t.replace('kind = "point"', 'kind = "blob"'), "body kind must be 'point' or 'rod'"),
    (lambda t: t.replace('"m1", "l1", "g"', '"m1", "l1"'), "must include the gravity 'g'"),
    (lambda t: t.replace("dimension = 2", "dimension = [2"), "not valid TOML"),
])
def test_bad_descriptions_are_named(edit, message):
    with pytest.raises(ModelError, match=message.replace("(", r"\(").replace(")", r"\)")):
        parse_model(edit(GOOD), "toy.toml")


def test_unknown_model():
    with pytest.raises(ModelError, match="unknown model 'nope'"):
        load_model("nope")


def test_the_atlas_is_data():
    """Its members, rule and thresholds come from catalog/atlases.toml; the members' link
    charts say which member is the standard, second and rotated chart of the rule."""
    from derive.codegen import contract
    from derive.derivation.cartesian import rule_models
    from derive.model.atlas import load_atlas
    a = load_atlas("spherical")
    assert contract.ATLAS_CHARTS == a.charts
    assert (contract.SINE_MIN, contract.SINE_SWITCH, contract.SINE_RULE) == (a.sine_min, a.sine_switch, a.sine_rule)
    assert set(rule_models().values()) == set(a.charts) and a.charts[0] == rule_models()["standard"]
    assert "atlases" not in model_names() and "charts" not in model_names()


ROD = GOOD.replace('body = { kind = "point", mass = "m1" }',
                   'body = { kind = "rod", mass = "m1", com = "COM", inertia = "m1*l1**2/12" }').replace(
    '"m1", "l1", "g"', '"m1", "l1", "d", "g"')


@pytest.mark.parametrize("com", ["l1/2", "0.5*l1", "l1**2/3"])
def test_a_com_that_is_a_distance_is_refused(com):
    """`com` is a fraction of the length: one that grows with the link's length is a distance
    written where a fraction is meant (it would pass the [0, 1] check for short links)."""
    with pytest.raises(ModelError, match=r"link 1 body: com = .* grows with the link's length l1: "
                                         r"com is a fraction of the length"):
        parse_model(ROD.replace("COM", com), "toy.toml")


@pytest.mark.parametrize("com", ["1/2", "d/l1", "d", "(l1 - d)/l1"])
def test_a_com_that_is_a_fraction_is_taken(com):
    assert parse_model(ROD.replace("COM", com), "toy.toml").links[0].body.com == com


@pytest.mark.parametrize("edit, message", [
    (lambda t: t.replace('length = "l1"', 'length = "-l1"'), "link 1: length = -l1 is never positive"),
    (lambda t: t.replace('mass = "m1"', 'mass = "m1*(1-2)"'), "link 1: body mass = m1*(1-2) is never positive"),
])
def test_a_quantity_no_parameter_values_make_possible_is_refused_when_read(edit, message):
    """A length or mass that is negative for every positive parameter passed derive, verify
    and generate and was caught only when a run started (a user trial)."""
    with pytest.raises(ModelError, match=re.escape(message)):
        parse_model(edit(GOOD), "toy.toml")


@pytest.mark.parametrize("length", ["l1 - 0.5", "2*l1", "l1*g"])
def test_a_quantity_some_values_make_possible_is_taken(length):
    assert parse_model(GOOD.replace('length = "l1"', f'length = "{length}"'), "toy.toml").links[0].length == length
