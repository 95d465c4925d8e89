//! The camera: a pinhole or thin lens looking from `from` to `to`, with the
//! field of view measured across the image width (as POV-Ray's `angle` and
//! Mitsuba's default `fov_axis`), and the per-pixel spread of its rays that
//! sets the texture footprint.
//!
//! Convention (the benchmark scenes' `spec.md`): `F = normalize(to - from)`,
//! `R = normalize(F x up)`, `U = R x F`, `t = tan(fov / 2)`; the ray through
//! image position `(px, py)` (pixels from the top-left corner, y down) has
//! direction `normalize(F + (2 px / W - 1) t R + (1 - 2 py / H) t (H / W) U)`.

use super::{Ray, Vec3};

#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    forward: Vec3,
    /// `R * t` and `U * t * H / W`: image-plane axes at unit distance.
    right: Vec3,
    up: Vec3,
    width: f32,
    height: f32,
    /// Lens radius (0 for a pinhole) and the distance of the plane in focus.
    lens_radius: f32,
    focus: f32,
}

impl Camera {
    /// `fov` in degrees across the width; `aperture` is the lens radius.
    pub fn new(
        from: Vec3,
        to: Vec3,
        up: Vec3,
        fov: f32,
        (width, height): (u32, u32),
        aperture: f32,
        focus: Option<f32>,
    ) -> Result<Camera, String> {
        let forward = (to - from).normalize_or_zero();
        if !from.is_finite() || !to.is_finite() || forward == Vec3::ZERO {
            return Err("the camera looks from a point to itself: `from` and `to` must differ".into());
        }
        let right = forward.cross(up).normalize_or_zero();
        if right == Vec3::ZERO || !right.is_finite() {
            return Err("the camera's `up` is parallel to its view direction (or zero)".into());
        }
        if !(fov > 0.0 && fov < 180.0) {
            return Err(format!("the field of view must be between 0 and 180 degrees, found {fov}"));
        }
        if width == 0 || height == 0 {
            return Err(format!("the image size must be positive, found {width}x{height}"));
        }
        if !(aperture >= 0.0 && aperture.is_finite()) {
            return Err(format!("the aperture must be zero or positive, found {aperture}"));
        }
        let focus = focus.unwrap_or((to - from).length());
        if !(focus > 0.0 && focus.is_finite()) {
            return Err(format!("the focus distance must be positive, found {focus}"));
        }
        let t = (fov.to_radians() / 2.0).tan();
        let true_up = right.cross(forward);
        let (w, h) = (width as f32, height as f32);
        Ok(Camera {
            eye: from,
            forward,
            right: right * t,
            up: true_up * (t * h / w),
            width: w,
            height: h,
            lens_radius: aperture,
            focus,
        })
    }

    /// The direction (not normalised) through image position `(px, py)`.
    fn direction(&self, px: f32, py: f32) -> Vec3 {
        self.forward + (2.0 * px / self.width - 1.0) * self.right + (1.0 - 2.0 * py / self.height) * self.up
    }

    /// The ray through image position `(px, py)`; `lens` in [0, 1)^2
    /// picks the point on the lens (ignored by a pinhole). The direction is
    /// unit length.
    pub fn ray(&self, px: f32, py: f32, lens: [f32; 2]) -> Ray {
        let d = self.direction(px, py);
        if self.lens_radius == 0.0 {
            return Ray::new(self.eye, d.normalize());
        }
        // Thin lens: every ray through the same pixel meets at the plane in
        // focus, at distance `focus` along the view axis.
        let focal_point = self.eye + d * self.focus;
        let [dx, dy] = super::sampling::square_to_uniform_disk_concentric(lens);
        let r = self.right.normalize();
        let u = self.up.normalize();
        let origin = self.eye + self.lens_radius * (dx * r + dy * u);
        Ray::new(origin, (focal_point - origin).normalize())
    }

    /// How far a unit-length camera ray's direction moves from one pixel to
    /// the next (the smaller of x and y): the angular footprint of a pixel.
    pub fn pixel_spread(&self) -> f32 {
        let dx = 2.0 * self.right.length() / self.width;
        let dy = 2.0 * self.up.length() / self.height;
        dx.min(dy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec_camera() -> Camera {
        // The `whitted` benchmark camera.
        Camera::new(Vec3::new(0.0, 1.5, 5.0), Vec3::new(0.0, 0.8, 0.0), Vec3::Y, 45.0, (512, 512), 0.0, None).unwrap()
    }

    #[test]
    fn the_centre_ray_looks_at_the_target_and_x_is_right() {
        let c = spec_camera();
        let r = c.ray(256.0, 256.0, [0.5, 0.5]);
        let f = (Vec3::new(0.0, 0.8, 0.0) - Vec3::new(0.0, 1.5, 5.0)).normalize();
        assert!((r.dir - f).length() < 1e-6);
        // The right edge of the image looks toward +x (world), the top up.
        assert!(c.ray(512.0, 256.0, [0.5, 0.5]).dir.x > 0.0);
        assert!(c.ray(256.0, 0.0, [0.5, 0.5]).dir.y > r.dir.y);
    }

    #[test]
    fn the_horizontal_field_of_view_spans_the_width() {
        let c = spec_camera();
        let (l, r) = (c.ray(0.0, 256.0, [0.5; 2]).dir, c.ray(512.0, 256.0, [0.5; 2]).dir);
        assert!((l.angle_between(r).to_degrees() - 45.0).abs() < 1e-3);
        // A wide image keeps the horizontal angle and narrows the vertical.
        let w = Camera::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90.0, (200, 100), 0.0, None).unwrap();
        let (t, b) = (w.ray(100.0, 0.0, [0.5; 2]).dir, w.ray(100.0, 100.0, [0.5; 2]).dir);
        assert!((t.angle_between(b).to_degrees() - 2.0 * 0.5f32.atan().to_degrees()).abs() < 1e-3);
    }

    #[test]
    fn thin_lens_rays_meet_at_the_focus_distance() {
        let c = Camera::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 40.0, (64, 64), 0.2, Some(3.0)).unwrap();
        let a = c.ray(10.0, 20.0, [0.1, 0.9]);
        let b = c.ray(10.0, 20.0, [0.8, 0.3]);
        assert!(a.origin != b.origin);
        let ta = -3.0 / a.dir.z;
        let tb = -3.0 / b.dir.z;
        assert!((a.at(ta) - b.at(tb)).length() < 1e-4);
    }

    #[test]
    fn degenerate_cameras_are_errors() {
        let e = |r: Result<Camera, String>| r.unwrap_err();
        assert!(e(Camera::new(Vec3::ONE, Vec3::ONE, Vec3::Y, 40.0, (8, 8), 0.0, None)).contains("differ"));
        assert!(e(Camera::new(Vec3::ZERO, Vec3::Y, Vec3::Y, 40.0, (8, 8), 0.0, None)).contains("parallel"));
        assert!(e(Camera::new(Vec3::ZERO, Vec3::Z, Vec3::Y, 180.0, (8, 8), 0.0, None)).contains("180"));
        assert!(e(Camera::new(Vec3::ZERO, Vec3::Z, Vec3::Y, 40.0, (0, 8), 0.0, None)).contains("size"));
    }
}
