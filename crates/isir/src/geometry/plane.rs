//! Infinite plane (a point and a normal).

use crate::math::ray::{gamma, Ray};
use glam::Vec3;

/// An infinite plane through `point` with unit `normal`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// A point of the plane.
    pub point: Vec3,
    /// Its unit normal.
    pub normal: Vec3,
}

impl Plane {
    /// The plane through `point` with normal `normal` (normalized here).
    #[must_use]
    pub fn new(point: Vec3, normal: Vec3) -> Self {
        Self { point, normal: normal.normalize() }
    }

    /// `t` in `[t_min, t_max)` where the ray meets the plane; none when parallel.
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        let denom = ray.direction.dot(self.normal);
        if denom == 0.0 {
            return None;
        }
        let t = (self.point - ray.origin).dot(self.normal) / denom;
        (t >= t_min && t < t_max).then_some(t)
    }

    /// The point where the ray meets the plane at `t`, and a bound on its error per axis:
    /// `o + t·d` projected back onto the plane along its normal, within the rounding of the
    /// projection (a few ULPs of the magnitudes involved, bounded by `γ(8)`).
    #[must_use]
    pub fn surface_point(&self, ray: &Ray, t: f32) -> (Vec3, Vec3) {
        let q = ray.at(t);
        let rel = q - self.point;
        let p = q - self.normal * rel.dot(self.normal);
        (p, gamma(8) * (p.abs() + self.point.abs() + Vec3::splat(rel.abs().max_element())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_sides_and_parallel() {
        let p = Plane::new(Vec3::new(0.0, -3.0, 0.0), Vec3::Y);
        assert_eq!(p.intersect(&Ray::new(Vec3::ZERO, -Vec3::Y), 0.0, f32::INFINITY), Some(3.0));
        assert_eq!(p.intersect(&Ray::new(Vec3::new(0.0, -5.0, 0.0), Vec3::Y), 0.0, f32::INFINITY), Some(2.0));
        assert_eq!(p.intersect(&Ray::new(Vec3::ZERO, Vec3::X), 0.0, f32::INFINITY), None);
        assert_eq!(p.intersect(&Ray::new(Vec3::ZERO, Vec3::Y), 0.0, f32::INFINITY), None);
    }
}
