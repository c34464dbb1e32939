"""A small progress bar on stderr (only when stderr is a terminal or forced)."""
from __future__ import annotations

import sys
import time


class Progress:
    """`label [#####.....] done/total elapsed`, redrawn in place; silent when the
    stream is not a terminal (logs and CI get no carriage-return noise)."""

    def __init__(self, label: str, total: int, stream=None, width: int = 30, force: bool = False):
        self.label, self.total, self.width = label, max(total, 1), width
        self.stream = stream or sys.stderr
        self.enabled = force or self.stream.isatty()
        self.start = time.perf_counter()
        self.update(0)

    def update(self, done: int) -> None:
        if not self.enabled:
            return
        filled = int(self.width * done / self.total)
        elapsed = time.perf_counter() - self.start
        self.stream.write(f"\r{self.label} [{'#' * filled}{'.' * (self.width - filled)}] "
                          f"{done}/{self.total} {elapsed:5.1f} s")
        self.stream.flush()

    def close(self) -> None:
        if not self.enabled:
            return
        self.stream.write("\n")
        self.stream.flush()
