//! Axis-aligned bounding box ("boîte min-max", TP4 exercise 2).

use crate::math::ray::Ray;
use glam::Vec3;

/// An axis-aligned box from `min` to `max`. The empty box has `min = +∞`, `max = -∞`,
/// so that extending it by anything gives that thing's box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The empty box.
    pub const EMPTY: Self = Self { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    /// The box from two corners.
    #[must_use]
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    /// Grow to contain `p`. Non-finite components are ignored (`f32::min` skips NaN).
    #[inline]
    pub fn extend(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Grow to contain `other`.
    #[inline]
    pub fn extend_aabb(&mut self, other: &Aabb) {
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
    }

    /// The union of two boxes.
    #[inline]
    #[must_use]
    pub fn union(mut self, other: &Aabb) -> Aabb {
        self.extend_aabb(other);
        self
    }

    /// True when the box contains nothing.
    #[inline]
    #[must_use]
    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }

    /// True when the box holds something and its corners are finite: a box a BVH can use.
    #[inline]
    #[must_use]
    pub fn is_finite_nonempty(&self) -> bool {
        !self.is_empty() && self.min.is_finite() && self.max.is_finite()
    }

    /// The centre of the box.
    #[inline]
    #[must_use]
    pub fn centroid(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// The vector from `min` to `max`.
    #[inline]
    #[must_use]
    pub fn diagonal(&self) -> Vec3 {
        self.max - self.min
    }

    /// The axis (0 = x, 1 = y, 2 = z) along which the box is longest.
    #[inline]
    #[must_use]
    pub fn largest_axis(&self) -> usize {
        let d = self.diagonal();
        if d.x >= d.y && d.x >= d.z {
            0
        } else if d.y >= d.z {
            1
        } else {
            2
        }
    }

    /// Half the surface area (the SAH only needs ratios); 0 for an empty box.
    #[inline]
    #[must_use]
    pub fn half_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.diagonal();
        d.x * d.y + d.y * d.z + d.z * d.x
    }

    /// Slab test: the parameter interval `[t0, t1]` where the ray is inside the box, clipped
    /// to `[t_min, t_max]`, or `None`. Rays with NaN components must be filtered by the
    /// caller ([`Ray::is_valid`]).
    #[inline]
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<(f32, f32)> {
        let inv = ray.direction.recip();
        let a = (self.min - ray.origin) * inv;
        let b = (self.max - ray.origin) * inv;
        let t0 = a.min(b).max_element().max(t_min);
        let t1 = a.max(b).min_element().min(t_max);
        if t0 <= t1 {
            Some((t0, t1))
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extend_centroid_and_axis() {
        let mut b = Aabb::EMPTY;
        assert!(b.is_empty());
        b.extend(Vec3::new(1.0, 2.0, 3.0));
        b.extend(Vec3::new(-1.0, 0.0, 7.0));
        assert_eq!(b.min, Vec3::new(-1.0, 0.0, 3.0));
        assert_eq!(b.max, Vec3::new(1.0, 2.0, 7.0));
        assert_eq!(b.centroid(), Vec3::new(0.0, 1.0, 5.0));
        assert_eq!(b.largest_axis(), 2);
        assert_eq!(b.half_area(), 2.0 * 2.0 + 2.0 * 4.0 + 4.0 * 2.0);
    }

    #[test]
    fn slab_test() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let r = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z);
        assert_eq!(b.intersect(&r, 0.0, f32::INFINITY), Some((4.0, 6.0)));
        assert_eq!(b.intersect(&r, 0.0, 3.0), None);
        let miss = Ray::new(Vec3::new(2.0, 0.0, -5.0), Vec3::Z);
        assert_eq!(b.intersect(&miss, 0.0, f32::INFINITY), None);
    }
}
