//! Infinite plane (a point and a normal).

use crate::math::ray::{gamma, lane_mask, Ray, RayLanes, LANES};
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

    /// Which of the rays `rays` meet the plane in their interval: bit `k` for lane `k`, the
    /// answers of [`Plane::intersect`] (the same operations lane by lane, vectorised).
    /// PERF: its own loop rather than `closest_lanes` on a copy of `t_max` (the same
    /// answers): that form, which also keeps each lane's `t`, made tp3-quad-soft 12% and
    /// tp4-sphere 9% slower (64 spp, medians of 7).
    #[must_use]
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    pub fn hit_lanes(&self, rays: &RayLanes) -> u32 {
        let (p, n) = (self.point, self.normal);
        let mut hit = [false; LANES];
        for k in 0..LANES {
            let (o, d) = ([rays.o[0][k], rays.o[1][k], rays.o[2][k]], [rays.d[0][k], rays.d[1][k], rays.d[2][k]]);
            let denom = d[0] * n.x + d[1] * n.y + d[2] * n.z;
            let t = ((p.x - o[0]) * n.x + (p.y - o[1]) * n.y + (p.z - o[2]) * n.z) / denom;
            hit[k] = (denom != 0.0) & (t >= rays.t_min[k]) & (t < rays.t_max[k]);
        }
        lane_mask(&hit)
    }

    /// [`Plane::hit_lanes`] written with AVX2 intrinsics: the same operations in the same
    /// order (no FMA), eight lanes at a time, the lanes' answers gathered with
    /// `vmovmskps`.
    /// PERF: from the compiler's vectorised loop, the flags went through packs, a store and
    /// multiplications into a mask (`lane_mask`), 12% of `Scene::occluded_lanes` on
    /// tp6-matte-quad.
    ///
    /// # Safety
    /// Call it only where the CPU has AVX2 (`is_x86_feature_detected!("avx2")`).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[must_use]
    #[inline]
    pub fn hit_lanes_avx2(&self, rays: &RayLanes) -> u32 {
        use std::arch::x86_64::{
            _mm256_add_ps, _mm256_and_ps, _mm256_cmp_ps, _mm256_div_ps, _mm256_loadu_ps, _mm256_movemask_ps, _mm256_mul_ps, _mm256_set1_ps,
            _mm256_setzero_ps, _mm256_sub_ps, _CMP_GE_OQ, _CMP_LT_OQ, _CMP_NEQ_UQ,
        };
        let (p, n) = (self.point, self.normal);
        let (nx, ny, nz) = (_mm256_set1_ps(n.x), _mm256_set1_ps(n.y), _mm256_set1_ps(n.z));
        let (px, py, pz) = (_mm256_set1_ps(p.x), _mm256_set1_ps(p.y), _mm256_set1_ps(p.z));
        let mut mask = 0;
        for half in 0..LANES / 8 {
            // SAFETY: eight floats from `8 * half` of sixteen-float arrays, in bounds.
            let at = |a: &[f32; LANES]| unsafe { _mm256_loadu_ps(a.as_ptr().add(8 * half)) };
            let (ox, oy, oz) = (at(&rays.o[0]), at(&rays.o[1]), at(&rays.o[2]));
            let (dx, dy, dz) = (at(&rays.d[0]), at(&rays.d[1]), at(&rays.d[2]));
            let denom = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, nx), _mm256_mul_ps(dy, ny)), _mm256_mul_ps(dz, nz));
            let num = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(_mm256_sub_ps(px, ox), nx), _mm256_mul_ps(_mm256_sub_ps(py, oy), ny)),
                _mm256_mul_ps(_mm256_sub_ps(pz, oz), nz),
            );
            let t = _mm256_div_ps(num, denom);
            // `denom != 0.0` (true for NaN), `t >= t_min`, `t < t_max` (false for NaN).
            let hit = _mm256_and_ps(
                _mm256_and_ps(_mm256_cmp_ps::<_CMP_NEQ_UQ>(denom, _mm256_setzero_ps()), _mm256_cmp_ps::<_CMP_GE_OQ>(t, at(&rays.t_min))),
                _mm256_cmp_ps::<_CMP_LT_OQ>(t, at(&rays.t_max)),
            );
            mask |= (_mm256_movemask_ps(hit) as u32) << (8 * half);
        }
        mask
    }

    /// Closest hits of the rays `rays`: each lane `k` whose ray meets the plane in
    /// `[t_min[k], t_best[k])` gets that `t` in `t_best[k]` and its bit set in the result.
    /// The `t` of [`Plane::intersect`], by the same operations lane by lane, vectorised.
    /// `t_best` holds no NaN ([`crate::Scene::intersect_lanes`] starts a NaN `t_max`'s lane
    /// at -∞, an empty interval, as it does an invalid ray's).
    /// PERF: the conditions are joined with `&` and `|`, not `&&` and `||`: the
    /// short-circuits became branches and LLVM kept the loop scalar (tp4-sphere, 64 spp:
    /// 0.99 s → 0.87 s with both shapes' lane loops vectorised).
    #[must_use]
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    pub fn closest_lanes(&self, rays: &RayLanes, t_best: &mut [f32; LANES]) -> u32 {
        let (p, n) = (self.point, self.normal);
        let mut hit = [false; LANES];
        for k in 0..LANES {
            let (o, d) = ([rays.o[0][k], rays.o[1][k], rays.o[2][k]], [rays.d[0][k], rays.d[1][k], rays.d[2][k]]);
            let denom = d[0] * n.x + d[1] * n.y + d[2] * n.z;
            let t = ((p.x - o[0]) * n.x + (p.y - o[1]) * n.y + (p.z - o[2]) * n.z) / denom;
            hit[k] = (denom != 0.0) & (t >= rays.t_min[k]) & (t < t_best[k]);
            // The new best as a minimum, not as a select of the old one: LLVM made that
            // select a masked store (`vmaskmovps`), slow on AMD, which the next loads of
            // `t_best` waited for (tp4-bunny 3% faster without). A hit's `t` is below the old
            // best; a miss leaves the old best (never NaN) as the minimum with ∞.
            let cand = if hit[k] { t } else { f32::INFINITY };
            t_best[k] = t_best[k].min(cand);
        }
        lane_mask(&hit)
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

    /// `hit_lanes` answers as `intersect` on each lane (see `check_hit_lanes`).
    #[test]
    fn hit_lanes_answers_as_intersect() {
        let shape = Plane::new(Vec3::new(0.0, -1.0, 0.5), Vec3::new(0.2, 1.0, -0.1));
        crate::math::ray::check_hit_lanes(|lanes| shape.hit_lanes(lanes), |ray, t_min, t_max| shape.intersect(ray, t_min, t_max).is_some());
    }

    /// The AVX2 intrinsics answer as `intersect` too, where this CPU has AVX2 (the other
    /// CPUs run `hit_lanes`, tested above).
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn hit_lanes_avx2_answers_as_intersect() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("no AVX2 on this CPU: hit_lanes_avx2 not run");
            return;
        }
        let shape = Plane::new(Vec3::new(0.0, -1.0, 0.5), Vec3::new(0.2, 1.0, -0.1));
        // SAFETY: the CPU has AVX2 (checked above).
        crate::math::ray::check_hit_lanes(
            |lanes| unsafe { shape.hit_lanes_avx2(lanes) },
            |ray, t_min, t_max| shape.intersect(ray, t_min, t_max).is_some(),
        );
    }

    /// `closest_lanes` gives each lane the `t` of `intersect` (see `check_closest_lanes`).
    #[test]
    fn closest_lanes_are_the_hits_of_intersect() {
        let shape = Plane::new(Vec3::new(0.0, -1.0, 0.5), Vec3::new(0.2, 1.0, -0.1));
        crate::math::ray::check_closest_lanes(
            |lanes, t| shape.closest_lanes(lanes, t),
            |ray, t_min, t_max| shape.intersect(ray, t_min, t_max),
        );
    }
}
