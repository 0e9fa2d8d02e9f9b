//! The course's Whitted integrator: mirrors recurse along the reflection, transparent
//! materials split into `kr·reflect + (1 - kr)·refract` (Fresnel `kr = (Rs + Rp)/2`,
//! both rays traced, no randomness; total internal reflection reflects only), every other
//! material gets direct lighting; black after `max_depth` bounces.

use super::direct::direct_lighting;
use super::RayCounters;
use crate::geometry::Hit;
use crate::materials::{fresnel_dielectric, reflect, refract, Material};
use crate::math::color::{Color, BLACK};
use crate::math::ray::Ray;
use crate::math::sampling::Sampler;
use crate::scene::Scene;
use glam::Vec3;

/// A branch of the recursion whose weight (the product of the `kr` and `1 - kr` on the
/// way) is below this is not traced. Glass doubles the rays at each bounce, so without it
/// `max_depth` 30 would be 2^30 rays per sample; the weights of one depth's branches sum
/// to at most 1, so with it a depth has fewer than 1/`WHITTED_MIN_WEIGHT` branches. What
/// is left out weighs under 1e-5 of the radiance it would have brought: at the course's
/// depth 5 only paths of three or more internal reflections (`kr³ ≈ 5e-6` at ior 1.3).
pub const WHITTED_MIN_WEIGHT: f32 = 1e-5;

/// How a specular surface sends a ray on: the reflection with weight `kr`, and the
/// refraction with weight `1 - kr` (none past the critical angle, where `kr` = 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecularSplit {
    /// The mirror direction of `wo`.
    pub reflected: Vec3,
    /// The weight of the reflection (1 for a mirror; Fresnel's for glass).
    pub kr: f32,
    /// The refracted direction, weighted `1 - kr`; `None` for a mirror and under total
    /// internal reflection.
    pub refracted: Option<Vec3>,
}

/// The split of Whitted's recursion at `hit` for a ray leaving towards `wo` (unit,
/// away from the surface), or `None` for a material that gets direct lighting.
#[must_use]
pub fn specular_split(material: &Material, hit: &Hit, wo: Vec3) -> Option<SpecularSplit> {
    let n = hit.normal;
    match *material {
        Material::Mirror => Some(SpecularSplit { reflected: reflect(wo, n), kr: 1.0, refracted: None }),
        Material::Transparent { ior } => {
            // The index across the surface as the ray crosses it: entering the glass (the
            // front face), `ior`; leaving it, `1 / ior`.
            let eta = if hit.front_face { ior } else { 1.0 / ior };
            let cos_o = n.dot(wo);
            match refract(wo, n, eta) {
                Some(t) => Some(SpecularSplit { reflected: reflect(wo, n), kr: fresnel_dielectric(cos_o, eta), refracted: Some(t) }),
                None => Some(SpecularSplit { reflected: reflect(wo, n), kr: 1.0, refracted: None }),
            }
        }
        _ => None,
    }
}

/// What every level of the recursion shares.
struct Ctx<'a> {
    scene: &'a Scene,
    light_samples: u32,
    max_depth: u32,
}

/// Whitted's `Li`.
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
    let ctx = Ctx { scene, light_samples, max_depth };
    trace(&ctx, ray, t_min, t_max, 0, 1.0, sampler, counters)
}

/// The colour along `ray`, which has made `depth` bounces and carries `weight` of the
/// camera ray's colour.
#[allow(clippy::too_many_arguments)]
fn trace(
    ctx: &Ctx,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    depth: u32,
    weight: f32,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Color {
    let Some(hit) = ctx.scene.intersect(ray, t_min, t_max) else {
        return ctx.scene.background;
    };
    at_hit(ctx, ray, &hit, depth, weight, sampler, counters)
}

/// Whitted's colour of a camera ray whose closest hit is `hit` (found by
/// [`Scene::intersect_lanes`]): what [`li`] returns for it once the hit is known.
#[allow(clippy::too_many_arguments)]
pub(super) fn li_at_hit(
    scene: &Scene,
    ray: &Ray,
    hit: &Hit,
    light_samples: u32,
    max_depth: u32,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Color {
    at_hit(&Ctx { scene, light_samples, max_depth }, ray, hit, 0, 1.0, sampler, counters)
}

/// The colour along `ray` (`depth` bounces, `weight` of the camera ray's colour) whose
/// closest hit is `hit`: direct lighting, or the specular recursion.
#[allow(clippy::too_many_arguments)]
fn at_hit(ctx: &Ctx, ray: &Ray, hit: &Hit, depth: u32, weight: f32, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
    let hit = *hit;
    let material = ctx.scene.material(&hit);
    let wo = -ray.direction.normalize();
    let Some(split) = specular_split(material, &hit, wo) else {
        return direct_lighting(ctx.scene, ray, &hit, ctx.light_samples, sampler, counters);
    };
    if depth >= ctx.max_depth {
        return BLACK;
    }
    let mut c = BLACK;
    let mut follow = |dir: Vec3, w: f32, counters: &mut RayCounters, sampler: &mut Sampler| {
        if w > 0.0 && weight * w >= WHITTED_MIN_WEIGHT {
            counters.secondary += 1;
            c += w * trace(ctx, &hit.spawn_ray(dir), 0.0, f32::INFINITY, depth + 1, weight * w, sampler, counters);
        }
    };
    follow(split.reflected, split.kr, counters, sampler);
    if let Some(t) = split.refracted {
        follow(t, 1.0 - split.kr, counters, sampler);
    }
    c
}
