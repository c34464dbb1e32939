"""A user's own models through every stage: model files anywhere, any chain of links,
damping, applied forces and run-time inputs, names the generated code uses itself, and
expressions that are data.  (The equations themselves are checked against independent
sympy.physics.mechanics and Cartesian references in tests/derivation/test_equations_against_mechanics.py.)"""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from tests.codegen.test_generate_and_compile import quad_flags
from tests.in_process import derive_cli

import derive
from derive.runtime.loader import load
from derive.model import ModelError, load_model

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "models"


def cli(*args, cwd):
    """`derive *args` in `cwd`, in this process (tests/in_process.py): these tests check what
    the commands print and write; the process around them is tests/system/test_cli_errors.py's."""
    return derive_cli(*args, cwd=cwd)


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


LINK = '[[links]]\nchart = "planar"\nlength = "{l}"\nbody = {{ kind = "point", mass = "{m}" }}\n'


def chain(name: str, n: int, extra: str = "", params: str | None = None) -> str:
    ps = params or ", ".join([f'"m{i}"' for i in range(1, n + 1)] + [f'"l{i}"' for i in range(1, n + 1)] + ['"g"'])
    return (f'name = "{name}"\ndimension = 2\nparameters = [{ps}]\n{extra}\n'
            + "".join(LINK.format(l=f"l{i}", m=f"m{i}") for i in range(1, n + 1)))


# -- any chain, through the generated code ------------------------------------------------

def test_a_single_damped_link_decays_and_balances_its_power(tmp_path):
    path = write(tmp_path, "one_link", chain("one_link", 1, 'dissipation = "c*theta1_dot**2/2"',
                                             '"m1", "l1", "g", "c"'))
    p = {"m1": 1.0, "l1": 1.0, "g": 9.81, "c": 0.3}
    r = derive.simulate(str(path), [1.0, 0.0], np.linspace(0, 10, 201), p, rtol=1e-11)
    assert r.ok and r.positions.shape == (201, 1, 2)
    # dE/dt = -c theta'^2 <= 0: the energy never rises (beyond rounding) and ends lower
    assert np.all(np.diff(r.energy) < 1e-9) and r.energy[-1] < r.energy[0] - 1.0
    # the small-angle damped oscillator: theta ~ exp(-c t / (2 m l^2)) envelope
    rn = derive.simulate("one_link", [1.0, 0.0], np.linspace(0, 10, 201), p, rtol=1e-11, backend="numpy")
    assert np.max(np.abs(r.y - rn.y)) < 1e-8


@pytest.mark.parametrize("n", [3, 4])
def test_planar_chains_conserve_energy_in_c_and_numpy(tmp_path, n):
    path = write(tmp_path, f"chain{n}", chain(f"chain{n}", n))
    p = [1.0] * n + [0.8] * n + [9.81]
    y0 = [0.4 * (k + 1) for k in range(n)] + [0.0] * n
    r = derive.simulate(str(path), y0, np.linspace(0, 3, 31), p, rtol=1e-12)
    rn = derive.simulate(f"chain{n}", y0, np.linspace(0, 3, 31), p, rtol=1e-12, backend="numpy")
    assert r.ok and rn.ok
    assert np.max(np.abs(r.energy - r.energy[0])) < 1e-9 * abs(r.energy[0])
    assert np.max(np.abs(r.y - rn.y)) < 1e-8
    k = load(f"chain{n}")
    rng = np.random.default_rng(n)
    y = np.concatenate([rng.uniform(-3, 3, (100, n)), rng.uniform(-2, 2, (100, n))], axis=1)
    J = k.jacobian(y[:5], p)
    eps = 1e-6
    Jn = np.stack([(k.rhs(y[:5] + eps * e, p) - k.rhs(y[:5] - eps * e, p)) / (2 * eps)
                   for e in np.eye(2 * n)], axis=-1)
    assert np.max(np.abs(J - Jn)) < 1e-5 * max(1, np.max(np.abs(J)))
    # the solve: q'' = M^-1 F
    ref = np.linalg.solve(k.mass_matrix(y, p), k.forcing(y, p)[..., None])[..., 0]
    assert np.max(np.abs(k.rhs(y, p)[:, n:] - ref) / np.maximum(1, np.abs(ref))) < 1e-12


def test_friction_with_abs_and_sign_goes_through_sympy(tmp_path, monkeypatch):
    """Quadratic air drag, -c q' |q'|, and Coulomb friction, -mu sign(q'): SymEngine's
    converters take neither, so the file's one CSE pass is SymPy's (emit.cse_file's
    fallback); the C rhs is still M^-1 F of the derivation's own M and F, lambdified, and
    the Jacobian the central difference of the rhs away from the friction's jump (sign's
    derivative taken as zero there, symbolic.almost_everywhere: no DiracDelta to print)."""
    import sympy as sp
    from derive.codegen import emit, sources
    from derive.derivation.derivation import derive as derivation
    from derive.derivation.symbolic import engine_cse
    from derive.runtime.simulate import resolve_model
    passes = []

    def keep(roots, symbols):
        passes.append(engine_cse(roots, symbols))
        return passes[-1]

    monkeypatch.setattr(emit, "engine_cse", keep)
    monkeypatch.setenv("DERIVE_CACHE_DIR", str(tmp_path / "cache"))      # rendered here, now
    sources._both_files.cache_clear()
    forces = ('[forces]\ntheta1 = "-c*theta1_dot*abs(theta1_dot) - mu*sign(theta1_dot)"\n'
              'theta3 = "-c*theta3_dot*abs(theta3_dot)"\n')
    path = write(tmp_path, "dragged3", chain("dragged3", 3, forces,
                                             '"m1", "m2", "m3", "l1", "l2", "l3", "g", "c", "mu"'))
    name = resolve_model(str(path))
    k = load(name)
    assert passes and all(found is None for found in passes)
    d = derivation(name)
    s = d.symbols
    args = list(s.q) + list(s.qd), list(s.params)
    M, F = sp.lambdify(args, d.M, "numpy"), sp.lambdify(args, list(d.F), "numpy")
    p = np.array([1.0, 0.7, 1.2, 1.0, 0.8, 0.6, 9.81, 0.3, 0.4])
    rng = np.random.default_rng(3)
    states = np.concatenate([rng.uniform(-3, 3, (20, 3)), rng.uniform(0.3, 2, (20, 3)) * rng.choice([-1, 1], (20, 3))],
                            axis=1)
    for y in states:
        ref = np.linalg.solve(np.array(M(y, p), dtype=float), np.array(F(y, p), dtype=float))
        assert np.allclose(k.rhs(y[None], p)[0, 3:], ref, rtol=1e-12, atol=1e-12)
    eps = 1e-6
    J = k.jacobian(states, p)
    Jn = np.stack([(k.rhs(states + eps * e, p) - k.rhs(states - eps * e, p)) / (2 * eps) for e in np.eye(6)], axis=-1)
    assert np.all(np.isfinite(J)) and np.max(np.abs(J - Jn)) < 1e-5 * max(1, np.max(np.abs(J)))
    sources._both_files.cache_clear()


def test_the_hamiltonian_form_of_a_triple_pendulum(tmp_path):
    """Beyond two coordinates there is no closed-form M^-1: the code solves M q' = p."""
    load_model(EXAMPLES / "triple.toml")
    k = load("triple")
    p = np.array([1.0, 2.0, 0.5, 1.0, 0.7, 1.2, 0.1, 9.81])
    y = np.array([[0.3, -1.0, 2.0, 0.5, -0.2, 1.5]])
    x = k.to_canonical(y, p)
    assert np.allclose(k.from_canonical(x, p), y, rtol=1e-13, atol=1e-13)
    xdot = k.hamiltonian_rhs(x, p)
    ydot = k.rhs(y, p)
    assert np.allclose(xdot[0, :3], ydot[0, :3], rtol=1e-13)           # q' = M^-1 p
    r = derive.simulate("triple", y[0], np.linspace(0, 2, 3), p, method="gauss2", step=2e-3)
    assert r.ok and abs(r.energy[-1] - r.energy[0]) < 1e-9 * abs(r.energy[0])


def test_inputs_are_an_argument_of_their_own(tmp_path):
    load_model(EXAMPLES / "driven.toml")
    k = load("driven")
    assert [n for n, _ in k.rhs.inputs] == ["y", "p", "u"]
    p = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81, "c1": 0.0, "c2": 0.0}
    # a constant torque at the base joint only, from rest hanging: link 1 turns positive
    r = derive.simulate("driven", [0, 0, 0, 0], np.linspace(0, 0.5, 6), p, inputs={"tau1": 2.0, "tau2": 0.0})
    assert r.ok and r.y[-1, 0] > 0.01
    r0 = derive.simulate("driven", [0, 0, 0, 0], np.linspace(0, 0.5, 6), p, inputs=[0.0, 0.0])
    assert np.all(r0.y == 0)
    for bad, message in ((None, "needs its inputs (tau1, tau2)"), ({"tau1": 1.0}, "missing input 'tau2'"),
                         ({"tau1": 1, "tau2": 0, "tau3": 0}, "unknown input 'tau3'"),
                         (lambda t, y: [0], "got 1 from inputs(0, y)"), ([1.0], "takes 2 inputs"),
                         (lambda t, y: 1 / 0, "inputs(0, y) raised ZeroDivisionError"),
                         (lambda t: 0, "inputs(0, y) raised TypeError")):
        with pytest.raises(derive.SimulationInputError, match=re.escape(message)):
            derive.simulate("driven", [0, 0, 0, 0], [0, 1], p, inputs=bad)
    with pytest.raises(derive.SimulationInputError, match="has no inputs"):
        derive.simulate("planar", [0, 0, 0, 0], [0, 1], [1, 1, 1, 1, 9.81], inputs=[1.0])


def test_names_the_generated_code_uses_itself(tmp_path):
    """Parameters called M, p, lambda, F, y, int, double: C and NumPy agree, and the name
    tables keep the model's own names."""
    text = ('name = "natural"\ndimension = 2\nparameters = ["M", "p", "lambda", "F", "y", "int", "double", "g"]\n'
            '[[links]]\nchart = "planar"\nlength = "lambda"\nbody = { kind = "point", mass = "M" }\n'
            '[[links]]\nchart = "planar"\nlength = "int"\n'
            'body = { kind = "rod", mass = "p", com = "1/2", inertia = "double" }\n')
    path = write(tmp_path, "natural", text)
    values = {"M": 1.0, "p": 1.5, "lambda": 1.0, "F": 0.3, "y": 0.2, "int": 0.8, "double": 0.05, "g": 9.81}
    r = derive.simulate(str(path), [1, 0.5, 0, 0], np.linspace(0, 2, 5), values)
    rn = derive.simulate("natural", [1, 0.5, 0, 0], np.linspace(0, 2, 5), values, backend="numpy")
    assert r.ok and np.max(np.abs(r.y - rn.y)) < 1e-8
    assert load("natural").names["param_names"] == ("M", "p", "lambda", "F", "y", "int", "double", "g")


def test_inputs_may_have_the_names_of_the_generated_codes_own_values(tmp_path):
    """A torque called F (and M, F1, and the very names of the one-link rhs's stages and
    temporaries, F0, M00, t0, qdd0): derive, verify, generate and simulate take them."""
    names = ["F", "M", "F1", "F0", "M00", "t0", "qdd0"]
    text = ('name = "torqued"\ndimension = 2\nparameters = ["m1", "l1", "g"]\n'
            f'inputs = [{", ".join(repr(n).replace(chr(39), chr(34)) for n in names)}]\n'
            '[forces]\ntheta1 = "F + M*F1 + F0 + M00 + t0 + qdd0"\n'
            '[[links]]\nchart = "planar"\nlength = "l1"\nbody = { kind = "point", mass = "m1" }\n')
    write(tmp_path, "torqued", text)
    runs = {args[0]: cli(*args, cwd=tmp_path) for args in (
        ("derive", "torqued.toml"), ("verify", "torqued.toml"), ("generate", "torqued.toml", "--out", "gen"))}
    assert all(run.returncode == 0 for run in runs.values()), {k: r.stderr for k, r in runs.items()}
    assert "torqued: power balance" in runs["verify"].stdout
    assert '"F", "M", "F1", "F0", "M00", "t0", "qdd0"' in (tmp_path / "gen" / "c" / "torqued.c").read_text()
    # no gravity, from rest: theta = a t^2 / 2 with a = (F + M F1 + F0 + M00 + t0 + qdd0) / (m l^2)
    u = {"F": 0.5, "M": 2.0, "F1": 0.25, "F0": 0.125, "M00": -0.375, "t0": 0.0625, "qdd0": 0.1875}
    a = (u["F"] + u["M"] * u["F1"] + u["F0"] + u["M00"] + u["t0"] + u["qdd0"]) / (2.0 * 1.5 ** 2)
    t = np.linspace(0, 2, 5)
    for backend in ("c", "numpy"):
        r = derive.simulate(str(tmp_path / "torqued.toml"), [0.0, 0.0], t, {"m1": 2.0, "l1": 1.5, "g": 0.0},
                            inputs=u, rtol=1e-12, backend=backend)
        assert r.ok and np.max(np.abs(r.y[:, 0] - a * t ** 2 / 2)) < 1e-10, backend
    assert load("torqued").names["input_names"] == tuple(names)


# The fast tier: clang's warnings (its front end's, the same at any -O) without building;
# the slow tier: the -O2 builds, with gcc's optimiser-driven warnings (about 20 s of CPU).
@pytest.mark.parametrize("cc", ["clang-syntax", *(pytest.param(c, marks=pytest.mark.slow)
                                                  for c in ("gcc", "clang", "g++"))])
def test_a_user_models_c_is_clean_under_werror(tmp_path, cc):
    gen = tmp_path / "gen"
    run = cli("generate", str(EXAMPLES / "triple.toml"), str(EXAMPLES / "driven.toml"), "--out", str(gen), cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    compiler, build = ("clang", ["-fsyntax-only"]) if cc == "clang-syntax" else \
        (cc, ["-O2", "-c", "-o", str(tmp_path / "x.o")])
    flags = ["-std=c99", "-pedantic"] if compiler != "g++" else ["-x", "c++"]
    for src in sorted((gen / "c").glob("*.c")):
        proc = subprocess.run([compiler, *flags, *quad_flags(compiler, src), "-Wall", "-Wextra", "-Werror",
                               *build, str(src)], capture_output=True, text=True)
        assert proc.returncode == 0, (src.name, proc.stderr)


# -- model files anywhere ------------------------------------------------------------------

def test_every_command_takes_a_model_file(tmp_path):
    path = write(tmp_path, "mine", chain("mine", 3))
    run = cli("derive", str(path), cwd=tmp_path)
    assert run.returncode == 0 and "mine" in run.stdout, run.stderr
    run = cli("verify", "mine.toml", cwd=tmp_path)
    assert run.returncode == 0 and "mine: energy conserved" in run.stdout, run.stderr
    assert "Cartesian constraint forces" in run.stdout
    run = cli("latex", "mine.toml", cwd=tmp_path)
    assert run.returncode == 0 and (tmp_path / "mine.tex").is_file(), run.stderr


def test_a_scene_names_its_model_file_relative_to_itself(tmp_path):
    (tmp_path / "models").mkdir()
    write(tmp_path / "models", "trio", chain("trio", 3))
    scene = tmp_path / "scenes" / "trio.toml"
    scene.parent.mkdir()
    scene.write_text('[pendulum]\nmodel = "../models/trio.toml"\n'
                     'parameters = { m1 = 1, m2 = 1, m3 = 1, l1 = 1, l2 = 1, l3 = 1, g = 9.81 }\n'
                     '[initial]\nstate = [0.5, 0.2, 0.1, 0, 0, 0]\n[time]\nstop = 1.0\noutputs = 11\n'
                     '[accuracy]\ntarget = 1e-6\n[output]\ndirectory = "out"\ntrajectory = ["csv"]\n')
    run = cli("run", str(scene), cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    # the output folder is relative to the scene file, as the model path is
    header = (tmp_path / "scenes" / "out" / "trio.csv").read_text().splitlines()[0].split(",")
    assert header[:7] == ["t", "theta1", "theta2", "theta3", "theta1_dot", "theta2_dot", "theta3_dot"]
    assert "x3_y" in header


def test_one_bad_model_does_not_stop_the_others(tmp_path):
    good = write(tmp_path, "good", chain("good", 2))
    bad = write(tmp_path, "bad", chain("bad", 2).replace('chart = "planar"', 'chart = "hyperbolic"', 1))
    run = cli("generate", str(bad), str(good), "--out", "gen", cwd=tmp_path)
    assert run.returncode == 2
    assert "unknown chart 'hyperbolic'" in run.stderr and str(bad) in run.stderr
    assert (tmp_path / "gen" / "c" / "good.c").is_file()


def test_editing_one_model_changes_only_its_keys(tmp_path):
    from derive.codegen import sources
    path = write(tmp_path, "keyed", chain("keyed", 2))
    load_model(path)
    before = {n: sources.sources_key(n) for n in ("keyed", "planar", "compound")}
    path.write_text('title = "edited"\n' + chain("keyed", 2))
    load_model(path)
    after = {n: sources.sources_key(n) for n in ("keyed", "planar", "compound")}
    assert before["keyed"] != after["keyed"]
    assert before["planar"] == after["planar"] and before["compound"] == after["compound"]


# -- model files are data -----------------------------------------------------------------

@pytest.mark.parametrize("expression, message", [
    ("__import__('os').system('touch {marker}') or 1", "not an expression"),   # 'or' is no operator here
    ("__import__('os').system('touch {marker}')", "the construct 'Attribute'"),
    ("exec('open(1)')", "the function 'exec'"),
    ("l1.real", "the construct 'Attribute'"),
    ("(lambda: 1)()", "not an expression"),
    ("l1 ^ 2", "'^' is not a power"),
    ("[l1][0]", "the construct 'Subscript'"),
    ("'l1'", "the constant"),
    ("l9", "'l9' is not a declared parameter"),
    ("sqrt(l1, 2)", "sqrt with 2 arguments"),
])
def test_model_expressions_are_never_evaluated(tmp_path, expression, message):
    marker = tmp_path / "executed"
    value = expression.format(marker=marker)          # no double quotes: a TOML basic string
    text = chain("evil", 2).replace('length = "l1"', f'length = "{value}"', 1)
    path = write(tmp_path, "evil", text)
    with pytest.raises(ModelError, match="link 1") as info:
        load_model(path)
    assert message in str(info.value)
    assert not marker.exists()


@pytest.mark.parametrize("edit, message", [
    (lambda t: t.replace('dimension = 2', 'dimension = 2\nforms = ["lagrangian", "hamiltonian"]\n'
                         'dissipation = "c*theta1_dot**2"').replace('"g"]', '"g", "c"]'),
     "the Hamiltonian form is for conservative models"),
    (lambda t: t + '\n[forces]\nphi7 = "1"\n', "forces.phi7: not a coordinate"),
    (lambda t: t.replace('"g"]', '"g", "sin"]'), "'sin' is reserved: a function or constant of the expression grammar"),
    (lambda t: t.replace('dimension = 2', 'dimension = 2\ninputs = ["pi"]'), "'inputs': 'pi' is reserved: a function"),
    (lambda t: t.replace('dimension = 2', 'dimension = 2\ninputs = ["theta1_dot"]'),
     "the input 'theta1_dot' has the name of a state (theta1, theta2, theta1_dot, theta2_dot): an expression could not"),
    (lambda t: t.replace('dimension = 2', 'dimension = 2\ninputs = ["m1"]'), "'m1' is both a parameter and an input"),
    (lambda t: t.replace('"g"]', '"g", "m1"]'), "'m1' is given twice"),
    (lambda t: t.replace('"g"]', '"g", "theta1"]'), "has the name of a state"),
    (lambda t: t.replace('dimension = 2', 'dimension = 2\ndissipation = "c"').replace('"g"]', '"g", "c"]'),
     "dissipation uses no rate"),
    (lambda t: t.replace('dimension = 2', 'dimension = 4'), "'dimension' must be 2"),
    (lambda t: t.replace('name = "x"', 'name = "../../x"'), "'name' must be an identifier"),
])
def test_a_wrong_model_file_is_one_line_naming_the_key(tmp_path, edit, message):
    path = write(tmp_path, "x", edit(chain("x", 2)))
    with pytest.raises(ModelError, match=re.escape(message)) as info:
        load_model(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_the_power_balance_check_catches_a_wrong_dissipation(monkeypatch):
    """The check could fail: with the sign of -dR/dq' flipped in F, it does."""
    from derive.derivation import derive as derive_model
    from derive.verification import physics
    load_model(EXAMPLES / "driven.toml")
    good = physics.energy_conservation("driven")
    assert good.passed
    d = derive_model("driven")
    s = d.symbols
    wrong = d.F + 2 * __import__("sympy").Matrix([d.dissipation.diff(v) for v in s.qd])
    fake = type(d)(**{**d.__dict__, "F": wrong})
    monkeypatch.setattr(physics, "derive", lambda name: fake)
    monkeypatch.setattr(physics, "_system_functions", {})
    assert not physics.energy_conservation("driven").passed


def test_a_model_file_edited_during_a_session_is_read_anew(tmp_path):
    """Nothing made of the old file (derivation, sources, libraries) is used after an edit."""
    path = write(tmp_path, "edited", chain("edited", 2))
    p = [1.0, 1.0, 1.0, 1.0, 9.81]
    before = derive.simulate(str(path), [1.0, 0.5, 0, 0], [0.0, 1.0], p, rtol=1e-12)
    path.write_text(chain("edited", 2).replace('length = "l2"', 'length = "2*l2"'))
    after = derive.simulate(str(path), [1.0, 0.5, 0, 0], [0.0, 1.0], p, rtol=1e-12)
    longer = derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 1.0], [1.0, 1.0, 1.0, 2.0, 9.81], rtol=1e-12)
    assert np.max(np.abs(before.y[-1] - after.y[-1])) > 1e-3
    assert np.max(np.abs(after.y[-1] - longer.y[-1])) < 1e-9


def test_inputs_as_a_function_of_time_are_held_over_each_output_interval():
    """A zero-order hold: u(t_k) on [t_k, t_k+1).  With a switch at t = 0.5 on a grid that
    has 0.5, the run equals two constant-input runs one after the other."""
    load_model(EXAMPLES / "driven.toml")
    p = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81, "c1": 0.1, "c2": 0.05}
    u = lambda t, y: {"tau1": 3.0 if t < 0.5 else -1.0, "tau2": 0.5}
    t = np.linspace(0, 1, 11)
    held = derive.simulate("driven", [0.2, 0, 0, 0], t, p, inputs=u, rtol=1e-12, hold="zoh")
    a = derive.simulate("driven", [0.2, 0, 0, 0], t[:6], p, inputs=[3.0, 0.5], rtol=1e-12)
    b = derive.simulate("driven", a.y[-1], t[5:], p, inputs=[-1.0, 0.5], rtol=1e-12)
    assert held.ok and held.y.shape == (11, 4) and held.velocities.shape == (11, 2, 2)
    assert np.max(np.abs(held.y[5] - a.y[-1])) < 1e-9 and np.max(np.abs(held.y[-1] - b.y[-1])) < 1e-9


def test_a_scene_sets_a_models_inputs(tmp_path):
    (tmp_path / "driven.toml").write_text((EXAMPLES / "driven.toml").read_text())
    scene = ('[pendulum]\nmodel = "driven.toml"\n'
             'parameters = { m1 = 1, m2 = 1, l1 = 1, l2 = 1, g = 9.81, c1 = 0.1, c2 = 0.05 }\n'
             '{inputs}[initial]\nstate = [0.1, 0.0, 0.0, 0.0]\n[time]\nstop = 2.0\noutputs = 21\n'
             '[accuracy]\ntarget = 1e-6\n')
    (tmp_path / "s.toml").write_text(scene.replace("{inputs}", "inputs = { tau1 = 2.0, tau2 = 0.0 }\n"))
    run = cli("run", "s.toml", "--json", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    import json
    assert json.loads(run.stdout)["target_met"] is True
    (tmp_path / "s.toml").write_text(scene.replace("{inputs}", ""))
    run = cli("run", "s.toml", cwd=tmp_path)
    assert run.returncode == 2 and "'pendulum.inputs' is missing" in run.stderr
    (tmp_path / "s.toml").write_text(scene.replace("{inputs}", "inputs = { tau1 = 2.0, tau9 = 0.0 }\n"))
    run = cli("run", "s.toml", cwd=tmp_path)
    assert run.returncode == 2 and "not an input of 'driven'" in run.stderr


def test_link_quantities_written_as_expressions_are_checked(tmp_path):
    """'l1 - 3' with l1 = 1 is a negative length: one line, not a run with status ok."""
    path = write(tmp_path, "shifted", chain("shifted", 1).replace('length = "l1"', 'length = "l1 - 3"'))
    with pytest.raises(derive.SimulationInputError, match=re.escape("link 1 length = l1 - 3 = -2 must be positive")):
        derive.simulate(str(path), [0.1, 0], [0, 1], [1.0, 1.0, 9.81])
    with pytest.raises(ModelError, match=re.escape("link 2 body com = 3/2 must be in [0, 1]")):
        load_model(write(tmp_path, "farcom", (EXAMPLES / "triple.toml").read_text()
                         .replace('name = "triple"', 'name = "farcom"').replace('com = "1/2"', 'com = "3/2"')))


def test_generate_into_a_folder_keeps_the_other_models_there(tmp_path):
    a, b = write(tmp_path, "first", chain("first", 2)), write(tmp_path, "second_one", chain("second_one", 1))
    assert cli("generate", str(a), str(b), "--out", "gen", cwd=tmp_path).returncode == 0
    run = cli("generate", str(b), "--out", "gen", cwd=tmp_path)
    assert run.returncode == 0 and (tmp_path / "gen" / "c" / "first.c").is_file()
    assert cli("generate", str(a), "--out", "gen", "--check", cwd=tmp_path).returncode == 0


def test_derive_derive_of_the_atlas_derives_its_charts(tmp_path):
    run = cli("derive", "spherical", cwd=tmp_path)
    assert run.returncode == 0 and "spherical_std" in run.stdout and "spherical_rot" in run.stdout
