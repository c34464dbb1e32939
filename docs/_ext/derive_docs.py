"""The docs' generated parts: what the code already says is rendered from it at build time,
so no page can go stale.

A page writes a marker, ``<!-- derive:NAME -->`` on a line of its own, and the build
(Sphinx's ``source-read`` event) replaces it by the Markdown that ``GENERATORS[NAME]``
makes: the command line from derive's argparse parser, the exit statuses, the API from
``derive.__all__``, the run contract's tables (methods, statuses, options, the precision
ladder) from derive/codegen/contract.py, the seeds' errata from derive/verification/errata.py,
and the changelog from git.  ``expand(text)`` is the same substitution for the tests.
"""
from __future__ import annotations

import argparse
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MARKER = re.compile(r"^<!-- derive:([a-z-]+)(?: ([\w./-]+))? -->$", re.MULTILINE)
GENERATED_C = ROOT / "generated" / "c"
BENCH_RESULTS = ROOT / "bench" / "results"


def _cell(text) -> str:
    """A Markdown table cell: pipes escaped, on one line."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def _escape(text: str) -> str:
    """Commit subjects as Markdown text: their * _ ` < are literal characters."""
    return re.sub(r"([*_`<\[\]\\])", r"\\\1", text)


def _table(header: tuple, rows) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def _subcommands(parser: argparse.ArgumentParser):
    """(name, help, subparser) of each subcommand, in the parser's order."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help for a in action._choices_actions}
            for name, sub in action.choices.items():
                yield name, helps.get(name, ""), sub


def _argument_rows(parser: argparse.ArgumentParser):
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)):
            continue
        name = ", ".join(f"`{s}`" for s in action.option_strings) or f"`{action.dest}`"
        if action.nargs in ("*", "?"):
            name += " (optional)" if action.nargs == "?" else " (any number)"
        text = action.help or ""
        if action.choices and not isinstance(action.choices, dict):
            text += " (one of " + ", ".join(f"`{c}`" for c in action.choices) + ")"
        if action.default not in (None, False, argparse.SUPPRESS) and action.option_strings:
            text += f" (default `{action.default}`)"
        yield name, text


def cli() -> str:
    """Every subcommand of ``derive``: its usage line, what it does and every argument."""
    from derive.cli import build_parser
    parser = build_parser()
    parts = [f"`derive --help`: {parser.description}\n",
             _table(("argument", "meaning"), _argument_rows(parser))]
    for name, text, sub in _subcommands(parser):
        usage = " ".join(sub.format_usage().split())
        usage = usage.removeprefix("usage: ")
        parts.append(f"### `derive {name}`\n\n{text[0].upper() + text[1:]}.\n\n```text\n{usage}\n```\n")
        rows = list(_argument_rows(sub))
        if rows:
            parts.append(_table(("argument", "meaning"), rows))
    return "\n".join(parts)


def exit_statuses() -> str:
    """The exit statuses, as ``derive --help`` states them (derive/cli.py, EXIT_CODES)."""
    from derive.cli import EXIT_CODES
    text = EXIT_CODES.removeprefix("exit status: ")
    rows = [(m.group(1), m.group(2).strip()) for m in re.finditer(r"(\d+) ([^;]+)", text)]
    return _table(("exit status", "meaning"), rows)


def api() -> str:
    """One autodoc entry per name in ``derive.__all__``: functions, exceptions, the sweep function.

    In an ``{eval-rst}`` block: autodoc writes reStructuredText, which MyST would read as Markdown.
    """
    import inspect

    import derive
    entries = []
    for name in sorted(derive.__all__, key=lambda n: (not n[0].islower(), n)):
        value = getattr(derive, name)
        if name == "__version__":
            entries.append(f".. py:data:: derive.__version__\n\n   The version of derive, ``{value}``.")
        elif inspect.isclass(value) and issubclass(value, BaseException):
            entries.append(f".. autoexception:: derive.{name}\n   :show-inheritance:")
        elif inspect.isclass(value):
            entries.append(f".. autoclass:: derive.{name}\n   :members:")
        elif inspect.ismodule(value):            # derive.sweep: the stage, callable as its function
            entries.append(f".. autofunction:: derive.sweep.{name}")
        else:
            entries.append(f".. autofunction:: derive.{name}")
    return "```{eval-rst}\n" + "\n\n".join(entries) + "\n```\n"


def methods() -> str:
    from derive.codegen.contract import METHOD_TABLE
    return _table(("method", "kind", "order", "implicit", "on the atlas", "what"),
                  ((f"`{m.name}`", m.kind, m.order, "yes" if m.implicit else "no",
                    "yes" if m.atlas else "no", m.doc) for m in METHOD_TABLE)) + \
        "\nand `taylor`: Taylor's method, generated per model, order from rtol (below).\n"


def statuses() -> str:
    """The status codes, their descriptions filled in as the generated headers' are."""
    from derive.codegen.contract import STATUS_TABLE
    from derive.codegen.integrators import NEWTON_THETA_DIVERGE, NEWTON_THETA_MAX
    return _table(("code", "C macro", "`status_name`", "meaning"),
                  ((s.code, f"`<MODEL>_INTEGRATE_{s.macro}`", s.name,
                    " ".join(s.doc).format(theta_max=NEWTON_THETA_MAX, theta_diverge=NEWTON_THETA_DIVERGE))
                   for s in STATUS_TABLE))


def options() -> str:
    from derive.codegen.contract import OPTIONS, INFO
    return (_table(("option", "C type", "default", "meaning"),
                   ((f"`{f.name}`", f"`{f.ctype}`", f"`{f.c_default or 'SINE_MIN'}`", f.doc) for f in OPTIONS))
            + "\nA run's `info` struct:\n\n"
            + _table(("field", "C type", "meaning"),
                     ((f"`{f.name}`", f"`{f.ctype}`", f.doc.replace("{M}", "<MODEL>")) for f in INFO)))


def precisions() -> str:
    from derive.codegen.contract import PRECISION_TABLE
    return _table(("`dtype=`", "scene `scalar =`", "C type", "entry suffix", "unit roundoff",
                   "default rtol", "methods"),
                  ((f"`{p.key}`", f"`{p.scalar}`", f"`{p.ctype}`", f"`{p.suffix or '(none)'}`",
                    f"{p.eps:.3g}" if p.eps else "the platform's", f"{p.default_rtol:g}",
                    "taylor only" if p.taylor_only else "all") for p in PRECISION_TABLE))


def charts() -> str:
    """Every chart (joint) of derive/model/catalog/charts.toml, as the model reader loads it."""
    import tomllib

    from derive.model.description import charts_file, load_chart
    names = list(tomllib.loads(charts_file().read_text()))
    rows = []
    for name in names:
        chart = load_chart(name)
        rows.append((f"`{name}`", chart.dimension, ", ".join(f"`{c}`" for c in chart.coordinates),
                     "(" + ", ".join(f"`{u}`" for u in chart.unit) + ")",
                     f"`{chart.polar_sine}` = 0" if chart.polar_sine else "none", chart.source))
    return _table(("`chart =`", "`dimension`", "coordinates", "unit vector of the link", "poles", "source"),
                  rows)


def catalogue() -> str:
    """The catalogue's models with their states and parameters, as derive loads them."""
    from derive.model import load_model, model_names
    rows = []
    for name in model_names():
        model = load_model(name)
        rows.append((f"`{name}`", model.title, ", ".join(f"`{s}`" for s in model.state_names),
                     ", ".join(f"`{q}`" for q in model.parameters)))
    return _table(("model", "what", "state", "parameters"), rows)


def c_header(name: str) -> str:
    """A generated header's own description (its leading comment) and every prototype in it."""
    text = (GENERATED_C / name).read_text()
    comment = text[text.index("/*") + 2:text.index("*/")]
    lines = [line.removeprefix(" *").removeprefix(" ") for line in comment.splitlines()]
    prototypes = [line for line in text.splitlines()
                  if re.match(r"^[a-z][\w\s*]*\b\w+\(.*\);$", line) and not line.startswith("typedef")]
    structs = re.findall(r"typedef struct \w+ \{.*?\} \w+;", text, re.DOTALL)
    return (f"`generated/c/{name}`, as generated:\n\n```text\n" + "\n".join(lines).strip() + "\n```\n\n"
            + ("```c\n" + "\n\n".join(structs) + "\n```\n\n" if structs else "")
            + "```c\n" + "\n".join(prototypes) + "\n```\n")


def bench(name: str) -> str:
    """A file the benchmark wrote into bench/results/, as it is: its headings two levels down
    (under a section of the page), its images shown from the copies the build publishes
    (docs/_ext/derive_figures.py)."""
    text = (BENCH_RESULTS / name).read_text()
    text = re.sub(r"^(#+) ", r"##\1 ", text, flags=re.MULTILINE)
    return re.sub(r"!\[([^\]]*)\]\(([\w.-]+\.png)\)",
                  r'<img src="_figures/bench/\2" alt="\1" width="100%">', text)


def errata() -> str:
    from derive.verification.errata import errata_markdown
    return errata_markdown().strip() + "\n"


def changelog() -> str:
    """The commits of the branch, newest first, from git (the themes are the page's prose)."""
    try:
        log = subprocess.run(["git", "-C", str(ROOT), "log", "--no-merges", "--format=%as %s"],
                             capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return "(not a git checkout: the commit list is in the source repository)\n"
    lines = [line.split(" ", 1) for line in log.splitlines() if " " in line]
    return "\n".join(f"- {day}: {_escape(subject)}" for day, subject in lines) + "\n"


GENERATORS = {"cli": cli, "exit-statuses": exit_statuses, "api": api, "methods": methods,
              "statuses": statuses, "options": options, "precisions": precisions,
              "errata": errata, "c-header": c_header, "bench": bench, "charts": charts, "catalogue": catalogue, "changelog": changelog}


def expand(text: str) -> str:
    """The page's Markdown with every marker replaced by what it stands for."""
    def one(match):
        name, argument = match.group(1), match.group(2)
        if name not in GENERATORS:
            raise ValueError(f"unknown docs marker derive:{name}")
        return GENERATORS[name](argument) if argument else GENERATORS[name]()
    return MARKER.sub(one, text)


def _source_read(app, docname, source):
    source[0] = expand(source[0])


def setup(app):
    app.connect("source-read", _source_read)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
