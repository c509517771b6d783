/* A haptic-style loop through the C interface: load a parameters file, find the orientation of
 * the first reading by spmcal_forward, track 10,000 steps of a smooth joint trajectory with
 * spmcal_track, and check spmcal_ik against the readings (to 1e-10 rad). malloc, calloc and
 * realloc are wrapped (-Wl,--wrap=...) and counted: the tracking loop must not allocate. Prints
 * every tracked reading and quaternion as the bit patterns of their doubles, for the Rust test to
 * compare bit for bit and to check against its own IK.
 *
 * Usage: track PARAMETERS_FILE
 */
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "spmcal.h"

static long allocations = 0;
void *__real_malloc(size_t size);
void *__real_calloc(size_t n, size_t size);
void *__real_realloc(void *p, size_t size);
void *__wrap_malloc(size_t size) { allocations++; return __real_malloc(size); }
void *__wrap_calloc(size_t n, size_t size) { allocations++; return __real_calloc(n, size); }
void *__wrap_realloc(void *p, size_t size) { allocations++; return __real_realloc(p, size); }

#define STEPS 10000

static void reading(int k, double joints[3]) {
    double t = (double)k / 1000.0; /* 1 kHz */
    joints[0] = 0.30 * sin(0.9 * t);
    joints[1] = 0.25 * sin(1.3 * t + 1.0) - 0.21;
    joints[2] = 0.20 * sin(0.7 * t + 2.0) - 0.18;
}

static uint64_t bits(double x) { uint64_t b; memcpy(&b, &x, sizeof b); return b; }

int main(int argc, char **argv) {
    if (argc != 2) { fprintf(stderr, "usage: %s PARAMETERS_FILE\n", argv[0]); return 2; }
    SpmcalModel *model = NULL;
    if (spmcal_model_load(argv[1], &model) != SPMCAL_STATUS_OK) {
        fprintf(stderr, "load: %s\n", spmcal_last_error());
        return 1;
    }
    /* Errors are codes plus a message, never a crash. */
    if (spmcal_model_load("/nonexistent/params.yaml", &(SpmcalModel *){NULL}) != SPMCAL_STATUS_FILE
        || strstr(spmcal_last_error(), "/nonexistent/params.yaml") == NULL) {
        fprintf(stderr, "a missing file must be SPMCAL_STATUS_FILE naming it: %s\n", spmcal_last_error());
        return 1;
    }
    double bad[4] = {2.0, 0.0, 0.0, 0.0}, out[4], joints[3];
    if (spmcal_ik(model, bad, joints) != SPMCAL_STATUS_BAD_QUATERNION || spmcal_forward(model, NULL, out) != SPMCAL_STATUS_NULL_ARGUMENT) {
        fprintf(stderr, "bad arguments must be refused\n");
        return 1;
    }
    double q[4], back[3];
    reading(0, joints);
    if (spmcal_forward(model, joints, q) != SPMCAL_STATUS_OK) { fprintf(stderr, "forward: %s\n", spmcal_last_error()); return 1; }
    static double trace[STEPS][4], read[STEPS][3];
    long before = allocations;
    double worst_ik = 0.0;
    for (int k = 1; k <= STEPS; k++) {
        reading(k, joints);
        if (spmcal_track(model, joints, q, q) != SPMCAL_STATUS_OK) {
            fprintf(stderr, "track at step %d: %s\n", k, spmcal_last_error());
            return 1;
        }
        memcpy(trace[k - 1], q, sizeof q);
        memcpy(read[k - 1], joints, sizeof joints);
        if (spmcal_ik(model, q, back) != SPMCAL_STATUS_OK) { fprintf(stderr, "ik: %s\n", spmcal_last_error()); return 1; }
        for (int i = 0; i < 3; i++) worst_ik = fmax(worst_ik, fabs(back[i] - joints[i]));
    }
    long during = allocations - before;
    if (before == 0) { fprintf(stderr, "the wrapped malloc counted nothing while loading: the check would be void\n"); return 5; }
    fprintf(stderr, "allocations while loading the model: %ld\n", before);
    /* First line: the reading and orientation the loop started from; then one line per step. */
    reading(0, joints);
    double first[4];
    spmcal_forward(model, joints, first);
    printf("%016" PRIx64 " %016" PRIx64 " %016" PRIx64, bits(joints[0]), bits(joints[1]), bits(joints[2]));
    printf(" %016" PRIx64 " %016" PRIx64 " %016" PRIx64 " %016" PRIx64 "\n", bits(first[0]), bits(first[1]), bits(first[2]), bits(first[3]));
    for (int k = 0; k < STEPS; k++) {
        printf("%016" PRIx64 " %016" PRIx64 " %016" PRIx64, bits(read[k][0]), bits(read[k][1]), bits(read[k][2]));
        printf(" %016" PRIx64 " %016" PRIx64 " %016" PRIx64 " %016" PRIx64 "\n", bits(trace[k][0]), bits(trace[k][1]), bits(trace[k][2]), bits(trace[k][3]));
    }
    fprintf(stderr, "allocations during %d tracking steps: %ld; worst IK round trip %.3e rad\n", STEPS, during, worst_ik);
    spmcal_model_free(model);
    if (during != 0) return 3;
    if (worst_ik > 1e-10) return 4;
    return 0;
}
