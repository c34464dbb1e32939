"""The generated C under AddressSanitizer and UndefinedBehaviorSanitizer.

For a catalogue model (planar, from generated/) and a user model (examples/models/
triple.toml, through `derive generate FILE --out DIR`), a C driver written here from the
headers calls EVERY exported function (kernels single and batched, the integrators and
their batch entry points, the step building blocks, dense output, the fixed-step and
throughput loops) in float, double and long double, with ordinary, NaN, infinite and NaN
parameter inputs, batches of n = 0 and n = 3, and stride-0 (broadcast) arrays.  Every
buffer is allocated at exactly the size the header states, so a read or write past it
is an ASan error; -fno-sanitize-recover=all makes any report fatal."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SANITIZE = ("-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer")
CC = os.environ.get("CC") or shutil.which("gcc") or shutil.which("cc") or shutil.which("clang")
PROTO = re.compile(r"^(int|long|void|const char \*)\s*(\w+)\((.*)\);$", re.M)
TYPES = {"float": "f", "double": "d", "long double": "l", "derive_quad": "q"}

pytestmark = [pytest.mark.slow, pytest.mark.skipif(CC is None, reason="no C compiler")]


def prototypes(folder: Path) -> list[tuple[str, str, list[str], str]]:
    """(return type, name, arguments, header) of every function the headers declare."""
    out = []
    for h in sorted(folder.glob("*.h")):
        for ret, name, args in PROTO.findall(h.read_text()):
            params = [] if args.strip() == "void" else [a.strip() for a in args.split(",")]    # f(void): none
            out.append((ret.strip(), name, params, h.stem))
    return out


def _arg(arg: str) -> tuple[str, str, bool, bool, str]:
    """(C type, name, pointer, const, form) of one parameter; form 'rows' for T (*K)[N]."""
    m = re.match(r"^(const )?(long double|double|float|int|long|\w+)\s*(\(\*restrict (\w+)\)\[\w+\]|"
                 r"\*\s*(?:restrict )?(\w+)|(\w+))$", arg)
    assert m, arg
    const, ctype = bool(m.group(1)), m.group(2)
    if m.group(4):
        return ctype, m.group(4), True, const, "rows"
    if m.group(5):
        return ctype, m.group(5), True, const, "array"
    return ctype, m.group(6), False, const, "scalar"


class Driver:
    """C source calling every function of one model's headers."""

    def __init__(self, model: str, header_text: str):
        self.model, self.M = model, model.upper()
        self.macros = dict(re.findall(rf"^#define ({self.M}_\w+) (-?\d+)$", header_text, re.M))
        self.methods = len([k for k in self.macros if k.startswith(f"{self.M}_METHOD_")])
        self.lines: list[str] = []
        self.called: set[str] = set()

    def size(self, func: str, name: str, ctype: str, form: str, batch: bool) -> str:
        """The element count of one array argument (per trajectory when `batch`)."""
        M = self.M
        kernel = re.sub(rf"^{self.model}_", "", func)
        kernel = re.sub(r"(_batch)?(_f|_l|_dd|_q)?$", "", kernel).upper()
        macro = f"{M}_{kernel}_{name.upper()}_SIZE"
        if macro in self.macros:
            return macro
        if form == "rows":
            return f"({'7' if name == 'F' else M + '_INTEGRATE_MAX_STAGES'} * {M}_N_STATES)"
        if name == "p":
            return f"{M}_N_PARAMS"
        if name == "t":
            return "NT"
        if name == "y_out":
            return f"(NT * {M}_N_STATES)"
        if name == "chart_out":
            return "NT"
        if name in ("err", "chart0", "status", "steps"):
            return "1"
        if name == "coef":                  # <model>_taylor_coefficients at order 8
            return f"({M}_N_STATES * 9)"
        return f"{M}_N_STATES"

    def call(self, ret: str, func: str, args: list[str]) -> None:
        parsed = [_arg(a) for a in args]
        batch = any(n == "n" and not ptr for _, n, ptr, _, _ in parsed)
        throughput = "_throughput_" in func
        body, values, frees = [], [], []
        for ctype, name, ptr, const, form in parsed:
            if not ptr:
                values.append({"n": "n", "method": "method", "chart": "0", "chart0": "0", "nt": "NT",
                               "nsteps": "10", "ld": "n", "h": "0.01", "theta": "0.5", "rule": "0.5",
                               "status": "st", "order": "8", "sine_min": "0.1"}.get(name) or
                              (f"(bcast ? 0 : {self.size(func, name[:-7], ctype, 'array', True)})"
                               if name.endswith("_stride") else None) or _fail(func, name))
                continue
            if ctype.endswith("_options"):
                values.append("&opt")
                continue
            if ctype.endswith("_info"):
                body.append(f"{ctype} *{name} = calloc(n_alloc, sizeof *{name});")
                values.append(name)
                frees.append(name)
                continue
            count = self.size(func, name, ctype, form, batch)
            if throughput and name == "y":
                count = f"{self.M}_N_STATES"            # structure of arrays: N x ld
            per = f"({count}) * n_alloc" if (batch and name != "t") or throughput and name in ("y", "status", "steps") \
                else f"({count})"
            if batch and name.endswith("stride") is False and any(
                    n2 == f"{name}_stride" for _, n2, _, _, _ in parsed):
                per = f"({count}) * (bcast ? 1 : n_alloc)"      # a broadcast array holds one item
            body.append(f"{ctype} *{name} = malloc(sizeof({ctype}) * {per});")
            if ctype in TYPES:
                body.append(f"fill_{TYPES[ctype]}({name}, {per}, vs, {1 if name == 'p' else 0});")
                if name == "t":
                    body.append(f"for (long k = 0; k < NT; k++) t[k] = ({ctype})k * 0.025;")
            elif ctype == "derive_dd":
                body.append(f"fill_dd({name}, {per}, vs, {1 if name == 'p' else 0});")
                if name == "t":
                    body.append("for (long k = 0; k < NT; k++) { t[k].hi = (double)k * 0.025; t[k].lo = 0; }")
            else:
                body.append(f"memset({name}, 0, sizeof({ctype}) * {per});")
            cast = f"({ctype} (*)[{self.M}_N_STATES])" if form == "rows" else ""
            values.append(cast + name)
            frees.append(name)
        needs = {"n": batch or throughput, "method": any(n == "method" for _, n, *_ in parsed)}
        call = f"{func}({', '.join(values)})"
        code = [f"sink += (double)({call});" if ret in ("int", "long") else
                f"sink += (double)strlen({call});" if ret.startswith("const char") else f"{call};"]
        if needs["method"]:
            code = [f"for (int method = 0; method < {self.methods}; method++) {{", *code, "}"]
        if any(n == "status" and not p for _, n, p, *_ in parsed):
            code = ["for (int st = -1; st < 9; st++) {", *code, "}"]
        self.lines += ["{", *body, *code, *[f"free({f});" for f in frees], "}"]
        if not needs["n"]:
            self.lines[-len(body) - len(code) - len(frees) - 2] = "if (n == 0 && !bcast) {"
        self.called.add(func)

    def source(self, includes: list[str]) -> str:
        fills = "\n".join(f"""
static void fill_{s}({t} *a, long count, int vs, int params) {{
    for (long k = 0; k < count; k++) a[k] = params ? ({t})1 + ({t})(k % 3) / 4 : ({t})0.3 + ({t})(k % 5) / 7;
    if (count > 0 && !params && vs == 1) a[0] = NAN;
    if (count > 1 && !params && vs == 2) a[1] = INFINITY;
    if (count > 1 && !params && vs == 2) a[count - 1] = -INFINITY;
    if (count > 0 && params && vs == 3) a[0] = NAN;
}}""" for t, s in TYPES.items()) + """
static void fill_dd(derive_dd *a, long count, int vs, int params) {
    double *d = malloc(sizeof(double) * (size_t)(count > 0 ? count : 1));
    fill_d(d, count, vs, params);
    for (long k = 0; k < count; k++) { a[k].hi = d[k]; a[k].lo = 0; }
    free(d);
}"""
        return "\n".join([
            "#include <math.h>", "#include <stdio.h>", "#include <stdlib.h>", "#include <string.h>",
            *[f'#include "{h}.h"' for h in includes], "#define NT 5", fills,
            "int main(void) {", "    double sink = 0;",
            f"    {self.model}_integrate_options opt;",
            "    for (int vs = 0; vs < 4; vs++) for (int nb = 0; nb < 2; nb++) for (int bcast = 0; bcast < 2; bcast++) {",
            "    long n = nb ? 3 : 0; long n_alloc = n ? n : 1;",
            f"    {self.model}_integrate_defaults(&opt); opt.h = 0.01; opt.max_steps = 20000;",
            *self.lines,
            "    }", '    printf("calls done %d\\n", sink == sink || sink != sink);', "    return 0;", "}"])


def _fail(func, name):
    raise AssertionError(f"{func}: no value for scalar argument {name}")


def _driver_for(folder: Path, model: str) -> tuple[str, list[str], set[str]]:
    protos = prototypes(folder)
    text = "\n".join(h.read_text() for h in sorted(folder.glob("*.h")))
    d = Driver(model, text)
    for ret, name, args, _ in protos:
        if name.startswith(model):
            d.call(ret, name, args)
    names = {name for _, name, _, _ in protos if name.startswith(model)}
    return d.source(sorted({h for *_, h in protos})), names, d.called


def _sanitized_run(folder: Path, model: str, tmp_path: Path, extra=()) -> subprocess.CompletedProcess:
    source, exported, called = _driver_for(folder, model)
    assert exported and exported == called, sorted(exported - called)      # every entry point
    driver = tmp_path / "driver.c"
    driver.write_text(source)
    exe = tmp_path / "driver"
    sources = sorted(str(c) for c in folder.glob(f"{model}*.c"))
    build = subprocess.run([CC, "-std=c99", "-O1", "-g", *SANITIZE, *extra, "-I", str(folder), str(driver),
                            *sources, "-o", str(exe), "-lquadmath", "-lm"], capture_output=True, text=True, timeout=900)
    assert build.returncode == 0, build.stderr[-3000:]
    env = dict(os.environ, ASAN_OPTIONS="detect_leaks=1:abort_on_error=0",
               UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1")
    return subprocess.run([str(exe)], capture_output=True, text=True, timeout=900, env=env)


def _generated(tmp_path: Path, model_file: Path) -> Path:
    out = tmp_path / "gen"
    run = subprocess.run([sys.executable, "-m", "derive", "generate", str(model_file), "--out", str(out)],
                         env=dict(os.environ, PYTHONPATH=str(ROOT)), capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr
    return out / "c"


def _folder_of(model: str, tmp_path: Path) -> Path:
    if model == "planar":                    # the catalogue's golden files, as shipped
        folder = tmp_path / "planar"
        folder.mkdir()
        for f in [*(ROOT / "generated" / "c").glob("planar*"), *(ROOT / "generated" / "c").glob("derive_*.h")]:
            shutil.copy(f, folder)      # the model's files and the integrators' C library
        return folder
    return _generated(tmp_path, ROOT / "examples" / "models" / f"{model}.toml")


@pytest.mark.parametrize("model", ["planar", "triple"])
def test_every_entry_point_runs_clean_under_asan_and_ubsan(model, tmp_path):
    run = _sanitized_run(_folder_of(model, tmp_path), model, tmp_path)
    assert run.returncode == 0 and "runtime error" not in run.stderr and "ERROR: " not in run.stderr, \
        run.stderr[-4000:]
    assert "calls done 1" in run.stdout


def test_the_driver_calls_every_prototype(tmp_path):
    """The driver generator covers every declared function (a new entry point, e.g. from a
    template change, fails here until it is called)."""
    source, exported, called = _driver_for(ROOT / "generated" / "c", "planar")
    assert len(exported) > 80 and exported == called
    for name in exported:
        assert re.search(rf"\b{name}\(", source), name


STEP_COUNT_DRIVER = r"""
#include <stdio.h>
#include "planar_integrate.h"
int main(void) {
    double y0[PLANAR_N_STATES] = {2.5, 2.0, 0.0, 0.0}, p[PLANAR_N_PARAMS] = {1, 1, 1, 1, 9.81};
    double t[2] = {0.0, 1.0}, y[2 * PLANAR_N_STATES];
    planar_integrate_options opt;
    planar_integrate_info info;
    planar_integrate_defaults(&opt);
    opt.h = 1e-30;                       /* 1e30 steps: more than a long can count */
    int status = planar_integrate(PLANAR_METHOD_RK4, y0, p, 2, t, y, &opt, &info);
    printf("status %d\n", status);
    return status == PLANAR_INTEGRATE_BAD_INPUT ? 0 : 1;
}
"""


def test_a_step_count_that_overflows_is_refused_in_c(tmp_path):
    folder = _folder_of("planar", tmp_path)
    (tmp_path / "steps.c").write_text(STEP_COUNT_DRIVER)
    exe = tmp_path / "steps"
    build = subprocess.run([CC, "-std=c99", "-O1", "-g", *SANITIZE, "-fsanitize=float-cast-overflow",
                            "-I", str(folder), str(tmp_path / "steps.c"), str(folder / "planar_integrate.c"),
                            str(folder / "planar.c"), "-o", str(exe), "-lm"],
                           capture_output=True, text=True, timeout=900)
    assert build.returncode == 0, build.stderr[-3000:]
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0 and "runtime error" not in run.stderr, (run.stdout, run.stderr[-2000:])


MSAN = ("-fsanitize=memory", "-fsanitize-memory-track-origins", "-fno-sanitize-recover=all",
        "-fno-omit-frame-pointer")
UNINITIALISED = r"""
#include <stdio.h>
#include <stdlib.h>
int main(void) {
    double *a = malloc(4 * sizeof(double));
    a[0] = 1;
    if (a[2] > 0) printf("positive\n");      /* a[2] was never written */
    printf("done\n");
    free(a);
    return 0;
}
"""


def _msan_clang(tmp_path: Path) -> str:
    """clang with a working MemorySanitizer runtime; an environment without one fails the test
    (tests/run.sh installs it: Debian's libclang-rt-dev)."""
    clang = shutil.which(os.environ.get("DERIVE_TEST_CLANG", "clang"))
    assert clang, "clang not found: MemorySanitizer needs clang (apt-get install clang libclang-rt-dev)"
    probe = tmp_path / "uninitialised.c"
    probe.write_text(UNINITIALISED)
    build = subprocess.run([clang, "-O1", "-g", *MSAN, str(probe), "-o", str(tmp_path / "uninitialised")],
                           capture_output=True, text=True, timeout=300)
    assert build.returncode == 0, ("clang cannot build with -fsanitize=memory (its runtime, "
                                   "libclang_rt.msan, is missing: apt-get install libclang-rt-dev): "
                                   + build.stderr[-1500:])
    # the runtime works: a read of uninitialised memory is reported, with its origin
    run = subprocess.run([str(tmp_path / "uninitialised")], capture_output=True, text=True, timeout=120)
    assert run.returncode != 0 and "use-of-uninitialized-value" in run.stderr, run.stderr[-2000:]
    assert "allocated by" in run.stderr or "malloc" in run.stderr, run.stderr[-2000:]
    return clang


def test_every_entry_point_runs_clean_under_memory_sanitizer(tmp_path):
    """The same driver for planar (every entry point: kernels, integrators, steps, dense
    output, loops, Taylor, lanes, double-double and quad) built with clang's MemorySanitizer,
    which reports any branch, index or call argument computed from uninitialised memory
    (an output the generated code forgets to write and then reads, a scratch array used
    before it is filled).  The quad translation unit is included: libquadmath is not
    instrumented, but every quad value the driver passes in is initialised and the
    library's results are only returned, so no report is expected from it; clang finds
    <quadmath.h> among GCC's headers."""
    clang = _msan_clang(tmp_path)
    folder = _folder_of("planar", tmp_path)
    source, exported, called = _driver_for(folder, "planar")
    assert exported and exported == called, sorted(exported - called)
    assert any(name.endswith("_q") for name in called)            # quad is among them
    driver = tmp_path / "driver.c"
    driver.write_text(source)
    exe = tmp_path / "driver"
    gcc_include = subprocess.run(["gcc", "-print-file-name=include"], capture_output=True, text=True).stdout.strip()
    sources = sorted(str(c) for c in folder.glob("planar*.c"))
    build = subprocess.run([clang, "-std=c99", "-O1", "-g", *MSAN, "-idirafter", gcc_include, "-I", str(folder),
                            str(driver), *sources, "-o", str(exe), "-lquadmath", "-lm"],
                           capture_output=True, text=True, timeout=900)
    assert build.returncode == 0, build.stderr[-3000:]
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=900,
                         env=dict(os.environ, MSAN_OPTIONS="halt_on_error=1"))
    assert run.returncode == 0 and "WARNING: MemorySanitizer" not in run.stderr, run.stderr[-4000:]
    assert "calls done 1" in run.stdout
