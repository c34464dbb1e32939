"""The import rule of the house, as docs/architecture.md states it.

import-linter's layers contract (pyproject.toml, [tool.importlinter]) holds the stages in
their order: a stage imports only the stages below it, counting every import, at module
level or in a function, direct or through other modules.  The tests here add what the
contract does not say: function-local imports are kept for what needs them (the CLI's
commands, which import their stage when they run, and the optional extras), and no module
name is repeated across the package's folders where a distinct name says more.
"""
import ast
from collections import Counter
from pathlib import Path

import subprocess
import sys

from importlinter import api

ROOT = Path(__file__).resolve().parents[2]
DERIVE = ROOT / "derive"
# the packages of derive's optional extras (pyproject.toml): imported where they are used,
# so that derive runs without them
# PIL (Pillow) comes with matplotlib: the plot extra writes its GIFs with it
EXTRAS = {"matplotlib", "PIL", "scipy", "numba", "heyoka", "dask", "distributed", "xarray", "zarr"}
# derive/cli.py: each command imports its stage when it runs (start-up); derive/__main__.py:
# the CLI imported under a guard, so that Ctrl-C during the imports is one line too
LAZY_MODULES = {"derive/cli.py", "derive/__main__.py"}


def test_the_layers_contract_is_kept():
    """lint-imports, as a developer runs it from the checkout; its report says what broke."""
    code = ("from importlinter.cli import lint_imports_command as lint; "
            "lint.main(['--config', 'pyproject.toml', '--no-cache'])")
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    assert "1 kept, 0 broken" in run.stdout


def test_the_contract_names_every_stage():
    """A new folder of derive/ is placed in the layers on purpose, not left out of them."""
    config = api.read_configuration(str(ROOT / "pyproject.toml"))
    (contract,) = [c for c in config["contracts_options"] if c["type"] == "layers"]
    named = {name.strip() for layer in contract["layers"] for name in layer.replace(":", "|").split("|")}
    packages = {p.parent.name for p in DERIVE.glob("*/__init__.py")}
    modules = {p.stem for p in DERIVE.glob("*.py") if p.stem != "__init__"}
    assert packages | modules <= named, sorted((packages | modules) - named)


def _local_imports():
    for path in sorted(DERIVE.rglob("*.py")):
        rel = str(path.relative_to(ROOT))
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.Import, ast.ImportFrom)) and node.col_offset > 0:
                names = [node.module or ""] if isinstance(node, ast.ImportFrom) else [a.name for a in node.names]
                yield rel, node.lineno, node.level if isinstance(node, ast.ImportFrom) else 0, names


def test_function_local_imports_only_where_needed():
    offenders = [f"{rel}:{line}" for rel, line, level, names in _local_imports()
                 if rel not in LAZY_MODULES and (level or any(n.split(".")[0] not in EXTRAS for n in names))]
    assert offenders == []


def test_no_module_name_repeated_across_folders():
    names = Counter(p.stem for p in DERIVE.rglob("*.py") if p.stem != "__init__")
    assert {n for n, k in names.items() if k > 1} == set()
