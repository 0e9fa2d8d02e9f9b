//! A quad light's samples seen from one hit, sixteen at a time, as arrays: the light
//! points, directions, pdfs and radiances of [`LightSampler::sample`] and the shadow rays
//! of [`ShadowRays::to`], bit for bit, in straight-line loops the compiler turns into SIMD
//! (square roots and divisions four or eight at a time, no branches).
//!
//! PERF: one sample at a time, setting up a sample and its shadow ray cost about as much
//! as tracing the ray (~360 instructions, measured with callgrind on the conference room).

use crate::lights::{LightSample, LightSampler};
use crate::math::color::Color;
use crate::math::ray::{Ray, ShadowRays};
use glam::{Vec2, Vec3};

/// Samples per batch.
pub(super) const BATCH: usize = 16;

/// Up to [`BATCH`] samples of a quad light from one hit, and their shadow rays.
pub(super) struct QuadBatch {
    point: [[f32; BATCH]; 3],
    wi: [[f32; BATCH]; 3],
    distance: [f32; BATCH],
    pdf: [f32; BATCH],
    radiance: [[f32; BATCH]; 3],
    /// `max(wi · n, 0)` with the hit's shading normal.
    pub(super) cos: [f32; BATCH],
    origin: [[f32; BATCH]; 3],
    dir: [[f32; BATCH]; 3],
    t_max: [f32; BATCH],
    /// The sample lights the hit (`cos > 0`, some radiance) and its shadow ray exists.
    pub(super) live: [bool; BATCH],
    /// The shadow ray exists (its target is finite and not its origin).
    pub(super) has_ray: [bool; BATCH],
}

impl QuadBatch {
    /// Samples `xi[..n]` of the quad light `light` seen from the hit whose shading normal is
    /// `normal` and whose shadow rays leave as `rays` says.
    pub(super) fn new(light: &LightSampler, rays: &ShadowRays, normal: Vec3, xi: &[Vec2; BATCH]) -> Self {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F, which is all `new_avx512` is compiled for.
            return unsafe { Self::new_avx512(light, rays, normal, xi) };
        }
        Self::new_portable(light, rays, normal, xi)
    }

    /// [`Self::new`] compiled for AVX-512: the same operations sixteen lanes wide (no FMA
    /// contraction, so the same floats).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl")]
    fn new_avx512(light: &LightSampler, rays: &ShadowRays, normal: Vec3, xi: &[Vec2; BATCH]) -> Self {
        Self::new_portable(light, rays, normal, xi)
    }

    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loops vectorise
    fn new_portable(light: &LightSampler, rays: &ShadowRays, normal: Vec3, xi: &[Vec2; BATCH]) -> Self {
        let LightSampler::Quad { corner, u, v, normal: ln, area, emitted } = *light else {
            unreachable!("quad lights only");
        };
        let (x, ng) = rays.surface();
        let [front, back] = rays.both_origins();
        let mut b = QuadBatch {
            point: [[0.0; BATCH]; 3],
            wi: [[0.0; BATCH]; 3],
            distance: [0.0; BATCH],
            pdf: [0.0; BATCH],
            radiance: [[0.0; BATCH]; 3],
            cos: [0.0; BATCH],
            origin: [[0.0; BATCH]; 3],
            dir: [[0.0; BATCH]; 3],
            t_max: [0.0; BATCH],
            live: [false; BATCH],
            has_ray: [false; BATCH],
        };
        // The operations of `LightSampler::sample`, `Vec3::dot`, `Vec3::length` and
        // `ShadowRays::to`, in their order, so every float is the same.
        for j in 0..BATCH {
            let (a, c) = (xi[j].x, xi[j].y);
            let y = [corner.x + a * u.x + c * v.x, corner.y + a * u.y + c * v.y, corner.z + a * u.z + c * v.z];
            let to = [y[0] - x.x, y[1] - x.y, y[2] - x.z];
            let d = (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]).sqrt();
            let wi = [to[0] / d, to[1] / d, to[2] / d];
            let cl = ln.x * wi[0] + ln.y * wi[1] + ln.z * wi[2];
            // The back of the light (or NaN): nothing.
            let lit = cl > 0.0;
            let pdf = d * d / (area * cl);
            let rad = [emitted.x / pdf, emitted.y / pdf, emitted.z / pdf];
            let cos = (wi[0] * normal.x + wi[1] * normal.y + wi[2] * normal.z).max(0.0);
            let side_back = to[0] * ng.x + to[1] * ng.y + to[2] * ng.z < 0.0;
            let o = if side_back { back } else { front };
            let t2 = [y[0] - o.x, y[1] - o.y, y[2] - o.z];
            let dist = (t2[0] * t2[0] + t2[1] * t2[1] + t2[2] * t2[2]).sqrt();
            for k in 0..3 {
                b.point[k][j] = y[k];
                b.wi[k][j] = wi[k];
                b.radiance[k][j] = if lit { rad[k] } else { 0.0 };
                b.origin[k][j] = o[k];
                b.dir[k][j] = t2[k] / dist;
            }
            b.distance[j] = d;
            b.pdf[j] = if lit { pdf } else { 0.0 };
            b.cos[j] = cos;
            b.t_max[j] = dist * (1.0 - 1e-4);
            let some_radiance = lit && (rad[0] != 0.0 || rad[1] != 0.0 || rad[2] != 0.0);
            b.has_ray[j] = dist > 0.0 && dist.is_finite();
            b.live[j] = cos != 0.0 && some_radiance && b.has_ray[j];
        }
        b
    }

    /// Sample `j` as [`LightSampler::sample`] returns it.
    pub(super) fn sample(&self, j: usize) -> LightSample {
        let at = |a: &[[f32; BATCH]; 3]| Vec3::new(a[0][j], a[1][j], a[2][j]);
        LightSample {
            direction: at(&self.wi),
            distance: self.distance[j],
            point: at(&self.point),
            radiance: at(&self.radiance),
            pdf: self.pdf[j],
        }
    }

    /// The radiance of sample `j`.
    pub(super) fn radiance(&self, j: usize) -> Color {
        Vec3::new(self.radiance[0][j], self.radiance[1][j], self.radiance[2][j])
    }

    /// The shadow ray of sample `j` and its `t_max`, as [`ShadowRays::to`] returns them.
    pub(super) fn shadow_ray(&self, j: usize) -> (Ray, f32) {
        let at = |a: &[[f32; BATCH]; 3]| Vec3::new(a[0][j], a[1][j], a[2][j]);
        (Ray::new(at(&self.origin), at(&self.dir)), self.t_max[j])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::Light;
    use crate::math::sampling::Sampler;

    /// Every field equals the one-at-a-time computation, bit for bit, including samples
    /// behind the light, on the light's plane, and hits on either side of the surface.
    #[test]
    fn batches_are_the_samples_and_shadow_rays_of_one_at_a_time() {
        let mut rng = Sampler::from_seed(5);
        let light = Light::Quad {
            corner: Vec3::new(-1.0, 3.0, -1.0),
            u: Vec3::new(2.0, 0.0, 0.0),
            v: Vec3::new(0.0, 0.5, 2.0),
            color: Vec3::new(1.0, 0.8, 0.6),
            power: 12.0,
        };
        let ls = light.sampler();
        let (mut live, mut dead) = (0, 0);
        for _ in 0..2000 {
            let mut r = || rng.next_f32() * 8.0 - 4.0;
            let p = Vec3::new(r(), r(), r());
            let ng = Vec3::new(r(), r(), r()).normalize();
            let normal = (ng + 0.2 * Vec3::new(r(), r(), r())).normalize();
            let err = Vec3::splat(r().abs() * 1e-6);
            let mut xi = [Vec2::ZERO; BATCH];
            for x in &mut xi {
                *x = Vec2::new(rng.next_f32(), rng.next_f32());
            }
            let mut rays = ShadowRays::new(p, err, ng);
            let batch = QuadBatch::new(&ls, &rays, normal, &xi);
            // Both code paths where this CPU has both.
            let portable = QuadBatch::new_portable(&ls, &rays, normal, &xi);
            for j in 0..BATCH {
                assert_eq!(
                    (portable.sample(j), portable.shadow_ray(j), portable.live[j]),
                    (batch.sample(j), batch.shadow_ray(j), batch.live[j])
                );
                let s = ls.sample(p, xi[j]);
                assert_eq!(batch.sample(j), s);
                let cos = s.direction.dot(normal).max(0.0);
                assert_eq!(batch.cos[j].to_bits(), cos.to_bits());
                let ray = rays.to(s.point);
                assert_eq!(batch.has_ray[j], ray.is_some());
                let expected = cos != 0.0 && s.radiance != Color::ZERO && ray.is_some();
                assert_eq!(batch.live[j], expected);
                if let Some(ray) = ray {
                    assert_eq!(batch.shadow_ray(j), ray);
                }
                if expected {
                    live += 1;
                } else {
                    dead += 1;
                }
            }
        }
        assert!(live > 1000 && dead > 1000, "{live} {dead}");
    }
}
