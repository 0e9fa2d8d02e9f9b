//! Sphere (centre, radius).

use crate::math::ray::{gamma, Ray};
use glam::Vec3;

/// A sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius.
    pub radius: f32,
}

impl Sphere {
    /// A sphere of `radius` about `center`.
    #[must_use]
    pub fn new(center: Vec3, radius: f32) -> Self {
        Self { center, radius }
    }

    /// The nearest `t` in `[t_min, t_max)` where the ray meets the sphere.
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        let oc = ray.origin - self.center;
        let a = ray.direction.length_squared();
        let half_b = oc.dot(ray.direction);
        let c = oc.length_squared() - self.radius * self.radius;
        let disc = half_b * half_b - a * c;
        if disc.is_nan() || disc < 0.0 || a == 0.0 {
            return None;
        }
        let sq = disc.sqrt();
        [(-half_b - sq) / a, (-half_b + sq) / a].into_iter().find(|&t| t >= t_min && t < t_max)
    }

    /// The point where the ray meets the sphere at `t`, and a bound on its error per axis:
    /// `o + t·d` pulled back onto the sphere along its radius (pbrt-v4 §6.8.5: the
    /// reprojected point is within `γ(5)` of its magnitude about the centre), plus the
    /// rounding of adding the centre back.
    #[must_use]
    pub fn surface_point(&self, ray: &Ray, t: f32) -> (Vec3, Vec3) {
        let mut local = ray.at(t) - self.center;
        let len = local.length();
        if len > 0.0 {
            local *= self.radius / len;
        }
        let p = self.center + local;
        (p, gamma(5) * local.abs() + gamma(1) * p.abs())
    }

    /// Outward unit normal at a point of the sphere.
    #[must_use]
    pub fn normal(&self, p: Vec3) -> Vec3 {
        (p - self.center) / self.radius
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_front_then_back() {
        let s = Sphere::new(Vec3::new(0.0, 0.0, 3.0), 1.0);
        let r = Ray::new(Vec3::ZERO, Vec3::Z);
        assert_eq!(s.intersect(&r, 0.0, f32::INFINITY), Some(2.0));
        assert_eq!(s.intersect(&r, 2.5, f32::INFINITY), Some(4.0));
        assert_eq!(s.intersect(&r, 0.0, 1.0), None);
        assert_eq!(s.intersect(&Ray::new(Vec3::ZERO, Vec3::Y), 0.0, f32::INFINITY), None);
        assert_eq!(s.normal(Vec3::new(0.0, 0.0, 2.0)), -Vec3::Z);
    }
}
