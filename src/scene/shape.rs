//! Shapes and transforms as numbers: what each analytic shape needs to be
//! well formed, and which object transforms can place a shape. The scene
//! description checks every object with these rules, and `render` checks
//! again with the same functions when it places a shape, so the two never
//! disagree about what renders.

use super::{Mat4, Vec3};

/// A shape as written in the scene, in its own frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ShapeKind {
    Sphere { center: Vec3, radius: f32 },
    Plane { point: Vec3, normal: Vec3, tile: f32 },
    Quad { corner: Vec3, edge1: Vec3, edge2: Vec3 },
    Disk { center: Vec3, normal: Vec3, radius: f32 },
    Box { min: Vec3, max: Vec3 },
    Cylinder { base: Vec3, axis: Vec3, radius: f32, height: f32 },
}

fn fail<T>(property: &'static str, message: String) -> Result<T, ShapeError> {
    Err(ShapeError { property, message })
}

/// What is wrong with a shape: the scene property at fault (its name as
/// written, `"radius"`, `"edge2"`, ...) and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShapeError {
    pub property: &'static str,
    pub message: String,
}

impl ShapeKind {
    /// The shape with its normal or axis made unit length, or the first
    /// thing wrong with its numbers.
    pub fn validated(self) -> Result<ShapeKind, ShapeError> {
        let finite = |v: Vec3, property: &'static str, what: &str| {
            if v.is_finite() { Ok(()) } else { fail(property, format!("the {what} is not finite: {v}")) }
        };
        let positive = |x: f32, property: &'static str, what: &str| {
            if x > 0.0 && x.is_finite() {
                Ok(())
            } else {
                fail(property, format!("the {what} must be positive, found {x}"))
            }
        };
        let unit = |v: Vec3, property: &'static str, what: &str| {
            finite(v, property, what)?;
            let u = v.normalize_or_zero();
            if u == Vec3::ZERO { fail(property, format!("the {what} must not be the zero vector")) } else { Ok(u) }
        };
        Ok(match self {
            ShapeKind::Sphere { center, radius } => {
                finite(center, "center", "centre")?;
                positive(radius, "radius", "radius")?;
                self
            }
            ShapeKind::Plane { point, normal, tile } => {
                finite(point, "point", "point")?;
                positive(tile, "tile", "tile size")?;
                ShapeKind::Plane { point, normal: unit(normal, "normal", "normal")?, tile }
            }
            ShapeKind::Quad { corner, edge1, edge2 } => {
                finite(corner, "corner", "corner")?;
                finite(edge1, "edge1", "edge1")?;
                finite(edge2, "edge2", "edge2")?;
                let n = edge1.cross(edge2);
                if n.length() <= 1e-12 * edge1.length().max(1.0) * edge2.length().max(1.0) {
                    return fail("edge2", "a quad's edges must not be zero or parallel".into());
                }
                self
            }
            ShapeKind::Disk { center, normal, radius } => {
                finite(center, "center", "centre")?;
                positive(radius, "radius", "radius")?;
                ShapeKind::Disk { center, normal: unit(normal, "normal", "normal")?, radius }
            }
            ShapeKind::Box { min, max } => {
                finite(min, "min", "minimum")?;
                finite(max, "max", "maximum")?;
                if min.cmpgt(max).any() {
                    return fail("max", format!("a box's `min` {min} must not exceed its `max` {max} on any axis"));
                }
                if (max - min).min_element() <= 0.0 {
                    return fail(
                        "max",
                        format!("a box must have volume: `min` {min} and `max` {max} share a coordinate"),
                    );
                }
                self
            }
            ShapeKind::Cylinder { base, axis, radius, height } => {
                finite(base, "base", "base")?;
                positive(radius, "radius", "radius")?;
                positive(height, "height", "height")?;
                ShapeKind::Cylinder { base, axis: unit(axis, "axis", "axis")?, radius, height }
            }
        })
    }
}

/// Why `to_world` cannot place an analytic shape, if it cannot: it must be
/// finite and invertible, with a finite determinant (the shape's frame
/// and its normals use the inverse).
pub fn shape_transform_error(to_world: &Mat4) -> Option<&'static str> {
    if !to_world.is_finite() {
        return Some("the object's transform is not finite");
    }
    let det = to_world.determinant();
    if det.abs() < 1e-12 || !det.is_finite() {
        return Some("the object's transform is singular (a scale of 0?)");
    }
    None
}

/// Why `to_world` cannot place a mesh, if it cannot: it must be finite and
/// invertible. (A mesh's vertices are moved once, so a determinant too
/// large for a float is allowed.)
pub fn mesh_transform_error(to_world: &Mat4) -> Option<&'static str> {
    if !to_world.is_finite() || to_world.determinant().abs() < 1e-12 {
        return Some("the object's transform is singular or not finite");
    }
    None
}

/// One object transform, as written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Transform {
    Translate(Vec3),
    /// Degrees about x, then y, then z.
    Rotate(Vec3),
    /// Per axis (a single float is written as the same on all three).
    Scale(Vec3),
    /// An affine map, `transform M` with the three rows of a TSL matrix.
    Matrix(Mat4),
}

impl Transform {
    pub fn matrix(&self) -> Mat4 {
        match *self {
            Transform::Translate(v) => Mat4::from_translation(v.into()),
            Transform::Rotate(r) => {
                Mat4::from_rotation_z(r.z.to_radians())
                    * Mat4::from_rotation_y(r.y.to_radians())
                    * Mat4::from_rotation_x(r.x.to_radians())
            }
            Transform::Scale(s) => Mat4::from_scale(s.into()),
            Transform::Matrix(m) => m,
        }
    }
}

/// Transforms composed in the order written: the first applies first.
pub fn compose<'t>(steps: impl IntoIterator<Item = &'t Transform>) -> Mat4 {
    steps.into_iter().fold(Mat4::IDENTITY, |m, t| t.matrix() * m)
}

/// A TSL matrix (three rows of an affine map, row-major, twelve floats) as
/// a `Mat4`.
pub fn affine_rows(w: &[f32]) -> Mat4 {
    let col = |c: usize| glam::Vec4::new(w[c], w[4 + c], w[8 + c], if c == 3 { 1.0 } else { 0.0 });
    Mat4::from_cols(col(0), col(1), col(2), col(3))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degenerate_shapes_name_the_property_at_fault() {
        let quad = ShapeKind::Quad { corner: Vec3::ZERO, edge1: Vec3::X, edge2: Vec3::X * 2.0 };
        assert_eq!(quad.validated().unwrap_err().property, "edge2");
        let plane = ShapeKind::Plane { point: Vec3::ZERO, normal: Vec3::ZERO, tile: 1.0 };
        assert_eq!(plane.validated().unwrap_err().property, "normal");
        let boxed = ShapeKind::Box { min: Vec3::ONE, max: Vec3::ZERO };
        assert!(boxed.validated().unwrap_err().message.contains("exceed"));
        let disk = ShapeKind::Disk { center: Vec3::ZERO, normal: Vec3::Y * 3.0, radius: 1.0 };
        assert_eq!(disk.validated().unwrap(), ShapeKind::Disk { center: Vec3::ZERO, normal: Vec3::Y, radius: 1.0 });
    }

    #[test]
    fn transforms_compose_in_the_order_written() {
        let steps = [Transform::Scale(Vec3::splat(2.0)), Transform::Translate(Vec3::X)];
        let m = compose(&steps);
        assert_eq!(m.transform_point3(glam::Vec3::ONE), glam::Vec3::new(3.0, 2.0, 2.0));
        assert!(shape_transform_error(&compose(&[Transform::Scale(Vec3::ZERO)])).is_some());
        let huge = compose(&[Transform::Scale(Vec3::splat(1e20))]);
        assert!(shape_transform_error(&huge).is_some() && mesh_transform_error(&huge).is_none());
    }
}
