/* Times the generated planar_rhs against the hand-written peer in a C loop.
 * Usage: harness <evaluations> <repeats>.  Prints one line per function:
 * "<name> <best ns per evaluation>".  Calls alternate between the two so both
 * see the same machine state; the best of the repeats is reported.
 */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "planar.h"
#include "planar_hand.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double run_hand(long n, double *sink)
{
    double y[4] = {0.7, -1.1, 0.3, -0.2}, p[5] = {1.0, 1.3, 0.9, 1.1, 9.81}, out[4];
    double acc = 0.0, t0 = now();
    long i;
    for (i = 0; i < n; ++i) {
        y[0] = 0.7 + 1e-7 * (double)i;
        hand_planar_rhs(y, p, out);
        acc += out[2] + out[3];
    }
    *sink += acc;
    return (now() - t0) / (double)n * 1e9;
}

static double run_generated(long n, double *sink)
{
    double y[4] = {0.7, -1.1, 0.3, -0.2}, p[5] = {1.0, 1.3, 0.9, 1.1, 9.81}, out[4];
    double acc = 0.0, t0 = now();
    long i;
    int status = 0;
    for (i = 0; i < n; ++i) {
        y[0] = 0.7 + 1e-7 * (double)i;
        status |= planar_rhs(y, p, out);
        acc += out[2] + out[3];
    }
    *sink += acc + status;
    return (now() - t0) / (double)n * 1e9;
}

static double run_batch(long n, double *sink)
{
    /* the batch entry point over a block of states that stays in cache, called
     * n / BLOCK times: the per-state cost without per-call overhead */
    enum { BLOCK = 1024 };
    static double y[4 * BLOCK], out[4 * BLOCK];
    double p[5] = {1.0, 1.3, 0.9, 1.1, 9.81};
    double acc = 0.0, t0;
    long i, calls = n / BLOCK > 0 ? n / BLOCK : 1;
    int status = 0;
    for (i = 0; i < BLOCK; ++i) {
        y[4 * i] = 0.7 + 1e-4 * (double)i;
        y[4 * i + 1] = -1.1;
        y[4 * i + 2] = 0.3;
        y[4 * i + 3] = -0.2;
    }
    t0 = now();
    for (i = 0; i < calls; ++i) {
        y[0] = 0.7 + 1e-9 * (double)i;
        status |= planar_rhs_batch(BLOCK, y, 4, p, 0, out, NULL);
        acc += out[2];
    }
    t0 = (now() - t0) / (double)(calls * BLOCK) * 1e9;
    *sink += acc + status;
    return t0;
}

int main(int argc, char **argv)
{
    long n = argc > 1 ? atol(argv[1]) : 2000000;
    int repeats = argc > 2 ? atoi(argv[2]) : 7, r;
    double best_hand = 1e30, best_gen = 1e30, best_batch = 1e30, sink = 0.0, t;
    for (r = 0; r < repeats; ++r) {
        t = run_hand(n, &sink);
        if (t < best_hand) best_hand = t;
        t = run_generated(n, &sink);
        if (t < best_gen) best_gen = t;
        t = run_batch(n, &sink);
        if (t < best_batch) best_batch = t;
    }
    printf("hand %.3f\ngenerated %.3f\nbatch %.3f\nsink %g\n", best_hand, best_gen, best_batch, sink);
    return 0;
}
