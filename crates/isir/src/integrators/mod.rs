//! Integrators: `Li(scene, ray, tMin, tMax)`, the colour seen along a ray.

use crate::geometry::Hit;
use crate::math::color::Color;
use crate::math::ray::Ray;
use crate::math::sampling::Sampler;
use crate::scene::Scene;

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounters {
    /// Camera rays.
    pub primary: u64,
    /// Shadow rays.
    pub shadow: u64,
}

impl RayCounters {
    /// All rays.
    #[must_use]
    pub fn total(&self) -> u64 {
        self.primary + self.shadow
    }
}

/// The course's integrators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Integrator {
    /// Flat colour of the material times `max(dot(n, -dir), 0)`.
    RayCast,
    /// Direct lighting with shadow rays: `light_samples` samples per area light, one per
    /// point light.
    DirectLighting {
        /// The course's `nbLightSamples`.
        light_samples: u32,
    },
}

impl Integrator {
    /// The same integrator with another light sample count (ray cast ignores it).
    #[must_use]
    pub fn with_light_samples(self, n: u32) -> Self {
        match self {
            Integrator::RayCast => Integrator::RayCast,
            Integrator::DirectLighting { .. } => Integrator::DirectLighting { light_samples: n.max(1) },
        }
    }

    /// The radiance arriving along `ray`.
    pub fn li(&self, scene: &Scene, ray: &Ray, t_min: f32, t_max: f32, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
        counters.primary += 1;
        let Some(hit) = scene.intersect(ray, t_min, t_max) else {
            return scene.background;
        };
        match *self {
            Integrator::RayCast => scene.material(&hit).flat_color() * hit.normal.dot(-ray.direction).max(0.0),
            Integrator::DirectLighting { light_samples } => direct_lighting(scene, ray, &hit, light_samples, sampler, counters),
        }
    }
}

/// Sum over the lights of the average over samples of `shade · radiance · cos`, counting a
/// sample only when its shadow ray reaches the light.
fn direct_lighting(scene: &Scene, ray: &Ray, hit: &Hit, light_samples: u32, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
    let material = scene.material(hit);
    let mut li = Color::ZERO;
    for light in &scene.lights {
        let n = if light.is_surface() { light_samples.max(1) } else { 1 };
        let mut sum = Color::ZERO;
        for _ in 0..n {
            let ls = light.sample(hit.point, sampler.next_2d());
            let cos = ls.direction.dot(hit.normal).max(0.0);
            if cos == 0.0 || ls.radiance == Color::ZERO {
                continue;
            }
            // ---- Shadow ray, from outside the hit point's error bound on the light's side ----
            let Some((shadow, t_max)) = hit.spawn_ray_to(ls.point) else { continue };
            counters.shadow += 1;
            if !scene.occluded(&shadow, 0.0, t_max) {
                sum += material.shade(ray, hit, &ls) * ls.radiance * cos;
            }
        }
        li += sum / n as f32;
    }
    li
}
