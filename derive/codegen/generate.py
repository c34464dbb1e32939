"""`derive generate`: regenerate everything under generated/, or check it is current."""
from __future__ import annotations

import difflib
from pathlib import Path

from ..derivation import derive
from ..model import model_names
from .emit import cse_file
from .languages import LANGUAGES
from .spec import model_spec

MANAGED = {"c": (".c", ".h"), "numpy": (".py",)}   # files generate_all owns under generated/


def render_model(name: str) -> dict[str, str]:
    """All generated files of one model: relative path under generated/ -> text."""
    spec = model_spec(derive(name))
    bodies = cse_file(spec)
    files: dict[str, str] = {}
    for lang in LANGUAGES:
        files.update(lang.files(spec, bodies))
    return files


def render_all() -> dict[str, str]:
    files: dict[str, str] = {}
    for name in model_names():
        files.update(render_model(name))
    return dict(sorted(files.items()))


def _existing(out: Path) -> set[str]:
    found = set()
    for folder, suffixes in MANAGED.items():
        d = out / folder
        if d.is_dir():
            found |= {f"{folder}/{p.name}" for p in d.iterdir() if p.is_file() and p.suffix in suffixes}
    return found


def generate_all(root: Path, check: bool = False) -> tuple[list[str], str]:
    """Regenerate root/generated/; with check=True only compare.

    Returns the changed (or stale) paths, relative to root, and a unified diff of
    what regeneration changes (empty when generated/ is current).
    """
    root = Path(root)
    out = root / "generated"
    files = render_all()
    changed, diffs = [], []
    for rel in sorted(set(files) | _existing(out)):
        path = out / rel
        new = files.get(rel)
        old = path.read_text() if path.is_file() else None
        if old == new:
            continue
        shown = f"generated/{rel}"
        changed.append(shown)
        diffs.extend(difflib.unified_diff(
            (old or "").splitlines(keepends=True), (new or "").splitlines(keepends=True),
            fromfile=f"a/{shown}" if old is not None else "/dev/null",
            tofile=f"b/{shown}" if new is not None else "/dev/null"))
        if not check:
            if new is None:
                path.unlink()
            else:
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(new)
    return changed, "".join(diffs)
