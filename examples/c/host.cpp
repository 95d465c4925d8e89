// A C++ host of TSL: the C header used unchanged, each handle owned by a
// std::unique_ptr with its free function, each failed call thrown as an
// exception carrying the rustc-style text. It compiles the texture tree,
// binds rough_conductor's alpha at run time, changes it, and shades one
// point and a batch; floats printed as bits, as host.c prints them.
//
//   c++ -std=c++17 -Iinclude examples/c/host.cpp -Ltarget/debug -ltsl -o host_cpp
#include "tsl.h"

#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsl {

// The RAII wrapper: an owning pointer per handle type, and `check`.
template <typename T, void (*Free)(T *)>
struct Deleter {
    void operator()(T *p) const { Free(p); }
};
using Program = std::unique_ptr<TslProgram, Deleter<TslProgram, tsl_program_free>>;
using Compiler = std::unique_ptr<TslCompiler, Deleter<TslCompiler, tsl_compiler_free>>;
using Shader = std::unique_ptr<TslShader, Deleter<TslShader, tsl_shader_free>>;
using Instance = std::unique_ptr<TslInstance, Deleter<TslInstance, tsl_instance_free>>;
using Material = std::unique_ptr<TslMaterial, Deleter<TslMaterial, tsl_material_free>>;
using Batch = std::unique_ptr<TslBatch, Deleter<TslBatch, tsl_batch_free>>;
using Error = std::unique_ptr<TslError, Deleter<TslError, tsl_error_free>>;

struct Failure : std::runtime_error {
    Error error;
    explicit Failure(TslError *e) : std::runtime_error(tsl_error_message(e).ptr), error(e) {}
};

// `tsl::Try t; t = tsl_call(..., &t.error);` throws a Failure owning the
// error when the call fails (the call runs before the assignment).
struct Try {
    TslError *error = nullptr;
    void operator=(TslStatus status) {
        if (status != TSL_OK) throw Failure(error);
    }
};

}  // namespace tsl

static const std::string WOOD =
    "float rings(float scale = 8) { return fract(length(vec2(Pl.x, Pl.z)) * scale); }\n"
    "material wood = mix(rings(), lambert(kd: rgb(0.6, 0.4, 0.2)), lambert(kd: rgb(0.35, 0.2, 0.08)));\n";

static void print_floats(const char *label, const float *xs, size_t n) {
    std::printf("%s", label);
    for (size_t i = 0; i < n; i++) {
        unsigned u;
        std::memcpy(&u, &xs[i], sizeof u);
        std::printf(" %08x", u);
    }
    std::printf("\n");
}

static tsl::Material bind(TslInstance *instance, float alpha) {
    tsl::Try t;
    TslMaterial *material = nullptr;
    t = tsl_instance_set_float(instance, "alpha", 5, alpha, &t.error);
    t = tsl_instance_bind(instance, &material, &t.error);
    return tsl::Material(material);
}

int main() {
    tsl::Compiler compiler(tsl_compiler_new());
    tsl::Try t;
    TslProgram *raw = nullptr;
    try {
        t = tsl_compiler_source(compiler.get(), "bad.tsl", 7, "material m = lamberd;", 21, &t.error);
        t = tsl_compiler_compile(compiler.get(), &raw, &t.error);
    } catch (const tsl::Failure &f) {
        std::printf("bad status %d\n", int(tsl_error_status(f.error.get())));
        TslDiagnostic d;
        for (size_t i = 0; tsl_error_diagnostic(f.error.get(), i, &d); i++)
            std::printf("diagnostic %.*s:%u:%u: %.*s\n", int(d.file.len), d.file.ptr, d.line, d.column,
                        int(d.message.len), d.message.ptr);
    }
    try {
        t = tsl_compiler_source(compiler.get(), "wood.tsl", 8, WOOD.data(), WOOD.size(), &t.error);
        t = tsl_compiler_compile(compiler.get(), &raw, &t.error);
        tsl::Program program(raw);
        size_t lanes = tsl_program_lanes(program.get());
        std::printf("lanes %zu\n", lanes);
        TslShader *shader = nullptr;
        t = tsl_program_shader(program.get(), "rough_conductor", 15, &shader, &t.error);
        tsl::Shader metal(shader);
        TslInstance *instance = nullptr;
        t = tsl_shader_instance(metal.get(), &instance, &t.error);
        tsl::Instance gold(instance);
        t = tsl_instance_set_string(gold.get(), "distribution", 12, "ggx", 3, &t.error);
        tsl::Material golds[2] = {bind(gold.get(), 0.2f), bind(gold.get(), 0.05f)};
        TslMaterial *material = nullptr;
        t = tsl_program_material(program.get(), "wood", 4, &material, &t.error);
        tsl::Material wood(material);

        TslGlobals g = tsl_globals_default();
        g.pl[0] = 0.1f;
        float wo[3] = {0.0f, 0.6f, 0.8f}, wi[3] = {0.0f, -0.6f, 0.8f};
        std::vector<float> eta(lanes), out(lanes);
        t = tsl_program_rgb(program.get(), 1.0f, 1.0f, 1.0f, eta.data(), lanes, &t.error);
        const std::vector<float> light = eta;
        t = tsl_material_reflection(wood.get(), &g, wo, eta.data(), wi, light.data(), lanes, out.data(), &t.error);
        print_floats("wood reflection", out.data(), lanes);
        for (int k = 0; k < 2; k++) {
            TslSample s;
            float pdf;
            t = tsl_material_sample(golds[k].get(), &g, wo, eta.data(), lanes, 0.5f, 0.3f, 0.7f, &s, out.data(),
                                    &t.error);
            std::printf("gold%d sample", k);
            print_floats(" wi", s.wi, 3);
            print_floats("  weight", out.data(), lanes);
            print_floats("  pdf", &s.pdf, 1);
            t = tsl_material_eval_pdf(golds[k].get(), &g, wo, eta.data(), lanes, wi, out.data(), &pdf, &t.error);
            std::printf("gold%d eval_pdf", k);
            print_floats(" value", out.data(), lanes);
            print_floats("  pdf", &pdf, 1);
        }

        const size_t points = 8;
        std::vector<float> pl(points * 3);
        for (size_t i = 0; i < points; i++) {
            pl[3 * i] = 0.05f * float(i);
            pl[3 * i + 2] = 0.02f * float(i);
        }
        TslBatch *raw_batch = nullptr;
        t = tsl_batch_new(points, &g, &raw_batch, &t.error);
        tsl::Batch batch(raw_batch);
        const TslColumn pl_columns[3] = {{&pl[0], 3, 0}, {&pl[1], 3, 0}, {&pl[2], 3, 0}};
        t = tsl_batch_set(batch.get(), "Pl", 2, pl_columns, 3, &t.error);
        std::vector<TslColumn> wo_c, wi_c, eta_c;
        for (int k = 0; k < 3; k++) {
            wo_c.push_back({nullptr, 0, wo[k]});
            wi_c.push_back({nullptr, 0, wi[k]});
        }
        for (float e : eta) eta_c.push_back({nullptr, 0, e});
        std::vector<float> values(points * lanes);
        t = tsl_material_batch_reflection(wood.get(), batch.get(), wo_c.data(), eta_c.data(), wi_c.data(),
                                          eta_c.data(), lanes, points, values.data(), &t.error);
        for (size_t i = 0; i < points; i++) {
            std::printf("batch wood reflection %zu", i);
            print_floats("", &values[i * lanes], lanes);
        }
    } catch (const tsl::Failure &f) {
        std::fprintf(stderr, "%s", f.what());
        return 1;
    }
    std::printf("done\n");
    return 0;
}
