//! Ray–triangle intersection: Möller–Trumbore (MT97) (TP4 question 1) and the watertight
//! test of Woop, Benthin and Wald (JCGT 2013).
//!
//! Both return `t` and the barycentrics `(u, v)` of Möller–Trumbore: the hit point is
//! `(1-u-v)·v0 + u·v1 + v·v2`. Both faces are hit (no culling), as in the course.
//! Every comparison is written so that NaN is a miss.

use crate::math::ray::Ray;
use glam::Vec3;

/// Which ray–triangle test a mesh uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TriangleTest {
    /// Möller–Trumbore (the course's; the fastest).
    #[default]
    MollerTrumbore,
    /// Woop–Benthin–Wald: no ray slips between two triangles sharing an edge.
    Watertight,
}

/// Distance and barycentrics of a ray–triangle hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Ray parameter.
    pub t: f32,
    /// Weight of `v1`.
    pub u: f32,
    /// Weight of `v2`.
    pub v: f32,
}

/// Möller–Trumbore with the edges precomputed: `e1 = v1 - v0`, `e2 = v2 - v0`.
///
/// Accepts `t_min <= t < t_max`. The arithmetic is written out in a fixed order so that
/// the SIMD versions in [`crate::accel::wide`] give bit-identical results.
#[inline(always)]
#[must_use]
pub fn moller_trumbore_edges(ray: &Ray, v0: Vec3, e1: Vec3, e2: Vec3, t_min: f32, t_max: f32) -> Option<TriangleHit> {
    let d = ray.direction;
    let p = cross(d, e2);
    let det = dot(e1, p);
    if det == 0.0 {
        return None; // ray parallel to the plane, or a degenerate triangle
    }
    let inv = 1.0 / det;
    let s = ray.origin - v0;
    let u = dot(s, p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    if !(v >= 0.0 && u + v <= 1.0) {
        return None;
    }
    let t = dot(e2, q) * inv;
    if t >= t_min && t < t_max {
        Some(TriangleHit { t, u, v })
    } else {
        None
    }
}

/// Möller–Trumbore on the triangle's three vertices.
#[inline]
#[must_use]
pub fn moller_trumbore(ray: &Ray, v0: Vec3, v1: Vec3, v2: Vec3, t_min: f32, t_max: f32) -> Option<TriangleHit> {
    moller_trumbore_edges(ray, v0, v1 - v0, v2 - v0, t_min, t_max)
}

#[inline(always)]
fn cross(a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x)
}

#[inline(always)]
fn dot(a: Vec3, b: Vec3) -> f32 {
    a.x * b.x + a.y * b.y + a.z * b.z
}

/// The per-ray part of the watertight test: the axis permutation and the shear.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    origin: Vec3,
    k: [usize; 3],
    shear: Vec3,
}

impl WatertightRay {
    /// Precompute for `ray` (whose direction must not be zero).
    #[must_use]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.direction;
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky); // keep the winding
        }
        let shear = Vec3::new(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
        Self { origin: ray.origin, k: [kx, ky, kz], shear }
    }

    /// The watertight test: a ray through a shared edge or vertex of a closed mesh hits at
    /// least one of the triangles around it.
    #[must_use]
    pub fn intersect(&self, v0: Vec3, v1: Vec3, v2: Vec3, t_min: f32, t_max: f32) -> Option<TriangleHit> {
        let [kx, ky, kz] = self.k;
        let (sx, sy, sz) = (self.shear.x, self.shear.y, self.shear.z);
        let a = v0 - self.origin;
        let b = v1 - self.origin;
        let c = v2 - self.origin;
        let ax = a[kx] - sx * a[kz];
        let ay = a[ky] - sy * a[kz];
        let bx = b[kx] - sx * b[kz];
        let by = b[ky] - sy * b[kz];
        let cx = c[kx] - sx * c[kz];
        let cy = c[ky] - sy * c[kz];
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // On an edge in single precision: decide in double precision.
            let (ax, ay, bx, by, cx, cy) = (ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64);
            u = (cx * by - cy * bx) as f32;
            v = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || det.is_nan() {
            return None;
        }
        let az = sz * a[kz];
        let bz = sz * b[kz];
        let cz = sz * c[kz];
        let t_scaled = u * az + v * bz + w * cz;
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        if t >= t_min && t < t_max {
            Some(TriangleHit { t, u: v * inv, v: w * inv })
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const V0: Vec3 = Vec3::new(0.0, 0.0, 0.0);
    const V1: Vec3 = Vec3::new(1.0, 0.0, 0.0);
    const V2: Vec3 = Vec3::new(0.0, 1.0, 0.0);

    fn both(ray: &Ray, t_min: f32, t_max: f32) -> (Option<TriangleHit>, Option<TriangleHit>) {
        (moller_trumbore(ray, V0, V1, V2, t_min, t_max), WatertightRay::new(ray).intersect(V0, V1, V2, t_min, t_max))
    }

    #[test]
    fn hand_computed_hit() {
        // Through (0.25, 0.5, 0) from z = -2 along +z: t = 2, u = 0.25 (weight of v1), v = 0.5.
        let ray = Ray::new(Vec3::new(0.25, 0.5, -2.0), Vec3::Z);
        for hit in [both(&ray, 0.0, f32::INFINITY).0, both(&ray, 0.0, f32::INFINITY).1] {
            let h = hit.expect("hit");
            assert!((h.t - 2.0).abs() < 1e-6 && (h.u - 0.25).abs() < 1e-6 && (h.v - 0.5).abs() < 1e-6, "{h:?}");
        }
        // A direction of length 2 halves t.
        let ray = Ray::new(Vec3::new(0.25, 0.5, -2.0), Vec3::new(0.0, 0.0, 2.0));
        assert!((both(&ray, 0.0, f32::INFINITY).0.unwrap().t - 1.0).abs() < 1e-6);
    }

    #[test]
    fn hit_point_matches_barycentrics() {
        let (a, b, c) = (Vec3::new(-1.0, 2.0, 3.0), Vec3::new(4.0, -1.0, 2.5), Vec3::new(0.5, 3.0, -2.0));
        let o = Vec3::new(0.3, 0.2, -9.0);
        let target = 0.2 * a + 0.5 * b + 0.3 * c;
        let ray = Ray::new(o, target - o);
        let mt = moller_trumbore(&ray, a, b, c, 0.0, f32::INFINITY).unwrap();
        let wt = WatertightRay::new(&ray).intersect(a, b, c, 0.0, f32::INFINITY).unwrap();
        for h in [mt, wt] {
            let p = (1.0 - h.u - h.v) * a + h.u * b + h.v * c;
            assert!((p - ray.at(h.t)).length() < 1e-4, "{h:?}");
            assert!((h.u - 0.5).abs() < 1e-5 && (h.v - 0.3).abs() < 1e-5 && (h.t - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn back_faces_are_hit() {
        let ray = Ray::new(Vec3::new(0.25, 0.25, 2.0), -Vec3::Z);
        let (mt, wt) = both(&ray, 0.0, f32::INFINITY);
        assert!((mt.unwrap().t - 2.0).abs() < 1e-6);
        assert!((wt.unwrap().t - 2.0).abs() < 1e-6);
    }

    #[test]
    fn misses_outside_behind_and_beyond() {
        let outside = Ray::new(Vec3::new(0.75, 0.75, -1.0), Vec3::Z);
        assert_eq!(both(&outside, 0.0, f32::INFINITY), (None, None));
        let behind = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::Z);
        assert_eq!(both(&behind, 0.0, f32::INFINITY), (None, None));
        let short = Ray::new(Vec3::new(0.25, 0.25, -1.0), Vec3::Z);
        assert_eq!(both(&short, 0.0, 0.5), (None, None));
    }

    #[test]
    fn parallel_and_grazing_rays_miss() {
        // In the plane of the triangle, through its interior: parallel, no hit.
        let inplane = Ray::new(Vec3::new(-1.0, 0.25, 0.0), Vec3::X);
        assert_eq!(both(&inplane, 0.0, f32::INFINITY), (None, None));
        // Parallel above the plane.
        let above = Ray::new(Vec3::new(-1.0, 0.25, 1.0), Vec3::X);
        assert_eq!(both(&above, 0.0, f32::INFINITY), (None, None));
        // Grazing: almost parallel, crossing the plane far outside the triangle.
        let grazing = Ray::new(Vec3::new(-1.0, 0.25, -1e-3), Vec3::new(1.0, 0.0, 1e-6));
        assert_eq!(both(&grazing, 0.0, f32::INFINITY), (None, None));
        // Grazing and crossing inside: still a correct hit.
        let grazing_in = Ray::new(Vec3::new(0.0, 0.25, -1e-4), Vec3::new(1.0, 0.0, 1e-3));
        let h = both(&grazing_in, 0.0, f32::INFINITY).0.expect("grazing hit");
        assert!((h.t - 0.1).abs() < 1e-4 && (h.u - 0.1).abs() < 1e-3, "{h:?}");
    }

    #[test]
    fn degenerate_triangles_and_nan_rays_never_hit() {
        let ray = Ray::new(Vec3::new(0.25, 0.25, -1.0), Vec3::Z);
        assert_eq!(moller_trumbore(&ray, V0, V0, V2, 0.0, f32::INFINITY), None);
        assert_eq!(moller_trumbore(&ray, V0, V1, 2.0 * V1, 0.0, f32::INFINITY), None);
        let nan = Ray::new(Vec3::new(0.25, f32::NAN, -1.0), Vec3::Z);
        assert_eq!(both(&nan, 0.0, f32::INFINITY), (None, None));
        let nan_tri = Vec3::new(f32::NAN, 0.0, 0.0);
        assert_eq!(moller_trumbore(&ray, nan_tri, V1, V2, 0.0, f32::INFINITY), None);
    }

    #[test]
    fn watertight_on_shared_edges() {
        // A square of two triangles sharing the diagonal; rays exactly on the diagonal
        // and on the shared vertex must hit one of them.
        let (a, b, c, d) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        for i in 0..=64 {
            let s = i as f32 / 64.0;
            let ray = Ray::new(Vec3::new(s, s, -1.0), Vec3::new(0.0, 0.0, 1.0));
            let w = WatertightRay::new(&ray);
            let hit = w.intersect(a, b, c, 0.0, f32::INFINITY).or(w.intersect(a, c, d, 0.0, f32::INFINITY));
            assert!(hit.is_some(), "gap at s = {s}");
        }
    }
}
