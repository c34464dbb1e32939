"""`derive generate`: regenerate everything under generated/, or check it is current."""
from __future__ import annotations

import difflib
from dataclasses import dataclass
from pathlib import Path

from ..model import model_names
from .backends import managed_suffixes
from .emit import COMPILED, compiled_templates
from .sources import ATLAS, PREAMBLE, PROVENANCE, SHARED, render, render_fresh
from .. import paths
from ..paths import VERSION as __version__
import sympy
import tomllib



def catalogue_names() -> list[str]:
    """What `derive generate` renders by default: every catalogue model, then the atlas."""
    return [*model_names(), ATLAS]


def render_models(names, fresh: bool = False, backends: tuple[str, ...] | None = None) -> dict[str, str]:
    """The generated files of `names` (catalogue names or model files) in the languages
    `backends` (None: the default ones): path -> text; from the cache where it holds them
    (fresh=True: rendered now, the cache unread)."""
    files: dict[str, str] = {}
    if backends is not None:
        backends = tuple(sorted(set(backends)))     # one cache entry per set of backends
    for name in names:
        for rel, text in (render_fresh(name, backends) if fresh else render(name, backends)).items():
            if rel in files and files[rel] != text:
                raise ValueError(f"two models write generated/{rel}")
            files[rel] = text
    return dict(sorted(files.items()))


def render_everything(fresh: bool = False) -> dict[str, str]:
    """Every file of the golden generated/: the catalogue and the atlas."""
    return render_models(catalogue_names(), fresh)


render_all = render_everything


def _existing(out: Path) -> set[str]:
    """Files under generated/ that derive wrote (they start with its preamble).

    Anything else there (hand-written notes, other tools' output) is left alone;
    a file with the preamble that nothing produces any more is stale."""
    found = set()
    for folder, suffixes in managed_suffixes().items():
        d = out / folder
        if d.is_dir():
            for p in d.iterdir():
                if p.is_file() and p.suffix in suffixes:
                    with p.open(errors="replace") as fh:
                        head = fh.read(200)
                    if PROVENANCE.search(head) or PREAMBLE.search(head) or SHARED.search(head):
                        found.add(f"{folder}/{p.name}")
    return found


def write_tree(out: Path, files: dict[str, str], check: bool = False,
               shown: str = "generated", prune: bool = True) -> tuple[list[str], str]:
    """Write `files` into folder `out`; with prune (the golden tree) also remove the files
    derive made there that nothing produces any more, so `out` holds exactly `files`; with
    check=True only compare.  Returns the changed (or stale) paths, as `shown`/<rel>, and
    a unified diff of what writing changes (empty when `out` is current)."""
    out = Path(out)
    changed, diffs = [], []
    for rel in sorted(set(files) | (_existing(out) if prune else set())):
        path = out / rel
        new = files.get(rel)
        old = path.read_text() if path.is_file() else None
        if old == new:
            continue
        name = f"{shown}/{rel}"
        changed.append(name)
        diffs.extend(difflib.unified_diff(
            (old or "").splitlines(keepends=True), (new or "").splitlines(keepends=True),
            fromfile=f"a/{name}" if old is not None else "/dev/null",
            tofile=f"b/{name}" if new is not None else "/dev/null"))
        if not check:
            if new is None:
                path.unlink()
            else:
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(new)
    return changed, "".join(diffs)


def write_compiled_templates(check: bool = False) -> tuple[list[str], str]:
    """templates/compiled/ made anew from the templates (`compiled_templates`), beside the
    golden generated/ (a checkout's package folder; with check=True only compared): the
    changed paths, as templates/compiled/<file>, and their diff (`write_tree`'s)."""
    folder = paths.templates_dir() / COMPILED
    files = compiled_templates()
    stale = {p.name: None for p in folder.glob("tmpl_*.py") if p.name not in files} if folder.is_dir() else {}
    changed, diff = write_tree(folder, files, check=check, shown=f"templates/{COMPILED}", prune=False)
    for name in sorted(stale):                      # a template removed or renamed
        changed.append(f"templates/{COMPILED}/{name}")
        if not check:
            (folder / name).unlink()
    return changed, diff


@dataclass
class Written:
    """What `write_models` did.

    Parameters
    ----------
    files : dict
        Every file of the models: path in the folder -> text.
    changed : list of str
        The paths written (with check: those that differ), as the folder is shown.
    diff : str
        Their unified diff.
    note : str or None
        A note when another SymPy made the folder (`manifest_note`).
    """
    files: dict[str, str]
    changed: list[str]
    diff: str
    note: str | None


def write_models(out: Path, names, backends: tuple[str, ...] | None = None, check: bool = False,
                 prune: bool = False, shown: str | None = None, progress=None) -> Written:
    """`derive generate`: render `names` in the languages `backends` into folder `out`.

    Parameters
    ----------
    out : pathlib.Path
        The folder (out/c/, out/numpy/, ... one per backend).
    names : list of str
        Catalogue model names, model files' names, or an atlas.
    backends : tuple of str, optional
        Backend names (None: the default ones, `backends.default_names`).
    check : bool, optional
        Write nothing, only compare.
    prune : bool, optional
        Also remove the files derive made in `out` that nothing produces any more (the
        golden tree; an --out folder keeps other models' files).
    shown : str, optional
        How `out` is named in the changed paths and the diff (default: `out` itself).
    progress : callable, optional
        Called as progress(i, total, name) before model `name` is rendered.

    Returns
    -------
    Written
        The files, the changed paths, the diff and the manifest note (`manifest_note`,
        read before the manifest is rewritten).

    Raises
    ------
    UsageError
        An unknown backend name.
    ModelError
        An unknown model.
    WriteError
        A file the system refuses to write.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as out:
    ...     written = write_models(Path(out), ["planar"], ("jax",))
    ...     sorted(written.files), sorted(written.changed) == [f"{out}/{f}" for f in sorted(written.files)]
    (['jax/planar_jax.py', 'jax/planar_linearize_jax.py'], True)
    """
    out = Path(out)
    files: dict[str, str] = {}
    for i, name in enumerate(names, 1):
        if progress is not None:
            progress(i, len(names), name)
        files.update(render_models([name], backends=backends))
    changed, diff = write_tree(out, files, check=check, shown=str(out) if shown is None else shown,
                               prune=prune)
    note = manifest_note(out)
    if not check:
        write_manifest(out)
    return Written(files, changed, diff, note)


def generate_all(root: Path, check: bool = False,
                 files: dict[str, str] | None = None) -> tuple[list[str], str]:
    """Regenerate root/generated/ (the catalogue's golden files); with check=True only
    compare.  `files` (the output of render_everything()) skips rendering when at hand."""
    return write_tree(Path(root) / "generated", render_everything() if files is None else files, check)


# -- the manifest: which derive and SymPy made a generated tree ----------------------

MANIFEST = "MANIFEST.toml"


def write_manifest(out: Path) -> None:
    """out/MANIFEST.toml: the derive and SymPy versions that wrote this tree (the files
    themselves name only the derive version, so regeneration under one SymPy is
    byte-identical)."""
    text = (f"# Written by `derive generate`: what made the files beside it.\n"
            f'derive = "{__version__}"\nsympy = "{sympy.__version__}"\n')
    path = Path(out) / MANIFEST
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)


def manifest_note(out: Path) -> str | None:
    """A note when the SymPy in use is not the one that made `out` (its printers and CSE
    ordering shape the files), or None."""

    path = Path(out) / MANIFEST
    if not path.is_file():
        return None
    try:
        made = tomllib.loads(path.read_text()).get("sympy")
    except tomllib.TOMLDecodeError:
        return f"{path} is not valid TOML"
    if made and made != sympy.__version__:
        return (f"{out} was generated with SymPy {made}, this is SymPy {sympy.__version__}: "
                f"differences may come from SymPy's printers and CSE, not from derive")
    return None
