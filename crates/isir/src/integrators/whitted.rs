//! The course's Whitted integrator: mirrors recurse along the reflection, transparent
//! materials split into `kr·reflect + (1 - kr)·refract` (Fresnel `kr = (Rs + Rp)/2`,
//! both rays traced, no randomness; total internal reflection reflects only), every other
//! material gets direct lighting; black after `max_depth` bounces.

use super::direct::direct_lighting;
use super::RayCounters;
use crate::geometry::Hit;
use crate::materials::{fresnel_dielectric, reflect, refract, Material};
use crate::math::color::{Color, BLACK};
use crate::math::ray::{lanes_of, Ray, RayLanes, LANES};
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
    match specular_eta(material, hit)? {
        None => Some(SpecularSplit { reflected: reflect(wo, n), kr: 1.0, refracted: None }),
        Some(eta) => {
            let cos_o = n.dot(wo);
            match refract(wo, n, eta) {
                Some(t) => Some(SpecularSplit { reflected: reflect(wo, n), kr: fresnel_dielectric(cos_o, eta), refracted: Some(t) }),
                None => Some(SpecularSplit { reflected: reflect(wo, n), kr: 1.0, refracted: None }),
            }
        }
    }
}

/// Whether Whitted splits the recursion at `hit`: `None` for a material that gets direct
/// lighting, `Some(None)` for a mirror, `Some(Some(eta))` for glass, `eta` the index across
/// the surface as the ray crosses it (entering the glass at its front face, `ior`; leaving
/// it, `1 / ior`).
fn specular_eta(material: &Material, hit: &Hit) -> Option<Option<f32>> {
    match *material {
        Material::Mirror => Some(None),
        Material::Transparent { ior } => Some(Some(if hit.front_face { ior } else { 1.0 / ior })),
        _ => None,
    }
}

/// [`specular_split`] of up to [`LANES`] mirror and glass hits at once, bit for bit: the
/// same operations on the same floats (`reflect`, `refract`, `fresnel_dielectric` and
/// glam's `normalize`, in their order, without FMA), every lane computed without a branch
/// so that the loops are SIMD (eight lanes wide where the CPU has AVX2).
/// PERF: one hit at a time, a split is a chain of dependent divisions and square roots
/// (the ray's `normalize`, Snell's law, Fresnel's two quotients).
struct SplitLanes {
    reflected: [[f32; LANES]; 3],
    refracted: [[f32; LANES]; 3],
    kr: [f32; LANES],
    /// The lanes whose split has a refraction (glass short of total internal reflection).
    refracts: u32,
}

impl SplitLanes {
    /// The splits of lanes whose shading normal is `n`, whose ray arrived along `d` (not
    /// necessarily unit), glass (bit set in `glass`) of relative index `eta` or a mirror.
    fn new(n: &[[f32; LANES]; 3], d: &[[f32; LANES]; 3], eta: &[f32; LANES], glass: u32) -> Self {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            #[target_feature(enable = "avx2")]
            fn avx2(n: &[[f32; LANES]; 3], d: &[[f32; LANES]; 3], eta: &[f32; LANES], glass: u32) -> SplitLanes {
                SplitLanes::portable(n, d, eta, glass)
            }
            // SAFETY: the CPU has AVX2, which is all `avx2` is compiled for.
            return unsafe { avx2(n, d, eta, glass) };
        }
        Self::portable(n, d, eta, glass)
    }

    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    fn portable(n: &[[f32; LANES]; 3], d: &[[f32; LANES]; 3], eta: &[f32; LANES], glass: u32) -> Self {
        let mut s = SplitLanes { reflected: [[0.0; LANES]; 3], refracted: [[0.0; LANES]; 3], kr: [1.0; LANES], refracts: 0 };
        let mut refracts = [false; LANES];
        for k in 0..LANES {
            // `wo = -ray.direction.normalize()`.
            let r = 1.0 / (d[0][k] * d[0][k] + d[1][k] * d[1][k] + d[2][k] * d[2][k]).sqrt();
            let wo = [-(d[0][k] * r), -(d[1][k] * r), -(d[2][k] * r)];
            let cos_o = n[0][k] * wo[0] + n[1][k] * wo[1] + n[2][k] * wo[2];
            // `reflect`: `2·(n·wo)·n - wo`.
            let twice = 2.0 * cos_o;
            for axis in 0..3 {
                s.reflected[axis][k] = twice * n[axis][k] - wo[axis];
            }
            // `refract`.
            let e = eta[k];
            let sin2_t = (1.0 - cos_o * cos_o).max(0.0) / (e * e);
            let cos_t = (1.0 - sin2_t).sqrt();
            let a = cos_o / e - cos_t;
            let t = [-wo[0] / e + a * n[0][k], -wo[1] / e + a * n[1][k], -wo[2] / e + a * n[2][k]];
            let rt = 1.0 / (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
            for axis in 0..3 {
                s.refracted[axis][k] = t[axis] * rt;
            }
            // `refract`'s `None` only where `sin2_t >= 1` (a NaN goes on, as there).
            refracts[k] = glass & (1 << k) != 0 && (sin2_t < 1.0 || sin2_t.is_nan());
            // `fresnel_dielectric(cos_o, eta)`.
            let ci = cos_o.clamp(0.0, 1.0);
            let f2 = (1.0 - ci * ci) / (e * e);
            let ct = (1.0 - f2).sqrt();
            let rs = (ci - e * ct) / (ci + e * ct);
            let rp = (e * ci - ct) / (e * ci + ct);
            let fresnel = if f2 >= 1.0 { 1.0 } else { 0.5 * (rs * rs + rp * rp) };
            s.kr[k] = if refracts[k] { fresnel } else { 1.0 };
        }
        s.refracts = crate::math::ray::lane_mask(&refracts);
        s
    }

    /// Lane `k`'s split, as [`specular_split`] returns it.
    fn split(&self, k: usize) -> SpecularSplit {
        let v = |a: &[[f32; LANES]; 3]| Vec3::new(a[0][k], a[1][k], a[2][k]);
        SpecularSplit {
            reflected: v(&self.reflected),
            kr: self.kr[k],
            refracted: (self.refracts & (1 << k) != 0).then(|| v(&self.refracted)),
        }
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
    rays: &RayLanes,
    hits: &[Option<Hit>; LANES],
    mask: u32,
    light_samples: u32,
    max_depth: u32,
    samplers: &mut [Sampler],
    counters: &mut RayCounters,
    out: &mut [Color],
) {
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
        for chunk in frontier.chunks(LANES) {
            // The splits of sixteen nodes at once (`SplitLanes`), then their branches node
            // by node, in the order `at_hit` follows them.
            let (mut n, mut d, mut eta) = ([[0f32; LANES]; 3], [[0f32; LANES]; 3], [1f32; LANES]);
            let (mut splitting, mut glass) = (0u32, 0u32);
            for (k, &i) in chunk.iter().enumerate() {
                let node = &nodes[i];
                let Some(hit) = &node.hit else { continue };
                let Some(e) = specular_eta(scene.material(hit), hit) else { continue };
                if node.depth >= max_depth {
                    continue;
                }
                if let Some(e) = e {
                    (glass, eta[k]) = (glass | 1 << k, e);
                }
                splitting |= 1 << k;
                for axis in 0..3 {
                    n[axis][k] = hit.normal[axis];
                    d[axis][k] = node.ray.direction[axis];
                }
            }
            if splitting == 0 {
                continue;
            }
            let splits = SplitLanes::new(&n, &d, &eta, glass);
            for k in lanes_of(splitting) {
                let i = chunk[k];
                let Node { hit: Some(hit), depth, weight, .. } = nodes[i] else { unreachable!("a splitting node has a hit") };
                for (b, (dir, w)) in splits.split(k).branches(weight).enumerate() {
                    counters.secondary += 1;
                    let child = nodes.len();
                    nodes.push(Node { ray: hit.spawn_ray(dir), hit: None, depth: depth + 1, weight: weight * w, children: [None, None] });
                    nodes[i].children[b] = Some((child, w));
                    born.push(child);
                }
            }
        }
        // Their closest hits, sixteen at a time.
        let mut found = [None; LANES];
        for chunk in born.chunks(LANES) {
            let mut lanes = RayLanes::EMPTY;
            for (j, &c) in chunk.iter().enumerate() {
                lanes.set(j, nodes[c].ray.origin, nodes[c].ray.direction, 0.0, f32::INFINITY);
            }
            let closest = scene.intersect_lanes(&lanes, chunk.len());
            scene.lane_hits_into(&lanes, &closest, chunk.len(), &mut found);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `SplitLanes` (the AVX2 build where the CPU has it, and the portable one) gives
    /// `specular_split`'s splits bit for bit: mirrors and glass entered and left, past the
    /// critical angle and short of it, grazing, with directions of any length, zero and NaN.
    #[test]
    fn split_lanes_are_specular_splits() {
        let mut rng = Sampler::from_seed(21);
        let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        let same3 = |a: Vec3, b: Vec3| (0..3).all(|i| same(a[i], b[i]));
        let (mut tir, mut refracted, mut mirrors) = (0, 0, 0);
        for round in 0..400 {
            let mut r = || 2.0 * rng.next_f32() - 1.0;
            let (mut n, mut d, mut eta) = ([[0f32; LANES]; 3], [[0f32; LANES]; 3], [1f32; LANES]);
            let mut hits = Vec::new();
            let mut glass = 0u32;
            for k in 0..LANES {
                let normal = Vec3::new(r(), r(), r()).normalize();
                let mut dir = Vec3::new(r(), r(), r()) * [1.0, 1e-3, 40.0][k % 3];
                // Grazing, straight on, zero and NaN directions.
                match (round + k) % 11 {
                    0 => dir = normal.cross(Vec3::new(r(), r(), r())),
                    1 => dir = -normal * 3.0,
                    2 => dir = Vec3::ZERO,
                    3 => dir.y = f32::NAN,
                    _ => {}
                }
                let material = if k % 4 == 0 { Material::Mirror } else { Material::Transparent { ior: [1.3, 1.0, 2.4, 0.7][k % 4] } };
                let hit = Hit { t: 1.0, normal, geometric_normal: normal, front_face: (round + k) % 2 == 0, ..Hit::ZERO };
                if let Some(Some(e)) = specular_eta(&material, &hit) {
                    (glass, eta[k]) = (glass | 1 << k, e);
                }
                for axis in 0..3 {
                    (n[axis][k], d[axis][k]) = (normal[axis], dir[axis]);
                }
                hits.push((material, hit, dir));
            }
            for lanes in [SplitLanes::new(&n, &d, &eta, glass), SplitLanes::portable(&n, &d, &eta, glass)] {
                for (k, (material, hit, dir)) in hits.iter().enumerate() {
                    let expected = specular_split(material, hit, -dir.normalize()).unwrap();
                    let got = lanes.split(k);
                    assert!(same3(got.reflected, expected.reflected) && same(got.kr, expected.kr), "{got:?} {expected:?}");
                    match (got.refracted, expected.refracted) {
                        (Some(a), Some(b)) => assert!(same3(a, b), "{a} {b}"),
                        (None, None) => {}
                        other => panic!("{other:?} for {hit:?} {dir}"),
                    }
                }
            }
            let lanes = SplitLanes::new(&n, &d, &eta, glass);
            refracted += lanes.refracts.count_ones();
            tir += lanes_of(glass & !lanes.refracts).count();
            mirrors += lanes_of(!glass & 0xffff).count();
        }
        assert!(tir > 300 && refracted > 1000 && mirrors > 1000, "{tir} {refracted} {mirrors}");
    }
}
