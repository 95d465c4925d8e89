//! The built-in ray tracer: scenes from the `scene { ... }` block, shapes,
//! the BVH, lights, the Whitted and path-tracing integrators, and image
//! output. It talks to materials only through the generic material
//! interface ([`crate::Material`]).

pub use glam::{Mat4, Vec3};

/// A ray `origin + t * dir`. `dir` need not be unit length; every `t` is in
/// units of `dir`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray { origin, dir }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}
