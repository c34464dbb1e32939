/* derive's compiled call path: simulate's plain call, from its Python arguments to its
   SimulationResult, in one C function (derive/runtime/compiled_call.py builds this file
   into derive's cache and prepares one `Call` per set of option arguments).

   A `Call` holds what derive/runtime/fast_path.py's plan checks once (sizes, limits, the
   parameter vectors that passed the model's checks, the options struct and the entry
   point).  Calling it with (y0, t, params) makes the fast path's checks of the arguments,
   fills the buffers, calls the integrator's batch entry point for one trajectory (the
   runner's entry, Runner.execute's call) and builds the result as Runner.execute and
   simulate's _finish do.  Anything not plainly valid, or any case it does not cover,
   returns None: Python's fast path then runs, which gives every refusal its one line.
   So this file only accelerates; it decides nothing the Python paths do not. */
#define PY_SSIZE_T_CLEAN
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <Python.h>
#include <structmember.h>
#include <numpy/arrayobject.h>
#include <math.h>
#include <string.h>
#include "compiled_call.h"

/* the batch entry points (derive/templates: <model>_integrate.h, <model>_taylor.h):
   B, [method,] y0, its row stride, p, its row stride, nt, t, out, options, infos */
typedef long (*rk_batch)(long, int, const void *, long, const void *, long, long, const void *,
                         void *, const void *, void *);
typedef long (*taylor_batch)(long, const void *, long, const void *, long, long, const void *,
                             void *, const void *, void *);

enum { REAL_FLOAT, REAL_DOUBLE, REAL_LONG_DOUBLE };
enum { COUNTERS = 6 };
#define EXACT_INT_DOUBLE 9007199254740992.0     /* 2^53: ints beyond are not exactly doubles */
#define EXACT_INT_FLOAT 16777216.0              /* 2^24: ints beyond are rounded by float */

/* the result's fields this file sets, by name (interned once) */
enum { F_T, F_Y, F_STATUS, F_STATUS_NAME, F_T_STOP, F_Y_STOP, F_PARAMS, F_OBSERVE, F_LAST_STEP,
       F_NFEV, F_NJEV, F_NSTEPS, F_NACCEPTED, F_NREJECTED, F_NNEWTON, F_ERROR_ESTIMATE, F_COUNT };
static const char *field_names[F_COUNT] = {
    "t", "y", "status", "status_name", "t_stop", "y_stop", "params", "observe", "last_step",
    "nfev", "njev", "nsteps", "naccepted", "nrejected", "nnewton", "error_estimate"};
static PyObject *fields[F_COUNT];
static long max_steps_status = -1;      /* the status of a run stopped at its step budget */

typedef struct {
    PyObject_HEAD
    void *entry;                 /* the batch entry point */
    int method;                  /* its method index; -1: Taylor's (no method argument) */
    int n, n_params, n_coordinates, real, typenum;
    double eps;                  /* the run's machine epsilon (the angle check) */
    double row_bytes, max_bytes, step, max_steps, limit, quick_steps;
    int budget_given, tolerance, local_error, pilot;
    const void *options;         /* the options struct (owned by options_owner) */
    Py_ssize_t info_size;
    Py_ssize_t off_status, off_t, off_h_end, off_local_error, off_y, off_counters[COUNTERS];
    PyObject *options_owner, *names, *checked, *status_names, *cls, *prototype;
    PyObject *partial, *observe, *model, *dtype, *backend;
    double last_params[DERIVE_COMPILED_CALL_MAX_N];    /* the last vector found in checked */
    int has_last;
    vectorcallfunc vectorcall;
} Call;

/* -- reading plain arguments ---------------------------------------------------------- */

/* A number as fast_path.plain_numbers accepts it (a finite float, or an int exactly
   representable in the run's real type): 1 and its value, or 0. */
static int plain_number(PyObject *v, int real, double *out)
{
    if (PyFloat_Check(v)) {
        double d = PyFloat_AS_DOUBLE(v);
        if (d - d != 0)
            return 0;
        *out = d;
        return 1;
    }
    if (PyLong_CheckExact(v)) {
        int overflow = 0;
        long long x = PyLong_AsLongLongAndOverflow(v, &overflow);
        double limit = real == REAL_FLOAT ? EXACT_INT_FLOAT : EXACT_INT_DOUBLE;
        if (overflow || (x == -1 && PyErr_Occurred())) {
            PyErr_Clear();
            return 0;
        }
        if ((double)x > limit || (double)x < -limit)
            return 0;
        *out = (double)x;
        return 1;
    }
    return 0;
}

/* The items of a plain sequence: a list or tuple (any length), or a 1-D float64 array of
   at most DERIVE_COMPILED_CALL_MAX_N items (fast_path.LIST_MAX).  Returns its length and
   fills values (up to cap; a longer list is read by the caller through *items), or -1. */
typedef struct { PyObject **items; PyArrayObject *array; Py_ssize_t len; } Plain;

static int plain_sequence(PyObject *obj, Plain *s)
{
    s->items = NULL;
    s->array = NULL;
    if (PyList_CheckExact(obj) || PyTuple_CheckExact(obj)) {
        s->items = PySequence_Fast_ITEMS(obj);
        s->len = PySequence_Fast_GET_SIZE(obj);
        return 1;
    }
    if (PyArray_CheckExact(obj)) {
        PyArrayObject *a = (PyArrayObject *)obj;
        if (PyArray_TYPE(a) != NPY_DOUBLE || PyArray_NDIM(a) != 1 ||
            PyArray_DIM(a, 0) > DERIVE_COMPILED_CALL_MAX_N)
            return 0;
        s->array = a;
        s->len = PyArray_DIM(a, 0);
        return 1;
    }
    return 0;
}

static int plain_item(const Plain *s, Py_ssize_t i, int real, double *out)
{
    if (s->items)
        return plain_number(s->items[i], real, out);
    double d = *(const double *)PyArray_GETPTR1(s->array, i);
    if (d - d != 0)
        return 0;
    *out = d;
    return 1;
}

/* n plain numbers from obj into values: 1, or 0 when obj is not plainly that. */
static int plain_vector(PyObject *obj, int n, int real, double *values)
{
    Plain s;
    if (!plain_sequence(obj, &s) || s.len != n)
        return 0;
    for (Py_ssize_t i = 0; i < n; i++)
        if (!plain_item(&s, i, real, &values[i]))
            return 0;
    return 1;
}

/* The parameter values (a dict by exactly the model's names, or a plain sequence:
   fast_path.RunPlan.params) into values, when the plan has them among the vectors that
   passed the model's checks (by tuple(p), as the plan remembers them): 1, or 0 (not
   plain, or not checked yet: Python's fast path decides). */
static int plain_params(Call *c, PyObject *params, double *values)
{
    PyObject *key;
    if (PyDict_CheckExact(params)) {
        if (PyDict_GET_SIZE(params) != c->n_params)
            return 0;
        for (int i = 0; i < c->n_params; i++) {
            PyObject *v = PyDict_GetItemWithError(params, PyTuple_GET_ITEM(c->names, i));
            if (!v || !plain_number(v, c->real, &values[i])) {
                PyErr_Clear();
                return 0;
            }
        }
    } else if (!plain_vector(params, c->n_params, c->real, values)) {
        return 0;
    }
    /* the model's checks depend on the values only: the vector found last needs no lookup */
    if (c->has_last && !memcmp(values, c->last_params, sizeof(double) * (size_t)c->n_params))
        return 1;
    if (PyDict_CheckExact(params)) {
        key = PyTuple_New(c->n_params);
        for (int i = 0; key && i < c->n_params; i++)
            PyTuple_SET_ITEM(key, i, PyFloat_FromDouble(values[i]));
    } else {
        if (PyTuple_CheckExact(params)) {
            key = params;
            Py_INCREF(key);
        } else if (PyList_CheckExact(params)) {
            key = PyList_AsTuple(params);
        } else {
            key = PyTuple_New(c->n_params);
            for (int i = 0; key && i < c->n_params; i++)
                PyTuple_SET_ITEM(key, i, PyFloat_FromDouble(values[i]));
        }
    }
    if (!key) {
        PyErr_Clear();
        return 0;
    }
    int known = PySet_Contains(c->checked, key);
    Py_DECREF(key);
    if (known != 1) {
        PyErr_Clear();
        return 0;
    }
    memcpy(c->last_params, values, sizeof(double) * (size_t)c->n_params);
    c->has_last = 1;
    return 1;
}

/* -- the run's reals -------------------------------------------------------------------- */

static void store(void *base, int real, Py_ssize_t i, double v)
{
    switch (real) {
    case REAL_FLOAT: ((float *)base)[i] = (float)v; break;
    case REAL_DOUBLE: ((double *)base)[i] = v; break;
    default: ((long double *)base)[i] = (long double)v; break;
    }
}

/* |t[last] - t[0]| in the run's own arithmetic, as simulate._fixed_steps computes it */
static double stored_span(const void *t, int real, Py_ssize_t last)
{
    switch (real) {
    case REAL_FLOAT: return (double)fabsf(((const float *)t)[last] - ((const float *)t)[0]);
    case REAL_DOUBLE: return fabs(((const double *)t)[last] - ((const double *)t)[0]);
    default: return (double)fabsl(((const long double *)t)[last] - ((const long double *)t)[0]);
    }
}

static PyArrayObject *new_array(Call *c, int nd, npy_intp *dims)
{
    return (PyArrayObject *)PyArray_SimpleNew(nd, dims, c->typenum);
}

/* The output times into a new array of the run's type when plainly valid (a plain
   sequence, strictly monotone: fast_path.plain_times); NULL otherwise.  *span: |t1 - t0|. */
static PyArrayObject *plain_times(Call *c, PyObject *t, double *span)
{
    Plain s;
    if (!plain_sequence(t, &s) || s.len < 1)
        return NULL;
    npy_intp nt = s.len;
    PyArrayObject *out = new_array(c, 1, &nt);
    if (!out)
        return NULL;
    void *data = PyArray_DATA(out);
    double first = 0, previous = 0, direction = 0;
    for (Py_ssize_t i = 0; i < nt; i++) {
        double v;
        if (!plain_item(&s, i, c->real, &v))
            goto refuse;
        if (i == 0) {
            first = v;
        } else {
            if (i == 1)
                direction = v > previous ? 1 : -1;
            if (!((v - previous) * direction > 0))
                goto refuse;
        }
        previous = v;
        store(data, c->real, i, v);
    }
    *span = fabs(previous - first);
    return out;
refuse:
    Py_DECREF(out);
    return NULL;
}

/* -- the call --------------------------------------------------------------------------- */

/* The fast path's checks of size and steps (RunPlan.fits), and whether the run is one
   simulate makes directly, not cancellably (simulate._drive: a fixed step's steps within
   QUICK_STEPS). */
static int fits(Call *c, npy_intp nt, double span, const void *t)
{
    if (nt * c->row_bytes > c->max_bytes || !(span - span == 0))
        return 0;
    double steps = c->step ? span / c->step : 0.0;
    if (!(steps <= c->max_steps && (c->budget_given || steps <= c->limit)))
        return 0;
    if (c->tolerance)
        return 1;
    double stored = nt > 1 ? stored_span(t, c->real, nt - 1) : 0.0;
    return (c->step ? stored / c->step : 0.0) <= c->quick_steps;
}

static int set_field(PyObject *d, int f, PyObject *v)
{
    if (!v)
        return -1;
    int rc = PyDict_SetItem(d, fields[f], v);
    Py_DECREF(v);
    return rc;
}

static PyObject *long_at(const char *info, Py_ssize_t offset)
{
    return PyLong_FromLong(*(const long *)(info + offset));
}

/* The result as Runner.execute makes it (result_factory: the prototype's fields, then the
   run's own), _finish's fields already in the prototype. */
static PyObject *result(Call *c, const char *info, PyArrayObject *t, PyArrayObject *out,
                        PyArrayObject *p)
{
    int status = *(const int *)(info + c->off_status);
    if (status < 0 || status >= PyTuple_GET_SIZE(c->status_names)) {
        PyErr_Format(PyExc_RuntimeError, "derive: the integrator returned status %d", status);
        return NULL;
    }
    npy_intp n = c->n;
    PyArrayObject *y_stop = (PyArrayObject *)PyArray_SimpleNew(
        1, &n, c->real == REAL_LONG_DOUBLE ? NPY_LONGDOUBLE : NPY_DOUBLE);
    if (!y_stop)
        return NULL;
    const long double *y = (const long double *)(info + c->off_y);
    for (npy_intp i = 0; i < n; i++) {
        if (c->real == REAL_LONG_DOUBLE)
            ((long double *)PyArray_DATA(y_stop))[i] = y[i];
        else
            ((double *)PyArray_DATA(y_stop))[i] = (double)y[i];
    }
    PyObject *d = PyDict_Copy(c->prototype);
    if (!d) {
        Py_DECREF(y_stop);
        return NULL;
    }
    /* the output times last: a time-dependent model's energy and positions take them */
    PyObject *observe_args[7] = {c->observe, c->model, (PyObject *)out, (PyObject *)p, c->dtype,
                                 c->backend, (PyObject *)t};
    double h_end = *(const double *)(info + c->off_h_end);
    PyObject *status_name = PyTuple_GET_ITEM(c->status_names, status);
    Py_INCREF(t); Py_INCREF(out); Py_INCREF(p); Py_INCREF(status_name);
    int bad = set_field(d, F_T, (PyObject *)t) | set_field(d, F_Y, (PyObject *)out) |
        set_field(d, F_STATUS, PyLong_FromLong(status)) | set_field(d, F_STATUS_NAME, status_name) |
        set_field(d, F_T_STOP, PyFloat_FromDouble(*(const double *)(info + c->off_t))) |
        set_field(d, F_Y_STOP, (PyObject *)y_stop) | set_field(d, F_PARAMS, (PyObject *)p) |
        set_field(d, F_OBSERVE, PyObject_Vectorcall(c->partial, observe_args, 7, NULL));
    if (h_end && !c->tolerance)
        bad |= set_field(d, F_LAST_STEP, PyFloat_FromDouble(h_end));
    else
        bad |= PyDict_SetItem(d, fields[F_LAST_STEP], Py_None);
    for (int k = 0; k < COUNTERS; k++)
        bad |= set_field(d, F_NFEV + k, long_at(info, c->off_counters[k]));
    if (c->local_error)
        bad |= set_field(d, F_ERROR_ESTIMATE,
                         PyFloat_FromDouble(*(const double *)(info + c->off_local_error)));
    else
        bad |= PyDict_SetItem(d, fields[F_ERROR_ESTIMATE], Py_None);
    /* tp_alloc, not object.__new__: the instance values object.__new__ makes would be
       discarded for the dict set next */
    PyObject *r = bad ? NULL : ((PyTypeObject *)c->cls)->tp_alloc((PyTypeObject *)c->cls, 0);
    if (r && PyObject_GenericSetDict(r, d, NULL) < 0)
        Py_CLEAR(r);
    Py_DECREF(d);
    return r;
}

/* One run of the call c: args (y0, t, params) -> SimulationResult, or None (Python's fast
   path decides). */
static PyObject *run(Call *c, PyObject *const *args)
{
    double y0[DERIVE_COMPILED_CALL_MAX_N], pv[DERIVE_COMPILED_CALL_MAX_N], span = 0;
    if (!plain_params(c, args[2], pv))
        Py_RETURN_NONE;
    if (!plain_vector(args[0], c->n, c->real, y0))
        Py_RETURN_NONE;
    double qmax = 0;
    for (int i = 0; i < c->n_coordinates; i++)
        qmax = fabs(y0[i]) > qmax ? fabs(y0[i]) : qmax;
    if (qmax * c->eps > 0.5e-3)              /* simulate.MAX_ANGLE_ULP / 2, as RunPlan.state */
        Py_RETURN_NONE;
    PyArrayObject *t = plain_times(c, args[1], &span);
    if (!t)
        Py_RETURN_NONE;
    npy_intp nt = PyArray_DIM(t, 0);
    if (!fits(c, nt, span, PyArray_DATA(t))) {
        Py_DECREF(t);
        Py_RETURN_NONE;
    }
    npy_intp np_ = c->n_params, dims[2] = {nt, c->n};
    PyArrayObject *p = new_array(c, 1, &np_), *out = new_array(c, 2, dims);
    PyObject *r = NULL;
    if (p && out) {
        _Alignas(16) char state[sizeof(long double) * DERIVE_COMPILED_CALL_MAX_N];
        _Alignas(16) char info[DERIVE_COMPILED_CALL_INFO_MAX];
        for (int i = 0; i < c->n; i++)
            store(state, c->real, i, y0[i]);
        for (int i = 0; i < c->n_params; i++)
            store(PyArray_DATA(p), c->real, i, pv[i]);
        memset(info, 0, (size_t)c->info_size);
        const void *pd = PyArray_DATA(p), *td = PyArray_DATA(t);
        void *od = PyArray_DATA(out);
        Py_BEGIN_ALLOW_THREADS
        if (c->method < 0)
            ((taylor_batch)c->entry)(1, state, c->n, pd, 0, nt, td, od, c->options, info);
        else
            ((rk_batch)c->entry)(1, c->method, state, c->n, pd, 0, nt, td, od, c->options, info);
        Py_END_ALLOW_THREADS
        r = result(c, info, t, out, p);
    }
    Py_XDECREF(p);
    Py_XDECREF(out);
    Py_DECREF(t);
    return r;
}

/* Call(y0, t, params) -> SimulationResult, or None (Python's fast path decides). */
static PyObject *call_vectorcall(PyObject *self, PyObject *const *args, size_t nargsf, PyObject *kw)
{
    if (PyVectorcall_NARGS(nargsf) != 3 || kw) {
        PyErr_SetString(PyExc_TypeError, "Call(y0, t, params)");
        return NULL;
    }
    return run((Call *)self, args);
}

/* -- simulate's arguments to their call ------------------------------------------------ */

static PyObject *registry;       /* call_key -> Call (compiled_call.py's registry) */
static PyObject *local;          /* "local", simulate's default error_estimate */

/* simulate's arguments, in its signature's order */
enum { A_MODEL, A_Y0, A_T, A_PARAMS, A_METHOD, A_RTOL, A_ATOL, A_STEP, A_DTYPE, A_BACKEND, A_MAX_STEPS,
       A_SINE_MIN, A_NEWTON_TOL, A_NEWTON_MAX, A_HMAX, A_INPUTS, A_ATLAS, A_EVENTS, A_ERROR_ESTIMATE,
       A_HOLD, A_COUNT };

/* The key of simulate's call (compiled_call.call_key) has these arguments, in this order. */
enum { KEY_SIZE = 11 };
static const int key_args[KEY_SIZE] = {A_MODEL, A_METHOD, A_DTYPE, A_RTOL, A_ATOL, A_STEP, A_HMAX, A_MAX_STEPS,
                                       A_NEWTON_TOL, A_NEWTON_MAX, A_SINE_MIN};
/* the key found last and its call: a loop passes the same objects every time, and the
   same objects are the same key, found without hashing it (forget() drops them) */
static PyObject *last_key, *last_call;

static PyObject *last_call_of(PyObject *const *a)
{
    if (!last_key)
        return NULL;
    for (int k = 0; k < KEY_SIZE; k++)
        if (PyTuple_GET_ITEM(last_key, k) != a[key_args[k]])
            return NULL;
    return last_call;
}

/* dispatch(*simulate's twenty arguments) -> the result of their registered call; (the
   result,) for an adaptive run's pilot that stopped at its step budget (simulate goes on
   from it); None where there is no call or the call declines (the Python paths run). */
static PyObject *dispatch(PyObject *module, PyObject *const *a, Py_ssize_t nargs)
{
    if (nargs != A_COUNT) {
        PyErr_SetString(PyExc_TypeError, "dispatch takes simulate's twenty arguments");
        return NULL;
    }
    /* simulate's plain call: backend "c", no atlas, inputs, events or hold, the local estimate */
    if (!registry || !PyUnicode_CheckExact(a[A_BACKEND]) || PyUnicode_CompareWithASCIIString(a[A_BACKEND], "c") ||
        a[A_ATLAS] != Py_False || a[A_INPUTS] != Py_None || a[A_EVENTS] != Py_None || a[A_HOLD] != Py_None ||
        !PyUnicode_CheckExact(a[A_ERROR_ESTIMATE]) || PyUnicode_Compare(a[A_ERROR_ESTIMATE], local))
        Py_RETURN_NONE;
    PyObject *call = last_call_of(a);
    if (!call) {
        PyObject *key = PyTuple_Pack(KEY_SIZE, a[A_MODEL], a[A_METHOD], a[A_DTYPE], a[A_RTOL], a[A_ATOL],
                                     a[A_STEP], a[A_HMAX], a[A_MAX_STEPS], a[A_NEWTON_TOL], a[A_NEWTON_MAX],
                                     a[A_SINE_MIN]);
        if (!key)
            return NULL;
        call = PyDict_GetItemWithError(registry, key);       /* borrowed */
        if (!call) {
            Py_DECREF(key);
            PyErr_Clear();              /* an unhashable argument: the Python paths decide */
            Py_RETURN_NONE;
        }
        Py_XSETREF(last_key, key);
        Py_INCREF(call);
        Py_XSETREF(last_call, call);
    }
    Py_INCREF(call);
    PyObject *args[3] = {a[A_Y0], a[A_T], a[A_PARAMS]};
    PyObject *r = run((Call *)call, args);
    int pilot = ((Call *)call)->pilot;
    Py_DECREF(call);
    if (!r || r == Py_None || !pilot)
        return r;
    PyObject *status = PyObject_GetAttr(r, fields[F_STATUS]);
    long code = status ? PyLong_AsLong(status) : -1;
    Py_XDECREF(status);
    if (code != max_steps_status)
        return r;
    PyObject *stopped = PyTuple_Pack(1, r);
    Py_DECREF(r);
    return stopped;
}

/* forget(): the registry changed (cleared, or a key given another call) */
static PyObject *forget(PyObject *module, PyObject *unused)
{
    Py_CLEAR(last_key);
    Py_CLEAR(last_call);
    Py_RETURN_NONE;
}

/* use(registry, max_steps_status): the registry dispatch reads, and the status of a run
   stopped at its step budget. */
static PyObject *use(PyObject *module, PyObject *args)
{
    PyObject *d;
    if (!PyArg_ParseTuple(args, "O!l", &PyDict_Type, &d, &max_steps_status))
        return NULL;
    Py_INCREF(d);
    Py_XSETREF(registry, d);
    return forget(module, NULL);
}

static PyMethodDef functions[] = {
    {"forget", forget, METH_NOARGS, "forget(): the registry changed"},
    {"dispatch", (PyCFunction)(void (*)(void))dispatch, METH_FASTCALL,
     "dispatch(*simulate's arguments) -> result, (pilot,) or None"},
    {"use", use, METH_VARARGS, "use(registry, max_steps_status)"},
    {NULL}
};

/* -- the Call type ------------------------------------------------------------------------ */

static int take(PyObject *spec, const char *name, PyObject **slot)
{
    PyObject *v = PyDict_GetItemString(spec, name);
    if (!v) {
        PyErr_Format(PyExc_KeyError, "Call spec: no '%s'", name);
        return -1;
    }
    Py_INCREF(v);
    *slot = v;
    return 0;
}

static int number(PyObject *spec, const char *name, double *out)
{
    PyObject *v = PyDict_GetItemString(spec, name);
    if (!v) {
        PyErr_Format(PyExc_KeyError, "Call spec: no '%s'", name);
        return -1;
    }
    *out = PyFloat_AsDouble(v);
    return PyErr_Occurred() ? -1 : 0;
}

static int integer(PyObject *spec, const char *name, Py_ssize_t *out)
{
    double v;
    if (number(spec, name, &v) < 0)
        return -1;
    *out = (Py_ssize_t)v;
    return 0;
}

/* Call(spec): spec a dict, made by derive/runtime/compiled_call.py (call_spec). */
static PyObject *call_new(PyTypeObject *type, PyObject *args, PyObject *kw)
{
    PyObject *spec;
    if (!PyArg_ParseTuple(args, "O!", &PyDict_Type, &spec))
        return NULL;
    Call *c = (Call *)type->tp_alloc(type, 0);
    if (!c)
        return NULL;
    c->vectorcall = call_vectorcall;
    Py_ssize_t entry, options, method, n, n_params, n_coordinates, real, budget, tol, local, pilot;
    PyObject *offsets = NULL;
    static const char *counter_names[COUNTERS] = {"nfev", "njev", "nsteps", "naccepted", "nrejected",
                                                   "nnewton"};
    if (integer(spec, "entry", &entry) || integer(spec, "options", &options) ||
        integer(spec, "method", &method) || integer(spec, "n", &n) ||
        integer(spec, "n_params", &n_params) || integer(spec, "n_coordinates", &n_coordinates) ||
        integer(spec, "real", &real) || integer(spec, "budget_given", &budget) ||
        integer(spec, "tolerance", &tol) || integer(spec, "local_error", &local) ||
        integer(spec, "pilot", &pilot) ||
        integer(spec, "info_size", &c->info_size) || number(spec, "eps", &c->eps) ||
        number(spec, "row_bytes", &c->row_bytes) || number(spec, "max_bytes", &c->max_bytes) ||
        number(spec, "step", &c->step) || number(spec, "max_steps", &c->max_steps) ||
        number(spec, "limit", &c->limit) || number(spec, "quick_steps", &c->quick_steps) ||
        take(spec, "options_owner", &c->options_owner) || take(spec, "names", &c->names) ||
        take(spec, "checked", &c->checked) || take(spec, "status_names", &c->status_names) ||
        take(spec, "cls", &c->cls) || take(spec, "prototype", &c->prototype) ||
        take(spec, "partial", &c->partial) || take(spec, "observe", &c->observe) ||
        take(spec, "model", &c->model) || take(spec, "dtype", &c->dtype) ||
        take(spec, "backend", &c->backend) || take(spec, "offsets", &offsets))
        goto fail;
    c->entry = (void *)entry;
    c->options = (const void *)options;
    c->method = (int)method;
    c->n = (int)n;
    c->n_params = (int)n_params;
    c->n_coordinates = (int)n_coordinates;
    c->real = (int)real;
    c->typenum = real == REAL_FLOAT ? NPY_FLOAT : real == REAL_DOUBLE ? NPY_DOUBLE : NPY_LONGDOUBLE;
    c->budget_given = (int)budget;
    c->tolerance = (int)tol;
    c->local_error = (int)local;
    c->pilot = (int)pilot;
    if (n > DERIVE_COMPILED_CALL_MAX_N || n_params > DERIVE_COMPILED_CALL_MAX_N ||
        c->info_size > DERIVE_COMPILED_CALL_INFO_MAX || !PyDict_Check(offsets) ||
        !PyTuple_Check(c->names) || PyTuple_GET_SIZE(c->names) != n_params ||
        !PyAnySet_Check(c->checked) || !PyTuple_Check(c->status_names) || !PyDict_Check(c->prototype) ||
        !PyType_Check(c->cls)) {
        PyErr_SetString(PyExc_ValueError, "Call spec: sizes or types out of range");
        goto fail;
    }
    if (integer(offsets, "status", &c->off_status) || integer(offsets, "t", &c->off_t) ||
        integer(offsets, "h_end", &c->off_h_end) || integer(offsets, "local_error", &c->off_local_error) ||
        integer(offsets, "y", &c->off_y))
        goto fail;
    for (int k = 0; k < COUNTERS; k++)
        if (integer(offsets, counter_names[k], &c->off_counters[k]))
            goto fail;
    Py_DECREF(offsets);
    return (PyObject *)c;
fail:
    Py_XDECREF(offsets);
    Py_DECREF(c);
    return NULL;
}

static void call_dealloc(Call *c)
{
    Py_XDECREF(c->options_owner); Py_XDECREF(c->names); Py_XDECREF(c->checked);
    Py_XDECREF(c->status_names); Py_XDECREF(c->cls); Py_XDECREF(c->prototype);
    Py_XDECREF(c->partial); Py_XDECREF(c->observe); Py_XDECREF(c->model);
    Py_XDECREF(c->dtype); Py_XDECREF(c->backend);
    Py_TYPE(c)->tp_free((PyObject *)c);
}

static PyMemberDef call_members[] = {
    {"pilot", T_INT, offsetof(Call, pilot), READONLY,
     "1: the run is an adaptive run's pilot (a stop at its step budget goes on in Python)"},
    {"options_owner", T_OBJECT, offsetof(Call, options_owner), READONLY,
     "the options struct the call passes (kept alive by the call)"},
    {NULL}
};

static PyTypeObject CallType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_derive_compiled_call.Call",
    .tp_basicsize = sizeof(Call),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_VECTORCALL,
    .tp_doc = "One prepared simulate call: Call(spec); call(y0, t, params) -> result or None.",
    .tp_new = call_new,
    .tp_dealloc = (destructor)call_dealloc,
    .tp_call = PyVectorcall_Call,
    .tp_vectorcall_offset = offsetof(Call, vectorcall),
    .tp_members = call_members,
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_derive_compiled_call",
    "simulate's plain call in C (derive/runtime/compiled_call.py)", -1, functions,
};

PyMODINIT_FUNC PyInit__derive_compiled_call(void)
{
    import_array();
    for (int f = 0; f < F_COUNT; f++)
        if (!(fields[f] = PyUnicode_InternFromString(field_names[f])))
            return NULL;
    if (!(local = PyUnicode_InternFromString("local")) || PyType_Ready(&CallType) < 0)
        return NULL;
    PyObject *m = PyModule_Create(&module);
    if (!m)
        return NULL;
    Py_INCREF(&CallType);
    if (PyModule_AddObject(m, "Call", (PyObject *)&CallType) < 0) {
        Py_DECREF(&CallType);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
