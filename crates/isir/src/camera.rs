//! The course's perspective pinhole camera.
//!
//! Basis `w = normalize(position - look_at)`, `u = normalize(up × w)`, `v = w × u`;
//! viewport height `2·tan(fovy/2)·focal`, width `height·aspect`; screen coordinates
//! `(sx, sy) ∈ [0,1]²` with row 0 at the top. Looking down +z from (0,0,-6), world +x is on
//! the **left** of the image, as in the course.

use crate::math::ray::Ray;
use glam::Vec3;

/// A perspective camera with focal distance 1.
#[derive(Clone, Debug)]
pub struct Camera {
    position: Vec3,
    /// The top-left corner of the viewport relative to the position: directions are formed
    /// without adding and subtracting the position, which would round them to its ULPs (a
    /// camera a few 1e7 units from the origin gave NaN rays).
    to_top_left: Vec3,
    viewport_u: Vec3,
    viewport_v: Vec3,
}

impl Camera {
    /// A camera at `position` looking at `look_at`, vertical field of view `fovy_degrees`,
    /// `aspect` = width / height.
    #[must_use]
    pub fn new(position: Vec3, look_at: Vec3, up: Vec3, fovy_degrees: f32, aspect: f32) -> Self {
        let focal = 1.0;
        // Scaled before normalizing: the squared length overflows beyond ~1e19.
        let to_eye = position - look_at;
        let w = (to_eye / to_eye.abs().max_element()).normalize();
        let u = up.cross(w).normalize();
        let v = w.cross(u);
        let height = 2.0 * (fovy_degrees.to_radians() * 0.5).tan() * focal;
        let width = height * aspect;
        let to_top_left = -w * focal + v * height * 0.5 - u * width * 0.5;
        Self { position, to_top_left, viewport_u: u * width, viewport_v: v * height }
    }

    /// The camera's position.
    #[must_use]
    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// The ray through screen coordinates `(sx, sy) ∈ [0,1]²`, row 0 at the top;
    /// its direction is normalized.
    #[inline]
    #[must_use]
    pub fn generate_ray(&self, sx: f32, sy: f32) -> Ray {
        let direction = self.to_top_left + sx * self.viewport_u - sy * self.viewport_v;
        Ray::new(self.position, direction.normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_at_target_and_plus_x_is_left() {
        let cam = Camera::new(Vec3::new(0.0, 0.0, -6.0), Vec3::new(0.0, 0.0, 79.0), Vec3::Y, 60.0, 1.5);
        let c = cam.generate_ray(0.5, 0.5);
        assert!((c.direction - Vec3::Z).length() < 1e-6);
        let left = cam.generate_ray(0.0, 0.5);
        assert!(left.direction.x > 0.0, "the left of the image looks towards +x");
        let top = cam.generate_ray(0.5, 0.0);
        assert!(top.direction.y > 0.0, "row 0 is the top");
        // Half the vertical field of view: 30 degrees.
        assert!((top.direction.y.atan2(top.direction.z).to_degrees() - 30.0).abs() < 1e-3);
    }

    #[test]
    fn rays_stay_finite_and_distinct_far_from_the_origin() {
        for far in [1e7f32, 1e12, 1e20, 1e30] {
            let p = Vec3::new(far, -far, 0.5 * far);
            let cam = Camera::new(p, p + Vec3::new(1.0, 2.0, 3.0) * far * 1e-3, Vec3::Y, 60.0, 1.5);
            let (a, b) = (cam.generate_ray(0.5, 0.5), cam.generate_ray(0.501, 0.5));
            assert!(a.is_valid() && b.is_valid(), "{far}: {a:?}");
            assert!((a.direction - Vec3::new(1.0, 2.0, 3.0).normalize()).length() < 1e-3, "{far}: {a:?}");
            assert!(a.direction != b.direction, "{far}: neighbouring pixels share a direction");
        }
    }
}
