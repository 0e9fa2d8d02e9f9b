//! Triangle mesh (the course's `MeshTriangle` and `TriangleMeshGeometry`): shared arrays
//! of vertices, normals and uvs, and triangles as index triples into them, so that no
//! vertex is stored twice. A triangle is its index in [`TriangleMesh::triangles`].

use crate::accel::bvh::{Bvh, BvhQuality};
use crate::accel::triangle::{moller_trumbore, TriangleTest, WatertightRay};
use crate::accel::wide::{TraversalStats, WideBvh};
use crate::accel::{Accel, MeshHit, Triangles};
use crate::math::aabb::Aabb;
use crate::math::ray::{gamma, lane_mask, Ray, RayLanes, LANES};
use glam::{Vec2, Vec3};

/// Triangle tests by one probe ray above which [`TriangleMesh::overlap_probe`] reports
/// an overlap (ordinary meshes need tens).
pub const OVERLAP_WARNING: u64 = 1000;

/// Mark as invalid every valid triangle whose three vertex positions (as a set, `-0.0` as
/// `0.0`) equal an earlier valid triangle's; return how many. Closest-hit traversal cannot
/// cull coincident triangles (they are all at the same distance), so two million copies
/// of one triangle were two million tests per ray.
///
/// PERF: 64-bit hashes computed in parallel, then one pass through a map from hash to the
/// first triangle with it (a pre-hashed key: no second hashing). It costs the conference
/// room ~15 ms (its whole `TriangleMesh::new` is 4.4 ms), so it runs only where the overlap
/// probe found copies to remove. A hash met again is confirmed by comparing the vertices;
/// the astronomically rare different triangle with an equal hash is kept.
fn mark_duplicates(vertices: &[Vec3], triangles: &[[u32; 3]], valid: &mut [bool]) -> usize {
    use rayon::prelude::*;
    use std::collections::hash_map::{Entry, HashMap};
    let key = |t: &[u32; 3]| -> [[u32; 3]; 3] {
        let mut k = t.map(|i| {
            let p = vertices[i as usize] + Vec3::ZERO; // -0.0 + 0.0 = 0.0
            [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
        });
        k.sort_unstable();
        k
    };
    let hashes: Vec<u64> = triangles
        .par_iter()
        .map(|t| {
            key(t)
                .iter()
                .flatten()
                .fold(0xcbf2_9ce4_8422_2325u64, |h, &x| (h ^ u64::from(x)).wrapping_mul(0x0000_0100_0000_01b3).rotate_left(29))
        })
        .collect();
    let mut first: HashMap<u64, u32, std::hash::BuildHasherDefault<PreHashed>> =
        HashMap::with_capacity_and_hasher(triangles.len(), Default::default());
    let mut duplicates = 0;
    for (i, &h) in hashes.iter().enumerate() {
        if !valid[i] {
            continue;
        }
        match first.entry(h) {
            Entry::Vacant(e) => {
                e.insert(i as u32);
            }
            Entry::Occupied(e) => {
                if key(&triangles[*e.get() as usize]) == key(&triangles[i]) {
                    valid[i] = false;
                    duplicates += 1;
                }
            }
        }
    }
    duplicates
}

/// A hasher for keys that are hashes already.
#[derive(Default)]
struct PreHashed(u64);

impl std::hash::Hasher for PreHashed {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 << 8) ^ u64::from(b);
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = x;
    }
}

/// Which normal shades a hit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Shading {
    /// Interpolate the vertex normals with the barycentrics (TP4 question 3, figure 1b);
    /// the face normal when the mesh has none.
    #[default]
    Smooth,
    /// The face normal `normalize((v1-v0) × (v2-v0))`: facets show (figure 1a).
    Flat,
}

/// The acceleration structure of a mesh, one of the four steps of the TP4 lesson.
#[derive(Clone, Debug, Default)]
pub enum MeshAccel {
    /// Every triangle for every ray (the start of TP4).
    #[default]
    None,
    /// The mesh's box first, then every triangle (exercise 2).
    Aabb,
    /// A binary BVH over the indexed triangles, as the course builds it (exercise 3).
    Bvh(Bvh),
    /// The SAH BVH converted to the wide SIMD layout with triangle data in the leaves.
    Wide(WideBvh),
}

/// The per-ray state of a triangle test.
enum RayTest {
    MollerTrumbore(Ray),
    Watertight(WatertightRay),
}

/// Figures about a mesh's acceleration structure.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshStats {
    /// Triangles in the mesh.
    pub triangles: usize,
    /// Triangles left out of every query: zero area or non-finite vertices.
    pub degenerate: usize,
    /// Triangles left out of every query because an earlier triangle has the same three
    /// vertex positions (in any order): the first copy is the one hit. Counted (and left
    /// out) by [`TriangleMesh::remove_overlaps`] only where copies slowed traversal.
    pub duplicates: usize,
    /// BVH nodes (0 without a BVH).
    pub nodes: usize,
    /// SAH cost of the BVH (0 without one): for `bvh-mid`, of the binary tree with 1:1
    /// weights ([`crate::accel::bvh::Bvh::sah_cost`]); for `bvh-sah`, of the wide tree traced
    /// ([`WideBvh::sah_cost`]).
    pub sah_cost: f32,
    /// Bytes of the acceleration structure per triangle.
    pub bytes_per_triangle: f32,
    /// `bvh-sah` was asked for but its tree was too large for the wide layout
    /// ([`crate::accel::wide::TooLarge`]): the binary SAH tree is traced instead, correct
    /// but slower ([`MeshStats::warning`]).
    pub binary_fallback: bool,
}

impl MeshStats {
    /// What a user should be told about the structure built: the binary fallback.
    #[must_use]
    pub fn warning(&self) -> Option<String> {
        self.binary_fallback.then(|| {
            format!("{} triangles: {}; the binary SAH BVH is traced instead (slower)", self.triangles, crate::accel::wide::TooLarge)
        })
    }
}

/// A triangle mesh.
#[derive(Clone, Debug)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub vertices: Vec<Vec3>,
    /// Per-vertex normals: empty, or one per vertex.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates: empty, or one per vertex (unused for now).
    pub uvs: Vec<Vec2>,
    /// Triangles: three indices into the vertex arrays.
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle, which of the object's materials it uses.
    pub material_slots: Vec<u32>,
    /// Smooth or flat shading.
    pub shading: Shading,
    /// The ray–triangle test of every query (set before [`Self::build_accel`]).
    pub triangle_test: TriangleTest,
    aabb: Aabb,
    /// `aabb` grown for [`TriangleMesh::may_hit`] ([`TriangleMesh::grown_box_of`]),
    /// computed once.
    grown: (Vec3, Vec3),
    valid: Vec<bool>,
    accel: MeshAccel,
    stats: MeshStats,
}

impl Default for TriangleMesh {
    /// The mesh of no triangles, as [`TriangleMesh::new`] makes it (its box empty).
    fn default() -> Self {
        Self::new(Vec::new(), Vec::new(), Vec::new())
    }
}

impl Triangles for TriangleMesh {
    #[inline]
    fn vertices_of(&self, prim: u32) -> [Vec3; 3] {
        self.triangle_vertices(prim)
    }

    fn test(&self) -> TriangleTest {
        self.triangle_test
    }
}

impl TriangleMesh {
    /// A mesh from its arrays. Indices must be in range (the loaders check them);
    /// `normals` is dropped unless it has one entry per vertex. Degenerate triangles
    /// (zero area, non-finite vertices) are kept in the numbering but never hit;
    /// [`MeshStats::degenerate`] counts them.
    ///
    /// # Panics
    /// If a triangle indexes past the vertex array.
    #[must_use]
    pub fn new(vertices: Vec<Vec3>, mut normals: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Self {
        if normals.len() != vertices.len() {
            normals.clear();
        }
        let n = vertices.len() as u32;
        assert!(triangles.iter().all(|t| t.iter().all(|&i| i < n)), "triangle index out of range");
        let mut aabb = Aabb::EMPTY;
        let valid: Vec<bool> = triangles
            .iter()
            .map(|&[a, b, c]| {
                let (a, b, c) = (vertices[a as usize], vertices[b as usize], vertices[c as usize]);
                let ok = a.is_finite() && b.is_finite() && c.is_finite() && (b - a).cross(c - a) != Vec3::ZERO;
                if ok {
                    aabb.extend(a);
                    aabb.extend(b);
                    aabb.extend(c);
                }
                ok
            })
            .collect();
        let degenerate = valid.iter().filter(|v| !**v).count();
        let material_slots = vec![0; triangles.len()];
        let stats = MeshStats { triangles: triangles.len(), degenerate, ..MeshStats::default() };
        Self {
            vertices,
            normals,
            uvs: Vec::new(),
            triangles,
            material_slots,
            shading: Shading::Smooth,
            triangle_test: TriangleTest::MollerTrumbore,
            grown: Self::grown_box_of(&aabb),
            aabb,
            valid,
            accel: MeshAccel::None,
            stats,
        }
    }

    /// The box of the mesh's (valid) triangles.
    #[must_use]
    pub fn aabb(&self) -> Aabb {
        self.aabb
    }

    /// Figures about the mesh and its acceleration structure.
    #[must_use]
    pub fn stats(&self) -> MeshStats {
        self.stats
    }

    /// The acceleration structure in use.
    #[must_use]
    pub fn accel(&self) -> &MeshAccel {
        &self.accel
    }

    /// Look for places where many triangles overlap (coincident, nested or rotated copies
    /// in one plane), which make closest-hit traversal test them all: rays through random
    /// points of random triangles, along their normals, each counting its triangle tests.
    /// Returns the worst count and the point where it happened when it exceeds
    /// [`OVERLAP_WARNING`], `None` otherwise or without a BVH. Costs at most about 2^20
    /// triangle tests (a few milliseconds), whatever the mesh.
    #[must_use]
    pub fn overlap_probe(&self) -> Option<(u64, Vec3)> {
        let valid: Vec<u32> = (0..self.triangles.len() as u32).filter(|&i| self.valid[i as usize]).collect();
        if valid.len() <= OVERLAP_WARNING as usize {
            return None;
        }
        let mut rng = crate::math::sampling::Sampler::from_seed(0x15_1e);
        let (mut spent, mut worst) = (0u64, (0u64, Vec3::ZERO));
        for _ in 0..256 {
            let prim = valid[(rng.next_f32() * valid.len() as f32) as usize % valid.len()];
            let xi = rng.next_2d();
            let (u, v) = if xi.x + xi.y > 1.0 { (1.0 - xi.x, 1.0 - xi.y) } else { (xi.x, xi.y) };
            let (p, _) = self.surface_point(prim, u, v);
            let n = self.face_normal(prim);
            let reach = self.aabb.diagonal().length();
            let ray = Ray::new(p + n * reach, -n);
            let tests = match &self.accel {
                MeshAccel::Wide(w) => {
                    let mut stats = crate::accel::wide::TraversalStats::default();
                    w.intersect_stats::<true>(&ray, 0.0, f32::INFINITY, &mut stats);
                    stats.triangles
                }
                MeshAccel::Bvh(bvh) => {
                    let test = self.ray_test(&ray);
                    let mut tests = 0u64;
                    bvh.intersect(&ray, 0.0, f32::INFINITY, |prim, t_max| {
                        tests += 1;
                        self.hit_triangle(&test, prim, 0.0, t_max).map(|h| h.t)
                    });
                    tests
                }
                MeshAccel::None | MeshAccel::Aabb => return None, // every triangle by choice
            };
            if tests > worst.0 {
                worst = (tests, p);
            }
            spent += tests;
            if spent > 1 << 20 {
                break;
            }
        }
        (worst.0 > OVERLAP_WARNING).then_some(worst)
    }

    /// Make sure overlapping triangles do not turn traversal into a linear scan, after
    /// [`Self::build_accel`]: when [`Self::overlap_probe`] finds a place where one ray
    /// tests over [`OVERLAP_WARNING`] triangles, exact copies of a triangle are left out
    /// (the first copy stays: [`MeshStats::duplicates`]) and the structure rebuilt. Returns
    /// what the probe still finds then (nested or rotated coplanar copies, which no
    /// renderer can cull), for a warning. Ordinary meshes pay a few hundred probe rays.
    pub fn remove_overlaps(&mut self) -> Option<(u64, Vec3)> {
        self.overlap_probe()?;
        let removed = mark_duplicates(&self.vertices, &self.triangles, &mut self.valid);
        if removed > 0 {
            self.stats.duplicates += removed;
            let accel = match self.accel {
                MeshAccel::None => Accel::None,
                MeshAccel::Aabb => Accel::Aabb,
                MeshAccel::Bvh(_) if self.stats.binary_fallback => Accel::BvhSah,
                MeshAccel::Bvh(_) => Accel::BvhMid,
                MeshAccel::Wide(_) => Accel::BvhSah,
            };
            let level = match &self.accel {
                MeshAccel::Wide(w) => Some(w.level()),
                _ => None,
            };
            self.build_accel(accel);
            if let (Some(level), MeshAccel::Wide(w)) = (level, &mut self.accel) {
                w.set_level(level);
            }
        }
        self.overlap_probe()
    }

    /// The three vertices of triangle `prim`.
    #[inline]
    #[must_use]
    pub fn triangle_vertices(&self, prim: u32) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[prim as usize];
        [self.vertices[a as usize], self.vertices[b as usize], self.vertices[c as usize]]
    }

    /// One box per triangle; empty for degenerate triangles, so BVHs leave them out.
    #[must_use]
    pub fn triangle_boxes(&self) -> Vec<Aabb> {
        use rayon::prelude::*;
        (0..self.triangles.len() as u32)
            .into_par_iter()
            .map(|i| if self.valid[i as usize] { self.triangle_box(i) } else { Aabb::EMPTY })
            .collect()
    }

    /// The box of triangle `prim`.
    #[inline]
    fn triangle_box(&self, prim: u32) -> Aabb {
        let mut b = Aabb::EMPTY;
        for v in self.triangle_vertices(prim) {
            b.extend(v);
        }
        b
    }

    /// Build the acceleration structure (replacing any previous one). A `bvh-sah` tree
    /// too large for the wide layout (about 175 million triangles) is traced as the binary
    /// SAH tree: [`MeshStats::binary_fallback`].
    pub fn build_accel(&mut self, accel: Accel) {
        self.build_accel_within(accel, crate::accel::wide::MAX_NODES);
    }

    /// [`Self::build_accel`] with at most `max_wide_nodes` wide nodes (fewer than
    /// [`crate::accel::wide::MAX_NODES`] in tests, which cannot build meshes that large).
    pub(crate) fn build_accel_within(&mut self, accel: Accel, max_wide_nodes: usize) {
        self.stats.binary_fallback = false;
        let (accel, sah_cost) = match accel {
            Accel::None => (MeshAccel::None, 0.0),
            Accel::Aabb => (MeshAccel::Aabb, 0.0),
            Accel::BvhMid => {
                let bvh = Bvh::build(&self.triangle_boxes(), BvhQuality::Midpoint);
                let cost = bvh.sah_cost();
                (MeshAccel::Bvh(bvh), cost)
            }
            Accel::BvhSah => {
                // PERF: boxes computed into the build's records, without an 8 MB box
                // array of every triangle to fault in, fill and read back (conference
                // room build ~63 -> ~56 ms).
                let valid: Vec<u32> = (0..self.triangles.len() as u32).filter(|&i| self.valid[i as usize]).collect();
                // The build's records and then the wide tree's blocks in one storage.
                let mut storage = WideBvh::block_storage(valid.len());
                let bvh = Bvh::build_sah_in(&valid, |i| self.triangle_box(i), &mut storage);
                // PERF: the wide tree's cost comes free from the collapse; the binary
                // tree's took a pass over it (~1 ms of the build).
                match WideBvh::from_bvh_in(&bvh, self, storage, max_wide_nodes) {
                    Ok(wide) => {
                        let cost = wide.sah_cost();
                        (MeshAccel::Wide(wide), cost)
                    }
                    Err(crate::accel::wide::TooLarge) => {
                        self.stats.binary_fallback = true;
                        let cost = bvh.sah_cost();
                        (MeshAccel::Bvh(bvh), cost)
                    }
                }
            }
        };
        self.accel = accel;
        let (nodes, bytes) = match &self.accel {
            MeshAccel::None | MeshAccel::Aabb => (0, 0),
            MeshAccel::Bvh(b) => (b.nodes.len(), b.nodes.len() * 32 + b.prim_indices.len() * 4),
            MeshAccel::Wide(w) => (w.node_count(), w.bytes()),
        };
        self.stats.nodes = nodes;
        self.stats.sah_cost = sah_cost;
        self.stats.bytes_per_triangle = bytes as f32 / self.triangles.len().max(1) as f32;
    }

    /// Choose the code path of the wide BVH; false when the mesh has none.
    ///
    /// # Panics
    /// If this CPU cannot run `level` (see [`crate::accel::wide::SimdLevel::available`]).
    pub fn set_simd_level(&mut self, level: crate::accel::wide::SimdLevel) -> bool {
        match &mut self.accel {
            MeshAccel::Wide(w) => {
                w.set_level(level);
                true
            }
            _ => false,
        }
    }

    /// Choose when the wide BVH's batches of rays are interleaved
    /// ([`TriangleMesh::intersect_batch`]); false when the mesh has no wide BVH.
    pub fn set_interleave(&mut self, interleave: crate::accel::wide::Interleave) -> bool {
        match &mut self.accel {
            MeshAccel::Wide(w) => {
                w.set_interleave(interleave);
                true
            }
            _ => false,
        }
    }

    /// How many rays of a batch each thread traces at a time
    /// ([`TriangleMesh::intersect_batch`]): [`crate::accel::wide::IN_FLIGHT`] when the
    /// wide BVH interleaves them, otherwise 1.
    #[must_use]
    pub fn rays_in_flight(&self) -> usize {
        match &self.accel {
            MeshAccel::Wide(w) if w.interleaves() => crate::accel::wide::IN_FLIGHT,
            _ => 1,
        }
    }

    /// The per-ray part of the mesh's triangle test, prepared once per query.
    fn ray_test(&self, ray: &Ray) -> RayTest {
        match self.triangle_test {
            TriangleTest::MollerTrumbore => RayTest::MollerTrumbore(*ray),
            TriangleTest::Watertight => RayTest::Watertight(WatertightRay::new(ray)),
        }
    }

    /// The mesh's triangle test on triangle `prim`, or `None` for a degenerate one.
    #[inline]
    fn hit_triangle(&self, test: &RayTest, prim: u32, t_min: f32, t_max: f32) -> Option<MeshHit> {
        if !self.valid[prim as usize] {
            return None;
        }
        let [a, b, c] = self.triangle_vertices(prim);
        let hit = match test {
            RayTest::MollerTrumbore(ray) => moller_trumbore(ray, a, b, c, t_min, t_max),
            RayTest::Watertight(w) => w.intersect(a, b, c, t_min, t_max),
        };
        hit.map(|h| MeshHit { t: h.t, prim, u: h.u, v: h.v })
    }

    /// Every triangle, in order: the reference the acceleration structures are tested against.
    #[must_use]
    pub fn intersect_brute_force(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<MeshHit> {
        if !ray.is_valid() {
            return None;
        }
        let test = self.ray_test(ray);
        let mut best: Option<MeshHit> = None;
        for prim in 0..self.triangles.len() as u32 {
            let limit = best.map_or(t_max, |b| b.t);
            if let Some(h) = self.hit_triangle(&test, prim, t_min, limit) {
                best = Some(h);
            }
        }
        best
    }

    /// Every triangle until one blocks the ray: the any-hit reference.
    #[must_use]
    pub fn occluded_brute_force(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        let test = self.ray_test(ray);
        ray.is_valid() && (0..self.triangles.len() as u32).any(|p| self.hit_triangle(&test, p, t_min, t_max).is_some())
    }

    /// The closest hit in `[t_min, t_max)`.
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<MeshHit> {
        match &self.accel {
            MeshAccel::None => self.intersect_brute_force(ray, t_min, t_max),
            MeshAccel::Aabb => {
                self.aabb.intersect(ray, t_min, t_max)?;
                self.intersect_brute_force(ray, t_min, t_max)
            }
            MeshAccel::Bvh(bvh) => {
                let test = self.ray_test(ray);
                let mut best = None;
                bvh.intersect(ray, t_min, t_max, |prim, t_max| {
                    let h = self.hit_triangle(&test, prim, t_min, t_max)?;
                    best = Some(h);
                    Some(h.t)
                });
                best
            }
            MeshAccel::Wide(w) => {
                if !self.may_hit(ray, t_min, t_max) {
                    return None;
                }
                w.intersect(ray, t_min, t_max)
            }
        }
    }

    /// [`TriangleMesh::intersect`], and what finding the hit cost: nodes visited (binary
    /// nodes for `bvh-mid`, 8-wide nodes for `bvh-sah`, the mesh's box for `aabb`) and
    /// triangle tests (all of them for `none` and, when the box is hit, `aabb`; four per
    /// block for `bvh-sah`). The TP4 lesson made visible (`--aov cost`).
    #[must_use]
    pub fn intersect_cost(&self, ray: &Ray, t_min: f32, t_max: f32) -> (Option<MeshHit>, TraversalStats) {
        let all = self.triangles.len() as u64;
        match &self.accel {
            MeshAccel::None => (self.intersect_brute_force(ray, t_min, t_max), TraversalStats { nodes: 0, triangles: all }),
            MeshAccel::Aabb => match self.aabb.intersect(ray, t_min, t_max) {
                None => (None, TraversalStats { nodes: 1, triangles: 0 }),
                Some(_) => (self.intersect_brute_force(ray, t_min, t_max), TraversalStats { nodes: 1, triangles: all }),
            },
            MeshAccel::Bvh(bvh) => {
                let test = self.ray_test(ray);
                let (mut best, mut stats) = (None, TraversalStats::default());
                bvh.intersect_counting(ray, t_min, t_max, &mut stats.nodes, |prim, t_max| {
                    stats.triangles += 1;
                    let h = self.hit_triangle(&test, prim, t_min, t_max)?;
                    best = Some(h);
                    Some(h.t)
                });
                (best, stats)
            }
            MeshAccel::Wide(w) => {
                let mut stats = TraversalStats::default();
                (w.intersect_stats::<true>(ray, t_min, t_max, &mut stats), stats)
            }
        }
    }

    /// False only when the ray certainly misses the mesh in `[t_min, t_max)`: a slab test
    /// of the mesh's box grown by 2^-16 of its size and of its distance from the origin, far
    /// more than the rounding of any test inside. PERF: before the wide traversal, whose
    /// set-up (three divisions, its stack) costs more than this on rays that miss the box:
    /// `tp4-bunny` at 64 spp, most rays on the room's planes: ray cast 0.77 -> 0.65 s,
    /// direct lighting 1.68 -> 1.48 s.
    /// Rays that start inside the box pass without the slab test (PERF: its three
    /// divisions were 8% of the conference room's time, where every ray starts inside).
    #[inline]
    pub(crate) fn may_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        let (lo, hi) = self.grown_box();
        Self::inside(lo, hi, ray.origin) || Self::box_may_hit(lo, hi, ray, t_min, t_max)
    }

    /// [`TriangleMesh::may_hit`] as a filter of ray segments, its box computed once.
    #[inline(always)]
    fn may_hit_filter(&self) -> impl Fn(&crate::math::ray::RaySegment) -> bool {
        let (lo, hi) = self.grown_box();
        move |r| Self::inside(lo, hi, r.origin) || Self::box_may_hit(lo, hi, &r.ray(), r.t_min, r.t_max)
    }

    /// True when `p` lies in the box `lo..hi`: [`TriangleMesh::may_hit`] lets such rays
    /// through untested (a filter may let through what the traversal then misses).
    #[inline(always)]
    fn inside(lo: Vec3, hi: Vec3, p: Vec3) -> bool {
        p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z
    }

    /// The mesh's box grown by 2^-16 of its size and of its distance from the origin
    /// ([`TriangleMesh::may_hit`]).
    #[inline(always)]
    fn grown_box(&self) -> (Vec3, Vec3) {
        self.grown
    }

    /// `aabb` grown by 2^-16 of its size and of its distance from the origin.
    fn grown_box_of(aabb: &Aabb) -> (Vec3, Vec3) {
        let margin = Vec3::splat((aabb.max - aabb.min).max_element() + aabb.min.abs().max(aabb.max.abs()).max_element()) * (1.0 / 65_536.0);
        (aabb.min - margin, aabb.max + margin)
    }

    /// The slab test of [`TriangleMesh::may_hit`] against the box `lo..hi`: selects only
    /// (glam's `min`, `max`, `max_element`, `min_element`), so a loop over lanes vectorises.
    #[inline(always)]
    fn box_may_hit(lo: Vec3, hi: Vec3, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        let (inv, _) = crate::accel::wide::slab_inverse(ray.direction);
        let a = (lo - ray.origin) * inv;
        let b = (hi - ray.origin) * inv;
        let near = a.min(b).max_element().max(t_min);
        let far = a.max(b).min_element().min(t_max);
        // NaN anywhere: no verdict here (only a definite "entry after exit" rejects).
        let (near, far) = (near - near.abs() * 1e-5, far + far.abs() * 1e-5);
        near.partial_cmp(&far) != Some(std::cmp::Ordering::Greater)
    }

    /// [`TriangleMesh::may_hit`] for every lane of `rays` (bit `k` for lane `k`), by the
    /// same operations lane by lane, without branches, so that the loop vectorises. Every
    /// lane for `none`, which tests every triangle for every ray (the TP4 lesson: its
    /// lanes culled by the box, it was no slower than `aabb`).
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    pub(crate) fn may_hit_lanes(&self, rays: &RayLanes) -> u32 {
        if matches!(self.accel, MeshAccel::None) {
            return u32::MAX >> (32 - LANES);
        }
        let (lo, hi) = self.grown_box();
        let mut hit = [false; LANES];
        for k in 0..LANES {
            let ray = rays.ray(k);
            hit[k] = Self::inside(lo, hi, ray.origin) | Self::box_may_hit(lo, hi, &ray, rays.t_min[k], rays.t_max[k]);
        }
        lane_mask(&hit)
    }

    /// True when some triangle meets the ray in `[t_min, t_max)` (any-hit query).
    #[must_use]
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        match &self.accel {
            MeshAccel::None => self.occluded_brute_force(ray, t_min, t_max),
            MeshAccel::Aabb => {
                ray.is_valid() && self.aabb.intersect(ray, t_min, t_max).is_some() && self.occluded_brute_force(ray, t_min, t_max)
            }
            MeshAccel::Bvh(bvh) => {
                let test = self.ray_test(ray);
                bvh.occluded(ray, t_min, t_max, |prim, t_max| self.hit_triangle(&test, prim, t_min, t_max).is_some())
            }
            MeshAccel::Wide(w) => self.may_hit(ray, t_min, t_max) && w.occluded(ray, t_min, t_max),
        }
    }

    /// [`TriangleMesh::intersect`] of every ray of `rays` (each in its own interval):
    /// `out[i]` for ray `i`, the same answers. A wide BVH larger than the CPU's
    /// last-level cache traces them [`crate::accel::wide::IN_FLIGHT`] at a time per
    /// thread ([`WideBvh::interleaves`]); otherwise one after the other.
    ///
    /// # Panics
    /// If `out` is shorter than `rays`.
    pub fn intersect_batch(&self, rays: &[crate::math::ray::RaySegment], out: &mut [Option<MeshHit>]) {
        assert!(out.len() >= rays.len(), "one answer per ray");
        match &self.accel {
            MeshAccel::Wide(w) if w.interleaves() => w.batch::<false>(rays, self.may_hit_filter(), |i, h| out[i] = h),
            MeshAccel::Wide(w) => {
                // PERF: the filter's box computed once, the accel matched once, not per
                // ray as `intersect` does: conference rays, one thread, +2% diffuse and
                // random, +5% primary. `WideBvh::batch` has the same loop for a tree it
                // does not interleave; through it (answers put by index) primary and shadow
                // rays took 1.01 of the time.
                let may_hit = self.may_hit_filter();
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = if may_hit(r) { w.intersect(&r.ray(), r.t_min, r.t_max) } else { None };
                }
            }
            _ => {
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = self.intersect(&r.ray(), r.t_min, r.t_max);
                }
            }
        }
    }

    /// [`TriangleMesh::occluded`] of every ray of `rays`, as [`TriangleMesh::intersect_batch`].
    ///
    /// # Panics
    /// If `out` is shorter than `rays`.
    pub fn occluded_batch(&self, rays: &[crate::math::ray::RaySegment], out: &mut [bool]) {
        assert!(out.len() >= rays.len(), "one answer per ray");
        match &self.accel {
            MeshAccel::Wide(w) if w.interleaves() => w.batch::<true>(rays, self.may_hit_filter(), |i, h| out[i] = h.is_some()),
            MeshAccel::Wide(w) => {
                // PERF: as in `intersect_batch`.
                let may_hit = self.may_hit_filter();
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = may_hit(r) && w.occluded(&r.ray(), r.t_min, r.t_max);
                }
            }
            _ => {
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = self.occluded(&r.ray(), r.t_min, r.t_max);
                }
            }
        }
    }

    /// [`Self::occluded`] for up to [`crate::accel::packet::PACKET`] rays: bit `i` set
    /// when `rays[i]` is occluded. Traced together through the wide BVH
    /// ([`WideBvh::occluded_packet`]), one at a time otherwise.
    #[must_use]
    pub fn occluded_packet(&self, rays: &[crate::math::ray::RaySegment]) -> u32 {
        match &self.accel {
            MeshAccel::Wide(w) => w.occluded_packet(rays),
            _ => rays.iter().enumerate().fold(0, |m, (i, r)| m | u32::from(self.occluded(&r.ray(), r.t_min, r.t_max)) << i),
        }
    }

    /// [`TriangleMesh::intersect`] for the lanes `mask` of `rays` (whose rays may meet the
    /// mesh's box), each up to its own `t_max[k]`: `out[k]` for lane `k`, `None` outside
    /// `mask`. Traced together through the wide BVH ([`WideBvh::intersect_lanes`]), one at
    /// a time otherwise.
    pub(crate) fn intersect_lanes_near(&self, rays: &RayLanes, t_max: &[f32; LANES], mask: u32, out: &mut [Option<MeshHit>; LANES]) {
        match &self.accel {
            MeshAccel::Wide(w) => w.intersect_lanes(rays, t_max, mask, out),
            _ => {
                for (k, o) in out.iter_mut().enumerate() {
                    *o = if mask & (1 << k) != 0 { self.intersect(&rays.ray(k), rays.t_min[k], t_max[k]) } else { None };
                }
            }
        }
    }

    /// [`Self::occluded`] for the lanes `mask` of `rays`: bit `k` set when lane `k` is in
    /// `mask` and occluded. Traced together through the wide BVH
    /// ([`WideBvh::occluded_lanes`]), one at a time otherwise.
    #[must_use]
    pub fn occluded_lanes(&self, rays: &RayLanes, mask: u32) -> u32 {
        match &self.accel {
            MeshAccel::Wide(w) => w.occluded_lanes(rays, mask),
            _ => crate::math::ray::lanes_of(mask & (u32::MAX >> (32 - LANES)))
                .fold(0, |m, k| m | u32::from(self.occluded(&rays.ray(k), rays.t_min[k], rays.t_max[k])) << k),
        }
    }

    /// [`Self::occluded_lanes`] for two batches at once, `[first's, second's]`: one AVX2
    /// stream through the wide BVH ([`WideBvh::occluded_lane_pair`]), batch by batch
    /// otherwise.
    #[must_use]
    pub fn occluded_lane_pair(&self, rays: [&RayLanes; 2], mask: [u32; 2]) -> [u32; 2] {
        match &self.accel {
            MeshAccel::Wide(w) => w.occluded_lane_pair(rays, mask),
            _ => [self.occluded_lanes(rays[0], mask[0]), self.occluded_lanes(rays[1], mask[1])],
        }
    }

    /// The face normal `normalize((v1-v0) × (v2-v0))` of triangle `prim`.
    #[must_use]
    pub fn face_normal(&self, prim: u32) -> Vec3 {
        let [a, b, c] = self.triangle_vertices(prim);
        let n = (b - a).cross(c - a);
        // Scaled to its largest component first: the squared length of the cross product
        // overflows for edges beyond ~1e10 and underflows below ~1e-10.
        (n / n.abs().max_element()).normalize_or_zero()
    }

    /// The point of triangle `prim` at barycentrics `(u, v)`, computed from them (not as
    /// `o + t·d`, whose error grows with the distance travelled), and a conservative bound
    /// on its error per axis.
    ///
    /// Two terms (pbrt-v4 §6.8.4 and §6.8.6): the rounding of `b0·p0 + b1·p1 + b2·p2`,
    /// `γ(7)·Σ|bi·pi|`; and, along the normal, the error of Möller–Trumbore's `t` for a ray
    /// starting on this triangle. That `t` is a triple product `e2·(s × e1)` divided by the
    /// determinant; its rounding is up to `γ(8)·|s|·|e1|·|e2|` while its true value is the
    /// height above the plane times `|e1 × e2|`. With `|s|` up to twice the longest edge
    /// (for neighbours sharing the plane too), a ray starting closer to the plane than
    /// `γ(8)·2·max|e|·|e1|·|e2| / |e1 × e2|` may find its own triangle in front of it: long
    /// thin triangles (polygon fans) need far more than the point's own rounding.
    #[must_use]
    pub fn surface_point(&self, prim: u32, u: f32, v: f32) -> (Vec3, Vec3) {
        let [p0, p1, p2] = self.triangle_vertices(prim);
        let b0 = 1.0 - u - v;
        let p = b0 * p0 + u * p1 + v * p2;
        let point_error = gamma(7) * ((b0 * p0).abs() + (u * p1).abs() + (v * p2).abs());
        // In f64: |e|³ overflows f32 for triangles beyond ~1e12.
        let (e1, e2) = ((p1 - p0).as_dvec3(), (p2 - p0).as_dvec3());
        let c = e1.cross(e2);
        let area2 = c.length();
        if area2 == 0.0 || !area2.is_finite() {
            return (p, point_error);
        }
        let (l1, l2) = (e1.length(), e2.length());
        let height = f64::from(gamma(8)) * 2.0 * l1.max(l2) * (l1 / area2) * l2;
        let along_normal = ((c / area2).abs() * height).as_vec3();
        (p, point_error + along_normal)
    }

    /// The texture coordinates at barycentrics `(u, v)` of triangle `prim` (zero when the
    /// mesh has none).
    #[must_use]
    pub fn texture_uv(&self, prim: u32, u: f32, v: f32) -> Vec2 {
        if self.uvs.is_empty() {
            return Vec2::ZERO;
        }
        let [a, b, c] = self.triangles[prim as usize];
        (1.0 - u - v) * self.uvs[a as usize] + u * self.uvs[b as usize] + v * self.uvs[c as usize]
    }

    /// The shading normal at barycentrics `(u, v)` of triangle `prim` (not yet facing the ray).
    #[must_use]
    pub fn shading_normal(&self, prim: u32, u: f32, v: f32) -> Vec3 {
        self.shading_normal_or(prim, u, v, || self.face_normal(prim))
    }

    /// [`Self::shading_normal`], with `face` giving the triangle's [`Self::face_normal`]
    /// when it is needed (the caller may have it already). PERF: a mesh without normals
    /// (the conference room) took the face normal twice per hit.
    #[inline(always)]
    #[must_use]
    pub fn shading_normal_or(&self, prim: u32, u: f32, v: f32, face: impl FnOnce() -> Vec3) -> Vec3 {
        if self.shading == Shading::Flat || self.normals.is_empty() {
            return face();
        }
        let [a, b, c] = self.triangles[prim as usize];
        let n = (1.0 - u - v) * self.normals[a as usize] + u * self.normals[b as usize] + v * self.normals[c as usize];
        n.try_normalize().unwrap_or_else(face)
    }
}
