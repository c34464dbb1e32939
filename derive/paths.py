"""Every path derive reads or writes, in one place.

Read (package data, shipped in the wheel, found with importlib.resources):
  templates/        the Jinja2 templates of every target language and the LaTeX report
  model/catalog/    the model catalogue and the chart descriptions
  codegen/tableaus/ the Butcher tableaus (*.toml)
  scenes/           the example scenes (`derive run default`)
  measurement/c/    the C sources the benchmark compiles (rhs cost loop, hand-written peers)
  codegen/backends/c/library/   the integrators' C library, copied beside generated C
  codegen/backends/numpy/library/   the NumPy one, copied beside generated NumPy

Written (only where the user says):
  the cache         cache_dir(): derivations, verdicts, rendered sources, compiled libraries;
                    $DERIVE_CACHE_DIR, else $XDG_CACHE_HOME/derive, else ~/.cache/derive
  an output folder  given on the command line or in a scene
  generated/        the catalogue's golden files, rewritten only by `derive generate` without
                    --out, and only inside a source checkout (checkout_root())
"""
from __future__ import annotations


import atexit
import os
import shutil
import stat
import sys
import tempfile
from functools import cache
from importlib import resources
from pathlib import Path

from .errors import CacheError, PackageDataError, WriteError

# The package's version, here at the bottom of the house so that every stage can stamp
# what it writes with it without importing the package face (derive/__init__.py).
VERSION = "0.2.0"
BENCH_OUT = "derive-bench"     # `derive bench` writes here (relative to the current directory)


@cache
def package_root() -> Path:
    """The installed package's folder (a wheel installs it as plain files)."""
    root = Path(str(resources.files("derive")))
    if not root.is_dir():
        raise PackageDataError(f"derive is installed as {root}, not as a folder; "
                               f"install it with pip from a wheel or a checkout")
    return root


def package_data(*parts: str) -> Path:
    """A folder or file of derive's package data; a missing one is a broken install."""
    path = package_root().joinpath(*parts)
    if not path.exists():
        raise PackageDataError(f"derive's package data is missing {'/'.join(parts)} "
                               f"(looked in {package_root()}); reinstall derive")
    return path


def templates_dir() -> Path:
    return package_data("templates")


def catalog_dir() -> Path:
    return package_data("model", "catalog")


def tableau_file(name: str) -> Path:
    return package_data("codegen/tableaus", name)


def scenes_dir() -> Path:
    return package_data("scenes")


def bench_c_dir() -> Path:
    return package_data("measurement", "c")


def c_library_file(name: str) -> Path:
    """A file of the integrators' hand-written C library (derive_integrators.h, ...)."""
    return package_data("codegen", "backends", "c", "library", name)


def numpy_library_file(name: str) -> Path:
    """A file of the integrators' hand-written NumPy library (derive_integrators.py)."""
    return package_data("codegen", "backends", "numpy", "library", name)


@cache
def checkout_root() -> Path | None:
    """The source checkout this package runs from, or None for an installed wheel.

    A checkout is the folder above the package that holds this project's
    pyproject.toml and the golden generated/ folder."""
    root = package_root().parent
    project = root / "pyproject.toml"
    if (root / "generated").is_dir() and project.is_file() and 'name = "derive"' in project.read_text():
        return root
    return None


def replace_file(path: Path, write, mode: int | None = None) -> None:
    """Write a file through a temporary one beside it, then rename it into place: a reader
    never sees a half-written file, a concurrent writer of the same content wins the race
    harmlessly, and a symbolic link planted at `path` is replaced, not written through.
    `write(tmp)` writes the temporary file (its suffix is the final one, for writers that
    go by it); `mode` sets its permissions (mkstemp makes it 0600).
    A write the system refuses (no space left, a quota, an I/O error) leaves nothing behind
    and is a WriteError naming `path` and the reason."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}-", suffix=path.suffix)
    except OSError as exc:
        raise write_error(path, exc) from None
    os.close(fd)
    try:
        write(Path(tmp))
        if mode is not None:
            os.chmod(tmp, mode)
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise write_error(path, exc) from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_error(path: Path, exc: OSError) -> WriteError:
    """The one-line error of a refused write: the path and the system's reason."""
    if isinstance(exc, WriteError):
        return exc
    return WriteError(f"cannot write '{path}': {exc.strerror or exc}")


def cache_dir() -> Path:
    """The cache: created private (0700); one owned by another user or writable by others
    is refused (derive loads compiled code from it), in one line.  One that cannot be
    written (a read-only mount, no write permission) is replaced, for this process, by a
    private temporary cache removed at exit, with one note on stderr: the run works,
    computing what it needs, and nothing is reused or kept."""
    root = os.environ.get("DERIVE_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "derive")
    return _checked_cache(root)


@cache
def _checked_cache(root: str) -> Path:
    path = Path(root)
    try:
        path.mkdir(parents=True, exist_ok=True, mode=0o700)
        st = path.stat()
    except OSError as exc:
        raise CacheError(f"cannot use the cache directory '{path}': {exc.strerror or exc}; "
                         f"set DERIVE_CACHE_DIR to a folder of yours") from None
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        raise CacheError(f"the cache directory '{path}' belongs to another user: derive loads compiled "
                         f"code from it; set DERIVE_CACHE_DIR to a folder of your own")
    if st.st_mode & 0o022:
        raise CacheError(f"the cache directory '{path}' is writable by others (mode "
                         f"{st.st_mode & 0o777:o}): derive loads compiled code from it; "
                         f"chmod go-w it or set DERIVE_CACHE_DIR to a private folder")
    try:
        fd, probe = tempfile.mkstemp(dir=path, prefix=".write-probe-")
    except OSError as exc:
        return _temporary_cache(path, exc)
    os.close(fd)
    os.unlink(probe)
    return path


def _temporary_cache(path: Path, exc: OSError) -> Path:
    temporary = Path(tempfile.mkdtemp(prefix="derive-cache-"))     # 0700, ours
    atexit.register(shutil.rmtree, temporary, ignore_errors=True)
    print(f"derive: note: the cache directory '{path}' is not writable ({exc.strerror or exc}); "
          f"working in a temporary cache removed at exit (nothing is reused or kept)", file=sys.stderr)
    return temporary


def writable_dir(path: Path) -> Path:
    """Create `path` if needed and prove it writable, before long work.

    Parameters
    ----------
    path : Path
        An output folder the user named.

    Returns
    -------
    Path
        `path`, now an existing folder this process can write into.

    Raises
    ------
    OSError
        When it cannot be made or written.
    """
    path.mkdir(parents=True, exist_ok=True)
    # a probe of its own (not a fixed name): concurrent runs into one folder do not race
    fd, probe = tempfile.mkstemp(dir=path, prefix=".derive-write-test-")
    os.close(fd)
    os.unlink(probe)
    return path


# -- a user's input file (a model, a scene, a sweep): a regular file of bounded size ---------
# A device (/dev/zero), a FIFO, a socket or a directory is refused before anything is read,
# and so is a file larger than MAX_BYTES: an input file of derive is a page of TOML.  The
# file is opened without blocking (a FIFO swapped in after the check would otherwise wait
# for a writer) and checked again on the open descriptor, then read to at most
# MAX_BYTES + 1 bytes.

MAX_BYTES = 1 << 20          # 1 MiB


def _short(path: Path) -> str:
    text = str(path)
    return text if len(text) <= 120 else text[:100] + "..." + text[-15:]


def exists(path: Path) -> bool:
    """Path.exists, False for a path the system cannot even look up (a name too long)."""
    try:
        return path.exists()
    except (OSError, ValueError):
        return False


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a directory"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def read_input_text(path: str | os.PathLike, what: str, error: type[Exception]) -> str:
    """The text of the `what` file at `path` ("model", "scene", "sweep"); `error` (one
    line naming the file) when it does not exist, is no regular file, is too large or is
    not UTF-8 text."""
    path = Path(path)
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise error(f"{what} file '{path}' does not exist") from None
    except OSError as exc:                        # a name too long, a loop of links, ...
        raise error(f"cannot read {what} file {_short(path)!r}: {exc.strerror or exc}") from None
    except ValueError as exc:                     # a NUL in the path
        raise error(f"cannot read {what} file {_short(path)!r}: {exc}") from None
    if not stat.S_ISREG(info.st_mode):
        raise error(f"{what} file '{path}' is {_kind(info.st_mode)}, not a regular file")
    if info.st_size > MAX_BYTES:
        raise error(f"{what} file '{path}' has {info.st_size} bytes (at most {MAX_BYTES}: "
                    f"an input file is a page of TOML)")
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        raise error(f"cannot read {what} file {str(path)!r}: {exc.strerror or exc}") from None
    with os.fdopen(fd, "rb") as f:
        info = os.fstat(f.fileno())
        if not stat.S_ISREG(info.st_mode):
            raise error(f"{what} file '{path}' is {_kind(info.st_mode)}, not a regular file")
        data = f.read(MAX_BYTES + 1)
    if len(data) > MAX_BYTES:
        raise error(f"{what} file '{path}' has more than {MAX_BYTES} bytes (an input file is a page of TOML)")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"cannot read {what} file {str(path)!r}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
