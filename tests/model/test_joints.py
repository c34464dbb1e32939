"""Joints and bodies as data (issue 23 item 1): how a kinematic tree is read -- link names
and parents, prismatic and revolute joints, offsets, massless links, the state's order, a
potential, springs -- and the one-line refusals of what does not make a model.  (The
equations are checked against sympy.physics.mechanics in
tests/derivation/test_joints_against_mechanics.py.)"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from derive.model import ModelError, load_model
from derive.model.description import parse_model

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "models"

HEAD = 'name = "tree"\ndimension = 2\nparameters = ["m1", "m2", "l1", "l2", "k", "g"]\n'
POINT = '[[links]]\n{keys}\nbody = {{ kind = "point", mass = "{m}" }}\n'


def model(*links: str, head: str = HEAD, extra: str = ""):
    return parse_model(head + extra + "".join(links), "tree.toml")


def hinge(m: str, keys: str = "") -> str:
    return POINT.format(keys=f'chart = "planar"\nlength = "l{m[-1]}"\n{keys}', m=m)


def test_a_chain_file_is_read_as_before_and_takes_the_chain_path():
    planar = load_model("planar")
    assert planar.is_chain
    assert planar.coordinate_names == ["theta1", "theta2"]
    assert [link.parent for link in planar.links] == [-1, 0]


def test_the_examples_are_trees_with_the_states_the_issue_names():
    expected = {"cart_pole": ["x", "theta"], "double_pendulum_cart": ["x", "theta1", "theta2"],
                "elastic_pendulum": ["r", "theta"], "pendulum_tree": ["theta1", "theta2", "theta3"],
                "hinge_ball": ["psi", "vartheta2", "varphi2"], "spinning_body": ["alpha", "beta", "gamma"]}
    for name, coordinates in expected.items():
        m = load_model(EXAMPLES / f"{name}.toml")
        assert not m.is_chain
        assert m.state_names == coordinates + [f"{c}_dot" for c in coordinates]
    cart = load_model(EXAMPLES / "cart_pole.toml")
    assert cart.parameters == ("M", "m", "l", "g") and cart.inputs == ("F",)
    assert (cart.unit_of("x"), cart.unit_of("x_dot"), cart.unit_of("theta")) == ("m", "m/s", "rad")


def test_a_parent_by_name_makes_a_branch():
    m = model(hinge("m1", 'name = "trunk"'), hinge("m2", 'parent = "trunk"'))
    assert [link.parent for link in m.links] == [-1, 0]
    branched = model(hinge("m1", 'name = "trunk"'), hinge("m2", 'parent = "trunk"'),
                     hinge("m2", 'parent = "trunk"\ncoordinate = "phi"'))
    assert [link.parent for link in branched.links] == [-1, 0, 0]
    assert not branched.is_chain and branched.coordinate_names == ["theta1", "theta2", "phi"]


def test_a_slider_names_its_coordinate_and_has_no_length():
    slider = POINT.format(keys='joint = "prismatic"\naxis = [1, 0]\ncoordinate = "x"', m="m1")
    m = model(slider, hinge("m2"))
    assert m.coordinate_names == ["x", "theta2"] and m.links[0].length == "0"
    roles = m.parameter_roles()
    assert roles["l2"] == "length" and "l1" not in roles       # a slider has no length of its own


REFUSED = [
    (hinge("m1", 'parent = "nobody"'), "'parent' = 'nobody' is not 'pivot' or an earlier link's name"),
    (hinge("m1", 'name = "pivot"'), "'name' = 'pivot' is taken"),
    (hinge("m1", 'joint = "ball"'), "unknown joint 'ball'"),
    (POINT.format(keys='joint = "prismatic"\ncoordinate = "x"', m="m1"), "a prismatic joint needs 'axis'"),
    (POINT.format(keys='joint = "prismatic"\naxis = [1, 0]', m="m1"), "a prismatic joint needs 'coordinate'"),
    (POINT.format(keys='joint = "prismatic"\naxis = [0, 0]\ncoordinate = "x"', m="m1"), "axis is the zero vector"),
    (POINT.format(keys='joint = "prismatic"\naxis = [1, 0]\ncoordinate = "x"\nlength = "l1"', m="m1"),
     "a prismatic joint has no 'length'"),
    (POINT.format(keys='joint = "prismatic"\naxis = [1]\ncoordinate = "x"', m="m1"), "'axis' must be a list of 2"),
    (POINT.format(keys='joint = "revolute"\naxis = [0, 1]', m="m1"), "a revolute joint is 3-D"),
    (hinge("m1", 'coordinates = ["a", "b"]'), "the joint has 1 coordinate, 'coordinates' names 2"),
    (hinge("m1", 'coordinate = "g"'), "the parameter 'g' has the name of a state"),
    (hinge("m1", 'offset = ["0"]'), "'offset' must be a list of 2"),
]


@pytest.mark.parametrize("link, message", REFUSED, ids=[m for _, m in REFUSED])
def test_what_is_no_joint_is_refused_in_one_line(link, message):
    with pytest.raises(ModelError) as err:
        model(link)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_coordinates_given_twice_the_states_order_and_the_forms_of_a_tree():
    with pytest.raises(ModelError, match="the coordinate 'theta1' is named by two links"):
        model(hinge("m1"), hinge("m2", 'coordinate = "theta1"'))
    with pytest.raises(ModelError, match="'coordinates' must list the links' coordinates"):
        model(hinge("m1"), extra='coordinates = ["theta1", "theta9"]\n')
    reordered = model(hinge("m1"), hinge("m2"), extra='coordinates = ["theta2", "theta1"]\n')
    assert reordered.coordinate_names == ["theta2", "theta1"] and not reordered.is_chain
    with pytest.raises(ModelError, match="the Hamiltonian and 'paper' forms are a chain's"):
        model(hinge("m1"), hinge("m2"), extra='coordinates = ["theta2", "theta1"]\nforms = ["hamiltonian"]\n')


def test_a_potential_and_springs_are_read_and_checked():
    m = model(hinge("m1", 'name = "a"'), hinge("m2", 'name = "b"'),
              extra='potential = "k*theta1**2/2"\n'
                    '[[springs]]\nbetween = ["pivot", "b.centre"]\nstiffness = "k"\n'
                    '[[springs]]\njoint = "b"\nstiffness = "k"\nrest_angle = "1/2"\n')
    assert m.potential == "k*theta1**2/2" and len(m.springs) == 2
    assert m.springs[0].between == ("pivot", "b.centre") and m.springs[1].joint == 1
    assert m.is_conservative and m.is_chain        # springs and a potential keep a chain a chain
    for extra, message in (('potential = "k*theta1_dot"\n', "potential: the name 'theta1_dot' is not declared"),
                           ('[[springs]]\nbetween = ["pivot", "c"]\nstiffness = "k"\n',
                            "'c' is not 'pivot', a link's name"),
                           ('[[springs]]\njoint = "a"\n', "missing key 'stiffness'"),
                           ('[[springs]]\nstiffness = "k"\n', "give 'between'")):
        with pytest.raises(ModelError) as err:
            model(hinge("m1", 'name = "a"'), extra=extra)
        assert message in str(err.value), str(err.value)


def test_a_spherical_parent_has_no_frame_for_an_offset(tmp_path):
    text = ('name = "ball_offset"\ndimension = 3\nparameters = ["m1", "m2", "l1", "l2", "g"]\n'
            '[[links]]\nname = "ball"\nchart = "second"\nlength = "l1"\nbody = { kind = "point", mass = "m1" }\n'
            '[[links]]\nparent = "ball"\noffset = ["0", "0", "0"]\nchart = "second"\nlength = "l2"\n'
            'body = { kind = "point", mass = "m2" }\n')
    path = tmp_path / "ball_offset.toml"
    path.write_text(text)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    run = subprocess.run([sys.executable, "-m", "derive", "derive", str(path)], env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode != 0
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("derive: error: ")
    assert "is a spherical link, whose direction does not fix a frame" in lines[0]


def test_a_rigid_body_needs_a_revolute_joint_and_a_symmetric_tensor():
    head = 'name = "rigid"\ndimension = 3\nparameters = ["m", "l", "A", "B", "g"]\n'
    tensor = '[["A", "0", "0"], ["0", "A", "0"], ["0", "0", "B"]]'
    body = f'body = {{ kind = "rigid", mass = "m", inertia = {tensor} }}\n'
    spun = model('[[links]]\njoint = "revolute"\naxis = [0, 1, 0]\nlength = "l"\n' + body, head=head)
    assert spun.links[0].body.tensor[2] == ("0", "0", "B") and spun.coordinate_names == ["theta1"]
    refused = [('[[links]]\nchart = "second"\nlength = "l"\n' + body, "a rigid body needs a frame"),
               ('[[links]]\njoint = "revolute"\naxis = [0, 1, 0]\nlength = "l"\n'
                'body = { kind = "rigid", mass = "m", inertia = [["A", "1", "0"], ["0", "A", "0"], ["0", "0", "B"]] }\n',
                "must be symmetric"),
               ('[[links]]\njoint = "revolute"\naxis = [0, 1, 0]\nlength = "l"\n'
                'body = { kind = "rigid", mass = "m", inertia = ["A", "A", "B"] }\n', "a list of three rows")]
    for link, message in refused:
        with pytest.raises(ModelError, match=message):
            model(link, head=head)


def test_loads_at_points_are_read_and_checked():
    m = model(hinge("m1", 'name = "a"'), hinge("m2", 'name = "b"'),
              extra='[[loads]]\npoint = "b"\nforce = ["k*sin(t)", "-k*theta2_dot"]\n'
                    '[[loads]]\npoint = "a.centre"\nforce = [1, 0]\n')
    assert [(load.point, load.force) for load in m.loads] == [
        ("b", ("k*sin(t)", "-k*theta2_dot")), ("a.centre", ("1", "0"))]
    assert not m.is_conservative and m.is_time_dependent and m.is_chain
    for extra, message in (('[[loads]]\npoint = "c"\nforce = ["1", "0"]\n', "'point': 'c' is not 'pivot'"),
                           ('[[loads]]\npoint = "a"\nforce = ["1"]\n', "'force' must be a list of 2"),
                           ('[[loads]]\npoint = "a"\n', "missing key 'force'"),
                           ('[[loads]]\npoint = "a"\nforce = ["1", "0"]\ntorque = "1"\n', "unknown key 'torque'"),
                           ('[[loads]]\npoint = "a"\nforce = ["F", "0"]\n', "load 1 force x: the name 'F'")):
        with pytest.raises(ModelError) as err:
            model(hinge("m1", 'name = "a"'), extra=extra)
        assert message in str(err.value), str(err.value)


def test_degenerate_springs_and_loads_are_refused_in_one_line():
    """A user's trial: these were accepted and did nothing (or nonsense)."""
    for extra, message in (('[[springs]]\nbetween = ["a", "a"]\nstiffness = "k"\n', "names 'a' twice"),
                           ('[[springs]]\nbetween = ["pivot", "a"]\nstiffness = "k"\nrest_length = "-1"\n',
                            "rest_length = '-1' is negative"),
                           ('[[loads]]\npoint = "pivot"\nforce = ["1", "0"]\n', "a load at the fixed pivot does no work")):
        with pytest.raises(ModelError) as err:
            model(hinge("m1", 'name = "a"'), extra=extra)
        assert message in str(err.value) and "\n" not in str(err.value), str(err.value)
