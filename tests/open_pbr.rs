//! open_pbr_surface's thin film, geometry opacity and coat anisotropy
//! (stdlib/openpbr.tsl): Airy's reflectance against its closed form, the
//! film-less limits and energy (its sampling is in tests/sampling.rs);
//! opacity as a mix with a hole, at the surface and in renders; the
//! anisotropic coat against rough_dielectric.

mod common;

use common::Rng;
use tsl::render::{self, Overrides, RenderOptions};
use tsl::{Color, ColorModel, Compiler, Material, Program, ShadingGlobals};

fn compile(src: &str) -> Program {
    Compiler::new().source("open_pbr.tsl", src).compile().unwrap_or_else(|e| panic!("{e}"))
}

/// A flat surface point with normal +z and tangents along x and y.
fn surface() -> ShadingGlobals {
    ShadingGlobals {
        p: [0.1, 0.2, 0.0],
        pl: [0.1, 0.2, 0.0],
        n: [0.0, 0.0, 1.0],
        ng: [0.0, 0.0, 1.0],
        dpdu: [1.0, 0.0, 0.0],
        dpdv: [0.0, 1.0, 0.0],
        t: 1.0,
        ..ShadingGlobals::default()
    }
}

fn direction(theta: f32, phi: f32) -> [f32; 3] {
    let (t, p) = (theta.to_radians(), phi.to_radians());
    [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
}

/// The stdlib's film reflectance and the film-less Fresnel term, as the
/// reflection of probe materials (gray, so every lane holds the value).
const PROBES: &str = "
    material airy(float cos_i = 1, float film = 1.4, float thickness = 0, float lambda = 550, float base = 1.5) {
        color reflection(vector wi, color light, vector wo) {
            return gray(thin_film_reflectance(cos_i, film, thickness, lambda, vec2(base, 0)));
        }
    }
    material fresnel(float cos_i = 1, float base = 1.5) {
        color reflection(vector wi, color light, vector wo) {
            return gray(fresnel_dielectric(cos_i, base));
        }
    }
";

/// The reflection of each probe instance in `srcs` (all compiled at once).
fn probes(srcs: &[String]) -> Vec<f32> {
    let mut src = PROBES.to_string();
    for (i, s) in srcs.iter().enumerate() {
        src += &format!("material probe{i} = {s};\n");
    }
    let q = compile(&src);
    let one = q.rgb(1.0, 1.0, 1.0);
    (0..srcs.len())
        .map(|i| {
            let m = q.material(&format!("probe{i}")).unwrap();
            m.reflection(&surface(), [0.0, 0.0, 1.0], &one, [0.0, 0.0, 1.0]).lanes()[0]
        })
        .collect()
}

/// Airy's sum at normal incidence for a film of index `film` and
/// `thickness` micrometres over a dielectric of index `base`, from air:
/// |(r12 + r23 e^(i phi)) / (1 + r12 r23 e^(i phi))|^2, phi the round trip's
/// phase 4 pi film d / lambda.
fn airy_at_normal(film: f64, thickness: f64, lambda: f64, base: f64) -> f64 {
    let r12 = (1.0 - film) / (1.0 + film);
    let r23 = (film - base) / (film + base);
    let phi = 4.0 * std::f64::consts::PI * film * thickness * 1000.0 / lambda;
    let (c, s) = (phi.cos(), phi.sin());
    let (nr, ni) = (r12 + r23 * c, r23 * s);
    let (dr, di) = (1.0 + r12 * r23 * c, r12 * r23 * s);
    (nr * nr + ni * ni) / (dr * dr + di * di)
}

#[test]
fn the_film_reflects_as_airys_closed_form_at_normal_incidence() {
    let mut cases = Vec::new();
    for (film, base) in [(1.4, 1.5), (1.8, 1.5), (1.33, 1.0)] {
        for thickness in [0.0, 0.1, 0.25, 0.31, 0.5, 1.0] {
            for lambda in [450.0, 550.0, 650.0] {
                cases.push((film, thickness, lambda, base));
            }
        }
    }
    let srcs: Vec<String> = cases
        .iter()
        .map(|(film, thickness, lambda, base)| {
            format!("airy(film: {film}, thickness: {thickness}, lambda: {lambda}, base: {base})")
        })
        .collect();
    for (&(film, thickness, lambda, base), got) in cases.iter().zip(probes(&srcs)) {
        let want = airy_at_normal(film, thickness, lambda, base);
        assert!(
            (f64::from(got) - want).abs() < 1e-4,
            "film {film} of {thickness} um over {base} at {lambda} nm: {got}, Airy {want}"
        );
    }
}

#[test]
fn a_film_of_thickness_zero_reflects_as_the_bare_interface_at_every_angle() {
    let mut cases = Vec::new();
    let mut srcs = Vec::new();
    for cos_i in [1.0, 0.8, 0.5, 0.2, 0.05] {
        for base in [1.2, 1.5, 2.4] {
            cases.push((cos_i, base));
            srcs.push(format!("airy(cos_i: {cos_i}, film: 1.7, thickness: 0, base: {base})"));
            srcs.push(format!("fresnel(cos_i: {cos_i}, base: {base})"));
        }
    }
    let got = probes(&srcs);
    for ((cos_i, base), pair) in cases.iter().zip(got.chunks(2)) {
        let (film, bare) = (pair[0], pair[1]);
        assert!((film - bare).abs() < 1e-5, "cos {cos_i}, index {base}: film {film}, bare {bare}");
    }
}

/// The largest difference of `f cos` between two materials over a spread
/// of directions (reflection only).
fn largest_difference(p: &Program, a: &str, b: &str) -> f32 {
    let (ma, mb) = (p.material(a).unwrap(), p.material(b).unwrap());
    let one = p.rgb(1.0, 1.0, 1.0);
    let mut worst = 0.0f32;
    for to in [0.0, 30.0, 60.0, 80.0] {
        for ti in [5.0, 30.0, 50.0, 70.0, 85.0] {
            for pi in [0.0, 100.0, 215.0] {
                let (wi, wo) = (direction(ti, pi), direction(to, 20.0));
                let fa = ma.reflection(&surface(), wi, &one, wo);
                let fb = mb.reflection(&surface(), wi, &one, wo);
                for (x, y) in fa.lanes().iter().zip(fb.lanes()) {
                    worst = worst.max((x - y).abs());
                }
            }
        }
    }
    worst
}

#[test]
fn a_film_of_weight_or_thickness_zero_is_the_film_less_material() {
    let base = "base_color: rgb(0.7, 0.4, 0.2), base_metalness: 0.5, specular_roughness: 0.3, \
                coat_weight: 0.5, specular_color: rgb(0.9, 0.8, 1)";
    let p = compile(&format!(
        "material bare = open_pbr_surface({base});
         material no_weight = open_pbr_surface({base}, thin_film_weight: 0, thin_film_thickness: 0.3);
         material no_thickness = open_pbr_surface({base}, thin_film_weight: 1, thin_film_thickness: 0);
         material filmed = open_pbr_surface({base}, thin_film_weight: 1, thin_film_thickness: 0.3);"
    ));
    assert_eq!(largest_difference(&p, "bare", "no_weight"), 0.0);
    assert_eq!(largest_difference(&p, "bare", "no_thickness"), 0.0);
    let film = largest_difference(&p, "bare", "filmed");
    assert!(film > 0.01, "a film of 0.3 um changes the reflection by only {film}");
}

/// `∫ f cos dωi` toward `wo` per lane, the largest lane (importance
/// sampling with the material's own pdf; transmitted light counted as
/// energy, times e²).
fn largest_lane_albedo(m: &Material, wo: [f32; 3], eta: &Color, n: usize) -> f64 {
    let mut rng = Rng(7);
    let e = f64::from(eta.brightness());
    let mut sums = vec![0.0f64; eta.lanes().len()];
    for _ in 0..n {
        let s = m.sample(&surface(), wo, eta, rng.range(0.0, 1.0), [rng.range(0.0, 1.0), rng.range(0.0, 1.0)]);
        let scale = if s.wi[2] > 0.0 { 1.0 } else { e * e };
        for (sum, w) in sums.iter_mut().zip(s.weight.lanes()) {
            *sum += f64::from(*w) * scale;
        }
    }
    sums.into_iter().fold(0.0, f64::max) / n as f64
}

#[test]
fn a_filmed_open_pbr_surface_never_reflects_more_than_it_receives() {
    let mut src = String::new();
    let mut names = Vec::new();
    for (kind, what) in [
        ("base_metalness: 0", "dielectric"),
        ("base_metalness: 1", "metal"),
        ("transmission_weight: 1", "glass"),
        ("coat_weight: 1, coat_roughness: 0.2", "coated"),
    ] {
        for roughness in [0.0, 0.5] {
            for thickness in [0.15, 0.6] {
                let name = format!("m{}", names.len());
                src += &format!(
                    "material {name} = open_pbr_surface(base_color: gray(1), {kind}, specular_roughness: {roughness}, \
                         specular_ior: 1.6, thin_film_weight: 1, thin_film_thickness: {thickness}, thin_film_ior: 1.9);\n"
                );
                names.push((name, format!("{what} roughness {roughness} film {thickness} um")));
            }
        }
    }
    let p = compile(&src);
    let eta = p.rgb(1.6, 1.6, 1.6);
    for (name, what) in &names {
        let m = p.material(name).unwrap();
        for theta in [0.0, 45.0, 80.0] {
            let r = largest_lane_albedo(&m, direction(theta, 30.0), &eta, 8_000);
            assert!(r <= 1.01, "{what} at {theta} degrees reflects {r}");
        }
    }
}

#[test]
fn geometry_opacity_scales_the_surface_and_is_the_slab_itself_at_one() {
    let base = "base_color: rgb(0.7, 0.3, 0.2), coat_weight: 0.6, fuzz_weight: 0.3, thin_film_weight: 0.5";
    let p = compile(&format!(
        "material slab = open_pbr_slab({base});
         material full = open_pbr_surface({base});
         material half = open_pbr_surface({base}, geometry_opacity: 0.5);"
    ));
    assert_eq!(largest_difference(&p, "slab", "full"), 0.0);
    let (full, half) = (p.material("full").unwrap(), p.material("half").unwrap());
    let one = p.rgb(1.0, 1.0, 1.0);
    for (ti, to) in [(10.0, 20.0), (40.0, 60.0), (75.0, 5.0)] {
        let (wi, wo) = (direction(ti, 180.0), direction(to, 10.0));
        let f = full.reflection(&surface(), wi, &one, wo);
        let h = half.reflection(&surface(), wi, &one, wo);
        for (a, b) in f.lanes().iter().zip(h.lanes()) {
            assert!((0.5 * a - b).abs() <= 1e-6 * a.abs().max(1.0), "opacity 0.5 reflects {b}, full {a}");
        }
        assert!(f.brightness() > 0.01, "nothing to halve at {ti}/{to}");
    }
}

/// The mean of a 12 x 12, 48 spp render of a unit sphere of `material`
/// filling the view, against `background`.
fn sphere_on(material: &str, background: &str, depth: u32) -> [f64; 3] {
    let src = format!(
        "scene {{
            background {background};
            camera {{ from (0, 0, 4); to (0, 0, 0); fov 18; }}
            render {{ width 12; height 12; spp 48; integrator \"path\"; }}
            object sphere {{ center (0, 0, 0); radius 1; material {material}; }}
        }}"
    );
    let program = Compiler::new().color_model(ColorModel::Rgb).source("open_pbr.tsl", &src).compile().unwrap();
    let scene = render::Scene::build(&program, &Overrides { max_depth: Some(depth), ..Default::default() }).unwrap();
    let image = render::render(&scene, &RenderOptions::default()).unwrap().0;
    let mut sum = [0.0f64; 3];
    for p in &image.color {
        for (s, c) in sum.iter_mut().zip(p) {
            *s += f64::from(*c);
        }
    }
    sum.map(|s| s / image.color.len() as f64)
}

#[test]
fn geometry_opacity_zero_lets_every_ray_through() {
    for material in [
        "open_pbr_surface(base_color: rgb(0.9, 0.1, 0.1), geometry_opacity: 0)",
        "open_pbr_surface(transmission_weight: 1, geometry_opacity: 0)",
    ] {
        let seen = sphere_on(material, "rgb(0.2, 0.5, 0.9)", 8);
        for (s, want) in seen.iter().zip([0.2, 0.5, 0.9]) {
            assert!((s - want).abs() < 1e-4, "{material}: {seen:?}, not the background");
        }
    }
    // Half present over a translucent base: rays through a hole still enter
    // the base's medium (documented), about 1% over one in a white furnace.
    let half = sphere_on("open_pbr_surface(transmission_weight: 1, geometry_opacity: 0.5)", "gray(1)", 8);
    assert!(half.iter().all(|c| (0.95..=1.02).contains(c)), "a half-present glass sphere: {half:?}");
}

/// `∫ f cos dωi` toward `wo`, per lane, on a cosine-warped midpoint grid
/// (deterministic; `n` x `n` directions).
fn albedo_on_grid(m: &Material, one: &Color, wo: [f32; 3], n: usize) -> Vec<f64> {
    let mut sums = vec![0.0f64; one.lanes().len()];
    for i in 0..n {
        for j in 0..n {
            let (u, v) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            let (r, phi) = (u.sqrt(), 2.0 * std::f64::consts::PI * v);
            let wi = [(r * phi.cos()) as f32, (r * phi.sin()) as f32, (1.0 - u).sqrt() as f32];
            let f = m.reflection(&surface(), wi, one, wo);
            // pdf = cos / pi
            for (sum, x) in sums.iter_mut().zip(f.lanes()) {
                *sum += f64::from(*x) * std::f64::consts::PI / f64::from(wi[2]);
            }
        }
    }
    sums.into_iter().map(|s| s / (n * n) as f64).collect()
}

#[test]
fn a_rough_white_diffuse_base_keeps_its_energy_and_scatters_back() {
    let p = compile(
        "material smooth = open_pbr_surface(base_color: gray(1), specular_weight: 0);
         material rough = open_pbr_surface(base_color: gray(1), specular_weight: 0, base_diffuse_roughness: 1);
         material half = open_pbr_surface(base_color: gray(1), specular_weight: 0, base_diffuse_roughness: 0.5);
         material red = open_pbr_surface(base_color: rgb(0.8, 0.3, 0.1), specular_weight: 0, base_diffuse_roughness: 1);",
    );
    let one = p.rgb(1.0, 1.0, 1.0);
    // EON: a white base reflects all the light at every roughness and
    // angle (Fujii's lobe alone loses up to 22% at roughness 1).
    for name in ["rough", "half"] {
        let m = p.material(name).unwrap();
        for theta in [0.0, 30.0, 60.0, 80.0] {
            let a = albedo_on_grid(&m, &one, direction(theta, 40.0), 96);
            for x in a {
                assert!((x - 1.0).abs() < 0.01, "{name} at {theta} degrees reflects {x}");
            }
        }
    }
    // Rough surfaces scatter back toward the light: more f cos toward the
    // light than away from it, where a Lambertian base is symmetric.
    let (rough, smooth) = (p.material("rough").unwrap(), p.material("smooth").unwrap());
    let (wi, back, forth) = (direction(60.0, 0.0), direction(60.0, 0.0), direction(60.0, 180.0));
    let f = |m: &Material, wo| m.reflection(&surface(), wi, &one, wo).lanes()[0];
    assert!(f(&rough, back) > 1.3 * f(&rough, forth), "{} vs {}", f(&rough, back), f(&rough, forth));
    assert_eq!(f(&smooth, back), f(&smooth, forth));
    // A colored rough base reflects less than its color, never more.
    let red = albedo_on_grid(&p.material("red").unwrap(), &one, direction(30.0, 0.0), 64);
    for (x, c) in red.iter().zip([0.8, 0.3, 0.1]) {
        assert!(*x <= c + 1e-3 && *x > 0.8 * c, "red base reflects {x} of {c}");
    }
}

/// The largest relative difference of the reflection of `a` and `b` over a
/// spread of directions above the surface.
fn largest_relative_difference(p: &Program, a: &str, b: &str) -> f32 {
    let (ma, mb) = (p.material(a).unwrap(), p.material(b).unwrap());
    let one = p.rgb(1.0, 1.0, 1.0);
    let mut worst = 0.0f32;
    for (to, po) in [(0.0, 0.0), (40.0, 30.0), (75.0, 200.0)] {
        for ti in [5.0, 30.0, 50.0, 70.0, 85.0] {
            for pi in [0.0, 100.0, 170.0, 215.0, 300.0] {
                let (wi, wo) = (direction(ti, pi), direction(to, po));
                let fa = ma.reflection(&surface(), wi, &one, wo);
                let fb = mb.reflection(&surface(), wi, &one, wo);
                for (x, y) in fa.lanes().iter().zip(fb.lanes()) {
                    worst = worst.max((x - y).abs() / x.abs().max(y.abs()).max(1e-3));
                }
            }
        }
    }
    worst
}

/// On a black base without specular the coat reflects alone: the
/// reflection of rough_dielectric of the coat's index and the
/// specification's alphas (isotropic at anisotropy 0, stretched along dPdu
/// as the specular lobe is otherwise).
#[test]
fn coat_roughness_anisotropy_stretches_the_coat_lobe_along_dpdu() {
    let coat = |anisotropy: f32| {
        format!(
            "open_pbr_surface(base_color: gray(0), specular_weight: 0, coat_weight: 1, coat_roughness: 0.5, \
                 coat_roughness_anisotropy: {anisotropy}, coat_darkening: 0)"
        )
    };
    let p = compile(&format!(
        "material iso = {};
         material aniso = {};
         material iso_dielectric = rough_dielectric(int_ior: 1.6, ext_ior: 1, alpha: 0.25, distribution: \"ggx\");
         material aniso_dielectric = rough_dielectric(int_ior: 1.6, ext_ior: 1, alpha_u: 0.32827, alpha_v: 0.13131, \
             distribution: \"ggx\");",
        coat(0.0),
        coat(0.6)
    ));
    let d = largest_relative_difference(&p, "iso", "iso_dielectric");
    assert!(d < 2e-3, "an isotropic coat differs from rough_dielectric by {d}");
    let d = largest_relative_difference(&p, "aniso", "aniso_dielectric");
    assert!(d < 2e-3, "an anisotropic coat differs from rough_dielectric by {d}");
    // The highlight's shape: light 20 degrees off the mirror direction
    // along dPdu (x) or across it (y). Isotropic: the same; anisotropic:
    // wider along x, where the lobe's alpha is larger.
    let one = p.rgb(1.0, 1.0, 1.0);
    let wo = [0.0, 0.0, 1.0];
    let off = |m: &str, along_x: bool| {
        let wi = if along_x { direction(20.0, 0.0) } else { direction(20.0, 90.0) };
        p.material(m).unwrap().reflection(&surface(), wi, &one, wo).lanes()[0]
    };
    let (x, y) = (off("iso", true), off("iso", false));
    assert!((x - y).abs() <= 1e-6 * x, "isotropic coat: {x} along x, {y} along y");
    let (x, y) = (off("aniso", true), off("aniso", false));
    assert!(x > 2.0 * y, "anisotropic coat: {x} along x, {y} along y");
}

#[test]
fn an_anisotropic_coat_never_reflects_more_than_it_receives() {
    let mut src = String::new();
    let mut names = Vec::new();
    for (base, what) in [("base_metalness: 1", "metal"), ("specular_weight: 1", "dielectric")] {
        for anisotropy in [0.5, 1.0] {
            let name = format!("m{}", names.len());
            src += &format!(
                "material {name} = open_pbr_surface(base_color: gray(1), {base}, coat_weight: 1, coat_roughness: 0.4, \
                     coat_roughness_anisotropy: {anisotropy}, specular_roughness: 0.2);\n"
            );
            names.push((name, format!("{what} under a coat of anisotropy {anisotropy}")));
        }
    }
    let p = compile(&src);
    let eta = p.rgb(1.0, 1.0, 1.0);
    for (name, what) in &names {
        let m = p.material(name).unwrap();
        for (theta, phi) in [(0.0, 0.0), (45.0, 0.0), (45.0, 90.0), (80.0, 30.0)] {
            let r = largest_lane_albedo(&m, direction(theta, phi), &eta, 8_000);
            assert!(r <= 1.01 && r > 0.5, "{what} at {theta}/{phi} degrees reflects {r}");
        }
    }
}

/// transmission_depth makes transmission_color the volume's: the light
/// left after a distance d inside is pow(color, d / depth) (glass's
/// `transmittance` per unit distance color^(1 / depth)); the interface
/// itself no longer tints.
#[test]
fn transmission_depth_absorbs_inside_as_beers_law() {
    let p = compile(
        "material deep = open_pbr_surface(transmission_weight: 1, transmission_color: rgb(0.3, 0.6, 0.9), \
             transmission_depth: 2);
         material clear = open_pbr_surface(transmission_weight: 1);
         material surface_tint = open_pbr_surface(transmission_weight: 1, transmission_color: rgb(0.3, 0.6, 0.9));",
    );
    let (deep, clear, tinted) =
        (p.material("deep").unwrap(), p.material("clear").unwrap(), p.material("surface_tint").unwrap());
    let light = p.rgb(1.0, 0.5, 2.0);
    for d in [0.0f32, 0.7, 2.0, 5.0] {
        let got = deep.absorption(&surface(), &light, d);
        for ((g, l), c) in got.lanes().iter().zip(light.lanes()).zip([0.3f32, 0.6, 0.9]) {
            let want = l * c.powf(d / 2.0);
            assert!((g - want).abs() <= 1e-5 * want.max(1e-3), "after {d}: {got:?}, want {want} in a lane");
        }
        assert_eq!(clear.absorption(&surface(), &light, d).lanes(), light.lanes());
        assert_eq!(tinted.absorption(&surface(), &light, d).lanes(), light.lanes());
    }
    // The refraction is the clear base's (the color left to the volume),
    // where depth 0 tints it.
    let eta = p.rgb(1.5, 1.5, 1.5);
    let (wi, wo) = (direction(160.0, 10.0), direction(30.0, 200.0));
    let one = p.rgb(1.0, 1.0, 1.0);
    let (a, b) = (deep.refraction(&surface(), wi, &one, &eta, wo), clear.refraction(&surface(), wi, &one, &eta, wo));
    assert!(b.lanes()[0] > 0.0);
    assert_eq!(a.lanes(), b.lanes());
    let t = tinted.refraction(&surface(), wi, &one, &eta, wo);
    assert!((t.lanes()[0] - 0.3 * b.lanes()[0]).abs() <= 1e-5, "{t:?} vs {b:?}");
}

/// In a render the renderer enters a translucent open_pbr_surface as a
/// medium and applies its absorption along each segment inside: a smooth
/// sphere renders as glass of the equivalent per-unit transmittance, at two
/// depths; a rough one absorbs about as much.
#[test]
fn a_deep_translucent_sphere_renders_as_absorbing_glass() {
    let color = [0.3f64, 0.6, 0.9];
    let open_pbr = |roughness: f64, depth: f64| {
        format!(
            "open_pbr_surface(transmission_weight: 1, specular_roughness: {roughness}, \
                 transmission_color: rgb(0.3, 0.6, 0.9), transmission_depth: {depth})"
        )
    };
    let mut seen = Vec::new();
    for depth in [0.5, 2.0] {
        let t = color.map(|c| c.powf(1.0 / depth));
        let glass = format!("glass(ior: gray(1.5), transmittance: rgb({}, {}, {}))", t[0], t[1], t[2]);
        let (a, b) = (sphere_on(&open_pbr(0.0, depth), "gray(1)", 8), sphere_on(&glass, "gray(1)", 8));
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() <= 0.01 * b[k] + 0.001, "depth {depth}: open_pbr {a:?}, glass {b:?}");
        }
        seen.push(a);
    }
    // Deeper color, less absorbed: red 0.3 over 0.5 leaves far less than over 2.
    assert!(seen[0][0] < 0.6 * seen[1][0], "depth 0.5 {:?}, depth 2 {:?}", seen[0], seen[1]);
    let rough = sphere_on(&open_pbr(0.3, 2.0), "gray(1)", 8);
    for k in 0..3 {
        assert!((rough[k] - seen[1][k]).abs() <= 0.06 * seen[1][k], "rough {rough:?}, smooth {:?}", seen[1]);
    }
}

/// A thin wall (geometry_thin_walled): a smooth one passes light straight
/// through from either side, bounds no medium (index 1, no absorption), and
/// a clear one loses nothing at roughness 0 (its two interfaces reflect
/// 2F / (1 + F), transmit the rest); rough or coated it never creates
/// energy.
#[test]
fn a_thin_wall_transmits_unbent_and_bounds_no_medium() {
    let wall = |extra: &str| format!("open_pbr_surface(transmission_weight: 1, geometry_thin_walled: true{extra})");
    let p = compile(&format!(
        "material smooth = {};
         material rough = {};
         material coated = {};
         material tinted = {};",
        wall(", specular_roughness: 0"),
        wall(", specular_roughness: 0.4, specular_roughness_anisotropy: 0.5"),
        wall(", specular_roughness: 0.2, coat_weight: 1, coat_roughness: 0.3, fuzz_weight: 0.5"),
        wall(", specular_roughness: 0, transmission_color: rgb(0.2, 0.5, 0.9), transmission_depth: 1"),
    ));
    let one = p.rgb(1.0, 1.0, 1.0);
    let smooth = p.material("smooth").unwrap();
    assert_eq!(smooth.refraction_index(&surface()).lanes(), one.lanes());
    assert_eq!(smooth.absorption(&surface(), &p.rgb(0.5, 0.5, 0.5), 3.0).lanes(), [0.5; 3]);
    let tinted = p.material("tinted").unwrap();
    assert_eq!(tinted.absorption(&surface(), &p.rgb(0.5, 0.5, 0.5), 3.0).lanes(), [0.5; 3]);
    let mut rng = Rng(11);
    for wo in [direction(0.0, 0.0), direction(35.0, 60.0), direction(70.0, 200.0), direction(140.0, 30.0)] {
        let mut through = 0;
        for _ in 0..200 {
            let s =
                smooth.sample(&surface(), wo, &one, rng.range(0.0, 1.0), [rng.range(0.0, 1.0), rng.range(0.0, 1.0)]);
            if s.wi[2] * wo[2] < 0.0 {
                through += 1;
                let straight = -(s.wi[0] * wo[0] + s.wi[1] * wo[1] + s.wi[2] * wo[2]);
                assert!(straight > 0.9999, "wo {wo:?}: transmitted along {:?}", s.wi);
            }
        }
        assert!(through > 100, "wo {wo:?}: only {through} of 200 samples pass the wall");
    }
    for theta in [0.0, 40.0, 75.0, 120.0, 170.0] {
        let wo = direction(theta, 30.0);
        let r = largest_lane_albedo(&smooth, wo, &one, 4_000);
        assert!((r - 1.0).abs() < 0.01, "a clear smooth wall at {theta} degrees keeps {r}");
        for name in ["rough", "coated", "tinted"] {
            let r = largest_lane_albedo(&p.material(name).unwrap(), wo, &one, 8_000);
            assert!(r <= 1.01, "`{name}` at {theta} degrees gives back {r}");
        }
    }
    // A tinted wall: the light through it is tinted once per crossing of
    // the wall (transmission_color at normal incidence, less the
    // reflections), red least.
    let s = tinted.sample(&surface(), [0.0, 0.0, 1.0], &one, 0.99, [0.3, 0.3]);
    assert!(s.wi[2] < 0.0, "{s:?}");
    let w = s.weight.lanes();
    assert!(w[0] < w[1] && w[1] < w[2] && w[0] < 0.25, "{w:?}");
}

/// In a white furnace a clear thin-walled sphere, smooth or rough, gives
/// back all the light at depth enough (no medium, nothing absorbed).
#[test]
fn a_thin_walled_sphere_keeps_its_energy_in_a_white_furnace() {
    for roughness in [0.0, 0.3] {
        let m = format!(
            "open_pbr_surface(transmission_weight: 1, geometry_thin_walled: true, specular_roughness: {roughness})"
        );
        let seen = sphere_on(&m, "gray(1)", 32);
        for c in seen {
            assert!((0.97..=1.01).contains(&c), "a thin-walled sphere of roughness {roughness}: {seen:?}");
        }
    }
}

/// The subsurface as the dielectric base's diffuse lobe (no volume):
/// weight 0 is the base alone whatever its color; weight 1 is the base
/// with base_color the subsurface's; on a thin wall half its light goes
/// through to the other side (a white one keeps it all).
#[test]
fn the_subsurface_is_a_diffuse_lobe_and_a_thin_walls_translucency() {
    let rest = "coat_weight: 0.6, coat_roughness: 0.3, base_diffuse_roughness: 0.5, specular_roughness: 0.4";
    let p = compile(&format!(
        "material bare = open_pbr_surface(base_color: rgb(0.7, 0.3, 0.2), {rest});
         material none = open_pbr_surface(base_color: rgb(0.7, 0.3, 0.2), subsurface_weight: 0, \
             subsurface_color: rgb(0.1, 0.9, 0.5), subsurface_radius: 3, {rest});
         material full = open_pbr_surface(base_color: gray(0.2), subsurface_weight: 1, \
             subsurface_color: rgb(0.1, 0.9, 0.5), {rest});
         material as_base = open_pbr_surface(base_color: rgb(0.1, 0.9, 0.5), {rest});
         material leaf = open_pbr_surface(base_color: gray(0.5), subsurface_weight: 1, subsurface_color: gray(1), \
             specular_weight: 0, geometry_thin_walled: true);
         material solid_leaf = open_pbr_surface(base_color: gray(0.5), subsurface_weight: 1, subsurface_color: gray(1), \
             specular_weight: 0);"
    ));
    assert_eq!(largest_difference(&p, "bare", "none"), 0.0);
    let d = largest_relative_difference(&p, "full", "as_base");
    assert!(d < 1e-5, "subsurface_weight 1 differs from the base of its color by {d}");
    assert!(largest_difference(&p, "bare", "full") > 0.01);
    let (leaf, solid) = (p.material("leaf").unwrap(), p.material("solid_leaf").unwrap());
    assert!(!leaf.opaque(&surface()) && solid.opaque(&surface()));
    let one = p.rgb(1.0, 1.0, 1.0);
    for wo in [direction(0.0, 0.0), direction(60.0, 30.0), direction(130.0, 200.0)] {
        let mut rng = Rng(5);
        let (mut reflected, mut through, n) = (0.0f64, 0.0f64, 20_000);
        for _ in 0..n {
            let s = leaf.sample(&surface(), wo, &one, rng.range(0.0, 1.0), [rng.range(0.0, 1.0), rng.range(0.0, 1.0)]);
            let w = f64::from(s.weight.lanes()[0]) / f64::from(n);
            if s.wi[2] * wo[2] > 0.0 { reflected += w } else { through += w }
        }
        assert!((reflected - 0.5).abs() < 0.01 && (through - 0.5).abs() < 0.01, "wo {wo:?}: {reflected} + {through}");
    }
    // Through the Material API: the light through is the cosine lobe, half
    // of the white subsurface's.
    let (wi, wo) = (direction(150.0, 10.0), direction(20.0, 80.0));
    let f = leaf.refraction(&surface(), wi, &one, &one, wo).lanes()[0];
    let want = 0.5 * (150.0f32.to_radians().cos()).abs() / std::f32::consts::PI;
    assert!((f - want).abs() < 1e-5, "{f} vs {want}");
}

/// transmission_dispersion_scale makes the index a Cauchy fit n(l) = a +
/// b / l^2 through specular_ior at 587.6 nm with the Abbe number
/// transmission_dispersion_abbe_number / scale: (n_d - 1) / (n_F - n_C).
/// Scale 0 (the default) is the constant index; a thin wall stays at 1.
#[test]
fn transmission_dispersion_follows_the_abbe_number() {
    let model = ColorModel::Spectral { samples: 40 };
    let p = Compiler::new()
        .color_model(model)
        .source(
            "open_pbr.tsl",
            "material plain = open_pbr_surface(transmission_weight: 1, specular_ior: 1.6);
             material flint = open_pbr_surface(transmission_weight: 1, specular_ior: 1.6, \
                 transmission_dispersion_scale: 1, transmission_dispersion_abbe_number: 30);
             material doubled = open_pbr_surface(transmission_weight: 1, specular_ior: 1.6, \
                 transmission_dispersion_scale: 2, transmission_dispersion_abbe_number: 30);
             material thin = open_pbr_surface(transmission_weight: 1, specular_ior: 1.6, \
                 transmission_dispersion_scale: 1, geometry_thin_walled: true);",
        )
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    let lanes = |name: &str| p.material(name).unwrap().refraction_index(&surface()).lanes().to_vec();
    assert!(lanes("plain").iter().all(|n| *n == 1.6));
    assert!(lanes("thin").iter().all(|n| *n == 1.0));
    let wavelengths = model.wavelengths();
    // The fit's index at a wavelength by the lanes (linear between bin centres).
    let at = |n: &[f32], l: f32| {
        let k = wavelengths.iter().position(|w| *w > l).unwrap();
        let t = (l - wavelengths[k - 1]) / (wavelengths[k] - wavelengths[k - 1]);
        f64::from(n[k - 1] + t * (n[k] - n[k - 1]))
    };
    for (name, abbe) in [("flint", 30.0), ("doubled", 15.0)] {
        let n = lanes(name);
        assert!(n.windows(2).all(|w| w[1] < w[0]), "{name}: the index falls with wavelength: {n:?}");
        let (nd, nf, nc) = (at(&n, 587.6), at(&n, 486.1), at(&n, 656.3));
        assert!((nd - 1.6).abs() < 1e-3, "{name}: n_d {nd}");
        let v = (nd - 1.0) / (nf - nc);
        assert!((v / abbe - 1.0).abs() < 0.02, "{name}: Abbe number {v}, want {abbe}");
    }
    // Rendered in RGB (an index per channel), a dispersive rough glass
    // sphere still all but vanishes in a white furnace.
    let m = "open_pbr_surface(transmission_weight: 1, specular_roughness: 0.1, transmission_dispersion_scale: 1)";
    let seen = sphere_on(m, "gray(1)", 64);
    assert!(seen.iter().all(|c| (0.95..=1.02).contains(c)), "a dispersive sphere in a white furnace: {seen:?}");
}
