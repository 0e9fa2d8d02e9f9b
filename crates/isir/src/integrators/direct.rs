//! The course's direct lighting: for each light, the average over its samples of
//! `shade · radiance · cos`, a sample counting only when its shadow ray reaches the light.

use super::shadow::{live_mask, QuadScratch, BATCH, BATCH_FROM};
use super::RayCounters;
use crate::geometry::Hit;
use crate::lights::LightSampler;
use crate::materials::Material;
use crate::math::color::Color;
use crate::math::ray::{Ray, ShadowRays};
use crate::math::sampling::Sampler;
use crate::scene::Scene;
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
            LightSampler::Quad { .. } => {
                let mut scratch = QuadScratch::EMPTY;
                quad_light(scene, ray, hit, material, &light_sampler, &mut shadow_rays, n, sampler, counters, &mut scratch)
            }
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
/// ([`QuadBatch`]), then traced and summed in order (the same sum as one sample at a time);
/// fewer than [`BATCH_FROM`] samples one at a time ([`one_light`]).
/// PERF: out of line, so that point lights keep a small `direct_lighting` (inlined, it made
/// point-light scenes 20% slower). `scratch` is the batch's memory, reused from call to
/// call by the caller (made and zeroed per batch, then copied out of `QuadBatch::new`, it
/// was 8% of tp6-matte-quad's Whitted render).
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
) -> Color {
    if n < BATCH_FROM {
        return one_light(scene, ray, hit, material, light_sampler, shadow_rays, n, sampler, counters);
    }
    let mut sum = Color::ZERO;
    let mut xi = [Vec2::ZERO; BATCH];
    for first in (0..n).step_by(BATCH) {
        let count = (n - first).min(BATCH as u32) as usize;
        sampler.fill_2d(&mut xi[..count]);
        let QuadScratch { batch, f } = scratch;
        // Lanes past `count` may hold an earlier batch's samples: never live, never summed.
        batch.fill(light_sampler, shadow_rays, hit.normal, &xi, count);
        let live = live_mask(&batch.live, count);
        counters.shadow += u64::from(live.count_ones());
        // All the hit's shadow rays at once (`Scene::occluded_lanes` decides how).
        let blocked = scene.occluded_lanes(&batch.rays, live);
        // `material.shade(ray, hit, &batch.sample(j))` of every sample, computed together.
        batch.shade_into(material, ray, hit, f);
        batch.add_seen(f, live & !blocked, count, &mut sum);
    }
    sum / n as f32
}
