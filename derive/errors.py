"""One error hierarchy: every failure derive expects is a DeriveError.

The command line catches DeriveError and prints its message as one line.  The
exit status says whose problem it is:

  2  bad input or a missing tool (a wrong key, an unknown model, no C compiler,
     no pdflatex, an unwritable output path): the user can fix it and retry;
  1  a run that started and failed (a stiff stop, a compiler error in
     generated code, a failed verification).

Each stage has its own subclass, so a caller of the Python API can catch one
stage's failures (`except derive.ModelError`) or all of them (`except
derive.DeriveError`).  The input errors are also ValueErrors, as Python users
expect of bad arguments.
"""
from __future__ import annotations


class DeriveError(Exception):
    """Anything derive reports as one line; `exit_status` is the command line's code.

    The base of every error derive expects, raised by no stage itself: catch it to catch
    them all.  Its message is one line naming the problem (the command line prints it as
    ``derive: error: ...``); `exit_status` is 2 for what the user can fix (an input, a
    missing tool), 1 for a run that started and failed.

    Examples
    --------
    >>> import derive
    >>> try:
    ...     derive.load_model("no_such_model")
    ... except derive.DeriveError as exc:
    ...     print(type(exc).__name__, exc.exit_status)
    ModelError 2
    """
    exit_status = 1


class InputError(DeriveError, ValueError):
    """Bad input from the user (exit status 2).

    Raised by every stage that reads what the user gives (models, scenes, sweep files, the
    arguments of derive.simulate, derive.linearize, ...), mostly as one of its subclasses
    (ModelError, SceneError, SimulationInputError).  A DeriveError, and also a ValueError,
    as Python users expect of bad arguments.

    Examples
    --------
    >>> import derive
    >>> derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 1.0], [1, 1, 1, 1, 9.81],  # doctest: +ELLIPSIS
    ...                 method="euler", backend="numpy")
    Traceback (most recent call last):
    ...
    derive.errors.SimulationInputError: unknown method 'euler' (known: rk4, dopri5, ...)
    >>> issubclass(derive.InputError, ValueError)
    True
    """
    exit_status = 2


class ToolMissingError(DeriveError):
    """A program derive needs is not installed (exit status 2).

    Raised where a stage calls a program or an optional package first: the C compiler
    (the runtime's build, as CompilerMissingError), pdflatex (`derive latex --pdf`), the
    sweep extra (derive.sweep, SimulationResult.to_xarray).  The message names what to
    install.  A DeriveError.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from derive.runtime.loader import build
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     source = Path(folder, "hello.c")
    ...     _ = source.write_text("int hello(void) { return 1; }")
    ...     _ = source.with_suffix(".h").write_text("int hello(void);")
    ...     build(source, cc="no-such-compiler", cache=Path(folder))
    Traceback (most recent call last):
    ...
    derive.errors.CompilerMissingError: no C compiler found: 'no-such-compiler' is not on PATH; set CC or install gcc or clang
    >>> issubclass(CompilerMissingError, ToolMissingError)
    True
    """
    exit_status = 2


class PackageDataError(DeriveError):
    """derive's own files (templates, catalogue, tableaus) are missing: a broken install."""
    exit_status = 2


class CacheError(DeriveError):
    """The cache directory cannot be used safely (another owner, writable by others)."""
    exit_status = 2


class WriteError(DeriveError, OSError):
    """A file could not be written (no space left, a quota, an I/O error); the message names
    the path and the system's reason (exit status 2: free space or choose another place).
    Also an OSError, for callers that handle the system's errors."""
    exit_status = 2


class UsageError(InputError):
    """A wrong command-line argument or an unwritable output path."""


class ModelError(InputError):
    """A model or chart description is wrong; the message names the file and the key.

    Raised by the model stage (derive/model/) as it reads a catalogue name or a model file:
    an unknown name (the message lists the known ones), a missing or wrong key.  An
    InputError, so also a ValueError (exit status 2).

    Examples
    --------
    >>> import derive
    >>> derive.load_model("no_such_model")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    derive.errors.ModelError: unknown model 'no_such_model' (known: compound, planar, ...)
    """


class SceneError(InputError):
    """A scene file is wrong; the message names the key.

    Raised by the scene stage (derive/scene/) and the sweep stage (derive/sweep/, whose
    files are scenes with axes) as they read a file: a missing file, an unknown or
    missing key, a value out of range.  An InputError, so also a ValueError (exit status 2).

    Examples
    --------
    >>> import derive
    >>> derive.sweep("no_such_sweep.toml", workers=0)
    Traceback (most recent call last):
    ...
    derive.errors.SceneError: sweep file 'no_such_sweep.toml' does not exist
    """


class SimulationInputError(InputError):
    """Bad arguments to derive.simulate (one line, names the problem).

    Raised by the runtime stage (derive.simulate, derive.ensemble, derive.scipy_rhs,
    derive.linearize, derive.equilibria) before a run starts: an unknown model or method,
    a missing parameter, a state of the wrong size.  An InputError, so also a ValueError
    (exit status 2).

    Examples
    --------
    >>> import derive
    >>> derive.simulate("nope", [1.0, 0.5, 0, 0], [0.0, 1.0], [1, 1, 1, 1, 9.81])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    derive.errors.SimulationInputError: unknown model 'nope' (known: compound, planar, ...); or 'spherical' for the chart atlas
    >>> derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 1.0], {"m1": 1.0}, backend="numpy")
    Traceback (most recent call last):
    ...
    derive.errors.SimulationInputError: missing parameter 'm2' for model 'planar' (parameters: m1, m2, l1, l2, g)
    """


class SpecError(InputError):
    """A model the code generator cannot handle; the message names the model and kernel."""


class PrintError(SpecError):
    """An expression a target language's printer cannot print."""


class BuildError(DeriveError):
    """Compiling or loading generated code failed (a compiler error, a missing file).

    Raised by the runtime stage's build (derive/runtime/loader.py) when derive.simulate,
    derive.ensemble or derive.scipy_rhs first needs a model's compiled library; the message
    holds the compiler's command and output.  A DeriveError (exit status 1); its subclass
    CompilerMissingError (exit status 2) is raised when there is no compiler at all.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from derive.runtime.loader import build
    >>> with tempfile.TemporaryDirectory() as folder:  # doctest: +ELLIPSIS
    ...     source = Path(folder, "broken.c")
    ...     _ = source.write_text("int broken(void) { return }")
    ...     _ = source.with_suffix(".h").write_text("int broken(void);")
    ...     build(source, cache=Path(folder))
    Traceback (most recent call last):
    ...
    derive.errors.BuildError: compiling broken.c failed (...
    """


class CompilerMissingError(BuildError, ToolMissingError):
    """No C compiler: `CC` unset and neither cc, gcc nor clang on PATH.

    Raised by the runtime stage's build (derive/runtime/loader.py) before it compiles a
    model's library, also when `CC` names a program that is not on PATH.  Both a
    BuildError and a ToolMissingError (exit status 2).  derive.simulate(..., backend="numpy")
    and derive.scipy_rhs run without a compiler.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from derive.runtime.loader import build
    >>> with tempfile.TemporaryDirectory() as folder:  # doctest: +ELLIPSIS
    ...     source = Path(folder, "hello.c")
    ...     _ = source.write_text("int hello(void) { return 1; }")
    ...     _ = source.with_suffix(".h").write_text("int hello(void);")
    ...     build(source, cc="no-such-compiler", cache=Path(folder))
    Traceback (most recent call last):
    ...
    derive.errors.CompilerMissingError: no C compiler found: 'no-such-compiler' is not on PATH; ...
    """
    exit_status = 2


class SimulationError(DeriveError):
    """A run that stopped before its end (raise_for_status).

    derive.simulate itself returns a run that stopped early (r.ok is False, r.status_name
    says why: the step limit, a stiff or unstable stop, a chart's pole);
    SimulationResult.raise_for_status raises this with r.message, which names the time,
    the state and the way out.  A DeriveError (exit status 1: a run that started).

    Examples
    --------
    >>> import derive
    >>> r = derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 10.0], [1, 1, 1, 1, 9.81],
    ...                     max_steps=5, backend="numpy")
    >>> r.ok, r.status_name
    (False, 'maximum number of steps reached')
    >>> r.raise_for_status()  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    derive.errors.SimulationError: integration stopped at t = ...: maximum number of steps reached; state ...
    """


class VerificationError(DeriveError):
    """A verification that could not run (not a formula that failed: that is a verdict)."""
