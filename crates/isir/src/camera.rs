//! The course's perspective pinhole camera.
//!
//! Basis `w = normalize(position - look_at)`, `u = normalize(up × w)`, `v = w × u`;
//! viewport height `2·tan(fovy/2)·focal`, width `height·aspect`; screen coordinates
//! `(sx, sy) ∈ [0,1]²` with row 0 at the top. Looking down +z from (0,0,-6), world +x is on
//! the **left** of the image, as in the course.

use crate::ray::Ray;
use glam::Vec3;

/// A perspective camera with focal distance 1.
#[derive(Clone, Debug)]
pub struct Camera {
    position: Vec3,
    top_left: Vec3,
    viewport_u: Vec3,
    viewport_v: Vec3,
}

impl Camera {
    /// A camera at `position` looking at `look_at`, vertical field of view `fovy_degrees`,
    /// `aspect` = width / height.
    #[must_use]
    pub fn new(position: Vec3, look_at: Vec3, up: Vec3, fovy_degrees: f32, aspect: f32) -> Self {
        let focal = 1.0;
        let w = (position - look_at).normalize();
        let u = up.cross(w).normalize();
        let v = w.cross(u);
        let height = 2.0 * (fovy_degrees.to_radians() * 0.5).tan() * focal;
        let width = height * aspect;
        let top_left = position - w * focal + v * height * 0.5 - u * width * 0.5;
        Self { position, top_left, viewport_u: u * width, viewport_v: v * height }
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
        let target = self.top_left + sx * self.viewport_u - sy * self.viewport_v;
        Ray::new(self.position, (target - self.position).normalize())
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
}
