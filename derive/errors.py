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
    """Anything derive reports as one line; `exit_status` is the command line's code."""
    exit_status = 1


class InputError(DeriveError, ValueError):
    """Bad input from the user (exit status 2)."""
    exit_status = 2


class ToolMissingError(DeriveError):
    """A program derive needs is not installed (exit status 2)."""
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
    """A model or chart description is wrong; the message names the file and the key."""


class SceneError(InputError):
    """A scene file is wrong; the message names the key."""


class SimulationInputError(InputError):
    """Bad arguments to derive.simulate (one line, names the problem)."""


class SpecError(InputError):
    """A model the code generator cannot handle; the message names the model and kernel."""


class PrintError(SpecError):
    """An expression a target language's printer cannot print."""


class BuildError(DeriveError):
    """Compiling or loading generated code failed (a compiler error, a missing file)."""


class CompilerMissingError(BuildError, ToolMissingError):
    """No C compiler: `CC` unset and neither cc, gcc nor clang on PATH."""
    exit_status = 2


class SimulationError(DeriveError):
    """A run that stopped before its end (raise_for_status)."""


class VerificationError(DeriveError):
    """A verification that could not run (not a formula that failed: that is a verdict)."""
