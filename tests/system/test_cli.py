"""The command line as a user meets it: output formats, exit codes, one-line errors."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def derive(*args, cwd=ROOT):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "derive", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


# what a command that needs none of them must not import at start-up (cli.py's imports)
HEAVY = ("sympy", "numpy", "matplotlib", "jinja2", "derive.measurement.bench", "derive.model.description")


def _imported(*args):
    """The modules `python -m derive ARGS` imports, as -X importtime reports them."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    run = subprocess.run([sys.executable, "-X", "importtime", "-m", "derive", *args], cwd=ROOT, env=env,
                         capture_output=True, text=True, timeout=120)
    lines = [line for line in run.stderr.splitlines() if line.startswith("import time:")]
    return run, {line.rsplit("|", 1)[1].strip() for line in lines}


@pytest.mark.parametrize("args, status", [(("--help",), 0), (("--version",), 0), (("run", "--list"), 0),
                                          (("generate", "--no-such-option"), 2), (("bench", "--help"), 0)])
def test_a_light_command_starts_without_sympy_or_numpy(args, status):
    run, modules = _imported(*args)
    assert run.returncode == status, run.stderr[-2000:]
    assert {"derive.cli", "argparse"} <= modules        # the report was read
    assert sorted(m for m in modules if m.split(".")[0] in HEAVY or m in HEAVY) == []


@pytest.mark.slow     # verifies every formula of every seed claim: about 50 s
def test_verify_json_lists_every_formula():
    run = derive("verify", "--json")
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    assert set(out) == {"formulas", "physics_checks"}
    rows = out["formulas"]
    assert len(rows) >= 200
    assert all(set(r) == {"seed", "equation", "what", "model", "verdict", "summary", "printed",
                          "derived", "discrepancy", "corrected", "origin"} for r in rows)
    assert all(set(r["printed"]) == {"latex", "sympy"} and r["derived"]["latex"] for r in rows)
    assert all(r["corrected"] is not None for r in rows if r["verdict"] == "erratum")
    checks = out["physics_checks"]
    assert checks and all(c["passed"] for c in checks)
    assert {"name", "passed", "detail", "models", "states", "tolerance", "worst"} <= set(checks[0])
    assert {r["verdict"] for r in rows} == {"match", "erratum"}
    assert {r["seed"] for r in rows} == {"000_22f1304773697fe8.txt", "001_025e500cdf7d3415.txt"}
    assert any(r["equation"] == "3.40" and r["verdict"] == "erratum" for r in rows)


@pytest.mark.slow     # `derive verify` of every seed claim in a subprocess (tests/verification checks them in-process)
def test_verify_table_and_summary():
    run = derive("verify")
    assert run.returncode == 0, run.stderr
    assert "errata" in run.stdout and "physics checks pass" in run.stdout


@pytest.mark.parametrize("args,message", [
    (["frobnicate"], "invalid choice"),
    (["derive", "triple"], "unknown model 'triple'"),
    (["latex", "triple"], "unknown model 'triple'"),
    (["latex", "planar", "-o", "/no/such/dir/x.tex"], "does not exist"),
    (["verify", "--colour"], "unrecognized arguments"),
    (["run"], "derive run: give a scene file or an example's name (derive run --list lists them)"),
    (["sweep", "default"], "a scene, not a sweep (it has no [axes] and no record); run it with `derive run default`"),
])
def test_bad_input_is_one_line_and_exit_2(args, message):
    run = derive(*args)
    assert run.returncode == 2
    assert message in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1, run.stderr
    assert "Traceback" not in run.stderr


@pytest.mark.parametrize("model", ["compound", pytest.param("spherical_std", marks=pytest.mark.slow)])
def test_latex_document_compiles(model, tmp_path):
    run = derive("latex", model, "-o", str(tmp_path / f"{model}.tex"), "--pdf")
    assert run.returncode == 0, run.stdout + run.stderr
    tex = (tmp_path / f"{model}.tex").read_text()
    assert r"\begin{document}" in tex and r"\verdict{match}" in tex
    if model == "spherical_std":
        assert r"\verdict{erratum}" in tex   # e.g. (3.40) is printed wrong in the seed
    assert (tmp_path / f"{model}.pdf").stat().st_size > 10_000


def test_bench_refuses_an_unwritable_output_directory_before_running():
    run = derive("bench", "--quick", "--quiet", "--no-throughput", "--out", "/proc/no-such-dir")
    assert run.returncode == 2 and "cannot write to '/proc/no-such-dir'" in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1


def test_run_list_names_every_example_with_its_title():
    run = derive("run", "--list")
    assert run.returncode == 0, run.stderr
    lines = dict(line.split(maxsplit=1) for line in run.stdout.splitlines())
    examples = sorted(p.stem for p in (ROOT / "derive" / "scenes").glob("*.toml"))
    assert sorted(lines) == examples
    assert lines["default"] == "Chaotic planar double pendulum"
    assert lines["flip_map"].endswith("(a sweep: derive sweep flip_map)")
    assert "sweep" not in lines["spherical_pole"]


def test_verify_of_an_own_model_names_its_physics_checks(tmp_path):
    """No seed formula belongs to a user's model: no '0 seed formulas' line, the checks instead."""
    (tmp_path / "mine.toml").write_text(
        'name = "mine_verify"\ndimension = 2\nparameters = ["m1", "l1", "g"]\n'
        '[[links]]\nchart = "planar"\nlength = "l1"\nbody = { kind = "point", mass = "m1" }\n')
    run = derive("verify", "mine.toml", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "seed formulas" not in run.stdout
    assert ("3/3 physics checks pass (M symmetric positive definite; energy conserved; "
            "bob accelerations = Cartesian constraint forces)") in run.stdout
