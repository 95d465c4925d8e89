/*
 * One program shaded from 8 threads at once (tests/c_host.rs builds and
 * runs it): each thread shades every point with a bound instance of
 * rough_conductor and a texture tree, point by point and as one batch
 * each, and every result must be the bits of the single-threaded run.
 * Prints "threads: N results agree" and exits 0, or names the first
 * difference and exits 1.
 */
#include "tsl.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define THREADS 8
#define POINTS 256
#define LANES_MAX 64

static const char *SOURCE =
    "float rings(float scale = 8) { return fract(length(vec2(Pl.x, Pl.z)) * scale); }\n"
    "material wood = mix(rings(), lambert(kd: rgb(0.6, 0.4, 0.2)), rough_conductor(alpha: 0.3));\n";

static TslMaterial *materials[2];
static size_t lanes;
static float eta[LANES_MAX];
static float pl[POINTS][3], u1[POINTS], u2[POINTS];

/* What one run computes: per material, a sample per point by point calls,
   and the batch's samples. */
typedef struct {
    float wi[2][POINTS][3], weight[2][POINTS][LANES_MAX], pdf[2][POINTS];
    float batch_wi[2][POINTS][3], batch_weight[2][POINTS * LANES_MAX], batch_pdf[2][POINTS];
    bool batch_delta[2][POINTS];
    int failed;
} Results;

static void fail(Results *r, TslStatus status, TslError *error, const char *what) {
    if (status == TSL_OK) return;
    TslStr m = tsl_error_message(error);
    fprintf(stderr, "%s: %.*s\n", what, (int)m.len, m.ptr);
    tsl_error_free(error);
    r->failed = 1;
}

static void *shade(void *arg) {
    Results *r = arg;
    TslError *error = NULL;
    TslGlobals g = tsl_globals_default();
    float wo[3] = {0.0f, 0.6f, 0.8f};
    for (int m = 0; m < 2; m++) {
        for (int i = 0; i < POINTS; i++) {
            TslSample s;
            memcpy(g.pl, pl[i], sizeof g.pl);
            fail(r, tsl_material_sample(materials[m], &g, wo, eta, lanes, 0.5f, u1[i], u2[i], &s, r->weight[m][i], &error),
                 error, "sample");
            memcpy(r->wi[m][i], s.wi, sizeof s.wi);
            r->pdf[m][i] = s.pdf;
        }
        TslBatch *batch = NULL;
        fail(r, tsl_batch_new(POINTS, NULL, &batch, &error), error, "batch");
        TslColumn pl_c[3] = {{&pl[0][0], 3, 0}, {&pl[0][1], 3, 0}, {&pl[0][2], 3, 0}};
        fail(r, tsl_batch_set(batch, "Pl", 2, pl_c, 3, &error), error, "batch set");
        TslColumn wo_c[3] = {{NULL, 0, wo[0]}, {NULL, 0, wo[1]}, {NULL, 0, wo[2]}}, eta_c[LANES_MAX];
        for (size_t k = 0; k < lanes; k++) eta_c[k] = (TslColumn){NULL, 0, eta[k]};
        TslColumn uc = {NULL, 0, 0.5f}, u1c = {u1, 1, 0}, u2c = {u2, 1, 0};
        fail(r, tsl_material_batch_sample(materials[m], batch, wo_c, eta_c, lanes, uc, u1c, u2c, POINTS,
                                          &r->batch_wi[m][0][0], r->batch_weight[m], r->batch_pdf[m],
                                          r->batch_delta[m], &error),
             error, "batch sample");
        tsl_batch_free(batch);
    }
    return NULL;
}

int main(void) {
    TslError *error = NULL;
    TslCompiler *compiler = tsl_compiler_new();
    TslProgram *program = NULL;
    TslShader *shader = NULL;
    TslInstance *gold = NULL;
    Results *reference = calloc(1, sizeof *reference);
    Results *runs = calloc(THREADS, sizeof *runs);
    fail(reference, tsl_compiler_source(compiler, "wood.tsl", 8, SOURCE, strlen(SOURCE), &error), error, "source");
    fail(reference, tsl_compiler_compile(compiler, &program, &error), error, "compile");
    fail(reference, tsl_program_material(program, "wood", 4, &materials[0], &error), error, "wood");
    fail(reference, tsl_program_shader(program, "rough_conductor", 15, &shader, &error), error, "shader");
    fail(reference, tsl_shader_instance(shader, &gold, &error), error, "instance");
    fail(reference, tsl_instance_set_float(gold, "alpha", 5, 0.25f, &error), error, "alpha");
    fail(reference, tsl_instance_bind(gold, &materials[1], &error), error, "bind");
    lanes = tsl_program_lanes(program);
    fail(reference, tsl_program_rgb(program, 1.0f, 1.0f, 1.0f, eta, lanes, &error), error, "eta");
    if (reference->failed) return 1;
    for (int i = 0; i < POINTS; i++) {
        pl[i][0] = 0.013f * (float)i;
        pl[i][1] = 0.0f;
        pl[i][2] = 0.007f * (float)(i % 17);
        u1[i] = (float)((i * 37) % POINTS) / POINTS;
        u2[i] = (float)((i * 91) % POINTS) / POINTS;
    }

    shade(reference);
    pthread_t threads[THREADS];
    for (int t = 0; t < THREADS; t++) pthread_create(&threads[t], NULL, shade, &runs[t]);
    for (int t = 0; t < THREADS; t++) pthread_join(threads[t], NULL);

    int status = reference->failed;
    for (int t = 0; t < THREADS && !status; t++) {
        if (runs[t].failed || memcmp(&runs[t], reference, sizeof *reference) != 0) {
            fprintf(stderr, "thread %d's results differ from the single-threaded ones\n", t);
            status = 1;
        }
    }
    /* The batch gives the bits of the calls point by point too. */
    for (int m = 0; m < 2 && !status; m++) {
        for (int i = 0; i < POINTS; i++) {
            if (memcmp(reference->wi[m][i], reference->batch_wi[m][i], sizeof reference->wi[m][i]) != 0 ||
                memcmp(reference->weight[m][i], &reference->batch_weight[m][i * lanes], lanes * sizeof(float)) != 0 ||
                memcmp(&reference->pdf[m][i], &reference->batch_pdf[m][i], sizeof(float)) != 0) {
                fprintf(stderr, "material %d point %d: the batch differs from the point call\n", m, i);
                status = 1;
                break;
            }
        }
    }
    if (!status) printf("threads: %d threads x %d results agree\n", THREADS, 2 * 2 * POINTS);
    free(runs);
    free(reference);
    tsl_material_free(materials[0]);
    tsl_material_free(materials[1]);
    tsl_instance_free(gold);
    tsl_shader_free(shader);
    tsl_program_free(program);
    tsl_compiler_free(compiler);
    return status;
}
