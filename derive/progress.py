"""Progress on a terminal: a bar for work counted in parts, a status line for stages;
and, for a log, plain progress lines.

The bar and the status line write to stderr and only when it is a terminal, so logs,
pipes and CI get no carriage-return noise, and --json output on stdout stays clean.
ProgressLines writes whole lines to stdout when it is not a terminal (a log, a pipe),
so a long run piped to a file says how far it is while it runs.

    with Stage("derive") as stage:          # silent for the first 2 s, then
        for name in models:                 # "derive planar (2/5) 3.4 s", redrawn
            stage.set(f"{name} ({i}/{n})")
"""
from __future__ import annotations

import sys
import threading
import time

QUIET_FOR = 2.0          # s: stages shorter than this never draw anything


class Progress:
    """`label [#####.....] done/total elapsed`, redrawn in place; once a part is done, the
    remaining time estimated from the mean time per part so far (`~12 s left`)."""

    def __init__(self, label: str, total: int, stream=None, width: int = 30, force: bool = False):
        self.label, self.total, self.width = label, max(total, 1), width
        self.stream = stream or sys.stderr
        self.enabled = force or _isatty(self.stream)
        self.start = time.perf_counter()
        self._drawn = 0
        self.update(0)

    def update(self, done: int) -> None:
        if not self.enabled:
            return
        filled = int(self.width * done / self.total)
        elapsed = time.perf_counter() - self.start
        text = (f"\r{self.label} [{'#' * filled}{'.' * (self.width - filled)}] "
                f"{done}/{self.total} {elapsed:5.1f} s")
        left = remaining(done, self.total, elapsed)
        if left is not None:
            text += f", ~{_duration(left)} left"
        pad = max(0, self._drawn - len(text))
        self.stream.write(text + " " * pad)
        self._drawn = len(text)
        self.stream.flush()

    def close(self) -> None:
        if not self.enabled:
            return
        self.stream.write("\n")
        self.stream.flush()


class ProgressLines:
    """`label: 12/40 chunks (30%), 4.1 s, ~9.6 s left`, one plain line a part when there are
    at most `steps` parts, else one each 1/steps of them; written (and flushed) only where
    the stream is not a terminal (a terminal has the bar)."""

    def __init__(self, label: str, total: int, unit: str = "parts", stream=None, steps: int = 20,
                 force: bool = False):
        self.label, self.total, self.unit, self.steps = label, max(total, 1), unit, steps
        self.stream = stream or sys.stdout
        self.enabled = force or not _isatty(self.stream)
        self.start = time.perf_counter()
        self._first = self._mark = None

    def update(self, done: int) -> None:
        if not self.enabled:
            return
        mark = done if self.total <= self.steps else done * self.steps // self.total
        if self._first is None:
            self._first = done                   # done before this run (a resumed one)
        elif mark == self._mark and done < self.total:
            return
        self._mark = mark
        elapsed = time.perf_counter() - self.start
        text = f"{self.label}: {done}/{self.total} {self.unit} ({100 * done // self.total}%), {elapsed:.1f} s"
        left = remaining(done - self._first, self.total - self._first, elapsed)
        if left is not None:
            text += f", ~{_duration(left)} left"
        self.stream.write(text + "\n")
        self.stream.flush()


class Stage:
    """A status line `label detail elapsed` for a stage of unknown length, drawn by a
    background thread once the stage has run QUIET_FOR seconds, erased when it ends."""

    def __init__(self, label: str, stream=None, enabled: bool | None = None, quiet_for: float = QUIET_FOR):
        self.label, self.detail = label, ""
        self.stream = stream or sys.stderr
        self.enabled = _isatty(self.stream) if enabled is None else enabled
        self.quiet_for = quiet_for
        self.start = time.perf_counter()
        self._stop = threading.Event()
        self._drawn = 0
        self._thread = None

    @property
    def seconds(self) -> float:
        return time.perf_counter() - self.start

    def set(self, detail: str) -> None:
        self.detail = detail

    def _draw(self) -> None:
        text = f"{self.label} {self.detail} {self.seconds:.0f} s".replace("  ", " ")
        pad = max(0, self._drawn - len(text))
        self.stream.write("\r" + text + " " * pad)
        self.stream.flush()
        self._drawn = len(text)

    def _loop(self) -> None:
        if self._stop.wait(self.quiet_for):
            return
        while not self._stop.is_set():
            self._draw()
            self._stop.wait(0.5)

    def __enter__(self) -> "Stage":
        self.start = time.perf_counter()
        if self.enabled:
            self._thread = threading.Thread(target=self._loop, daemon=True)
            self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            if self._drawn:
                self.stream.write("\r" + " " * self._drawn + "\r")
                self.stream.flush()


def remaining(done: int, total: int, elapsed: float) -> float | None:
    """Seconds left if the remaining parts take as long as the done ones did on average;
    None before the first part is done (nothing to estimate from)."""
    if done <= 0 or done >= total or elapsed <= 0:
        return None
    return elapsed / done * (total - done)


def _duration(seconds: float) -> str:
    """`12 s`, `3 min 5 s`, `2 h 7 min`: whole units (at least 1 s)."""
    s = max(1, round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60} s"
    return f"{s // 3600} h {s % 3600 // 60} min"


def _isatty(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False
