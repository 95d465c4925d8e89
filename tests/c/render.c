/*
 * Renders a scene file into a caller-owned buffer (tests/c_host.rs builds
 * and runs it with the scene's path): prints the image size, each float's
 * bits, whether progress reached every pixel, then renders again with a
 * progress callback that cancels and prints the status.
 */
#include "tsl.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    pthread_mutex_t lock;
    uint64_t done, total, calls;
    uint64_t cancel_after; /* calls; 0 never cancels */
} Progress;

/* Called from several render threads at once. */
static bool progress(void *user_data, uint64_t done, uint64_t total) {
    Progress *p = user_data;
    pthread_mutex_lock(&p->lock);
    if (done > p->done) p->done = done;
    p->total = total;
    p->calls++;
    bool go_on = p->cancel_after == 0 || p->calls < p->cancel_after;
    pthread_mutex_unlock(&p->lock);
    return go_on;
}

static void check(TslStatus status, TslError *error, const char *what) {
    if (status == TSL_OK) return;
    TslStr m = tsl_error_message(error);
    fprintf(stderr, "%s failed: %.*s", what, (int)m.len, m.ptr);
    exit(1);
}

int main(int argc, char **argv) {
    if (argc != 2) return 2;
    TslError *error = NULL;
    TslCompiler *compiler = tsl_compiler_new();
    TslProgram *program = NULL;
    TslScene *scene = NULL;
    check(tsl_compiler_file(compiler, argv[1], strlen(argv[1]), &error), error, "file");
    check(tsl_compiler_compile(compiler, &program, &error), error, "compile");
    TslRenderSettings settings = {24, 18, 4, 0, 7, true, TSL_INTEGRATOR_PATH};
    check(tsl_scene_new(program, &settings, &scene, &error), error, "scene");
    uint32_t width, height;
    check(tsl_scene_size(scene, &width, &height, &error), error, "size");
    printf("size %ux%u\n", width, height);
    size_t len = (size_t)width * height * 3;
    float *image = malloc(len * sizeof(float));

    /* A buffer of the wrong size is refused. */
    TslStatus status = tsl_scene_render(scene, 0, image, len - 1, NULL, NULL, &error);
    printf("short buffer: status %d\n", (int)status);
    tsl_error_free(error);
    error = NULL;

    Progress p = {PTHREAD_MUTEX_INITIALIZER, 0, 0, 0, 0};
    check(tsl_scene_render(scene, 2, image, len, progress, &p, &error), error, "render");
    printf("progress %s\n", p.done == p.total && p.total == (uint64_t)width * height ? "complete" : "incomplete");
    for (size_t i = 0; i < len; i++) {
        unsigned u;
        memcpy(&u, &image[i], sizeof u);
        printf("%08x%c", u, i % 8 == 7 ? '\n' : ' ');
    }
    if (len % 8 != 0) printf("\n");

    Progress cancel = {PTHREAD_MUTEX_INITIALIZER, 0, 0, 0, 1};
    status = tsl_scene_render(scene, 2, image, len, progress, &cancel, &error);
    TslStr message = tsl_error_message(error);
    printf("cancelled: status %d, %.*s", (int)status, (int)message.len, message.ptr);
    tsl_error_free(error);

    free(image);
    tsl_scene_free(scene);
    tsl_program_free(program);
    tsl_compiler_free(compiler);
    return 0;
}
