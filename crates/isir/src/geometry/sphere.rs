//! Sphere (centre, radius).

use crate::math::ray::{gamma, lane_mask, Ray, RayLanes, LANES};
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

    /// A finite centre and a positive, finite radius: a sphere rays can meet (a negative
    /// radius shades its centre black, or vanishes under the scene BVH).
    #[must_use]
    pub fn is_traceable(&self) -> bool {
        self.center.is_finite() && self.radius.is_finite() && self.radius > 0.0
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
        let inside = |t: f32| t >= t_min && t < t_max;
        // The far root only when the near one is out of the interval (a division saved).
        let near = (-half_b - sq) / a;
        if inside(near) {
            return Some(near);
        }
        let far = (-half_b + sq) / a;
        inside(far).then_some(far)
    }

    /// Which of the rays `rays` meet the sphere in their interval: bit `k` for lane `k`, the
    /// answers of [`Sphere::intersect`] (the same operations lane by lane, vectorised).
    /// PERF: its own loop rather than `closest_lanes` on a copy of `t_max` (the same
    /// answers): that form, which also keeps each lane's `t`, made tp3-quad-soft 12% and
    /// tp4-sphere 9% slower (64 spp, medians of 7).
    #[must_use]
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    pub fn hit_lanes(&self, rays: &RayLanes) -> u32 {
        let Some(q) = self.quadratic_lanes(rays) else { return 0 };
        let mut hit = [false; LANES];
        for k in 0..LANES {
            let sq = q.disc[k].sqrt();
            let (t0, t1) = ((-q.half_b[k] - sq) / q.a[k], (-q.half_b[k] + sq) / q.a[k]);
            let (lo, hi) = (rays.t_min[k], rays.t_max[k]);
            hit[k] = ((t0 >= lo) & (t0 < hi)) | ((t1 >= lo) & (t1 < hi));
        }
        q.ok & lane_mask(&hit)
    }

    /// The quadratic of [`Sphere::intersect`] for every lane (`a`, `half_b` and the
    /// discriminant, by the same operations), and the mask of the lanes whose line meets
    /// the sphere; `None` when no lane's does.
    /// PERF: the square roots and divisions only when some lane needs them: a point's
    /// shadow rays towards a quad light mostly all miss a sphere (in `hit_lanes`:
    /// tp6-matte-quad 0.961, tp6-mirror-quad 0.956, tp3-quad-soft 0.978), and so do a
    /// pixel's camera rays (in `closest_lanes` too: tp1-sphere 0.955, tp5-phong 0.975;
    /// medians of 7, the same images).
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    fn quadratic_lanes(&self, rays: &RayLanes) -> Option<QuadraticLanes> {
        let (ctr, r2) = (self.center, self.radius * self.radius);
        let mut q = QuadraticLanes { a: [0.0; LANES], half_b: [0.0; LANES], disc: [0.0; LANES], ok: 0 };
        let mut ok = [false; LANES];
        for k in 0..LANES {
            let oc = [rays.o[0][k] - ctr.x, rays.o[1][k] - ctr.y, rays.o[2][k] - ctr.z];
            let d = [rays.d[0][k], rays.d[1][k], rays.d[2][k]];
            q.a[k] = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            q.half_b[k] = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
            let c = (oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2]) - r2;
            q.disc[k] = q.half_b[k] * q.half_b[k] - q.a[k] * c;
            ok[k] = (q.disc[k] >= 0.0) & (q.a[k] != 0.0);
        }
        q.ok = lane_mask(&ok);
        (q.ok != 0).then_some(q)
    }

    /// Closest hits of the rays `rays`: each lane `k` whose ray meets the sphere in
    /// `[t_min[k], t_best[k])` gets the nearest such `t` in `t_best[k]` and its bit set in
    /// the result. The `t` of [`Sphere::intersect`], by the same operations lane by lane,
    /// vectorised. `t_best` holds no NaN (see [`crate::geometry::Plane::closest_lanes`]).
    /// PERF: the conditions are joined with `&` and `|`, not `&&` and `||`: the
    /// short-circuits became branches and LLVM kept the loop scalar (tp4-sphere, 64 spp:
    /// 0.99 s → 0.87 s with both shapes' lane loops vectorised).
    #[must_use]
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    pub fn closest_lanes(&self, rays: &RayLanes, t_best: &mut [f32; LANES]) -> u32 {
        let Some(q) = self.quadratic_lanes(rays) else { return 0 };
        let mut hit = [false; LANES];
        for k in 0..LANES {
            let ok = q.ok & (1 << k) != 0;
            let sq = q.disc[k].sqrt();
            let (t0, t1) = ((-q.half_b[k] - sq) / q.a[k], (-q.half_b[k] + sq) / q.a[k]);
            let (lo, hi) = (rays.t_min[k], t_best[k]);
            let (in0, in1) = ((t0 >= lo) & (t0 < hi), (t1 >= lo) & (t1 < hi));
            hit[k] = ok & (in0 | in1);
            let t = if in0 { t0 } else { t1 };
            // A minimum, not a select of the old best: see `Plane::closest_lanes`.
            let cand = if hit[k] { t } else { f32::INFINITY };
            t_best[k] = hi.min(cand);
        }
        lane_mask(&hit)
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

/// The quadratic of a sphere's test for [`LANES`] rays ([`Sphere::quadratic_lanes`]).
struct QuadraticLanes {
    a: [f32; LANES],
    half_b: [f32; LANES],
    disc: [f32; LANES],
    /// The lanes whose discriminant is a number `>= 0` and `a` not zero.
    ok: u32,
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

    /// `hit_lanes` answers as `intersect` on each lane (see `check_hit_lanes`).
    #[test]
    fn hit_lanes_answers_as_intersect() {
        let shape = Sphere { center: Vec3::new(0.5, -0.25, 3.0), radius: 1.5 };
        crate::math::ray::check_hit_lanes(|lanes| shape.hit_lanes(lanes), |ray, t_min, t_max| shape.intersect(ray, t_min, t_max).is_some());
    }

    /// `closest_lanes` gives each lane the `t` of `intersect` (see `check_closest_lanes`).
    #[test]
    fn closest_lanes_are_the_hits_of_intersect() {
        let shape = Sphere { center: Vec3::new(0.5, -0.25, 3.0), radius: 1.5 };
        crate::math::ray::check_closest_lanes(
            |lanes, t| shape.closest_lanes(lanes, t),
            |ray, t_min, t_max| shape.intersect(ray, t_min, t_max),
        );
    }
}
