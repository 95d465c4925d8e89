//! Shading one point: the shading globals as a C struct and a material's
//! surface calls (`reflection`, `emission`, `sample`, `eval_pdf`, `pdf`)
//! at one hit. Colours are `lanes` floats of the program's colour model.

use super::{Outcome, TslError, TslMaterial, TslStatus, guard, handle, invalid, slice_arg, slice_out, vec3_arg};
use crate::{Color, ColorModel, Program, ShadingGlobals, SurfaceRecord};
use std::cell::RefCell;

/// The shading point (TSL's globals by their language names). Start from
/// `tsl_globals_default()` and set what the renderer knows. In the `hero`
/// colour model the lanes' wavelengths are TSL's defaults.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct TslGlobals {
    /// `P`: hit point, world space.
    pub p: [f32; 3],
    /// `Pl`: hit point, object space.
    pub pl: [f32; 3],
    /// `N`: shading normal (unit).
    pub n: [f32; 3],
    /// `Ng`: geometric normal (unit).
    pub ng: [f32; 3],
    pub u: f32,
    pub v: f32,
    pub dpdu: [f32; 3],
    pub dpdv: [f32; 3],
    /// Surface number (box faces 0-5, ...).
    pub face: i32,
    /// Ray length.
    pub t: f32,
    /// Pixel footprint: change of P, u and v to the next pixel in x and y.
    pub dpdx: [f32; 3],
    pub dpdy: [f32; 3],
    pub dudx: f32,
    pub dudy: f32,
    pub dvdx: f32,
    pub dvdy: f32,
    /// The frame being rendered and its time in seconds.
    pub frame: i32,
    pub time: f32,
}

impl TslGlobals {
    pub(crate) fn to_rust(self) -> ShadingGlobals {
        let TslGlobals { p, pl, n, ng, u, v, dpdu, dpdv, face, t, dpdx, dpdy, dudx, dudy, dvdx, dvdy, frame, time } =
            self;
        ShadingGlobals {
            p,
            pl,
            n,
            ng,
            u,
            v,
            dpdu,
            dpdv,
            face,
            t,
            dpdx,
            dpdy,
            dudx,
            dudy,
            dvdx,
            dvdy,
            frame,
            time,
            ..ShadingGlobals::default()
        }
    }
}

/// What `tsl_material_sample` drew (its weight goes to a caller buffer).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct TslSample {
    /// The incident direction, unit, away from the surface; zero when the
    /// material drew nothing (the path ends).
    pub wi: [f32; 3],
    /// The solid-angle density of `wi` (0 for a delta lobe).
    pub pdf: f32,
    /// Whether `wi` is a perfect (delta) direction.
    pub delta: bool,
}

/// Every global zero but `N` and `Ng`, which are +z, as a host would
/// start from. Thread-safe.
#[unsafe(no_mangle)]
pub extern "C" fn tsl_globals_default() -> TslGlobals {
    let g = ShadingGlobals::default();
    TslGlobals {
        p: g.p,
        pl: g.pl,
        n: [0.0, 0.0, 1.0],
        ng: [0.0, 0.0, 1.0],
        u: g.u,
        v: g.v,
        dpdu: g.dpdu,
        dpdv: g.dpdv,
        face: g.face,
        t: g.t,
        dpdx: g.dpdx,
        dpdy: g.dpdy,
        dudx: g.dudx,
        dudy: g.dudy,
        dvdx: g.dvdx,
        dvdy: g.dvdy,
        frame: g.frame,
        time: g.time,
    }
}

/// An error unless `lanes` is the colour model's.
pub(crate) fn check_lanes(model: &ColorModel, lanes: usize) -> Outcome {
    if lanes != model.lanes() {
        return invalid(format!(
            "a color of the {} color model has {} lanes, not {lanes}",
            model.name(),
            model.lanes()
        ));
    }
    Ok(())
}

/// The colour of `lanes` floats at `ptr`, checked against the program's
/// model.
pub(crate) fn color_arg(program: &Program, ptr: *const f32, lanes: usize, what: &str) -> Outcome<Color> {
    let model = program.color_model();
    check_lanes(&model, lanes)?;
    Ok(Color::from_lanes(model, slice_arg(ptr, lanes, what)?))
}

/// The arguments every point call shares, read and checked.
struct Hit<'a> {
    material: &'a crate::Material,
    g: ShadingGlobals,
    wo: [f32; 3],
    eta: Color,
    lanes: usize,
}

fn hit<'a>(
    material: *const TslMaterial,
    globals: *const TslGlobals,
    wo: *const f32,
    eta: *const f32,
    lanes: usize,
) -> Outcome<Hit<'a>> {
    let material = &handle(material, "material")?.material;
    let model = material.color_model();
    check_lanes(&model, lanes)?;
    Ok(Hit {
        material,
        g: handle(globals, "globals")?.to_rust(),
        wo: vec3_arg(wo, "wo")?,
        eta: Color::from_lanes(model, slice_arg(eta, lanes, "eta")?),
        lanes,
    })
}

impl Hit<'_> {
    /// Runs `call` on the surface at this hit, with the calling thread's
    /// scratch record (reused from call to call: no allocation per call).
    fn with<T>(&self, call: impl FnOnce(&mut crate::Surface<'_>) -> T) -> T {
        thread_local! {
            static RECORD: RefCell<SurfaceRecord> = RefCell::new(SurfaceRecord::new());
        }
        RECORD.with(|record| {
            // Shading never calls back into this module, so the record is
            // free; a fresh one all the same if it ever is not.
            let mut fresh;
            let mut borrowed = record.try_borrow_mut();
            let record = match &mut borrowed {
                Ok(r) => &mut **r,
                Err(_) => {
                    fresh = SurfaceRecord::new();
                    &mut fresh
                }
            };
            let mut surface = self.material.at(&self.g, self.wo, &self.eta, record);
            call(&mut surface)
        })
    }

    fn color(&self, ptr: *const f32, what: &str) -> Outcome<Color> {
        Ok(Color::from_lanes(self.material.color_model(), slice_arg(ptr, self.lanes, what)?))
    }

    fn put_color(&self, out: *mut f32, c: &Color) -> Outcome {
        slice_out(out, self.lanes, "out")?.copy_from_slice(&c.lanes()[..self.lanes]);
        Ok(())
    }
}

/// The material's response at the hit: light `light` (`lanes` floats)
/// arriving from `wi` (3 floats, unit, away from the surface) reflected
/// toward `wo`, `f * cos`, into `out` (`lanes` floats). `eta` is the
/// relative index of refraction outside/inside (`lanes` floats; all 1 for
/// air and most uses). Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_material_reflection(
    material: *const TslMaterial,
    globals: *const TslGlobals,
    wo: *const f32,
    eta: *const f32,
    wi: *const f32,
    light: *const f32,
    lanes: usize,
    out: *mut f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let h = hit(material, globals, wo, eta, lanes)?;
        let (wi, light) = (vec3_arg(wi, "wi")?, h.color(light, "light")?);
        let c = h.with(|s| s.reflection(wi, &light));
        h.put_color(out, &c)
    })
}

/// The light the surface emits toward `wo`, into `out` (`lanes` floats).
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_material_emission(
    material: *const TslMaterial,
    globals: *const TslGlobals,
    wo: *const f32,
    eta: *const f32,
    lanes: usize,
    out: *mut f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let h = hit(material, globals, wo, eta, lanes)?;
        let c = h.with(|s| s.emission());
        h.put_color(out, &c)
    })
}

/// The fraction of light from `wo` the surface reflects (its directional
/// albedo; what a `layer` above it would not let through), into `out`
/// (`lanes` floats). Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_material_albedo(
    material: *const TslMaterial,
    globals: *const TslGlobals,
    wo: *const f32,
    eta: *const f32,
    lanes: usize,
    out: *mut f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let h = hit(material, globals, wo, eta, lanes)?;
        let c = h.with(|s| s.albedo());
        h.put_color(out, &c)
    })
}

/// Draws an incident direction from the uniform numbers `uc` (which lobe)
/// and `(u1, u2)` (where in it) into `*out`, its weight (`f * cos / pdf`)
/// into `weight` (`lanes` floats). Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_material_sample(
    material: *const TslMaterial,
    globals: *const TslGlobals,
    wo: *const f32,
    eta: *const f32,
    lanes: usize,
    uc: f32,
    u1: f32,
    u2: f32,
    out: *mut TslSample,
    weight: *mut f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let h = hit(material, globals, wo, eta, lanes)?;
        let s = h.with(|s| s.sample(uc, [u1, u2]));
        h.put_color(weight, &s.weight)?;
        super::write(out, TslSample { wi: s.wi, pdf: s.pdf, delta: s.delta }, "out")
    })
}

/// For a light direction `wi`: `f * cos` for unit light into `value`
/// (`lanes` floats) and the density with which `sample` draws `wi` into
/// `*pdf`, in one call. Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_material_eval_pdf(
    material: *const TslMaterial,
    globals: *const TslGlobals,
    wo: *const f32,
    eta: *const f32,
    lanes: usize,
    wi: *const f32,
    value: *mut f32,
    pdf: *mut f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let h = hit(material, globals, wo, eta, lanes)?;
        let wi = vec3_arg(wi, "wi")?;
        let e = h.with(|s| s.eval_pdf(wi));
        h.put_color(value, &e.value)?;
        super::write(pdf, e.pdf, "pdf")
    })
}

/// The density with which `sample` draws `wi`, into `*pdf`. Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_material_pdf(
    material: *const TslMaterial,
    globals: *const TslGlobals,
    wo: *const f32,
    eta: *const f32,
    lanes: usize,
    wi: *const f32,
    pdf: *mut f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let h = hit(material, globals, wo, eta, lanes)?;
        let wi = vec3_arg(wi, "wi")?;
        let p = h.with(|s| s.pdf(wi));
        super::write(pdf, p, "pdf")
    })
}
