//! The geometry of sixteen sphere and plane hits at once: each lane's
//! [`Sphere::surface_point`] and [`Sphere::normal`], or [`Plane::surface_point`] and the
//! plane's normal, turned to face the ray, the same floats, in straight-line loops over
//! the lanes that the compiler turns into SIMD (AVX2 where the CPU has it: the spheres'
//! square roots and divisions eight lanes at a time).
//!
//! PERF: one hit at a time, building the hits of the path tracer's bounces was 14% of its
//! time on the TP6 room (each lane's square root, divisions and branch on its kind, then
//! the hit). In lanes: the path tracer (Lambert, 64 spp, CPU time, medians of 5)
//! tp6-matte 0.987, tp6-glass-quad 0.96; Whitted and direct lighting within noise. Small:
//! most of the cost left is building and reading the hits themselves.

use super::{HitRows, Plane, Sphere};
use crate::math::ray::{gamma, lane_mask, RayLanes, LANES};

/// Sixteen lanes' shapes, as arrays (`[axis][lane]`): a sphere's centre and radius, or a
/// plane's point and normal.
pub(crate) struct ShapeLanes {
    /// A sphere's centre, a plane's point.
    at: [[f32; LANES]; 3],
    /// A plane's normal (zero for a sphere).
    normal: [[f32; LANES]; 3],
    /// A sphere's radius (zero for a plane).
    radius: [f32; LANES],
    /// The lane holds a sphere.
    sphere: [bool; LANES],
}

impl ShapeLanes {
    /// No shapes yet (lanes not set are planes of zero normal: their answers are not read).
    pub(crate) const EMPTY: ShapeLanes =
        ShapeLanes { at: [[0.0; LANES]; 3], normal: [[0.0; LANES]; 3], radius: [0.0; LANES], sphere: [false; LANES] };

    /// Lane `k` holds the sphere `s`.
    #[inline(always)]
    pub(crate) fn set_sphere(&mut self, k: usize, s: &Sphere) {
        for axis in 0..3 {
            self.at[axis][k] = s.center[axis];
        }
        (self.radius[k], self.sphere[k]) = (s.radius, true);
    }

    /// Lane `k` holds the plane `p`.
    #[inline(always)]
    pub(crate) fn set_plane(&mut self, k: usize, p: &Plane) {
        for axis in 0..3 {
            self.at[axis][k] = p.point[axis];
            self.normal[axis][k] = p.normal[axis];
        }
        self.sphere[k] = false;
    }

    /// Each lane's hit of its shape by the ray of `rays` at `t`: what `Scene::intersect`
    /// builds for a sphere or a plane, bit for bit. The lanes of `mask` into `rows` (the
    /// surface point, its error bound and the normal facing the ray, as both the geometric
    /// and the shading normal; zeros in the other lanes); returned, whether the ray arrived
    /// on the side the normal points to.
    /// PERF: written into the rows the path tracer keeps: as an array of its own, each
    /// bounce's was zeroed, then copied into the rows.
    /// PERF: lanes of planes alone skip the spheres' square roots and divisions (TP4's
    /// rooms, whose walls are planes beside a mesh).
    pub(crate) fn hits(&self, rays: &RayLanes, t: &[f32; LANES], mask: u32, rows: &mut HitRows) -> [bool; LANES] {
        let spheres = lane_mask(&self.sphere) & mask != 0;
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            #[target_feature(enable = "avx2")]
            fn hits_avx2(shapes: &ShapeLanes, rays: &RayLanes, t: &[f32; LANES], mask: u32, rows: &mut HitRows) -> [bool; LANES] {
                shapes.hits_portable::<true>(rays, t, mask, rows)
            }
            #[target_feature(enable = "avx2")]
            fn planes_avx2(shapes: &ShapeLanes, rays: &RayLanes, t: &[f32; LANES], mask: u32, rows: &mut HitRows) -> [bool; LANES] {
                shapes.hits_portable::<false>(rays, t, mask, rows)
            }
            // SAFETY: the CPU has AVX2, which is all `hits_avx2` and `planes_avx2` are
            // compiled for.
            return unsafe {
                if spheres {
                    hits_avx2(self, rays, t, mask, rows)
                } else {
                    planes_avx2(self, rays, t, mask, rows)
                }
            };
        }
        if spheres {
            self.hits_portable::<true>(rays, t, mask, rows)
        } else {
            self.hits_portable::<false>(rays, t, mask, rows)
        }
    }

    /// The operations of `Ray::at`, `Sphere::surface_point`, `Sphere::normal`,
    /// `Plane::surface_point` (and glam's `length`, `dot`, `abs` and `max_element` inside
    /// them) and `Scene::interaction_given`'s facing, in their order; both kinds computed
    /// in every lane, each lane's kept by a select; without `SPHERES` (no lane of `mask`
    /// holds a sphere) the planes' alone.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loops vectorise
    fn hits_portable<const SPHERES: bool>(&self, rays: &RayLanes, t: &[f32; LANES], mask: u32, rows: &mut HitRows) -> [bool; LANES] {
        let mut front = [false; LANES];
        let (o, d, c, n, r) = (&rays.o, &rays.d, &self.at, &self.normal, &self.radius);
        let (g1, g5, g8) = (gamma(1), gamma(5), gamma(8));
        // glam's `max_element`: max(x, max(y, z)) with `if a > b { a } else { b }`.
        let max = |a: f32, b: f32| if a > b { a } else { b };
        // `if c { a } else { b }` as bits. PERF: as selects, LLVM split the loop's body
        // on them and wrote the rows with masked stores (`vmaskmovps`, slow on AMD): the
        // path tracer on the TP6 room 8% slower than one lane at a time.
        let sel = |c: bool, a: f32, b: f32| {
            let m = u32::from(c).wrapping_neg();
            f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
        };
        for j in 0..LANES {
            // The lanes outside `mask` keep zeros (AND masks, for the same reason).
            let keep = u32::from(mask & (1 << j) != 0).wrapping_neg();
            let keep = |x: f32| f32::from_bits(x.to_bits() & keep);
            // `Ray::at`: origin + t · direction.
            let q = [o[0][j] + t[j] * d[0][j], o[1][j] + t[j] * d[1][j], o[2][j] + t[j] * d[2][j]];
            // The point relative to the sphere's centre or the plane's point (`local` in
            // `Sphere::surface_point`, `rel` in `Plane::surface_point`).
            let rel = [q[0] - c[0][j], q[1] - c[1][j], q[2] - c[2][j]];
            // ---- Sphere::surface_point, then its normal ----
            let len = (rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2]).sqrt();
            let scale = r[j] / len;
            let shrink = len > 0.0;
            let l = [sel(shrink, rel[0] * scale, rel[0]), sel(shrink, rel[1] * scale, rel[1]), sel(shrink, rel[2] * scale, rel[2])];
            let ps = [c[0][j] + l[0], c[1][j] + l[1], c[2][j] + l[2]];
            // ---- Plane::surface_point ----
            let dn = rel[0] * n[0][j] + rel[1] * n[1][j] + rel[2] * n[2][j];
            let pp = [q[0] - n[0][j] * dn, q[1] - n[1][j] * dn, q[2] - n[2][j] * dn];
            let m = max(rel[0].abs(), max(rel[1].abs(), rel[2].abs()));
            let s = SPHERES && self.sphere[j];
            let mut nn = [0f32; 3];
            for axis in 0..3 {
                let es = g5 * l[axis].abs() + g1 * ps[axis].abs();
                let ep = g8 * (pp[axis].abs() + c[axis][j].abs() + m);
                rows.surface.p[axis][j] = keep(sel(s, ps[axis], pp[axis]));
                rows.surface.p_error[axis][j] = keep(sel(s, es, ep));
                nn[axis] = sel(s, (ps[axis] - c[axis][j]) / r[j], n[axis][j]);
            }
            // ---- The normal facing the ray; the side the ray arrived on ----
            let dot = d[0][j] * nn[0] + d[1][j] * nn[1] + d[2][j] * nn[2];
            // `-n` where the ray and the normal point the same way, as a flip of the sign bit.
            let flip = u32::from(dot > 0.0) << 31;
            for axis in 0..3 {
                let facing = keep(f32::from_bits(nn[axis].to_bits() ^ flip));
                (rows.surface.ng[axis][j], rows.normal[axis][j]) = (facing, facing);
            }
            front[j] = dot <= 0.0;
        }
        rows.mask = mask;
        front
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::ray::Ray;
    use crate::math::sampling::Sampler;
    use glam::Vec3;

    /// Each lane is the scalar code's hit, bit for bit: `Sphere::surface_point` and
    /// `Sphere::normal`, `Plane::surface_point` and the plane's normal, faced as
    /// `Scene::interaction_given` faces them; spheres and planes mixed across the lanes,
    /// near and far, hit from either side, and points at a sphere's centre (no length to
    /// scale), on both code paths; every fourth round planes alone (the path without the
    /// spheres' arithmetic; half of those planes set over a sphere first), and in another
    /// fourth of the rounds a sphere only in the lane outside the mask (the same path).
    #[test]
    fn shape_lanes_are_the_hits_of_one_at_a_time() {
        let mut rng = Sampler::from_seed(5);
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        for round in 0..2000 {
            let mut r = || rng.next_f32() * 8.0 - 4.0;
            let scale = [1.0, 1e-3, 1e4][round % 3];
            let mut shapes = ShapeLanes::EMPTY;
            let mut rays = RayLanes::EMPTY;
            let mut t = [0f32; LANES];
            let mut expected = Vec::new();
            #[allow(clippy::needless_range_loop)] // one index into several arrays
            for k in 0..LANES {
                let origin = Vec3::new(r(), r(), r()) * scale;
                let direction = Vec3::new(r(), r(), r()).normalize_or(Vec3::X);
                let ray = Ray::new(origin, direction);
                t[k] = r().abs() * scale;
                rays.set(k, origin, direction, 0.0, f32::INFINITY);
                let plane = match round % 4 {
                    3 => true,
                    1 => k != round % LANES,
                    _ => (round + k) % 3 == 0,
                };
                let (point, error, normal) = if plane {
                    if round % 4 == 3 && k % 2 == 0 {
                        // A sphere first, replaced by the plane.
                        shapes.set_sphere(k, &Sphere::new(Vec3::new(r(), r(), r()), 1.0));
                    }
                    let p = Plane::new(Vec3::new(r(), r(), r()) * scale, Vec3::new(r(), r(), r()).normalize_or(Vec3::Y));
                    shapes.set_plane(k, &p);
                    let (point, error) = p.surface_point(&ray, t[k]);
                    (point, error, p.normal)
                } else {
                    // Every seventh sphere centred on the ray's point at `t`.
                    let center = if k % 7 == 0 { ray.at(t[k]) } else { Vec3::new(r(), r(), r()) * scale };
                    let s = Sphere::new(center, r().abs() * scale + 1e-3);
                    shapes.set_sphere(k, &s);
                    let (point, error) = s.surface_point(&ray, t[k]);
                    (point, error, s.normal(point))
                };
                let facing = if direction.dot(normal) > 0.0 { -normal } else { normal };
                expected.push((point, error, facing, direction.dot(normal) <= 0.0));
            }
            // Every lane but one (which must hold zeros).
            let (mask, out) = (!(1u32 << (round % LANES)) & 0xffff, round % LANES);
            let (mut portable, mut dispatched, mut planes) = (HitRows::default(), HitRows::default(), HitRows::default());
            let front_portable = shapes.hits_portable::<true>(&rays, &t, mask, &mut portable);
            let front_dispatched = shapes.hits(&rays, &t, mask, &mut dispatched);
            let planes_only = round % 4 == 3 || round % 4 == 1;
            assert_eq!(lane_mask(&shapes.sphere) & mask == 0, planes_only);
            let front_planes = if planes_only { shapes.hits_portable::<false>(&rays, &t, mask, &mut planes) } else { front_portable };
            if !planes_only {
                planes = portable;
            }
            let at = |a: &[[f32; LANES]; 3], k: usize| Vec3::new(a[0][k], a[1][k], a[2][k]);
            for (k, (point, error, facing, front)) in expected.into_iter().enumerate() {
                for (got, got_front) in [(&portable, front_portable), (&dispatched, front_dispatched), (&planes, front_planes)] {
                    let (p, e, ng, n) = (at(&got.surface.p, k), at(&got.surface.p_error, k), at(&got.surface.ng, k), at(&got.normal, k));
                    let row = (bits(p), bits(e), bits(ng), bits(n));
                    if k == out {
                        assert_eq!(row, ([0; 3], [0; 3], [0; 3], [0; 3]), "round {round}, lane {k} (not in the mask)");
                        continue;
                    }
                    assert_eq!(
                        (row, got_front[k]),
                        ((bits(point), bits(error), bits(facing), bits(facing)), front),
                        "round {round}, lane {k}"
                    );
                }
                assert_eq!(portable.mask, mask);
                assert_eq!(dispatched.mask, mask);
            }
        }
    }
}
