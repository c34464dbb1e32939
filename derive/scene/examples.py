"""The example scenes and sweeps shipped with derive: their names and titles, read
without the scene stage's imports (for `derive run --list`)."""
from __future__ import annotations

import tomllib

from ..paths import scenes_dir


def example_scenes() -> list[str]:
    """The example scenes shipped with derive (`derive run default`).

    Returns
    -------
    list of str
        The name of every example scene and sweep, sorted.
    """
    return sorted(p.stem for p in scenes_dir().glob("*.toml"))


def example_listing() -> list[tuple[str, str, bool]]:
    """The example scenes and sweeps shipped with derive, for `derive run --list`.

    Returns
    -------
    list of (str, str, bool)
        Each example's name, its title and whether it is a sweep (it has [axes]: run by
        `derive sweep`, the others by `derive run`), by name.
    """
    out = []
    for name in example_scenes():
        table = tomllib.loads((scenes_dir() / f"{name}.toml").read_text())
        out.append((name, str(table.get("title", "")), "axes" in table))
    return out
