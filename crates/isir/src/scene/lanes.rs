//! The seam for many rays at once: the closest hits of up to [`LANES`] rays (the camera
//! samples the renderer traces together), each lane's answer that of [`Scene::intersect`]
//! for its ray, bit for bit.
//!
//! Spheres and planes are tested against all the lanes in one vectorised loop each
//! ([`crate::geometry::Sphere::closest_lanes`], [`crate::geometry::Plane::closest_lanes`]);
//! meshes and the other shapes take the lanes one by one. Objects are met in the order of
//! [`Scene::intersect`], so ties between objects go to the same one.

use super::Scene;
use crate::geometry::{Geometry, Hit};
use crate::math::ray::{RayLanes, LANES};

/// No object: the lane's ray met nothing.
pub const NO_OBJECT: u32 = u32::MAX;

/// The closest hits of up to [`LANES`] rays, phase 1 (what [`Scene::intersect`] finds
/// before it builds the surface interaction): object, `t`, triangle and barycentrics.
#[derive(Clone, Copy, Debug)]
pub struct LaneHits {
    /// The object hit, or [`NO_OBJECT`].
    pub object: [u32; LANES],
    /// The hit's `t`.
    pub t: [f32; LANES],
    /// Triangle within a mesh (0 for other shapes).
    pub prim: [u32; LANES],
    /// Barycentric `u` on a triangle.
    pub u: [f32; LANES],
    /// Barycentric `v` on a triangle.
    pub v: [f32; LANES],
}

impl Scene {
    /// The closest hits of the first `count` rays of `rays`, each in its `[t_min, t_max)`:
    /// lane `k` holds what [`Scene::intersect`] finds for ray `k` before it builds the
    /// [`Hit`] ([`Scene::lane_hit`] builds it). Invalid rays and lanes from `count` on
    /// meet nothing.
    #[must_use]
    pub fn intersect_lanes(&self, rays: &RayLanes, count: usize) -> LaneHits {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, which is all `intersect_lanes_avx2` is compiled for.
            return unsafe { self.intersect_lanes_avx2(rays, count) };
        }
        self.intersect_lanes_portable(rays, count)
    }

    /// [`Scene::intersect_lanes`] compiled for AVX2: the spheres' and planes' lane loops
    /// eight lanes wide (no FMA contraction: the same floats).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn intersect_lanes_avx2(&self, rays: &RayLanes, count: usize) -> LaneHits {
        self.intersect_lanes_portable(rays, count)
    }

    #[inline(always)]
    pub(crate) fn intersect_lanes_portable(&self, rays: &RayLanes, count: usize) -> LaneHits {
        let mut hits = LaneHits { object: [NO_OBJECT; LANES], t: [0.0; LANES], prim: [0; LANES], u: [0.0; LANES], v: [0.0; LANES] };
        let count = count.min(LANES);
        let valid: [bool; LANES] = std::array::from_fn(|k| k < count && rays.ray(k).is_valid());
        if self.top_level.is_some() {
            for k in (0..count).filter(|&k| valid[k]) {
                if let Some((i, t, prim, u, v)) = self.closest(&rays.ray(k), rays.t_min[k], rays.t_max[k]) {
                    (hits.object[k], hits.t[k], hits.prim[k], hits.u[k], hits.v[k]) = (i as u32, t, prim, u, v);
                }
            }
            return hits;
        }
        // An interval no `t` is in: `t < -∞` never holds.
        let mut t_best: [f32; LANES] = std::array::from_fn(|k| if valid[k] { rays.t_max[k] } else { f32::NEG_INFINITY });
        for (i, object) in self.objects.iter().enumerate() {
            let mark = |mask: u32, hits: &mut LaneHits| {
                let mut m = mask;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    (hits.object[k], hits.prim[k], hits.u[k], hits.v[k]) = (i as u32, 0, 0.0, 0.0);
                }
            };
            match &object.geometry {
                Geometry::Sphere(s) => mark(s.closest_lanes(rays, &mut t_best), &mut hits),
                Geometry::Plane(p) => mark(p.closest_lanes(rays, &mut t_best), &mut hits),
                Geometry::Mesh(m) => {
                    // The mesh's box against all the lanes at once, then the lanes that may
                    // meet it one by one.
                    let near = m.may_hit_lanes(rays);
                    for k in (0..count).filter(|&k| valid[k] && near & (1 << k) != 0) {
                        if let Some(h) = m.intersect_near(&rays.ray(k), rays.t_min[k], t_best[k]) {
                            t_best[k] = h.t;
                            (hits.object[k], hits.prim[k], hits.u[k], hits.v[k]) = (i as u32, h.prim, h.u, h.v);
                        }
                    }
                }
                _ => {
                    for k in (0..count).filter(|&k| valid[k]) {
                        if let Some((t, prim, u, v)) = self.hit_object(i, &rays.ray(k), rays.t_min[k], t_best[k]) {
                            t_best[k] = t;
                            (hits.object[k], hits.prim[k], hits.u[k], hits.v[k]) = (i as u32, prim, u, v);
                        }
                    }
                }
            }
        }
        hits.t = t_best;
        hits
    }

    /// The surface interaction of lane `k` of `hits` (found for the rays `rays`), as
    /// [`Scene::intersect`] returns it for ray `k`; `None` where the lane met nothing.
    /// PERF: the ray is read from the lanes here, not passed by reference: a `Ray` written
    /// float by float and read back as pairs of floats stalled on store forwarding.
    #[must_use]
    pub fn lane_hit(&self, rays: &RayLanes, hits: &LaneHits, k: usize) -> Option<Hit> {
        let i = hits.object[k];
        (i != NO_OBJECT).then(|| self.interaction_inline(&rays.ray(k), i as usize, hits.t[k], hits.prim[k], hits.u[k], hits.v[k]))
    }
}

#[cfg(test)]
mod tests {
    use crate::math::ray::{RayLanes, RaySegment, LANES};
    use crate::math::sampling::Sampler;
    use crate::{scenes, Accel};
    use glam::Vec3;

    /// A mesh's box test in lanes answers as the one-ray test, lane by lane: rays from
    /// inside, outside and far from the box, axis-parallel, zero and NaN directions.
    #[test]
    fn may_hit_lanes_answers_as_may_hit() {
        let desc = scenes::builtin("tp4-bunny").unwrap();
        let scene = desc.build(Accel::BvhSah).unwrap();
        let (_, mesh) = scene.meshes().next().unwrap();
        let (lo, hi) = (mesh.aabb().min, mesh.aabb().max);
        let mut rng = Sampler::from_seed(8);
        let (mut yes, mut no) = (0, 0);
        for round in 0..2000 {
            let rays: Vec<RaySegment> = (0..1 + round % LANES)
                .map(|k| {
                    let mut r = |a: f32, b: f32| a + (b - a) * rng.next_f32();
                    let spread = [0.5, 2.0, 50.0][k % 3];
                    let c = (lo + hi) * 0.5;
                    let e = (hi - lo) * spread;
                    let origin = Vec3::new(r(c.x - e.x, c.x + e.x), r(c.y - e.y, c.y + e.y), r(c.z - e.z, c.z + e.z));
                    let mut direction = Vec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(-1.0, 1.0));
                    match (round + k) % 7 {
                        0 => direction = Vec3::ZERO,
                        1 => direction.y = 0.0,
                        2 => direction.x = f32::NAN,
                        _ => {}
                    }
                    RaySegment { origin, t_min: 0.0, direction, t_max: [f32::INFINITY, 0.05, 1.0][k % 3] }
                })
                .collect();
            let mask = mesh.may_hit_lanes(&RayLanes::new(&rays));
            for (k, r) in rays.iter().enumerate() {
                let expected = mesh.may_hit(&r.ray(), r.t_min, r.t_max);
                assert_eq!(mask & (1 << k) != 0, expected, "{r:?}");
                if expected {
                    yes += 1;
                } else {
                    no += 1;
                }
            }
        }
        assert!(yes > 1000 && no > 1000, "{yes} {no}");
    }

    /// Every lane finds the hit of `Scene::intersect`, field for field, on scenes of
    /// spheres, planes, meshes, an implicit surface and a top-level BVH, with invalid rays
    /// and partial groups among them.
    #[test]
    fn lanes_find_the_hits_of_intersect() {
        let mut many = scenes::builtin("tp2-plane-point").unwrap();
        let sphere = many.objects[0].clone();
        for i in 0..20 {
            let mut s = sphere.clone();
            s.name = format!("s{i}");
            if let scenes::ShapeDesc::Sphere(sph) = &mut s.shape {
                sph.center += Vec3::new(i as f32 * 0.3 - 3.0, (i % 3) as f32 * 0.5, (i % 5) as f32);
                sph.radius = 0.4;
            }
            many.objects.push(s);
        }
        let mut rng = Sampler::from_seed(3);
        for desc in
            ["tp2-plane-point", "tp4-bunny", "tp6-glass", "tp7-implicit"].map(|n| scenes::builtin(n).unwrap()).into_iter().chain([many])
        {
            let scene = desc.build(Accel::BvhSah).unwrap();
            let camera = desc.camera.build(1.5);
            let mut found = 0;
            for round in 0..300 {
                let count = 1 + round % LANES;
                let rays: Vec<RaySegment> = (0..count)
                    .map(|k| {
                        let mut r = camera.generate_ray(rng.next_f32(), rng.next_f32());
                        match (round + k) % 13 {
                            0 => r.direction = Vec3::ZERO,
                            1 => r.origin.y = f32::NAN,
                            _ => {}
                        }
                        let t_max = if k % 4 == 1 { 5.0 } else { f32::INFINITY };
                        RaySegment { origin: r.origin, t_min: 0.0, direction: r.direction, t_max }
                    })
                    .collect();
                let lanes = RayLanes::new(&rays);
                let hits = scene.intersect_lanes(&lanes, count);
                for (k, r) in rays.iter().enumerate() {
                    let expected = scene.intersect(&r.ray(), r.t_min, r.t_max);
                    let got = scene.lane_hit(&lanes, &hits, k);
                    assert_eq!(format!("{got:?}"), format!("{expected:?}"), "{}: {r:?}", desc.name);
                    found += usize::from(got.is_some());
                }
            }
            assert!(found > 300, "{}: {found} hits", desc.name);
        }
    }
}
