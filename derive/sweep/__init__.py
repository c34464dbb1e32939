"""Stage: sweeps and maps at scale, on Dask (the `sweep` extra: dask, distributed, zarr, xarray).

    ds = derive.sweep("scenes/flip_map.toml", out="out")       # an xarray Dataset
    ds.flip_time.sel(theta1=0.5, theta2=2.0, method="nearest")

A sweep file is a scene plus axes over initial values and parameters and the
quantities to record per trajectory (sweep_file.py); its product of axes is cut into
chunks (layout.py), each a Dask task that integrates its trajectories as one
batch of the compiled integrator (chunk.py, level_crossings.py, bounds.py; event times
verified to an accuracy by runs again, verify.py) and whose result is written
into a Zarr store as it finishes (store.py, driver.py), a mirror-symmetric sweep's
other half as the mirror image of the first (mirror.py), with a PNG per quantity
for 2-D sweeps (images.py).
"""
from __future__ import annotations

import importlib

from ..errors import ToolMissingError
from .driver import run

EXTRA = ("dask", "distributed", "zarr", "xarray")
MISSING_EXTRA = "derive sweep needs the sweep extra: pip install 'derive[sweep]'"


def require_extra() -> None:
    """One line (exit status 2) when a package of the sweep extra is missing."""
    for name in EXTRA:
        try:
            importlib.import_module(name)
        except ImportError:
            raise ToolMissingError(MISSING_EXTRA) from None


def sweep(source, out=None, scheduler: str | None = None, workers: int | None = None,
          progress: bool = False, on_chunk=None):
    """Run a sweep file into OUT/<name>.zarr (resuming a stopped one) and return its data.

    Called as ``derive.sweep(...)`` (the sweep extra: Dask, Zarr, xarray).

    Parameters
    ----------
    source : str or path
        A sweep file, or the name of an example sweep (``flip_map``).
    out : str or path, optional
        The output folder (default: the file's ``output.directory``).
    scheduler : str, optional
        An existing Dask cluster, ``tcp://HOST:PORT`` (or ``DASK_SCHEDULER_ADDRESS``).
    workers : int, optional
        Without a scheduler: a local cluster of this many processes (default one per core);
        0: in this process.
    progress : bool
        A progress bar (a plain line per chunk where stdout is no terminal).
    on_chunk : callable, optional
        ``on_chunk(k)`` is called after chunk k is written (an exception there stops the sweep).

    Returns
    -------
    xarray.Dataset
        The quantities recorded, one dimension per grid axis.

    Raises
    ------
    ToolMissingError
        A package of the sweep extra (dask, distributed, zarr, xarray) is not installed.
    SceneError
        The sweep file does not exist or is wrong (the message names the key).
    InputError
        An output folder that cannot be written, a scheduler that cannot be reached.
    BuildError
        The model's library cannot be compiled (the sweep runs compiled C).

    Examples
    --------
    A sweep of three initial angles, run in this process (workers=0: no cluster), its store
    in a temporary folder:

    >>> import os, tempfile
    >>> import derive
    >>> lines = ['record = ["energy_error"]',
    ...          '[pendulum]', 'model = "planar"',
    ...          'parameters = { m1 = 1.0, m2 = 1.0, l1 = 1.0, l2 = 1.0, g = 9.81 }',
    ...          '[initial]', 'state = { theta1 = 0.0, theta2 = 0.0 }', 'rest = true',
    ...          '[time]', 'stop = 1.0', 'outputs = 3',
    ...          '[accuracy]', 'method = "dop853"', 'rtol = 1e-8',
    ...          '[axes]', 'theta1 = { linspace = [0.1, 0.5], num = 3 }']
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = os.path.join(folder, "tiny.toml")
    ...     with open(path, "w") as f:
    ...         _ = f.write("\\n".join(lines))
    ...     ds = derive.sweep(path, out=folder, workers=0)
    ...     print(ds["theta1"].values, ds["status"].values, bool((ds["energy_error"] < 1e-8).all()))
    [0.1 0.3 0.5] [0 0 0] True
    """
    return run_sweep(source, out, scheduler, workers, progress, on_chunk).dataset


def run_sweep(source, out=None, scheduler=None, workers=None, progress=False, on_chunk=None):
    """As sweep(), returning the run's Report (store, images, chunks computed and skipped, time)."""
    require_extra()
    return run(source, out, scheduler, workers, progress, on_chunk)


class _CallableStage(__import__("types").ModuleType):
    """`derive.sweep` is this package and the function at once: calling the module runs
    sweep() (the package's name and the API's cannot differ, and a submodule import
    would otherwise rebind derive.sweep to the module)."""

    def __call__(self, *args, **kwargs):
        return sweep(*args, **kwargs)


__import__("sys").modules[__name__].__class__ = _CallableStage
