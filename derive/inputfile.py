"""Reading a user's input file (a model, a scene, a sweep): a regular file of bounded size.

A device (/dev/zero), a FIFO, a socket or a directory is refused before anything is read,
and so is a file larger than MAX_BYTES: an input file of derive is a page of TOML.  The
file is opened without blocking (a FIFO swapped in after the check would otherwise wait
for a writer) and checked again on the open descriptor, then read to at most
MAX_BYTES + 1 bytes.
"""
from __future__ import annotations

import os
import stat
from pathlib import Path

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
