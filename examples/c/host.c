/*
 * A C host of TSL: compiles a texture tree from a string, lists a
 * shader's parameters, binds rough_conductor's `alpha` at run time and
 * changes it, and shades one point and a batch of points. Floats are
 * printed as their bits (%08x) so tests/c_host.rs can compare them with
 * the Rust API's exactly.
 *
 *   cc -std=c99 -Iinclude examples/c/host.c -Ltarget/debug -ltsl -o host
 *   LD_LIBRARY_PATH=target/debug ./host
 */
#include "tsl.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define POINTS 8

static const char *WOOD =
    "float rings(float scale = 8) { return fract(length(vec2(Pl.x, Pl.z)) * scale); }\n"
    "material wood = mix(rings(), lambert(kd: rgb(0.6, 0.4, 0.2)), lambert(kd: rgb(0.35, 0.2, 0.08)));\n";

static unsigned bits(float x) {
    unsigned u;
    memcpy(&u, &x, sizeof u);
    return u;
}

static void print_floats(const char *label, const float *xs, size_t n) {
    printf("%s", label);
    for (size_t i = 0; i < n; i++) printf(" %08x", bits(xs[i]));
    printf("\n");
}

/* Prints the error's fields and exits: a host would report and recover. */
static void check(TslStatus status, TslError *error, const char *what) {
    if (status == TSL_OK) return;
    TslStr message = tsl_error_message(error);
    fprintf(stderr, "%s failed (status %d):\n%.*s", what, (int)status, (int)message.len, message.ptr);
    tsl_error_free(error);
    exit(1);
}

#define CHECK(call) check((call), error, #call)

static TslMaterial *bind_gold(TslInstance *gold, float alpha) {
    TslError *error = NULL;
    TslMaterial *material = NULL;
    CHECK(tsl_instance_set_float(gold, "alpha", 5, alpha, &error));
    CHECK(tsl_instance_bind(gold, &material, &error));
    return material;
}

int main(void) {
    TslError *error = NULL;

    /* Compile errors: the rustc-style text and each diagnostic's fields. */
    TslCompiler *compiler = tsl_compiler_new();
    const char *bad = "material m = lamberd;";
    CHECK(tsl_compiler_source(compiler, "bad.tsl", 7, bad, strlen(bad), &error));
    TslProgram *program = NULL;
    TslStatus status = tsl_compiler_compile(compiler, &program, &error);
    printf("bad status %d\n", (int)status);
    for (size_t i = 0; i < tsl_error_diagnostic_count(error); i++) {
        TslDiagnostic d;
        tsl_error_diagnostic(error, i, &d);
        printf("diagnostic %.*s:%u:%u: %.*s\n", (int)d.file.len, d.file.ptr, d.line, d.column, (int)d.message.len,
               d.message.ptr);
    }
    tsl_error_free(error);
    error = NULL;

    /* The texture tree, compiled from a string. */
    CHECK(tsl_compiler_color_model(compiler, "rgb", 3, &error));
    CHECK(tsl_compiler_source(compiler, "wood.tsl", 8, WOOD, strlen(WOOD), &error));
    CHECK(tsl_compiler_compile(compiler, &program, &error));
    tsl_compiler_free(compiler);
    size_t lanes = tsl_program_lanes(program);
    printf("lanes %zu\n", lanes);

    /* What rough_conductor takes, as oslquery lists it. */
    TslShader *metal = NULL;
    CHECK(tsl_program_shader(program, "rough_conductor", 15, &metal, &error));
    for (size_t i = 0; i < tsl_shader_param_count(metal); i++) {
        TslParam p;
        CHECK(tsl_shader_param(metal, i, &p, &error));
        printf("param %.*s type %d default %.*s doc %.*s", (int)p.name.len, p.name.ptr, (int)p.ty,
               (int)p.default_source.len, p.default_source.ptr, (int)p.doc.len, p.doc.ptr);
        for (size_t k = 0; k < p.option_count; k++) {
            TslStr option = tsl_shader_param_option(metal, i, k);
            printf(" option %.*s", (int)option.len, option.ptr);
        }
        if (p.default_value.kind == TSL_VALUE_FLOAT) printf(" value %08x", bits(p.default_value.floats[0]));
        printf("\n");
    }

    /* An instance bound at run time; a wrong name is an error. */
    TslInstance *gold = NULL;
    CHECK(tsl_shader_instance(metal, &gold, &error));
    CHECK(tsl_instance_set_string(gold, "distribution", 12, "ggx", 3, &error));
    status = tsl_instance_set_float(gold, "alpah", 5, 0.2f, &error);
    TslStr message = tsl_error_message(error);
    printf("set alpah: status %d, %s\n", (int)status, strstr(message.ptr, "did you mean `alpha`?") ? "did you mean alpha" : "?");
    tsl_error_free(error);
    error = NULL;
    TslMaterial *gold_rough = bind_gold(gold, 0.2f);
    TslMaterial *gold_smooth = bind_gold(gold, 0.05f); /* compiles nothing new */
    TslMaterial *wood = NULL;
    CHECK(tsl_program_material(program, "wood", 4, &wood, &error));

    /* One point. */
    TslGlobals g = tsl_globals_default();
    g.pl[0] = 0.1f;
    float wo[3] = {0.0f, 0.6f, 0.8f}, wi[3] = {0.0f, -0.6f, 0.8f};
    float eta[64], light[64], out[64];
    CHECK(tsl_program_rgb(program, 1.0f, 1.0f, 1.0f, eta, lanes, &error));
    CHECK(tsl_program_rgb(program, 1.0f, 1.0f, 1.0f, light, lanes, &error));
    CHECK(tsl_material_reflection(wood, &g, wo, eta, wi, light, lanes, out, &error));
    print_floats("wood reflection", out, lanes);
    TslMaterial *golds[2] = {gold_rough, gold_smooth};
    for (int k = 0; k < 2; k++) {
        TslSample s;
        float pdf;
        CHECK(tsl_material_sample(golds[k], &g, wo, eta, lanes, 0.5f, 0.3f, 0.7f, &s, out, &error));
        printf("gold%d sample", k);
        print_floats(" wi", s.wi, 3);
        print_floats("  weight", out, lanes);
        print_floats("  pdf", &s.pdf, 1);
        CHECK(tsl_material_eval_pdf(golds[k], &g, wo, eta, lanes, wi, out, &pdf, &error));
        printf("gold%d eval_pdf", k);
        print_floats(" value", out, lanes);
        print_floats("  pdf", &pdf, 1);
    }
    /* The fraction of light from wo the rough gold reflects. */
    CHECK(tsl_material_albedo(gold_rough, &g, wo, eta, lanes, out, &error));
    print_floats("gold0 albedo", out, lanes);

    /* A batch: Pl point by point (an array of xyz triples, read by stride),
       wo and eta the same at every point, u1 and u2 as plain arrays. */
    float pl[POINTS][3], u1[POINTS], u2[POINTS];
    for (int i = 0; i < POINTS; i++) {
        pl[i][0] = 0.05f * (float)i;
        pl[i][1] = 0.0f;
        pl[i][2] = 0.02f * (float)i;
        u1[i] = (float)i / POINTS;
        u2[i] = 1.0f - (float)i / POINTS;
    }
    TslBatch *batch = NULL;
    CHECK(tsl_batch_new(POINTS, &g, &batch, &error));
    TslColumn pl_columns[3] = {{&pl[0][0], 3, 0}, {&pl[0][1], 3, 0}, {&pl[0][2], 3, 0}};
    CHECK(tsl_batch_set(batch, "Pl", 2, pl_columns, 3, &error));
    TslColumn wo_columns[3], wi_columns[3], eta_columns[64], light_columns[64];
    for (int k = 0; k < 3; k++) {
        wo_columns[k] = (TslColumn){NULL, 0, wo[k]};
        wi_columns[k] = (TslColumn){NULL, 0, wi[k]};
    }
    for (size_t k = 0; k < lanes; k++) {
        eta_columns[k] = (TslColumn){NULL, 0, eta[k]};
        light_columns[k] = (TslColumn){NULL, 0, light[k]};
    }
    float *values = malloc(sizeof(float) * POINTS * lanes);
    CHECK(tsl_material_batch_reflection(wood, batch, wo_columns, eta_columns, wi_columns, light_columns, lanes,
                                        POINTS, values, &error));
    for (int i = 0; i < POINTS; i++) {
        printf("batch wood reflection %d", i);
        print_floats("", values + i * lanes, lanes);
    }
    float wis[POINTS][3], pdfs[POINTS];
    bool deltas[POINTS];
    TslColumn uc = {NULL, 0, 0.5f}, u1c = {u1, 1, 0}, u2c = {u2, 1, 0};
    CHECK(tsl_material_batch_sample(gold_rough, batch, wo_columns, eta_columns, lanes, uc, u1c, u2c, POINTS,
                                    &wis[0][0], values, pdfs, deltas, &error));
    for (int i = 0; i < POINTS; i++) {
        printf("batch gold0 sample %d", i);
        print_floats(" wi", wis[i], 3);
        print_floats("  weight", values + i * lanes, lanes);
        print_floats("  pdf", &pdfs[i], 1);
    }
    CHECK(tsl_material_batch_albedo(wood, batch, wo_columns, eta_columns, lanes, POINTS, values, &error));
    for (int i = 0; i < POINTS; i++) {
        printf("batch wood albedo %d", i);
        print_floats("", values + i * lanes, lanes);
    }
    free(values);

    tsl_batch_free(batch);
    tsl_material_free(wood);
    tsl_material_free(gold_smooth);
    tsl_material_free(gold_rough);
    tsl_instance_free(gold);
    tsl_shader_free(metal);
    tsl_program_free(program);
    printf("done\n");
    return 0;
}
