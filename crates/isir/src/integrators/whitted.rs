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

impl SpecularSplit {
    /// The branches Whitted follows from a ray carrying `weight` of the camera ray's
    /// colour, in order (the reflection, then the refraction), each with its weight `w`:
    /// those with `w > 0` and `weight · w` at least [`WHITTED_MIN_WEIGHT`].
    fn branches(&self, weight: f32) -> impl Iterator<Item = (Vec3, f32)> {
        [Some((self.reflected, self.kr)), self.refracted.map(|t| (t, 1.0 - self.kr))]
            .into_iter()
            .flatten()
            .filter(move |&(_, w)| w > 0.0 && weight * w >= WHITTED_MIN_WEIGHT)
    }
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
    for (dir, w) in split.branches(weight) {
        counters.secondary += 1;
        c += w * trace(ctx, &hit.spawn_ray(dir), 0.0, f32::INFINITY, depth + 1, weight * w, sampler, counters);
    }
    c
}

/// A ray of the recursion of [`li_at_hits`]: where it goes, what it meets, and the
/// branches it splits into.
struct Node {
    ray: Ray,
    /// The closest hit (`None`: the background).
    hit: Option<Hit>,
    depth: u32,
    weight: f32,
    /// The branches followed, in `at_hit`'s order (reflection, then refraction): the
    /// node's index and its weight `w`.
    children: [Option<(usize, f32)>; 2],
}

/// Whitted's colours of the camera rays `rays` of the lanes of `mask`, which met mirror or
/// glass at `hits` (into `out`): what [`li`] returns for them once the hits are known, bit
/// for bit, with the same random numbers drawn from each lane's sampler. The recursion's rays are found breadth first, all lanes'
/// rays of one depth together ([`Scene::intersect_lanes`]); then each lane's tree is
/// summed depth first, as `at_hit` sums it, its direct lighting drawn in the same order.
/// PERF: one lane at a time, each ray of the recursion one `Scene::intersect`: tp6-glass
/// 0.939 this way, tp6-mirror 0.970, tp6-glass-quad 0.983 (medians of 9, the same images).
#[allow(clippy::too_many_arguments)]
pub(super) fn li_at_hits(
    scene: &Scene,
    rays: &crate::math::ray::RayLanes,
    hits: &[Option<Hit>; crate::math::ray::LANES],
    mask: u32,
    light_samples: u32,
    max_depth: u32,
    samplers: &mut [Sampler],
    counters: &mut RayCounters,
    out: &mut [Color],
) {
    use crate::math::ray::{lanes_of, RayLanes, RaySegment, LANES};
    let mut nodes: Vec<Node> = Vec::new();
    let mut roots = [usize::MAX; LANES];
    let mut frontier = Vec::new();
    for k in lanes_of(mask) {
        roots[k] = nodes.len();
        frontier.push(nodes.len());
        nodes.push(Node { ray: rays.ray(k), hit: hits[k], depth: 0, weight: 1.0, children: [None, None] });
    }
    while !frontier.is_empty() {
        // The branches of this depth's mirror and glass hits.
        let mut born = Vec::new();
        for &i in &frontier {
            let Node { ray, hit, depth, weight, .. } = nodes[i];
            let Some(hit) = hit else { continue };
            let wo = -ray.direction.normalize();
            let Some(split) = specular_split(scene.material(&hit), &hit, wo) else { continue };
            if depth >= max_depth {
                continue;
            }
            for (b, (dir, w)) in split.branches(weight).enumerate() {
                counters.secondary += 1;
                let child = nodes.len();
                nodes.push(Node { ray: hit.spawn_ray(dir), hit: None, depth: depth + 1, weight: weight * w, children: [None, None] });
                nodes[i].children[b] = Some((child, w));
                born.push(child);
            }
        }
        // Their closest hits, sixteen at a time.
        for chunk in born.chunks(LANES) {
            let segments: Vec<RaySegment> = chunk
                .iter()
                .map(|&c| RaySegment { origin: nodes[c].ray.origin, t_min: 0.0, direction: nodes[c].ray.direction, t_max: f32::INFINITY })
                .collect();
            let lanes = RayLanes::new(&segments);
            let closest = scene.intersect_lanes(&lanes, chunk.len());
            let found = scene.lane_hits(&lanes, &closest, chunk.len());
            for (j, &c) in chunk.iter().enumerate() {
                nodes[c].hit = found[j];
            }
        }
        frontier = born;
    }
    for k in lanes_of(mask) {
        out[k] = sum_tree(scene, &nodes, roots[k], light_samples, max_depth, &mut samplers[k], counters);
    }
}

/// The colour of node `i` of a recursion built by [`li_at_hits`], as `at_hit` (or `trace`)
/// computes it.
fn sum_tree(
    scene: &Scene,
    nodes: &[Node],
    i: usize,
    light_samples: u32,
    max_depth: u32,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Color {
    let node = &nodes[i];
    let Some(hit) = &node.hit else {
        return scene.background;
    };
    // A mirror or glass has a split (`specular_split`), any other material direct lighting.
    if !scene.material(hit).is_delta() {
        return direct_lighting(scene, &node.ray, hit, light_samples, sampler, counters);
    }
    if node.depth >= max_depth {
        return BLACK;
    }
    let mut c = BLACK;
    for (child, w) in node.children.iter().flatten() {
        c += *w * sum_tree(scene, nodes, *child, light_samples, max_depth, sampler, counters);
    }
    c
}
