"""derive_integrators.py: the NumPy integrators of derive, written once for every model.

The same methods, step control, status codes and output conventions as the C library
(derive_integrators.h, derive_driver.h): rk4, dopri5, dop853 (adaptive, dense output),
midpoint, gauss2 (implicit, simplified Newton with the generated Jacobian), rk8 and
abm12 (fixed step; abm12 stops with MULTISTEP_UNSTABLE, see abm12_step).

A model is its generated kernel module (<model>.py beside this file), passed in:

    integrate(kernels, method, y0, p, t, dtype=numpy.float64, **options)
        -> (status, y_out (len(t), n), info)          one trajectory
    integrate_batch(kernels, method, y0s, p, t, ...)  many, one per row of y0s (the
        explicit methods as arrays: each kernel call evaluates every running row)

What a model brings is read off its module (see System): the sizes from its name
tables, chart guards where it has polar_sines (no kernel is evaluated where a polar
sine is below options["sine_min"]), Hamilton's equations where it has
hamiltonian_rhs (the implicit methods then run on x = (q, p) and are symplectic; else
on y' = f(y) with the generated jacobian: symmetric, order 2s, not symplectic in y),
run-time inputs where it has INPUT_NAMES (p is then the parameters, then the inputs).

The run contract (status codes, METHODS, DEFAULTS, the info fields) and the methods'
coefficients are derive_tableaus.py's, rendered once for every model; this file is
copied verbatim beside it (derive/codegen/backends/numpy/library/).  Only numpy is
imported: a folder of generated NumPy runs without derive.
"""
import difflib
import importlib.util
import inspect
import pathlib

import numpy


def _power(x, y):
    """x ** y elementwise (x float64, y a number) by numpy's power ufunc, both operands
    arrays: the one power integrate (through _pow1) and integrate_batch take, so that a
    batch's rows are integrate's runs bit for bit on any machine.  numpy's power runs SIMD
    loops (SVML on AVX-512) that differ from libm's pow, the Python float's, in the last bit
    for some arguments (6% of them on one AVX-512 machine); an array's ** 0.5 is numpy's
    sqrt, which differs from pow too."""
    x = numpy.asarray(x, numpy.float64)
    return numpy.power(x, numpy.full_like(x, y))


def _pow1(x, y):
    """x ** y of one number as integrate_batch takes it on a row (_power)."""
    return float(_power(numpy.array([x], numpy.float64), y)[0])


def _beside(name):
    """The module <name>.py of this file's folder, loaded from its path (so that the
    folder need not be on sys.path, as when derive loads a generated tree by path)."""
    spec = importlib.util.spec_from_file_location(
        "_derive_" + name, pathlib.Path(__file__).with_name(name + ".py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_data = _beside("derive_tableaus")
# the status codes in the contract's order (a test holds these names to it)
(OK, STEP_UNDERFLOW, MAX_STEPS, NEWTON, NONFINITE, CHART_SINGULAR, BAD_INPUT, CANCELLED,
 MULTISTEP_UNSTABLE) = _data.STATUS_CODES.values()
STATUS_NAMES = _data.STATUS_NAMES
METHODS = _data.METHODS
SINE_MIN = _data.SINE_MIN
NEWTON_THETA_MAX = _data.NEWTON_THETA_MAX
NEWTON_THETA_DIVERGE = _data.NEWTON_THETA_DIVERGE
DEFAULTS = _data.DEFAULTS
IMPLICIT = ("midpoint", "gauss2")
_CACHE = {}


def new_info():
    """A run's info dict, every counter zero: the fields of the C info struct, and
    "reason", which for BAD_INPUT is one line saying what is wrong (else None)."""
    return dict(_data.INFO, reason=None)


def options_of(options, defaults=None):
    """The options of a run: `defaults` (DEFAULTS) updated by `options`.

    Parameters
    ----------
    options : dict
        The caller's options, each a key of `defaults`.
    defaults : dict, optional
        Every option with its default (DEFAULTS unless given).

    Returns
    -------
    dict
        The merged options.

    Raises
    ------
    TypeError
        For a key that is no option (a typo): one line naming it and the options.
    """
    defaults = DEFAULTS if defaults is None else defaults
    for key in options:
        if key not in defaults:
            near = difflib.get_close_matches(str(key), list(defaults), n=1)
            hint = f"; did you mean '{near[0]}'?" if near else ""
            raise TypeError(f"unknown option '{key}' (options: {', '.join(defaults)}){hint}")
    return dict(defaults, **options)


def _tab(name, dtype):
    """The tableau with every coefficient as a scalar of dtype (parsed from its string)."""
    key = (name, dtype.name)
    if key not in _CACHE:
        def conv(x):
            if isinstance(x, str):
                return numpy.array([x]).astype(dtype)[0]
            if isinstance(x, (list, tuple)):
                return [conv(e) for e in x]
            return x
        _CACHE[key] = {k: conv(v) for k, v in _data.TABLEAUS[name].items()}
    return _CACHE[key]


def _takes_time(kernel):
    """Whether a generated kernel takes the time t first."""
    return next(iter(inspect.signature(kernel).parameters), None) == "t"


def _status_of(f):
    return OK if numpy.all(numpy.isfinite(f)) else NONFINITE


class System:
    """What the methods need of one model: its kernel module's sizes and its guarded,
    counted right-hand side, and the implicit methods' system and Jacobian.

    Parameters
    ----------
    kernels : module
        The model's generated NumPy kernels (<model>.py): rhs and jacobian; polar_sines
        for a model with chart guards; hamiltonian_rhs, hamiltonian_jacobian,
        to_canonical and from_canonical for one with a Hamiltonian form.
    """

    def __init__(self, kernels):
        self.kernels = kernels
        self.n = len(kernels.STATE_NAMES)
        self.n_model_params = len(kernels.PARAM_NAMES)
        inputs = getattr(kernels, "INPUT_NAMES", ())
        self.has_inputs = len(inputs) > 0
        self.n_params = self.n_model_params + len(inputs)      # p = (parameters, inputs)
        self.guarded = hasattr(kernels, "polar_sines")
        self.hamiltonian = hasattr(kernels, "hamiltonian_rhs")
        # a time-dependent model's rhs (and Jacobian) take the time first, where their
        # expressions use it (each stage passes its own)
        self.timed = _takes_time(kernels.rhs)
        self.jacobian_timed = hasattr(kernels, "jacobian") and _takes_time(kernels.jacobian)

    def _time(self, t, y, timed=None):
        """A kernel's leading argument: t as one slot, (1,) or (B, 1); none for a kernel
        without it (`timed`: whether it takes it, default the rhs's)."""
        return (numpy.asarray(t, y.dtype)[..., None],) if (self.timed if timed is None else timed) else ()

    def guard(self, y, opt):
        """OK, or why no kernel may be evaluated at y (its chart is singular there)."""
        if not self.guarded:
            return OK
        s = self.kernels.polar_sines(y)
        if not numpy.all(numpy.isfinite(s)):
            return NONFINITE
        if not numpy.all(numpy.abs(s) >= opt["sine_min"]):
            return CHART_SINGULAR
        return OK

    def _split(self, p):
        """The kernels' arguments after the state: p, or the parameters and the inputs."""
        if self.has_inputs:
            return p[..., :self.n_model_params], p[..., self.n_model_params:]
        return (p,)

    def eval(self, y, p, opt, info, t=None):
        """f(t, y) (t: a time-dependent model's only), counted and guarded: (status, f)."""
        g = self.guard(y, opt)
        if g:
            return g, numpy.full_like(y, numpy.nan)
        info["nfev"] += 1
        with numpy.errstate(all="ignore"):      # a non-finite result is reported by status
            f = self.kernels.rhs(*self._time(t, y), y, *self._split(p)).astype(y.dtype, copy=False)
        return _status_of(f), f

    def sys_eval(self, x, p, opt, info, t=None):
        """The implicit methods' system: Hamilton's equations where the model has them."""
        if not self.hamiltonian:
            return self.eval(x, p, opt, info, t)
        info["nfev"] += 1
        with numpy.errstate(all="ignore"):
            f = self.kernels.hamiltonian_rhs(x, p).astype(x.dtype, copy=False)
        return _status_of(f), f

    def sys_jac(self, x, p, opt, info, t=None):
        """The Jacobian of sys_eval, counted (and guarded, for y' = f(y)): (status, J)."""
        if self.hamiltonian:
            info["njev"] += 1
            J = self.kernels.hamiltonian_jacobian(x, p).astype(x.dtype, copy=False)
            return _status_of(J), J
        g = self.guard(x, opt)
        if g:
            return g, None
        info["njev"] += 1
        J = self.kernels.jacobian(*self._time(t, x, self.jacobian_timed), x, *self._split(p)).astype(x.dtype, copy=False)
        return _status_of(J), J


# -- one step of each method -------------------------------------------------------

def _combo(row, K):
    acc = None
    for j, a in row:
        term = a * K[j]
        acc = term if acc is None else acc + term
    return acc


def _at(t, c, h):
    """A stage's time t + c h (None, an autonomous model's, stays None)."""
    return None if t is None else t + c * h


def explicit_step(system, name, y, h, p, K, opt, info, t=None):
    """One step of rk4, dopri5 or dop853 from time t (a time-dependent model's; each stage
    at t + c_i h); K[0] = f(y) on entry.  (status, y_new, err)."""
    tab = _tab(name, y.dtype)
    for i, row in enumerate(tab["rows"], start=1):
        st, K[i] = system.eval(y + h * _combo(row, K), p, opt, info, _at(t, tab["c"][i], h))
        if st:
            return st, None, None
    y_new = y + h * _combo(tab["b"], K)
    if name == "rk4":
        return OK, y_new, 0.0
    sk = opt["atol"] + opt["rtol"] * numpy.maximum(numpy.abs(y), numpy.abs(y_new))
    if name == "dopri5":
        st, K[6] = system.eval(y_new, p, opt, info, _at(t, 1, h))
        if st:
            return st, None, None
        e = h * _combo(tab["e"], K) / sk
        return OK, y_new, float(numpy.sqrt(numpy.mean(e * e)))
    e3 = float(numpy.sum((_combo(tab["e3"], K) / sk) ** 2))
    e5 = float(numpy.sum((_combo(tab["e5"], K) / sk) ** 2))
    deno = e5 + 0.01 * e3
    if deno <= 0:
        deno = 1.0
    return OK, y_new, abs(float(h)) * e5 * _pow1(1.0 / (len(y) * deno), 0.5)


def dopri5_dense(y, h, K, theta):
    """dopri5's 4th-order dense output at y + theta h (K: the step's stages)."""
    tab = _tab("dopri5", y.dtype)
    acc = numpy.zeros_like(y)
    for k, coefs in tab["p"]:
        b = coefs[3]
        for j in (2, 1, 0):
            b = coefs[j] + theta * b
        acc = acc + (theta * b) * K[k]
    return y + h * acc


def dop853_dense_prepare(system, y, y_new, h, p, K, opt, info, t=None):
    """dop853's three extra stages (at t + c_i h) and the 7 coefficient rows of its dense
    output: (status, F); K[12] = f(y_new) on entry."""
    tab = _tab("dop853", y.dtype)
    for i, row in tab["extra"]:
        st, K[i] = system.eval(y + h * _combo(row, K), p, opt, info, _at(t, tab["c"][i], h))
        if st:
            return st, None
    F = numpy.empty((7,) + y.shape, y.dtype)
    F[0] = y_new - y
    F[1] = h * K[0] - F[0]
    F[2] = F[0] - h * K[12] - F[1]
    for r, row in enumerate(tab["d"]):
        F[3 + r] = h * _combo(row, K)
    return OK, F


def dop853_dense(y, F, theta):
    """dop853's 7th-order dense output at y + theta h from dop853_dense_prepare's F."""
    s1 = 1 - theta
    return y + theta * (F[0] + s1 * (F[1] + theta * (F[2] + s1 * (F[3] + theta * (F[4] + s1 * (F[5] + theta * F[6]))))))


def _gauss_matrix(A, h, J, dtype):
    """W = I - h (a_ij J_j) (J_j: the Jacobian for stage j), and W in the dtype of the solve."""
    ns, n = len(A), J[0].shape[0]
    W = numpy.eye(ns * n, dtype=dtype)
    for i in range(ns):
        for j in range(ns):
            W[i * n:(i + 1) * n, j * n:(j + 1) * n] -= h * A[i][j] * J[j]
    solve_dtype = numpy.float64 if dtype == numpy.longdouble else dtype
    Wf = W.astype(solve_dtype)
    return W, Wf, bool(numpy.all(numpy.isfinite(Wf)))


def gauss_step(system, name, x, h, p, opt, info, t=None):
    """One step of midpoint or gauss2 on the system's x from time t (a time-dependent
    model's; stage i at t + c_i h): (status, x_new).

    Simplified Newton with the Jacobian at x.  With the contraction rate
    theta_k = |dZ_k| / |dZ_k-1|: an increment that shrinks slowly (NEWTON_THETA_MAX <
    theta < 1) re-evaluates the Jacobian at the current stage values x + Z_j (one per
    stage, W = I - h (a_ij J_j)) and restarts the rate estimate; one that grows (1 <=
    theta < NEWTON_THETA_DIVERGE) does the same at the iterate before it, once per
    step.  NEWTON, the last resort, when an increment grows again, grows by
    NEWTON_THETA_DIVERGE or more, is not finite, or no convergence in
    opt["newton_max"] iterations (the same logic as the C step)."""
    tab = _tab(name, x.dtype)
    ns, A, c, d = tab["ns"], tab["A"], tab["c"], tab["d"]
    n = len(x)
    eps = numpy.finfo(x.dtype).eps
    tol = opt["newton_tol"] if opt["newton_tol"] > 0 else 10 * eps
    rounding = 1000 * eps
    theta_max = x.dtype.type(NEWTON_THETA_MAX)
    theta_diverge = x.dtype.type(NEWTON_THETA_DIVERGE)
    st, J0 = system.sys_jac(x, p, opt, info, t)
    if st:
        return st, None
    st, f0 = system.sys_eval(x, p, opt, info, t)
    if st:
        return st, None
    Z = numpy.array([c[i] * h * f0 for i in range(ns)])
    W, Wf, finite = _gauss_matrix(A, h, [J0] * ns, x.dtype)
    if not finite:
        return NEWTON, None
    solve_dtype = Wf.dtype
    Am = numpy.array(A, dtype=x.dtype)
    Fv = numpy.empty((ns, n), x.dtype)
    prev, grown, conv = 0.0, False, False
    for it in range(opt["newton_max"]):
        Zold = Z
        for i in range(ns):
            st, Fv[i] = system.sys_eval(x + Z[i], p, opt, info, _at(t, c[i], h))
            if st:
                return st, None
        G = -(Z - h * numpy.einsum("ij,jk->ik", Am, Fv))
        try:
            dZ = numpy.linalg.solve(Wf, G.reshape(-1).astype(solve_dtype)).astype(x.dtype)
        except numpy.linalg.LinAlgError:
            return NEWTON, None
        if x.dtype == numpy.longdouble:
            # one step of iterative refinement brings the double solve to long double
            r = G.reshape(-1) - W @ dZ
            dZ = dZ + numpy.linalg.solve(Wf, r.astype(solve_dtype)).astype(x.dtype)
        Z = Z + dZ.reshape(ns, n)
        nrm = float(numpy.max(numpy.abs(dZ.reshape(ns, n)) / (1 + numpy.abs(x))))
        info["nnewton"] += 1
        bad = 0                 # 1: slow, 2: growing
        if nrm != nrm or nrm > 1e30:
            return NEWTON, None
        elif nrm <= tol:
            conv = True
            break
        elif prev > 0:
            theta = nrm / prev
            if theta < 1 and theta / (1 - theta) * nrm <= tol:
                conv = True
                break
            if nrm <= rounding:
                if theta >= 1:
                    conv = True     # stagnation at rounding level
                    break
            elif theta >= theta_diverge:
                return NEWTON, None     # diverges: the step is too large for the motion
            elif theta >= 1:
                bad = 2
            elif theta > theta_max:
                bad = 1
        if bad:
            if bad == 2:
                if grown:
                    return NEWTON, None     # grows again after a re-evaluation
                grown, Z = True, Zold
            J = []
            for j in range(ns):
                st, Jj = system.sys_jac(x + Z[j], p, opt, info, _at(t, c[j], h))
                if st:
                    return st, None
                J.append(Jj)
            W, Wf, finite = _gauss_matrix(A, h, J, x.dtype)
            if not finite:
                return NEWTON, None
            prev = 0.0              # restart: the rate is estimated anew
            continue
        prev = nrm
    if not conv:
        return NEWTON, None
    return OK, x + sum(d[i] * Z[i] for i in range(ns))


def abm12_step(c, z, h):
    """abm12 on the grid, as in the C: rk8 for the first 11 steps, then PECE; a step whose
    local error (Milne's estimate from the predictor-corrector difference) exceeds
    atol + rtol |y|_max is MULTISTEP_UNSTABLE.  c: the run (_Run), its history c.hist."""
    w = _tab("abm12", z.dtype)
    k = len(w["ab"])
    if not c.hist:
        st, f = c.eval(z)
        if st:
            return st, None, None
        c.hist = [f]
    err = 0.0
    if len(c.hist) < k:
        K = numpy.zeros((16, len(z)), z.dtype)
        K[0] = c.hist[0]
        st, zn, _ = explicit_step(c.system, "dop853", z, h, c.p, K, c.opt, c.info, c.time())
    else:
        yp = z + h * sum(w["ab"][j] * c.hist[j] for j in range(k - 1, -1, -1))
        st, fp = c.eval(yp, _at(c.time(), 1, h))
        if st:
            return st, None, None
        zn = z + h * (sum(w["am"][j] * c.hist[j - 1] for j in range(k - 1, 0, -1)) + w["am"][0] * fp)
        err = float(w["milne"] * numpy.max(numpy.abs(zn - yp))) / (c.opt["atol"] + c.opt["rtol"] * float(numpy.max(numpy.abs(z))))
        if not err <= 1:
            return MULTISTEP_UNSTABLE, None, None
    if st:
        return st, None, None
    st, f = c.eval(zn, _at(c.time(), 1, h))
    c.hist = [f] + c.hist[:k - 1]
    return st, zn, err


class _Run:
    """The driver's view of one run of one model (one chart, never switches)."""

    def __init__(self, system, method, p, opt, info, dtype):
        self.system, self.method, self.p, self.opt, self.info, self.dtype = system, method, p, opt, info, dtype
        self.canonical = system.hamiltonian and method in IMPLICIT
        self.z = None
        self.hist = []          # abm12: f at the last grid points, newest first
        self.t = None           # the time the driver has reached (it sets it: _set_time)

    def time(self):
        """The driver's time, for a time-dependent model's kernels (None: an autonomous one)."""
        return self.t if self.system.timed else None

    def eval(self, z, t=None):
        """f at z, at time t (default: the driver's)."""
        return self.system.eval(z, self.p, self.opt, self.info, self.time() if t is None else t)

    def step(self, z, h, K=None):
        t = self.time()
        if self.method in IMPLICIT:
            st, zn = gauss_step(self.system, self.method, z, h, self.p, self.opt, self.info, t)
            return st, zn, 0.0
        if self.method == "abm12":
            return abm12_step(self, z, h)
        if K is None:
            K = numpy.zeros((16, len(z)), z.dtype)
        if self.method in ("rk4", "rk8"):
            st, K[0] = self.eval(z)
            if st:
                return st, None, None
        if self.method == "rk8":           # DOP853's 8th-order formula, its error unused
            st, zn, _ = explicit_step(self.system, "dop853", z, h, self.p, K, self.opt, self.info, t)
            return st, zn, 0.0
        return explicit_step(self.system, self.method, z, h, self.p, K, self.opt, self.info, t)

    def partial_step(self, z, h):
        """A shortened step off the grid: abm12 takes an rk8 step (its history is the grid's)."""
        if self.method != "abm12":
            return self.step(z, h)
        K = numpy.zeros((16, len(z)), z.dtype)
        st, K[0] = self.eval(z)
        if st:
            return st, None, None
        st, zn, _ = explicit_step(self.system, "dop853", z, h, self.p, K, self.opt, self.info, self.time())
        return st, zn, 0.0

    def dense_prepare(self, z, zn, h, K):
        if self.method == "dop853":
            return dop853_dense_prepare(self.system, z, zn, h, self.p, K, self.opt, self.info, self.time())
        return OK, None

    def dense(self, z, zn, h, K, F, theta):
        if self.method == "dop853":
            return dop853_dense(z, F, theta)
        return dopri5_dense(z, h, K, theta)

    def inp(self, y):
        if self.canonical:
            x = self.system.kernels.to_canonical(y, self.p).astype(self.dtype, copy=False)
            return _status_of(x), x
        return self.system.guard(y, self.opt), y

    def out(self, z):
        if self.canonical:
            y = self.system.kernels.from_canonical(z, self.p).astype(self.dtype, copy=False)
            return _status_of(y), y
        return OK, z

    def switch(self, z, force):
        return 0

    def set_y(self, z):
        st, y = self.out(z)
        self.info["y"] = numpy.array(y if st == OK else z, dtype=self.dtype)


# -- the stepping loop, shared with the chart atlas --------------------------------
# The loop sets c.t, the time it has reached (a step's start), before each evaluation and
# step: a time-dependent model's run (_Run) passes it, and each stage's, to the kernels.
# A run (c) gives the loop: c.info, c.opt, c.method, c.dtype; c.eval(z) -> (status, f);
# c.step(z, h[, K]) -> (status, z_new, err); c.partial_step (optional); c.dense_prepare,
# c.dense; c.inp(y) and c.out(z) (the state the method runs on and back); c.switch(z,
# force) -> 0, 1 (switched: the new state in c.z) or -status; c.set_y(z).

def _eval_at(c, z, t):
    """c.eval(z) with the driver's time at t for the call."""
    reached, c.t = c.t, t
    try:
        return c.eval(z)
    finally:
        c.t = reached


def _hinit(c, z, f0, direction, hmax, order):
    """Hairer's starting step (Solving ODEs I, II.4), from the time c.t."""
    sk = c.opt["atol"] + c.opt["rtol"] * numpy.abs(z)
    dnf = float(numpy.sum((f0 / sk) ** 2))
    dny = float(numpy.sum((z / sk) ** 2))
    h = 1e-6 if (dnf <= 1e-10 or dny <= 1e-10) else _pow1(dny / dnf, 0.5) * 0.01
    h = min(h, hmax)
    st, f1 = _eval_at(c, z + direction * h * f0, c.t + c.dtype.type(direction * h))
    if st:
        return h
    der2 = _pow1(float(numpy.sum(((f1 - f0) / sk) ** 2)), 0.5) / h
    der12 = max(der2, _pow1(dnf, 0.5))
    h1 = max(1e-6, h * 1e-3) if der12 <= 1e-15 else _pow1(0.01 / der12, 1.0 / order)
    return min(100 * h, h1, hmax)


def _fixed_step(c, z, h, partial):
    """One fixed step (partial: a shortened one to an output off the grid): the step
    budget, the chart switch at the start, the redo after a chart singularity, the
    finiteness of the result.  -> (status, z (perhaps switched), z_new)."""
    info = c.info
    if info["nsteps"] >= c.opt["max_steps"]:
        return MAX_STEPS, z, None
    sw = c.switch(z, False)
    if sw < 0:
        return -sw, z, None
    if sw == 1:
        z = c.z
    info["nsteps"] += 1
    # a multistep method's shortened steps are one-step steps (its history is the grid's)
    st, zn, err = (getattr(c, "partial_step", c.step) if partial else c.step)(z, h)
    if st == CHART_SINGULAR:
        sw = c.switch(z, True)       # switch at the step start and redo
        if sw < 0:
            return -sw, z, None
        if sw == 1:
            z = c.z
            st, zn, err = c.step(z, h)
    if st:
        return st, z, None
    if not numpy.all(numpy.isfinite(zn)):
        return NONFINITE, z, None
    info["naccepted"] += 1
    if err > 0:        # abm12: Milne's estimate, in units of atol + rtol |z|_max (as the step scaled it)
        info["local_error"] += float(err) * (c.opt["atol"] + c.opt["rtol"] * float(numpy.max(numpy.abs(z))))
    return OK, z, zn


def _drive_fixed(c, z, t_out, direction, done, y_out):
    """The fixed-step methods: the grid t0 + k h whatever the outputs; an output between
    grid points is a shortened step from the grid point before it into a side state (as
    in the C)."""
    info, nt = c.info, len(t_out)
    eps = float(numpy.finfo(c.dtype).eps)
    t = t_out[0]
    h = c.dtype.type(direction * c.opt["h"])
    info["h_end"] = 0.0
    kgrid, zside = 0, None
    for iout in range(1, nt):
        slack = 16 * eps * (abs(float(t_out[0])) + abs(float(t_out[iout])) + abs(float(h)))
        while True:
            tnext = t_out[0] + c.dtype.type(kgrid + 1) * h
            if float((tnext - t_out[iout]) * direction) > slack:
                break
            c.t = t
            st, z, zn = _fixed_step(c, z, h, False)
            if st:
                return done(st, z, t, h)
            z, t, kgrid = zn, tnext, kgrid + 1
        if float((t_out[iout] - t) * direction) <= slack:
            zside, info["h_end"] = None, 0.0
            st, y_out[iout] = c.out(z)
        else:
            info["h_end"] = float(t_out[iout] - t)
            c.t = t
            st, z, zside = _fixed_step(c, z, t_out[iout] - t, True)
            if st:
                return done(st, z, t, h)
            st, y_out[iout] = c.out(zside)
        if st:
            return done(st, z, t, h)
        info["nout"] += 1
    return done(OK, z if zside is None else zside, t_out[-1], h)


def _drive_adaptive(c, z, t_out, direction, done, y_out):
    """dopri5 and dop853: Hairer's step-size control, dense output between steps."""
    info, method, opt = c.info, c.method, c.opt
    nt, n = len(t_out), len(z)
    eps = float(numpy.finfo(c.dtype).eps)
    t, h = t_out[0], c.dtype.type(0)
    if method == "dopri5":
        order, facmin, facmax, fsal = 5.0, 0.2, 10.0, 6
    else:
        order, facmin, facmax, fsal = 8.0, 0.333, 6.0, 12
    tend = t_out[-1]
    hmax = opt["hmax"] if opt["hmax"] > 0 else abs(float(tend - t))
    c.t = t
    st, f0 = c.eval(z)
    if st:
        return done(st, z, t, h)
    K = numpy.zeros((16, n), c.dtype)
    K[0] = f0
    if opt["h"] > 0:
        h = min(opt["h"], hmax)
    else:
        h = _hinit(c, z, K[0], direction, hmax, order)
    h = c.dtype.type(direction * h)
    cause, rejected, iout = 0, False, 1
    while iout < nt:
        if info["nsteps"] >= opt["max_steps"]:
            return done(MAX_STEPS, z, t, h)
        last = False
        if (t + h - tend) * direction >= 0:
            h = tend - t
            last = True
        hmin = max(16 * eps * abs(float(t)), opt["hmin"])
        if abs(float(h)) <= hmin or h == 0:
            return done(cause or STEP_UNDERFLOW, z, t, h)
        info["nsteps"] += 1
        c.t = t
        st, zn, err = c.step(z, h, K)
        if st == 0 and err <= 1 and method == "dop853":
            st, K[12] = _eval_at(c, zn, t + h)
        if st or not err <= 1:
            info["nrejected"] += 1
            if st:
                cause, fac = st, 0.25
            elif err != err:
                cause, fac = NONFINITE, 0.25
            else:
                cause, fac = 0, min(1.0, max(facmin, 0.9 * _pow1(float(err), -1.0 / order)))
            rejected = True
            h = h * c.dtype.type(fac)
            continue
        cause = 0
        tnew = tend if last else t + h
        dense = None
        while iout < nt and (t_out[iout] - tnew) * direction <= 0:
            if t_out[iout] == tnew:
                st, y_out[iout] = c.out(zn)
            else:
                if dense is None:
                    st, dense = c.dense_prepare(z, zn, h, K)
                    if st:
                        return done(st, z, t, h)
                theta = (t_out[iout] - t) / h
                st, y_out[iout] = c.out(c.dense(z, zn, h, K, dense, theta))
            if st:
                return done(st, z, t, h)
            info["nout"] += 1
            iout += 1
        # the step's local-error estimate in the state's units (err is scaled per component
        # by atol + rtol max(|y|, |y_new|): the largest of those scales bounds it)
        size = max(float(numpy.max(numpy.abs(z))), float(numpy.max(numpy.abs(zn))))
        info["local_error"] += float(err) * (opt["atol"] + opt["rtol"] * size)
        z, t = zn, tnew
        c.t = t
        K[0] = K[fsal]
        info["naccepted"] += 1
        sw = c.switch(z, False)
        if sw < 0:
            return done(-sw, z, t, h)
        if sw == 1:
            z = c.z
            st, K[0] = c.eval(z)
            if st:
                return done(st, z, t, h)
        fac = 0.9 * _pow1(float(err), -1.0 / order) if err > 0 else facmax
        fac = max(facmin, min(fac, 1.0 if rejected else facmax))
        rejected = False
        h = h * c.dtype.type(fac)
        if abs(float(h)) > hmax:
            h = c.dtype.type(direction * hmax)
    return done(OK, z, t, h)


def drive(c, y0, t_out):
    """From y0 at t_out[0] through every output time: (status, y_out); c: the run."""
    info = c.info
    nt, n = len(t_out), len(y0)
    y_out = numpy.full((nt, n), numpy.nan, c.dtype)
    t, h = t_out[0], c.dtype.type(0)

    def done(st, z, t, h):
        info["status"], info["t"], info["h"] = st, float(t), float(h)
        c.set_y(z)
        y_out[info["nout"]:] = numpy.nan
        return st, y_out

    c.t = t
    st, z = c.inp(y0)
    if st:
        return done(st, y0, t, h)
    st, y_out[0] = c.out(z)
    if st:
        return done(st, z, t, h)
    info["nout"] = 1
    if nt == 1:
        return done(OK, z, t, h)
    direction = 1 if t_out[-1] > t_out[0] else -1
    if c.method not in ("dopri5", "dop853"):
        return _drive_fixed(c, z, t_out, direction, done, y_out)
    return _drive_adaptive(c, z, t_out, direction, done, y_out)


# -- the entry points ----------------------------------------------------------------

def problem(method, y0, p, t, opt):
    """What makes a run's input BAD_INPUT, as the C entry points check: one line, or None."""
    if method not in METHODS:
        return f"unknown method {method!r} (methods: {', '.join(METHODS)})"
    if len(t) < 1:
        return "no output times (t is empty)"
    for name, values in (("y0", y0), ("p", p), ("t", t)):
        if not numpy.all(numpy.isfinite(values)):
            return f"{name} has a value that is not finite"
    if len(t) > 1 and not numpy.all(numpy.sign(numpy.diff(t)) * numpy.sign(t[-1] - t[0]) > 0):
        return "the output times t are not strictly monotone"
    if method in ("dopri5", "dop853"):
        if not 0 < opt["rtol"] < 1:
            return f"rtol = {opt['rtol']!r} is outside (0, 1)"
        for key in ("atol", "h", "hmin", "hmax"):
            if not opt[key] >= 0:
                return f"{key} = {opt[key]!r} is negative"
    elif len(t) > 1 and not 0 < opt["h"] < 1e300:
        return (f"{method} is a fixed-step method: it needs the option h, the step (0 < h < 1e300; "
                f"h = {opt['h']!r})")
    elif len(t) > 1 and not abs(float(t[-1]) - float(t[0])) / opt["h"] <= 2.0 ** 53:
        # more than 2^53 grid steps: k h no longer tells grid points apart
        return f"h = {opt['h']!r} makes more than 2^53 steps over the span of t"
    if opt["max_steps"] < 1:
        return f"max_steps = {opt['max_steps']!r} is below 1"
    if not 0 <= opt["sine_min"] < 1:
        return f"sine_min = {opt['sine_min']!r} is outside [0, 1)"
    return None


def check(method, y0, p, t, opt):
    """BAD_INPUT or OK, as the C entry points check (problem says why)."""
    return BAD_INPUT if problem(method, y0, p, t, opt) else OK


def integrate(kernels, method, y0, p, t, dtype=numpy.float64, **options):
    """One trajectory of the model whose kernel module is `kernels`.

    Parameters
    ----------
    kernels : module or System
        The model's generated kernels (<model>.py), or a System made of them.
    method : str
        One of METHODS.
    y0 : array_like, shape (n,)
        The initial state.
    p : array_like, shape (n_params,)
        The parameters (then the run-time inputs, for a model with inputs).
    t : array_like
        The output times, strictly monotone; t[0] is the start.
    dtype : numpy dtype
        The real type of the run (float32, float64, longdouble).
    **options
        Any of DEFAULTS (rtol, atol, h, hmin, hmax, max_steps, newton_tol, newton_max,
        sine_min, cancel); another key raises TypeError.  A fixed-step method needs h.

    Returns
    -------
    status : int
        OK or the code that stopped the run (STATUS_NAMES[status] says it).
    y_out : ndarray, shape (len(t), n)
        The state at each output time (NaN from the first one not reached).
    info : dict
        The run's counters and where it stopped (new_info's fields); its y has dtype (a
        longdouble run's state to its full precision, as C's long double info.y), its t,
        h, h_end and local_error are float64 whatever dtype is.
    """
    system = kernels if isinstance(kernels, System) else System(kernels)
    n = system.n
    dtype = numpy.dtype(dtype)
    opt = options_of(options)
    y0 = numpy.asarray(y0, dtype).reshape(n)
    p = numpy.asarray(p, dtype).reshape(system.n_params)
    t = numpy.asarray(t, dtype).reshape(-1)
    info = new_info()
    info["t"], info["y"] = float(t[0]) if len(t) else 0.0, numpy.array(y0, dtype)
    info["reason"] = problem(method, y0, p, t, opt)
    if info["reason"]:
        info["status"] = BAD_INPUT
        return BAD_INPUT, numpy.full((len(t), n), numpy.nan, dtype), info
    st, y_out = drive(_Run(system, method, p, opt, info, dtype), y0, t)
    return st, y_out, info


# -- many trajectories at once -----------------------------------------------------
# The explicit methods (rk4, rk8, dopri5, dop853) run a batch as arrays (B, n): each
# kernel call evaluates every running trajectory, each trajectory keeps its own step,
# time, outputs and counters, and one leaves the batch when it ends; the same operations
# as integrate's, row by row.  The implicit methods and abm12 (a Newton solve and a
# history per trajectory) run integrate once a row.
BATCHED = ("rk4", "rk8", "dopri5", "dop853")


class _Batch:
    """The running state of a batch of B trajectories of one explicit method."""

    def __init__(self, system, method, y0, p, t_out, opt, dtype):
        B, n = y0.shape
        self.system, self.method, self.p, self.opt, self.dtype = system, method, p, opt, dtype
        self.t_out, self.nt = t_out, len(t_out)
        self.z = y0.copy()
        self.t = numpy.full(B, t_out[0], dtype)
        self.h = numpy.zeros(B, dtype)
        self.y_out = numpy.full((B, self.nt, n), numpy.nan, dtype)
        self.count = {k: numpy.zeros(B, numpy.int64) for k in ("nfev", "nsteps", "naccepted", "nrejected", "nout")}
        self.local_error = numpy.zeros(B)
        self.h_end = numpy.zeros(B)
        self.status = numpy.full(B, -1)           # -1: running
        self.t_stop, self.h_stop = numpy.zeros(B), numpy.zeros(B)
        self.y_stop = y0.copy()

    def eval(self, rows, y, counted=None, t=None):
        """f(t, y) of trajectories `rows` (y: their states; t: their times, a time-dependent
        model's), guarded; counted where `counted` (default every row): (status (R,), f)."""
        system, opt = self.system, self.opt
        st = numpy.zeros(len(rows), numpy.int64)
        with numpy.errstate(all="ignore"):      # a non-finite result is reported by status
            if system.guarded:
                s = system.kernels.polar_sines(y)
                st = numpy.where(~numpy.all(numpy.isfinite(s), axis=-1), NONFINITE,
                                 numpy.where(numpy.all(numpy.abs(s) >= opt["sine_min"], axis=-1), OK, CHART_SINGULAR))
            f = system.kernels.rhs(*system._time(t, y), y, *system._split(self.p[rows])).astype(y.dtype, copy=False)
        ok = st == OK
        f[~ok] = numpy.nan
        self.count["nfev"][rows] += ok if counted is None else ok & counted
        st = numpy.where(ok & ~numpy.all(numpy.isfinite(f), axis=-1), NONFINITE, st)
        return st, f

    def stages(self, rows, name, z, h, K, st, rows_of, t=None):
        """The stages K[i] of tableau rows `rows_of` (name's) from z at the times t (each
        stage at t + c_i h); st: each row's status so far (the first failure stays, later
        stages of that row are not counted)."""
        c = _tab(name, z.dtype)["c"]
        for i, row in rows_of:
            with numpy.errstate(all="ignore"):      # a failed row's stages are not used
                y = z + h[:, None] * _combo(row, K)
            s, K[i] = self.eval(rows, y, st == OK, _at(t, c[i], h))
            st = numpy.where(st == OK, s, st)
        return st

    def step(self, rows, z, h, K, st, t=None):
        """One explicit step of trajectories `rows` from their times t (a time-dependent
        model's); K[0] = f(z) on entry, st its status: (status, z_new, err)."""
        name = "dop853" if self.method == "rk8" else self.method
        tab, opt = _tab(name, z.dtype), self.opt
        st = self.stages(rows, name, z, h, K, st, enumerate(tab["rows"], start=1), t)
        with numpy.errstate(all="ignore"):
            zn = z + h[:, None] * _combo(tab["b"], K)
        if self.method in ("rk4", "rk8"):
            return st, zn, numpy.zeros(len(rows))
        with numpy.errstate(all="ignore"):
            sk = opt["atol"] + opt["rtol"] * numpy.maximum(numpy.abs(z), numpy.abs(zn))
            if name == "dopri5":
                s, K[6] = self.eval(rows, zn, st == OK, _at(t, 1, h))
                st = numpy.where(st == OK, s, st)
                e = h[:, None] * _combo(tab["e"], K) / sk
                return st, zn, numpy.sqrt(numpy.mean(e * e, axis=-1)).astype(numpy.float64)
            e3 = numpy.sum((_combo(tab["e3"], K) / sk) ** 2, axis=-1).astype(numpy.float64)
            e5 = numpy.sum((_combo(tab["e5"], K) / sk) ** 2, axis=-1).astype(numpy.float64)
            deno = e5 + 0.01 * e3
            deno = numpy.where(deno <= 0, 1.0, deno)
            return st, zn, numpy.abs(h.astype(numpy.float64)) * e5 * _power(1.0 / (z.shape[1] * deno), 0.5)

    def finish(self, rows, status, z, t, h):
        """Trajectories `rows` end with `status` in state z at t (h: their last step)."""
        self.status[rows] = status
        self.t_stop[rows], self.h_stop[rows] = t.astype(numpy.float64), h.astype(numpy.float64)
        self.y_stop[rows] = z
        for r in rows:
            self.y_out[r, self.count["nout"][r]:] = numpy.nan

    def running(self):
        return numpy.flatnonzero(self.status < 0)

    def infos(self):
        infos = []
        for r in range(len(self.status)):
            info = new_info()
            info.update({k: int(v[r]) for k, v in self.count.items()})
            info.update(status=int(self.status[r]), t=float(self.t_stop[r]), h=float(self.h_stop[r]),
                        h_end=float(self.h_end[r]), y=self.y_stop[r].copy(), local_error=float(self.local_error[r]))
            infos.append(info)
        return infos


def _batch_start(b, direction):
    """drive's start for every row: the guard at y0, the first output row; rows of one
    output time end there.  -> the running rows."""
    rows = numpy.arange(len(b.z))
    h0 = numpy.zeros(len(rows), b.dtype)
    if b.system.guarded:
        with numpy.errstate(all="ignore"):
            s = b.system.kernels.polar_sines(b.z)
        st = numpy.where(~numpy.all(numpy.isfinite(s), axis=-1), NONFINITE,
                         numpy.where(numpy.all(numpy.abs(s) >= b.opt["sine_min"], axis=-1), OK, CHART_SINGULAR))
        bad = st != OK
        b.finish(rows[bad], st[bad], b.z[bad], b.t[bad], h0[bad])
        rows = rows[~bad]
    b.y_out[rows, 0] = b.z[rows]
    b.count["nout"][rows] = 1
    if b.nt == 1:
        b.finish(rows, OK, b.z[rows], b.t[rows], h0[:len(rows)])
        return rows[:0]
    return rows


def _batch_hinit(b, rows, f0, direction, hmax, order):
    """_hinit for trajectories `rows` (the same operations, row by row)."""
    z, opt = b.z[rows], b.opt
    with numpy.errstate(all="ignore"):
        sk = opt["atol"] + opt["rtol"] * numpy.abs(z)
        dnf = numpy.sum((f0 / sk) ** 2, axis=-1).astype(numpy.float64)
        dny = numpy.sum((z / sk) ** 2, axis=-1).astype(numpy.float64)
        h = numpy.where((dnf <= 1e-10) | (dny <= 1e-10), 1e-6, _power(dny / dnf, 0.5) * 0.01)
        h = numpy.minimum(h, hmax)
        st, f1 = b.eval(rows, z + (direction * h).astype(b.dtype)[:, None] * f0, None,
                        b.t[rows] + (direction * h).astype(b.dtype))
        der2 = _power(numpy.sum(((f1 - f0) / sk) ** 2, axis=-1).astype(numpy.float64), 0.5) / h
        der12 = numpy.maximum(der2, _power(dnf, 0.5))
        h1 = numpy.where(der12 <= 1e-15, numpy.maximum(1e-6, h * 1e-3), _power(0.01 / der12, 1.0 / order))
        return numpy.where(st != OK, h, numpy.minimum(numpy.minimum(100 * h, h1), hmax))


def _batch_adaptive(b, rows, direction):
    """_drive_adaptive for every row at once: dopri5 and dop853, each row its own step."""
    opt, dt, t_out, nt = b.opt, b.dtype, b.t_out, b.nt
    eps = float(numpy.finfo(dt).eps)
    if b.method == "dopri5":
        order, facmin, facmax, fsal = 5.0, 0.2, 10.0, 6
    else:
        order, facmin, facmax, fsal = 8.0, 0.333, 6.0, 12
    tend = t_out[-1]
    hmax = opt["hmax"] if opt["hmax"] > 0 else abs(float(tend - t_out[0]))
    B, n = b.z.shape
    K = numpy.zeros((16, B, n), dt)
    st, K[0, rows] = b.eval(rows, b.z[rows], None, b.t[rows])
    bad = st != OK
    b.finish(rows[bad], st[bad], b.z[rows[bad]], b.t[rows[bad]], b.h[rows[bad]])
    rows = rows[~bad]
    if opt["h"] > 0:
        h = numpy.full(len(rows), min(opt["h"], hmax))
    else:
        h = _batch_hinit(b, rows, K[0, rows], direction, hmax, order)
    b.h[rows] = (direction * h).astype(dt)
    cause = numpy.zeros(B, numpy.int64)
    rejected = numpy.zeros(B, bool)
    iout = numpy.ones(B, numpy.int64)
    while True:
        rows = b.running()
        if not len(rows):
            return
        over = b.count["nsteps"][rows] >= opt["max_steps"]
        b.finish(rows[over], MAX_STEPS, b.z[rows[over]], b.t[rows[over]], b.h[rows[over]])
        rows = rows[~over]
        last = (b.t[rows] + b.h[rows] - tend) * direction >= 0
        b.h[rows[last]] = tend - b.t[rows[last]]
        hmin = numpy.maximum(16 * eps * numpy.abs(b.t[rows].astype(numpy.float64)), opt["hmin"])
        under = (numpy.abs(b.h[rows].astype(numpy.float64)) <= hmin) | (b.h[rows] == 0)
        u = rows[under]
        b.finish(u, numpy.where(cause[u] != 0, cause[u], STEP_UNDERFLOW), b.z[u], b.t[u], b.h[u])
        rows, last = rows[~under], last[~under]
        if not len(rows):
            continue
        b.count["nsteps"][rows] += 1
        z, h, Kr = b.z[rows], b.h[rows], K[:, rows]
        st, zn, err = b.step(rows, z, h, Kr, numpy.zeros(len(rows), numpy.int64), b.t[rows])
        if b.method == "dop853":
            good = (st == OK) & (err <= 1)
            s, Kr[12, good] = b.eval(rows[good], zn[good], None, b.t[rows[good]] + h[good])
            st[good] = s
        fail = (st != OK) | ~(err <= 1)
        # rejected: a smaller step from the same state
        r, sr, er = rows[fail], st[fail], err[fail]
        b.count["nrejected"][r] += 1
        with numpy.errstate(all="ignore"):
            shrink = numpy.minimum(1.0, numpy.maximum(facmin, 0.9 * _power(er, -1.0 / order)))
        nonfinite = er != er
        fac = numpy.where((sr != OK) | nonfinite, 0.25, shrink)
        cause[r] = numpy.where(sr != OK, sr, numpy.where(nonfinite, NONFINITE, 0))
        rejected[r] = True
        b.h[r] = h[fail] * fac.astype(dt)
        K[:, r] = Kr[:, fail]
        # accepted: the outputs it passes, then the next step
        acc = ~fail
        a, z, zn, h, err, Kr = rows[acc], z[acc], zn[acc], h[acc], err[acc], Kr[:, acc]
        cause[a] = 0
        tnew = numpy.where(last[acc], tend, b.t[a] + h)
        stopped = _batch_outputs(b, a, z, zn, h, Kr, tnew, iout, direction)
        keep = ~stopped
        a, z, zn, h, err, Kr, tnew = a[keep], z[keep], zn[keep], h[keep], err[keep], Kr[:, keep], tnew[keep]
        size = numpy.maximum(numpy.max(numpy.abs(z), axis=-1), numpy.max(numpy.abs(zn), axis=-1)).astype(numpy.float64)
        b.local_error[a] += err * (opt["atol"] + opt["rtol"] * size)
        b.z[a], b.t[a] = zn, tnew
        Kr[0] = Kr[fsal]
        K[:, a] = Kr
        b.count["naccepted"][a] += 1
        with numpy.errstate(all="ignore"):
            grow = numpy.where(err > 0, 0.9 * _power(err, -1.0 / order), facmax)
        fac = numpy.maximum(facmin, numpy.minimum(grow, numpy.where(rejected[a], 1.0, facmax)))
        rejected[a] = False
        hn = h * fac.astype(dt)
        b.h[a] = numpy.where(numpy.abs(hn.astype(numpy.float64)) > hmax, dt.type(direction * hmax), hn)
        ended = iout[a] >= nt
        b.finish(a[ended], OK, b.z[a[ended]], b.t[a[ended]], b.h[a[ended]])


def _batch_outputs(b, rows, z, zn, h, K, tnew, iout, direction):
    """The output times each accepted step of trajectories `rows` passes: its end state,
    or its dense output.  -> the rows that stopped (dop853's dense-output stages failed)."""
    nt, t_out = b.nt, b.t_out
    R, n = z.shape
    stopped = numpy.zeros(R, bool)
    prepared = numpy.zeros(R, bool)
    F = numpy.zeros((7, R, n), b.dtype) if b.method == "dop853" else None
    while True:
        at = numpy.minimum(iout[rows], nt - 1)
        due = (iout[rows] < nt) & ((t_out[at] - tnew) * direction <= 0) & ~stopped
        if not due.any():
            return stopped
        exact = due & (t_out[at] == tnew)
        dense = due & ~exact
        if F is not None and (dense & ~prepared).any():
            need = dense & ~prepared
            st = _batch_dense_prepare(b, rows, z, zn, h, K, need, F)
            prepared |= need
            failed = need & (st != OK)
            b.finish(rows[failed], st[failed], z[failed], b.t[rows[failed]], h[failed])
            stopped |= failed
            dense &= ~failed
        with numpy.errstate(all="ignore"):
            theta = ((t_out[at] - b.t[rows]) / h)[:, None]
            y = dop853_dense(z, F, theta) if F is not None else dopri5_dense(z, h[:, None], K, theta)
        b.y_out[rows[exact], iout[rows[exact]]] = zn[exact]
        b.y_out[rows[dense], iout[rows[dense]]] = y[dense]
        moved = rows[exact | dense]
        b.count["nout"][moved] += 1
        iout[moved] += 1


def _batch_dense_prepare(b, rows, z, zn, h, K, need, F):
    """dop853_dense_prepare for the trajectories of mask `need`: their three extra stages
    into K and their rows of F.  -> each row's status."""
    tab = _tab("dop853", z.dtype)
    sel = numpy.flatnonzero(need)
    Ks, zs, hs = K[:, sel], z[sel], h[sel]
    st = numpy.zeros(len(rows), numpy.int64)
    st[sel] = b.stages(rows[sel], "dop853", zs, hs, Ks, numpy.zeros(len(sel), numpy.int64), tab["extra"],
                       b.t[rows[sel]])
    K[:, sel] = Ks
    hc = hs[:, None]
    F[0, sel] = zn[sel] - zs
    F[1, sel] = hc * Ks[0] - F[0, sel]
    F[2, sel] = F[0, sel] - hc * Ks[12] - F[1, sel]
    for r, row in enumerate(tab["d"]):
        F[3 + r, sel] = hc * _combo(row, Ks)
    return st


def _batch_fixed_step(b, rows, z, h, t):
    """_fixed_step of rk4 or rk8 for trajectories `rows`, all at the same h from the grid
    time t: (status, z_new)."""
    over = b.count["nsteps"][rows] >= b.opt["max_steps"]
    b.count["nsteps"][rows[~over]] += 1
    K = numpy.zeros((16,) + z.shape, b.dtype)
    ts = numpy.full(len(rows), t, b.dtype)
    st, K[0] = b.eval(rows, z, ~over, ts)
    st = numpy.where(over, MAX_STEPS, st)
    st, zn, _ = b.step(rows, z, numpy.full(len(rows), h, b.dtype), K, st, ts)
    st = numpy.where((st == OK) & ~numpy.all(numpy.isfinite(zn), axis=-1), NONFINITE, st)
    b.count["naccepted"][rows[st == OK]] += 1
    return st, zn


def _batch_fixed(b, rows, direction):
    """_drive_fixed for every row at once: the grid t0 + k h, shared by the rows."""
    dt, t_out, nt = b.dtype, b.t_out, b.nt
    eps = float(numpy.finfo(dt).eps)
    t = t_out[0]
    h = dt.type(direction * b.opt["h"])
    h_end, kgrid, side = 0.0, 0, None
    z = b.z[rows]

    def stop(bad, st):
        """Rows `bad` (a mask) end with status st at the grid point t: -> the others."""
        b.h_end[rows[bad]] = h_end
        b.finish(rows[bad], st[bad], z[bad], numpy.full(bad.sum(), t, dt), numpy.full(bad.sum(), h, dt))
        return rows[~bad], z[~bad], ~bad
    for iout in range(1, nt):
        slack = 16 * eps * (abs(float(t_out[0])) + abs(float(t_out[iout])) + abs(float(h)))
        while len(rows):
            tnext = t_out[0] + dt.type(kgrid + 1) * h
            if float((tnext - t_out[iout]) * direction) > slack:
                break
            st, zn = _batch_fixed_step(b, rows, z, h, t)
            rows, z, keep = stop(st != OK, st)
            z, t, kgrid = zn[keep], tnext, kgrid + 1
        if not len(rows):
            return
        if float((t_out[iout] - t) * direction) <= slack:
            side, h_end = None, 0.0
            b.y_out[rows, iout] = z
        else:
            h_end = float(t_out[iout] - t)
            st, side = _batch_fixed_step(b, rows, z, t_out[iout] - t, t)
            rows, z, keep = stop(st != OK, st)
            side = side[keep]
            b.y_out[rows, iout] = side
        b.count["nout"][rows] += 1
    b.h_end[rows] = h_end
    b.finish(rows, OK, z if side is None else side, numpy.full(len(rows), t_out[-1], dt), numpy.full(len(rows), h, dt))


def _batch_problems(method, y0, p, t, opt):
    """problem() of each row: the rows' shared checks once, a row's own (a value of its y0
    or p not finite) where it has one."""
    common = problem(method, numpy.zeros(y0.shape[1], y0.dtype), numpy.zeros(p.shape[1], p.dtype), t, opt)
    finite = numpy.all(numpy.isfinite(y0), axis=1) & numpy.all(numpy.isfinite(p), axis=1)
    return [common if finite[i] else problem(method, y0[i], p[i], t, opt) for i in range(len(y0))]


def integrate_batch(kernels, method, y0, p, t, dtype=numpy.float64, **options):
    """Many trajectories of the model whose kernel module is `kernels`.

    The explicit methods (BATCHED: rk4, rk8, dopri5, dop853) integrate the batch as arrays,
    every kernel call evaluating all its running trajectories, each with its own steps,
    status and counters, as integrate would; the implicit methods and abm12 call integrate
    once a row.

    Parameters
    ----------
    kernels : module or System
        The model's generated kernels (<model>.py), or a System made of them.
    method : str
        One of METHODS.
    y0 : array_like, shape (B, n)
        The initial states, one a row.
    p : array_like, shape (n_params,) or (B, n_params)
        The parameters (then the inputs): one vector for every row, or one a row.
    t : array_like
        The output times, strictly monotone, shared by the rows.
    dtype : numpy dtype
        The real type of the run.
    **options
        As integrate's; another key raises TypeError (once, not once a row).

    Returns
    -------
    statuses : ndarray, shape (B,)
    y_out : ndarray, shape (B, len(t), n)
    infos : list of dict
        Each row's info, as integrate's.
    """
    system = kernels if isinstance(kernels, System) else System(kernels)
    opt = options_of(options)            # a typo fails once, not once per trajectory
    dtype = numpy.dtype(dtype)
    y0 = numpy.asarray(y0, dtype).reshape(-1, system.n)
    p = numpy.broadcast_to(numpy.asarray(p, dtype), (len(y0), system.n_params))
    if method not in BATCHED:
        results = [integrate(system, method, y0[i], p[i], t, dtype, **options) for i in range(len(y0))]
        return (numpy.array([r[0] for r in results], dtype=int),
                numpy.array([r[1] for r in results]).reshape(len(y0), -1, system.n), [r[2] for r in results])
    t = numpy.asarray(t, dtype).reshape(-1)
    reasons = _batch_problems(method, y0, p, t, opt)
    good = numpy.array([r is None for r in reasons], bool)
    statuses = numpy.full(len(y0), BAD_INPUT, int)
    y_out = numpy.full((len(y0), len(t), system.n), numpy.nan, dtype)
    infos = []
    for i, reason in enumerate(reasons):
        info = new_info()
        info.update(status=BAD_INPUT, t=float(t[0]) if len(t) else 0.0, y=numpy.array(y0[i], dtype), reason=reason)
        infos.append(info)
    if good.any():
        rows = numpy.flatnonzero(good)
        b = _Batch(system, method, y0[rows], numpy.ascontiguousarray(p[rows]), t, opt, dtype)
        direction = 1 if t[-1] > t[0] else -1
        running = _batch_start(b, direction)
        if len(running):
            (_batch_adaptive if method in ("dopri5", "dop853") else _batch_fixed)(b, running, direction)
        statuses[rows], y_out[rows] = b.status, b.y_out
        for r, info in zip(rows, b.infos()):
            infos[r] = info
    return statuses, y_out, infos
