//! The language's `noise`, for hosts: what a shader's `noise(x)`,
//! `noise(vec2)` and `noise(vec3)` return, so a host can write a reference
//! shader in Rust, place geometry by the same pattern or check a result.
//! These are the natives the compiled code calls; where the compiler inlines
//! noise (single precision) it agrees with them within 2e-6 for coordinates
//! below 2^63 (`ir::tests::lowering::inlined_noise_is_the_native_noise`).
//!
//! Improved Perlin noise (Perlin 2002) in [-1, 1], 0 at lattice points and
//! 0 when a coordinate is not finite; never panics.
//!
//! ```
//! let n = tsl::noise::noise3(0.3, 1.7, -2.2);
//! assert!((-1.0..=1.0).contains(&n));
//! assert_eq!(tsl::noise::noise3(1.0, 2.0, 3.0), 0.0);
//! assert_eq!(tsl::noise::noise1(f32::NAN), 0.0);
//! ```

/// `noise(x)`: 1D improved Perlin noise, in [-1, 1]; 0 at integers and for
/// non-finite `x`.
pub fn noise1(x: f32) -> f32 {
    crate::runtime::tsl_noise1(x)
}

/// `noise(vec2(x, y))`: 2D improved Perlin noise, in [-1, 1]; 0 at lattice
/// points and when a coordinate is not finite.
pub fn noise2(x: f32, y: f32) -> f32 {
    crate::runtime::tsl_noise2(x, y)
}

/// `noise(vec3(x, y, z))`: 3D improved Perlin noise, in [-1, 1]; 0 at
/// lattice points and when a coordinate is not finite.
pub fn noise3(x: f32, y: f32, z: f32) -> f32 {
    crate::runtime::tsl_noise3(x, y, z)
}
