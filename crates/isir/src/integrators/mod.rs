//! Integrators: `Li(scene, ray, tMin, tMax)`, the colour seen along a ray.
//!
//! - [`Integrator::RayCast`] and [`Integrator::DirectLighting`]: the course's first two
//!   (`ray_cast.rs`, `direct.rs`).
//! - [`Integrator::Whitted`]: the course's recursive ray tracer (`whitted.rs`).
//! - [`Integrator::Path`]: beyond the course, a path tracer with next-event estimation
//!   and multiple importance sampling (`path.rs`), written against the materials'
//!   `eval` / `pdf` / `sample` contract ([`crate::materials`]).

mod direct;
mod lanes;
mod path;
mod ray_cast;
mod shadow;
mod whitted;

use crate::materials::Material;
use crate::math::color::Color;
use crate::math::ray::Ray;
use crate::math::sampling::Sampler;
use crate::scene::Scene;

pub use whitted::{specular_split, SpecularSplit, WHITTED_MIN_WEIGHT};

/// The course's `maxBounces`: the default `max_depth` of Whitted and the path tracer.
pub const DEFAULT_MAX_DEPTH: u32 = 5;

/// The largest `max_depth` accepted: the Whitted recursion is that deep at most (on the
/// worker's stack), and a path that long carries nothing visible. An integrator built
/// with a larger one renders with this one (scene files and the CLI refuse it).
pub const MAX_DEPTH_LIMIT: u32 = 256;

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounters {
    /// Camera rays.
    pub primary: u64,
    /// Shadow rays.
    pub shadow: u64,
    /// Rays leaving a surface (Whitted's reflections and refractions, the path tracer's
    /// BSDF-sampled rays).
    pub secondary: u64,
}

impl RayCounters {
    /// All rays.
    #[must_use]
    pub fn total(&self) -> u64 {
        self.primary + self.shadow + self.secondary
    }

    /// The sum of two counts.
    #[must_use]
    pub fn add(&self, o: &RayCounters) -> RayCounters {
        RayCounters { primary: self.primary + o.primary, shadow: self.shadow + o.shadow, secondary: self.secondary + o.secondary }
    }
}

/// The course's integrators, and the path tracer.
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
    /// Whitted: mirrors reflect, transparent materials reflect `kr` and refract `1 - kr`
    /// (Fresnel, both rays traced; total internal reflection reflects only), every other
    /// material gets direct lighting; black after `max_depth` bounces. Rays that miss see
    /// the background.
    Whitted {
        /// Samples per area light for the direct lighting.
        light_samples: u32,
        /// The course's `maxBounces`: reflections and refractions along a path.
        max_depth: u32,
    },
    /// A path tracer: next-event estimation on every light (`light_samples` samples per
    /// quad light, one per point light), BSDF sampling, the power heuristic between the
    /// two for quad lights, Russian roulette from the fourth vertex on. A path has at
    /// most `max_depth` BSDF-sampled rays (`max_depth` 1: direct lighting). The quad
    /// light is a one-sided emitting rectangle, seen by camera and BSDF-sampled rays but
    /// not blocking anything (as it blocks no shadow ray); the background is a uniform
    /// environment seen by every ray that leaves the scene.
    Path {
        /// Samples per quad light at each vertex.
        light_samples: u32,
        /// Most BSDF-sampled rays in a path.
        max_depth: u32,
    },
}

impl Integrator {
    /// The command-line names, in order (`--integrator`).
    pub const NAMES: [&'static str; 4] = ["ray-cast", "direct", "whitted", "path"];

    /// The command-line name.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Integrator::RayCast => Self::NAMES[0],
            Integrator::DirectLighting { .. } => Self::NAMES[1],
            Integrator::Whitted { .. } => Self::NAMES[2],
            Integrator::Path { .. } => Self::NAMES[3],
        }
    }

    /// Samples per area light (1 for ray cast, which samples none).
    #[must_use]
    pub fn light_samples(&self) -> u32 {
        match *self {
            Integrator::RayCast => 1,
            Integrator::DirectLighting { light_samples }
            | Integrator::Whitted { light_samples, .. }
            | Integrator::Path { light_samples, .. } => light_samples,
        }
    }

    /// The bounce limit ([`DEFAULT_MAX_DEPTH`] for those without one).
    #[must_use]
    pub fn max_depth(&self) -> u32 {
        match *self {
            Integrator::Whitted { max_depth, .. } | Integrator::Path { max_depth, .. } => max_depth,
            _ => DEFAULT_MAX_DEPTH,
        }
    }

    /// The same integrator with another light sample count (ray cast ignores it).
    #[must_use]
    pub fn with_light_samples(self, n: u32) -> Self {
        let n = n.max(1);
        match self {
            Integrator::RayCast => Integrator::RayCast,
            Integrator::DirectLighting { .. } => Integrator::DirectLighting { light_samples: n },
            Integrator::Whitted { max_depth, .. } => Integrator::Whitted { light_samples: n, max_depth },
            Integrator::Path { max_depth, .. } => Integrator::Path { light_samples: n, max_depth },
        }
    }

    /// The same integrator with another bounce limit, clamped to `1..=MAX_DEPTH_LIMIT`
    /// (ray cast and direct lighting ignore it).
    #[must_use]
    pub fn with_max_depth(self, d: u32) -> Self {
        let max_depth = d.clamp(1, MAX_DEPTH_LIMIT);
        match self {
            Integrator::Whitted { light_samples, .. } => Integrator::Whitted { light_samples, max_depth },
            Integrator::Path { light_samples, .. } => Integrator::Path { light_samples, max_depth },
            other => other,
        }
    }

    /// What a user should know before trusting this integrator's image of `scene`, one
    /// line each: the path tracer warns once when objects use the course's
    /// `ColorMaterial`, which it treats as Lambert with albedo = colour.
    #[must_use]
    pub fn warnings(&self, scene: &Scene) -> Vec<String> {
        let mut out = Vec::new();
        if let Integrator::Path { .. } = self {
            let mut used: Vec<u32> = scene.objects.iter().flat_map(|o| o.materials.iter().copied()).collect();
            used.sort_unstable();
            used.dedup();
            let colors = used.iter().filter(|&&m| matches!(scene.materials.get(m as usize), Some(Material::Color(_)))).count();
            if colors > 0 {
                out.push(format!(
                    "the path tracer treats ColorMaterial (the course's BRDF = colour, no 1/π, not energy conserving) as Lambert \
                     with albedo = colour, so surfaces of {colors} ColorMaterial{} are π times darker than with direct lighting",
                    if colors == 1 { "" } else { "s" }
                ));
            }
        }
        out
    }

    /// The radiance arriving along `ray`.
    pub fn li(&self, scene: &Scene, ray: &Ray, t_min: f32, t_max: f32, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
        match *self {
            Integrator::RayCast => ray_cast::li(scene, ray, t_min, t_max, counters),
            Integrator::DirectLighting { light_samples } => direct::li(scene, ray, t_min, t_max, light_samples, sampler, counters),
            Integrator::Whitted { light_samples, max_depth } => {
                whitted::li(scene, ray, t_min, t_max, light_samples, max_depth.min(MAX_DEPTH_LIMIT), sampler, counters)
            }
            Integrator::Path { light_samples, max_depth } => {
                path::li(scene, ray, t_min, t_max, light_samples, max_depth.min(MAX_DEPTH_LIMIT), sampler, counters)
            }
        }
    }
}

#[cfg(test)]
mod tests;
