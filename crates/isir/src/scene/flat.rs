//! A few spheres and planes (the scenes of TP1–3, TP5 and TP6) tested against one ray all
//! at once: their data as arrays, each lane computing what [`Sphere::intersect`] or
//! [`Plane::intersect`] computes, operation for operation, in straight-line loops the
//! compiler turns into SIMD (AVX2 where the CPU has it). One object at a time, each test
//! waits on a division and a branch; side by side, the divisions overlap.
//!
//! The closest hit is then chosen in object order with the loop's strict `<`, so the
//! answer is the one-by-one loop's, bit for bit: each object's `t` here is tested against
//! `[t_min, t_max)` rather than the shrinking `[t_min, t_best)`, which changes only which
//! root of a sphere beyond the closest hit is kept, and that root loses either way.

use crate::geometry::{Geometry, Plane, Sphere};
use crate::math::ray::Ray;

use super::Object;

/// Lanes of each kind: scenes with more spheres or planes than this are not flattened.
const LANES: usize = 16;

/// The fewest objects flattened: one or two are tested one by one as quickly as the
/// arrays are filled (TP1's lone sphere: within noise either way). The TP6 room (seven
/// objects), path tracer: 0.86x the time flattened.
const FLAT_FROM: usize = 3;

/// The spheres and planes of a scene made only of them, as arrays.
#[derive(Clone, Debug)]
pub(crate) struct FlatObjects {
    /// Planes: a point and the normal, by axis.
    point: [[f32; LANES]; 3],
    normal: [[f32; LANES]; 3],
    planes: usize,
    /// Spheres: the centre by axis, and `radius · radius`.
    center: [[f32; LANES]; 3],
    radius2: [f32; LANES],
    spheres: usize,
    /// Per object, in order, its lane: planes at `0..LANES`, spheres at `LANES..`.
    lane: Vec<u8>,
}

impl FlatObjects {
    /// The flat form of `objects`, when they are all spheres and planes, at most [`LANES`]
    /// of each.
    pub(crate) fn new(objects: &[Object]) -> Option<FlatObjects> {
        #[cfg(target_arch = "x86_64")]
        let simd = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let simd = false;
        if !simd || objects.len() < FLAT_FROM {
            return None;
        }
        let mut f = FlatObjects {
            // Padding lanes never hit: a zero normal (the division's denominator is zero)
            // and a NaN radius (a NaN discriminant).
            point: [[0.0; LANES]; 3],
            normal: [[0.0; LANES]; 3],
            planes: 0,
            center: [[0.0; LANES]; 3],
            radius2: [f32::NAN; LANES],
            spheres: 0,
            lane: Vec::with_capacity(objects.len()),
        };
        for o in objects {
            match &o.geometry {
                Geometry::Plane(Plane { point, normal }) if f.planes < LANES => {
                    for axis in 0..3 {
                        (f.point[axis][f.planes], f.normal[axis][f.planes]) = (point[axis], normal[axis]);
                    }
                    f.lane.push(f.planes as u8);
                    f.planes += 1;
                }
                Geometry::Sphere(Sphere { center, radius }) if f.spheres < LANES => {
                    for axis in 0..3 {
                        f.center[axis][f.spheres] = center[axis];
                    }
                    // As `Sphere::intersect` computes it.
                    f.radius2[f.spheres] = radius * radius;
                    f.lane.push((LANES + f.spheres) as u8);
                    f.spheres += 1;
                }
                _ => return None,
            }
        }
        Some(f)
    }

    /// Objects flattened (the scene's object count when it was built).
    pub(crate) fn len(&self) -> usize {
        self.lane.len()
    }

    /// Each object's hit distance in `[t_min, t_max)` (+∞ where it misses), by lane.
    #[inline(always)]
    fn distances(&self, ray: &Ray, t_min: f32, t_max: f32) -> [f32; 2 * LANES] {
        let mut t = [f32::INFINITY; 2 * LANES];
        #[cfg(target_arch = "x86_64")]
        // SAFETY: a `FlatObjects` is only built on a CPU with AVX2 (`new`).
        unsafe {
            self.distances_avx2(ray, t_min, t_max, &mut t);
        }
        t
    }

    /// [`Self::distances`], eight lanes at a time: the operations of
    /// [`Plane::intersect`] and [`Sphere::intersect`] in their order (no FMA: the same
    /// floats).
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn distances_avx2(&self, ray: &Ray, t_min: f32, t_max: f32, out: &mut [f32; 2 * LANES]) {
        use std::arch::x86_64::*;
        let (o, d) = (ray.origin, ray.direction);
        let (ox, oy, oz) = (_mm256_set1_ps(o.x), _mm256_set1_ps(o.y), _mm256_set1_ps(o.z));
        let (dx, dy, dz) = (_mm256_set1_ps(d.x), _mm256_set1_ps(d.y), _mm256_set1_ps(d.z));
        let (lo, hi, inf, zero) = (_mm256_set1_ps(t_min), _mm256_set1_ps(t_max), _mm256_set1_ps(f32::INFINITY), _mm256_setzero_ps());
        let (mul, add, sub) = (|a, b| _mm256_mul_ps(a, b), |a, b| _mm256_add_ps(a, b), |a, b| _mm256_sub_ps(a, b));
        let inside = |t| _mm256_and_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(t, lo), _mm256_cmp_ps::<_CMP_LT_OQ>(t, hi));
        for first in (0..self.planes).step_by(8) {
            // SAFETY: `first + 8 <= LANES`: each load reads eight floats of an array of sixteen.
            let ld = |a: &[f32; LANES]| unsafe { _mm256_loadu_ps(a.as_ptr().add(first)) };
            let (p, n) = (&self.point, &self.normal);
            let (nx, ny, nz) = (ld(&n[0]), ld(&n[1]), ld(&n[2]));
            let denom = add(add(mul(dx, nx), mul(dy, ny)), mul(dz, nz));
            let num = add(add(mul(sub(ld(&p[0]), ox), nx), mul(sub(ld(&p[1]), oy), ny)), mul(sub(ld(&p[2]), oz), nz));
            let t = _mm256_div_ps(num, denom);
            let ok = _mm256_and_ps(_mm256_cmp_ps::<_CMP_NEQ_UQ>(denom, zero), inside(t));
            // SAFETY: eight floats of `out`'s plane lanes.
            unsafe { _mm256_storeu_ps(out.as_mut_ptr().add(first), _mm256_blendv_ps(inf, t, ok)) };
        }
        if self.spheres > 0 {
            // `Vec3::length_squared`.
            let a = _mm256_set1_ps(d.x * d.x + d.y * d.y + d.z * d.z);
            let sign = _mm256_set1_ps(-0.0);
            for first in (0..self.spheres).step_by(8) {
                // SAFETY: as for the planes.
                let ld = |a: &[f32; LANES]| unsafe { _mm256_loadu_ps(a.as_ptr().add(first)) };
                let c = &self.center;
                let (ocx, ocy, ocz) = (sub(ox, ld(&c[0])), sub(oy, ld(&c[1])), sub(oz, ld(&c[2])));
                let half_b = add(add(mul(ocx, dx), mul(ocy, dy)), mul(ocz, dz));
                let cc = sub(add(add(mul(ocx, ocx), mul(ocy, ocy)), mul(ocz, ocz)), ld(&self.radius2));
                let disc = sub(mul(half_b, half_b), mul(a, cc));
                let sq = _mm256_sqrt_ps(disc);
                let neg_half_b = _mm256_xor_ps(half_b, sign);
                let near = _mm256_div_ps(sub(neg_half_b, sq), a);
                let far = _mm256_div_ps(add(neg_half_b, sq), a);
                let t = _mm256_blendv_ps(_mm256_blendv_ps(inf, far, inside(far)), near, inside(near));
                let ok = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(disc, zero), _mm256_cmp_ps::<_CMP_NEQ_UQ>(a, zero));
                // SAFETY: eight floats of `out`'s sphere lanes.
                unsafe { _mm256_storeu_ps(out.as_mut_ptr().add(LANES + first), _mm256_blendv_ps(inf, t, ok)) };
            }
        }
    }

    /// The closest object hit in `[t_min, t_max)` and its distance: the loop over the
    /// objects' own tests, in order, a later object replacing the best only when nearer.
    #[inline(always)]
    pub(crate) fn closest(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<(usize, f32)> {
        let t = self.distances(ray, t_min, t_max);
        let mut best = None;
        let mut t_best = t_max;
        for (i, &lane) in self.lane.iter().enumerate() {
            let ti = t[lane as usize];
            if ti < t_best {
                t_best = ti;
                best = Some((i, ti));
            }
        }
        best
    }

    /// True when some object meets the ray in `[t_min, t_max)`.
    #[inline(always)]
    pub(crate) fn any(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        self.distances(ray, t_min, t_max).iter().any(|&t| t < f32::INFINITY)
    }
}

#[cfg(test)]
mod tests {
    use crate::geometry::{Geometry, Plane, Sphere};
    use crate::math::ray::Ray;
    use crate::math::sampling::Sampler;
    use crate::scene::{Object, Scene};
    use glam::Vec3;

    /// Random spheres and planes, with exact duplicates (ties) and axis-aligned planes
    /// (rays parallel to them): the flat tests must answer as the loop, bit for bit.
    #[test]
    fn flat_objects_answer_as_the_loop_over_objects() {
        let mut rng = Sampler::from_seed(3);
        let mut r = |s: f32| (rng.next_f32() * 2.0 - 1.0) * s;
        let mut checked = (0, 0, 0);
        for round in 0..60 {
            let mut objects = Vec::new();
            let n = 3 + round % 20;
            for i in 0..n {
                let geometry = match i % 4 {
                    0 => Geometry::Plane(Plane::new(Vec3::new(r(5.0), r(5.0), r(5.0)), Vec3::new(r(1.0), r(1.0), r(1.0)))),
                    1 => Geometry::Plane(Plane::new(Vec3::new(0.0, r(5.0), 0.0), Vec3::Y)),
                    _ => Geometry::Sphere(Sphere::new(Vec3::new(r(4.0), r(4.0), r(4.0)), 0.1 + r(2.0).abs())),
                };
                objects.push(Object { name: format!("o{i}"), geometry, materials: vec![0] });
                if i % 5 == 4 {
                    let twin = objects.last().unwrap().clone();
                    objects.push(twin);
                }
            }
            let flat = Scene::new(objects.clone(), vec![crate::Material::Color(crate::Color::ONE)], Vec::new(), crate::Color::ZERO);
            let flattened = flat.flat.is_some();
            // More than sixteen of a kind, or a CPU without AVX2: not flattened.
            let kinds = |plane: bool| objects.iter().filter(|o| matches!(o.geometry, Geometry::Plane(_)) == plane).count();
            #[cfg(target_arch = "x86_64")]
            let simd = std::arch::is_x86_feature_detected!("avx2");
            #[cfg(not(target_arch = "x86_64"))]
            let simd = false;
            assert_eq!(flattened, kinds(true) <= 16 && kinds(false) <= 16 && simd);
            let mut one_by_one = flat.clone();
            one_by_one.flat = None;
            for k in 0..400 {
                let mut d = Vec3::new(r(1.0), r(1.0), r(1.0));
                if k % 7 == 0 {
                    d.y = 0.0;
                }
                let ray = Ray::new(Vec3::new(r(6.0), r(6.0), r(6.0)), d);
                let (t_min, t_max) = if k % 3 == 0 { (r(2.0), 1.0 + r(8.0).abs()) } else { (1e-4, f32::INFINITY) };
                let want = one_by_one.closest(&ray, t_min, t_max);
                let got = flat.closest(&ray, t_min, t_max);
                assert_eq!(got.map(|h| (h.0, h.1.to_bits())), want.map(|h| (h.0, h.1.to_bits())), "{ray:?} in [{t_min}, {t_max})");
                assert_eq!(flat.occluded(&ray, t_min, t_max), one_by_one.occluded(&ray, t_min, t_max), "{ray:?}");
                checked.0 += usize::from(flattened);
                checked.1 += usize::from(want.is_some());
                checked.2 += usize::from(want.is_some_and(|(i, ..)| i + 1 < objects.len() && objects[i + 1].name == objects[i].name));
            }
        }
        assert!(checked.0 > 10_000 && checked.1 > 5_000, "{checked:?}");
        assert!(checked.2 > 50, "ties between twins: {checked:?}");
    }
}
