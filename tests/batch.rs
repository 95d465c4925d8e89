//! Batch calls (`Function::call_batch`, `TypedFunction::call_batch`,
//! `Material::at_batch`) give, at every point, the bits the same call
//! gives point by point: generators and every stdlib material, both back
//! ends, RGB and spectral, prepared (split) and whole materials, bound
//! instances; columns of every kind (structure of arrays, a field of an
//! array of vectors, one value for all); both result layouts; from many
//! threads at once. Bad batches are errors before anything runs.

mod common;

use common::{Rng, args, shading_point};
use tsl::{
    Backend, ColorModel, Column, Compiler, HitCalls, Layout, Material, MaterialSource, Program, ShadingBatch,
    ShadingGlobals, SurfaceOptions, SurfaceRecord,
};

const POINTS: usize = 37;

/// Per-point globals of a batch, as columns of every kind: `P` from an
/// array of vectors, `N` and `Ng` word by word (structure of arrays), `u`
/// and `v` floats, `face` ints, `time` one value for all.
struct Globals {
    p: Vec<[f32; 3]>,
    n: [Vec<f32>; 3],
    uv: [Vec<f32>; 2],
    pl: Vec<f32>,
    dpdu: Vec<[f32; 3]>,
    dpdx: Vec<[f32; 3]>,
    face: Vec<i32>,
}

impl Globals {
    fn new(rng: &mut Rng) -> Globals {
        let points: Vec<ShadingGlobals> = (0..POINTS).map(|_| shading_point(rng)).collect();
        Globals {
            p: points.iter().map(|g| g.p).collect(),
            n: [0, 1, 2].map(|k| points.iter().map(|g| g.n[k]).collect()),
            uv: [points.iter().map(|g| g.u).collect(), points.iter().map(|g| g.v).collect()],
            // Pl as one row-major matrix (n × 3), read with a stride.
            pl: points.iter().flat_map(|g| g.pl).collect(),
            dpdu: points.iter().map(|g| g.dpdu).collect(),
            dpdx: points.iter().map(|g| g.dpdx).collect(),
            face: points.iter().map(|g| g.face).collect(),
        }
    }

    fn batch(&self) -> ShadingBatch<'_> {
        let mut b = ShadingBatch::with_base(POINTS, ShadingGlobals { time: 1.5, dudx: 0.003, ..Default::default() });
        let normal = [0, 1, 2].map(|k| Column::floats(&self.n[k]));
        b.set_vectors("P", &self.p).unwrap();
        b.set("N", &normal).unwrap();
        b.set("Ng", &normal).unwrap();
        b.set_floats("u", &self.uv[0]).unwrap().set_floats("v", &self.uv[1]).unwrap();
        b.set("Pl", &[0, 1, 2].map(|k| Column::strided(&self.pl, k, 3))).unwrap();
        b.set_vectors("dPdu", &self.dpdu).unwrap().set_vectors("dPdx", &self.dpdx).unwrap();
        b.set("face", &[Column::ints(&self.face)]).unwrap();
        b
    }
}

/// Generators of every kind of result and argument, reading globals of
/// every kind, with loops, noise and branches.
const GENERATORS: &str = r#"
float grain(float scale) { return noise(Pl * scale) + 0.1 * u; }
vector bent(vector d, float k) { return normalize(N + d * k * v); }
color tint(color c, int n) {
    color acc = c;
    for i in 0..n { acc = acc * 0.5 + gray(fbm(P * float(i), 3)); }
    return acc * float(face + 2);
}
bool upward(float bias) { return N.y + bias > 0; }
int stripes(int count) { return int(floor(u * float(count))) + face; }
vec2 flow(vec2 at) { return vec2(at.x + time, at.y * length(dPdx) + dudx); }
"#;

fn program(src: &str, model: ColorModel) -> Program {
    Compiler::new().color_model(model).source("b.tsl", src).compile().unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn generator_batches_give_the_bits_of_calls_point_by_point() {
    let mut rng = Rng(0xba7c4);
    let globals = Globals::new(&mut rng);
    let batch = globals.batch();
    for model in [ColorModel::Rgb, ColorModel::Spectral { samples: 8 }] {
        let program = program(GENERATORS, model);
        for name in ["grain", "bent", "tint", "upward", "stripes", "flow"] {
            let f = program.function(name).unwrap();
            // Arguments: the first point by point (an array of structs, read
            // with a stride), the rest one value for all.
            let per_point: Vec<Vec<u32>> = (0..POINTS).map(|_| args(&mut rng, f.params(), model)).collect();
            let width = f.arg_words();
            let flat: Vec<u32> = per_point.iter().flatten().copied().collect();
            let floats: Vec<f32> = flat.iter().map(|w| f32::from_bits(*w)).collect();
            let first_param = per_point[0].len().min(3).min(width);
            let columns: Vec<Column> = (0..width)
                .map(|k| {
                    if k < first_param {
                        Column::strided(&floats, k, width)
                    } else {
                        Column::uniform_word(per_point[0][k])
                    }
                })
                .collect();
            let results = f.result_types().len();
            for backend in [Backend::Jit, Backend::Interpreter] {
                for layout in [Layout::PointMajor, Layout::WordMajor] {
                    let mut out = vec![0xdead_beef_u32; POINTS * results];
                    f.call_batch(backend, &batch, &columns, &mut out, layout).unwrap();
                    for i in 0..POINTS {
                        let mut a: Vec<u32> = per_point[i].clone();
                        a[first_param..].copy_from_slice(&per_point[0][first_param..]);
                        let mut want = vec![0u32; results];
                        f.call_words(backend, &batch.point(i), &a, &mut want).unwrap();
                        for (k, w) in want.iter().enumerate() {
                            let at = match layout {
                                Layout::PointMajor => i * results + k,
                                Layout::WordMajor => k * POINTS + i,
                            };
                            assert_eq!(out[at], *w, "{model:?} {name} {backend:?} {layout:?} point {i} word {k}");
                        }
                    }
                }
            }
        }
    }
    // The batch's points are the globals given, column by column.
    let g = batch.point(5);
    assert_eq!(
        (g.p, g.pl[1], g.u, g.face, g.time),
        (globals.p[5], globals.pl[16], globals.uv[0][5], globals.face[5], 1.5)
    );
}

/// Noise in one, two and three dimensions: the four-lane entries look its
/// gradient tables up by byte shuffles (`jit::simd`), 2D's diagonals with
/// all four bytes set, and its permutation by loads. At 4096 points every
/// gradient of every table is reached.
/// 1D, 2D and 3D noise of the JIT's batch entry at points `p`, in
/// `layout`, give the bits of `reference`'s point-by-point call.
fn noise_batches_agree(p: &[[f32; 3]], layout: Layout, reference: Backend) {
    let src = "float n1() { return noise(P.x); }
               float n2() { return noise(vec2(P.x, P.y)); }
               float n3() { return noise(P); }";
    batches_agree(src, &["n1", "n2", "n3"], p, layout, reference);
}

/// The functions `names` of `src` (no arguments, one word of result) give
/// in the JIT's batch entry at points `p`, in `layout`, the bits of
/// `reference`'s point-by-point call.
fn batches_agree(src: &str, names: &[&str], p: &[[f32; 3]], layout: Layout, reference: Backend) {
    let program = program(src, ColorModel::Rgb);
    let mut batch = ShadingBatch::new(p.len());
    batch.set_vectors("P", p).unwrap();
    for name in names {
        let f = program.function(name).unwrap();
        let mut out = vec![0u32; p.len()];
        f.call_batch(Backend::Jit, &batch, &[], &mut out, layout).unwrap();
        for (i, got) in out.iter().enumerate() {
            let mut want = [0u32];
            f.call_words(reference, &batch.point(i), &[], &mut want).unwrap();
            assert_eq!(*got, want[0], "{name} at {:?}", p[i]);
        }
    }
}

/// Loops of constant trips: at the top, where every lane runs them alike
/// (the four-lane entry runs them without masks), until the call's budget
/// of iterations is spent (4 x 65,536, the same in every lane, and the
/// loops after it run no trip); after loops of per-point trips that spent
/// the lanes' budgets unevenly (the constant loops then stop lane by lane);
/// under a branch, around one, and left by `break`.
#[test]
fn loops_of_constant_trips_give_the_bits_point_by_point() {
    let src = "
        float octaves() {
            float s = 0;
            float a = 0.5;
            vector q = P;
            for o in 0..6 {
                s += a * noise(q) + float(o) * 0.01;
                q = q * 2.03;
                a *= 0.5;
            }
            return s;
        }
        float spent() {
            float s = P.x;
            for i in 0..65536 { s = s * 0.999 + 0.5; }
            for i in 0..65536 { s = s * 0.999 + 0.25; }
            for i in 0..65536 { s = s * 0.999 + 0.125; }
            for i in 0..65536 { s = s * 0.999 + 1.0; }
            for i in 0..3 { s += 7; }
            int n = int(abs(P.y) * 3.0);
            for j in 0..n { s += 2; }
            return s;
        }
        float uneven() {
            float s = 0;
            int n = int(abs(P.x) * 200.0) % 60000;
            for i in 0..4 { for j in 0..n { s += 1; } }
            for k in 0..65536 { s += 0.5; }
            for k in 0..65536 { s += 0.25; }
            return s;
        }
        float branchy() {
            float s = 0;
            if P.x > 0 { for i in 0..5 { s += float(i); } }
            for i in 0..7 { if P.y > float(i * 40) { s += 1; } else { s -= 0.5; } }
            for i in 0..9 { if float(i * 60) > P.z + 300 { break; } s += 0.25; }
            return s;
        }";
    let mut rng = Rng(0x100b5);
    let p: Vec<[f32; 3]> = (0..4 * 9 + 3).map(|_| [0, 1, 2].map(|_| rng.range(-300.0, 300.0))).collect();
    batches_agree(src, &["octaves", "spent", "uneven", "branchy"], &p, Layout::PointMajor, Backend::Jit);
}

/// Float to int conversions at the edges of their range: saturated at
/// 2^31 and beyond, NaN to 0, the largest floats below 2^31 and at -2^31
/// exact (the four-lane entry converts in a sequence of its own on x86-64).
#[test]
fn float_to_int_batches_give_the_bits_point_by_point() {
    let edges = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        2147483648.0,
        2147483520.0,
        -2147483648.0,
        -2147483904.0,
        1e20,
        -1e20,
        0.5,
        -0.5,
        -0.0,
        3.7,
        -3.7,
    ];
    let p: Vec<[f32; 3]> = (0..edges.len() + 3).map(|i| [0, 1, 2].map(|k| edges[(i + 5 * k) % edges.len()])).collect();
    let src = "int ix() { return int(P.x); }
               int iy() { return int(P.y * 2.0); }
               int iz() { return int(floor(P.z)); }";
    batches_agree(src, &["ix", "iy", "iz"], &p, Layout::PointMajor, Backend::Interpreter);
}

#[test]
fn noise_batches_give_the_bits_of_noise_point_by_point() {
    let mut rng = Rng(0x9015e);
    let p: Vec<[f32; 3]> = (0..4096).map(|_| [0, 1, 2].map(|_| rng.range(-300.0, 300.0))).collect();
    noise_batches_agree(&p, Layout::PointMajor, Backend::Interpreter);
}

/// Noise at lattice cells on the edges of its tables: the permutation's
/// first and last entries (cells 0 and 255, and -1 and 256, which wrap to
/// them), the ends of its first 16-entry chunk (15, 16), each lane of a
/// group at a different edge, in a batch whose last group is not whole.
#[test]
fn noise_batches_at_the_edges_of_the_tables_give_the_bits_point_by_point() {
    let cells = [0.0f32, 15.0, 16.0, 255.0, -1.0, 256.0, 1.0, 254.0, -256.0, 511.0];
    let mut rng = Rng(0xed9e);
    let p: Vec<[f32; 3]> = (0..4 * 61 + 3)
        .map(|_| [0, 1, 2].map(|_| cells[rng.next() as usize % cells.len()] + rng.range(0.0, 1.0)))
        .collect();
    noise_batches_agree(&p, Layout::WordMajor, Backend::Jit);
}

#[test]
fn typed_batches_give_the_values_of_typed_calls() {
    let program = program(GENERATORS, ColorModel::Rgb);
    let globals = Globals::new(&mut Rng(7));
    let batch = globals.batch();
    let bent = program.typed_function::<([f32; 3], f32), [f32; 3]>("bent").unwrap();
    let args: Vec<([f32; 3], f32)> = (0..POINTS).map(|i| ([0.1 * i as f32, 1.0, -0.5], 0.3 + i as f32)).collect();
    let got = bent.call_batch(&batch, &args).unwrap();
    let uniform = bent.call_batch_uniform(&batch, args[3]).unwrap();
    for i in 0..POINTS {
        assert_eq!(got[i], bent.call(&batch.point(i), args[i]), "point {i}");
        assert_eq!(uniform[i], bent.call(&batch.point(i), args[3]), "point {i}");
    }
    let tint = program.typed_function::<(tsl::Color, i32), tsl::Color>("tint").unwrap();
    let c = program.rgb(0.2, 0.4, 0.8);
    let colors = tint.call_batch_uniform(&batch, (c, 3)).unwrap();
    assert_eq!(colors[9], tint.call(&batch.point(9), (c, 3)));
    let err = bent.call_batch(&batch, &args[..3]).unwrap_err().to_string();
    assert!(err.contains("3 argument tuples for a batch of 37 points"), "{err}");
}

/// Every call of a surface batch against a surface at each point.
fn assert_surface_batch_matches(m: &Material, globals: &Globals, rng: &mut Rng, what: &str) {
    let model = m.color_model();
    let lanes = model.lanes();
    let batch = globals.batch();
    let wo: Vec<[f32; 3]> = (0..POINTS).map(|_| rng.unit()).collect();
    let wi: Vec<[f32; 3]> = (0..POINTS).map(|_| rng.unit()).collect();
    let eta: Vec<f32> = (0..POINTS * lanes).map(|_| rng.range(1.0, 1.8)).collect();
    let light: Vec<f32> = (0..POINTS * lanes).map(|_| rng.range(0.0, 2.0)).collect();
    let (uc, u0, u1, dist): (Vec<f32>, Vec<f32>, Vec<f32>, Vec<f32>) = (
        (0..POINTS).map(|_| rng.range(0.0, 1.0)).collect(),
        (0..POINTS).map(|_| rng.range(0.0, 1.0)).collect(),
        (0..POINTS).map(|_| rng.range(0.0, 1.0)).collect(),
        (0..POINTS).map(|_| rng.range(0.0, 3.0)).collect(),
    );
    let (eta_columns, light_columns) = (Column::colors(&eta, lanes), Column::colors(&light, lanes));
    let mut s = m.at_batch(&batch, Column::vectors(&wo), &eta_columns).unwrap();
    let sample = s.sample(Column::floats(&uc), [Column::floats(&u0), Column::floats(&u1)]).unwrap();
    let eval = s.eval_pdf(Column::vectors(&wi)).unwrap();
    let lobes = s.delta_lobes().unwrap();
    let reflection = s.reflection(Column::vectors(&wi), &light_columns).unwrap();
    let refraction = s.refraction(Column::vectors(&wi), &light_columns).unwrap();
    let (ior, emission, diffuse) = (s.refraction_index().unwrap(), s.emission().unwrap(), s.diffuse().unwrap());
    let ambient = s.ambient(&light_columns).unwrap();
    let absorption = s.absorption(&light_columns, Column::floats(&dist)).unwrap();
    let (rdir, tdir, normal) = (s.reflection_dir().unwrap(), s.refraction_dir().unwrap(), s.normal().unwrap());
    let (opaque, pdf) = (s.opaque().unwrap(), s.pdf(Column::vectors(&wi)).unwrap());
    let albedo = s.albedo().unwrap();

    let mut record = SurfaceRecord::new();
    let color = |i: usize, xs: &[f32]| tsl::Color::from_lanes(model, &xs[i * lanes..(i + 1) * lanes]);
    for i in 0..POINTS {
        let g = batch.point(i);
        let (eta_i, light_i) = (color(i, &eta), color(i, &light));
        let at = format!("{what}: point {i}");
        let mut one = m.at(&g, wo[i], &eta_i, &mut record);
        let want = one.sample(uc[i], [u0[i], u1[i]]);
        assert_eq!(
            (sample.wi[i], sample.weight.get(i), sample.pdf[i], sample.delta[i]),
            (want.wi, want.weight.lanes(), want.pdf, want.delta),
            "{at}: sample"
        );
        let want = one.eval_pdf(wi[i]);
        assert_eq!((eval.value.get(i), eval.pdf[i]), (want.value.lanes(), want.pdf), "{at}: eval_pdf");
        let want = one.delta_lobes();
        let lobe =
            |l: Option<tsl::DeltaLobe>| l.map_or(([0.0; 3], vec![0.0; lanes]), |l| (l.dir, l.weight.lanes().to_vec()));
        assert_eq!(
            (lobes.reflect_dir[i], lobes.reflect_weight.get(i).to_vec()),
            lobe(want.reflect),
            "{at}: reflect lobe"
        );
        assert_eq!(
            (lobes.refract_dir[i], lobes.refract_weight.get(i).to_vec()),
            lobe(want.refract),
            "{at}: refract lobe"
        );
        assert_eq!(reflection.get(i), one.reflection(wi[i], &light_i).lanes(), "{at}: reflection");
        assert_eq!(refraction.get(i), one.refraction(wi[i], &light_i).lanes(), "{at}: refraction");
        assert_eq!(ior.get(i), one.refraction_index().lanes(), "{at}: refraction_index");
        assert_eq!(emission.get(i), one.emission().lanes(), "{at}: emission");
        assert_eq!(diffuse.get(i), one.diffuse().lanes(), "{at}: diffuse");
        assert_eq!(albedo.get(i), one.albedo().lanes(), "{at}: albedo");
        assert_eq!(ambient.get(i), one.ambient(&light_i).lanes(), "{at}: ambient");
        assert_eq!(absorption.get(i), one.absorption(&light_i, dist[i]).lanes(), "{at}: absorption");
        assert_eq!((rdir[i], tdir[i], normal[i]), (one.reflection_dir(), one.refraction_dir(), one.normal()), "{at}");
        assert_eq!((opaque[i], pdf[i]), (one.opaque(), one.pdf(wi[i])), "{at}: opaque, pdf");
    }
}

/// A textured template, its material parameter and a stdlib model.
const TEXTURED: &str = r#"
material grainy(float scale = 4, material base = phong) = mix(noise(Pl * scale) * 0.5 + 0.5, base, glass);
material host = grainy(scale: 6, base: rough_conductor(alpha: 0.2));
"#;

#[test]
fn surface_batches_give_the_bits_of_surfaces_for_every_stdlib_material() {
    let mut rng = Rng(0x5afe);
    let globals = Globals::new(&mut rng);
    for model in [ColorModel::Rgb, ColorModel::Spectral { samples: 8 }] {
        let program = program(TEXTURED, model);
        let mut checked = 0;
        for shader in program.shaders() {
            let mut instance = shader.instance();
            let required: Vec<_> = shader.params().iter().filter(|p| p.required()).collect();
            for p in required {
                let value = match p.ty {
                    tsl::ParamType::Material => program.shader("lambert").unwrap().instance().into(),
                    tsl::ParamType::Float => tsl::ParamValue::Float(0.5),
                    tsl::ParamType::Color => tsl::ParamValue::Triple([0.8, 0.5, 0.2]),
                    _ => continue,
                };
                instance.set(&p.name, value).unwrap();
            }
            let what = format!("{model:?} {}", instance.source());
            let bound = instance.bind().unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_surface_batch_matches(&bound, &globals, &mut rng, &format!("{what} bound"));
            checked += 1;
        }
        assert!(checked >= 20, "{checked} shaders");
        // The renderer's split materials (a per-hit stage and its group).
        let sources = [MaterialSource::Named("host".into()), MaterialSource::Named("glass".into())];
        for hit_calls in [HitCalls::Path, HitCalls::Whitted] {
            let options = SurfaceOptions { hit_calls: Some(hit_calls), ..Default::default() };
            let materials = program.compile_surfaces(&sources, &options).unwrap();
            assert!(materials[0].is_prepared(), "the textured material is split");
            for m in &materials {
                assert_surface_batch_matches(m, &globals, &mut rng, &format!("{model:?} {hit_calls:?}"));
            }
        }
        let whole = program.material("host").unwrap();
        assert!(!whole.is_prepared());
        assert_surface_batch_matches(&whole, &globals, &mut rng, &format!("{model:?} host"));
    }
}

#[test]
fn batches_run_from_many_threads_at_once() {
    let program = program(GENERATORS, ColorModel::Rgb);
    let globals = Globals::new(&mut Rng(3));
    let f = program.function("grain").unwrap();
    let batch = globals.batch();
    let reference: Vec<Vec<u32>> = (0..POINTS)
        .map(|i| {
            let mut out = vec![0u32; 1];
            f.call_words(Backend::Jit, &batch.point(i), &[(1.5f32 + i as f32).to_bits()], &mut out).unwrap();
            out
        })
        .collect();
    // Every thread's first call races to compile the batch form.
    std::thread::scope(|scope| {
        for _ in 0..4 {
            scope.spawn(|| {
                let scales: Vec<f32> = (0..POINTS).map(|i| 1.5 + i as f32).collect();
                for _ in 0..20 {
                    let mut out = vec![0u32; POINTS];
                    f.call_batch(Backend::Jit, &batch, &[Column::floats(&scales)], &mut out, Layout::PointMajor)
                        .unwrap();
                    assert_eq!(out, reference.concat());
                }
            });
        }
    });
}

#[test]
fn bad_batches_are_errors_before_anything_runs() {
    let program = program(GENERATORS, ColorModel::Rgb);
    let f = program.function("bent").unwrap();
    let p = [[0.0f32; 3]; 4];
    let mut batch = ShadingBatch::new(4);
    let err = |e: tsl::Error| e.to_string();
    assert!(err(batch.set_vectors("Pll", &p).unwrap_err()).contains("no global `Pll`; did you mean `Pl`?"));
    assert!(err(batch.set("P", &[Column::uniform(1.0)]).unwrap_err()).contains("`P` is a point: 3 columns, not 1"));
    let short = [[0.0f32; 3]; 3];
    let e = err(batch.set_vectors("P", &short).unwrap_err());
    assert!(e.contains("column 0 of `P` has values for 3 points, and the batch has 4"), "{e}");
    batch.set_vectors("P", &p).unwrap();

    let mut out = [0xffff_ffffu32; 12];
    let full = [Column::uniform(0.0), Column::uniform(1.0), Column::uniform(0.0), Column::uniform(2.0)];
    let e = err(f.call_batch(Backend::Jit, &batch, &full[..3], &mut out, Layout::PointMajor).unwrap_err());
    assert!(e.contains("`bent` takes 4 argument columns, not 3"), "{e}");
    let xs = [1.0f32; 3];
    let mut with_short = full;
    with_short[3] = Column::floats(&xs);
    let e = err(f.call_batch(Backend::Jit, &batch, &with_short, &mut out, Layout::PointMajor).unwrap_err());
    assert!(e.contains("argument column 3 of `bent` has values for 3 points"), "{e}");
    let e = err(f.call_batch(Backend::Jit, &batch, &full, &mut out[..11], Layout::WordMajor).unwrap_err());
    assert!(e.contains("`bent` writes 3 words for each of 4 points: `out` holds 11"), "{e}");
    assert!(out.iter().all(|w| *w == 0xffff_ffff), "nothing ran");
    // A stride-0 column past the end of its slice has no points.
    assert_eq!(Column::strided(&xs, 3, 0).len(), Some(0));
    assert_eq!(Column::strided(&xs, 1, 2).len(), Some(1));

    let m = Compiler::new().source("m.tsl", "material m = lambert;").compile().unwrap().material("m").unwrap();
    let two = Column::uniforms(&[1.0, 1.0]);
    let e = err(m.at_batch(&batch, Column::vectors(&p), &two).err().unwrap());
    assert!(e.contains("`eta` needs 3 columns (the color model's lanes), not 2"), "{e}");
    // An empty batch runs nothing and is no error.
    let empty = ShadingBatch::new(0);
    f.call_batch(Backend::Jit, &empty, &full, &mut [], Layout::PointMajor).unwrap();
}
