"""Every failure a user can provoke is one line on stderr and the documented exit status:
2 for bad input or a missing tool, 1 for a run that failed; never a traceback.

Each case is provoked for real: a PATH without a compiler or pdflatex, a template
folder with a file missing, an output path under a file, model files the pipeline
rejects."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import derive
from derive import errors
from derive.cli import main

ROOT = Path(__file__).resolve().parents[2]


def cli(*args, cwd=None, env_extra=None, path=None):
    env = dict(os.environ, PYTHONPATH=str(ROOT), **(env_extra or {}))
    if path is not None:
        env["PATH"] = path
    return subprocess.run([sys.executable, "-m", "derive", *args], cwd=cwd or ROOT, env=env,
                          capture_output=True, text=True, timeout=900)


def one_line(run, status: int, fragment: str) -> None:
    assert run.returncode == status, (run.returncode, run.stdout, run.stderr)
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1, run.stderr
    assert fragment in lines[0], lines[0]
    assert "Traceback" not in run.stderr


def test_every_expected_error_is_a_derive_error():
    for cls in (errors.ModelError, errors.SceneError, errors.SimulationInputError, errors.SpecError,
                errors.PrintError, errors.BuildError, errors.CompilerMissingError,
                errors.ToolMissingError, errors.PackageDataError, errors.SimulationError):
        assert issubclass(cls, derive.DeriveError), cls
    for cls in (errors.ModelError, errors.SceneError, errors.SimulationInputError, errors.SpecError):
        assert issubclass(cls, ValueError) and cls.exit_status == 2
    assert errors.CompilerMissingError.exit_status == 2 and errors.BuildError.exit_status == 1


def test_no_c_compiler(tmp_path):
    """CC unset and no cc, gcc or clang on PATH: the run says how to get one."""
    empty = tmp_path / "bin"
    empty.mkdir()
    env = {"DERIVE_CACHE_DIR": str(tmp_path / "cache")}
    env_no_cc = {k: v for k, v in os.environ.items() if k != "CC"}
    run = subprocess.run([sys.executable, "-m", "derive", "run", "default", "--output-dir", str(tmp_path / "o")],
                         cwd=tmp_path, capture_output=True, text=True, timeout=900,
                         env=dict(env_no_cc, PYTHONPATH=str(ROOT), PATH=str(empty), **env))
    one_line(run, 2, "no C compiler found: set CC or install gcc or clang")


def test_cc_that_does_not_exist(tmp_path):
    run = cli("run", "default", "--output-dir", str(tmp_path / "o"), cwd=tmp_path,
              env_extra={"CC": "no-such-cc-xyz", "DERIVE_CACHE_DIR": str(tmp_path / "cache")})
    one_line(run, 2, "'no-such-cc-xyz' (from CC) is not on PATH")


def test_no_pdflatex_still_writes_the_tex(tmp_path):
    empty = tmp_path / "bin"
    empty.mkdir()
    run = cli("latex", "planar", "-o", str(tmp_path / "p.tex"), "--pdf", path=str(empty))
    one_line(run, 2, "pdflatex not found: install TeX Live (texlive-latex-base) or omit --pdf")
    assert r"\begin{document}" in (tmp_path / "p.tex").read_text()
    assert not (tmp_path / "p.pdf").exists()


def test_pdflatex_leaves_only_the_tex_and_the_pdf(tmp_path):
    run = cli("latex", "planar", "-o", str(tmp_path / "p.tex"), "--pdf", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.pdf", "p.tex"]


def test_a_missing_template(tmp_path, monkeypatch, capsys):
    from derive import paths
    from derive.codegen import sources
    broken = tmp_path / "templates"
    shutil.copytree(paths.templates_dir(), broken)
    (broken / "c" / "source.c.jinja").unlink()
    monkeypatch.setattr(paths, "templates_dir", lambda: broken)
    monkeypatch.setenv("DERIVE_CACHE_DIR", str(tmp_path / "cache"))    # nothing rendered before
    sources.render.cache_clear()
    try:
        status = main(["generate", "planar", "--out", str(tmp_path / "gen")])
    finally:
        sources.render.cache_clear()
    err = capsys.readouterr().err
    assert status == 2, err
    assert err.count("\n") == 1 and "template c/source.c.jinja is missing" in err and "reinstall" in err


def test_missing_package_data(tmp_path, monkeypatch, capsys):
    from derive import paths
    # imported first: a module imported while package_root is patched would keep the patch
    import derive.codegen.generate, derive.codegen.sources, derive.derivation.derivation  # noqa: F401,E401
    monkeypatch.setattr(paths, "package_root", lambda: tmp_path)
    status = main(["generate", "planar", "--out", str(tmp_path / "gen")])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and "package data is missing" in err, err


@pytest.mark.parametrize("args", [
    ["generate", "planar", "--out", "{file}/gen"],
    ["run", "default", "--output-dir", "{file}/out"],
    ["bench", "--quick", "--quiet", "--no-throughput", "--out", "{file}/bench"],
    ["latex", "planar", "-o", "{file}/p.tex"],
])
def test_unwritable_output(tmp_path, args):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder\n")
    run = cli(*[a.format(file=blocker) for a in args], cwd=tmp_path)
    assert run.returncode == 2, run.stderr
    assert len(run.stderr.strip().splitlines()) == 1 and "Traceback" not in run.stderr
    assert str(blocker) in run.stderr


BAD_MODELS = {
    "not TOML": ("name = ", "not valid TOML"),
    "unknown chart": ('name = "x"\ndimension = 2\nparameters = ["m1", "l1", "g"]\n'
                      '[[links]]\nchart = "hyperbolic"\nlength = "l1"\nbody = { kind = "point", mass = "m1" }\n',
                      "unknown chart 'hyperbolic'"),
    "undeclared parameter": ('name = "x"\ndimension = 2\nparameters = ["m1", "g"]\n'
                             '[[links]]\nchart = "planar"\nlength = "l1"\nbody = { kind = "point", mass = "m1" }\n',
                             "'l1' is not a declared parameter"),
    "name that is a path": ('name = "../../x"\ndimension = 2\nparameters = ["m1", "l1", "g"]\n'
                            '[[links]]\nchart = "planar"\nlength = "l1"\nbody = { kind = "point", mass = "m1" }\n',
                            "'name' must be an identifier"),
}


@pytest.mark.parametrize("case", sorted(BAD_MODELS))
def test_a_model_file_the_pipeline_rejects(tmp_path, case):
    text, fragment = BAD_MODELS[case]
    path = tmp_path / "bad.toml"
    path.write_text(text)
    run = cli("generate", str(path), "--out", str(tmp_path / "gen"), cwd=tmp_path)
    one_line(run, 2, fragment)
    assert str(path) in run.stderr
    assert not (tmp_path / "gen").exists()


def test_a_missing_model_file(tmp_path):
    one_line(cli("derive", str(tmp_path / "nope.toml")), 2, "does not exist")


def test_an_unexpected_failure_is_one_line_too(monkeypatch, capsys):
    from derive import cli as cli_module

    def boom(args):
        raise ZeroDivisionError("a bug")
    parser = cli_module.build_parser()
    monkeypatch.setattr(cli_module, "build_parser", lambda: parser)
    parser._subparsers._group_actions[0].choices["verify"].set_defaults(func=boom)
    status = main(["verify"])
    err = capsys.readouterr().err
    assert status == 1 and err.count("\n") == 1 and "internal error: ZeroDivisionError: a bug" in err


def test_cc_with_flags_is_a_command(tmp_path):
    """CC="gcc -O2" (or "ccache gcc") is a program and its first words, not a missing program."""
    from derive.runtime.loader import compiler_command, compiler_identity
    assert compiler_command("gcc -O2") == ["gcc", "-O2"]
    assert "gcc" in compiler_identity("gcc -O2")


def test_an_option_is_only_its_full_name(tmp_path):
    """argparse's prefix matching took `latex --out tex` for `--output tex` and wrote a file
    named `tex`: a shortened option is refused, and `latex --out DIR` is the output folder
    every other command's --out is."""
    one_line(cli("latex", "planar", "--outp", "x", cwd=tmp_path), 2, "unrecognized arguments: --outp")
    run = cli("latex", "planar", "--out", "tex", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["planar.tex", "tex"]
    assert "\\documentclass" in (tmp_path / "tex" / "planar.tex").read_text()
    one_line(cli("latex", "planar", "--out", "a", "-o", "b.tex", cwd=tmp_path), 2, "not allowed with")
