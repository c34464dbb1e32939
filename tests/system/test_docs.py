"""The docs are executed, not decorative: the site builds with warnings as errors, every code
example of the README and of docs/*.md runs (tests/system/doc_examples.py says how), and
the pages' generated parts are what the code says."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from tests.system.doc_examples import (DOCS, PAGE_FOLDER, README, ROOT, blocks, c_program, pages,
                                       runnable, shell_script)

sys.path.insert(0, str(DOCS / "_ext"))
import derive_docs  # noqa: E402

DOC_PAGES = sorted(DOCS.glob("*.md"))
# The page whose examples run in seconds stays in the fast tier; the others derive, verify,
# compile and run models (the README's taste alone costs most of a minute from a cold cache).
FAST_PAGES = ("cli.md",)


def _env() -> dict:
    return dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))


def _scratch(page: Path, tmp_path: Path) -> Path:
    """A scratch folder for a page's commands: a copy of the tutorial's files, as tutorial/ and
    (for the pages that continue it) as the folder itself, and of examples/."""
    shutil.copytree(DOCS / "tutorial", tmp_path / "tutorial")
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    folder = PAGE_FOLDER.get(page.name)
    return tmp_path / folder if folder else tmp_path


def _run_page(page: Path, tmp_path: Path) -> None:
    script = shell_script(page, sys.executable)
    assert script is not None, f"{page.name} has no sh or python example"
    done = subprocess.run(["bash", "-c", script], cwd=_scratch(page, tmp_path), env=_env(),
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, (f"{page.name}: an example failed (exit {done.returncode})\n"
                                  f"{done.stdout[-3000:]}\n{done.stderr[-3000:]}")


def _pages_with_commands(fast: bool):
    return [pytest.param(p, id=p.name) for p in pages()
            if shell_script(p, "python") and (p.name in FAST_PAGES) == fast]


@pytest.mark.parametrize("page", _pages_with_commands(fast=True))
def test_the_quick_pages_examples_run(page, tmp_path):
    _run_page(page, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("page", _pages_with_commands(fast=False))
def test_every_pages_examples_run(page, tmp_path):
    _run_page(page, tmp_path)


def test_every_toml_example_is_a_file_derive_reads():
    from derive.model.description import parse_model
    from derive.scene.scene import parse_scene
    from derive.sweep.sweep_file import parse_sweep
    read = 0
    for page in pages():
        for block in runnable(page):
            if block.language != "toml":
                continue
            where = f"{page.name}:{block.line}"
            table = tomllib.loads(block.code)
            if "links" in table:
                parse_model(block.code, where)
            elif "axes" in table:
                parse_sweep(block.code, where)
            else:
                assert "pendulum" in table, f"{where}: a TOML example that is no model, scene or sweep"
                parse_scene(block.code, where)
            read += 1
    assert read >= 3


def test_every_c_example_compiles_and_runs(tmp_path):
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    assert cc, "no C compiler (tests/run.sh installs one)"
    generated = ROOT / "generated" / "c"
    ran = 0
    for page in pages():
        for block in runnable(page):
            if block.language != "c":
                continue
            source = tmp_path / f"{page.stem}_{block.line}.c"
            source.write_text(c_program(block))
            program = tmp_path / source.stem
            subprocess.run([cc, "-std=c99", "-O1", "-Wall", f"-I{generated}", str(source),
                            str(generated / "planar.c"), "-lm", "-o", str(program)], check=True)
            assert subprocess.run([str(program)]).returncode == 0, f"{page.name}:{block.line}"
            ran += 1
    assert ran >= 1


def test_a_block_that_is_not_run_says_why_and_few_are():
    exempt = [b for p in pages() for b in blocks(p) if b.not_run is not None]
    for block in exempt:
        assert len(block.not_run) > 20, f"{block.page.name}:{block.line}: say why it is not run"
        assert block.language in ("sh", "python"), f"{block.page.name}:{block.line}"
    assert len(exempt) <= 8


def test_every_code_block_has_a_language_we_know():
    for page in pages():
        for block in blocks(page):
            assert block.language in ("sh", "python", "toml", "c", "text"), \
                f"{page.name}:{block.line}: ```{block.language}"


def test_every_page_is_in_the_table_of_contents():
    index = (DOCS / "index.md").read_text()
    for page in DOC_PAGES:
        if page.name != "index.md":
            assert f"\n{page.stem}\n" in index, page.name


def test_the_generated_parts_are_what_the_code_says():
    """The markers expand to the parser's flags, derive.__all__, the contract and the errata."""
    import derive
    from derive.cli import build_parser
    from derive.codegen.contract import METHOD_TABLE, STATUS_TABLE
    from derive.verification.errata import errata_markdown
    cli = derive_docs.expand((DOCS / "cli.md").read_text())
    parser = build_parser()
    subparsers = next(a for a in parser._actions if a.dest == "command")
    for name, sub in subparsers.choices.items():
        assert f"### `derive {name}`" in cli
        for action in sub._actions:
            for flag in action.option_strings:
                if flag in ("-h", "--help"):
                    continue
                assert f"`{flag}`" in cli, (name, flag)
    for status in (0, 1, 2, 3, 130):
        assert f"| {status} |" in cli
    api = derive_docs.expand((DOCS / "python.md").read_text())
    for name in derive.__all__:
        assert f"derive.{name}" in api or f"derive.sweep.{name}" in api, name
    methods = derive_docs.expand((DOCS / "methods.md").read_text())
    assert all(f"`{m.name}`" in methods for m in METHOD_TABLE)
    c_api = derive_docs.expand((DOCS / "c-api.md").read_text())
    assert all(f"`<MODEL>_INTEGRATE_{s.macro}`" in c_api for s in STATUS_TABLE)
    assert "int planar_integrate(int method," in c_api
    assert errata_markdown().strip() in derive_docs.expand((DOCS / "errata.md").read_text())


def test_the_model_reference_names_every_chart_and_body_kind():
    import tomllib as toml

    from derive.model.description import charts_file
    models = derive_docs.expand((DOCS / "models.md").read_text())
    for chart in toml.loads(charts_file().read_text()):
        assert f"| `{chart}` |" in models
    assert "| `point` | `mass` |" in models and "| `rod` | `mass`, `com`, `inertia` |" in models


@pytest.mark.slow
def test_the_site_builds_with_warnings_as_errors(tmp_path):
    """sphinx-build -W: every page, the API's docstrings, the tutorial's plots (the build runs
    its scene) and the benchmark's plots."""
    out = tmp_path / "html"
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                           str(DOCS), str(out)], env=_env(), capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-4000:]
    tutorial = (out / "tutorial.html").read_text()
    for figure in ("_figures/scene_paths.png", "_figures/scene_energy.png"):
        assert figure in tutorial and (out / figure).stat().st_size > 1000
    for png in (ROOT / "bench" / "results").glob("*.png"):
        assert (out / "_figures" / "bench" / png.name).read_bytes() == png.read_bytes()
    assert "derive.simulate" in (out / "python.html").read_text()
    assert "derive run" in (out / "cli.html").read_text()


def test_the_explicit_time_pages_say_what_the_code_runs():
    """docs/models.md and docs/events.md on a time-dependent model (a moving pivot): an
    ensemble, a sweep and Taylor's method run (in the generated C, each stage or jet at its
    own t), so the page does not list them among the refusals; r.sol and events work, so events.md does not
    say every model is autonomous."""
    import re

    import numpy as np

    import derive
    model = str(ROOT / "examples" / "models" / "driven_pivot.toml")
    params = {"m": 1.0, "l": 1.0, "g": 9.81, "a": 0.1, "w": 3.0}
    ens = derive.ensemble(model, [[0.3, 0.0], [0.2, 0.0]], [0.0, 0.5], params)
    assert ens.status_names == ["ok", "ok"]
    r = derive.simulate(model, [0.3, 0.0], np.linspace(0, 2, 5), params, events={"turn": "theta1_dot"})
    assert r.sol is not None and len(r.events["turn"].t) >= 1
    models = " ".join((DOCS / "models.md").read_text().split())
    refused = re.search(r"Refused in one line, naming what runs it: ([^.]*)\.", models).group(1)
    assert "ensembles" not in refused and "sweeps" not in refused and "Taylor" not in refused
    # Taylor's jet has t in it (tests/runtime/test_taylor_explicit_time.py): the page says it runs
    assert derive.simulate(model, [0.3, 0.0], [0.0, 0.5], params, method="taylor").ok
    assert "Taylor's method runs it as well" in models
    assert "`derive.ensemble` runs one in C with threads" in models
    events = " ".join((DOCS / "events.md").read_text().split())
    assert "The models are autonomous" not in events
    assert "A time-dependent model" in events and "stage_solution.py" in events
