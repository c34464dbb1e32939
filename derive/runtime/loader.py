"""Python access to the generated C: compile into a cache, call from NumPy.

``load("planar")`` compiles the model's generated C (rendered into the cache by
derive.codegen.sources, or any folder given as ``generated=``) into a shared
library in ``cache_dir()/c-build/<key>/``, where the key is the SHA-256 of the source,
the header, the compiler (path and ``--version``) and the flags, so a change to
any of them rebuilds and nothing else does.  The library is opened with
ctypes; its kernels are read from the header (prototypes of the ``_batch``
entry points and the ``<MODEL>_<KERNEL>_<ARG>_SIZE/_RANK/_ROWS/_COLS`` macros)
and returned as NumPy-callable objects backed by the batch entry points:

    m = load("planar")
    ydot = m.rhs(y, p)               # y (..., 4), p (..., 5) or (5,) -> (..., 4)
    ydot, status = m.rhs(y, p, status=True)
    m.rhs_f(y, p), m.rhs_l(y, p)     # float and long double variants

Leading axes broadcast; a parameter vector shared by all states is passed
with stride 0, without copying.
"""
from __future__ import annotations

from typing import Callable

import ctypes
import errno
import hashlib
import importlib.util
import os
import platform
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from functools import lru_cache, partial
from math import prod
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from ..paths import cache_dir, write_error
from ..errors import BuildError, CompilerMissingError, SimulationInputError
from ..model.description import forget_on_model_change
from ..codegen.names import VECTOR_MATH
from ..model.atlas import atlases, find_atlas
from ..codegen.sources import model_sources, numpy_source
from .shared_library import EntryPoint, SharedLibrary

DEFAULT_FLAGS = ("-std=c99", "-O2", "-fPIC", "-shared")
PORTABLE_FLAGS = DEFAULT_FLAGS
# glibc's libmvec on x86-64: the `omp declare simd` sin/cos of the generated sources
# (templates/c/vector_math.jinja) become vector calls.  -fno-builtin-*: GCC would fuse a
# sin and a cos into one scalar sincos instead; -fpeel-loops: the loop over a few lanes
# is unrolled and its arrays stay in registers (without it the vector build is slower
# than the portable one).
VECTOR_MATH_FLAGS = ("-std=c99", "-O2", "-fpeel-loops", "-fopenmp-simd",
                     *(f"-fno-builtin-{f}" for f in VECTOR_MATH), "-DDERIVE_VECTOR_MATH",
                     "-fPIC", "-shared", "-Wl,--no-as-needed", "-lmvec")

_VARIANTS = {"": (np.float64, ctypes.c_double), "_f": (np.float32, ctypes.c_float),
             "_l": (np.longdouble, ctypes.c_longdouble)}
_PROTO = re.compile(r"^int (\w+?)_batch(_f|_l)?\(long n, (.*)\);$", re.M)
_DEFINE = re.compile(r"^#define (\w+) (-?\d+)$", re.M)


LoaderError = BuildError      # the name the loader's callers have always used


COMPILERS = ("cc", "gcc", "clang")       # tried in this order when CC is not set


def default_compiler() -> str:
    """$CC, else the first of cc, gcc, clang on PATH."""
    cc = os.environ.get("CC")
    if cc:
        return cc
    for name in COMPILERS:
        if shutil.which(name):
            return name
    raise CompilerMissingError("no C compiler found: set CC or install gcc or clang")


def compiler_command(cc: str) -> list[str]:
    """$CC as a command: 'gcc -O2' or 'ccache gcc' are a program and its first words."""
    words = shlex.split(cc)
    if not words:
        raise CompilerMissingError("no C compiler found: CC is empty; set CC or install gcc or clang")
    return words


@lru_cache(maxsize=None)
def compiler_identity(cc: str) -> str:
    words = compiler_command(cc)
    path = shutil.which(words[0])
    if path is None:
        where = " (from CC)" if os.environ.get("CC") == cc else ""
        raise CompilerMissingError(f"no C compiler found: '{words[0]}'{where} is not on PATH; "
                                   f"set CC or install gcc or clang")
    version = subprocess.run([path, *words[1:], "--version"], capture_output=True, text=True).stdout
    return f"{path}\n{version}"


_keys: dict[tuple, str] = {}      # in-process memo of build_key, by file identity


def build_key(sources: list[Path], cc: str, flags: tuple[str, ...]) -> str:
    """SHA-256 of every source and its header, the compiler identity and the flags.

    Memoised in the process by (path, size, mtime) of every file, so a warm call
    reads no file; an edited file has a new mtime and is hashed again."""
    stats = []
    for src in sources:
        for part in _parts(src):
            st = part.stat()
            stats.append((str(part), st.st_size, st.st_mtime_ns))
    memo = (tuple(stats), cc, tuple(flags))
    if memo not in _keys:
        _keys[memo] = _build_key(sources, cc, flags)
    return _keys[memo]


def _parts(src: Path) -> list[Path]:
    """A source and every header beside it (a header may include the others: the Taylor
    integrator's includes the integrators' for their structs)."""
    return [src] + sorted(src.parent.glob("*.h"))


def _build_key(sources: list[Path], cc: str, flags: tuple[str, ...]) -> str:
    h = hashlib.sha256()
    for src in sources:
        for part in _parts(src):
            h.update(hashlib.sha256(part.read_bytes()).digest())
    h.update(hashlib.sha256(compiler_identity(cc).encode()).digest())
    h.update(hashlib.sha256("\0".join(flags).encode()).digest())
    return h.hexdigest()


def build_library(stem: str, sources: list[Path], cc: str | None = None,
                  flags: tuple[str, ...] = DEFAULT_FLAGS, cache: Path | None = None,
                  libs: tuple[str, ...] = ()) -> Path:
    """Compile `sources` (headers beside them) into one shared library in the cache;
    `libs` (e.g. -lquadmath) are linked after the sources."""
    sources = [Path(s).resolve() for s in sources]
    for src in sources:
        if not src.is_file() or not src.with_suffix(".h").is_file():
            raise LoaderError(f"no C source at {src} (or its header beside it)")
    cc = cc or default_compiler()
    key = build_key(sources, cc, tuple(flags) + tuple(libs))
    root = Path(cache) if cache is not None else cache_dir() / "c-build"
    lib = root / key[:32] / f"lib{stem}.so"
    with _building(lib):        # another thread building this very library: wait for it, then reuse it
        return _built_library(lib, sources, cc, flags, root, libs)


def _built_library(lib: Path, sources: list[Path], cc: str, flags: tuple[str, ...], root: Path,
                   libs: tuple[str, ...]) -> Path:
    """The library `lib` from the cache, or built now (build_library's work, under its lock)."""
    if lib.is_file():
        state = _intact(lib)
        if state is True:
            return lib
        # a truncated or altered library would crash the process (SIGBUS) or run other code
        if state is not None:
            print(f"derive: note: the cached library {lib} {state}; rebuilding it", file=sys.stderr)
    try:
        lib.parent.mkdir(parents=True, exist_ok=True)
        tmp = tempfile.mkdtemp(dir=lib.parent)
    except OSError as exc:
        raise write_error(lib, exc) from None
    try:
        out = Path(tmp) / lib.name
        # several sources: each compiled once into an object of its own (an atlas library
        # links the objects its charts' libraries were built from), then linked
        folders = list(dict.fromkeys(src.parent for src in sources))      # each source sees every header
        inputs = _objects(sources, cc, flags, root, folders) if len(sources) > 1 else sources
        cmd = [*compiler_command(cc), *flags, "-I", str(sources[0].parent), *map(str, inputs), "-o", str(out), *libs, "-lm"]
        _compile(cmd, lib, sources)
        _store_checked(out, lib)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    _verified.add(str(lib))
    return lib


def _objects(sources: list[Path], cc: str, flags: tuple[str, ...], root: Path, folders: list[Path]) -> list[Path]:
    """The object of every source (_object), compiled side by side: a compiler is a process
    of its own, so the threads only wait on them (at most _compilers at once)."""
    with ThreadPoolExecutor(max_workers=len(sources)) as pool:
        return list(pool.map(lambda src: _object(src, cc, flags, root, folders), sources))


# The build cache's entries being made in this process, each by one thread: a thread that
# wants one another thread is building waits for it and reuses it (the atlas library
# wants its charts' objects while their own libraries compile them).
_targets: dict[Path, threading.Lock] = {}
_targets_lock = threading.Lock()


@contextmanager
def _building(target: Path):
    """Hold the lock of one build cache entry (a library or an object) of this process."""
    with _targets_lock:
        lock = _targets.setdefault(target, threading.Lock())
    with lock:
        yield


def _compiler_slots() -> int:
    """How many compilers run at once: ``$DERIVE_JOBS``, else one per core this process may use."""
    text = os.environ.get("DERIVE_JOBS", "").strip()
    if text.isdigit() and int(text) >= 1:
        return int(text)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:              # not Linux: the machine's count
        return os.cpu_count() or 1


# Compilers are CPU-bound processes: more at once than cores only share the cores (and
# memory), so the threads that build side by side take turns here.
_compilers = threading.BoundedSemaphore(_compiler_slots())


def _compile(cmd: list[str], target: Path, sources: list[Path]) -> None:
    """Run the compiler; a failure is a LoaderError with its output (a refused write, one
    line naming `target`)."""
    with _compilers:
        proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        refused = _refused_write(proc.stderr)
        if refused:                # the disk, not the code: one line naming the library
            raise write_error(target, OSError(refused, os.strerror(refused)))
        names = ", ".join(src.name for src in sources)
        raise LoaderError(f"compiling {names} failed ({' '.join(cmd)}):\n{proc.stderr}")


def _store_checked(built: Path, target: Path) -> None:
    """Move a freshly built file into the cache at `target`, its checksum beside it first."""
    try:
        digest = built.with_name(built.name + ".sha256")
        digest.write_text(_sha256(built))
        os.replace(digest, target.with_name(target.name + ".sha256"))   # the checksum first, then
        os.replace(built, target)                                         # the file it vouches for
    except OSError as exc:
        raise write_error(target, exc) from None


_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def _included(src: Path) -> list[Path]:
    """`src` and every local header it includes, directly or through another (each once)."""
    seen, todo = [], [src]
    while todo:
        path = todo.pop()
        if path in seen or not path.is_file():
            continue
        seen.append(path)
        todo += [path.parent / name for name in _INCLUDE.findall(path.read_text(errors="replace"))]
    return seen


def _forced_includes(flags, folders: list[Path]) -> list[Path]:
    """The headers `-include NAME` flags force into every source, found in `folders`."""
    names = [flags[i + 1] for i, f in enumerate(flags[:-1]) if f == "-include"]
    found = []
    for name in names:
        found += [folder / name for folder in folders if (folder / name).is_file()][:1]
    return found


def _object(src: Path, cc: str, flags: tuple[str, ...], root: Path, folders: list[Path]) -> Path:
    """`src` compiled (-c) into the object cache beside the libraries, keyed by its text and
    the local headers it includes (and those `-include` flags force in), the compiler
    identity and the flags: the same source under the same flags is compiled once,
    whichever folder and library it is for.  `folders`: every source folder of the
    library, searched for headers (a source may include another folder's, as the
    benchmark's rhs_cost.c includes the model's header)."""
    compile_flags = [f for f in flags if f != "-shared" and not f.startswith(("-Wl,", "-l"))]
    h = hashlib.sha256()
    parts = [path for header in _forced_includes(compile_flags, [src.parent, *folders])
             for path in _included(header)] + _included(src)
    for part in parts:
        h.update(part.name.encode() + b"\0" + hashlib.sha256(part.read_bytes()).digest())
    h.update(hashlib.sha256(compiler_identity(cc).encode()).digest())
    h.update(hashlib.sha256("\0".join(compile_flags).encode()).digest())
    obj = root / "objects" / h.hexdigest()[:32] / f"{src.stem}.o"
    with _building(obj):        # another thread compiling this very object: wait for it, then reuse it
        return _built_object(obj, src, cc, compile_flags, folders)


def _built_object(obj: Path, src: Path, cc: str, compile_flags: list[str], folders: list[Path]) -> Path:
    """The object `obj` from the cache, or compiled now (_object's work, under its lock)."""
    if obj.is_file() and _intact(obj) is True:
        return obj
    try:
        obj.parent.mkdir(parents=True, exist_ok=True)
        tmp = tempfile.mkdtemp(dir=obj.parent)
    except OSError as exc:
        raise write_error(obj, exc) from None
    try:
        out = Path(tmp) / obj.name
        includes = [arg for folder in dict.fromkeys([src.parent, *folders]) for arg in ("-I", str(folder))]
        _compile([*compiler_command(cc), *compile_flags, *includes, "-c", str(src), "-o", str(out)], obj, [src])
        _store_checked(out, obj)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    _verified.add(str(obj))
    return obj


def _refused_write(compiler_output: str) -> int | None:
    """The errno of a write the system refused, when the compiler (or its linker) says it
    could not write for lack of space or a file-size limit."""
    for code in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        if os.strerror(code) in compiler_output:
            return code
    return None


_verified: set[str] = set()            # libraries whose checksum this process has checked


def _sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _intact(lib: Path) -> bool | str | None:
    """True when a cached library matches the checksum written beside it when it was built
    (checked once per process); why not when it does not (or it or its checksum is a link
    or a file of another user: planted); None when it has no checksum (an older cache
    entry: rebuilt, not trusted)."""
    if str(lib) in _verified:
        return True
    mismatch = "does not match its checksum"
    try:
        digest = lib.with_name(lib.name + ".sha256")
        for part in (lib, digest):
            if part.is_symlink() or (hasattr(os, "getuid") and part.stat().st_uid != os.getuid()):
                return "or its checksum is a link or a file of another user"   # never loaded
        recorded = digest.read_text().strip()
    except FileNotFoundError:
        return None
    except (OSError, ValueError):    # unreadable, or bytes that are no text
        return mismatch
    if recorded != _sha256(lib):
        return mismatch
    _verified.add(str(lib))
    return True


_NO_VECTOR_MATH: set[str] = set()        # compilers that failed the vector-math build


def build_fastest(stem: str, sources: list[Path], extra: tuple[str, ...] = (),
                  cc: str | None = None, libs: tuple[str, ...] = ()) -> tuple[Path, tuple[str, ...]]:
    """build_library with VECTOR_MATH_FLAGS where they can work (Linux x86-64; a compiler
    or libc without libmvec fails once per process and is not asked again), else with the
    portable flags.  -> (library, the flags it was built with)."""
    cc = cc or default_compiler()
    if platform.system() == "Linux" and platform.machine() == "x86_64" and cc not in _NO_VECTOR_MATH:
        try:
            flags = (*VECTOR_MATH_FLAGS, *extra)
            return build_library(stem, sources, cc, flags, libs=libs), flags
        except LoaderError:
            _NO_VECTOR_MATH.add(cc)
    flags = (*PORTABLE_FLAGS, *extra)
    return build_library(stem, sources, cc, flags, libs=libs), flags


def build(source: Path, cc: str | None = None, flags: tuple[str, ...] = DEFAULT_FLAGS,
          cache: Path | None = None) -> Path:
    """Compile one `source` (and its header beside it) into the cache; return the library path."""
    return build_library(Path(source).stem, [Path(source)], cc, flags, cache)


class CKernel:
    """One batch entry point, called with NumPy arrays."""

    def __init__(self, lib: SharedLibrary, cname: str, suffix: str, inputs, outputs):
        self.name = cname
        self.dtype, ctype = _VARIANTS[suffix]
        self.inputs = inputs          # [(name, size)]
        self.outputs = outputs        # [(name, size, shape)]
        self._ptr = ctypes.POINTER(ctype)
        # n, each input with its row stride, the outputs, the status array
        entry = EntryPoint(f"{cname}_batch{{suffix}}", "int",
                           ("long", *("real *", "long") * len(inputs), *("real *",) * len(outputs),
                            "int *"))
        self._fn = lib.bind(entry, ctype, suffix=suffix)
        self._symbol = entry.symbol.format(suffix=suffix)
        self._lib = lib

    def at_point(self, *fixed) -> Callable:
        """This kernel at one point, its inputs after the first fixed (the parameters, say):
        ``f(x)`` with x of shape (size of the first input,) gives the first output, a new
        array.  For the callers that evaluate one point at a time in a loop (an integrator's
        rhs through scipy_rhs): the fixed inputs are converted once, and the call passes
        addresses (no broadcasting, no ctypes pointer objects), a few microseconds less a call.

        Parameters
        ----------
        *fixed : array_like
            The inputs after the first, each of its full size (one point).

        Returns
        -------
        callable
            f(x) -> the first output (its shape), NaN where the kernel cannot evaluate x.
        """
        if len(fixed) != len(self.inputs) - 1:
            raise TypeError(f"{self.name}: at_point takes the {len(self.inputs) - 1} inputs after the first")
        kept = []
        for a, (name, size) in zip(fixed, self.inputs[1:]):
            a = np.ascontiguousarray(np.asarray(a, self.dtype).reshape(-1))
            if a.size != size:
                raise ValueError(f"{self.name}: {name} must have {size} values, got {a.size}")
            kept.append(a)
        fn = self._lib.lib[self._symbol]         # its own function object: its own argument types
        fn.restype = ctypes.c_int
        fn.argtypes = [ctypes.c_long] + [ctypes.c_void_p, ctypes.c_long] * len(self.inputs) + \
            [ctypes.c_void_p] * len(self.outputs) + [ctypes.c_void_p]
        tail = [v for a in kept for v in (a.ctypes.data, 0)]
        size, dtype = self.inputs[0][1], self.dtype
        (_, out_size, out_shape), *others = self.outputs
        scratch = [np.empty(s, dtype) for _, s, _ in others]          # the outputs not returned
        scratch_addresses = [o.ctypes.data for o in scratch]

        def at(x):
            x = np.ascontiguousarray(x, dtype)
            if x.size != size:
                raise ValueError(f"{self.name}: {self.inputs[0][0]} must have {size} values, got {x.size}")
            out = np.empty(out_size, dtype)
            fn(1, x.ctypes.data, 0, *tail, out.ctypes.data, *scratch_addresses, None)
            return out.reshape(out_shape)

        at.keep = (kept, scratch)           # alive as long as the function is
        return at

    def __repr__(self) -> str:
        ins = ", ".join(f"{n}[{s}]" for n, s in self.inputs)
        return f"<CKernel {self.name}({ins}) {np.dtype(self.dtype).name}>"

    def __call__(self, *args, status: bool = False):
        if len(args) != len(self.inputs):
            raise TypeError(f"{self.name} takes {len(self.inputs)} arrays "
                            f"({', '.join(n for n, _ in self.inputs)}), got {len(args)}")
        arrays = []
        for a, (name, size) in zip(args, self.inputs):
            a = np.asarray(a, dtype=self.dtype)
            if a.ndim == 0 or a.shape[-1] != size:
                raise ValueError(f"{self.name}: {name} must have shape (..., {size}), got {a.shape}")
            arrays.append(a)
        batch = np.broadcast_shapes(*(a.shape[:-1] for a in arrays))
        n = prod(batch)
        call, keep = [n], []
        for a, (_, size) in zip(arrays, self.inputs):
            if a.shape[:-1] == batch:
                a, stride = np.ascontiguousarray(a), size
            elif prod(a.shape[:-1]) == 1:
                a, stride = np.ascontiguousarray(a.reshape(size)), 0
            else:
                a, stride = np.ascontiguousarray(np.broadcast_to(a, batch + (size,))), size
            keep.append(a)
            call += [a.ctypes.data_as(self._ptr), stride]
        outs = [np.empty((n, size), self.dtype) for _, size, _ in self.outputs]
        call += [o.ctypes.data_as(self._ptr) for o in outs]
        st = np.zeros(n, np.intc) if status else None
        call.append(st.ctypes.data_as(ctypes.POINTER(ctypes.c_int)) if status else None)
        self._fn(*call)
        results = [o.reshape(batch + shape) for o, (_, _, shape) in zip(outs, self.outputs)]
        result = results[0] if len(results) == 1 else tuple(results)
        if status:
            return result, st.reshape(batch)
        return result


class CompiledModel(SharedLibrary):
    """The kernels of one generated C file, as attributes (rhs, rhs_f, rhs_l, ...).

    Parameters
    ----------
    model : str
    lib_path : pathlib.Path
        The library built from <model>.c.
    header : str
        The text of <model>.h, whose prototypes and size macros declare the kernels.
    functions : str, optional
        What the kernels' C names start with, where it is not `model` (the file's stem):
        the file planar_linearize.c holds planar_linearize().
    """

    def __init__(self, model: str, lib_path: Path, header: str, functions: str | None = None):
        self.model = model
        super().__init__(lib_path)
        self.kernels: dict[str, CKernel] = {}
        macros = {m: int(v) for m, v in _DEFINE.findall(header)}
        prefix, functions = model.upper(), functions or model
        kernel_prefix = functions.upper()      # the kernels' macros: <FUNCTIONS>_<KERNEL>_<ARG>_SIZE
        for cname, suffix, argtext in _PROTO.findall(header):
            if not cname.startswith(functions + "_"):
                continue
            kname = cname[len(functions) + 1:]
            inputs, outputs = [], []
            for arg in argtext.split(", "):
                words = arg.replace("*", " ").split()
                name = words[-1]
                if name == "status" or (len(words) == 2 and words[0] == "long"):
                    continue
                m = f"{kernel_prefix}_{kname.upper()}_{name.upper()}"
                size, rank = macros[f"{m}_SIZE"], macros[f"{m}_RANK"]
                if words[0] == "const":
                    inputs.append((name, size))
                else:
                    shape = ((), (size,))[rank] if rank < 2 else (macros[f"{m}_ROWS"], macros[f"{m}_COLS"])
                    outputs.append((name, size, shape))
            self.kernels[kname + suffix] = CKernel(self, cname, suffix, inputs, outputs)
        self.names = {}
        for table, count in re.findall(rf"^extern const char \*const {model}_(\w+)\[{prefix}_N_(\w+)\];$",
                                       header, re.M):
            arr = self.value(ctypes.c_char_p * macros[f"{prefix}_N_{count}"], f"{model}_{table}")
            self.names[table] = tuple(s.decode() for s in arr)

    def __getattr__(self, name: str) -> CKernel:
        kernels = self.__dict__.get("kernels", {})
        if name in kernels:
            return kernels[name]
        raise AttributeError(f"model '{self.__dict__.get('model')}' has no kernel '{name}' "
                             f"(known: {', '.join(sorted(kernels))})")

    def __dir__(self):
        return sorted(set(super().__dir__()) | set(self.kernels))


_loaded: dict[Path, CompiledModel] = {}


def load(model: str, generated: Path | None = None, cc: str | None = None,
         flags: tuple[str, ...] = DEFAULT_FLAGS, cache: Path | None = None,
         file: str | None = None) -> CompiledModel:
    """Compile (if needed) and open the kernels <model>.c (or the model's file <file>.c,
    e.g. 'planar_linearize'), from `generated` (a folder of generated C, e.g. a checkout's
    generated/c) or else the cache's rendering; return them."""
    if generated is None:
        folder = model_sources(model) / "c"
    else:
        folder = Path(generated)
    stem = file or model
    source = folder / f"{stem}.c"
    if not source.is_file():
        raise LoaderError(f"no generated C for model '{model}' at {source}")
    lib = build(source, cc, flags, cache)
    if lib not in _loaded:
        _loaded[lib] = CompiledModel(stem, lib, source.with_suffix(".h").read_text(), functions=model)
    return _loaded[lib]


@forget_on_model_change
@lru_cache(maxsize=None)
def numpy_module(name: str):
    """The generated NumPy module `name` (a model, '<model>_integrate', '<model>_throughput',
    '<model>_linearize' or an atlas's prefix such as 'spherical_atlas'), imported from the
    cache's rendering of its model."""
    atlas = find_atlas(name) or next((a for a in atlases().values() if a.prefix == name), None)
    model = atlas.name if atlas is not None else \
        name.removesuffix("_integrate").removesuffix("_throughput").removesuffix("_linearize")
    return _import(numpy_source(model, f"{name}.py"), f"_derive_generated_{name}", model)


def _import(path: Path, name: str, model: str):
    if not path.is_file():
        raise SimulationInputError(f"no generated NumPy module {path.name} for model '{model}'")
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@forget_on_model_change
@lru_cache(maxsize=None)
def numpy_integrators(model: str) -> SimpleNamespace:
    """The NumPy integrators of a model, bound to the kernels numpy_module(model) imported.

    What the generated <model>_integrate.py gives a folder of generated NumPy (it loads the
    kernels beside it by file name, for a folder off sys.path), made here from the same
    library, derive_integrators.py of the model's rendering, and the session's one copy of
    the kernel module, the one the observables use.

    Parameters
    ----------
    model : str
        A model's name (catalogue or loaded model file); not the atlas (numpy_atlas).

    Returns
    -------
    types.SimpleNamespace
        integrate(method, y0, p, t, dtype, **options) and integrate_batch (the library's,
        with the kernels bound), library, system, METHODS, STATUS_NAMES, DEFAULTS, new_info.
    """
    library = _import(numpy_source(model, "derive_integrators.py"), f"_derive_generated_{model}_library", model)
    system = library.System(numpy_module(model))
    return SimpleNamespace(library=library, system=system, integrate=partial(library.integrate, system),
                           integrate_batch=partial(library.integrate_batch, system), METHODS=library.METHODS,
                           STATUS_NAMES=library.STATUS_NAMES, DEFAULTS=library.DEFAULTS,
                           new_info=library.new_info)
