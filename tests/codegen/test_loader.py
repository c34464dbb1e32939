"""derive.runtime.loader: compile into a content-keyed cache, call batch kernels from NumPy."""
from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from derive.runtime import loader
from derive.runtime.loader import LoaderError, build, load
from derive.model import ModelError

ROOT = Path(__file__).resolve().parents[2]
GEN_C = ROOT / "generated" / "c"


def _copy_planar(tmp_path: Path) -> Path:
    folder = tmp_path / "src"
    folder.mkdir()
    for ext in (".c", ".h"):
        shutil.copy(GEN_C / f"planar{ext}", folder / f"planar{ext}")
    return folder


def test_cache_is_keyed_by_source_compiler_and_flags(tmp_path, monkeypatch):
    folder = _copy_planar(tmp_path)
    cache = tmp_path / "cache"
    first = build(folder / "planar.c", cache=cache)
    assert first.is_file() and first.parent.parent == cache

    # a second build is a cache hit: the compiler is not run again
    def no_compiler(*args, **kwargs):
        raise AssertionError("compiler run on a cache hit")
    monkeypatch.setattr(loader.subprocess, "run", no_compiler)
    assert build(folder / "planar.c", cache=cache) == first
    monkeypatch.undo()

    flags = build(folder / "planar.c", flags=loader.DEFAULT_FLAGS + ("-DPLANAR_POLAR_SINE_MIN=1e-9",),
                  cache=cache)
    assert flags != first
    header = folder / "planar.h"
    header.write_text(header.read_text() + "/* edited */\n")
    assert build(folder / "planar.c", cache=cache) not in (first, flags)
    assert loader.build_key([folder / "planar.c"], "cc", loader.DEFAULT_FLAGS) != \
        loader.build_key([folder / "planar.c"], "gcc", loader.DEFAULT_FLAGS) or \
        loader.compiler_identity("cc") == loader.compiler_identity("gcc")


def test_compile_errors_and_missing_compiler_are_reported(tmp_path):
    folder = _copy_planar(tmp_path)
    (folder / "planar.c").write_text((folder / "planar.c").read_text() + "\nthis is not C;\n")
    with pytest.raises(LoaderError, match="compiling planar.c failed"):
        build(folder / "planar.c", cache=tmp_path / "cache")
    with pytest.raises(LoaderError, match="no C compiler found: .* set CC or install gcc or clang"):
        build(GEN_C / "planar.c", cc="no-such-compiler-xyz", cache=tmp_path / "cache")
    with pytest.raises(ModelError, match="unknown model 'no_such_model'"):
        load("no_such_model", cache=tmp_path / "cache")
    with pytest.raises(LoaderError, match="no generated C for model 'planar'"):
        load("planar", generated=tmp_path, cache=tmp_path / "cache")


def test_kernels_names_and_variants(tmp_path):
    m = load("planar", cache=tmp_path / "cache")
    assert m.names["state_names"] == ("theta1", "theta2", "theta1_dot", "theta2_dot")
    assert m.names["param_names"] == ("m1", "m2", "l1", "l2", "g")
    for k in ("rhs", "mass_matrix", "forcing", "energy", "positions", "jacobian", "hamiltonian_rhs"):
        for suffix in ("", "_f", "_l"):
            assert k + suffix in m.kernels
    with pytest.raises(AttributeError, match="no kernel 'nope'.*known: "):
        m.nope
    y, p = np.array([0.3, -0.2, 0.1, 0.4]), np.array([1.0, 1.2, 0.9, 1.1, 9.81])
    assert m.rhs(y, p).dtype == np.float64
    assert m.rhs_f(y, p).dtype == np.float32
    assert m.rhs_l(y, p).dtype == np.longdouble
    assert m.energy(y, p).shape == ()
    assert m.jacobian(y, p).shape == (4, 4)
    assert m.positions(y, p).shape == (2, 2)
    assert "rhs" in dir(m)


def test_broadcasting_and_strides(tmp_path):
    m = load("planar", cache=tmp_path / "cache")
    rng = np.random.default_rng(3)
    y = rng.uniform(-2, 2, (2, 3, 4))
    P = rng.uniform(0.5, 2, (2, 3, 5))
    one = P[0, 0]
    full = m.rhs(y, one)                                   # one parameter vector, stride 0
    assert full.shape == (2, 3, 4)
    assert np.array_equal(full, m.rhs(y, np.broadcast_to(one, (2, 3, 5))))
    assert np.array_equal(full, m.rhs(y, one.reshape(1, 1, 5)))
    assert np.array_equal(full[1, 2], m.rhs(y[1, 2], one))
    per = m.rhs(y, P)                                      # one parameter vector per state
    for i in range(2):
        for j in range(3):
            assert np.array_equal(per[i, j], m.rhs(y[i, j], P[i, j]))
    assert m.rhs(y[0, 0], P[:, 0]).shape == (2, 4)          # one state, many parameter sets
    assert m.rhs(y[:, :1], P[:1]).shape == (2, 3, 4)        # (2,1) against (1,3)
    yt = np.asfortranarray(y.reshape(6, 4))                 # non-contiguous input is copied
    assert np.array_equal(m.rhs(yt, one), full.reshape(6, 4))
    with pytest.raises(ValueError, match=r"y must have shape \(\.\.\., 4\)"):
        m.rhs(np.zeros(5), one)
    with pytest.raises(TypeError, match="takes 2 arrays"):
        m.rhs(y)


def test_status_per_state(tmp_path):
    m = load("spherical_std", cache=tmp_path / "cache")
    y = np.tile([0.5, 0.1, 1.0, -0.3, 0.2, 0.1, -0.1, 0.3], (3, 1))
    y[1, 0] = 0.0                 # link 1 on the pole of the standard chart
    y[2, 7] = np.nan
    p = np.array([1.0, 1.2, 0.9, 1.1, 9.81])
    out, status = m.rhs(y, p, status=True)
    assert status.tolist()[0] == 0 and status[1] & 2 and status[2] & 1
    assert np.all(np.isfinite(out[0]))


# -- the vector-math build (loader.build_fastest, templates/c/vector_math.jinja) ----------

def _libmvec_expected() -> bool:
    import platform
    return platform.system() == "Linux" and platform.machine() == "x86_64" and any(
        Path(d, "libmvec.so.1").exists() for d in ("/lib/x86_64-linux-gnu", "/usr/lib/x86_64-linux-gnu",
                                                   "/lib64", "/usr/lib64"))


def test_fastest_build_calls_libmvec_where_it_exists():
    import subprocess
    path, flags = loader.build_fastest("planar", [GEN_C / "planar.c"])
    if not _libmvec_expected():
        assert flags == loader.PORTABLE_FLAGS
        return
    assert flags == loader.VECTOR_MATH_FLAGS
    symbols = subprocess.run(["nm", "-D", str(path)], capture_output=True, text=True, check=True).stdout
    # the double kernels call the 2-lane vector sin and cos and no scalar double one; float
    # and long double keep their scalar calls
    assert "_ZGVbN2v_sin" in symbols and "_ZGVbN2v_cos" in symbols
    assert not re.search(r" U (sin|cos|sincos)@", symbols)
    assert re.search(r" U sin(cos)?l@", symbols) and re.search(r" U sin(cos)?f@", symbols)


@pytest.mark.parametrize("model", ["planar", "spherical_std"])
def test_vector_math_kernels_agree_with_the_portable_build(model, tmp_path):
    """libmvec's sin/cos are within 4 ulp of the scalar ones: every kernel output agrees to a
    few ulp of its magnitude, the status flags exactly."""
    portable = load(model, cache=tmp_path / "cache")
    vector = load(model, flags=loader.VECTOR_MATH_FLAGS, cache=tmp_path / "cache") if _libmvec_expected() else None
    if vector is None:
        pytest.skip("no libmvec on this platform: the portable build is the only one")
    rng = np.random.default_rng(3)
    n_states = len(portable.names["state_names"])
    y = rng.uniform(-3, 3, (2000, n_states))
    p = np.array([1.0, 1.3, 0.8, 1.1, 9.81])[:len(portable.names["param_names"])]
    for name in ("rhs", "jacobian", "energy", "mass_matrix"):
        a, sa = getattr(portable, name)(y, p, status=True)
        b, sb = getattr(vector, name)(y, p, status=True)
        assert np.array_equal(sa, sb)
        ok = sa == 0
        scale = np.abs(a[ok]).reshape(ok.sum(), -1).max(axis=1).reshape((-1,) + (1,) * (a.ndim - 1)) + 1.0
        assert np.all(np.abs(a[ok] - b[ok]) <= 1e-13 * scale), name


def test_a_damaged_cached_library_is_rebuilt_not_loaded(tmp_path):
    """A truncated library would kill the process with SIGBUS: its checksum is checked
    first, and a mismatch rebuilds it with a one-line note (in a fresh process, as a
    later run would meet it)."""
    import os
    import subprocess
    import sys
    cache = tmp_path / "cache"
    script = ("import sys; from derive.runtime.loader import build; from pathlib import Path; "
              f"print(build(Path({str(GEN_C / 'planar.c')!r}), cache=Path({str(cache)!r})))")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    first = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, check=True)
    lib = Path(first.stdout.strip())
    lib.write_bytes(lib.read_bytes()[:1000])                      # truncated
    second = subprocess.run([sys.executable, "-c", script + "; import ctypes; ctypes.CDLL(sys.argv[0] if False else "
                             f"{str(lib)!r}).planar_rhs"], capture_output=True, text=True, env=env)
    assert second.returncode == 0, second.stderr
    assert "does not match its checksum; rebuilding it" in second.stderr
    assert lib.stat().st_size > 1000
