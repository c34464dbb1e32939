"""The run contract of the generated integrators, once, as data.

Everything a run's two sides must agree on lives here: the methods (their
index in the C switch, kind, implicit flag and order), the status codes and
their names, the fields of the options and info structs (C type, default,
comment) and the counters of a run.  The templates under derive/templates
render their enums, status tables, struct definitions and `_defaults`
functions from these lists (derive/codegen/integrators.py passes them in the
Jinja context), derive/runtime/build.py and atlas_runner.py build the ctypes
Structures from the same field lists, and simulate, the atlas and the
benchmarks read the method and status tables from here.

It sits in the code generation stage, below the run time, because it is the
interface between the integrators' generation (derive/codegen/integrators.py) and
their run time (derive/runtime: build, simulate, the atlas runner): the ABI both sides
read.  It imports nothing of derive but the atlas data (derive/model/atlas.py), so
every stage from code generation on may import it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..model.atlas import ATLAS, load_atlas


@dataclass(frozen=True)
class Method:
    name: str
    index: int           # the value of <M>_METHOD_<NAME> in the C switch
    kind: str            # "fixed" or "adaptive"
    implicit: bool
    order: int
    doc: str             # one line in the header's method list
    multistep: bool = False      # needs a history of past steps
    atlas: bool = True           # in the chart atlas' step switch (spherical_atlas.c)

    @property
    def macro(self) -> str:
        return self.name.upper()


@dataclass(frozen=True)
class Status:
    code: int
    macro: str           # <M>_INTEGRATE_<MACRO>
    name: str            # what status_name says
    doc: tuple[str, ...]     # the header's description (lines; {theta_*} filled in by codegen)


@dataclass(frozen=True)
class Field:
    name: str
    ctype: str           # C type ("double", "long", "int", "const volatile int *")
    default: object = None   # options: the value <M>_integrate_defaults sets (None: SINE_MIN; cancel: NULL)
    c_default: str = ""      # ... as a C literal ("" for sine_min: the model's SINE_MIN macro)
    py_default: str = ""     # ... as a Python literal (generated NumPy DEFAULTS)
    doc: str = ""            # comment in <M>_integrate.h
    atlas_doc: str = ""      # comment in spherical_atlas.h
    length: str = ""         # an array: "n" (the number of states)


METHOD_TABLE = (
    Method("rk4", 0, "fixed", False, 4, "classical Runge-Kutta, order 4, fixed step (seed 001)"),
    Method("dopri5", 1, "adaptive", False, 5, "Dormand-Prince 5(4), adaptive, FSAL, 4th-order dense output"),
    Method("dop853", 2, "adaptive", False, 8, "Dormand-Prince 8(5,3), adaptive, 7th-order dense output"),
    Method("midpoint", 3, "fixed", True, 2,
           "implicit midpoint rule (Gauss-Legendre, 1 stage), order 2, fixed step"),
    Method("gauss2", 4, "fixed", True, 4, "Gauss-Legendre, 2 stages, order 4, fixed step"),
    Method("rk8", 5, "fixed", False, 8, "the 8th-order formula of DOP853 at a fixed step (12 stages)",
           atlas=False),
    Method("abm12", 6, "fixed", False, 12,
           "12-step Adams-Bashforth-Moulton PECE, order 12, fixed step, rk8 start (see below)",
           multistep=True, atlas=False),
)

STATUS_TABLE = (
    Status(0, "OK", "ok", ("every requested output was computed",)),
    Status(1, "STEP_UNDERFLOW", "step-size underflow",
           ("the adaptive step fell below hmin to meet the tolerance",)),
    Status(2, "MAX_STEPS", "maximum number of steps reached", ("options.max_steps steps were taken",)),
    Status(3, "NEWTON", "Newton iteration diverged",
           ("the Newton iteration of an implicit method did not",
            "converge: an increment not finite, growing by",
            "{theta_diverge} or more, or growing again after the Jacobian was",
            "re-evaluated at the stage values (it is, whenever the",
            "contraction rate |dZ_k|/|dZ_k-1| exceeds {theta_max}), or",
            "options.newton_max iterations; the step is too large",
            "for the motion.  No step is taken from such an iteration")),
    Status(4, "NONFINITE", "non-finite state or derivative",
           ("a derivative or the state became NaN or infinite",)),
    Status(5, "CHART_SINGULAR", "chart singular (polar sine below threshold)",
           ("the chart is singular there: a polar sine below",
            "options.sine_min (the mass matrix is singular)")),
    Status(6, "BAD_INPUT", "bad input", ("non-finite or inconsistent input (y0, p, t, options),",
                                         "a fixed-step method without its step options.h > 0,",
                                         "or a fixed step too small for the span",
                                         "(|t_end - t0| / h above 2^53)")),
    Status(7, "CANCELLED", "cancelled", ("*options.cancel became non-zero (checked every step)",)),
    Status(8, "MULTISTEP_UNSTABLE", "multistep unstable (step too large for abm12)",
           ("abm12: the predictor-corrector difference (Milne's",
            "estimate of the local error) exceeded atol + rtol |y|:",
            "the step is outside the method's stability region",
            "or too large for the motion; no step is taken from it")),
)

OPTIONS = (
    Field("rtol", "double", 1e-9, "1e-9", "1e-9", "adaptive: relative tolerance (default 1e-9)"),
    Field("atol", "double", 1e-12, "1e-12", "1e-12", "adaptive: absolute tolerance (default 1e-12)"),
    Field("h", "double", 0.0, "0", "0.0", "fixed step; adaptive: initial step (0: automatic)"),
    Field("hmin", "double", 0.0, "0", "0.0", "adaptive: smallest step (0: 16 eps max(|t|, |h|))"),
    Field("hmax", "double", 0.0, "0", "0.0", "adaptive: largest step (0: |t_end - t0|)"),
    Field("max_steps", "long", 100_000_000, "100000000L", "100000000",
          "steps (accepted and rejected) before giving up (default 10^8)"),
    Field("newton_tol", "double", 0.0, "0", "0.0", "implicit: scaled increment to stop Newton (0: 10 eps)"),
    Field("newton_max", "int", 30, "30", "30", "implicit: iterations per step (default 30)"),
    Field("sine_min", "double", None, "", "SINE_MIN", "no kernel evaluated where a polar sine is below this",
          atlas_doc="hard threshold"),
    # the caller's flag, read before every step: a run stops with CANCELLED once it is
    # non-zero (set from a signal handler or another thread; volatile: re-read each time)
    Field("cancel", "const volatile int *", None, "0", "None",
          "non-zero *cancel stops the run (CANCELLED); 0: none", atlas_doc="CANCELLED when *cancel != 0"),
)

INFO = (
    Field("status", "int", doc="{M}_INTEGRATE_*"),
    Field("nfev", "long", doc="right-hand side evaluations"),
    Field("njev", "long", doc="Jacobian evaluations (implicit: one per step, one per stage per re-evaluation)"),
    Field("nsteps", "long", doc="steps attempted"),
    Field("naccepted", "long"),
    Field("nrejected", "long"),
    Field("nnewton", "long", doc="Newton iterations"),
    Field("nout", "long", doc="output rows written"),
    Field("t", "double", doc="time reached (where it stopped on failure)"),
    Field("h", "double", doc="last step size (fixed: the step h of the grid)"),
    Field("h_end", "double", doc="fixed: the shortened step to the last output (0: on the grid)"),
    Field("y", "long double", doc="state at t (long double in every variant: each one's state exactly)",
          length="n"),
    # what derive.simulate reports as r.error_estimate with error_kind "local sum"
    Field("local_error", "double", doc="sum of the accepted steps' local-error estimates, in the state's "
          "units (dopri5, dop853, abm12, taylor; 0: none)"),
)

# The atlas (spherical_atlas.h) appends these to the options and info structs.
ATLAS_OPTIONS = (
    Field("sine_switch", "double", None, "", "", atlas_doc="switch below this"),
    Field("sine_rule", "double", None, "", "", atlas_doc='the rule\'s "not small"'),
)
ATLAS_INFO = (
    Field("nswitches", "long", atlas_doc="chart switches"),
    Field("chart", "int", atlas_doc="chart at t"),
)

COUNTERS = ("nfev", "njev", "nsteps", "naccepted", "nrejected", "nnewton")    # of a run's info
# the methods whose runs estimate their own local errors (info.local_error): the embedded
# pairs, abm12's predictor-corrector difference (Milne), Taylor's last term
LOCAL_ERROR_METHODS = ("dopri5", "dop853", "abm12", "taylor")

METHODS = tuple(m.name for m in sorted(METHOD_TABLE, key=lambda m: m.index))
METHOD = {m.name: m for m in METHOD_TABLE}
ADAPTIVE = tuple(m.name for m in METHOD_TABLE if m.kind == "adaptive")
FIXED = tuple(m.name for m in METHOD_TABLE if m.kind == "fixed")
IMPLICIT = tuple(m.name for m in METHOD_TABLE if m.implicit)
MULTISTEP = tuple(m.name for m in METHOD_TABLE if m.multistep)
ATLAS_METHODS = tuple(m.name for m in METHOD_TABLE if m.atlas)
ORDER = {m.name: m.order for m in METHOD_TABLE}
FIXED_ORDER = {m: ORDER[m] for m in FIXED}
# Taylor's method runs in a generated file of its own (<model>_taylor.c, derive/codegen/
# taylor.py), not in the integrators' method switch; it takes the same options
# (rtol is its tolerance) and fills the same info struct
TAYLOR = "taylor"
RUN_METHODS = METHODS + (TAYLOR,)              # every method derive.simulate runs
TOLERANCE_METHODS = ADAPTIVE + (TAYLOR,)       # methods steered by rtol (no fixed step)
STATUS_NAMES = tuple(s.name for s in sorted(STATUS_TABLE, key=lambda s: s.code))
STATUS = {s.macro: s.code for s in STATUS_TABLE}
OPTION_NAMES = tuple(f.name for f in OPTIONS)
INFO_NAMES = tuple(f.name for f in INFO)

# the atlas's members and thresholds are data (derive/model/catalog/atlases.toml)
_ATLAS = load_atlas(ATLAS)
ATLAS_CHARTS = _ATLAS.charts
SINE_MIN = _ATLAS.sine_min          # hard threshold: no kernel below it (per-model default, and atlas)
SINE_SWITCH = _ATLAS.sine_switch    # atlas: switch chart when a polar sine drops below
SINE_RULE = _ATLAS.sine_rule        # seed 000 section 5.1: "not small" means >= 0.5


# A closed loop (a model's `constraints`, derive/runtime/constraints.py): a run starts only
# from a state whose residuals |Phi| and |J q'| are within CONSTRAINT_START_TOLERANCE
# (absolute, in the constraints' own units: lengths and lengths per second for a loop
# closure), and one whose largest residual over its outputs exceeds CONSTRAINT_DRIFT_BOUND
# says so in its message.
CONSTRAINT_START_TOLERANCE = 1e-9
CONSTRAINT_DRIFT_BOUND = 1e-6

DEFAULT_METHOD = "dop853"          # simulate's, ensemble's and a sweep's method when none is given
REFERENCE_METHOD = "dop853"        # the reference runs (trust horizons, rerun estimates, the race)


# -- the precision ladder ------------------------------------------------------------

@dataclass(frozen=True)
class Precision:
    """One rung of the precision ladder: the real type a run computes in."""
    key: str                  # derive's name of it: simulate(dtype=...), results, the cache
    scalar: str               # a scene's word for it (accuracy.scalar)
    title: str                # as reports name it
    aliases: tuple            # further spellings simulate(dtype=...) takes
    ctype: str                # the C type of one real ("derive_dd": a pair of doubles)
    suffix: str               # of the entry points and kernels in it (planar_integrate_l)
    eps: float | None         # unit roundoff; None: the platform's (long double)
    default_rtol: float       # simulate's rtol when none is given
    rtol_floor: float         # the tightest rtol the scene planner gives a run in it
    reference_floor: float | None   # the tightest rtol of a reference run in it (None: 20 eps)
    taylor_only: bool         # only Taylor's method runs in it (the RK methods are hardware types)


PRECISION_TABLE = (           # lowest first: the order the scene planner climbs
    Precision("float32", "float", "float", ("float", "single"), "float", "_f", 2.0 ** -23,
              1e-5, 1e-5, 1e-9, False),
    Precision("float64", "double", "double", ("double",), "double", "", 2.0 ** -52,
              1e-9, 1e-14, 1e-14, False),
    Precision("longdouble", "long double", "long double", ("long double", "float128"), "long double", "_l",
              None, 1e-12, 1e-16, None, False),
    # double-double: 2^-104 as the QD library states it (its sums are exact to about
    # 2^-106, not every operation)
    Precision("double-double", "double-double", "double-double", ("dd",), "derive_dd", "_dd", 2.0 ** -104,
              1e-30, 1e-29, 1e-29, True),
    Precision("quad", "quad", "quad (IEEE binary128)", ("binary128", "float128-ieee"), "derive_quad", "_q",
              2.0 ** -113, 1e-32, 1e-32, 2e-33, True),
)
PRECISION = {p.key: p for p in PRECISION_TABLE}
LADDER = tuple(p.key for p in PRECISION_TABLE)
EXTENDED = tuple(p.key for p in PRECISION_TABLE if p.taylor_only)      # Taylor's method only
SCALARS = tuple(p.scalar for p in PRECISION_TABLE)
PRECISION_NAMES = {name: p.key for p in PRECISION_TABLE for name in (p.key, p.scalar, *p.aliases)}


def precision(name: str) -> Precision:
    """The rung a name, a scene's word or an alias stands for (KeyError when none)."""
    return PRECISION[PRECISION_NAMES[name]]


# -- Taylor's order rule ---------------------------------------------------------------
# The order for a tolerance (Jorba and Zou 2005): ceil(-ln(tol) / DIVISOR + OFFSET) in
# [ORDER_MIN, ORDER_MAX].  The rule is written once, as an expression that reads the same
# in Python (math's ceil and log) and in C (<math.h>'s, on a double): taylor_order
# evaluates it, the generated C renders it (DERIVE_TAYLOR_ORDER_FOR, derive_taylor.h),
# so both make the same double operations in the same order.
TAYLOR_ORDER_DIVISOR = 2
TAYLOR_ORDER_OFFSET = 1
TAYLOR_ORDER_MIN = 2
TAYLOR_ORDER_MAX = 60       # largest order compiled in (tol 1e-34 for quad needs 41; double <= 20)
TAYLOR_ORDER_RULE = f"ceil(-log(tol) / {TAYLOR_ORDER_DIVISOR} + {TAYLOR_ORDER_OFFSET})"
_ORDER_RULE = compile(TAYLOR_ORDER_RULE, "<the Taylor order rule>", "eval")


def taylor_order(tol: float) -> int:
    """The Taylor order for a tolerance, as the generated C computes it (the same expression)."""
    p = eval(_ORDER_RULE, {"__builtins__": {}}, {"ceil": math.ceil, "log": math.log, "tol": float(tol)})
    return min(max(p, TAYLOR_ORDER_MIN), TAYLOR_ORDER_MAX)


def default_options() -> dict:
    """The defaults of <M>_integrate_defaults as Python values."""
    return {f.name: float(SINE_MIN) if f.name == "sine_min" else f.default for f in OPTIONS}


# A fixed-step run's grid is t0 + k h with k counted in floating point: beyond 2^53 steps
# k h no longer tells neighbouring grid points apart (and a step count would not fit a
# 32-bit long anyway), so the C entry points refuse such an h with BAD_INPUT.
MAX_GRID_STEPS = 2.0 ** 53


assert METHODS == tuple(m.name for m in METHOD_TABLE), "METHOD_TABLE is listed in C switch order"
assert ATLAS_METHODS == METHODS[:len(ATLAS_METHODS)], "the atlas takes the first methods (a range check)"
assert [s.code for s in STATUS_TABLE] == list(range(len(STATUS_TABLE)))
assert set(COUNTERS) <= set(INFO_NAMES)
