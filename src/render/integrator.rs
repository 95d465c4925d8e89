//! The two integrators, written only against the generic material
//! interface: [`Tracer::whitted`] (the second paper's renderer: emission,
//! direct light through `reflection`, perfect reflection and refraction
//! followed recursively, absorption inside media) and [`Tracer::path`] (a
//! unidirectional path tracer with next-event estimation of one light
//! chosen by power or of every light, multiple importance sampling of area
//! lights and the environment, and Russian roulette).
//!
//! The path tracer draws each direction with the material's own `sample`
//! (the interface's sampling, composed by texture trees) and weighs light
//! samples with `f · cos` and the pdf of one `eval_pdf` call; perfect
//! directions come from `delta_lobes`. Where an object's material has a
//! hit group, these calls read the record its `prepare` wrote once per
//! vertex (`material_calls`).
//!
//! Depth follows Mitsuba: a path's depth is its number of segments from
//! the camera, counting a shadow connection as one. Whitted rays follow
//! POV-Ray: the camera ray has depth 1 and shadow rays do not count.

use super::geometry::Hit;
use super::light::{Light, LightKind, LightSample};
use super::sampling::{self, Sampler};
use super::scene::{LightSampling, Object, Scene, Strategy};
use super::shape::SurfaceHit;
use super::spectrum::Spectrum;
use super::wavelengths::HeroSample;
use super::{Ray, Vec3};
use crate::ShadingGlobals;
use crate::scene::Frame;
use media::{Media, NO_MEDIA};

mod material_calls;
mod media;

/// Per-sample auxiliary outputs of the first surface seen (for denoisers).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Aov {
    /// `diffuse()` of the first surface, in the color model's lanes
    /// converted to RGB by the caller.
    pub albedo: [f32; 3],
    pub normal: [f32; 3],
    /// Distance from the camera; infinite when the ray leaves the scene.
    pub depth: f32,
}

/// Counts kept while tracing.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    pub camera_rays: u64,
    pub secondary_rays: u64,
    pub shadow_rays: u64,
}

/// A surface point being shaded.
struct Shading<'s, 'g> {
    object: &'s Object,
    surface: SurfaceHit,
    g: &'g ShadingGlobals,
    /// Toward the viewer, unit.
    wo: Vec3,
    hit: Hit,
}

const ZERO_GLOBALS: ShadingGlobals = ShadingGlobals {
    p: [0.0; 3],
    pl: [0.0; 3],
    n: [0.0; 3],
    ng: [0.0; 3],
    u: 0.0,
    v: 0.0,
    dpdu: [0.0; 3],
    dpdv: [0.0; 3],
    face: 0,
    t: 0.0,
    dpdx: [0.0; 3],
    dpdy: [0.0; 3],
    dudx: 0.0,
    dudy: 0.0,
    dvdx: 0.0,
    dvdy: 0.0,
    frame: 0,
    time: 0.0,
    wavelengths: crate::color::HERO_DEFAULT_WAVELENGTHS,
    rgb_weights: [[0.0; crate::color::HERO_LANES]; 3],
};

/// A light sample closer than this (cosine) to a delta direction of the
/// material is skipped: a point light is never seen in a perfect mirror
/// (the stdlib's delta lobes accept directions within 0.9999).
const DELTA_CONE: f32 = 0.9999;

fn in_delta_cone(wi: Vec3, deltas: &[Option<Vec3>; 2]) -> bool {
    deltas.iter().flatten().any(|d| wi.dot(*d) >= DELTA_CONE)
}

/// What next-event estimation at a path vertex needs to weigh a light
/// sample against the material's own sampling: the relative index of
/// refraction its `pdf` (and refraction) take.
struct PathVertex<'e, const N: usize> {
    eta: &'e Spectrum<N>,
}

/// Traces rays in one scene with `N` radiance lanes. One per thread.
pub struct Tracer<'s, const N: usize> {
    scene: &'s Scene,
    lanes: usize,
    ones: Spectrum<N>,
    /// The camera's per-pixel angular spread, for texture footprints.
    spread: f32,
    /// Whether camera samples compute AOVs (they cost material calls).
    want_aov: bool,
    /// The delta lights of a reflection sum (`wi`, light), kept to reuse
    /// its allocation.
    gathered: Vec<([f32; 3], Spectrum<N>)>,
    /// The buffers of the surface at the current path vertex: its
    /// per-hit stage's record (see `material_calls`).
    record: crate::SurfaceRecord,
    /// The relative index at the current vertex, which its stage was
    /// prepared with.
    vertex_eta: Spectrum<N>,
    /// The buffers of calls elsewhere (shadow rays, emitters, media).
    scratch: crate::SurfaceRecord,
    /// The globals where the current camera sample's rays entered media.
    entered: Vec<ShadingGlobals>,
    /// With hero wavelength sampling, the current camera sample's
    /// wavelengths (set by the caller before each camera ray).
    pub hero: Option<HeroSample>,
    pub counters: Counters,
}

/// The perfect directions at a surface point, each with its weight (the
/// material's response to unit light arriving along it).
struct Lobes<const N: usize> {
    reflect: Option<(Vec3, Spectrum<N>)>,
    refract: Option<Refraction<N>>,
}

struct Refraction<const N: usize> {
    dir: Vec3,
    weight: Spectrum<N>,
    /// Whether crossing the surface along `dir` enters the object.
    entering: bool,
}

/// A direction the material drew: the interface's `bsdf_sample`.
struct Drawn<const N: usize> {
    wi: Vec3,
    weight: Spectrum<N>,
    pdf: f32,
    delta: bool,
}

/// Where a Whitted ray is in its tree: its depth (the camera ray has 1),
/// its weight in the pixel, and the path length before it.
#[derive(Clone, Copy)]
struct Depth {
    depth: u32,
    weight: f32,
    distance: f32,
    /// Hero sampling: the companion wavelengths ended above this ray.
    dispersed: bool,
}

/// Whitted rays whose weight in the pixel falls below this are not traced
/// (adaptive tree-depth control, as POV-Ray's `adc_bailout`): the image
/// changes by less than this fraction of the light.
pub const BAILOUT: f32 = 1e-6;

fn v3(v: Vec3) -> [f32; 3] {
    v.to_array()
}

/// The ray leaving `p` along `dir`, moved off the surface (geometric
/// normal `ng`) to the side `dir` goes, so it does not hit its own origin.
fn spawn(p: Vec3, ng: Vec3, dir: Vec3) -> Ray {
    let eps = 1e-4 * (1.0 + p.abs().max_element());
    let side = if dir.dot(ng) >= 0.0 { ng } else { -ng };
    Ray::new(p + side * eps, dir)
}

impl<'s, const N: usize> Tracer<'s, N> {
    pub fn new(scene: &'s Scene, want_aov: bool) -> Self {
        let lanes = scene.model.lanes();
        Tracer {
            scene,
            lanes,
            ones: Spectrum::splat(1.0, lanes),
            spread: scene.camera.pixel_spread(),
            want_aov,
            gathered: Vec::new(),
            record: crate::SurfaceRecord::new(),
            vertex_eta: Spectrum::splat(1.0, lanes),
            scratch: crate::SurfaceRecord::new(),
            entered: Vec::new(),
            hero: None,
            counters: Counters::default(),
        }
    }

    fn nearest(&self, ray: &Ray) -> Option<Hit> {
        self.scene.geometry.intersect(ray, 0.0, f32::INFINITY)
    }

    /// The shading record of a hit, its globals written into `g`;
    /// `distance` is the path length before this ray (for the texture
    /// footprint). The record borrows the globals rather than holding them:
    /// moving 200 bytes into it was a memcpy per hit.
    #[inline(always)]
    fn shade<'g>(&self, ray: &Ray, hit: Hit, distance: f32, g: &'g mut ShadingGlobals) -> Shading<'s, 'g> {
        let object = self.scene.object(hit.object);
        let s = self.scene.geometry.surface(ray, &hit, object.material.facts().reads_uv());
        let len = ray.dir.length();
        let wo = -ray.dir / len;
        globals_into(g, &s, hit.t * len, self.scene.settings.frame);
        self.wavelengths_into(g);
        if object.material.facts().reads_footprint() {
            footprint(g, &s, -wo, distance + hit.t * len, self.spread);
        }
        Shading { object, surface: s, g, wo, hit }
    }

    /// The current sample's wavelengths into globals (hero sampling only).
    fn wavelengths_into(&self, g: &mut ShadingGlobals) {
        if let Some(h) = &self.hero {
            g.wavelengths = h.wavelengths;
            g.rgb_weights = h.shader;
        }
    }

    /// A color of the scene description (a light's, an emitter's scale) in
    /// this sample's lanes: hero samples interpolate it at their wavelengths.
    fn scene_color(&self, c: &crate::Color) -> Spectrum<N> {
        match &self.hero {
            Some(h) => h.tabulated(c.lanes()),
            None => Spectrum::from_lanes(c.lanes()),
        }
    }

    /// With hero sampling, at a surface whose relative index varies over
    /// the lanes: one direction cannot serve every wavelength, so the
    /// companions end here and the hero carries the path on alone, weighed
    /// as many times (pbrt-v4's `TerminateSecondary`). Returns the index
    /// the surface is then shaded with (the hero's in every lane); `done`
    /// says whether this path's companions ended already.
    #[inline]
    fn disperse(&self, eta: Spectrum<N>, beta: &mut Spectrum<N>, done: &mut bool) -> Spectrum<N> {
        let lanes = self.lanes;
        let Some(h) = &self.hero else { return eta };
        if eta.0[..lanes].iter().all(|x| *x == eta.0[0]) {
            return eta;
        }
        if !*done {
            *done = true;
            let hero = beta.0[h.hero] * lanes as f32;
            *beta = Spectrum::ZERO;
            beta.0[h.hero] = hero;
        }
        Spectrum::splat(eta.0[h.hero], lanes)
    }

    // ------------------------------------------------------------ visibility

    /// The fraction of light that passes from `p` (on a surface with normal
    /// `ng`) along `wi` for `distance`: zero when something opaque is in
    /// the way; surfaces that let light through unbent (holes of cutouts)
    /// attenuate it by their `refraction`.
    fn transmittance(&mut self, p: Vec3, ng: Vec3, wi: Vec3, distance: f32) -> Spectrum<N> {
        self.counters.shadow_rays += 1;
        let ray = spawn(p, ng, wi);
        let t_max =
            if distance.is_finite() { (distance - (ray.origin - p).length()) * (1.0 - 1e-4) } else { f32::INFINITY };
        let mut through = self.ones;
        let scene = self.scene;
        let blocked = scene.geometry.occluded(&ray, 0.0, t_max, |hit| {
            let object = scene.object(hit.object);
            if object.material.facts().always_opaque {
                return true;
            }
            let mut g = ZERO_GLOBALS;
            let sh = self.shade(&ray, hit, 0.0, &mut g);
            let ones = self.ones;
            if object.material.at(sh.g, v3(sh.wo), &ones, &mut self.scratch).opaque() {
                return true;
            }
            let (eta, _) = self.eta(&sh, &NO_MEDIA);
            let dt = object.material.at(sh.g, v3(sh.wo), &eta, &mut self.scratch).refraction_dir();
            // Light refracted into glass, even unbent, does not reach the
            // light (`eta` is the surface's own index here).
            if Vec3::from(dt).dot(-sh.wo) < DELTA_CONE || !self.is_unit_index(&eta) {
                return true;
            }
            through *= self.refraction(&sh, Vec3::from(dt), &ones, &eta);
            through.is_black()
        });
        if blocked { Spectrum::ZERO } else { through }
    }

    /// Light from a delta light sample, as `intensity * scale`.
    fn delta_light(&self, kind: &LightKind, scale: f32) -> Spectrum<N> {
        match kind {
            LightKind::Point { intensity, .. } | LightKind::Spot { intensity, .. } => {
                self.scene_color(intensity) * scale
            }
            LightKind::Directional { irradiance, .. } => self.scene_color(irradiance) * scale,
            LightKind::Area { .. } | LightKind::Environment(_) => Spectrum::ZERO,
        }
    }

    /// Emission of a sampled light point toward `-wi`.
    fn surface_emission(&mut self, light_object: u32, surface: &SurfaceHit, wi: Vec3, distance: f32) -> Spectrum<N> {
        let object = self.scene.object(light_object);
        let mut g = globals_of(surface, distance, self.scene.settings.frame);
        self.wavelengths_into(&mut g);
        if object.material.facts().reads_footprint() {
            footprint(&mut g, surface, wi, distance, self.spread);
        }
        self.emission(object, &g, -wi)
    }

    /// Direct light at `sh`. Whitted (no `mis`) sums every light but the
    /// environment, which it sees only where rays leave the scene. The
    /// path tracer (`mis`: what the material's own pdf needs, to weigh
    /// light samples against) samples every light once, or one light
    /// chosen by power, as the settings say.
    fn direct(
        &mut self,
        sh: &Shading,
        sampler: &mut Sampler,
        mis: Option<&PathVertex<N>>,
        deltas: &[Option<Vec3>; 2],
    ) -> Spectrum<N> {
        let scene = self.scene;
        if mis.is_some() && scene.settings.light_sampling == LightSampling::Power {
            // The same three numbers as for one light of the "all" loop,
            // the third also choosing the light: with a single light the
            // two ways give the same bits.
            let u = sampler.next_2d();
            let u3 = sampler.next_1d();
            let Some((k, pmf, u3)) = scene.light_sampler.sample(u3) else { return Spectrum::ZERO };
            return self.light_sample(sh, &scene.lights[k], pmf, u, u3, mis, deltas);
        }
        let mut sum = Spectrum::ZERO;
        // With a reflection sum, delta lights are gathered (black where
        // they cannot reach) and shaded in one call after the loop.
        let summed = sh.object.material.summed_lights().is_some();
        let mut gathered = std::mem::take(&mut self.gathered);
        gathered.clear();
        for light in &scene.lights {
            if mis.is_none() && matches!(light.kind, LightKind::Environment(_)) {
                continue;
            }
            let u = sampler.next_2d();
            let u3 = sampler.next_1d();
            if summed && light.is_delta() {
                let mut li = Spectrum::ZERO;
                let mut dir = sh.surface.n;
                if let Some(LightSample::Delta { wi, distance, scale }) =
                    light.sample(&scene.geometry, sh.surface.p, u, u3)
                {
                    dir = wi;
                    // Reflected light comes from the viewer's side of the surface.
                    let same_side = sh.surface.ng.dot(wi) * sh.surface.ng.dot(sh.wo) > 0.0;
                    li = self.delta_light(&light.kind, scale);
                    if li.is_black() || !same_side || in_delta_cone(wi, deltas) {
                        li = Spectrum::ZERO;
                    } else {
                        li *= self.transmittance(sh.surface.p, sh.surface.ng, wi, distance);
                    }
                }
                gathered.push((v3(dir), li));
                continue;
            }
            sum += self.light_sample(sh, light, 1.0, u, u3, mis, deltas);
        }
        if summed {
            let eta = self.vertex_eta;
            let mut surface = sh.object.material.resume(sh.g, v3(sh.wo), &eta, &mut self.record);
            if let Some(out) = surface.reflection_sum(&gathered) {
                sum += out;
            }
        }
        self.gathered = gathered;
        sum
    }

    /// Light reflected at `sh` from one sample of `light`, chosen with
    /// probability `pmf`; `u` and `u3` are the sample's random numbers.
    #[allow(clippy::too_many_arguments)]
    fn light_sample(
        &mut self,
        sh: &Shading,
        light: &Light,
        pmf: f32,
        u: [f32; 2],
        u3: f32,
        mis: Option<&PathVertex<N>>,
        deltas: &[Option<Vec3>; 2],
    ) -> Spectrum<N> {
        let scene = self.scene;
        let Some(sample) = light.sample(&scene.geometry, sh.surface.p, u, u3) else { return Spectrum::ZERO };
        // Material sampling alone finds area lights and the environment.
        let skip_found = mis.is_some() && scene.settings.strategy == Strategy::Material;
        let (wi, distance, pdf, le) = match sample {
            LightSample::Delta { wi, distance, scale } => {
                let li = self.delta_light(&light.kind, scale);
                if li.is_black() || in_delta_cone(wi, deltas) {
                    return Spectrum::ZERO;
                }
                let f = match mis {
                    Some(v) => self.eval_pdf(sh, wi, v.eta).0 * (li / pmf),
                    None => self.reflection(sh, wi, &(li / pmf)),
                };
                if f.is_black() {
                    return Spectrum::ZERO;
                }
                return f * self.transmittance(sh.surface.p, sh.surface.ng, wi, distance);
            }
            LightSample::Surface { wi, distance, pdf, surface, .. } => {
                let Some(object) = light.object() else { return Spectrum::ZERO };
                if skip_found || pdf <= 0.0 || !pdf.is_finite() || in_delta_cone(wi, deltas) {
                    return Spectrum::ZERO;
                }
                (wi, distance, pdf, self.surface_emission(object, &surface, wi, distance))
            }
            LightSample::Environment { wi, pdf } => {
                if skip_found || pdf <= 0.0 || !pdf.is_finite() || in_delta_cone(wi, deltas) {
                    return Spectrum::ZERO;
                }
                (wi, f32::INFINITY, pdf, self.background(wi))
            }
        };
        if le.is_black() {
            return Spectrum::ZERO;
        }
        let (f, bsdf_pdf) = match mis {
            Some(v) => {
                let (f, pdf) = self.eval_pdf(sh, wi, v.eta);
                (f * le, pdf)
            }
            None => (self.reflection(sh, wi, &le), 0.0),
        };
        if f.is_black() {
            return Spectrum::ZERO;
        }
        let light_pdf = pmf * pdf;
        let weight = match mis {
            Some(_) if scene.settings.strategy == Strategy::Mis => {
                sampling::power_heuristic(1.0, light_pdf, 1.0, bsdf_pdf)
            }
            _ => 1.0,
        };
        f * self.transmittance(sh.surface.p, sh.surface.ng, wi, distance) * (weight / light_pdf)
    }

    /// The weight of light that material sampling found (a path hit an
    /// emitter or left the scene) against light sampling, which picks the
    /// same point with solid-angle density `light_pdf`.
    fn found_weight(&self, bsdf_pdf: f32, light_pdf: f32) -> f32 {
        match self.scene.settings.strategy {
            Strategy::Mis => sampling::power_heuristic(1.0, bsdf_pdf, 1.0, light_pdf),
            Strategy::Material => 1.0,
            // Light sampling counts it wherever it can reach it.
            Strategy::Light => {
                if light_pdf > 0.0 {
                    0.0
                } else {
                    1.0
                }
            }
        }
    }

    /// The shading normal from the material, turned toward the viewer.
    fn sampling_normal(&mut self, sh: &Shading) -> Vec3 {
        let ones = self.ones;
        let n =
            Vec3::from(sh.object.material.at(sh.g, v3(sh.wo), &ones, &mut self.scratch).normal()).normalize_or_zero();
        let n = if n == Vec3::ZERO { sh.surface.n } else { n };
        if n.dot(sh.wo) < 0.0 { -n } else { n }
    }

    /// The environment's radiance along `dir` (black without one).
    fn background(&self, dir: Vec3) -> Spectrum<N> {
        let mut out = Spectrum::ZERO;
        if let Some(env) = self.scene.environment() {
            env.radiance(dir.normalize(), self.hero.as_ref().map(|h| &h.wavelengths), &mut out.0);
        }
        out
    }

    fn aov(&mut self, sh: &Shading) -> Aov {
        let ones = self.ones;
        let albedo = sh.object.material.at(sh.g, v3(sh.wo), &ones, &mut self.scratch).diffuse();
        let albedo = match &self.hero {
            Some(h) => h.shader.map(|row| (0..self.lanes).map(|i| row[i] * albedo.0[i]).sum()),
            None => crate::color::lanes_to_rgb(self.scene.model, &albedo.0[..self.lanes]),
        };
        Aov { albedo, normal: v3(self.sampling_normal(sh)), depth: sh.g.t }
    }

    // ------------------------------------------------------------ Whitted

    /// Radiance along a camera ray by Whitted's recursion.
    pub fn whitted(&mut self, ray: &Ray, sampler: &mut Sampler) -> (Spectrum<N>, Aov) {
        self.counters.camera_rays += 1;
        self.entered.clear();
        let mut aov = Aov { depth: f32::INFINITY, ..Aov::default() };
        let start = Depth { depth: 1, weight: 1.0, distance: 0.0, dispersed: false };
        let l = self.whitted_ray(ray, start, &NO_MEDIA, sampler, self.want_aov.then_some(&mut aov));
        (l, aov)
    }

    fn whitted_ray(
        &mut self,
        ray: &Ray,
        Depth { depth, weight, distance, dispersed }: Depth,
        media: &Media,
        sampler: &mut Sampler,
        aov: Option<&mut Aov>,
    ) -> Spectrum<N> {
        let Some(hit) = self.nearest(ray) else {
            return self.background(ray.dir);
        };
        let mut g = ZERO_GLOBALS;
        let sh = self.shade(ray, hit, distance, &mut g);
        if let Some(aov) = aov {
            *aov = self.aov(&sh);
        }
        let here = distance + sh.g.t;
        let (eta, entering) = self.crossing(&sh, media);
        // A dispersive surface: this hit and what follows see the hero only.
        let mut scale = self.ones;
        let mut dispersed = dispersed;
        let first = !dispersed;
        let eta = self.disperse(eta, &mut scale, &mut dispersed);
        let ends_companions = first && dispersed;
        // The record serves this hit's calls, all made before the recursion.
        self.prepare(&sh, &eta);
        let lobes = self.lobes(&sh, entering);
        let deltas = [lobes.reflect.map(|r| r.0), lobes.refract.as_ref().map(|r| r.dir)];
        let mut l = self.emission(sh.object, sh.g, sh.wo);
        l += self.direct(&sh, sampler, None, &deltas);
        if depth < self.scene.settings.max_depth {
            // Materials are linear in the light they are given, so the
            // weight of a perfect direction is its response to unit light.
            if let Some((dr, w)) = lobes.reflect
                && weight * w.max_lane() >= BAILOUT
            {
                self.counters.secondary_rays += 1;
                let r = spawn(sh.surface.p, sh.surface.ng, dr);
                let next = Depth { depth: depth + 1, weight: weight * w.max_lane(), distance: here, dispersed };
                let lr = self.whitted_ray(&r, next, media, sampler, None);
                l += w * lr;
            }
            if let Some(Refraction { dir: dt, weight: w, entering }) = lobes.refract
                && weight * w.max_lane() >= BAILOUT
            {
                let inner = self.crossed(&sh, media, entering, dt);
                self.counters.secondary_rays += 1;
                let r = spawn(sh.surface.p, sh.surface.ng, dt);
                let next = Depth { depth: depth + 1, weight: weight * w.max_lane(), distance: here, dispersed };
                let lt = self.whitted_ray(&r, next, &inner, sampler, None);
                l += w * lt;
            }
        }
        if ends_companions {
            l *= scale;
        }
        // The light came to this point through the medium the ray is in.
        self.absorb(media.innermost(), l, sh.g.t)
    }

    // ------------------------------------------------------------ path tracing

    /// Radiance along a camera ray by path tracing.
    pub fn path(&mut self, camera_ray: &Ray, sampler: &mut Sampler) -> (Spectrum<N>, Aov) {
        self.counters.camera_rays += 1;
        self.entered.clear();
        let max_depth = self.scene.settings.max_depth;
        let mut aov = Aov { depth: f32::INFINITY, ..Aov::default() };
        let mut l = Spectrum::<N>::ZERO;
        let mut beta = self.ones;
        let mut ray = *camera_ray;
        let mut media = Media::NONE;
        let mut distance = 0.0;
        // The previous vertex and the solid-angle pdf of the direction taken
        // from it (None after a delta lobe or at the camera: no MIS).
        let mut prev: Option<(Vec3, f32)> = None;
        let mut depth = 1u32;
        let mut dispersed = false;
        // The squared relative indices of the surfaces crossed: a rough
        // dielectric's transmission divides radiance by eta², which
        // Russian roulette must not mistake for a path losing its worth
        // (Mitsuba's `eta`, pbrt-v4's `etaScale`).
        let mut eta_scale = 1.0f32;
        loop {
            let Some(hit) = self.nearest(&ray) else {
                // The environment found by following the path, weighed
                // against having sampled the same direction as a light.
                let le = self.background(ray.dir);
                let weight = match (prev, self.scene.environment_light, self.scene.environment()) {
                    (Some((_, bsdf_pdf)), Some(k), Some(env)) if !le.is_black() => {
                        let light_pdf = self.scene.light_pmf(k) * env.pdf(ray.dir.normalize());
                        self.found_weight(bsdf_pdf, light_pdf)
                    }
                    _ => 1.0,
                };
                l += beta * le * weight;
                break;
            };
            let mut g = ZERO_GLOBALS;
            let sh = self.shade(&ray, hit, distance, &mut g);
            if depth == 1 && self.want_aov {
                aov = self.aov(&sh);
            }
            beta = self.absorb(media.innermost(), beta, sh.g.t);
            distance += sh.g.t;
            // Emission found by following the path, weighed against having
            // sampled the same point as a light.
            let le = self.emission(sh.object, sh.g, sh.wo);
            if !le.is_black() {
                let weight = match (prev, self.scene.light_of_object[hit.object as usize]) {
                    (Some((x, bsdf_pdf)), Some(k)) => {
                        let light_pdf = self.scene.light_pmf(k) * self.scene.lights[k].pdf(x, &sh.surface);
                        self.found_weight(bsdf_pdf, light_pdf)
                    }
                    _ => 1.0,
                };
                l += beta * le * weight;
            }
            if depth >= max_depth {
                break;
            }
            let (eta, entering) = self.crossing(&sh, &media);
            let eta = self.disperse(eta, &mut beta, &mut dispersed);
            // The per-hit stage once; every call below reads its record.
            self.prepare(&sh, &eta);
            // Light samples near a perfect direction are not the smooth part.
            let facts = sh.object.material.facts();
            let deltas = if facts.reflects || facts.refracts {
                let lobes = self.lobes(&sh, entering);
                [lobes.reflect.map(|r| r.0), lobes.refract.map(|r| r.dir)]
            } else {
                [None, None]
            };
            // Next-event estimation: one more segment, to a light.
            l += beta * self.direct(&sh, sampler, Some(&PathVertex { eta: &eta }), &deltas);
            // The material chooses how the path goes on.
            let u1 = sampler.next_1d();
            let u2 = sampler.next_2d();
            let Some(s) = self.sample(&sh, u1, u2) else { break };
            let (wi, weight) = (s.wi, s.weight);
            if wi == Vec3::ZERO || !(s.delta || s.pdf > 0.0) || weight.is_black() || !weight.is_finite() {
                break;
            }
            if sh.surface.ng.dot(wi) * sh.surface.ng.dot(sh.wo) < 0.0 {
                if !sh.object.material.facts().transmits() {
                    break;
                }
                media = self.crossed(&sh, &media, entering, wi);
                let relative = eta.mean(N);
                eta_scale *= relative * relative;
            }
            beta *= weight;
            // Emission found along a delta lobe (or where light sampling
            // does not look) counts in full.
            prev = (!s.delta && !in_delta_cone(wi, &deltas)).then_some((sh.surface.p, s.pdf));
            // Russian roulette, as Mitsuba: from the fifth vertex on.
            if depth >= 5 {
                let q = (beta.max_lane() * eta_scale).min(0.95);
                if sampler.next_1d() >= q {
                    break;
                }
                beta = beta / q;
            }
            self.counters.secondary_rays += 1;
            ray = spawn(sh.surface.p, sh.surface.ng, wi);
            depth += 1;
        }
        (l, aov)
    }
}

/// The shading globals of a surface record (the footprint is filled by
/// [`footprint`]).
pub(super) fn globals_of(s: &SurfaceHit, t: f32, frame: Frame) -> ShadingGlobals {
    let mut g = ZERO_GLOBALS;
    globals_into(&mut g, s, t, frame);
    g
}

/// [`globals_of`] field by field into `g`, whose other fields are kept.
fn globals_into(g: &mut ShadingGlobals, s: &SurfaceHit, t: f32, frame: Frame) {
    g.p = v3(s.p);
    g.pl = v3(s.pl);
    g.n = v3(s.n);
    g.ng = v3(s.ng);
    g.u = s.u;
    g.v = s.v;
    g.dpdu = v3(s.dpdu);
    g.dpdv = v3(s.dpdv);
    g.face = s.face;
    g.t = t;
    g.frame = frame.number;
    g.time = frame.time;
}

/// The pixel footprint at a hit: how P, u and v change from one pixel to
/// the next. A ray that has travelled `distance` in all is treated as if
/// seen straight from the camera at that distance (pbrt-v4's approximation
/// for rays without differentials): two rays diverging by the camera's
/// per-pixel angle are intersected with the tangent plane.
fn footprint(g: &mut ShadingGlobals, s: &SurfaceHit, dir: Vec3, distance: f32, spread: f32) {
    let d = dir.normalize_or_zero();
    let n = s.ng;
    if d == Vec3::ZERO || !distance.is_finite() {
        return;
    }
    let origin = s.p - d * distance;
    let frame = sampling::Frame::new(d);
    let offset = |axis: Vec3| {
        let dd = d + axis * spread;
        let denom = n.dot(dd);
        if denom.abs() < 1e-6 {
            return axis * spread * distance;
        }
        let t = n.dot(s.p - origin) / denom;
        origin + dd * t - s.p
    };
    let dpdx = offset(frame.to_world(Vec3::X));
    let dpdy = offset(frame.to_world(Vec3::Y));
    // Least squares for (du, dv) with dpdu du + dpdv dv = dp.
    let (a00, a01, a11) = (s.dpdu.dot(s.dpdu), s.dpdu.dot(s.dpdv), s.dpdv.dot(s.dpdv));
    let det = a00 * a11 - a01 * a01;
    let solve = |dp: Vec3| {
        if det.abs() < 1e-20 {
            return (0.0, 0.0);
        }
        let (b0, b1) = (s.dpdu.dot(dp), s.dpdv.dot(dp));
        let du = (a11 * b0 - a01 * b1) / det;
        let dv = (a00 * b1 - a01 * b0) / det;
        let clamp = |x: f32| if x.is_finite() { x.clamp(-1e8, 1e8) } else { 0.0 };
        (clamp(du), clamp(dv))
    };
    let (dudx, dvdx) = solve(dpdx);
    let (dudy, dvdy) = solve(dpdy);
    g.dpdx = v3(dpdx);
    g.dpdy = v3(dpdy);
    (g.dudx, g.dvdx, g.dudy, g.dvdy) = (dudx, dvdx, dudy, dvdy);
}

/// Where the camera ray through the centre of pixel `(px, py)` (and of the
/// lens) first meets the scene, as a renderer shades it: the index of the
/// object's surface in [`Scene::objects`], its shading globals (the pixel footprint
/// included) and the direction toward the viewer. For probes, tools and
/// benchmarks that call materials as the integrators do.
pub fn camera_hit(scene: &Scene, px: u32, py: u32) -> Option<(usize, ShadingGlobals, [f32; 3])> {
    let ray = scene.camera.ray(px as f32 + 0.5, py as f32 + 0.5, [0.5, 0.5]);
    let hit = scene.geometry.intersect(&ray, 0.0, f32::INFINITY)?;
    let object = scene.object(hit.object);
    let s = scene.geometry.surface(&ray, &hit, object.material.facts().reads_uv());
    let len = ray.dir.length();
    let mut g = globals_of(&s, hit.t * len, scene.settings.frame);
    if object.material.facts().reads_footprint() {
        footprint(&mut g, &s, ray.dir / len, hit.t * len, scene.camera.pixel_spread());
    }
    Some((scene.surface_of_object[hit.object as usize] as usize, g, v3(-ray.dir / len)))
}
