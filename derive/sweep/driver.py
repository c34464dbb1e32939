"""Run a sweep: its unfinished chunks as Dask tasks, each written to the store as it finishes.

Where the tasks run:
  workers = 0                     in this process, one chunk after another (no Dask);
  scheduler (or DASK_SCHEDULER_ADDRESS)   an existing Dask cluster, tcp://HOST:PORT;
  otherwise                       a LocalCluster of `workers` processes (default: one per
                                  core), one thread each, started and stopped here.
A task carries its chunk's initial states and parameters and the sweep's settings
(a model file as its description); a worker needs derive installed, no checkout:
it builds or loads the integrator from its own cache by content hash.  When a
worker dies, Dask runs its tasks again elsewhere; a chunk is written once, by this
process, when its task's result arrives.
"""
from __future__ import annotations

import socket
from urllib.parse import urlsplit

import contextlib
import dataclasses
import logging
import os
import signal
import threading
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import UsageError
from ..progress import Progress, ProgressLines
from .chunk import integrate, prepare, variables
from .layout import Layout, chunk_inputs
from .mirror import mirror_axes, mirrored, plan as mirror_plan
from .sweep_file import Sweep, load_sweep
from .store import Lock, Writer, load, open_store
from .images import write_images

SCHEDULER_ENV = "DASK_SCHEDULER_ADDRESS"


@dataclass
class Report:
    store: Path
    images: list[Path]
    chunks: int
    computed: int
    skipped: int
    trajectories: int
    seconds: float                  # wall time of the chunks computed here (not the setup)
    workers: int                    # worker processes (0: this process)
    where: str
    computed_trajectories: int = 0  # integrated (a mirrored chunk's are not)
    cpu_seconds: float = 0.0        # CPU time of the computed chunks, summed over workers
    mirrored: int = 0               # chunks written as the mirror image of another (mirror.py)
    written_trajectories: int = 0   # in the chunks computed here, mirror images included
    dataset: object = field(default=None, repr=False)


def _task(sweep: Sweep, y0, p, shape):
    """The Dask task: one chunk's quantities (module-level, so workers import it from derive),
    and the CPU seconds it took (the throughput per core, whatever else shares the machine)."""
    cpu = time.thread_time()
    out = integrate(sweep, y0, p)
    return {name: value.reshape(shape) for name, value in out.items()}, time.thread_time() - cpu


def _light(sweep: Sweep) -> Sweep:
    """What a task needs of the sweep: its settings, not its axes (the task carries its inputs)."""
    return dataclasses.replace(sweep, axes=(), text="")


def _executor(scheduler: str | None, workers: int | None):
    """(client, cluster or None, description); client None: run in this process."""
    address = scheduler or os.environ.get(SCHEDULER_ENV) or None
    if workers == 0 and address is None:
        return None, None, "this process"
    from distributed import Client, LocalCluster    # the sweep extra
    if address is not None:
        _reachable(address)
        try:
            client = Client(address, timeout=30)
        except (OSError, TimeoutError) as exc:
            raise UsageError(f"cannot reach the Dask scheduler at {address}: {exc}") from None
        return client, None, f"the Dask cluster at {address}"
    n = workers or os.cpu_count() or 1
    # Workers log only CRITICAL: a task's error reaches this process as the task's exception,
    # and the ERROR a worker logs when Ctrl-C closes the scheduler mid-heartbeat is noise
    with _workers_ignore_ctrl_c():
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                               silence_logs=logging.CRITICAL)
    return Client(cluster), cluster, f"a local cluster of {n} worker process{'es' * (n != 1)}"


@contextlib.contextmanager
def _workers_ignore_ctrl_c():
    """Start the local workers with SIGINT ignored: Ctrl-C reaches the terminal's whole
    process group, and each worker process would print its own KeyboardInterrupt traceback.
    An ignored signal stays ignored across the workers' exec (and Python then installs no
    KeyboardInterrupt handler), so only this process sees Ctrl-C; it closes the cluster,
    which stops the workers."""
    if threading.current_thread() is not threading.main_thread():
        yield                       # signal handlers belong to the main thread
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _reachable(address: str, timeout: float = 5.0) -> None:
    """A TCP scheduler address that accepts connections, else one line at once (Dask's own
    client would retry for its whole timeout)."""
    if not address.startswith(("tcp://", "tls://")) and "://" in address:
        return                                   # another transport: Dask says
    parts = urlsplit(address if "://" in address else "tcp://" + address)
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        host = port = None
    if not host or port is None:
        raise UsageError(f"the Dask scheduler address {address!r} is not tcp://HOST:PORT")
    try:
        with socket.create_connection((host, port), timeout=timeout):
            pass
    except OSError as exc:
        raise UsageError(f"cannot reach the Dask scheduler at {address}: "
                         f"{exc.strerror or type(exc).__name__}") from None


def output_paths(sweep: Sweep, out: str | Path | None) -> tuple[Path, Path, str]:
    folder = Path(out) if out is not None else sweep.scene.output_dir
    stem = Path(sweep.source).stem
    return folder, folder / f"{stem}.zarr", stem


def run(source, out=None, scheduler: str | None = None, workers: int | None = None,
        progress: bool = True, on_chunk=None) -> Report:
    """Run the sweep file `source` (or a parsed Sweep) into OUT/<name>.zarr (and PNGs for a
    2-D sweep); finished chunks of an earlier run into the same store are skipped.
    on_chunk(k): called after chunk k is written (an exception there stops the sweep)."""
    sweep = source if isinstance(source, Sweep) else load_sweep(source)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 0):
        raise UsageError(f"workers must be a whole number >= 0, got {workers!r}")
    folder, path, stem = output_paths(sweep, out)
    layout = Layout(sweep)
    names = variables(sweep)
    lock = Lock(path)                           # one sweep writes a store at a time
    try:
        return _run(sweep, path, folder, stem, layout, names, scheduler, workers, progress, on_chunk)
    finally:
        lock.release()


def _run(sweep, path, folder, stem, layout, names, scheduler, workers, progress, on_chunk) -> Report:
    done = open_store(path, sweep, layout, names)
    writer = Writer(path, layout)
    bar = Progress(f"sweeping {stem}", layout.count) if progress else None
    lines = ProgressLines(f"sweeping {stem}", layout.count, "chunks") if progress else None
    if bar:
        bar.update(len(done))
        lines.update(len(done))
    unfinished = [k for k in range(layout.count) if k not in done]
    local = scheduler is None and not os.environ.get(SCHEDULER_ENV)
    client = cluster = None
    where = "this process"
    computed = traj = mirror_chunks = points = 0
    cpu = 0.0
    start = time.perf_counter()
    try:
        if unfinished and local:
            prepare(sweep)                      # build once here: local workers load it from the cache
        if unfinished:
            client, cluster, where = _executor(scheduler, workers)
        light = _light(sweep)
        pairs = _call(client, mirror_plan, sweep, layout) if unfinished else None
        dims = mirror_axes(sweep) if pairs is not None else None
        # a mirror pair is one task (its first chunk), run when either chunk is unfinished
        todo = unfinished if pairs is None else sorted({min(k, pairs[k]) for k in unfinished})
        start = time.perf_counter()             # the chunks' time, not the cluster's start-up
        for k, (values, seconds) in _results(client, light, sweep, layout, todo):
            cpu += seconds
            traj += values["status"].size
            written = [(k, values)]
            if pairs is not None and pairs[k] != k:
                written.append((pairs[k], mirrored(values, dims)))
            for chunk, chunk_values in written:
                if chunk in done:                # (the pair's other chunk was written before)
                    continue
                writer.write(chunk, chunk_values)
                computed += 1
                points += chunk_values["status"].size
                mirror_chunks += chunk != k
                if bar:
                    bar.update(len(done) + computed)
                    lines.update(len(done) + computed)
                if on_chunk is not None:
                    on_chunk(chunk)
    except KeyboardInterrupt:
        # Ctrl-C inside Dask's or Zarr's event loop leaves coroutines that were never awaited;
        # their warnings at collection time would follow the one line "derive: interrupted"
        warnings.filterwarnings("ignore", message="coroutine .* was never awaited", category=RuntimeWarning)
        raise
    finally:
        seconds = time.perf_counter() - start
        n_workers = len(client.scheduler_info()["workers"]) if client is not None else 0
        if bar:
            bar.close()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    ds = load(path)
    images = write_images(ds, folder, stem, sweep.scene.title) if len(sweep.dims) == 2 else []
    return Report(path, images, layout.count, computed, len(done), sweep.size, seconds, n_workers, where,
                  traj, cpu, mirror_chunks, points, ds)


def _call(client, fn, *args):
    """fn(*args) here, or as a task on the cluster (where the integrators are built)."""
    if client is None:
        return fn(*args)
    return client.submit(fn, *args, pure=False).result()


def _results(client, light: Sweep, sweep: Sweep, layout: Layout, todo: list[int]):
    """(chunk, values) as chunks finish, in this process or on the cluster."""
    if client is None:
        for k in todo:
            y0, p = chunk_inputs(sweep, layout, k)
            yield k, _task(light, y0, p, layout.block_shape(k))
        return
    from distributed import as_completed    # the sweep extra
    futures = {}
    for k in todo:
        y0, p = chunk_inputs(sweep, layout, k)
        f = client.submit(_task, light, y0, p, layout.block_shape(k), key=f"derive-sweep-chunk-{k}-{id(todo)}",
                          pure=False)
        futures[f] = k
    try:
        for f in as_completed(futures):
            yield futures[f], f.result()
    finally:
        client.cancel(list(futures))
