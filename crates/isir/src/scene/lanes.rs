//! The seam for many rays at once: the closest hits of up to [`LANES`] rays (the camera
//! samples the renderer traces together), each lane's answer that of [`Scene::intersect`]
//! for its ray, bit for bit.
//!
//! Spheres and planes are tested against all the lanes in one vectorised loop each
//! ([`crate::geometry::Sphere::closest_lanes`], [`crate::geometry::Plane::closest_lanes`]);
//! a mesh's lanes, or an instance's carried into its mesh's space, go down its tree
//! together; the other shapes take the lanes one by one. Objects are met in the order of
//! [`Scene::intersect`], so ties between objects go to the same one.

use super::{Scene, MESH_PACKET_FROM};
use crate::accel::shaft::{self, Cell, ShaftGrid};
use crate::accel::wide::{Cut, WideBvh};
use crate::geometry::{Geometry, Hit, HitRows, ShapeLanes, TriangleLanes};
use crate::kept::{Kept, Slot};
use crate::math::ray::{lanes_of, RayLanes, LANES};

/// The lanes of `live` whose rays are valid, in both batches. PERF: the lane loops eight
/// lanes wide where the CPU has AVX2.
fn valid_masks(rays: [&RayLanes; 2], live: [u32; 2]) -> [u32; 2] {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        #[target_feature(enable = "avx2")]
        fn avx2(rays: [&RayLanes; 2], live: [u32; 2]) -> [u32; 2] {
            [live[0] & rays[0].valid_mask(), live[1] & rays[1].valid_mask()]
        }
        // SAFETY: the CPU has AVX2, which is all `avx2` is compiled for.
        return unsafe { avx2(rays, live) };
    }
    [live[0] & rays[0].valid_mask(), live[1] & rays[1].valid_mask()]
}

/// No object: the lane's ray met nothing.
pub const NO_OBJECT: u32 = u32::MAX;

/// The fewest lanes meeting spheres and planes, in a scene with meshes too, built together
/// ([`ShapeLanes`]); fewer go one by one.
const SHAPE_LANES_FROM: u32 = 4;

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
        // The valid rays among the first `count` (`Ray::is_valid`), all the lanes at once.
        // PERF: lane by lane, each ray's six finiteness tests were 1.5% of the path tracer.
        let valid_lanes = rays.valid_mask() & ((1u32 << count) - 1);
        let valid = |k: usize| valid_lanes & (1 << k) != 0;
        if self.top_level.is_some() {
            for k in (0..count).filter(|&k| valid(k)) {
                if let Some((i, t, prim, u, v)) = self.closest(&rays.ray(k), rays.t_min[k], rays.t_max[k]) {
                    (hits.object[k], hits.t[k], hits.prim[k], hits.u[k], hits.v[k]) = (i as u32, t, prim, u, v);
                }
            }
            return hits;
        }
        // An interval no `t` is in: `t < -∞` never holds. A NaN `t_max` is such an interval
        // too (`t < NaN` never holds), given as -∞: the shapes' lane loops keep the best
        // as a minimum, which would replace a NaN.
        let mut t_best: [f32; LANES] =
            std::array::from_fn(|k| if valid(k) & !rays.t_max[k].is_nan() { rays.t_max[k] } else { f32::NEG_INFINITY });
        for (i, object) in self.objects.iter().enumerate() {
            match &object.geometry {
                Geometry::Sphere(s) => mark_shape(s.closest_lanes(rays, &mut t_best), i as u32, &mut hits),
                Geometry::Plane(p) => mark_shape(p.closest_lanes(rays, &mut t_best), i as u32, &mut hits),
                Geometry::Mesh(m) => {
                    // The mesh's box against all the lanes at once, then the valid lanes
                    // that may meet it together (one stream where the mesh has one).
                    let near = m.may_hit_lanes(rays) & valid_lanes;
                    let mut found = [None; LANES];
                    m.intersect_lanes_near(rays, &t_best, near, &mut found);
                    for k in lanes_of(near) {
                        if let Some(h) = found[k] {
                            t_best[k] = h.t;
                            (hits.object[k], hits.prim[k], hits.u[k], hits.v[k]) = (i as u32, h.prim, h.u, h.v);
                        }
                    }
                }
                Geometry::Instance(inst) => {
                    // The same in the mesh's space: the lanes' rays carried there as
                    // `Instance::intersect` carries each (the same `t`).
                    let local = inst.object_lanes(rays);
                    let near = inst.mesh.may_hit_lanes(&local) & valid_lanes;
                    let mut found = [None; LANES];
                    inst.mesh.intersect_lanes_near(&local, &t_best, near, &mut found);
                    for k in lanes_of(near) {
                        if let Some(h) = found[k] {
                            t_best[k] = h.t;
                            (hits.object[k], hits.prim[k], hits.u[k], hits.v[k]) = (i as u32, h.prim, h.u, h.v);
                        }
                    }
                }
                _ => {
                    for k in (0..count).filter(|&k| valid(k)) {
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

    /// [`Scene::lane_hit`] of the first `count` lanes (`None` from `count` on), in a new
    /// array: [`Scene::lane_hits_into`], which the renderer's loops call on their own.
    #[must_use]
    pub fn lane_hits(&self, rays: &RayLanes, hits: &LaneHits, count: usize) -> [Option<Hit>; LANES] {
        let mut out = [None; LANES];
        self.lane_hits_into(rays, hits, count, &mut out);
        out
    }

    /// [`Scene::lane_hits`] written into `out` (every lane: `None` from `count` on).
    /// PERF: built in place, in one loop: each `lane_hit` returned through the stack and
    /// copied into the array stalled on store forwarding (8% of tp4-bunny); and into the
    /// caller's array: returned by value, the sixteen hits (1.4 kB) were built in a local
    /// and then copied (`memmove`, 8% of tp1-sphere's samples).
    pub fn lane_hits_into(&self, rays: &RayLanes, hits: &LaneHits, count: usize, out: &mut [Option<Hit>; LANES]) {
        set_nones(out);
        self.hits_into_nones(rays, hits, count, out, None);
    }

    /// [`Scene::lane_hits`] written into `out` (every lane: `None` from `count` on), and
    /// the hits' rows into `rows` (those of [`HitRows::of`]`(out)`; in a scene of spheres
    /// and planes, written from the SIMD loops' own rows).
    /// PERF: the path tracer's loop keeps one array of hits: returned by value, each
    /// bounce's 1.3 kB of hits was copied into it (tp6-matte 0.93 of the time with the
    /// other arrays kept). Its own function: `lane_hits` calling it made tp4-sphere 5%
    /// slower. The rows: gathered from the hits by the path tracer's phases, tp6-matte
    /// took 1.05 of the time and tp6-glass-quad 1.03.
    pub fn lane_hit_rows_into(&self, rays: &RayLanes, hits: &LaneHits, count: usize, out: &mut [Option<Hit>; LANES], rows: &mut HitRows) {
        set_nones(out);
        self.hits_into_nones(rays, hits, count, out, Some(rows));
    }

    /// The hits of [`Scene::lane_hits`] written into `out`, whose lanes are all `None`.
    #[inline(always)]
    fn hits_into_nones(&self, rays: &RayLanes, hits: &LaneHits, count: usize, out: &mut [Option<Hit>; LANES], rows: Option<&mut HitRows>) {
        // A scene of one mesh (the conference room): its hits' face normals and points for
        // all the lanes at once (SIMD), then each hit built around them. PERF: all sixteen
        // lanes cost about what four computed one by one do; in scenes of several objects
        // finding the mesh lanes cost more than it saved (tp4-sphere 3% slower).
        const TRIANGLE_LANES_FROM: u32 = 4;
        let geometry = self.only_mesh().and_then(|m| {
            let meshes = (0..count.min(LANES)).filter(|&k| hits.object[k] == 0).fold(0u32, |m, k| m | 1 << k);
            (meshes.count_ones() >= TRIANGLE_LANES_FROM).then(|| {
                let mut p = [[[0f32; LANES]; 3]; 3];
                for k in lanes_of(meshes) {
                    m.vertices_into_lane(hits.prim[k], &mut p, k);
                }
                TriangleLanes::new(&p, &hits.u, &hits.v)
            })
        });
        // A scene of spheres and planes only (TP1–3, TP5, TP6): the hits' points, error
        // bounds and normals for all the lanes at once (SIMD), then each hit built around
        // them.
        if self.flat().is_some() {
            let mut shapes = ShapeLanes::EMPTY;
            let lanes = self.shape_lanes(hits, count, &mut shapes);
            let mut own = None;
            self.shape_hits_into(&shapes, lanes, rays, hits, rows_or(rows, &mut own), out);
            return;
        }
        // A scene of meshes beside spheres and planes (TP4's rooms): the lanes that met a
        // sphere or a plane, when there are enough of them, built as in a flat scene; the
        // others below, one by one. PERF: with planes alone skipping the spheres'
        // arithmetic (`ShapeLanes::hits`), tp4-bunny 0.986 of the CPU time (64 and 256
        // spp), tp4-sphere 0.989; computing the spheres' too, 1.02.
        let mut shape_lanes = 0u32;
        let mut rows = rows;
        if self.only_mesh().is_none() {
            let mut shapes = ShapeLanes::EMPTY;
            let lanes = self.shape_lanes(hits, count, &mut shapes);
            if lanes.count_ones() >= SHAPE_LANES_FROM {
                // The caller's rows as scratch (rewritten from `out` below), else zeroed ones.
                let mut own = None;
                self.shape_hits_into(&shapes, lanes, rays, hits, rows_or(rows.as_deref_mut(), &mut own), out);
                shape_lanes = lanes;
            }
        }
        // Its own loop: one loop taking an optional geometry made tp4-sphere 2% slower.
        if let Some(g) = geometry {
            for (k, slot) in out.iter_mut().enumerate().take(count) {
                if hits.object[k] != NO_OBJECT {
                    *slot = Some(self.interaction_given(&rays.ray(k), 0, hits.t[k], hits.prim[k], hits.u[k], hits.v[k], Some(g.lane(k))));
                }
            }
        } else {
            for (k, slot) in out.iter_mut().enumerate().take(count) {
                let i = hits.object[k];
                if i != NO_OBJECT && shape_lanes & (1 << k) == 0 {
                    *slot = Some(self.interaction_inline(&rays.ray(k), i as usize, hits.t[k], hits.prim[k], hits.u[k], hits.v[k]));
                }
            }
        }
        if let Some(rows) = rows {
            *rows = HitRows::of(out);
        }
    }

    /// The lanes (below `count`) whose hit is on a sphere or a plane, those shapes set in
    /// their lanes of `shapes`. PERF: `shapes` filled in place: returned by value, its
    /// copy (`memmove`) made tp1-sphere 4% slower.
    #[inline(always)]
    fn shape_lanes(&self, hits: &LaneHits, count: usize, shapes: &mut ShapeLanes) -> u32 {
        let mut lanes = 0u32;
        for k in 0..count.min(LANES) {
            let i = hits.object[k];
            if i == NO_OBJECT {
                continue;
            }
            match &self.objects[i as usize].geometry {
                Geometry::Sphere(s) => shapes.set_sphere(k, s),
                Geometry::Plane(p) => shapes.set_plane(k, p),
                _ => {
                    debug_assert!(self.flat().is_none(), "a flat scene is spheres and planes");
                    continue;
                }
            }
            lanes |= 1 << k;
        }
        lanes
    }

    /// The hits of the sphere and plane lanes `lanes` (their `shapes`): their points, error
    /// bounds and normals for all the lanes at once (SIMD, into `rows`), then each hit
    /// built around them into `out`.
    #[inline(always)]
    fn shape_hits_into(
        &self,
        shapes: &ShapeLanes,
        lanes: u32,
        rays: &RayLanes,
        hits: &LaneHits,
        rows: &mut HitRows,
        out: &mut [Option<Hit>; LANES],
    ) {
        let front = shapes.hits(rays, &hits.t, lanes, rows);
        let at = |a: &[[f32; LANES]; 3], k: usize| glam::Vec3::new(a[0][k], a[1][k], a[2][k]);
        for k in lanes_of(lanes) {
            let i = hits.object[k] as usize;
            let (point, point_error, normal) = (at(&rows.surface.p, k), at(&rows.surface.p_error, k), at(&rows.normal, k));
            out[k] = Some(Hit {
                t: hits.t[k],
                point,
                point_error,
                normal,
                geometric_normal: normal,
                front_face: front[k],
                object: i as u32,
                prim: hits.prim[k],
                u: hits.u[k],
                v: hits.v[k],
                uv: glam::Vec2::ZERO,
                // `interaction_given`'s material: slot 0 of the object's.
                material: self.objects[i].materials[0],
            });
        }
    }
}

/// Every lane of `out` `None`. PERF: lane by lane, a `None` is its tag alone; the whole
/// array assigned was a `memset` of its 1.4 kB, 0.8% of tp5-phong.
#[inline(always)]
fn set_nones(out: &mut [Option<Hit>; LANES]) {
    for o in out.iter_mut() {
        *o = None;
    }
}

/// The caller's rows, or else this thread's (as the last caller left them: what reads
/// them here, [`ShapeLanes::hits`], writes every lane of every row first).
#[inline(always)]
fn rows_or<'a>(rows: Option<&'a mut HitRows>, own: &'a mut Option<Kept<HitRows>>) -> &'a mut HitRows {
    match rows {
        Some(rows) => rows,
        None => own.insert(Kept::take(&SCRATCH_ROWS, HitRows::default)),
    }
}

thread_local! {
    /// The rows [`rows_or`] lends. PERF: zeroed per sixteen samples, their `memset` was
    /// 0.85% of tp5-phong.
    static SCRATCH_ROWS: Slot<HitRows> = const { std::cell::Cell::new(None) };
}

/// The lanes of `mask` now meet object `i`, a sphere or a plane (no triangle: `prim`,
/// `u` and `v` zero), every lane's row written at once, as bits.
/// PERF: lane by lane (a loop over the mask's bits), the marks were a fifth of
/// `intersect_lanes` in the TP6 room, the path tracer's bounces meeting several objects
/// each.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
fn mark_shape(mask: u32, i: u32, hits: &mut LaneHits) {
    if mask == 0 {
        return;
    }
    for k in 0..LANES {
        let m = 0u32.wrapping_sub((mask >> k) & 1);
        hits.object[k] = (i & m) | (hits.object[k] & !m);
        hits.prim[k] &= !m;
        hits.u[k] = f32::from_bits(hits.u[k].to_bits() & !m);
        hits.v[k] = f32::from_bits(hits.v[k].to_bits() & !m);
    }
}

impl Scene {
    /// [`Scene::occluded`] for the lanes `live` of `rays` (the shadow rays of one or many
    /// points, already in lanes): bit `k` set when `k` is in `live` and ray `k` is occluded
    /// in its `[t_min, t_max)`, the answers of one [`Scene::occluded`] per lane. Spheres and
    /// planes test all the lanes still open at once; meshes trace them as a packet
    /// ([`crate::geometry::TriangleMesh::occluded_lanes`]) from [`MESH_PACKET_FROM`] rays, one by one below.
    #[must_use]
    pub fn occluded_lanes(&self, rays: &RayLanes, live: u32) -> u32 {
        self.occluded_lanes_except(rays, live, 0)
    }

    /// [`Scene::occluded_lanes`] without testing the objects `skip` names (bit `i` for
    /// object `i`), which the caller has proved block none of the rays
    /// ([`Scene::quad_planes`]): the same answers.
    #[must_use]
    pub(crate) fn occluded_lanes_except(&self, rays: &RayLanes, live: u32, skip: u64) -> u32 {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, which is all `occluded_lanes_avx2` is compiled for.
            return unsafe { self.occluded_lanes_avx2(rays, live, skip) };
        }
        self.occluded_lanes_portable::<false>(rays, live, skip)
    }

    /// [`Scene::occluded_lanes`] for two batches of lanes at once (`[first's, second's]`,
    /// the same answers). A scene of one mesh traces both batches' rays as one stream
    /// ([`crate::geometry::TriangleMesh::occluded_lane_pair`]): four hits' light samples
    /// share every node of the tree. Other scenes go batch by batch.
    #[must_use]
    pub fn occluded_lane_pair(&self, rays: [&RayLanes; 2], live: [u32; 2]) -> [u32; 2] {
        if let Some(m) = self.pair_mesh() {
            return m.occluded_lane_pair(rays, valid_masks(rays, live));
        }
        [self.occluded_lanes(rays[0], live[0]), self.occluded_lanes(rays[1], live[1])]
    }

    /// [`Scene::occluded_lane_pair`] for shadow rays towards quad light `light` (from
    /// surface points to points of that light, as [`spawn_ray_to`] makes them): a ray
    /// whose origin's cell has a short list ([`ShaftGrid`]) is tested against that list,
    /// the others are traced; the same answers.
    ///
    /// [`spawn_ray_to`]: crate::math::ray::spawn_ray_to
    /// [`ShaftGrid`]: crate::accel::shaft::ShaftGrid
    pub(crate) fn occluded_pair_to_light(&self, light: usize, rays: [&RayLanes; 2], live: [u32; 2]) -> [u32; 2] {
        let Some((grid, bvh)) = self.shaft(light) else { return self.occluded_lane_pair(rays, live) };
        let mut starts = Starts::default();
        let answered =
            [listed_answers(grid, bvh, rays[0], live[0], 0, &mut starts), listed_answers(grid, bvh, rays[1], live[1], 1, &mut starts)];
        let mut traced = [0, 0];
        // The other rays, from each cut where their cells enter the tree (`shaft` answers
        // only in a scene of one mesh, the pair's mesh); the rays' validity found once.
        let valid = if starts.len == 0 { [0, 0] } else { valid_masks(rays, live) };
        for &(start, masks) in &starts.groups[..starts.len] {
            let t = bvh.occluded_lane_pair_from(start, rays, [masks[0] & valid[0], masks[1] & valid[1]]);
            traced = [traced[0] | t[0], traced[1] | t[1]];
        }
        [answered[0].1 | traced[0], answered[1].1 | traced[1]]
    }

    /// The mesh through which [`Scene::occluded_lane_pair`] traces two batches as one
    /// stream: that of a scene of one mesh (and no top-level tree).
    pub(crate) fn pair_mesh(&self) -> Option<&crate::geometry::TriangleMesh> {
        self.only_mesh().filter(|_| self.top_level.is_none())
    }

    /// [`Scene::occluded_lanes`] compiled for AVX2: the lane loops eight lanes wide (no FMA
    /// contraction: the same floats).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn occluded_lanes_avx2(&self, rays: &RayLanes, live: u32, skip: u64) -> u32 {
        self.occluded_lanes_portable::<true>(rays, live, skip)
    }

    /// The loops of [`Scene::occluded_lanes`]; `AVX2` when compiled into a function for
    /// AVX2 (the planes then tested with its intrinsics, [`Plane::hit_lanes_avx2`]).
    ///
    /// [`Plane::hit_lanes_avx2`]: crate::geometry::Plane::hit_lanes_avx2
    #[inline(always)]
    pub(crate) fn occluded_lanes_portable<const AVX2: bool>(&self, rays: &RayLanes, live: u32, skip: u64) -> u32 {
        let live = live & (u32::MAX >> (32 - LANES));
        let single = |i: usize, k: usize| u32::from(self.blocks(i, &rays.ray(k), rays.t_min[k], rays.t_max[k])) << k;
        if self.top_level.is_some() || live.count_ones() < 2 {
            return lanes_of(live).fold(0, |m, k| m | u32::from(self.occluded(&rays.ray(k), rays.t_min[k], rays.t_max[k])) << k);
        }
        let mut open = live & rays.valid_mask();
        if open == 0 {
            return 0;
        }
        // Whether the open rays share one origin (an area light's samples from one point),
        // asked only when a mesh is met. PERF: asked up front, 2.4% of tp6-glass-quad.
        let first = open.trailing_zeros() as usize;
        let one_origin = |open: u32| rays.same_origin_mask(first) & open == open;
        let mut occluded = 0;
        for (i, object) in self.objects.iter().enumerate() {
            if open == 0 {
                break;
            }
            if i < 64 && skip >> i & 1 != 0 {
                continue;
            }
            let blocked = match &object.geometry {
                Geometry::Sphere(s) => s.hit_lanes(rays) & open,
                Geometry::Plane(p) => {
                    #[cfg(target_arch = "x86_64")]
                    if AVX2 {
                        // SAFETY: `AVX2` is true only in `occluded_lanes_avx2`, which runs
                        // only where the CPU has AVX2.
                        unsafe { p.hit_lanes_avx2(rays) & open }
                    } else {
                        p.hit_lanes(rays) & open
                    }
                    #[cfg(not(target_arch = "x86_64"))]
                    {
                        p.hit_lanes(rays) & open
                    }
                }
                Geometry::Mesh(m) => {
                    // Only the rays that may meet the mesh's box (shadow rays from many
                    // hits miss a small mesh), then those together, their answers back in
                    // their lanes.
                    // PERF: rays of one origin (an area light's samples) skip the box test:
                    // on the conference room it costs 6% and culls nothing.
                    let near = if one_origin(open) { open } else { open & m.may_hit_lanes(rays) };
                    if (near.count_ones() as usize) < MESH_PACKET_FROM {
                        lanes_of(near).fold(0, |acc, k| acc | single(i, k))
                    } else {
                        m.occluded_lanes(rays, near)
                    }
                }
                Geometry::Instance(inst) => {
                    let local = inst.object_lanes(rays);
                    let near = open & inst.mesh.may_hit_lanes(&local);
                    if (near.count_ones() as usize) < MESH_PACKET_FROM {
                        lanes_of(near).fold(0, |acc, k| acc | single(i, k))
                    } else {
                        inst.mesh.occluded_lanes(&local, near)
                    }
                }
                _ => lanes_of(open).fold(0, |acc, k| acc | single(i, k)),
            };
            occluded |= blocked;
            open &= !blocked;
        }
        occluded
    }
}

/// The rays of two batches that no list answered, grouped by where they start their walk
/// down the tree: a cut of it ([`Cell::Entry`]) or the root (`None`), with the masks of
/// each group's lanes in the two batches.
#[derive(Default)]
struct Starts<'a> {
    groups: [(Option<&'a Cut>, [u32; 2]); 2 * LANES],
    len: usize,
}

impl<'a> Starts<'a> {
    /// Lanes `mask` of batch `batch` start at `start`.
    fn add(&mut self, start: Option<&'a Cut>, batch: usize, mask: u32) {
        let at = |s: Option<&Cut>| s.map(std::ptr::from_ref);
        if let Some(g) = self.groups[..self.len].iter_mut().find(|g| at(g.0) == at(start)) {
            g.1[batch] |= mask;
        } else {
            self.groups[self.len] = (start, [0, 0]);
            self.groups[self.len].1[batch] = mask;
            self.len += 1;
        }
    }
}

/// The lanes of `live` (shadow rays towards the light of `grid`) whose origin's cell has
/// a list, and those of them that a triangle of the list blocks: the lanes leaving from
/// one origin (a hit's samples) tested together, a lone lane by itself. The other lanes
/// go to `starts` as lanes of batch `batch`.
/// PERF: only for a hit's several samples. The sixteen lanes of one sample each, sixteen
/// origins (`quad_few_lanes`), answered here were slower than traced: the conference
/// room at one light sample and 64 spp, 2.38 -> 2.74 s of CPU.
fn listed_answers<'a>(
    grid: &'a ShaftGrid,
    bvh: &WideBvh,
    lanes: &RayLanes,
    live: u32,
    batch: usize,
    starts: &mut Starts<'a>,
) -> (u32, u32) {
    let origin = |k: usize| [lanes.o[0][k].to_bits(), lanes.o[1][k].to_bits(), lanes.o[2][k].to_bits()];
    // The lanes whose origin is `o`, bit for bit (a loop the compiler vectorises).
    let from = |o: [u32; 3]| {
        let mut m = 0u32;
        for k in 0..LANES {
            let e = (lanes.o[0][k].to_bits() == o[0]) & (lanes.o[1][k].to_bits() == o[1]) & (lanes.o[2][k].to_bits() == o[2]);
            m |= u32::from(e) << k;
        }
        m
    };
    let (mut answered, mut blocked) = (0, 0);
    let mut todo = live & (u32::MAX >> (32 - LANES));
    while todo != 0 {
        let first = todo.trailing_zeros() as usize;
        let o = origin(first);
        let same = if todo == 1 << first { todo } else { from(o) & todo };
        todo &= !same;
        let o = glam::Vec3::from_array(o.map(f32::from_bits));
        let list = match grid.cell_of(o).map(|c| grid.cell(bvh, c)) {
            Some(Cell::List(list)) => list,
            Some(Cell::Entry(cut)) => {
                starts.add(Some(cut), batch, same);
                continue;
            }
            _ => {
                starts.add(None, batch, same);
                continue;
            }
        };
        answered |= same;
        blocked |= if same == 1 << first {
            u32::from(shaft::occluded_by(list, &lanes.ray(first), lanes.t_min[first], lanes.t_max[first])) << first
        } else {
            shaft::fan_occluded(list, o, lanes, same)
        };
    }
    (answered, blocked)
}

#[cfg(test)]
mod tests {
    use crate::geometry::HitRows;
    use crate::math::ray::{RayLanes, RaySegment, LANES};
    use crate::math::sampling::Sampler;
    use crate::{scenes, Accel, Sphere};
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
        // `none` tests every triangle for every ray: no lane is culled, even far away.
        let scene = desc.build(Accel::None).unwrap();
        let (_, mesh) = scene.meshes().next().unwrap();
        let away = RaySegment { origin: Vec3::splat(1e6), t_min: 0.0, direction: Vec3::X, t_max: 1.0 };
        assert_eq!(mesh.may_hit_lanes(&RayLanes::new(&[away; LANES])), u32::MAX >> (32 - LANES));
    }

    /// `occluded_lanes` answers as `Scene::occluded` lane by lane, for the lanes asked
    /// about only: shadow rays of one point towards many targets (a mesh then takes them
    /// as one packet) and of many points, with invalid rays, empty intervals and partial
    /// masks among them, on scenes of spheres and planes, a mesh, an implicit surface and
    /// a top-level BVH.
    #[test]
    fn occluded_lanes_answer_as_occluded() {
        let mut rng = Sampler::from_seed(11);
        for name in ["tp2-plane-point", "tp4-bunny", "tp6-glass", "tp7-implicit", "tp4-sphere", "instanced tp4-bunny"] {
            let desc = match name.strip_prefix("instanced ") {
                Some(n) => instanced(n),
                None => scenes::builtin(name).unwrap(),
            };
            let mut scene = desc.build(Accel::BvhSah).unwrap();
            if name == "tp4-sphere" {
                scene.build_top_level();
            }
            let camera = desc.camera.build(1.5);
            let (mut blocked, mut open) = (0, 0);
            for round in 0..400 {
                // A point seen by the camera (or a far one), and targets around the scene.
                let r = camera.generate_ray(rng.next_f32(), rng.next_f32());
                let from = scene.intersect(&r, 0.0, f32::INFINITY).map_or(r.origin, |h| h.point + h.geometric_normal * 1e-3);
                let rays: Vec<RaySegment> = (0..LANES)
                    .map(|k| {
                        let mut t = || rng.next_f32() * 8.0 - 4.0;
                        let target = Vec3::new(t(), t() + 2.0, t());
                        let origin = if round % 2 == 0 { from } else { Vec3::new(t(), t(), t()) };
                        let mut direction = (target - origin).normalize();
                        let mut t_max = (target - origin).length();
                        match (round + k) % 17 {
                            0 => direction = Vec3::ZERO,
                            1 => direction.z = f32::NAN,
                            2 => t_max = 0.0,
                            _ => {}
                        }
                        RaySegment { origin, t_min: 0.0, direction, t_max }
                    })
                    .collect();
                let lanes = RayLanes::new(&rays);
                let live = match round % 4 {
                    0 => u32::MAX,
                    1 => (1 << (1 + round % LANES)) - 1,
                    _ => rng.next_f32().to_bits() >> 7 & 0xffff,
                };
                let got = scene.occluded_lanes(&lanes, live);
                // The portable loops (CPUs without AVX2) answer the same.
                assert_eq!(scene.occluded_lanes_portable::<false>(&lanes, live, 0), got);
                for (k, r) in rays.iter().enumerate() {
                    let expected = live & (1 << k) != 0 && scene.occluded(&r.ray(), r.t_min, r.t_max);
                    assert_eq!(got & (1 << k) != 0, expected, "{name}, round {round}, lane {k}: {r:?}");
                    if live & (1 << k) != 0 && r.ray().is_valid() {
                        if expected {
                            blocked += 1;
                        } else {
                            open += 1;
                        }
                    }
                }
            }
            assert!(blocked > 300 && open > 300, "{name}: {blocked} blocked, {open} open");
        }
    }

    /// `occluded_lane_pair` answers as `Scene::occluded`, lane by lane in both batches: on a
    /// scene of one mesh (both batches as one stream, lane 31 included) and on one of a
    /// mesh among planes (batch by batch). Shadow rays between surface points, two points
    /// to a batch as the renderer makes them, with invalid rays and partial masks.
    #[test]
    fn occluded_lane_pair_answers_as_occluded() {
        let mut rng = Sampler::from_seed(12);
        let mut masks = Sampler::from_seed(13);
        for name in ["tp4-conference", "tp4-bunny"] {
            let desc = scenes::builtin(name).unwrap();
            let scene = desc.build(Accel::BvhSah).unwrap();
            let camera = desc.camera.build(1.5);
            let mut seen = || {
                let r = camera.generate_ray(rng.next_f32(), rng.next_f32());
                scene.intersect(&r, 0.0, f32::INFINITY).map_or(r.origin + r.direction, |h| h.point + h.geometric_normal * 1e-2)
            };
            let (mut blocked, mut open) = (0, 0);
            for round in 0..150 {
                let batches: [Vec<RaySegment>; 2] = std::array::from_fn(|b| {
                    let origins = [seen(), seen()];
                    (0..LANES)
                        .map(|k| {
                            let origin = origins[k / (LANES / 2)];
                            let to = seen() - origin;
                            let mut direction = to.normalize_or_zero();
                            match (round + k + b) % 23 {
                                0 => direction = Vec3::ZERO,
                                1 => direction.y = f32::NAN,
                                _ => {}
                            }
                            RaySegment { origin, t_min: 0.0, direction, t_max: to.length() * (1.0 - 1e-4) }
                        })
                        .collect()
                });
                let lanes = [RayLanes::new(&batches[0]), RayLanes::new(&batches[1])];
                let live = match round % 3 {
                    0 => [u32::MAX, u32::MAX],
                    1 => [0, (1 << (round % LANES)) | 1 << (LANES - 1)],
                    _ => [masks.next_f32().to_bits() >> 7 & 0xffff, masks.next_f32().to_bits() >> 7 & 0xffff],
                };
                let got = scene.occluded_lane_pair([&lanes[0], &lanes[1]], live);
                for b in 0..2 {
                    assert_eq!(got[b] >> LANES, 0, "{name}: bits beyond the lanes");
                    for (k, r) in batches[b].iter().enumerate() {
                        let expected = live[b] & (1 << k) != 0 && scene.occluded(&r.ray(), r.t_min, r.t_max);
                        assert_eq!(got[b] & (1 << k) != 0, expected, "{name}, round {round}, batch {b}, lane {k}: {r:?}");
                        if live[b] & (1 << k) != 0 && r.ray().is_valid() {
                            *(if expected { &mut blocked } else { &mut open }) += 1;
                        }
                    }
                }
            }
            assert!(blocked > 200 && open > 200, "{name}: {blocked} blocked, {open} open");
        }
    }

    /// Shadow rays towards the conference room's light, made as the renderer makes them
    /// (eight samples of a hit from its `ShadowRays`), two hits to a batch: the answers
    /// from the light's cells (their lists, or the tree from their cuts) are those of
    /// [`super::Scene::occluded`], and a light moved without `prepare` is no longer
    /// answered from cells made for the old one.
    #[test]
    fn shadow_rays_towards_a_quad_light_answer_as_occluded() {
        let desc = scenes::builtin("tp4-conference").unwrap();
        let mut scene = desc.build(Accel::BvhSah).unwrap();
        let camera = desc.camera.build(1.5);
        let crate::Light::Quad { corner, u, v, .. } = scene.lights[0] else { panic!("the conference room has a quad light") };
        let mut rng = Sampler::from_seed(21);
        for moved in [false, true] {
            if moved {
                // Down through the table: the old cells would miss what now blocks.
                let crate::Light::Quad { corner, .. } = &mut scene.lights[0] else { unreachable!() };
                corner.y -= 450.0;
            }
            assert_eq!(scene.shaft(0).is_some(), !moved, "cells only for the light they were made for");
            let corner = if moved { corner - Vec3::new(0.0, 450.0, 0.0) } else { corner };
            let (mut listed, mut cut, mut blocked, mut open) = (0, 0, 0, 0);
            for round in 0..400 {
                let batches: [Vec<RaySegment>; 2] = std::array::from_fn(|_| {
                    let mut rays = Vec::new();
                    while rays.len() < LANES {
                        let r = camera.generate_ray(rng.next_f32(), rng.next_f32());
                        let Some(hit) = scene.intersect(&r, 0.0, f32::INFINITY) else { continue };
                        let mut sr = hit.shadow_rays();
                        for _ in 0..LANES / 2 {
                            let target = corner + u * rng.next_f32() + v * rng.next_f32();
                            if let Some((ray, t_max)) = sr.to(target) {
                                rays.push(RaySegment { origin: ray.origin, t_min: 0.0, direction: ray.direction, t_max });
                            }
                        }
                        rays.truncate(LANES);
                    }
                    rays
                });
                let lanes = [RayLanes::new(&batches[0]), RayLanes::new(&batches[1])];
                let live = if round % 2 == 0 {
                    [0xffff, 0xffff]
                } else {
                    [rng.next_f32().to_bits() & 0xffff, rng.next_f32().to_bits() >> 9 & 0xffff]
                };
                let got = scene.occluded_pair_to_light(0, [&lanes[0], &lanes[1]], live);
                for b in 0..2 {
                    for (k, r) in batches[b].iter().enumerate() {
                        let expected = live[b] & (1 << k) != 0 && scene.occluded(&r.ray(), r.t_min, r.t_max);
                        assert_eq!(got[b] & (1 << k) != 0, expected, "moved {moved}, round {round}, batch {b}, lane {k}: {r:?}");
                        if live[b] & (1 << k) != 0 {
                            *(if expected { &mut blocked } else { &mut open }) += 1;
                            if let Some((grid, bvh)) = scene.shaft(0) {
                                match grid.cell_of(r.origin).map(|c| grid.cell(bvh, c)) {
                                    Some(crate::accel::shaft::Cell::List(_)) => listed += 1,
                                    Some(crate::accel::shaft::Cell::Entry(_)) => cut += 1,
                                    _ => {}
                                }
                            }
                        }
                    }
                }
            }
            assert!(blocked > 1000 && open > 1000, "moved {moved}: {blocked} blocked, {open} open");
            assert!(moved || (listed > 2000 && cut > 2000), "{listed} rays answered from the cells' lists, {cut} from their cuts");
        }
    }

    /// `name`'s scene with its meshes placed as instances (scaled, turned and moved a
    /// little, so that the rays are carried into the mesh's space by a real transform).
    fn instanced(name: &str) -> scenes::SceneDescription {
        let mut desc = scenes::builtin(name).unwrap();
        let mut placed = 0;
        for o in &mut desc.objects {
            if let scenes::ShapeDesc::Mesh { source, shading } = &o.shape {
                let transform = scenes::Transform { translate: Vec3::new(0.1, -0.05, 0.2), rotate: Vec3::new(0.0, 12.0, 3.0), scale: 1.1 };
                o.shape = scenes::ShapeDesc::MeshInstance { source: source.clone(), shading: *shading, transform };
                placed += 1;
            }
        }
        assert_eq!(placed, 1, "{name}: one mesh to place");
        desc
    }

    /// Every lane finds the hit of `Scene::intersect`, field for field, on scenes of
    /// spheres, planes, meshes, an implicit surface and a top-level BVH, with invalid rays,
    /// NaN intervals and partial groups among them.
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
        // A sphere after the bunny in object order, between it and the camera: lanes that
        // meet the mesh, then the nearer sphere, lose the triangle's `prim`, `u` and `v`.
        let mut veiled = scenes::builtin("tp4-bunny").unwrap();
        veiled.name = "tp4-bunny behind a sphere".into();
        // (The bunny sits at the origin.)
        let eye = veiled.camera.position;
        let veil = Sphere::new(eye * 0.5, eye.length() * 0.08);
        veiled.objects.push(scenes::ObjectDesc { name: "veil".into(), shape: scenes::ShapeDesc::Sphere(veil), material: None });
        let mut rng = Sampler::from_seed(3);
        for desc in ["tp2-plane-point", "tp4-bunny", "tp6-glass", "tp7-implicit"].map(|n| scenes::builtin(n).unwrap()).into_iter().chain([
            many,
            instanced("tp4-bunny"),
            veiled,
        ]) {
            let scene = desc.build(Accel::BvhSah).unwrap();
            let camera = desc.camera.build(1.5);
            let mut found = 0;
            // `lane_hit_rows_into`'s arrays, refilled round after round: a round's hits
            // and rows replace every lane of the last round's.
            let (mut refilled, mut rows, mut kept) = ([None; LANES], HitRows::default(), [None; LANES]);
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
                        let t_max = match k % 8 {
                            1 | 5 => 5.0,
                            3 => f32::NAN,
                            _ => f32::INFINITY,
                        };
                        RaySegment { origin: r.origin, t_min: 0.0, direction: r.direction, t_max }
                    })
                    .collect();
                let lanes = RayLanes::new(&rays);
                let hits = scene.intersect_lanes(&lanes, count);
                let all = scene.lane_hits(&lanes, &hits, count);
                assert!(all[count..].iter().all(Option::is_none), "{}: lanes from {count} on", desc.name);
                scene.lane_hit_rows_into(&lanes, &hits, count, &mut refilled, &mut rows);
                assert_eq!(format!("{refilled:?}"), format!("{all:?}"), "{}: lane_hit_rows_into", desc.name);
                // Into an array holding the previous round's hits.
                scene.lane_hits_into(&lanes, &hits, count, &mut kept);
                assert_eq!(format!("{kept:?}"), format!("{all:?}"), "{}: lane_hits_into", desc.name);
                // Bit for bit (`-0.0` and `0.0` print apart).
                assert_eq!(format!("{rows:?}"), format!("{:?}", HitRows::of(&all)), "{}: the rows", desc.name);
                for (k, r) in rays.iter().enumerate() {
                    let expected = scene.intersect(&r.ray(), r.t_min, r.t_max);
                    let got = scene.lane_hit(&lanes, &hits, k);
                    assert_eq!(format!("{got:?}"), format!("{expected:?}"), "{}: {r:?}", desc.name);
                    assert_eq!(format!("{:?}", all[k]), format!("{expected:?}"), "{}: lane_hits, {r:?}", desc.name);
                    found += usize::from(got.is_some());
                }
            }
            assert!(found > 300, "{}: {found} hits", desc.name);
        }
    }
}
