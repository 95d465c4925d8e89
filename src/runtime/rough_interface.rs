//! What a rough dielectric interface lets through, for `rough_plastic`'s
//! diffuse base: the integrals Mitsuba 3's `roughplastic` tabulates.
//!
//! For a smooth-ish coat of relative index `eta` and isotropic microfacet
//! roughness `alpha` (Beckmann or GGX, Smith's masking as the stdlib's):
//!
//! - the *transmittance* `T(cos θ)`: the fraction of light arriving at
//!   `cos θ` from outside that the interface refracts inside, single
//!   scattering, `∫ D_wi(m) (1 − F(wi·m)) G1(wt, m) dm` over the visible
//!   normals `D_wi` of `wi` (Walter et al. 2007, Heitz 2014);
//! - the *internal reflectance*: the hemispherical average
//!   `2 ∫ R(μ) μ dμ` of the reflectance `R` seen from inside (index
//!   `1 / eta`), the part of the base's diffuse light that the coat sends
//!   back down.
//!
//! Both integrals are taken as Mitsuba takes them (see [`integrals`]), so
//! the numbers agree with it to quadrature error: the transmittance at
//! [`ROUGH_INTERFACE_NODES`] values of `cos θ` spaced evenly over [0, 1]
//! (interpolated linearly between them), the hemispherical average as the
//! mean over the same nodes.
//!
//! Mitsuba integrates once per material, for its one roughness. Here the
//! roughness may vary from point to point (a texture drives it), so the
//! integrals are taken on a fixed grid instead: [`ALPHA_NODES_PER_OCTAVE`]
//! roughness values per octave and [`ETA_NODES_PER_OCTAVE`] index values
//! per octave, each node computed on first use and kept for the process
//! (about 0.1 s in a debug build, a few milliseconds optimised; the whole
//! grid, never reached in practice, is [`MAX_GRID_NODES`]). Any `(alpha,
//! eta)` reads its grid cell's four nodes, blended bilinearly in `log2
//! alpha` and `log2 eta` ([`GridPoint`]); a result therefore depends on
//! the arguments alone, never on which tables some earlier call made.
//! Against the integrals at the exact arguments the blend differs by less
//! than 1e-3 in transmittance and 2.5e-3 in internal reflectance (tested;
//! the largest at nearly smooth interfaces, whose reflectance has a kink
//! at the critical angle that moves with the index).
//!
//! Lowering reads a constant roughness and index as a constant table of
//! the blended nodes (`Op::Table`, no call per hit, see
//! [`constant_table`]); the natives [`tsl_rough_transmittance`] and
//! [`tsl_rough_internal_reflectance`] blend at run time for anything else
//! (a bound instance, a textured roughness). Both blend with the same
//! operations and interpolate in `cos θ` with the same
//! [`lerp_transmittance`], so specialised and bound code agree bit for bit.

mod integrals;

use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

use crate::ir::semantics::{float_to_int, fmax, fmin};

/// The values of `cos θ` the transmittance is tabulated at, evenly spaced
/// over [0, 1] (Mitsuba's `MI_ROUGH_TRANSMITTANCE_RES`, 64): a power of
/// two, as an IR table needs.
pub const ROUGH_INTERFACE_NODES: usize = 64;

/// The roughness range the integrals accept: below it the stdlib clamps
/// too (Mitsuba's 1e-4), above it no surface is realistic and the
/// quadrature would only lose accuracy.
pub const ROUGH_ALPHA_RANGE: (f32, f32) = (1e-4, 4.0);

/// The relative index range accepted (1/16 to 16, every real coating and
/// its inverse); indices outside are clamped.
pub const ROUGH_ETA_RANGE: (f32, f32) = (1.0 / 16.0, 16.0);

/// Grid nodes per octave of roughness (8: neighbours 9% apart, where the
/// tables curve most the blend is still within 1e-3 of the integral).
pub const ALPHA_NODES_PER_OCTAVE: u32 = 8;

/// Grid nodes per octave of relative index (16: neighbours 4.4% apart).
pub const ETA_NODES_PER_OCTAVE: u32 = 16;

/// The grid's roughness span, `log2 alpha` from -14 to 2: it covers
/// [`ROUGH_ALPHA_RANGE`] with whole octaves.
const ALPHA_LOG2_SPAN: (f32, f32) = (-14.0, 2.0);

/// The grid's index span, `log2 eta` from -4 to 4: [`ROUGH_ETA_RANGE`].
const ETA_LOG2_SPAN: (f32, f32) = (-4.0, 4.0);

const ALPHA_CELLS: usize = ((ALPHA_LOG2_SPAN.1 - ALPHA_LOG2_SPAN.0) as u32 * ALPHA_NODES_PER_OCTAVE) as usize;
const ETA_CELLS: usize = ((ETA_LOG2_SPAN.1 - ETA_LOG2_SPAN.0) as u32 * ETA_NODES_PER_OCTAVE) as usize;

/// The most grid nodes a process can compute: both distributions over the
/// whole grid (2 x 129 x 129, 33,282 nodes of 260 bytes, 8.7 MB). Only the
/// nodes some roughness and index fall beside are computed: a constant
/// material needs 4, a roughness textured over [0.1, 0.4] about 70.
pub const MAX_GRID_NODES: usize = 2 * (ALPHA_CELLS + 1) * (ETA_CELLS + 1);

/// The most distinct constant (alpha, eta, distribution) tables lowering
/// keeps as IR constant data (1024, 256 KB); past it, lowering calls the
/// native instead, which gives the same bits.
pub const MAX_CONSTANT_TABLES: usize = 1024;

/// The integrals at one grid node.
#[derive(Debug)]
pub struct RoughInterface {
    /// `T(cos θ)` at `cos θ = k / 63`.
    pub transmittance: [f32; ROUGH_INTERFACE_NODES],
    /// The hemispherical average reflectance seen from inside.
    pub internal_reflectance: f32,
}

impl RoughInterface {
    /// The integrals at exactly `alpha` and `eta` (already in range).
    fn integrate(alpha: f32, eta: f32, ggx: bool) -> RoughInterface {
        RoughInterface {
            transmittance: integrals::transmittance_table(alpha, eta, ggx),
            internal_reflectance: integrals::internal_reflectance(alpha, eta, ggx),
        }
    }
}

/// Where a roughness and index fall in the grid: the cell's low corner
/// and the blend weights toward the high one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridPoint {
    alpha_cell: usize,
    eta_cell: usize,
    alpha_weight: f32,
    eta_weight: f32,
    ggx: bool,
}

impl GridPoint {
    /// The point for `alpha` and `eta`, clamped into
    /// [`ROUGH_ALPHA_RANGE`] and [`ROUGH_ETA_RANGE`]; `None` if either is
    /// NaN.
    pub fn new(alpha: f32, eta: f32, ggx: bool) -> Option<GridPoint> {
        if alpha.is_nan() || eta.is_nan() {
            return None;
        }
        let alpha = alpha.clamp(ROUGH_ALPHA_RANGE.0, ROUGH_ALPHA_RANGE.1);
        let eta = eta.clamp(ROUGH_ETA_RANGE.0, ROUGH_ETA_RANGE.1);
        let (alpha_cell, alpha_weight) = cell(alpha, ALPHA_LOG2_SPAN.0, ALPHA_NODES_PER_OCTAVE, ALPHA_CELLS);
        let (eta_cell, eta_weight) = cell(eta, ETA_LOG2_SPAN.0, ETA_NODES_PER_OCTAVE, ETA_CELLS);
        Some(GridPoint { alpha_cell, eta_cell, alpha_weight, eta_weight, ggx })
    }

    /// Node `k` of the blended transmittance table.
    pub fn transmittance_node(&self, k: usize) -> f32 {
        self.blend(|node| node.transmittance[k])
    }

    /// The blended internal reflectance.
    pub fn internal_reflectance(&self) -> f32 {
        self.blend(|node| node.internal_reflectance)
    }

    /// `value` of the four corners, bilinearly; a corner of weight zero is
    /// neither read nor computed.
    fn blend(&self, value: impl Fn(&RoughInterface) -> f32) -> f32 {
        let (i, j, ggx) = (self.alpha_cell, self.eta_cell, self.ggx);
        let along_alpha = |j| {
            let low = value(grid_node(i, j, ggx));
            if self.alpha_weight == 0.0 { low } else { lerp(low, value(grid_node(i + 1, j, ggx)), self.alpha_weight) }
        };
        let low = along_alpha(j);
        if self.eta_weight == 0.0 { low } else { lerp(low, along_alpha(j + 1), self.eta_weight) }
    }
}

/// The cell of `x` on a grid of `per_octave` nodes per octave from
/// `2^log2_min`, and the weight toward its upper node; `x` in range.
fn cell(x: f32, log2_min: f32, per_octave: u32, cells: usize) -> (usize, f32) {
    let at = (x.log2() - log2_min) * per_octave as f32;
    let low = (float_to_int(at).max(0) as usize).min(cells - 1);
    (low, (at - low as f32).clamp(0.0, 1.0))
}

fn lerp(a: f32, b: f32, w: f32) -> f32 {
    a + (b - a) * w
}

/// The grid node at roughness node `i` and index node `j`, computed on
/// first use; threads wanting the same node wait for one computation.
fn grid_node(i: usize, j: usize, ggx: bool) -> &'static RoughInterface {
    static GRID: OnceLock<Box<[OnceLock<Box<RoughInterface>>]>> = OnceLock::new();
    let grid = GRID.get_or_init(|| (0..MAX_GRID_NODES).map(|_| OnceLock::new()).collect());
    let index = (usize::from(ggx) * (ALPHA_CELLS + 1) + i) * (ETA_CELLS + 1) + j;
    grid[index].get_or_init(|| {
        let alpha = (ALPHA_LOG2_SPAN.0 + i as f32 / ALPHA_NODES_PER_OCTAVE as f32).exp2();
        let eta = (ETA_LOG2_SPAN.0 + j as f32 / ETA_NODES_PER_OCTAVE as f32).exp2();
        Box::new(RoughInterface::integrate(alpha, eta, ggx))
    })
}

/// The blended transmittance table of a constant roughness, index and
/// distribution as IR constant data (f32 bits), kept for the process;
/// `None` for a NaN argument or once [`MAX_CONSTANT_TABLES`] are kept.
pub fn constant_table(alpha: f32, eta: f32, ggx: bool) -> Option<&'static [u32; ROUGH_INTERFACE_NODES]> {
    let point = GridPoint::new(alpha, eta, ggx)?;
    let key = (alpha.to_bits(), eta.to_bits(), ggx);
    let mut kept = constant_tables().lock().unwrap_or_else(|e| e.into_inner());
    if let Some(table) = kept.get(&key) {
        return Some(table);
    }
    if kept.len() >= MAX_CONSTANT_TABLES {
        return None;
    }
    let table: &'static [u32; ROUGH_INTERFACE_NODES] =
        Box::leak(Box::new(std::array::from_fn(|k| point.transmittance_node(k).to_bits())));
    kept.insert(key, table);
    Some(table)
}

type ConstantTables = Mutex<HashMap<(u32, u32, bool), &'static [u32; ROUGH_INTERFACE_NODES]>>;

fn constant_tables() -> &'static ConstantTables {
    static KEPT: OnceLock<ConstantTables> = OnceLock::new();
    KEPT.get_or_init(Default::default)
}

/// `"rough_transmittance"` for a table [`constant_table`] made, for
/// printing IR.
pub fn table_name(table: &[u32]) -> Option<&'static str> {
    let kept = constant_tables().lock().unwrap_or_else(|e| e.into_inner());
    kept.values().any(|t| std::ptr::eq(t.as_slice(), table)).then_some("rough_transmittance")
}

/// The table whose node `k` is `node(k)`, read at `cos_theta` linearly
/// between its nodes: the exact operations lowering emits for a constant
/// table, so both agree.
pub fn lerp_transmittance(node: impl Fn(usize) -> f32, cos_theta: f32) -> f32 {
    let last = (ROUGH_INTERFACE_NODES - 1) as f32;
    let x = fmin(fmax(cos_theta, 0.0), 1.0) * last;
    let k = float_to_int(x);
    let k = if k < ROUGH_INTERFACE_NODES as i32 - 2 { k } else { ROUGH_INTERFACE_NODES as i32 - 2 };
    let w = x - k as f32;
    let a = node(k as usize);
    let b = node(k as usize + 1);
    a + (b - a) * w
}

/// `T(cos θ)` of the interface (native `rough_transmittance`; `ggx` is
/// nonzero for GGX). NaN for a NaN roughness or index.
pub extern "C" fn tsl_rough_transmittance(cos_theta: f32, alpha: f32, eta: f32, ggx: f32) -> f32 {
    match GridPoint::new(alpha, eta, ggx != 0.0) {
        Some(point) => lerp_transmittance(|k| point.transmittance_node(k), cos_theta),
        None => f32::NAN,
    }
}

/// The internal reflectance of the interface (native
/// `rough_internal_reflectance`). NaN for a NaN roughness or index.
pub extern "C" fn tsl_rough_internal_reflectance(alpha: f32, eta: f32, ggx: f32) -> f32 {
    GridPoint::new(alpha, eta, ggx != 0.0).map_or(f32::NAN, |point| point.internal_reflectance())
}

#[cfg(test)]
mod tests;
