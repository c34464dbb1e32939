"""Hostile inputs refused at once with one line: numbers of unbounded size in model, event
and sweep expressions, certain divisions by zero, non-ASCII look-alikes, link quantities
whose role hides behind another spelling (`1*l1`, `+m2`), model paths that are no regular
files, and model names too long or colliding with another artifact's files."""
from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

import derive
from derive.model import ModelError, load_model

ROOT = Path(__file__).resolve().parents[2]
PLANAR = (ROOT / "derive" / "model" / "catalog" / "planar.toml").read_text()


def cli(*args, cwd, timeout=60):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    start = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "derive", *args], cwd=cwd, env=env,
                       capture_output=True, text=True, timeout=timeout)
    r.seconds = time.monotonic() - start
    return r


def model_file(tmp_path: Path, name: str, length: str = "l1", mass: str = "m2") -> Path:
    text = (PLANAR.replace('name = "planar"', f'name = "{name}"')
            .replace('length = "l1"', f'length = "{length}"', 1)
            .replace('mass = "m2"', f'mass = "{mass}"', 1))
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def one_line(r, status: int = 2) -> str:
    lines = r.stderr.strip().splitlines()
    assert r.returncode == status, r.stderr
    assert len(lines) == 1 and lines[0].startswith("derive: error:"), r.stderr
    assert "Traceback" not in r.stderr and "internal error" not in r.stderr
    return lines[0]


# -- a number's size is bounded -----------------------------------------------------------

HUGE = [
    ("tower", "10**10**10", "too large"),
    ("power", "2**100000000", "too large"),
    ("negative power", "2**-100000000", "too small"),
    ("literal", "1e9999999", "too large"),
    ("tiny literal", "1e-9999999", "too small"),
    ("long integer", "9" * 400, "too large"),
    ("product", "1e200*1e200*l1", "too large"),
    ("exp", "exp(exp(exp(10)))*l1", "too large"),
    ("symbolic power", "l1**1000000", "an exponent"),
    ("nested power", "(l1**50)**50", "an exponent"),
    ("unary minus", "-" * 9000 + "l1", "operators"),
    ("sum", "+".join(["l1"] * 3000), "operators"),
    ("division by zero", "1/0", "division by zero"),
    ("cancelled division by zero", "l1/(l1 - l1)", "division by zero"),
    ("zero to a negative power", "0**-1", "division by zero"),
    ("square root of -1", "sqrt(-1)", "not a real number"),
    ("log of 0", "log(0)*l1", "not a real number"),
    ("asin of 2", "asin(2)", "not a real number"),
    ("odd root of a negative", "(-8)**(1/3)", "not a real number"),
    ("full-width l", "\uff4c1", "not ASCII"),
]


@pytest.mark.parametrize("length, message", [h[1:] for h in HUGE], ids=[h[0] for h in HUGE])
def test_a_length_of_unbounded_size_is_refused_at_once(tmp_path, length, message):
    path = model_file(tmp_path, "huge", length)
    start = time.monotonic()
    with pytest.raises(ModelError) as info:
        load_model(path)
    assert time.monotonic() - start < 0.5
    text = str(info.value)
    assert message in text and "\n" not in text
    assert text.startswith(f"{path}: link 1 length")


@pytest.mark.parametrize("length", ["10**10**10", "1e9999999", "-" * 9000 + "l1", "+".join(["l1"] * 3000),
                                    "1/0", "sqrt(-1)"])
def test_derive_derive_refuses_them_with_exit_2(tmp_path, length):
    path = model_file(tmp_path, "huge", length)
    r = cli("derive", str(path), cwd=tmp_path)
    line = one_line(r)
    assert str(path) in line and "link 1 length" in line
    assert r.seconds < 15             # the interpreter's start and imports; the refusal itself is instant


@pytest.mark.parametrize("key, value", [
    ("forces", '[forces]\ntheta1 = "1/(m1 - m1)"\n'),
    ("dissipation", 'dissipation = "theta1_dot**2/(l1 - l1)"\n'),
])
def test_a_certain_division_by_zero_in_forces_or_dissipation_is_refused(tmp_path, key, value):
    text = PLANAR.replace('name = "planar"', 'name = "divzero"').replace('forms = ["lagrangian", "hamiltonian"]\n', "")
    text = (text.replace("[[links]]", value + "\n[[links]]", 1) if key == "dissipation" else text + "\n" + value)
    path = tmp_path / "divzero.toml"
    path.write_text(text)
    with pytest.raises(ModelError, match="division by zero") as info:
        load_model(path)
    assert key in str(info.value) and str(path) in str(info.value)


def test_ordinary_expressions_still_parse():
    import sympy as sp
    from derive.model.expressions import parse_expression
    l1 = sp.Symbol("l1")
    assert parse_expression("-pi/2", {}, "x") == -sp.pi / 2
    assert parse_expression("sqrt(21)/14", {}, "x") == sp.sqrt(21) / 14
    assert parse_expression("1.5e-3*l1**2 + 10**300", {"l1": l1}, "x") == sp.Rational(3, 2000) * l1**2 + 10**300
    assert parse_expression("(l1 + 1)**100", {"l1": l1}, "x") == (l1 + 1)**100
    assert parse_expression("6.674e-11", {}, "x") == sp.Rational("6.674e-11")


def test_event_expressions_and_sweep_axes_are_bounded(tmp_path):
    with pytest.raises(derive.SimulationInputError, match="too large"):
        derive.simulate("planar", [1, 0, 0, 0], [0, 1], [1, 1, 1, 1, 9.81], events={"e": "theta1 - 10**10**10"})
    scene = (ROOT / "derive" / "scenes" / "default.toml").read_text().replace('"out/default"', '"o"')
    (tmp_path / "s.toml").write_text(scene + '\n[events]\ncross = "theta1 - 1e9999999"\n')
    line = one_line(cli("run", "s.toml", cwd=tmp_path))
    assert "s.toml" in line and "events.cross" in line and "too large" in line
    from derive.errors import SceneError
    from derive.sweep.sweep_file import number
    with pytest.raises(SceneError, match="too large") as info:
        number("10**10**10", "f.toml: 'axes.theta1'.linspace[1]")
    assert "f.toml" in str(info.value)


# -- roles hold whatever the spelling ------------------------------------------------------

@pytest.mark.parametrize("length, mass", [("1*l1", "m2"), ("+l1", "m2"), ("(l1)", "m2"), ("l1", "+m2"),
                                          ("l1", "1*m2")])
def test_a_role_holds_whatever_the_spelling(tmp_path, length, mass):
    name = "spelled_" + str(abs(hash((length, mass))) % 10**6)
    path = model_file(tmp_path, name, length, mass)
    model = load_model(path)
    roles = model.parameter_roles()
    assert roles["l1"] == "length" and roles["m2"] == "mass"
    with pytest.raises(derive.SimulationInputError, match="must be positive"):
        derive.simulate(str(path), [1, 0, 0, 0], [0, 1], [1.0, 1.0, -1.0, 1.0, 9.81])     # l1 < 0
    with pytest.raises(derive.SimulationInputError, match="must be positive"):
        derive.simulate(str(path), [1, 0, 0, 0], [0, 1], [1.0, -2.0, 1.0, 1.0, 9.81])     # m2 < 0


def test_a_link_quantity_undefined_at_the_values_is_refused(tmp_path):
    path = model_file(tmp_path, "pole", "1/(l1 - 1)")
    with pytest.raises(derive.SimulationInputError, match="not a finite real number"):
        derive.simulate(str(path), [1, 0, 0, 0], [0, 1], [1.0, 1.0, 1.0, 1.0, 9.81])


# -- input paths are regular files of bounded size -----------------------------------------

def _specials(tmp_path: Path) -> dict[str, tuple[Path, str]]:
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    (tmp_path / "dir.toml").mkdir()
    big = tmp_path / "big.toml"
    big.write_text("#" * (2 << 20))
    return {"device": (Path("/dev/zero"), "a character device"), "fifo": (fifo, "a FIFO"),
            "directory": (tmp_path / "dir.toml", "a directory"), "big": (big, "bytes (at most 1048576")}


@pytest.mark.parametrize("command, what", [("derive", "model"), ("run", "scene"), ("sweep", "sweep")])
def test_input_paths_are_regular_files_of_bounded_size(tmp_path, command, what):
    for kind, (path, message) in _specials(tmp_path).items():
        r = cli(command, str(path), cwd=tmp_path, timeout=30)     # /dev/zero or a FIFO would never end
        line = one_line(r)
        assert f"{what} file '{path}'" in line and message in line, (kind, line)


def test_a_scene_naming_a_device_as_its_model(tmp_path):
    from derive.errors import SceneError
    from derive.scene import load_scene
    scene = (ROOT / "derive" / "scenes" / "default.toml").read_text().replace('"planar"', '"/dev/zero"')
    (tmp_path / "s.toml").write_text(scene)
    with pytest.raises(SceneError, match="a character device, not a regular file"):
        load_scene(tmp_path / "s.toml")
    with pytest.raises(ModelError, match="not UTF-8"):
        (tmp_path / "bin.toml").write_bytes(b"\xff\xfe\x00")
        load_model(tmp_path / "bin.toml")


# -- names: bounded, and never another artifact's ------------------------------------------

@pytest.mark.parametrize("name, message", [
    ("derive_integrators", "starts with 'derive_'"), ("derive_driver", "starts with 'derive_'"),
    ("planar_integrate", "ends with '_integrate'"), ("planar_taylor", "ends with '_taylor'"),
    ("planar_taylor_lanes", "ends with '_taylor_lanes'"), ("mine_fixed", "ends with '_fixed'"),
    ("mine_second", "ends with '_second'"), ("planar_linearize", "ends with '_linearize'"),
    ("spherical", "chart atlas"),
    ("a" * 65, "65 characters long (at most 64)"), ("a" * 260, "260 characters long"),
])
def test_a_model_name_that_would_collide_or_is_too_long_is_refused(tmp_path, name, message):
    path = model_file(tmp_path, "n", "l1").rename(tmp_path / "named.toml")
    path.write_text(path.read_text().replace('name = "n"', f'name = "{name}"'))
    with pytest.raises(ModelError, match=re.escape(message)) as info:
        load_model(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_derive_derive_of_a_long_or_colliding_name_is_one_line(tmp_path):
    path = tmp_path / "long.toml"
    path.write_text(PLANAR.replace('name = "planar"', f'name = "{"a" * 260}"'))
    assert "characters long" in one_line(cli("derive", str(path), cwd=tmp_path))
    path.write_text(PLANAR.replace('name = "planar"', 'name = "derive_integrators"'))
    assert "derive_" in one_line(cli("generate", str(path), "--out", "gen", cwd=tmp_path))
    assert not (tmp_path / "gen").exists()
    assert "unknown model" in one_line(cli("derive", "a" * 300, cwd=tmp_path))
    assert "File name too long" in one_line(cli("run", "a" * 300, cwd=tmp_path))


def _produced(names) -> dict[str, set[str]]:
    """{model or atlas: the stems of every file every backend writes for it}."""
    from derive.codegen.generate import render_models
    out = {}
    for name in names:
        out[name] = {Path(rel).stem for rel in render_models([name])}
    return out


def test_every_file_of_the_golden_tree_is_a_models_name_or_reserved():
    from derive.model import model_names
    from derive.model.atlas import chain_rule
    from derive.model.description import model_name_problem
    golden = {Path(p).stem for p in (ROOT / "generated").glob("*/*") if p.suffix in (".c", ".h", ".py")}
    assert "derive_integrators" in golden and "planar_taylor" in golden
    for stem in golden:
        assert stem in model_names() or model_name_problem(stem) is not None, stem
    for name in model_names():
        assert model_name_problem(name) is None, name
    # a spherical chain's atlas: its members and its own files
    for member in chain_rule().member_names[1:]:
        assert model_name_problem(member.format(model="mine")) is not None
    assert model_name_problem("mine_atlas") is not None


@pytest.mark.slow
def test_every_artifact_name_of_every_backend_is_reserved():
    """Every file any backend writes for a model (or an atlas) is the model's own name or a
    name no model file may take: so no model's files can be another's."""
    from derive.codegen.backends import backends
    from derive.codegen.generate import render_models
    from derive.model.atlas import ATLAS, load_atlas
    from derive.model.description import model_name_problem
    assert {b.name for b in backends()} == {"c", "jax", "numpy"}     # a new backend: check its files here
    produced = _produced(["planar", "spherical_std", ATLAS])
    # jax (rendered only on request) writes jax/<model>_jax.py and jax/<model>_linearize_jax.py:
    # a folder of its own, files whose names carry the model's, so no two models' files can be one
    for name in ("planar", "spherical_std", ATLAS):
        jax_files = render_models([name], backends=("jax",))
        assert list(jax_files) == ([] if name == ATLAS else [f"jax/{name}_jax.py", f"jax/{name}_linearize_jax.py"])
    golden = {Path(p).stem for p in (ROOT / "generated").glob("*/*") if p.suffix in (".c", ".h", ".py")}
    assert set().union(*produced.values()) <= golden | {"derive_tableaus"}
    for name, stems in produced.items():
        own = load_atlas(name).prefix if name == ATLAS else name
        assert own in stems
        for stem in stems - {own}:
            assert model_name_problem(stem) is not None, (name, stem)
        assert model_name_problem(own) is None or name == ATLAS
    for stem in golden:          # every file of the golden tree, of every catalogue model
        models = [m for m in ("planar", "compound", "spherical_std", "spherical_alt", "spherical_rot")
                  if stem == m]
        assert models or model_name_problem(stem) is not None, stem


# -- regressions ---------------------------------------------------------------------------

def _run_json(tmp_path, scene_text):
    import json
    (tmp_path / "s.toml").write_text(scene_text)
    r = cli("run", "s.toml", "--json", cwd=tmp_path, timeout=300)
    return r, (json.loads(r.stdout) if r.stdout.strip().startswith("{") else None)


DEFAULT = (ROOT / "derive" / "scenes" / "default.toml").read_text().replace('"out/default"', '"o"')


def test_scalar_float_is_the_lowest_precision_and_climbs(tmp_path):
    r, s = _run_json(tmp_path, DEFAULT.replace("target = 1e-8", 'target = 1e-8\nscalar = "float"'))
    assert r.returncode == 0, r.stderr
    assert s["target_met"] is True and s["dtype"] == "float64" and "beyond float" in s["note"]
    short = DEFAULT.replace("stop = 5.0", "stop = 1.0").replace("target = 1e-8", 'target = 1e-3\nscalar = "float"')
    r, s = _run_json(tmp_path, short)
    assert r.returncode == 0 and s["dtype"] == "float32" and s["target_met"] is True


def test_a_step_longer_than_the_span_is_an_input_error(tmp_path):
    scene = DEFAULT.replace("target = 1e-8", 'method = "rk4"\nstep = 1e300')
    (tmp_path / "s.toml").write_text(scene)
    assert "longer than the span" in one_line(cli("run", "s.toml", cwd=tmp_path))


def test_the_lyapunov_window_is_the_one_asked_for_or_says_why_not():
    from derive.measurement.trust import MAX_WINDOW, largest_lyapunov
    y0, p = [2.5, 2.0, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0, 9.81]
    short = largest_lyapunov("planar", y0, p, 5.0)
    assert short.t_end == 5.0 and short.window_note == ""
    long = largest_lyapunov("planar", y0, p, 200.0)
    assert long.t_end == MAX_WINDOW and long.requested == 200.0
    assert f"t = 0 to {MAX_WINDOW:g} of the 200 asked" in long.window_note
    assert "(" not in long.window_note      # the chaos line sets it in parentheses of its own


def test_a_long_scene_says_over_what_its_exponent_was_measured(tmp_path):
    r, s = _run_json(tmp_path, DEFAULT.replace("stop = 5.0", "stop = 25.0").replace("target = 1e-8", "target = 1e-2"))
    assert s is not None, r.stderr
    assert s["lyapunov_window"] == 20.0 and "of the 25 asked" in s["lyapunov_note"]


# -- Ctrl-C at any moment ------------------------------------------------------------------

@pytest.mark.parametrize("seconds", [0.3, 0.8, 1.5])
def test_ctrl_c_at_any_moment_of_derive_run_is_one_line_and_130(tmp_path, seconds):
    """SIGINT while the interpreter still imports derive, while it plans, or while it
    integrates: always exit 130 and "derive: interrupted" (the race that made the
    Ctrl-C test of test_drivers.py flaky was an interrupt during the imports)."""
    import signal
    scene = DEFAULT.replace("stop = 5.0", "stop = 900.0").replace("outputs = 501", "outputs = 11") \
                   .replace("target = 1e-8", 'method = "rk4"\nstep = 1e-5')
    (tmp_path / "long.toml").write_text(scene)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    # SIGINT's default action in the child: a pytest-xdist worker runs with SIGINT ignored,
    # and an ignored signal stays ignored across exec (the child would never see Ctrl-C)
    proc = subprocess.Popen([sys.executable, "-m", "derive", "run", "long.toml", "--quiet"], cwd=tmp_path,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(seconds)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and err.strip().splitlines() == ["derive: interrupted"], (proc.returncode, err)
