/* Copied by derive 0.2.0 from codegen/backends/c/library/derive_driver.h for every model; do not edit. */
/* derive_driver.h: the stepping loop of derive's integrators, written once for every
 * model, every real type and the chart atlas (derive/codegen/backends/c/library/).
 *
 * Standalone C99, only <math.h>; reentrant: no globals, no allocation.  Included once
 * per real type: derive_integrators.h includes it for a model's own context, the atlas
 * (<atlas>.c) for its chart-switching one.  The including file defines, before each
 * inclusion (T: the type's name tag, e.g. x##_d):
 *
 *   the type       DERIVE_REAL, DERIVE_T(x), DERIVE_MATH(f) (fabs -> fabs, fabsf, fabsl),
 *                  DERIVE_EPS (the type's machine epsilon, a literal of the type)
 *   the contract   DERIVE_N (state size, a constant), DERIVE_OPTIONS (the options struct),
 *                  DERIVE_MAX_STAGES, DERIVE_METHOD_RK4 .. DERIVE_METHOD_LAST, DERIVE_METHOD_DOPRI5,
 *                  DERIVE_METHOD_DOP853, the status codes DERIVE_OK .. (see below)
 *   the context    DERIVE_DRIVER_CTX (a struct with p, opt, info, method) and its hooks,
 *                  called as
 *                    DERIVE_DRIVER_EVAL(c, z, f)                    f = z', guarded, counted
 *                    DERIVE_DRIVER_STEP(c, z, h, K, zn, err)        one step of c->method
 *                    DERIVE_DRIVER_DENSE_PREPARE(c, z, zn, h, K, F)
 *                    DERIVE_DRIVER_DENSE(c, z, zn, h, K, F, theta, out)
 *                    DERIVE_DRIVER_IN(c, y, z), DERIVE_DRIVER_OUT(c, z, y)   state <-> integration variable
 *                    DERIVE_DRIVER_SWITCH(c, z, force)              chart switch: 1, 0 or -status
 *                    DERIVE_DRIVER_SET_Y(c, z)                      info->y at the end
 *                  and, for a caller with a multistep method, DERIVE_DRIVER_PARTIAL_STEP(c, z,
 *                  h, K, zn): a one-step method for the shortened steps to output times off
 *                  the grid, which must not touch the multistep method's history.
 *   the time       DERIVE_TIMED, for a time-dependent model's context only: then EVAL, STEP,
 *                  PARTIAL_STEP and DENSE_PREPARE take the time first, after c (EVAL the
 *                  time of z, the others the step's start time): the driver passes the
 *                  time it has reached, or a stage's (DERIVE_WITH_T below).
 *
 * It defines (static) DERIVE_T(derive_drive)(c, y0, nt, t_out, y_out), the whole run, and
 * DERIVE_T(derive_check)(method, y0, ny, p, np, nt, t, opt), the checks of the entry
 * points; it undefines the DERIVE_DRIVER_* hooks (the type's macros are the includer's).
 */
#if defined(__cplusplus) && !defined(restrict)
#define restrict __restrict
#endif

/* "x," in a time-dependent model's code, nothing in an autonomous one's (as in
 * derive_integrators.h): an autonomous model's driver never forms the time. */
#ifndef DERIVE_WITH_T
#ifdef DERIVE_TIMED
#define DERIVE_WITH_T(x) x,
#else
#define DERIVE_WITH_T(x)
#endif
#endif


/* Hairer's starting step (Solving ODEs I, II.4). */
static DERIVE_REAL DERIVE_T(derive_hinit)(DERIVE_DRIVER_CTX *c, DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *z, const DERIVE_REAL *f0, DERIVE_REAL dir, DERIVE_REAL hmax, DERIVE_REAL order, DERIVE_REAL *z1, DERIVE_REAL *f1)
{
    DERIVE_REAL dnf = 0, dny = 0, der2 = 0, der12, h, h1, sk;
    int k;
    for (k = 0; k < DERIVE_N; ++k) {
        sk = (DERIVE_REAL)c->opt->atol + (DERIVE_REAL)c->opt->rtol * DERIVE_MATH(fabs)(z[k]);
        dnf += (f0[k] / sk) * (f0[k] / sk);
        dny += (z[k] / sk) * (z[k] / sk);
    }
    h = (dnf <= (DERIVE_REAL)1e-10 || dny <= (DERIVE_REAL)1e-10) ? (DERIVE_REAL)1e-6 : DERIVE_MATH(sqrt)(dny / dnf) * (DERIVE_REAL)0.01;
    if (h > hmax) {
        h = hmax;
    }
    for (k = 0; k < DERIVE_N; ++k) {
        z1[k] = z[k] + dir * h * f0[k];
    }
    if (DERIVE_DRIVER_EVAL(c, DERIVE_WITH_T(t + dir * h) z1, f1) != 0) {
        return h;
    }
    for (k = 0; k < DERIVE_N; ++k) {
        sk = (DERIVE_REAL)c->opt->atol + (DERIVE_REAL)c->opt->rtol * DERIVE_MATH(fabs)(z[k]);
        der2 += ((f1[k] - f0[k]) / sk) * ((f1[k] - f0[k]) / sk);
    }
    der2 = DERIVE_MATH(sqrt)(der2) / h;
    der12 = der2 > DERIVE_MATH(sqrt)(dnf) ? der2 : DERIVE_MATH(sqrt)(dnf);
    if (der12 <= (DERIVE_REAL)1e-15) {
        h1 = h * (DERIVE_REAL)1e-3 > (DERIVE_REAL)1e-6 ? h * (DERIVE_REAL)1e-3 : (DERIVE_REAL)1e-6;
    } else {
        h1 = DERIVE_MATH(pow)((DERIVE_REAL)0.01 / der12, 1 / order);
    }
    h = 100 * h < h1 ? 100 * h : h1;
    return h < hmax ? h : hmax;
}

static int DERIVE_T(derive_finite)(const DERIVE_REAL *z)
{
    DERIVE_REAL check = 0;
    int k;
    for (k = 0; k < DERIVE_N; ++k) {
        check += z[k] - z[k];
    }
    return !isnan(check);
}

/* One fixed step z -> zn of length h (partial: a shortened step to an output time off
 * the grid, by DERIVE_DRIVER_PARTIAL_STEP where there is one): the step budget, the
 * caller's cancellation flag, the chart switch at the step start and the redo of a step
 * that met a chart singularity, the finiteness of the result.  0 or a status. */
static int DERIVE_T(derive_fixed)(DERIVE_DRIVER_CTX *c, DERIVE_WITH_T(DERIVE_REAL t) DERIVE_REAL *z, DERIVE_REAL h, DERIVE_REAL (*K)[DERIVE_N], DERIVE_REAL *zn, int partial)
{
    DERIVE_REAL err = 0, size = 0;
    int st, sw, k;
#ifndef DERIVE_DRIVER_PARTIAL_STEP
    (void)partial;
#endif
    if (c->info->nsteps >= c->opt->max_steps) {
        return DERIVE_MAX_STEPS;
    }
    if (c->opt->cancel && *c->opt->cancel) {
        return DERIVE_CANCELLED;
    }
    sw = DERIVE_DRIVER_SWITCH(c, z, 0);
    if (sw < 0) {
        return -sw;
    }
    c->info->nsteps += 1;
#ifdef DERIVE_DRIVER_PARTIAL_STEP
    st = partial ? DERIVE_DRIVER_PARTIAL_STEP(c, DERIVE_WITH_T(t) z, h, K, zn) : DERIVE_DRIVER_STEP(c, DERIVE_WITH_T(t) z, h, K, zn, &err);
#else
    st = DERIVE_DRIVER_STEP(c, DERIVE_WITH_T(t) z, h, K, zn, &err);
#endif
    if (st == DERIVE_CHART_SINGULAR) {
        /* switch at the step start (if another chart is better) and redo */
        sw = DERIVE_DRIVER_SWITCH(c, z, 1);
        if (sw < 0) {
            return -sw;
        }
        if (sw == 1) {
            st = DERIVE_DRIVER_STEP(c, DERIVE_WITH_T(t) z, h, K, zn, &err);
        }
    }
    if (st) {
        return st;
    }
    if (!DERIVE_T(derive_finite)(zn)) {
        return DERIVE_NONFINITE;
    }
    c->info->naccepted += 1;
    if (err > 0) {
        /* abm12: Milne's estimate, err in units of atol + rtol |z|_max (as the step scaled it) */
        for (k = 0; k < DERIVE_N; ++k) {
            size = DERIVE_MATH(fabs)(z[k]) > size ? DERIVE_MATH(fabs)(z[k]) : size;
        }
        c->info->local_error += (double)(err * ((DERIVE_REAL)c->opt->atol + (DERIVE_REAL)c->opt->rtol * size));
    }
    return DERIVE_OK;
}

/* The stepping loop: from the context's state at t_out[0] through every output time. */
static int DERIVE_T(derive_drive)(DERIVE_DRIVER_CTX *c, const DERIVE_REAL *restrict y0, long nt, const DERIVE_REAL *restrict t_out, DERIVE_REAL *restrict y_out)
{
    DERIVE_REAL z[DERIVE_N], zn[DERIVE_N], tmp[DERIVE_N];
    DERIVE_REAL K[DERIVE_MAX_STAGES][DERIVE_N], F[7][DERIVE_N];
    DERIVE_REAL t = t_out[0], h = 0, err = 0, dir, tend, hmax, hmin, fac, facmin, facmax, order, tnew, theta, size;
    const int method = c->method;
    const int adaptive = (method == DERIVE_METHOD_DOPRI5 || method == DERIVE_METHOD_DOP853);
    const DERIVE_REAL eps = DERIVE_EPS;
    DERIVE_REAL tnext, slack;
    long iout = 1, kgrid = 0;
    int st, k, cause = 0, rejected = 0, dense_ready, fsal, last, sw, side = 0;   /* side: the last output is off the grid */

    st = DERIVE_DRIVER_IN(c, y0, z);
    if (st) {
        goto done;
    }
    st = DERIVE_DRIVER_OUT(c, z, y_out);
    if (st) {
        goto done;
    }
    c->info->nout = 1;
    c->info->h_end = 0;
    if (nt == 1) {
        goto done;
    }
    dir = t_out[nt - 1] > t_out[0] ? 1 : -1;
    if (!adaptive) {
        /* The grid t0 + k h: whole steps of the requested h whatever the outputs (a grid
         * point within roundoff of an output time is that output).  An output time between
         * grid points is reached by a shortened step from the grid point before it into
         * a side state; the grid goes on from the grid point, so the result at any time
         * does not depend on which outputs were asked for.  No step count is formed:
         * kgrid <= nsteps <= max_steps, and _check refuses |t_end - t0| / h > 2^53. */
        h = dir * (DERIVE_REAL)c->opt->h;
        for (iout = 1; iout < nt; ++iout) {
            slack = 16 * eps * (DERIVE_MATH(fabs)(t_out[0]) + DERIVE_MATH(fabs)(t_out[iout]) + DERIVE_MATH(fabs)(h));
            for (;;) {
                tnext = t_out[0] + (DERIVE_REAL)(kgrid + 1) * h;
                if ((tnext - t_out[iout]) * dir > slack) {
                    break;
                }
                st = DERIVE_T(derive_fixed)(c, DERIVE_WITH_T(t) z, h, K, zn, 0);
                if (st) {
                    goto done;
                }
                for (k = 0; k < DERIVE_N; ++k) {
                    z[k] = zn[k];
                }
                kgrid += 1;
                t = tnext;
            }
            if ((t_out[iout] - t) * dir <= slack) {
                st = DERIVE_DRIVER_OUT(c, z, y_out + iout * DERIVE_N);
                c->info->h_end = 0;
                side = 0;
            } else {
                c->info->h_end = (double)(t_out[iout] - t);
                side = 1;
                st = DERIVE_T(derive_fixed)(c, DERIVE_WITH_T(t) z, t_out[iout] - t, K, tmp, 1);
                if (st) {
                    goto done;
                }
                st = DERIVE_DRIVER_OUT(c, tmp, y_out + iout * DERIVE_N);
            }
            if (st) {
                goto done;
            }
            c->info->nout += 1;
        }
        /* the run ends at the last output time (the side state there) */
        if (side) {
            for (k = 0; k < DERIVE_N; ++k) {
                z[k] = tmp[k];
            }
        }
        t = t_out[nt - 1];
        goto done;
    }

    /* adaptive: DOPRI5 or DOP853 */
    if (method == DERIVE_METHOD_DOPRI5) {
        order = 5;
        facmin = (DERIVE_REAL)0.2;
        facmax = 10;
        fsal = 6;
    } else {
        order = 8;
        facmin = (DERIVE_REAL)0.333;
        facmax = 6;
        fsal = 12;
    }
    tend = t_out[nt - 1];
    hmax = c->opt->hmax > 0 ? (DERIVE_REAL)c->opt->hmax : DERIVE_MATH(fabs)(tend - t);
    st = DERIVE_DRIVER_EVAL(c, DERIVE_WITH_T(t) z, K[0]);
    if (st) {
        goto done;
    }
    if (c->opt->h > 0) {
        h = (DERIVE_REAL)c->opt->h < hmax ? (DERIVE_REAL)c->opt->h : hmax;
    } else {
        h = DERIVE_T(derive_hinit)(c, DERIVE_WITH_T(t) z, K[0], dir, hmax, order, zn, K[1]);
    }
    h *= dir;
    while (iout < nt) {
        if (c->info->nsteps >= c->opt->max_steps) {
            st = DERIVE_MAX_STEPS;
            goto done;
        }
        if (c->opt->cancel && *c->opt->cancel) {
            st = DERIVE_CANCELLED;
            goto done;
        }
        last = 0;
        if ((t + h - tend) * dir >= 0) {
            h = tend - t;
            last = 1;
        }
        hmin = 16 * eps * DERIVE_MATH(fabs)(t);
        if (hmin < (DERIVE_REAL)c->opt->hmin) {
            hmin = (DERIVE_REAL)c->opt->hmin;
        }
        if (DERIVE_MATH(fabs)(h) <= hmin || DERIVE_MATH(fabs)(h) <= 0) {     /* |h| <= 0: h is zero */
            st = cause ? cause : DERIVE_STEP_UNDERFLOW;
            goto done;
        }
        c->info->nsteps += 1;
        st = DERIVE_DRIVER_STEP(c, DERIVE_WITH_T(t) z, h, K, zn, &err);
        if (st == 0 && err <= 1 && method == DERIVE_METHOD_DOP853) {
            st = DERIVE_DRIVER_EVAL(c, DERIVE_WITH_T(t + h) zn, K[12]);
        }
        if (st != 0 || !(err <= 1)) {
            c->info->nrejected += 1;
            if (st) {
                cause = st;
                fac = (DERIVE_REAL)0.25;
            } else if (isnan(err)) {
                cause = DERIVE_NONFINITE;
                fac = (DERIVE_REAL)0.25;
            } else {
                cause = 0;
                fac = (DERIVE_REAL)0.9 * DERIVE_MATH(pow)(err, -1 / order);
                if (fac < facmin) {
                    fac = facmin;
                }
                if (fac > 1) {
                    fac = 1;
                }
            }
            st = 0;
            rejected = 1;
            h *= fac;
            continue;
        }
        cause = 0;
        tnew = last ? tend : t + h;
        dense_ready = 0;
        while (iout < nt && (t_out[iout] - tnew) * dir <= 0) {
            if (!(t_out[iout] < tnew || t_out[iout] > tnew)) {     /* the output time is the step's end */
                st = DERIVE_DRIVER_OUT(c, zn, y_out + iout * DERIVE_N);
            } else {
                if (!dense_ready) {
                    st = DERIVE_DRIVER_DENSE_PREPARE(c, DERIVE_WITH_T(t) z, zn, h, K, F);
                    if (st) {
                        goto done;
                    }
                    dense_ready = 1;
                }
                theta = (t_out[iout] - t) / h;
                DERIVE_DRIVER_DENSE(c, z, zn, h, K, F, theta, tmp);
                st = DERIVE_DRIVER_OUT(c, tmp, y_out + iout * DERIVE_N);
            }
            if (st) {
                goto done;
            }
            c->info->nout += 1;
            iout += 1;
        }
        /* the step's local-error estimate in the state's units: err is scaled per component
         * by atol + rtol max(|y|, |y_new|), so the largest of those scales bounds it */
        size = 0;
        for (k = 0; k < DERIVE_N; ++k) {
            size = DERIVE_MATH(fabs)(z[k]) > size ? DERIVE_MATH(fabs)(z[k]) : size;
            size = DERIVE_MATH(fabs)(zn[k]) > size ? DERIVE_MATH(fabs)(zn[k]) : size;
            z[k] = zn[k];
            K[0][k] = K[fsal][k];
        }
        c->info->local_error += (double)(err * ((DERIVE_REAL)c->opt->atol + (DERIVE_REAL)c->opt->rtol * size));
        t = tnew;
        c->info->naccepted += 1;
        sw = DERIVE_DRIVER_SWITCH(c, z, 0);
        if (sw < 0) {
            st = -sw;
            goto done;
        }
        if (sw == 1) {
            st = DERIVE_DRIVER_EVAL(c, DERIVE_WITH_T(t) z, K[0]);
            if (st) {
                goto done;
            }
        }
        fac = err > 0 ? (DERIVE_REAL)0.9 * DERIVE_MATH(pow)(err, -1 / order) : facmax;
        if (fac > (rejected ? 1 : facmax)) {
            fac = rejected ? 1 : facmax;
        }
        if (fac < facmin) {
            fac = facmin;
        }
        rejected = 0;
        h *= fac;
        if (DERIVE_MATH(fabs)(h) > hmax) {
            h = dir * hmax;
        }
    }
done:
    c->info->status = st;
    c->info->t = (double)t;
    c->info->h = (double)h;
    DERIVE_DRIVER_SET_Y(c, z);
    for (iout = c->info->nout; iout < nt; ++iout) {
        for (k = 0; k < DERIVE_N; ++k) {
            y_out[iout * DERIVE_N + k] = DERIVE_MATH(nan)("");
        }
    }
    return st;
}

/* Checks shared by the entry points: 0 or BAD_INPUT. */
static int DERIVE_T(derive_check)(int method, const DERIVE_REAL *y0, long ny, const DERIVE_REAL *p, long np, long nt, const DERIVE_REAL *t, const DERIVE_OPTIONS *opt)
{
    DERIVE_REAL check = 0;
    long i;
    if (method < DERIVE_METHOD_RK4 || method > DERIVE_METHOD_LAST || nt < 1 || !y0 || !t) {
        return DERIVE_BAD_INPUT;
    }
    for (i = 0; i < ny; ++i) {
        check += y0[i] - y0[i];
    }
    for (i = 0; i < np; ++i) {
        check += p[i] - p[i];
    }
    for (i = 0; i < nt; ++i) {
        check += t[i] - t[i];
    }
    if (isnan(check)) {
        return DERIVE_BAD_INPUT;
    }
    for (i = 1; i < nt; ++i) {
        if (!((t[i] - t[i - 1]) * (t[nt - 1] - t[0]) > 0)) {
            return DERIVE_BAD_INPUT;
        }
    }
    if (method == DERIVE_METHOD_DOPRI5 || method == DERIVE_METHOD_DOP853) {
        if (!(opt->rtol > 0) || !(opt->atol >= 0) || !(opt->rtol < 1) || !(opt->hmin >= 0) || !(opt->hmax >= 0) || !(opt->h >= 0)) {
            return DERIVE_BAD_INPUT;
        }
    } else if (nt > 1 && !(opt->h > 0 && opt->h < 1e300)) {
        return DERIVE_BAD_INPUT;
    } else if (nt > 1 && !(DERIVE_MATH(fabs)(t[nt - 1] - t[0]) / (DERIVE_REAL)opt->h <= (DERIVE_REAL)9007199254740992.0)) {
        return DERIVE_BAD_INPUT;     /* more than 2^53 grid steps (see _drive) */
    }
    if (opt->max_steps < 1 || !(opt->sine_min >= 0 && opt->sine_min < 1)) {
        return DERIVE_BAD_INPUT;
    }
    return DERIVE_OK;
}

#undef DERIVE_DRIVER_CTX
#undef DERIVE_DRIVER_EVAL
#undef DERIVE_DRIVER_STEP
#undef DERIVE_DRIVER_PARTIAL_STEP
#undef DERIVE_DRIVER_DENSE_PREPARE
#undef DERIVE_DRIVER_DENSE
#undef DERIVE_DRIVER_IN
#undef DERIVE_DRIVER_OUT
#undef DERIVE_DRIVER_SWITCH
#undef DERIVE_DRIVER_SET_Y
