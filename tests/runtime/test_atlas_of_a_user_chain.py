"""The chart atlas of a user's chain (derive/model/atlas.py, [chain] in atlases.toml): a
triple spherical pendulum from examples/models, with no atlas file of its own, through a
pole against an independent Cartesian constraint-force integration
(tests/oracles/cartesian_reference.py, nothing from derive), the rule of seed 000 section 5.1 for
N links, agreement of the chain's charts, and clean C."""
from __future__ import annotations

import ctypes
import subprocess
from pathlib import Path

import numpy as np
import pytest

from tests.oracles.cartesian_reference import chain_energy, chain_simulate  # noqa: E402

import derive  # noqa: E402
from derive.runtime.atlas_runner import atlas_library, numpy_atlas  # noqa: E402
from derive.derivation import cartesian  # noqa: E402
from derive.model import load_model  # noqa: E402
from derive.model.atlas import atlas_for  # noqa: E402

# One worker runs this file (--dist loadgroup, tests/run.sh): the triple chain's three charts are derived once
# with a cold cache, not by two workers at the same time.
pytestmark = pytest.mark.xdist_group("triple_spherical_atlas")

TRIPLE = str(Path(__file__).resolve().parents[2] / "examples" / "models" / "triple_spherical.toml")
MASSES, LENGTHS, G = (1.0, 0.8, 0.6), (1.0, 0.9, 0.7), 9.81
P = {"m1": 1.0, "m2": 0.8, "m3": 0.6, "l1": 1.0, "l2": 0.9, "l3": 0.7, "g": G}


def chain(directions, rates, lengths=LENGTHS) -> np.ndarray:
    """Positions then velocities of every bob (6 N numbers) from link directions and
    link-direction rates (made unit and tangent)."""
    x, v, X, V = np.zeros(3), np.zeros(3), [], []
    for u, w, length in zip(directions, rates, lengths):
        u = np.asarray(u, float) / np.linalg.norm(u)
        w = np.asarray(w, float)
        w = w - (w @ u) * u
        x, v = x + length * u, v + length * w
        X.append(x)
        V.append(v)
    return np.concatenate(X + V)


# Starts in the standard chart (every |sin theta_i| >= 0.5); link 1 swings through the
# bottom pole (|sin theta_1| about 0.02 on the way), where the standard chart is singular.
THROUGH_THE_POLE = chain([[0.7, 0.1, -0.7], [0.6, 0.5, -0.6], [0.6, 0.6, -0.5]],
                         [[-2.0, 0.1, -2.0], [0.5, -1.0, 0.5], [-1.0, 1.0, 1.0]])


@pytest.fixture(scope="module")
def atlas():
    return atlas_for(TRIPLE)


def test_a_spherical_chain_has_an_atlas_with_no_file_of_its_own(atlas):
    """The members are the same chain with every link's chart replaced, ordinary models."""
    assert atlas.name == "triple_spherical_atlas"
    assert atlas.charts == ("triple_spherical", "triple_spherical_second", "triple_spherical_rotated")
    for member, chart in zip(atlas.charts, ("standard", "second", "rotated")):
        m = load_model(member)
        assert [link.chart.name for link in m.links] == [chart] * 3
        assert m.parameters == load_model(TRIPLE).parameters
        assert [link.length for link in m.links] == ["l1", "l2", "l3"]
    assert (atlas.sine_rule, atlas.sine_switch, atlas.sine_min) == ("0.5", "0.3", "0.1")


@pytest.mark.slow     # derives chains of several links: about 90 s
def test_the_rule_for_n_links(atlas):
    """Seed 000 5.1 on every link; for N >= 3 where its chart has a polar sine below 0.5,
    the chart whose smallest polar sine is largest.  C, NumPy and Python agree."""
    rng = np.random.default_rng(12)
    lib = atlas_library(atlas.name)
    mod = numpy_atlas(atlas.name)
    p = np.array([P[n] for n in load_model(TRIPLE).parameters])
    fallbacks = 0
    for _ in range(300):
        c = chain(rng.normal(size=(3, 3)) * [1, 1, 3], np.zeros((3, 3)))
        chosen = cartesian.choose_chart(c, LENGTHS, atlas.name)
        smallest = {m: min(cartesian.polar_sines(m, c, LENGTHS)) for m in atlas.charts}
        seed_pick = dict(zip(("standard", "second", "rotated"), atlas.charts))[
            cartesian.rule_chart(*cartesian.std_sines(c, LENGTHS), 0.5)]
        if smallest[seed_pick] >= 0.5:
            assert chosen == seed_pick
        else:
            fallbacks += 1
            assert smallest[chosen] == max(smallest.values())
        y = cartesian.cartesian_to_state(atlas.charts[0], c, LENGTHS)
        fn = lib.choose_chart["float64"]
        ptr = ctypes.POINTER(ctypes.c_double)
        yc, pc = np.ascontiguousarray(y), np.ascontiguousarray(p)
        assert atlas.charts[fn(0, yc.ctypes.data_as(ptr), pc.ctypes.data_as(ptr), 0.5)] == chosen
        assert atlas.charts[mod.choose_chart(0, y, p)] == chosen
    assert fallbacks > 0          # the generalisation is exercised, not only the seed's rule
    # the limit of three charts: links along x, y and z leave every chart singular on one
    c = chain(np.eye(3), np.zeros((3, 3)))
    assert max(min(cartesian.polar_sines(m, c, LENGTHS)) for m in atlas.charts) < 1e-12


@pytest.mark.slow     # numpy: ~45 s of the triple chain's atlas; c: compiles it, minutes
@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_triple_chain_through_a_pole_agrees_with_a_cartesian_reference(backend):
    """Both at rtol 1e-12 (the reference 1e-13, DOP853 in SciPy on the constraint-force
    equations); over 5 s this motion amplifies a 1e-12 local error to about 1e-11 (measured
    2e-11); 1e-8 leaves room for other compilers while a wrong switch, conversion or
    chart-mixing would show at 1e-4 or more."""
    t = np.linspace(0.0, 5.0, 201)
    r = derive.simulate(TRIPLE, {"cartesian": THROUGH_THE_POLE}, t, P, atlas=True, rtol=1e-12, backend=backend)
    assert r.ok, r.message
    ref = chain_simulate(THROUGH_THE_POLE, t, MASSES, LENGTHS, G)
    d = np.diff(np.concatenate([np.zeros((len(t), 1, 3)), ref[:, :9].reshape(-1, 3, 3)], 1), axis=1)
    polar = np.hypot(d[..., 0], d[..., 1]) / np.linalg.norm(d, axis=-1)
    assert polar[:, 0].min() < 0.05                     # link 1 passes by the standard chart's axis
    mine = np.hstack([r.positions.reshape(len(t), -1), r.velocities.reshape(len(t), -1)])
    assert np.max(np.abs(mine - ref)) < 1e-8
    assert r.switches > 0 and set(r.chart) == set(atlas_for(TRIPLE).charts) and r.chart[0] == "triple_spherical"
    e_ref = chain_energy(ref, MASSES, G)
    assert abs(r.energy[0] - e_ref[0]) < 1e-12 * abs(e_ref[0])
    assert np.max(np.abs(r.energy - r.energy[0])) < 1e-9 * abs(r.energy[0])


@pytest.mark.slow     # runs the triple chain on its atlas
def test_the_charts_of_a_user_chain_agree(atlas):
    """The same motion integrated in the standard and in the second chart, away from both
    singularities, agrees after converting (to Cartesian, by each chart's own kernels)."""
    c0 = chain([[0.6, 0.5, -0.6], [0.5, 0.6, -0.6], [0.6, 0.6, -0.5]], [[0.3, -0.2, 0.1], [0.2, 0.1, 0.0], [-0.2, 0.2, 0.1]])
    t = np.linspace(0.0, 0.3, 7)
    runs = [derive.simulate(m, {"cartesian": c0}, t, P, rtol=1e-12) for m in atlas.charts]
    for r in runs:
        assert r.ok, r.message
        assert min(min(np.abs(cartesian.polar_sines(r.model, cartesian.state_to_cartesian(r.model, y, LENGTHS), LENGTHS)))
                   for y in r.y) > 0.3
    for other in runs[1:]:
        assert np.max(np.abs(other.positions - runs[0].positions)) < 1e-10
        assert np.max(np.abs(other.velocities - runs[0].velocities)) < 1e-9


def test_bad_atlas_requests_are_one_line():
    with pytest.raises(derive.SimulationInputError, match="atlas=True: .*spherical in the 'standard' chart"):
        derive.simulate("planar", [0, 0, 0, 0], [0, 1], {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81}, atlas=True)
    with pytest.raises(derive.SimulationInputError, match="must have 18 numbers"):
        derive.simulate(TRIPLE, {"cartesian": THROUGH_THE_POLE[:12]}, [0, 1], P, atlas=True)
    bad = THROUGH_THE_POLE.copy()
    bad[6:9] *= 1.01                               # bob 3 off its link
    with pytest.raises(derive.SimulationInputError, match="x3 - x2"):
        derive.simulate(TRIPLE, {"cartesian": bad}, [0, 1], P, atlas=True)


@pytest.mark.slow     # compiles the triple chain's atlas C, ~40 s a compiler
@pytest.mark.parametrize("cc", ["gcc", "clang", "g++"])
def test_a_user_atlas_c_is_clean_under_werror(atlas, cc, tmp_path):
    from derive.codegen.sources import model_sources
    folder = model_sources(atlas.name) / "c"
    flags = ["-std=c99", "-pedantic"] if cc != "g++" else ["-x", "c++"]
    sources = [folder / f"{atlas.prefix}.c"] + [folder / f"{m}_integrate.c" for m in atlas.charts]
    for src in sources:
        proc = subprocess.run([cc, *flags, "-Wall", "-Wextra", "-Werror", "-O2", "-c", str(src),
                               "-o", str(tmp_path / "x.o")], capture_output=True, text=True)
        assert proc.returncode == 0, (src.name, proc.stderr)
    header = (folder / f"{atlas.prefix}.h").read_text()
    assert "#define TRIPLE_SPHERICAL_ATLAS_N_STATES 12" in header and "N_PARAMS 7" in header


def _pole_scene(tmp_path, atlas_line: str) -> Path:
    """A scene of the triple chain from THROUGH_THE_POLE (Cartesian), with `atlas_line`."""
    c = THROUGH_THE_POLE
    vec = lambda k: "[" + ", ".join(f"{v:.17g}" for v in c[3 * k:3 * k + 3]) + "]"
    cart = ", ".join(f"{n}{i + 1} = {vec(3 * (n == 'v') + i)}" for n in "xv" for i in range(3))
    scene = tmp_path / "triple_pole.toml"
    scene.write_text(f'title = "Triple through a pole"\n[pendulum]\nmodel = "{TRIPLE}"\n{atlas_line}\n'
                     f'parameters = {{ {", ".join(f"{k} = {v}" for k, v in P.items())} }}\n'
                     f'[initial]\ncartesian = {{ {cart} }}\n[time]\nstop = 2.0\noutputs = 41\n'
                     f'[accuracy]\nmethod = "dop853"\nrtol = 1e-10\n'
                     f'[output]\ndirectory = "{tmp_path / "out"}"\ntrajectory = ["csv", "npz"]\nplots = ["paths", "energy"]\n')
    return scene


@pytest.mark.slow
def test_a_user_chain_scene_through_a_pole_runs_on_its_atlas_unless_one_chart_is_asked(tmp_path):
    """No `pendulum.atlas`: the one-chart run meets the standard chart's pole, and the scene
    runs on the chain's atlas instead, saying so; `atlas = false`: the stop, with the way out."""
    import json
    import os
    import sys
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    cli = lambda scene: subprocess.run([sys.executable, "-m", "derive", "run", str(scene), "--json"],
                                       capture_output=True, text=True, env=env, cwd=tmp_path, timeout=900)
    auto = cli(_pole_scene(tmp_path, ""))
    assert auto.returncode == 0, auto.stderr
    s = json.loads(auto.stdout)
    assert s["model"] == "triple_spherical_atlas" and s["ok"]
    rows = (tmp_path / "out" / "triple_pole.csv").read_text().splitlines()[1:]
    assert len({r.rsplit(",", 1)[1] for r in rows}) > 1          # it left the standard chart
    assert "triple_spherical's chart meets its pole at t = " in s["model_reason"]
    one = cli(_pole_scene(tmp_path, "atlas = false"))
    assert one.returncode == 1 and "chart singular" in one.stderr
    assert "pendulum.atlas = true runs it on the chart atlas" in one.stderr
    assert len(one.stderr.strip().splitlines()) == 1


@pytest.mark.slow     # runs the triple chain on its atlas
def test_an_atlas_scene_for_a_user_chain_writes_every_bob_and_the_chart(tmp_path):
    """[pendulum] atlas = true: CSV and NPZ with the chart of every row and the positions
    and velocities of all three bobs; the plots draw three bobs."""
    pytest.importorskip("matplotlib")
    from derive.scene import load_scene
    from derive.scene.outputs import write_outputs
    from derive.scene.run import run
    c = THROUGH_THE_POLE
    s = load_scene(_pole_scene(tmp_path, "atlas = true"))
    assert s.model == "triple_spherical_atlas"
    o = run(s, show_progress=False)
    assert o.result.ok and len(set(o.result.chart)) > 1      # chunks restart in the rule's chart
    files = write_outputs(o)
    header = (tmp_path / "out" / "triple_pole.csv").read_text().splitlines()[0].split(",")
    assert header[-1] == "chart" and "x3_z" in header and "v3_x" in header and "energy" in header
    rows = (tmp_path / "out" / "triple_pole.csv").read_text().splitlines()[1:]
    assert len(rows) == 41 and {r.rsplit(",", 1)[1] for r in rows} == set(atlas_for(TRIPLE).charts)
    npz = np.load(tmp_path / "out" / "triple_pole.npz")
    assert npz["positions"].shape == (41, 3, 3) and npz["velocities"].shape == (41, 3, 3)
    assert np.allclose(npz["positions"][0].ravel(), c[:9], atol=1e-12)
    assert any(f.endswith(".png") for f in files)


@pytest.mark.slow     # runs the triple chain on its atlas
def test_verify_checks_the_charts_of_a_user_chain():
    """derive verify (physics.model_checks) of a user's spherical chain compares its charts:
    the same Cartesian accelerations in all three, and a round trip through the second."""
    from derive.model import load_model
    from derive.verification.physics import model_checks
    name = load_model(Path(__file__).parents[2] / "examples" / "models" / "triple_spherical.toml").name
    checks = {c.name: c for c in model_checks(name)}
    charts = [k for k in checks if "same Cartesian accelerations" in k]
    assert len(charts) == 2 and any("round trip" in k for k in checks)
    assert all(c.passed for c in checks.values()), [c.detail for c in checks.values() if not c.passed]
