"""`derive ...` in the test process: derive.cli.main with what it prints captured.

For the tests that check what a command prints, writes and returns, not how a process
starts or ends: a `python -m derive` costs a second of interpreter start and imports
before its first line of work.  The exit status through `python -m derive`, a PATH
without tools, signals and the environment are checked with real processes
(tests/system/test_cli_errors.py, tests/system/test_cli.py and others keep theirs).
"""
from __future__ import annotations

import contextlib
import io
import subprocess
import warnings
from pathlib import Path

from derive.cli import main

# the interpreter's default warning filters (what `python -m derive` shows on stderr):
# every warning once per place, but deprecations only when __main__ raises them
_DEFAULT_IGNORED = (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning)


def derive_cli(*args, cwd: str | Path | None = None) -> subprocess.CompletedProcess:
    """Run `derive *args` in this process, as `python -m derive` would in `cwd`.

    Parameters
    ----------
    *args : str
        The command line after ``derive``.
    cwd : path-like, optional
        The folder to run in (relative paths of the command are read from it).

    Returns
    -------
    subprocess.CompletedProcess
        returncode (main's status, or the SystemExit code of an argparse refusal), and
        stdout and stderr as text; the warnings the run raised are on stderr as the
        interpreter would print them.
    """
    argv = [str(a) for a in args]
    out, err = io.StringIO(), io.StringIO()
    with contextlib.ExitStack() as stack:
        if cwd is not None:
            stack.enter_context(contextlib.chdir(cwd))
        caught = stack.enter_context(warnings.catch_warnings(record=True))
        warnings.simplefilter("default")
        for category in _DEFAULT_IGNORED:
            warnings.simplefilter("ignore", category)
        stack.enter_context(contextlib.redirect_stdout(out))
        stack.enter_context(contextlib.redirect_stderr(err))
        try:
            status = main(argv)
        except SystemExit as exc:          # argparse: --help, --version, a bad command line
            status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    shown = "".join(warnings.formatwarning(w.message, w.category, w.filename, w.lineno) for w in caught)
    return subprocess.CompletedProcess(["derive", *argv], status, out.getvalue(), err.getvalue() + shown)
