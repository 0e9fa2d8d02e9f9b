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
use crate::math::ray::{gamma, RayLanes, LANES};
use glam::Vec3;

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

/// Per lane (`[axis][lane]`): the surface point, its error bound and the normal facing the
/// ray, and whether the ray arrived on the side the normal points to.
pub(crate) struct ShapeHits {
    pub(crate) point: [[f32; LANES]; 3],
    pub(crate) error: [[f32; LANES]; 3],
    pub(crate) facing: [[f32; LANES]; 3],
    pub(crate) front: [bool; LANES],
}

impl ShapeHits {
    /// The rows of the lanes `mask` ([`HitRows`]: the facing normal is both the
    /// geometric and the shading one), zeros in the others.
    /// PERF: the lanes kept with AND masks: as selects, LLVM writes masked stores
    /// (`vmaskmovps`, slow on AMD).
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    pub(crate) fn rows_into(&self, mask: u32, rows: &mut HitRows) {
        for k in 0..LANES {
            let m = 0u32.wrapping_sub((mask >> k) & 1);
            let keep = |x: f32| f32::from_bits(x.to_bits() & m);
            for axis in 0..3 {
                rows.surface.p[axis][k] = keep(self.point[axis][k]);
                rows.surface.p_error[axis][k] = keep(self.error[axis][k]);
                rows.surface.ng[axis][k] = keep(self.facing[axis][k]);
                rows.normal[axis][k] = keep(self.facing[axis][k]);
            }
        }
        rows.mask = mask;
    }

    /// Lane `k`'s point, error bound and facing normal.
    #[inline(always)]
    pub(crate) fn lane(&self, k: usize) -> (Vec3, Vec3, Vec3) {
        let at = |a: &[[f32; LANES]; 3]| Vec3::new(a[0][k], a[1][k], a[2][k]);
        (at(&self.point), at(&self.error), at(&self.facing))
    }
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
    /// builds for a sphere or a plane, bit for bit.
    pub(crate) fn hits(&self, rays: &RayLanes, t: &[f32; LANES]) -> ShapeHits {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            #[target_feature(enable = "avx2")]
            fn hits_avx2(shapes: &ShapeLanes, rays: &RayLanes, t: &[f32; LANES]) -> ShapeHits {
                shapes.hits_portable(rays, t)
            }
            // SAFETY: the CPU has AVX2, which is all `hits_avx2` is compiled for.
            return unsafe { hits_avx2(self, rays, t) };
        }
        self.hits_portable(rays, t)
    }

    /// The operations of `Ray::at`, `Sphere::surface_point`, `Sphere::normal`,
    /// `Plane::surface_point` (and glam's `length`, `dot`, `abs` and `max_element` inside
    /// them) and `Scene::interaction_given`'s facing, in their order; both kinds computed
    /// in every lane, each lane's kept by a select.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loops vectorise
    fn hits_portable(&self, rays: &RayLanes, t: &[f32; LANES]) -> ShapeHits {
        let mut out = ShapeHits { point: [[0.0; LANES]; 3], error: [[0.0; LANES]; 3], facing: [[0.0; LANES]; 3], front: [false; LANES] };
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
            let s = self.sphere[j];
            let mut nn = [0f32; 3];
            for axis in 0..3 {
                let es = g5 * l[axis].abs() + g1 * ps[axis].abs();
                let ep = g8 * (pp[axis].abs() + c[axis][j].abs() + m);
                out.point[axis][j] = sel(s, ps[axis], pp[axis]);
                out.error[axis][j] = sel(s, es, ep);
                nn[axis] = sel(s, (ps[axis] - c[axis][j]) / r[j], n[axis][j]);
            }
            // ---- The normal facing the ray; the side the ray arrived on ----
            let dot = d[0][j] * nn[0] + d[1][j] * nn[1] + d[2][j] * nn[2];
            // `-n` where the ray and the normal point the same way, as a flip of the sign bit.
            let flip = u32::from(dot > 0.0) << 31;
            for axis in 0..3 {
                out.facing[axis][j] = f32::from_bits(nn[axis].to_bits() ^ flip);
            }
            out.front[j] = dot <= 0.0;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::ray::Ray;
    use crate::math::sampling::Sampler;

    /// Each lane is the scalar code's hit, bit for bit: `Sphere::surface_point` and
    /// `Sphere::normal`, `Plane::surface_point` and the plane's normal, faced as
    /// `Scene::interaction_given` faces them; spheres and planes mixed across the lanes,
    /// near and far, hit from either side, and points at a sphere's centre (no length to
    /// scale), on both code paths.
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
            for k in 0..LANES {
                let origin = Vec3::new(r(), r(), r()) * scale;
                let direction = Vec3::new(r(), r(), r()).normalize_or(Vec3::X);
                let ray = Ray::new(origin, direction);
                t[k] = r().abs() * scale;
                rays.set(k, origin, direction, 0.0, f32::INFINITY);
                let (point, error, normal) = if (round + k) % 3 == 0 {
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
            let portable = shapes.hits_portable(&rays, &t);
            let dispatched = shapes.hits(&rays, &t);
            for (k, (point, error, facing, front)) in expected.into_iter().enumerate() {
                for got in [&portable, &dispatched] {
                    let (p, e, n) = got.lane(k);
                    assert_eq!(
                        (bits(p), bits(e), bits(n), got.front[k]),
                        (bits(point), bits(error), bits(facing), front),
                        "round {round}, lane {k}"
                    );
                }
            }
        }
    }
}
