//! The path tracer (beyond the course; pbrt-v4's `PathIntegrator`): at each vertex,
//! next-event estimation towards every light and one BSDF-sampled ray, the two combined by
//! multiple importance sampling (power heuristic) for quad lights, whose emission a
//! BSDF-sampled ray can meet; Russian roulette on the throughput.
//!
//! What it estimates: the quad light emits `L_e = colour·power` from its front (the
//! course's sample radiance `colour·power / pdf` is exactly the estimate of that
//! surface's light), so with `max_depth` 1 and Lambert materials it converges to the
//! direct-lighting integrator's image. Point lights are met by next-event estimation
//! only. The background is a uniform environment: any ray leaving the scene brings it.

use super::shadow::{LaneBrdf, QuadBatch, VertexSamples, BATCH, BATCH_FROM};
use super::RayCounters;
use crate::geometry::Hit;
use crate::kept::{Kept, Slot};
use crate::lights::{Light, LightHit, LightSample, LightSampler};
use crate::materials::{BsdfSample, Material};
use crate::math::color::Color;
use crate::math::ray::{lanes_of, Ray};
use crate::math::sampling::Sampler;
use crate::scene::Scene;
use glam::{Vec2, Vec3};

/// Russian roulette starts once a path has this many BSDF-sampled rays: the first
/// bounces carry most of the light and are always traced.
pub(super) const ROULETTE_DEPTH: u32 = 3;

/// Veach's power heuristic (β = 2) for `nf` samples of pdf `f_pdf` against `ng` of `g_pdf`.
#[inline]
fn power_heuristic(nf: f32, f_pdf: f32, ng: f32, g_pdf: f32) -> f32 {
    let (f, g) = (nf * f_pdf, ng * g_pdf);
    if f.is_infinite() {
        return 1.0;
    }
    let (f2, g2) = (f * f, g * g);
    if f2 + g2 > 0.0 {
        f2 / (f2 + g2)
    } else {
        0.0
    }
}

/// The path tracer's `Li`.
#[allow(clippy::too_many_arguments)]
pub(super) fn li(
    scene: &Scene,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    light_samples: u32,
    max_depth: u32,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Color {
    counters.primary += 1;
    let lights = light_samplers(scene);
    let mut path = Path::new();
    path.follow(scene, &lights, ray, (t_min, t_max), light_samples, max_depth, sampler, counters);
    path.l
}

/// The samplers of the scene's lights, in order ([`Light::sampler`]: what sampling a
/// light needs, computed once per path, or once per sixteen paths in lanes).
pub(super) fn light_samplers(scene: &Scene) -> Vec<LightSampler> {
    scene.lights.iter().map(Light::sampler).collect()
}

/// A path being traced: what it has gathered so far (the ray it follows is the caller's).
/// [`li`] steps one path to its end; the lanes step sixteen paths side by side, each
/// bounce's hits found together.
#[derive(Clone, Copy, Debug)]
pub(super) struct Path {
    /// The radiance gathered.
    pub(super) l: Color,
    /// The throughput.
    beta: Color,
    /// The camera ray and rays from delta lobes: emitters they meet count fully (no light
    /// sampling could have found them).
    specular: bool,
    /// The solid-angle pdf of the BSDF sample that made the ray followed.
    bsdf_pdf: f32,
    /// BSDF-sampled rays so far.
    depth: u32,
}

impl Path {
    /// A path starting at the camera.
    pub(super) fn new() -> Path {
        Path { l: Color::ZERO, beta: Color::ONE, specular: true, bsdf_pdf: 0.0, depth: 0 }
    }

    /// The path from `ray` (in `t_min..t_max`) to its end, vertex by vertex
    /// ([`Path::step`]). [`li`] follows a path from the camera; the lanes follow their last
    /// few paths alone.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn follow(
        &mut self,
        scene: &Scene,
        lights: &[LightSampler],
        ray: &Ray,
        (t_min, t_max): (f32, f32),
        light_samples: u32,
        max_depth: u32,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
    ) {
        let (mut ray, mut t_min, mut t_max) = (*ray, t_min, t_max);
        while let Some(next) =
            self.step(scene, lights, &ray, t_min, t_max, scene.intersect(&ray, t_min, t_max), light_samples, max_depth, sampler, counters)
        {
            (ray, t_min, t_max) = (next, 0.0, f32::INFINITY);
        }
    }

    /// One vertex: `hit` is the closest hit of `ray` in `[t_min, t_max)`, `lights` the
    /// samplers of the scene's lights ([`light_samplers`]). Gathers the light met there;
    /// returns the next ray (`t` from 0 to ∞), `None` when the path ends. Four phases,
    /// which the lanes run phase by phase over their sixteen paths: [`Path::arrive`],
    /// [`Path::light_direct`], [`Path::sample_bsdf`], [`Path::advance`] (then the ray,
    /// [`Hit::spawn_ray`]).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn step(
        &mut self,
        scene: &Scene,
        lights: &[LightSampler],
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        hit: Option<Hit>,
        light_samples: u32,
        max_depth: u32,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
    ) -> Option<Ray> {
        let wo = self.arrive(scene, lights, ray, t_min, t_max, hit.as_ref(), light_samples, max_depth)?;
        let Some(hit) = &hit else { unreachable!("an arrived vertex has a hit") };
        self.light_direct(scene, lights, hit, wo, light_samples, sampler, counters);
        let bs = Path::sample_bsdf(scene, hit, wo, sampler);
        let wi = self.advance(bs, sampler, counters)?;
        Some(hit.spawn_ray(wi))
    }

    /// A vertex reached by `ray` (in `[t_min, t_max)`, its closest hit `hit`): quad lights
    /// met on the way ([`Path::meet_lights`]), the background when the ray met nothing.
    /// Returns the direction towards the ray's origin when the path goes on, `None` when
    /// it ends here.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn arrive(
        &mut self,
        scene: &Scene,
        lights: &[LightSampler],
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        hit: Option<&Hit>,
        light_samples: u32,
        max_depth: u32,
    ) -> Option<Vec3> {
        self.meet_lights(lights, ray, t_min, hit.map_or(t_max, |h| h.t), light_samples);
        self.goes_on(scene, hit, max_depth).then(|| -ray.direction.normalize())
    }

    /// The quad lights `ray` meets in `(t_min, t_hit)` (they block nothing): their
    /// emission, weighted against light sampling unless the ray is the camera's or
    /// specular.
    #[inline(always)]
    pub(super) fn meet_lights(&mut self, lights: &[LightSampler], ray: &Ray, t_min: f32, t_hit: f32, light_samples: u32) {
        for light in lights {
            if let Some(lh) = light.intersect(ray, t_min, t_hit) {
                self.meet_light(&lh, light_samples);
            }
        }
    }

    /// What a quad light met by the ray (`lh`) adds.
    #[inline(always)]
    pub(super) fn meet_light(&mut self, lh: &LightHit, light_samples: u32) {
        if lh.emitted != Color::ZERO {
            let w = if self.specular { 1.0 } else { power_heuristic(1.0, self.bsdf_pdf, light_samples.max(1) as f32, lh.pdf) };
            self.l += self.beta * lh.emitted * w;
        }
    }

    /// The background when the ray met nothing; false when the path ends here (no hit, or
    /// `max_depth` reached).
    #[inline(always)]
    pub(super) fn goes_on(&mut self, scene: &Scene, hit: Option<&Hit>, max_depth: u32) -> bool {
        if hit.is_none() {
            self.l += self.beta * scene.background;
            return false;
        }
        self.depth < max_depth
    }

    /// Next-event estimation at `hit` (none on a delta material), added to the path's
    /// radiance. (In a scene lit by one point light, the lanes take this phase as
    /// [`Path::defer_point`] instead, their shadow rays traced together.)
    #[allow(clippy::too_many_arguments)]
    pub(super) fn light_direct(
        &mut self,
        scene: &Scene,
        lights: &[LightSampler],
        hit: &Hit,
        wo: Vec3,
        light_samples: u32,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
    ) {
        let material = scene.material(hit);
        if !material.is_delta() {
            let sum = next_event(scene, lights, hit, material, wo, light_samples.max(1), sampler, counters);
            self.l += self.beta * sum;
        }
    }

    /// The BSDF sample at `hit` (its two random numbers drawn from `sampler`).
    #[inline]
    pub(super) fn sample_bsdf(scene: &Scene, hit: &Hit, wo: Vec3, sampler: &mut Sampler) -> Option<BsdfSample> {
        let (u_lobe, u) = (sampler.next_f32(), sampler.next_2d());
        scene.material(hit).sample(hit, wo, u_lobe, u)
    }

    /// The path past the BSDF sample `bs`: the throughput and Russian roulette. Returns
    /// the direction of the next ray, `None` when the path ends here.
    pub(super) fn advance(&mut self, bs: Option<BsdfSample>, sampler: &mut Sampler, counters: &mut RayCounters) -> Option<Vec3> {
        let bs = bs?;
        if bs.weight == Color::ZERO || !(bs.delta || bs.pdf > 0.0) {
            return None;
        }
        self.beta *= bs.weight;
        self.specular = bs.delta;
        self.bsdf_pdf = bs.pdf;
        self.depth += 1;
        if self.depth > ROULETTE_DEPTH {
            // Survive with probability max(β) (capped at 1) and carry 1/p more: unbiased.
            let p = self.beta.max_element().min(1.0);
            if p.is_nan() || sampler.next_f32() >= p {
                return None;
            }
            self.beta /= p;
        }
        counters.secondary += 1;
        Some(bs.wi)
    }
}

/// True when the lanes can leave a vertex's shadow ray untraced ([`Path::defer_point`]):
/// the scene is lit by one point light (one shadow ray per vertex).
pub(super) fn defers_shadow(scene: &Scene) -> bool {
    scene.lights.len() == 1 && !scene.lights[0].is_surface()
}

/// What a point light's shadow ray left untraced by [`Path::defer_point`] adds when it
/// is not blocked, and the throughput at that vertex (the ray itself stays in the lanes'
/// [`super::shadow::LightLanes`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct DeferredShadow {
    value: Color,
    beta: Color,
}

impl DeferredShadow {
    /// Nothing to add (a placeholder for lanes without a deferred ray).
    pub(super) const NONE: DeferredShadow = DeferredShadow { value: Color::ZERO, beta: Color::ZERO };
}

impl Path {
    /// [`Path::light_direct`] in a scene lit by one point light ([`defers_shadow`]), given
    /// that light's sample `ls` from `hit`, as the light's sampler makes it, and whether
    /// `ShadowRays::to` gives it a shadow ray (`has_ray`): what the shadow ray, left
    /// untraced, adds ([`Path::finish_shadow`] adds it once the ray is answered), or `None`
    /// after adding what the vertex adds without one. The same
    /// operations as [`next_event`], so the same floats. The lanes set up the samples and
    /// shadow rays of sixteen paths together ([`super::shadow::LightLanes`]) and trace
    /// the rays in one `Scene::occluded_lanes`.
    /// PERF: inlined into the lanes: its answer, returned through the stack, was copied
    /// before the callee's stores had retired.
    #[inline(always)]
    pub(super) fn defer_point(
        &mut self,
        scene: &Scene,
        hit: &Hit,
        wo: Vec3,
        ls: &LightSample,
        has_ray: bool,
        counters: &mut RayCounters,
    ) -> Option<DeferredShadow> {
        let material = scene.material(hit);
        debug_assert!(!material.is_delta() && defers_shadow(scene));
        if let Some(f) = traced_f(material, hit, wo, ls).filter(|_| has_ray) {
            counters.shadow += 1;
            return Some(self.deferred(unoccluded(ls, f, hit, 1.0)));
        }
        self.add_unlit();
        None
    }

    /// [`Path::defer_point`]'s deferred sample, given what it brings unoccluded.
    #[inline(always)]
    pub(super) fn deferred(&self, value: Color) -> DeferredShadow {
        DeferredShadow { value, beta: self.beta }
    }

    /// [`Path::defer_point`] without a shadow ray: `next_event`'s sum is zero (no sample
    /// reached the light), added as it adds it.
    #[inline(always)]
    pub(super) fn add_unlit(&mut self) {
        self.l += self.beta * Color::ZERO;
    }

    /// The BRDF value at `hit` of the light sample `ls` when it is worth a shadow ray, as
    /// [`next_event`] decides it (for the lanes, which set up the samples of many paths
    /// together).
    #[inline(always)]
    pub(super) fn light_sample_f(scene: &Scene, hit: &Hit, wo: Vec3, ls: &LightSample) -> Option<Color> {
        traced_f(scene.material(hit), hit, wo, ls)
    }

    /// What the unoccluded sample `ls` (BRDF value `f`) of a quad light sampled `n` times
    /// brings, weighted against BSDF sampling, as [`next_event`] computes it.
    pub(super) fn quad_sample_value(scene: &Scene, hit: &Hit, wo: Vec3, ls: &LightSample, f: Color, n: u32) -> Color {
        unoccluded(ls, f, hit, quad_weight(n, ls, scene.material(hit), hit, wo))
    }

    /// Adds one light's part of [`next_event`]'s sum: `acc`, the sum of its `n` samples,
    /// averaged (the same operations, so the same floats).
    pub(super) fn add_light_average(&mut self, acc: Color, n: u32) {
        let mut sum = Color::ZERO;
        sum += acc / n as f32;
        self.l += self.beta * sum;
    }

    /// Adds what [`next_event`] would have added with the deferred shadow ray `d`
    /// answered: the same operations, so the same floats.
    pub(super) fn finish_shadow(&mut self, d: &DeferredShadow, blocked: bool) {
        let mut acc = Color::ZERO;
        if !blocked {
            acc += d.value;
        }
        let mut sum = Color::ZERO;
        sum += acc / 1.0;
        self.l += d.beta * sum;
    }
}

thread_local! {
    /// This thread's batch of a vertex's quad-light samples (`Path::light_direct`), kept
    /// from vertex to vertex: [`QuadBatch::fill`] rewrites the lanes that are read (those
    /// below the count). PERF: made and zeroed per vertex, its `memset` was 1.6% of the
    /// path tracer on tp6-glass-quad (its own materials, sixteen light samples).
    static QUAD_BATCH: Slot<QuadBatch> = const { std::cell::Cell::new(None) };
}

/// The BRDF value of a light sample worth a shadow ray (some radiance, a valid pdf, a
/// nonzero BRDF), `None` for one that is not.
#[inline(always)]
fn traced_f(material: &Material, hit: &Hit, wo: Vec3, ls: &LightSample) -> Option<Color> {
    if ls.radiance == Color::ZERO || ls.pdf.is_nan() || ls.pdf <= 0.0 {
        return None;
    }
    Some(material.eval(hit, wo, ls.direction)).filter(|&f| f != Color::ZERO)
}

/// The MIS weight of the sample `ls` of a quad light sampled `n` times, against BSDF
/// sampling (power heuristic).
#[inline(always)]
fn quad_weight(n: u32, ls: &LightSample, material: &Material, hit: &Hit, wo: Vec3) -> f32 {
    power_heuristic(n as f32, ls.pdf, 1.0, material.pdf(hit, wo, ls.direction))
}

/// What an unoccluded light sample of BRDF value `f` brings, with MIS weight `w`.
#[inline(always)]
fn unoccluded(ls: &LightSample, f: Color, hit: &Hit, w: f32) -> Color {
    f * ls.radiance * ls.direction.dot(hit.normal).abs() * w
}

/// Light arriving at `hit` straight from the lights and leaving towards `wo`: for each
/// light the average over its samples (`n_light` per quad light, one per point light) of
/// `f · L · |cos| / pdf`, weighted against BSDF sampling for quad lights.
#[allow(clippy::too_many_arguments)]
fn next_event(
    scene: &Scene,
    lights: &[LightSampler],
    hit: &Hit,
    material: &Material,
    wo: Vec3,
    n_light: u32,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Color {
    let mut sum = Color::ZERO;
    let mut shadow_rays = hit.shadow_rays();
    for (light, light_sampler) in scene.lights.iter().zip(lights) {
        let n = if light.is_surface() { n_light } else { 1 };
        let mut acc = Color::ZERO;
        // What an unoccluded sample of BRDF value `f` brings.
        let unoccluded = |ls: &LightSample, f: Color| {
            let w = if light.is_surface() { quad_weight(n, ls, material, hit, wo) } else { 1.0 };
            unoccluded(ls, f, hit, w)
        };
        let traced_f = |ls: &LightSample| traced_f(material, hit, wo, ls);
        let mut visit = |ls: &LightSample, ray: Option<(Ray, f32)>, acc: &mut Color| {
            let Some(f) = traced_f(ls) else { return };
            let Some((shadow, t_max)) = ray else { return };
            counters.shadow += 1;
            if scene.occluded(&shadow, 0.0, t_max) {
                return;
            }
            *acc += unoccluded(ls, f);
        };
        if matches!(light_sampler, LightSampler::Quad { .. }) && n >= BATCH_FROM {
            // Sixteen samples set up at a time (`QuadBatch`), then used in order.
            let mut xi = [Vec2::ZERO; BATCH];
            let mut batch = Kept::take(&QUAD_BATCH, || QuadBatch::EMPTY);
            let lanes_brdf = LaneBrdf::of(material);
            for first in (0..n).step_by(BATCH) {
                let count = (n - first).min(BATCH as u32) as usize;
                sampler.fill_2d(&mut xi[..count]);
                batch.fill(light_sampler, &shadow_rays, hit.normal, &xi, count);
                if let Some(lobe) = lanes_brdf {
                    // The same samples, values and sums as below, computed in lanes.
                    let mut value = [[0f32; BATCH]; 3];
                    let traced = batch.brdf_values(VertexSamples { lobe, normal: hit.normal, wo, n, count }, &mut value);
                    counters.shadow += u64::from(traced.count_ones());
                    let blocked = scene.occluded_lanes(&batch.rays, traced);
                    for j in lanes_of(traced & !blocked) {
                        acc += Color::new(value[0][j], value[1][j], value[2][j]);
                    }
                    continue;
                }
                // The samples `visit` would trace, their shadow rays traced as one packet,
                // then summed in order as `visit` sums them.
                let mut f = [Color::ZERO; BATCH];
                let mut traced = 0u32;
                for j in (0..count).filter(|&j| batch.has_ray[j]) {
                    if let Some(fj) = traced_f(&batch.sample(j)) {
                        f[j] = fj;
                        traced |= 1 << j;
                    }
                }
                counters.shadow += u64::from(traced.count_ones());
                let blocked = scene.occluded_lanes(&batch.rays, traced);
                for j in (0..count).filter(|&j| traced & !blocked & (1 << j) != 0) {
                    let ls = batch.sample(j);
                    acc += unoccluded(&ls, f[j]);
                }
            }
        } else {
            for _ in 0..n {
                let ls = light_sampler.sample(hit.point, sampler.next_2d());
                visit(&ls, shadow_rays.to_inline(ls.point), &mut acc);
            }
        }
        sum += acc / n as f32;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::power_heuristic;

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(0.3f32, 2.0f32), (1.0, 1.0), (5.0, 0.01)] {
            let w = power_heuristic(4.0, a, 1.0, b) + power_heuristic(1.0, b, 4.0, a);
            assert!((w - 1.0).abs() < 1e-6);
        }
        assert_eq!(power_heuristic(1.0, 0.0, 1.0, 0.0), 0.0);
        assert_eq!(power_heuristic(1.0, 1.0, 1.0, 0.0), 1.0);
    }
}
