//! Shading N points in one call: a batch of shading points whose globals
//! are columns of the caller's arrays (structure of arrays, or one field of
//! an array of structs by its stride), and a material's surface calls over
//! it, results into caller buffers.

use super::surface::check_lanes;
use super::{
    Outcome, TslError, TslGlobals, TslMaterial, TslStatus, guard, handle, handle_mut, invalid, put, slice_arg,
    slice_out, str_arg,
};
use crate::{Column, ShadingBatch, ShadingGlobals, SurfaceBatch};
use std::ffi::c_char;

/// One input value per point: point `i` reads `values[i * stride]`; with
/// `values` null, every point reads `uniform`. `stride` is in floats (1
/// for a plain array, 3 for one field of an array of xyz triples; 0 reads
/// `values[0]` everywhere). The array must hold a value for every point.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct TslColumn {
    pub values: *const f32,
    pub stride: usize,
    pub uniform: f32,
}

/// The shading points of a batch: each global is the base globals' value
/// at every point unless `tsl_batch_set` gives a column for it. The batch
/// keeps the caller's pointers, not copies: the arrays must stay valid and
/// unchanged until the last call that uses the batch. Not for use from
/// two threads at once while one sets a column; any number of threads may
/// shade with one batch otherwise.
pub struct TslBatch {
    points: usize,
    base: ShadingGlobals,
    /// The columns given, by global name, in the order set.
    columns: Vec<(String, Vec<TslColumn>)>,
}

impl TslColumn {
    /// The column over `points` points.
    fn column<'a>(&self, points: usize, what: &str) -> Outcome<Column<'a>> {
        if self.values.is_null() {
            return Ok(Column::uniform(self.uniform));
        }
        let len = match points.checked_sub(1) {
            None => 0,
            Some(last) => match last.checked_mul(self.stride).and_then(|n| n.checked_add(1)) {
                Some(len) => len,
                None => {
                    return invalid(format!("`{what}`: a stride of {} overflows over {points} points", self.stride));
                }
            },
        };
        Ok(Column::strided(slice_arg(self.values, len, what)?, 0, self.stride))
    }
}

fn columns<'a>(ptr: *const TslColumn, count: usize, points: usize, what: &str) -> Outcome<Vec<Column<'a>>> {
    let given = slice_arg(ptr, count, what)?;
    given.iter().enumerate().map(|(k, c)| c.column(points, &format!("{what}[{k}]"))).collect()
}

fn vector<'a>(ptr: *const TslColumn, points: usize, what: &str) -> Outcome<[Column<'a>; 3]> {
    let c = columns(ptr, 3, points, what)?;
    Ok([c[0], c[1], c[2]])
}

impl TslBatch {
    fn shading_batch(&self) -> Outcome<ShadingBatch<'_>> {
        let mut batch = ShadingBatch::with_base(self.points, self.base);
        for (name, given) in &self.columns {
            let cols: Vec<Column<'_>> = given.iter().map(|c| c.column(self.points, name)).collect::<Outcome<_>>()?;
            batch.set(name, &cols)?;
        }
        Ok(batch)
    }
}

/// A batch of `points` shading points whose globals are `base`'s (null:
/// `tsl_globals_default()`) until set, into `*out` (free it with
/// `tsl_batch_free`).
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_batch_new(
    points: usize,
    base: *const TslGlobals,
    out: *mut *mut TslBatch,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        if points > crate::MAX_BATCH_WORDS {
            return invalid(format!("{points} points is more than a batch holds"));
        }
        // SAFETY: null or a readable `TslGlobals` (the header's contract).
        let base = unsafe { base.as_ref() }.copied().unwrap_or_else(|| super::tsl_globals_default()).to_rust();
        put(out, TslBatch { points, base, columns: Vec::new() }, "out")
    })
}

/// Frees a batch (null is ignored); the arrays it read stay the caller's.
/// Threads: not while another call uses the handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_batch_free(batch: *mut TslBatch) {
    super::free(batch);
}

/// The number of points of the batch (0 for null).
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_batch_len(batch: *const TslBatch) -> usize {
    super::guard_value(0, || handle(batch, "batch").map_or(0, |b| b.points))
}

/// Gives the global `name` (`P`, `N`, `Ng`, `u`, `face`, ...) point by
/// point: `count` columns, one per float (three for a point, vector or
/// normal; `face` and `frame` read the float's bits as an int). An
/// unknown name, a wrong number of columns or a null array is `TSL_ERROR`
/// or `TSL_INVALID_ARGUMENT`, and the batch is unchanged.
/// Threads: not while another call uses `batch`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_batch_set(
    batch: *mut TslBatch,
    name: *const c_char,
    name_len: usize,
    columns: *const TslColumn,
    count: usize,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let b = handle_mut(batch, "batch")?;
        let name = str_arg(name, name_len, "name")?;
        let given = slice_arg(columns, count, "columns")?.to_vec();
        // Checked now, so a bad column fails here rather than at a call.
        let cols: Vec<Column<'_>> = given.iter().map(|c| c.column(b.points, name)).collect::<Outcome<_>>()?;
        ShadingBatch::with_base(b.points, b.base).set(name, &cols)?;
        b.columns.retain(|(n, _)| n != name);
        b.columns.push((name.to_string(), given));
        Ok(())
    })
}

/// Reads the arguments every batch call shares and runs `call` on the
/// material's surfaces at the batch's points; `points` is what the
/// caller's output buffers were sized for.
fn with_surfaces(
    material: *const TslMaterial,
    batch: *const TslBatch,
    wo: *const TslColumn,
    eta: *const TslColumn,
    lanes: usize,
    points: usize,
    call: impl FnOnce(&mut SurfaceBatch<'_>, usize) -> Outcome,
) -> Outcome {
    let material = &handle(material, "material")?.material;
    check_lanes(&material.color_model(), lanes)?;
    let b = handle(batch, "batch")?;
    if points != b.points {
        return invalid(format!("the batch has {} points, not {points}: size the outputs for it", b.points));
    }
    let points = b.shading_batch()?;
    let wo = vector(wo, b.points, "wo")?;
    let eta = columns(eta, lanes, b.points, "eta")?;
    let mut surfaces = material.at_batch(&points, wo, &eta)?;
    call(&mut surfaces, b.points)
}

/// Copies `values` to the caller's `len` floats at `out`.
fn put_floats(out: *mut f32, values: &[f32], what: &str) -> Outcome {
    slice_out(out, values.len(), what)?.copy_from_slice(values);
    Ok(())
}

/// `tsl_material_reflection` at every point of `batch`: `wo` and `wi` are 3
/// columns each, `eta` and `light` `lanes` columns each; `out` receives
/// `points * lanes` floats, point by point. As in every batch call,
/// `points` is the number of points the output buffers hold, which must
/// be the batch's (`tsl_batch_len`). Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_material_batch_reflection(
    material: *const TslMaterial,
    batch: *const TslBatch,
    wo: *const TslColumn,
    eta: *const TslColumn,
    wi: *const TslColumn,
    light: *const TslColumn,
    lanes: usize,
    points: usize,
    out: *mut f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        with_surfaces(material, batch, wo, eta, lanes, points, |s, points| {
            let (wi, light) = (vector(wi, points, "wi")?, columns(light, lanes, points, "light")?);
            put_floats(out, &s.reflection(wi, &light)?.values, "out")
        })
    })
}

/// `tsl_material_emission` at every point: `points * lanes` floats into
/// `out`. Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_material_batch_emission(
    material: *const TslMaterial,
    batch: *const TslBatch,
    wo: *const TslColumn,
    eta: *const TslColumn,
    lanes: usize,
    points: usize,
    out: *mut f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        with_surfaces(material, batch, wo, eta, lanes, points, |s, _| put_floats(out, &s.emission()?.values, "out"))
    })
}

/// `tsl_material_albedo` at every point: `points * lanes` floats into
/// `out`. Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_material_batch_albedo(
    material: *const TslMaterial,
    batch: *const TslBatch,
    wo: *const TslColumn,
    eta: *const TslColumn,
    lanes: usize,
    points: usize,
    out: *mut f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        with_surfaces(material, batch, wo, eta, lanes, points, |s, _| put_floats(out, &s.albedo()?.values, "out"))
    })
}

/// `tsl_material_sample` at every point, from columns `uc`, `u1`, `u2`:
/// `wi` receives `points * 3` floats, `weight` `points * lanes`, `pdf`
/// `points` and `delta` `points` bools. Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_material_batch_sample(
    material: *const TslMaterial,
    batch: *const TslBatch,
    wo: *const TslColumn,
    eta: *const TslColumn,
    lanes: usize,
    uc: TslColumn,
    u1: TslColumn,
    u2: TslColumn,
    points: usize,
    wi: *mut f32,
    weight: *mut f32,
    pdf: *mut f32,
    delta: *mut bool,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        with_surfaces(material, batch, wo, eta, lanes, points, |s, points| {
            let u = [u1.column(points, "u1")?, u2.column(points, "u2")?];
            let sample = s.sample(uc.column(points, "uc")?, u)?;
            put_floats(wi, sample.wi.as_flattened(), "wi")?;
            put_floats(weight, &sample.weight.values, "weight")?;
            put_floats(pdf, &sample.pdf, "pdf")?;
            slice_out(delta, points, "delta")?.copy_from_slice(&sample.delta);
            Ok(())
        })
    })
}

/// `tsl_material_eval_pdf` at every point for directions `wi` (3
/// columns): `value` receives `points * lanes` floats, `pdf` `points`.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_material_batch_eval_pdf(
    material: *const TslMaterial,
    batch: *const TslBatch,
    wo: *const TslColumn,
    eta: *const TslColumn,
    lanes: usize,
    wi: *const TslColumn,
    points: usize,
    value: *mut f32,
    pdf: *mut f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        with_surfaces(material, batch, wo, eta, lanes, points, |s, points| {
            let e = s.eval_pdf(vector(wi, points, "wi")?)?;
            put_floats(value, &e.value.values, "value")?;
            put_floats(pdf, &e.pdf, "pdf")
        })
    })
}

/// `tsl_material_pdf` at every point: `points` floats into `pdf`.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_material_batch_pdf(
    material: *const TslMaterial,
    batch: *const TslBatch,
    wo: *const TslColumn,
    eta: *const TslColumn,
    lanes: usize,
    wi: *const TslColumn,
    points: usize,
    pdf: *mut f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        with_surfaces(material, batch, wo, eta, lanes, points, |s, points| {
            put_floats(pdf, &s.pdf(vector(wi, points, "wi")?)?, "pdf")
        })
    })
}
