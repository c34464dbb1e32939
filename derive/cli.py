"""The `derive` command line: one subcommand per pipeline stage, plus `run`, `all` and `bench`.

Every failure derive expects is a DeriveError (derive/errors.py): main() prints it
as one line and exits with its status (2: bad input or a missing tool; 1: a run
that failed).  Anything else is a bug in derive, reported in one line too
(DERIVE_DEBUG=1 shows the traceback).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

from .paths import BENCH_OUT, VERSION as __version__
from .errors import DeriveError, UsageError
from .model.listing import is_model_file, model_names
from .paths import checkout_root, writable_dir
from .progress import Stage

INTERRUPTED = 130            # Ctrl-C: the shell's status for a command stopped by SIGINT (derive/__main__.py)
EXIT_CODES = ("exit status: 0 done (and an accuracy target met); 1 a run or check that failed; "
              "2 bad input or a missing tool; 3 a run that finished but missed its accuracy target; "
              f"{INTERRUPTED} interrupted (Ctrl-C)")


def _model_arg(arg: str, allow_atlas: bool = False) -> str:
    """A model argument (a catalogue name, or the path of a model file) as a model name."""
    from .model import load_model    # start-up: a command imports its stage when it runs
    from .model.atlas import atlas_names
    if is_model_file(arg):
        return load_model(arg).name
    if allow_atlas and arg in atlas_names():
        return arg
    load_model(arg)                       # an unknown name is a ModelError naming the known ones
    return arg


def _model_args(args: list[str], allow_atlas: bool = False) -> list[str]:
    """Every model argument resolved; a bad one is reported in one line and skipped, so one
    bad model never stops the others (the command then exits 2 after doing the rest)."""
    names, bad = [], []
    for arg in args:
        try:
            names.append(_model_arg(arg, allow_atlas))
        except DeriveError as exc:
            bad.append(exc)
    if bad and not names:           # nothing to do: the last error is the command's
        for exc in bad[:-1]:
            print(f"derive: error: {exc}", file=sys.stderr)
        raise bad[-1]
    for exc in bad:
        print(f"derive: error: {exc}", file=sys.stderr)
    return names, bad


def _derive_all(models: list[str], stage: Stage | None = None,
                pairs: list[tuple[str, str]] = ()) -> tuple[float, list[tuple[str, float, bool]]]:
    """Derive `models` (the uncached ones side by side in worker processes, with the chart
    changes `pairs` a later step needs), then read them: (seconds, [(name, seconds, warm)])."""
    from .derivation import derive    # start-up: a command imports its stage when it runs
    from .derivation.batch import derive_uncached
    from .derivation.derivation import is_cached
    start = time.perf_counter()
    warm = {name: is_cached(name) for name in models}
    if stage is not None and not all(warm.values()):
        stage.set(f"{sum(not w for w in warm.values())} models side by side")
    derived = derive_uncached([m for m in models if not warm[m]], list(pairs))
    rows = []
    for i, name in enumerate(models, 1):
        if stage is not None:
            stage.set(f"{name} ({i}/{len(models)})")
        t0 = time.perf_counter()
        derive(name)
        rows.append((name, derived.get(name, time.perf_counter() - t0), warm[name]))
    return time.perf_counter() - start, rows


def _chart_pairs() -> list[tuple[str, str]]:
    """(source, target) of every chart change the catalogue's physics checks and atlas
    kernels need: each spherical model to the other members of its atlas."""
    from .codegen.spec import conversion_targets    # start-up: a command imports its stage when it runs
    from .model import load_model
    return [(name, target) for name in model_names() for target in conversion_targets(load_model(name))]


def cmd_derive(args) -> int:
    from .codegen.sources import members    # start-up: a command imports its stage when it runs
    models, bad = _model_args(args.models, allow_atlas=True)
    models = [m for name in models for m in members(name)] or model_names()    # the atlas: its charts
    with Stage("deriving") as stage:
        total, rows = _derive_all(models, stage)
    for name, seconds, warm in rows:
        print(f"{name:15s} {seconds:7.2f} s  ({'cache' if warm else 'derived'})")
    print(f"derived {len(rows)} model{'s' * (len(rows) != 1)} in {total:.2f} s")
    return 2 if bad else 0


def _tally(results, checks) -> tuple[str, bool]:
    """'N seed formulas: a match, b errata, c failed; k/K physics checks pass', and all-good;
    for models no seed formula belongs to (a user's own), the physics checks alone, named."""
    n_err = sum(r.verdict == "erratum" for r in results)
    n_bad = sum(r.verdict not in ("match", "erratum") for r in results)
    n_ok = sum(c.passed for c in checks)
    if not results:
        kinds = dict.fromkeys(c.name.split(": ", 1)[-1] for c in checks)
        return f"{n_ok}/{len(checks)} physics checks pass ({'; '.join(kinds)})", n_ok == len(checks)
    text = (f"{len(results)} seed formulas: {len(results) - n_err - n_bad} match, {n_err} errata, "
            f"{n_bad} failed; {n_ok}/{len(checks)} physics checks pass")
    return text, n_bad == 0 and n_ok == len(checks)


def _verify(fresh: bool = False):
    from .verification.cached import verify_all    # start-up: a command imports its stage when it runs
    with Stage("verifying") as stage:
        stage.set("deriving")
        derive_seconds, rows = _derive_all(model_names(), stage, _chart_pairs())
        stage.set("judging the seed formulas and the physics checks")
        results, checks, from_cache = verify_all(fresh=fresh)
    return derive_seconds, rows, results, checks, from_cache


def _verify_models(names: list[str]):
    """The seed verdicts and physics checks of the given models only (cached per model)."""
    from .verification.cached import physics_model, verify_model  # start-up: a command imports its stage when it runs
    results, checks = [], []
    with Stage("verifying") as stage:
        derive_seconds, rows = _derive_all(names, stage)
        for name in names:
            stage.set(name)
            results += verify_model(name)
            checks += physics_model(name)
    return derive_seconds, rows, results, checks, False


def cmd_verify(args) -> int:
    start = time.perf_counter()
    names, bad = _model_args(args.models)
    if names:
        derive_seconds, rows, results, checks, from_cache = _verify_models(names)
    else:
        derive_seconds, rows, results, checks, from_cache = _verify(args.fresh)
    seconds = time.perf_counter() - start
    tally, good = _tally(results, checks)
    if args.json:
        from .report.forms import verification_json    # start-up: a command imports its stage when it runs
        print(json.dumps(verification_json(results, checks), indent=1))
        return 2 if bad else 0 if good else 1
    if results:                 # a model without seed formulas has only its physics checks
        width = max(len(r.equation) for r in results)
        print(f"{'seed':4s} {'equation':{width}s}  {'verdict':8s} what / summary")
        for r in results:
            text = r.what if r.verdict == "match" else r.summary
            print(f"{r.seed[:3]:4s} {r.equation:{width}s}  {r.verdict:8s} {text}")
        print()
    for c in checks:
        print(f"{'ok  ' if c.passed else 'FAIL'} {c.name}: {c.detail}")
    if names:
        from .model import load_model                       # start-up: a command imports its stage when it runs
        from .verification.physics import not_applicable
        for name in names:
            for check, why in not_applicable(name):
                print(f"n/a  {load_model(name).name}: {check}: {why}")
    derivations = "warm" if all(w for _, _, w in rows) else "cold"
    print(f"\n{tally}")
    print(f"time {seconds:.1f} s (derivations {derive_seconds:.1f} s from a {derivations} cache; "
          f"verdicts {'from the cache' if from_cache else 'computed'})")
    return 2 if bad else 0 if good else 1


# -- derive generate --------------------------------------------------------------------

def _golden_root() -> Path:
    root = checkout_root()
    if root is None:
        raise UsageError("no golden generated/ here: this derive is installed, not a source checkout; "
                         "give --out DIR to generate into a folder of yours")
    return root


def cmd_generate(args) -> int:
    from .codegen import generate    # start-up: a command imports its stage when it runs
    from .codegen.backends import selected
    names, bad = _model_args(args.models, allow_atlas=True)
    backends = None if args.backend is None else tuple(b.name for b in selected(args.backend))
    if args.out:
        out, shown = Path(args.out), args.out.rstrip("/") or "/"
    else:
        if names:
            raise UsageError("give --out DIR for these models: without --out, derive generate "
                             "rewrites the catalogue's golden generated/ only")
        if backends is not None:
            raise UsageError("give --out DIR with --backend: the golden generated/ holds the "
                             "default backends only")
        out, shown = _golden_root() / "generated", "generated"
    names = names or generate.catalogue_names()
    if not args.check:
        _writable_folder(out)
    with Stage("generating") as stage:
        # --out DIR: only these models' files (others generated there before stay)
        written = generate.write_models(out, names, backends, check=args.check, prune=not args.out,
                                        shown=shown,
                                        progress=lambda i, n, name: stage.set(f"{name} ({i}/{n})"))
    changed, diff = written.changed, written.diff
    if not args.out:                # the golden files include the templates' compiled form
        more, more_diff = generate.write_compiled_templates(check=args.check)
        changed, diff = changed + more, diff + more_diff
    if args.check:
        if written.note:
            print(f"note: {written.note}", file=sys.stderr)
        if changed:
            sys.stdout.write(diff)
            chosen = "".join(f" --backend {b}" for b in backends or ())
            print(f"{shown}/ is stale: {len(changed)} file(s) differ; run `derive generate"
                  f"{' ' + ' '.join(args.models) + ' --out ' + args.out + chosen if args.out else ''}`",
                  file=sys.stderr)
            return 1
        print(f"{shown}/ is up to date ({len(written.files)} files of {len(names)} models)")
        return 2 if bad else 0
    if not args.out:
        print(f"rewrote the golden files in {out} (the catalogue: {len(names)} models)")
    print(f"wrote {len(changed)} changed file(s)" if changed else f"{shown}/ already up to date")
    for path in changed:
        print(f"  {path}")
    return 2 if bad else 0


def _writable_folder(path: Path) -> Path:
    try:
        return writable_dir(path)
    except OSError as exc:
        raise UsageError(f"cannot write to '{path}': {exc.strerror or exc}") from None
    except ValueError as exc:          # a NUL byte in the path
        raise UsageError(f"cannot write to {str(path)!r}: {exc}") from None


# -- derive latex -----------------------------------------------------------------------

class _OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage mistake is one line on stderr and exit status 2, and an option
    is only ever its full name (argparse would take `latex --out tex` for `--output tex`)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def _writable_file(path: Path) -> Path:
    if path.exists() and path.is_dir():
        raise UsageError(f"output path '{path}' is a directory")
    if not path.parent.exists():
        raise UsageError(f"cannot write '{path}': directory '{path.parent}' does not exist")
    return path


def cmd_latex(args) -> int:
    from .report.document import document, pdflatex    # start-up: a command imports its stage when it runs
    name = _model_arg(args.model, allow_atlas=True)
    if args.out is not None:
        out = _writable_file(_writable_folder(args.out) / f"{name}.tex")
    else:
        out = _writable_file(Path(args.output or f"{name}.tex"))
    with Stage("latex") as stage:
        doc = document(args.model, args.paper, progress=stage.set)
    try:
        out.write_text(doc.text)
    except OSError as exc:
        raise UsageError(f"cannot write '{out}': {exc.strerror or exc}") from None
    print(f"wrote {out} ({len(doc.results)} verified formulas, {len(doc.checks)} physics checks)")
    if args.pdf:
        with Stage("pdflatex"):
            pdf = pdflatex(out)
        print(f"wrote {pdf}")
    return 0


# -- derive run -------------------------------------------------------------------------

def _json_safe(value):
    """JSON has no infinity or NaN: an infinite trust horizon is "beyond the run", any
    other non-finite number null."""
    import math    # start-up: a command imports its stage when it runs
    if isinstance(value, dict):
        return {k: ("beyond the run" if k == "trust_horizon" and isinstance(v, float) and math.isinf(v)
                    else _json_safe(v)) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _print_run(summary: dict) -> None:
    s = summary
    print(f"scene   {s['scene']}: {s['title']}")
    print(f"model   {s['model']} ({s['model_reason']})"
          + (f"; kernels {s['specialised']}, the parameters folded in" if s.get("specialised") else ""))
    for line in s["steps"]:
        print(f"        {line}")
    tol = f"rtol {s['rtol']:.2g}" if s["rtol"] is not None else f"step {s['step']:g}"
    if s.get("last_step"):
        tol += f" (the last {s['last_step']:.3g}, to reach t = {s['t_stop']:g})"
    print(f"method  {s['method']}, {tol}, {s['dtype']}, backend {s['backend']}"
          + (f" -- {s['note']}" if s["note"] else ""))
    if s["lyapunov_exponent"] is not None and s["trust_horizon"] is not None:
        print(f"chaos   largest Lyapunov exponent {s['lyapunov_exponent']:.3g}; {_horizon_text(s)}"
              + (f" ({s['lyapunov_note']})" if s.get("lyapunov_note") else ""))
    print(f"error   {_error_text(s)}")
    if not s["ok"] and s["status"] != "meaningless":      # (a meaningless result: the reason says why)
        print(f"stopped {s['message']}")
    print(f"result  {s['status']} at t = {s['t_stop']:g} after {s['nfev']} rhs evaluations"
          + (f", {s['chart_switches']} chart switches" if s["chart_switches"] is not None else ""))
    print(f"energy  {_energy_text(s)}")
    if s.get("constraint_drift"):
        c = s["constraint_drift"]
        print(f"loop    constraint drift max |Phi| = {c['phi']:.3g}, max |J q'| = {c['phi_dot']:.3g} "
              + (f"(above the bound {c['bound']:g}: tighten the target)" if c["exceeded"] else
                 f"(within {c['bound']:g})"))
    for name, e in (s.get("events") or {}).items():
        when = ", ".join(f"{t:.10g}" for t in e["t"][:3]) + (", ..." if len(e["t"]) > 3 else "")
        print(f"event   {name} ({e['expression']}): {len(e['t'])} crossing{'s' * (len(e['t']) != 1)}"
              + (f" at t = {when}" if e["t"] else "")
              + (" -- terminal: the run stops there" if s.get("terminal_event") == name else ""))
    print(f"state   {', '.join(f'{n} = {v:.10g}' for n, v in zip(s['state_names'], s['final_state']))}"
          + (f" (chart {s['final_chart']})" if s["final_chart"] else ""))
    for f in s["files"]:
        note = s.get("file_notes", {}).get(f)
        print(f"wrote   {f}" + (f" ({note})" if note else ""))
    print(f"time    {s['seconds']:.2f} s"
          + (f" (writing the files {s['outputs_seconds']:.2f} s)" if s["files"] else ""))


def _horizon_text(s: dict) -> str:
    """The trust horizon in words: a horizon at the start is "never within" that error."""
    import math    # start-up: a command imports its stage when it runs
    level, horizon = s["horizon_error"], s["trust_horizon"]
    if s["early_error"] is not None and horizon <= s["t_start"]:
        return f"never within error {level:g} (its early error, about {s['early_error']:.2g}, is above it)"
    if math.isinf(horizon):
        return f"trust horizon beyond the run for error {level:g}"
    return f"trust horizon t = {horizon:.3g} for error {level:g}"


def _error_text(s: dict) -> str:
    """The achieved final-state error against the reference run, and the target's verdict."""
    reference = (f"reference {s['reference_method']} at rtol {s['reference_rtol']:.2g} in "
                 f"{s['reference_precision']}") if s["reference_rtol"] is not None else ""
    achieved = None if s["achieved_error"] is None else f"{s['achieved_error']:.2g}"
    if s["target"] is not None:
        predicted = ("not estimated" if s["predicted_error"] is None       # no Lyapunov estimate
                     else f"{s['predicted_error']:.2g}")
        head = f"target {s['target']:g}, predicted {predicted}"
        if achieved is None:          # said once: why it was not measured
            why = s["not_measured"] or "the run stopped"
            return f"{head}, achieved not measured: {why}" + (f" ({reference})" if reference else "")
        verdict = {True: "met", False: "MISSED"}[s["target_met"]]
        return f"{head}, achieved {achieved} ({'; '.join(x for x in (verdict, reference) if x)})"
    if achieved is not None:
        return f"final-state error {achieved} (no target; {reference})"
    why = s["not_measured"] or "the run stopped"
    own = (f"; its own local-error sum {s['error_estimate']:.2g} (not a global error)"
           if s["error_estimate"] is not None else "")
    return f"not measured: {why}{own}"


def _in_words(items: list[str]) -> str:
    """["a", "b", "c"] -> "a, b and c" (as derive.model.description.in_words, not imported at start-up)."""
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _energy_text(s: dict) -> str:
    """The relative energy error (or change) and what it is relative to."""
    what = ("relative error" if s["conservative"] else
            f"relative change (the work of {_in_words(s.get('work_done_by') or ['forces and damping'])})")
    error, scale = s["relative_energy_error"], f"{s['energy_scale']:.4g} = {s['energy_scale_is']}"
    if error is None or not abs(error) < float("inf"):          # overflowed (inf) or none finite (NaN)
        text = f"{what} not finite (its scale {scale})"
    else:
        text = f"{what} {error:.2g} of {scale}"
    stopped = not s["ok"] and s["status"] != "meaningless"
    return text + (", over the outputs before the stop" if stopped else "")


def _list_examples() -> int:
    from .scene.examples import example_listing    # start-up: a command imports its stage when it runs
    rows = example_listing()
    width = max(len(name) for name, _, _ in rows)
    for name, title, sweep in rows:
        print(f"{name:{width}s}  {title}" + (f" (a sweep: derive sweep {name})" if sweep else ""))
    return 0


def cmd_run(args) -> int:
    if args.list:
        return _list_examples()
    if args.scene is None:
        raise UsageError("derive run: give a scene file or an example's name (derive run --list lists them)")
    from .scene import load_scene    # start-up: a command imports its stage when it runs
    from .scene.outputs import write_outputs
    from .scene.run import run, summary, verdict
    scene = load_scene(args.scene)
    if args.output_dir:
        scene.output_dir = Path(args.output_dir)
    if scene.trajectory or scene.plots:         # before the work, not after it
        _writable_folder(scene.output_dir)
    start = time.perf_counter()
    outcome = run(scene, show_progress=not args.quiet and not args.json)
    t0 = time.perf_counter()
    outcome.files = write_outputs(outcome)
    outcome.seconds = time.perf_counter() - start
    s = summary(outcome)
    s["outputs_seconds"] = time.perf_counter() - t0
    status, reason = verdict(outcome)
    s["exit_status"], s["reason"] = status, reason
    if args.json:
        print(json.dumps(_json_safe(s), indent=1, allow_nan=False))
    elif not args.quiet:
        _print_run(s)
    for line in s["warnings"]:      # even with --quiet: a run past its trust horizon
        print(f"derive: {line}", file=sys.stderr)
    if reason is not None:          # even with --quiet: the one line that says why
        print(f"derive: {reason}", file=sys.stderr)
    return status


# -- derive all -------------------------------------------------------------------------

def _generate_step() -> tuple[str, bool]:
    """In a checkout: is generated/ what derive produces now?  Installed: render every
    catalogue model's code into the cache (there are no golden files to compare)."""
    from .codegen import generate, sources    # start-up: a command imports its stage when it runs
    root = checkout_root()
    with Stage("generate") as stage:
        if root is not None:
            stage.set("rendering the catalogue to compare with generated/")
            changed, _ = generate.generate_all(root, check=True)
            return (f"generated/ {'is current' if not changed else f'is STALE in {len(changed)} files'}",
                    not changed)
        names = generate.catalogue_names()
        for i, name in enumerate(names, 1):
            stage.set(f"rendering {name} into the cache ({i}/{len(names)})")
            sources.model_sources(name)
        return f"rendered {len(names)} models into the cache", True


def cmd_all(args) -> int:
    """The main job: derive, verify, generate (check), compile, run the default scene."""
    from .codegen.sources import ATLAS    # start-up: a command imports its stage when it runs
    from .scene import load_scene
    from .scene.artifacts import prepare_c
    from .scene.run import run, summary
    from .codegen.generate import catalogue_names
    from .codegen.sources import is_render_cached, render_into_cache
    start = time.perf_counter()
    t0 = time.perf_counter()
    with Stage("derive") as stage:
        seconds, rows = _derive_all(model_names(), stage, _chart_pairs())
    cached = sum(w for _, _, w in rows)
    print(f"derive    {len(rows)} models in {seconds:.1f} s ({cached} from the cache)")
    t0 = time.perf_counter()
    from .verification.cached import verify_all
    # the generated code needs the derivations only: the workers render it meanwhile
    by_cost = sorted(catalogue_names(), key=lambda name: name.startswith("spherical_"), reverse=True)
    renders = [(render_into_cache, (name,)) for name in by_cost if not is_render_cached(name)]
    with Stage("verify") as stage:
        stage.set("the seed formulas and the physics checks (and rendering the code)")
        results, checks, from_cache = verify_all(alongside=renders)
    tally, verified = _tally(results, checks)
    rendered = f", the code of {len(renders)} models rendered meanwhile" if renders else ""
    print(f"verify    {tally} ({time.perf_counter() - t0:.1f} s{', cached' if from_cache else ''}{rendered})")
    t0 = time.perf_counter()
    text, generated = _generate_step()
    print(f"generate  {text} ({time.perf_counter() - t0:.1f} s)")
    t0 = time.perf_counter()
    with Stage("compile") as stage:
        prepare_c(model_names() + [ATLAS], stage)
    print(f"compile   C kernels and integrators of every model ({time.perf_counter() - t0:.1f} s)")
    outcome = run(load_scene("default"), show_progress=sys.stderr.isatty())
    s = summary(outcome)
    print(f"run       {s['title']}: {s['method']} {s['dtype']} rtol {s['rtol']:.2g}, final-state error "
          f"{s['achieved_error']:.2g} (target {s['target']:g}), trust horizon t = {s['trust_horizon']:.3g}, "
          f"{s['nfev']} rhs evaluations in {s['seconds']:.2f} s")
    ok = verified and generated and outcome.result.ok
    print(f"{'done' if ok else 'FAILED'} in {time.perf_counter() - start:.1f} s")
    return 0 if ok else 1


# -- derive bench (the work-precision benchmark: derive/measurement/bench/) -------------

def cmd_bench(args) -> int:
    from .measurement.bench import BenchOptions, console_report, run_bench, write_all  # start-up: a command imports its stage when it runs
    from .progress import Progress
    if args.race:
        return _race(args)
    if args.repeats < 1:
        raise UsageError(f"--repeats must be >= 1, got {args.repeats}")
    out = _writable_folder(Path(args.out))
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
        if isinstance(exc, DeriveError):
            raise
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


def _race(args) -> int:
    """derive bench --race: derive against heyoka through both public APIs (measurement/race.py)."""
    from .measurement.race import console, run_race, write_race  # start-up: a command imports its stage when it runs
    from .progress import Progress
    out = _writable_folder(Path(args.out))
    bar = None if args.quiet else Progress("race", 1)

    def progress(done, total):
        if bar is not None:
            bar.total = max(total, 1)
            bar.update(done)

    try:
        race = run_race(quick=args.quick, progress=progress)
    finally:
        if bar is not None:
            bar.close()
    files = write_race(race, out, plots=not args.no_plots)
    if not args.quiet:
        print(console(race))
        for f in files:
            print(f"wrote   {f}")
    return 0


# -- derive sweep (derive/sweep: sweeps and maps on Dask, the `sweep` extra) ---------------

def cmd_sweep(args) -> int:
    from .sweep import require_extra    # start-up: a command imports its stage when it runs
    require_extra()
    from .sweep.driver import run
    from .sweep.sweep_file import load_sweep
    sweep = load_sweep(args.sweep)
    if args.out is not None:
        _writable_folder(Path(args.out))
    report = run(sweep, out=args.out, scheduler=args.scheduler, workers=args.workers,
                 progress=not args.quiet)
    if not args.quiet:
        rate = report.written_trajectories / report.seconds if report.seconds > 0 else 0.0
        print(f"sweep   {sweep.source}: {report.trajectories:,} trajectories over "
              f"{' x '.join(f'{d} {n}' for d, n in zip(sweep.dims, sweep.shape))}")
        mirrored = f" ({report.mirrored} as the mirror image of another)" if report.mirrored else ""
        print(f"chunks  {report.chunks} ({report.computed} computed on {report.where}{mirrored}, "
              f"{report.skipped} done before)")
        print(f"store   {report.store}")
        for image in report.images:
            print(f"wrote   {image}")
        per_cpu = report.written_trajectories / report.cpu_seconds if report.cpu_seconds > 0 else 0.0
        integrated = report.computed_trajectories / report.cpu_seconds if report.cpu_seconds > 0 else 0.0
        print(f"time    {report.seconds:.2f} s ({rate:,.0f} trajectories/s"
              + (f", {rate / report.workers:,.0f} per worker" if report.workers else "")
              + f"; {per_cpu:,.0f} per CPU second"
              + (f", {integrated:,.0f} integrated" if report.mirrored else "") + ")")
    return 0


def _assignments(items: list[str] | None, what: str) -> dict[str, str]:
    """NAME=VALUE pairs from repeated (or comma-separated) options, the values as written."""
    out: dict[str, str] = {}
    for item in items or []:
        for pair in filter(None, (s.strip() for s in item.split(","))):
            name, eq, value = pair.partition("=")
            if not eq or not name.strip() or not value.strip():
                raise UsageError(f"{what}: expected NAME=VALUE, got {pair!r}")
            if name.strip() in out:
                raise UsageError(f"{what}: '{name.strip()}' is given twice "
                                 f"({out[name.strip()]} and {value.strip()}); give it once")
            out[name.strip()] = value.strip()
    return out


def _matrix_lines(title: str, M, rows: list[str], cols: list[str]) -> list[str]:
    width = max([len(c) for c in cols] + [12])
    head = " " * (max(map(len, rows), default=0) + 2) + " ".join(f"{c:>{width}}" for c in cols)
    return [title, head] + [f"{r:<{max(map(len, rows))}}  " + " ".join(f"{v + 0.0:>{width}.6g}" for v in row)
                            for r, row in zip(rows, M)]


def cmd_linearize(args) -> int:
    from .runtime.linearize import linearize, parse_value    # start-up: imported when it runs
    from .runtime.simulate import model_ref, resolve_model
    ref = model_ref(resolve_model(args.model, explicit_time=True))
    params = {n: parse_value(v, f"--param {n}") for n, v in _assignments(args.param, "--param").items()}
    inputs = {n: parse_value(v, f"--input {n}") for n, v in _assignments(args.input, "--input").items()}
    state = _assignments(args.at, "--at")
    independent = [n.strip() for item in args.independent or [] for n in item.split(",") if n.strip()] or None
    if args.equilibria:
        return _print_equilibria(ref, params, args.json, independent)
    names, inputs_names = list(ref.info.state_names), list(ref.info.input_names)
    if args.project:
        from .runtime.loop_state import consistent_state       # start-up: imported when it runs
        from .runtime.linearize import state_values
        state = dict(zip(names, consistent_state(ref.name, state_values(ref, state), params).tolist()))
    A, B = linearize(ref.name, state, params, inputs or None, t=args.time, independent=independent)
    at = dict.fromkeys(names, 0.0) | {n: parse_value(v, f"--at {n}") for n, v in state.items()}
    if independent:       # a closed loop's A and B are in its free coordinates and their rates
        names = independent + [f"{n}_dot" for n in independent]
    if args.json:
        print(json.dumps({"ok": True, "model": ref.name, "state": at, "params": params,
                          "inputs": {n: inputs.get(n, 0.0) for n in inputs_names},
                          "state_names": names, "input_names": inputs_names,
                          "A": A.tolist(), "B": B.tolist()}, indent=1))
        return 0
    when = "" if args.time is None else f" and t = {parse_value(args.time, '--time'):g}"
    print(f"{ref.name} at " + ", ".join(f"{n} = {v:g}" for n, v in at.items()) + when)
    print("\n".join(_matrix_lines("A = df/dx", A, names, names)))
    if inputs_names:
        print("\n".join(_matrix_lines("B = df/du", B, names, inputs_names)))
    else:
        print("B = df/du: the model has no inputs")
    return 0


def _print_equilibria(ref, params: dict, as_json: bool, independent=None) -> int:
    from .runtime.linearize import equilibria    # start-up: imported when it runs
    found = equilibria(ref.name, params, independent=independent)
    if as_json:
        print(json.dumps({"ok": True, "model": ref.name, "equilibria": [
            {"state": e["state"], "stability": e["stability"],
             "eigenvalues": [[float(z.real), float(z.imag)] for z in e["eigenvalues"]]} for e in found]}, indent=1))
        return 0
    for e in found:
        at = ", ".join(f"{n} = {v:.6g}" for n, v in e["state"].items() if not n.endswith("_dot"))
        top = max(z.real for z in e["eigenvalues"])
        print(f"{e['stability']:15s} {at}" + ("" if math.isnan(top) else f"  (largest real part {top:.3g})"))
    return 0


def _linearize_parser(sub, model_help: str) -> None:
    p = sub.add_parser("linearize", help="the linearisation A = df/dx, B = df/du of a model at a state",
                       epilog=EXIT_CODES)
    p.add_argument("model", help=model_help)
    p.add_argument("--at", action="append", metavar="NAME=VALUE",
                   help="the state (repeat or separate by commas; left out: 0; values may use pi)")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help="a parameter (every one is needed)")
    p.add_argument("--input", action="append", metavar="NAME=VALUE", help="an input (left out: 0)")
    p.add_argument("--time", metavar="T", default=None,
                   help="the time t to linearize at (a time-dependent model needs it)")
    p.add_argument("--equilibria", action="store_true",
                   help="list the equilibria (q' = 0, u = 0) with their stability instead")
    p.add_argument("--independent", action="append", metavar="NAME",
                   help="a closed loop: a coordinate it leaves free (repeat or separate by commas); "
                        "A and B (and --equilibria's stability) are in these coordinates and their rates")
    p.add_argument("--project", action="store_true",
                   help="a closed loop: first put the state on the loop (derive.consistent_state)")
    p.add_argument("--json", action="store_true", help="print A and B (or the equilibria) as JSON")
    p.set_defaults(func=cmd_linearize)


def _sweep_parser(sub) -> None:
    p = sub.add_parser("sweep", help="run a sweep file (a scene plus axes and quantities) on Dask into "
                                     "a Zarr store, with an image per quantity of a 2-D sweep",
                       epilog=EXIT_CODES)
    p.add_argument("sweep", help="sweep file, or the name of an example sweep (flip_map)")
    p.add_argument("--out", help="output directory (default: the file's output.directory)")
    p.add_argument("--scheduler", help="an existing Dask scheduler, tcp://HOST:PORT "
                                       "(default: $DASK_SCHEDULER_ADDRESS, else a local cluster)")
    p.add_argument("--workers", type=int, help="local worker processes (default: one per core; "
                                               "0: run in this process)")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no summary")
    p.set_defaults(func=cmd_sweep)


def build_parser() -> argparse.ArgumentParser:
    parser = _OneLineParser(
        prog="derive", description="Derive, verify and generate code for pendulums.",
        epilog=EXIT_CODES)
    parser.add_argument("--version", action="version",
                        version=f"derive {__version__} (Python {sys.version.split()[0]})")
    sub = parser.add_subparsers(dest="command", required=True)
    model_help = "a catalogue model name or the path of a model file (.toml)"
    p = sub.add_parser("derive", help="derive the equations of motion (cached)", epilog=EXIT_CODES)
    p.add_argument("models", nargs="*", help=f"models (default: all of {', '.join(model_names())}); "
                                            f"each {model_help}")
    p.set_defaults(func=cmd_derive)
    p = sub.add_parser("verify", help="check every seed formula against the derivation, and the physics "
                                      "of every model (or of the models given)", epilog=EXIT_CODES)
    p.add_argument("models", nargs="*", help=f"only these models; each {model_help}")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.add_argument("--fresh", action="store_true", help="judge every formula again, ignoring cached verdicts")
    p.set_defaults(func=cmd_verify)
    p = sub.add_parser("generate", help="generate C and NumPy: the golden generated/ of a checkout, "
                                        "or chosen models into --out DIR", epilog=EXIT_CODES)
    p.add_argument("models", nargs="*", help=f"models to generate (needs --out); each {model_help}, "
                                            f"or 'spherical' for the chart atlas")
    p.add_argument("--out", help="write DIR/c/ and DIR/numpy/ (default: the checkout's generated/)")
    p.add_argument("--check", action="store_true",
                   help="write nothing; exit 1 with a diff when the folder is stale")
    p.add_argument("--backend", action="append", metavar="NAME",
                   help="a target language, as its folder of derive/codegen/backends/ is named (a "
                        "wrong name lists them); repeat for several; needs --out (default: every backend that needs no "
                        "optional extra)")
    p.set_defaults(func=cmd_generate)
    p = sub.add_parser("latex", help="write the derivation of a model as a standalone .tex", epilog=EXIT_CODES)
    p.add_argument("model", help=f"{model_help}, or 'spherical' for the chart atlas")
    where = p.add_mutually_exclusive_group()
    where.add_argument("-o", "--output", help="output .tex path (default: MODEL.tex here)")
    where.add_argument("--out", type=Path, help="output directory (made if missing): writes OUT/MODEL.tex")
    p.add_argument("--pdf", action="store_true", help="also compile it with pdflatex (TeX Live)")
    p.add_argument("--paper", choices=("a4", "letter"), default="a4",
                   help="paper size, portrait (default: a4)")
    p.set_defaults(func=cmd_latex)
    p = sub.add_parser("run", help="simulate a scene file (TOML), deriving and building only what it needs",
                       epilog=EXIT_CODES)
    p.add_argument("scene", nargs="?", help="scene file, or the name of an example scene (default, "
                                            "spherical_pole, ...: see --list)")
    p.add_argument("--list", action="store_true", help="list the example scenes, one line each, and exit")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no summary")
    p.add_argument("--json", action="store_true", help="print a machine-readable summary")
    p.add_argument("--output-dir", help="write outputs here instead of the scene's output.directory")
    p.set_defaults(func=cmd_run)
    p = sub.add_parser("all", help="the main job: derive, verify, generate, compile, run the default scene",
                       epilog=EXIT_CODES)
    p.set_defaults(func=cmd_all)
    p = sub.add_parser("bench", help="work-precision benchmark of every model, method, precision and "
                                     "backend against scipy/numba/hand-written peers", epilog=EXIT_CODES)
    p.add_argument("--quick", action="store_true", help="a small subset (seconds), for smoke tests")
    p.add_argument("--out", default=BENCH_OUT, help=f"output directory (default: ./{BENCH_OUT})")
    p.add_argument("--repeats", type=int, default=5, help="timed runs per configuration (median; default 5)")
    p.add_argument("--problems", help="comma-separated subset of: regular, chaotic, compound, spherical_pole")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--no-throughput", action="store_true", help="skip the batched-RK4 throughput runs")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no report")
    p.add_argument("--race", action="store_true",
                   help="only the race against heyoka through both public APIs (needs heyoka: the bench "
                        "extra); writes race.md, race.csv, race.png")
    p.set_defaults(func=cmd_bench)
    _sweep_parser(sub)
    _linearize_parser(sub, model_help)
    return parser


def _quick_exit() -> None:
    """Let the interpreter's final garbage collections skip what the command made: after a
    command, every SymPy expression it built is still alive, and Python's collections at
    exit walked them all (about 0.1 s after `derive generate` of a small model, a ninth
    of the command).  gc.freeze() moves them out of the collector's sight; the process
    still ends normally (exit handlers run, files are flushed and closed)."""
    import gc
    gc.freeze()


def main(argv: list[str] | None = None) -> int:
    args = None
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        status = args.func(args)
        if argv is None:        # the command line's own process, about to end: see _quick_exit
            _quick_exit()
        return status
    except DeriveError as exc:
        if getattr(args, "json", False):     # --json stays valid JSON on failure too
            print(json.dumps({"ok": False, "error": str(exc), "exit_status": exc.exit_status}, indent=1))
        print(f"derive: error: {exc}", file=sys.stderr)
        return exc.exit_status
    except KeyboardInterrupt:
        print("derive: interrupted", file=sys.stderr)
        return INTERRUPTED
    except BrokenPipeError:
        return 1
    except Exception as exc:            # a bug in derive: still one line, unless asked
        if os.environ.get("DERIVE_DEBUG"):
            raise
        print(f"derive: internal error: {type(exc).__name__}: {exc} "
              f"(a bug in derive {__version__}; DERIVE_DEBUG=1 shows the traceback)", file=sys.stderr)
        return 1
