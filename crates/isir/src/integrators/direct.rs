//! The course's direct lighting: for each light, the average over its samples of
//! `shade · radiance · cos`, a sample counting only when its shadow ray reaches the light.

use super::shadow::{divided, live_mask, QuadScratch, BATCH, BATCH_FROM};
use super::RayCounters;
use crate::geometry::Hit;
use crate::lights::LightSampler;
use crate::materials::Material;
use crate::math::color::Color;
use crate::math::ray::{lane_mask, Ray, ShadowRays};
use crate::math::sampling::Sampler;
use crate::scene::{BoxProof, QuadPlanes, Scene};
use glam::Vec2;

/// The direct-lighting integrator's `Li`.
pub(super) fn li(
    scene: &Scene,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    light_samples: u32,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Color {
    counters.primary += 1;
    let Some(hit) = scene.intersect(ray, t_min, t_max) else {
        return scene.background;
    };
    direct_lighting(scene, ray, &hit, light_samples, sampler, counters)
}

thread_local! {
    static QUAD_SCRATCH: std::cell::RefCell<QuadScratch> = const { std::cell::RefCell::new(QuadScratch::EMPTY) };
}

/// `f` with this thread's quad-light batches ([`quad_light`]'s memory), kept from call to
/// call: lanes past a batch's count are never live nor summed (see `quad_batches`).
/// PERF: zeroed per hit and light instead, `memset` was 2% of tp6-glass-quad, whose
/// Whitted paths light every hit one at a time.
pub(super) fn with_quad_scratch<R>(f: impl FnOnce(&mut QuadScratch) -> R) -> R {
    QUAD_SCRATCH.with_borrow_mut(f)
}

/// Sum over the lights of the average over samples of `shade · radiance · cos`, counting a
/// sample only when its shadow ray reaches the light.
pub(super) fn direct_lighting(
    scene: &Scene,
    ray: &Ray,
    hit: &Hit,
    light_samples: u32,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Color {
    let material = scene.material(hit);
    let mut li = Color::ZERO;
    let mut shadow_rays = hit.shadow_rays();
    for light in &scene.lights {
        let light_sampler = light.sampler();
        let n = if light.is_surface() { light_samples.max(1) } else { 1 };
        li += match light_sampler {
            LightSampler::Quad { .. } => with_quad_scratch(|scratch| {
                quad_light(scene, ray, hit, material, &light_sampler, &mut shadow_rays, n, sampler, counters, scratch, None)
            }),
            _ => one_light(scene, ray, hit, material, &light_sampler, &mut shadow_rays, n, sampler, counters),
        };
    }
    li
}

/// One light's average over its `n` samples, one sample at a time.
#[allow(clippy::too_many_arguments)]
pub(super) fn one_light(
    scene: &Scene,
    ray: &Ray,
    hit: &Hit,
    material: &Material,
    light_sampler: &LightSampler,
    shadow_rays: &mut ShadowRays,
    n: u32,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Color {
    let mut sum = Color::ZERO;
    for _ in 0..n {
        let ls = light_sampler.sample(hit.point, sampler.next_2d());
        let cos = ls.direction.dot(hit.normal).max(0.0);
        if cos == 0.0 || ls.radiance == Color::ZERO {
            continue;
        }
        // ---- Shadow ray, from outside the hit point's error bound on the light's side ----
        let Some((shadow, t_max)) = shadow_rays.to(ls.point) else { continue };
        counters.shadow += 1;
        if !scene.occluded(&shadow, 0.0, t_max) {
            sum += material.shade(ray, hit, &ls) * ls.radiance * cos;
        }
    }
    sum / n as f32
}

/// A quad light's average over its `n` samples: sixteen samples at a time, set up together
/// ([`super::shadow::QuadBatch`]), then traced and summed in order (the same sum as one sample at a time);
/// fewer than [`BATCH_FROM`] samples one at a time ([`one_light`]).
/// PERF: out of line, so that point lights keep a small `direct_lighting` (inlined, it made
/// point-light scenes 20% slower). `scratch` is the batch's memory, reused from call to
/// call by the caller (made and zeroed per batch, then copied out of `QuadBatch::new`, it
/// was 8% of tp6-matte-quad's Whitted render). Compiled for AVX2 and POPCNT where the CPU
/// has them: the sums' products eight lanes wide and the count of live lanes one
/// instruction (tp6-matte-quad 0.977, tp6-glass-quad 0.971, tp6-mirror-quad 0.982,
/// tp3-quad-soft 1.004, medians of 7 to 9). The parameters are passed one by one to the
/// AVX2 function and to `quad_batches`, repeated: gathered in a struct passed by reference,
/// tp6-matte-quad was 1.06 slower (the references inside a struct lose their no-alias
/// guarantees, so LLVM reloads what they point to around every store).
#[inline(never)]
#[allow(clippy::too_many_arguments)]
pub(super) fn quad_light(
    scene: &Scene,
    ray: &Ray,
    hit: &Hit,
    material: &Material,
    light_sampler: &LightSampler,
    shadow_rays: &mut ShadowRays,
    n: u32,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
    scratch: &mut QuadScratch,
    planes: Option<(&QuadPlanes, &BoxProof)>,
) -> Color {
    if n < BATCH_FROM {
        return one_light(scene, ray, hit, material, light_sampler, shadow_rays, n, sampler, counters);
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("popcnt") {
        #[target_feature(enable = "avx2,popcnt")]
        #[allow(clippy::too_many_arguments)]
        fn avx2(
            scene: &Scene,
            ray: &Ray,
            hit: &Hit,
            material: &Material,
            light_sampler: &LightSampler,
            shadow_rays: &mut ShadowRays,
            n: u32,
            sampler: &mut Sampler,
            counters: &mut RayCounters,
            scratch: &mut QuadScratch,
            planes: Option<(&QuadPlanes, &BoxProof)>,
        ) -> Color {
            quad_batches(scene, ray, hit, material, light_sampler, shadow_rays, n, sampler, counters, scratch, planes)
        }
        // SAFETY: the CPU has AVX2 and POPCNT, which is all `avx2` is compiled for.
        return unsafe { avx2(scene, ray, hit, material, light_sampler, shadow_rays, n, sampler, counters, scratch, planes) };
    }
    quad_batches(scene, ray, hit, material, light_sampler, shadow_rays, n, sampler, counters, scratch, planes)
}

/// [`quad_light`]'s batches, compiled for the caller's instruction set (no FMA
/// contraction: the same floats).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn quad_batches(
    scene: &Scene,
    ray: &Ray,
    hit: &Hit,
    material: &Material,
    light_sampler: &LightSampler,
    shadow_rays: &mut ShadowRays,
    n: u32,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
    scratch: &mut QuadScratch,
    planes: Option<(&QuadPlanes, &BoxProof)>,
) -> Color {
    let mut sum = Color::ZERO;
    let mut xi = [Vec2::ZERO; BATCH];
    // A material of one value in every direction needs no lanes of values.
    let same = material.shade_any_direction(hit);
    for first in (0..n).step_by(BATCH) {
        let count = (n - first).min(BATCH as u32) as usize;
        sampler.fill_2d(&mut xi[..count]);
        let QuadScratch { batch, f } = scratch;
        // Lanes past `count` may hold an earlier batch's samples: never live, never summed.
        batch.fill(light_sampler, shadow_rays, hit.normal, &xi, count);
        let live = live_mask(&batch.live, count);
        counters.shadow += u64::from(live.count_ones());
        // All the hit's shadow rays at once (`Scene::occluded_lanes` decides how).
        // The planes proved to block none of the rays (`Scene::quad_planes`): from the
        // front, and from the back too when a ray leaves from there.
        let skip = match planes {
            Some((table, proof)) => {
                let front = table.clear(proof, batch.origins[0]);
                if front != 0 && lane_mask(&batch.back) & live != 0 {
                    front & table.clear(proof, batch.origins[1])
                } else {
                    front
                }
            }
            None => 0,
        };
        let blocked = scene.occluded_lanes_except(&batch.rays, live, skip);
        match same {
            Some(c) => batch.add_seen_same(c, live & !blocked, count, &mut sum),
            None => {
                // `material.shade(ray, hit, &batch.sample(j))` of every sample, computed
                // together.
                batch.shade_into(material, ray, hit, f);
                batch.add_seen(f, live & !blocked, count, &mut sum);
            }
        }
    }
    divided(sum, n as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes;

    /// `quad_light` (compiled for AVX2 where the CPU has it) gives the sums of its batches
    /// compiled for the baseline instruction set, bit for bit, and draws the same random
    /// numbers: hits of the TP6 room's spheres and walls under its quad light, 4 to 40
    /// samples (one batch, then whole and partial batches).
    #[test]
    fn quad_light_is_its_portable_batches() {
        let desc = scenes::builtin("tp6-glass-quad").unwrap();
        let scene = desc.build(crate::Accel::BvhSah).unwrap();
        let camera = desc.camera.build(1.5);
        let light = scene.lights.iter().map(|l| l.sampler()).find(|s| matches!(s, LightSampler::Quad { .. })).unwrap();
        let mut rng = Sampler::from_seed(17);
        let mut lit = 0;
        for round in 0..400 {
            let ray = camera.generate_ray(rng.next_f32(), rng.next_f32());
            let Some(hit) = scene.intersect(&ray, 0.0, f32::INFINITY) else { continue };
            let material = scene.material(&hit);
            let n = [BATCH_FROM, 7, 16, 23, 40][round % 5];
            let (mut a, mut b) = (Sampler::from_seed(round as u64), Sampler::from_seed(round as u64));
            let (mut ca, mut cb) = (RayCounters::default(), RayCounters::default());
            let (mut sa, mut sb) = (QuadScratch::EMPTY, QuadScratch::EMPTY);
            let (mut ra, mut rb) = (hit.shadow_rays(), hit.shadow_rays());
            let fast = quad_light(&scene, &ray, &hit, material, &light, &mut ra, n, &mut a, &mut ca, &mut sa, None);
            let portable = quad_batches(&scene, &ray, &hit, material, &light, &mut rb, n, &mut b, &mut cb, &mut sb, None);
            assert_eq!(fast.to_array().map(f32::to_bits), portable.to_array().map(f32::to_bits), "round {round}");
            assert_eq!((ca, a.next_f32().to_bits()), (cb, b.next_f32().to_bits()), "round {round}");
            lit += usize::from(fast != Color::ZERO);
        }
        assert!(lit > 200, "{lit} lit hits");
    }
}
