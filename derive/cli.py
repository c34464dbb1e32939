"""The `derive` command line: one subcommand per pipeline stage, plus `run`."""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from .integration.simulate import SimulationInputError
from .model import ModelError, model_names
from .scene import SceneError

REPO_ROOT = Path(__file__).resolve().parent.parent


class UsageError(Exception):
    """Bad input from the user: reported as one line, exit status 2."""


def _derive_all(models: list[str]) -> tuple[float, list[tuple[str, float, bool]]]:
    from .derivation import derive
    from .derivation.derivation import is_cached
    rows, start = [], time.perf_counter()
    for name in models:
        warm = is_cached(name)
        t0 = time.perf_counter()
        derive(name)
        rows.append((name, time.perf_counter() - t0, warm))
    return time.perf_counter() - start, rows


def cmd_derive(args) -> int:
    models = args.models or model_names()
    for m in models:
        if m not in model_names():
            raise UsageError(f"unknown model '{m}' (known: {', '.join(model_names())})")
    total, rows = _derive_all(models)
    for name, seconds, warm in rows:
        print(f"{name:15s} {seconds:7.2f} s  ({'cache' if warm else 'derived'})")
    print(f"derived {len(rows)} models in {total:.2f} s")
    return 0


def _tally(results, checks) -> tuple[str, bool]:
    """'N seed formulas: a match, b errata, c failed; k/K physics checks pass', and all-good."""
    n_err = sum(r.verdict == "erratum" for r in results)
    n_bad = sum(r.verdict not in ("match", "erratum") for r in results)
    n_ok = sum(c.passed for c in checks)
    text = (f"{len(results)} seed formulas: {len(results) - n_err - n_bad} match, {n_err} errata, "
            f"{n_bad} failed; {n_ok}/{len(checks)} physics checks pass")
    return text, n_bad == 0 and n_ok == len(checks)


def cmd_verify(args) -> int:
    from .verification.cached import verify_all
    start = time.perf_counter()
    derive_seconds, rows = _derive_all(model_names())
    results, checks, from_cache = verify_all(fresh=args.fresh)
    seconds = time.perf_counter() - start
    tally, good = _tally(results, checks)
    if args.json:
        print(json.dumps([{"seed": r.seed, "equation": r.equation, "verdict": r.verdict,
                           "summary": r.summary} for r in results], indent=1))
        return 0 if good else 1
    width = max(len(r.equation) for r in results)
    print(f"{'seed':4s} {'equation':{width}s}  {'verdict':8s} what / summary")
    for r in results:
        text = r.what if r.verdict == "match" else r.summary
        print(f"{r.seed[:3]:4s} {r.equation:{width}s}  {r.verdict:8s} {text}")
    print()
    for c in checks:
        print(f"{'ok  ' if c.passed else 'FAIL'} {c.name}: {c.detail}")
    derivations = "warm" if all(w for _, _, w in rows) else "cold"
    print(f"\n{tally}")
    print(f"time {seconds:.1f} s (derivations {derive_seconds:.1f} s from a {derivations} cache; "
          f"verdicts {'from the cache' if from_cache else 'computed'})")
    return 0 if good else 1


def cmd_generate(args) -> int:
    from .codegen.generate import generate_all
    changed, diff = generate_all(REPO_ROOT, check=args.check)
    if args.check:
        if changed:
            sys.stdout.write(diff)
            print(f"generated/ is stale: {len(changed)} file(s) differ; run `derive generate`",
                  file=sys.stderr)
            return 1
        print("generated/ is up to date")
        return 0
    print(f"wrote {len(changed)} changed file(s)" if changed else "generated/ already up to date")
    for path in changed:
        print(f"  {path}")
    return 0


class _OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage mistake is one line on stderr and exit status 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def _writable(path: Path) -> Path:
    if path.exists() and path.is_dir():
        raise UsageError(f"output path '{path}' is a directory")
    if not path.parent.exists():
        raise UsageError(f"cannot write '{path}': directory '{path.parent}' does not exist")
    return path


def cmd_latex(args) -> int:
    if args.model not in model_names():
        raise UsageError(f"unknown model '{args.model}' (known: {', '.join(model_names())})")
    out = _writable(Path(args.output or f"{args.model}.tex"))
    from .derivation import derive
    from .report.latex import render
    from .verification.cached import verify_all
    d = derive(args.model)
    results = [r for r in verify_all()[0] if r.model == args.model]
    try:
        out.write_text(render(d, results))
    except OSError as exc:
        raise UsageError(f"cannot write '{out}': {exc.strerror}") from None
    print(f"wrote {out} ({len(results)} verified formulas)")
    if args.pdf:
        import subprocess
        run = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", out.name],
                             cwd=out.parent, capture_output=True, text=True)
        if run.returncode != 0:
            raise UsageError(f"pdflatex failed on {out}; see {out.with_suffix('.log')}")
        print(f"wrote {out.with_suffix('.pdf')}")
    return 0


def _print_run(summary: dict) -> None:
    s = summary
    print(f"scene   {s['scene']}: {s['title']}")
    print(f"model   {s['model']} ({s['model_reason']})")
    for line in s["steps"]:
        print(f"        {line}")
    tol = f"rtol {s['rtol']:.2g}" if s["rtol"] is not None else f"step {s['step']:g}"
    print(f"method  {s['method']}, {tol}, {s['dtype']}, backend {s['backend']}"
          + (f" -- {s['note']}" if s["note"] else ""))
    if s["lyapunov_exponent"] is not None and s["trust_horizon"] is not None:
        print(f"chaos   largest Lyapunov exponent {s['lyapunov_exponent']:.3g}; trust horizon "
              f"t = {s['trust_horizon']:.3g} for error {s['target'] or 1e-8:g}")
    if s["target"] is not None:
        achieved = "not measured" if s["achieved_error"] is None else f"{s['achieved_error']:.2g}"
        print(f"error   target {s['target']:g}, predicted {s['predicted_error']:.2g}, achieved {achieved}")
    if not s["ok"]:
        print(f"stopped {s['message']}")
    print(f"result  {s['status']} at t = {s['t_stop']:g} after {s['nfev']} rhs evaluations"
          + (f", {s['chart_switches']} chart switches" if s["chart_switches"] is not None else "")
          + f"; relative energy error {s['relative_energy_error']:.2g}")
    print(f"state   {', '.join(f'{v:.10g}' for v in s['final_state'])}")
    for f in s["files"]:
        print(f"wrote   {f}")
    print(f"time    {s['seconds']:.2f} s")


def cmd_run(args) -> int:
    from .scene import load_scene
    from .scene.outputs import write_outputs
    from .scene.run import run, summary
    scene = load_scene(args.scene)
    if args.output_dir:
        scene.output_dir = Path(args.output_dir)
    start = time.perf_counter()
    outcome = run(scene, show_progress=not args.quiet and not args.json)
    outcome.files = write_outputs(outcome)
    outcome.seconds = time.perf_counter() - start
    s = summary(outcome)
    if args.json:
        print(json.dumps(s, indent=1))
    elif not args.quiet:
        _print_run(s)
    return 0 if outcome.result.ok else 1


def cmd_all(args) -> int:
    """The main job: derive, verify, generate (check), compile, run the default scene."""
    from .codegen.generate import generate_all
    from .scene import load_scene
    from .scene.artifacts import prepare
    from .scene.run import run, summary
    from .verification.cached import verify_all
    start = time.perf_counter()
    seconds, rows = _derive_all(model_names())
    cached = sum(w for _, _, w in rows)
    print(f"derive    {len(rows)} models in {seconds:.1f} s ({cached} from the cache)")
    t0 = time.perf_counter()
    results, checks, from_cache = verify_all()
    tally, verified = _tally(results, checks)
    print(f"verify    {tally} ({time.perf_counter() - t0:.1f} s{', cached' if from_cache else ''})")
    t0 = time.perf_counter()
    changed, _ = generate_all(REPO_ROOT, check=True)
    print(f"generate  generated/ {'is current' if not changed else f'is STALE in {len(changed)} files'} "
          f"({time.perf_counter() - t0:.1f} s)")
    t0 = time.perf_counter()
    for name in model_names() + ["spherical"]:
        prepare(name, "c")
    print(f"compile   C kernels and integrators of every model ({time.perf_counter() - t0:.1f} s)")
    outcome = run(load_scene(REPO_ROOT / "scenes" / "default.toml"), show_progress=False)
    s = summary(outcome)
    print(f"run       {s['title']}: {s['method']} {s['dtype']} rtol {s['rtol']:.2g}, final-state error "
          f"{s['achieved_error']:.2g} (target {s['target']:g}), trust horizon t = {s['trust_horizon']:.3g}, "
          f"{s['nfev']} rhs evaluations in {s['seconds']:.2f} s")
    ok = verified and not changed and outcome.result.ok
    print(f"{'done' if ok else 'FAILED'} in {time.perf_counter() - start:.1f} s")
    return 0 if ok else 1


# -- derive bench (the work-precision benchmark: derive/measurement/bench.py) ----------

def cmd_bench(args) -> int:
    from .measurement.bench import BenchOptions, console_report, run_bench, write_all
    from .scene.progress import Progress
    if args.repeats < 1:
        raise UsageError(f"--repeats must be >= 1, got {args.repeats}")
    from .scene.outputs import writable_dir
    try:
        out = writable_dir(Path(args.out))
    except OSError as exc:
        raise UsageError(f"cannot write to '{args.out}': {exc.strerror}") from None
    problems = tuple(x for x in args.problems.split(",") if x) if args.problems else None
    bar = None if args.quiet else Progress("bench", 1)

    def progress(done, total, label=""):
        if bar is not None:
            bar.total = max(total, 1)
            bar.update(done)

    opts = BenchOptions(problems=problems, quick=args.quick, repeats=args.repeats,
                        throughput=not args.no_throughput, progress=progress)
    try:
        result = run_bench(opts)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    finally:
        if bar is not None:
            bar.close()
    files = write_all(result, out, plots=not args.no_plots)
    if not args.quiet:
        print(console_report(result))
        for f in files:
            print(f"wrote   {f}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = _OneLineParser(
        prog="derive", description="Derive, verify and generate code for double pendulums.")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("derive", help="derive the equations of motion (cached)")
    p.add_argument("models", nargs="*", help=f"models (default: all of {', '.join(model_names())})")
    p.set_defaults(func=cmd_derive)
    p = sub.add_parser("verify", help="check every seed formula against the derivation")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.add_argument("--fresh", action="store_true", help="judge every formula again, ignoring cached verdicts")
    p.set_defaults(func=cmd_verify)
    p = sub.add_parser("generate", help="regenerate generated/ from derive/ and templates/")
    p.add_argument("--check", action="store_true",
                   help="write nothing; exit 1 with a diff when generated/ is stale")
    p.set_defaults(func=cmd_generate)
    p = sub.add_parser("latex", help="write the derivation of a model as a standalone .tex")
    p.add_argument("model", help="model name")
    p.add_argument("-o", "--output", help="output .tex path (default: MODEL.tex)")
    p.add_argument("--pdf", action="store_true", help="also run pdflatex")
    p.set_defaults(func=cmd_latex)
    p = sub.add_parser("run", help="simulate a scene file (TOML), deriving and building only what it needs")
    p.add_argument("scene", help="scene file, e.g. scenes/default.toml")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no summary")
    p.add_argument("--json", action="store_true", help="print a machine-readable summary")
    p.add_argument("--output-dir", help="write outputs here instead of the scene's output.directory")
    p.set_defaults(func=cmd_run)
    p = sub.add_parser("all", help="the main job: derive, verify, generate, compile, run the default scene")
    p.set_defaults(func=cmd_all)
    p = sub.add_parser("bench", help="work-precision benchmark of every model, method, precision and "
                                     "backend against scipy/numba/hand-written peers")
    p.add_argument("--quick", action="store_true", help="a small subset (seconds), for smoke tests")
    p.add_argument("--out", default=str(REPO_ROOT / "bench" / "results"),
                   help="output directory (default: bench/results)")
    p.add_argument("--repeats", type=int, default=5, help="timed runs per configuration (median; default 5)")
    p.add_argument("--problems", help="comma-separated subset of: regular, chaotic, compound, spherical_pole")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--no-throughput", action="store_true", help="skip the batched-RK4 throughput runs")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no report")
    p.set_defaults(func=cmd_bench)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (UsageError, ModelError, SceneError, SimulationInputError) as exc:
        print(f"derive: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("derive: interrupted", file=sys.stderr)
        return 130
