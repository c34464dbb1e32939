"""The code examples of the README and of docs/*.md, read as the tests run them.

A page's fenced blocks are its examples; each is run by its language:

- ``sh``: every block of a page, in order, in one bash script (``set -euo pipefail``) in a
  scratch copy of the page's folder, where ``derive`` is this checkout's ``python -m derive``
  and each ``python`` block in between runs as ``python -`` at its place in the page;
- ``toml``: a complete model, scene or sweep file, read by derive's own reader (a model has
  ``[[links]]``, a sweep ``[axes]``, a scene ``[pendulum]``);
- ``c``: compiled with the generated C of the catalogue (a fragment without ``main`` is
  wrapped in one) and run.

``text`` blocks are output and reference, never run.  A block that cannot run in a test
says why on the line before it, ``<!-- not run: REASON -->``; the tests require a reason,
and that only these few are exempt.  Blocks inside a directive (``{literalinclude}``,
``{toctree}``) are Sphinx's, not examples: the files a literalinclude shows are run by the
page's own commands.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
README = ROOT / "README.md"
RUN_LANGUAGES = ("sh", "python", "toml", "c")
NOT_RUN = re.compile(r"^<!-- not run: (.+) -->$")
FENCE = re.compile(r"^(\s*)```(\S*)\s*$")
# The folder a page's commands run in (a scratch copy of it): the tutorial's are the
# tutorial's own files; the other pages' examples name docs/tutorial/ as tutorial/ or,
# where they continue the tutorial (study.toml), run beside its files.
PAGE_FOLDER = {"tutorial.md": "tutorial", "sweeps.md": "tutorial"}


@dataclass(frozen=True)
class Block:
    page: Path
    line: int             # 1-based line of the opening fence
    language: str
    code: str
    not_run: str | None   # the reason it is not run, or None


def pages() -> list[Path]:
    """The README and every page of the docs."""
    return [README] + sorted(DOCS.glob("*.md"))


def blocks(page: Path) -> list[Block]:
    """The fenced code blocks of a page, in order (not those of Sphinx directives)."""
    lines = page.read_text().splitlines()
    found, i = [], 0
    while i < len(lines):
        match = FENCE.match(lines[i])
        if not match or match.group(2).startswith("{"):
            if match:                                   # a directive: skip to its closing fence
                i += 1
                while i < len(lines) and lines[i].strip() != "```":
                    i += 1
            i += 1
            continue
        indent, language, start = match.group(1), match.group(2) or "text", i
        body = []
        i += 1
        while i < len(lines) and lines[i].strip() != "```":
            body.append(lines[i][len(indent):] if lines[i].startswith(indent) else lines[i])
            i += 1
        previous = lines[start - 1].strip() if start else ""
        reason = NOT_RUN.match(previous)
        found.append(Block(page, start + 1, language, "\n".join(body) + "\n",
                           reason.group(1) if reason else None))
        i += 1
    return found


def runnable(page: Path) -> list[Block]:
    return [b for b in blocks(page) if b.language in RUN_LANGUAGES and b.not_run is None]


def shell_script(page: Path, python: str) -> str | None:
    """The page's sh and python examples as one bash script, in the page's order (None: none)."""
    parts = []
    for block in runnable(page):
        if block.language == "sh":
            parts.append(f"# {page.name}:{block.line}\n{block.code}")
        elif block.language == "python":
            parts.append(f"# {page.name}:{block.line}\n{python} - <<'DERIVE_DOCS_PYTHON'\n"
                         f"{block.code}DERIVE_DOCS_PYTHON\n")
    if not parts:
        return None
    prologue = (f"set -euo pipefail\nderive() {{ {python} -m derive \"$@\"; }}\n"
                f"python3() {{ {python} \"$@\"; }}\nset -x\n")
    return prologue + "\n".join(parts)


def c_program(block: Block) -> str:
    """A C block as a whole program: a fragment's #include lines on top, the rest in main."""
    if "main(" in block.code:
        return block.code
    lines = block.code.splitlines()
    head = [line for line in lines if line.startswith("#")]
    body = [line for line in lines if not line.startswith("#")]
    return "\n".join(head + ["int main(void)", "{"] + ["    " + line for line in body]
                     + ["    return 0;", "}"]) + "\n"
