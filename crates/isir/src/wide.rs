//! Wide BVH: eight children per node tested at once with SIMD, triangles stored
//! intersection-ready four to a block in the leaves (after Embree's BVH8 + Triangle4
//! and Fuetterling et al., "Accelerated single ray tracing for wide vector units", 2017).
//!
//! Built by collapsing the binary SAH [`Bvh`] the SAH-optimal way (a dynamic program over
//! the binary tree chooses which binary nodes become wide nodes, which become lanes and
//! which small subtrees become one leaf of up to 16 triangles); each node's lanes are then
//! ordered by decreasing box area (any-hit queries try them in that order).
//!
//! # Layouts
//! - [`Node8`] (224 bytes, 32-byte aligned): the eight child boxes as structure of
//!   arrays (`lo[axis][lane]`, `hi[axis][lane]`) so one AVX load fetches one plane of eight
//!   boxes, and eight `u32` child codes. Empty lanes hold an inverted box (`+∞..-∞`) that no
//!   ray enters, so the box test needs no lane mask.
//! - Child code: an inner node's index, or `LEAF | (blocks - 1) << 28 | first block`.
//! - [`Tri4`] (160 bytes): four triangles as `v0`, `e1 = v1 - v0`, `e2 = v2 - v0` by
//!   component, and their triangle numbers. Unused lanes are NaN and never hit.
//!
//! # Paths
//! [`SimdLevel`] picks the code path at run time (`is_x86_feature_detected!`): plain
//! scalar Rust (the tested fallback, and the only path off x86-64), AVX2+FMA, and the
//! same kernels compiled for AVX-512. The triangle test computes exactly what
//! [`crate::triangle::moller_trumbore`] computes, operation for operation, so every path
//! returns bit-identical distances and barycentrics.

use crate::bvh::Bvh;
use crate::geometry::{MeshHit, TriangleMesh};
use crate::ray::Ray;
use crate::triangle::{moller_trumbore_edges, TriangleHit, TriangleTest, WatertightRay};
use glam::Vec3;

/// No child in this lane.
pub(crate) const EMPTY: u32 = u32::MAX;
/// Set in a child code for a leaf.
pub(crate) const LEAF: u32 = 1 << 31;
pub(crate) const BLOCKS_SHIFT: u32 = 28;
pub(crate) const FIRST_MASK: u32 = (1 << BLOCKS_SHIFT) - 1;
/// Leaves hold at most this many blocks of four triangles.
const MAX_BLOCKS: usize = 8;
/// Traversal stack entries: at most seven pushes per level.
pub(crate) const STACK_SIZE: usize = 7 * crate::bvh::STACK_SIZE + 8;
/// Box distances are widened by a few ULPs so that rounding in the box test never culls a
/// triangle the exact test would hit (the conservative traversal of pbrt and Embree).
/// The interval `[near, far]` becomes `[near - |near|·WIDEN, far + |far|·WIDEN]`, wider
/// whatever the signs (rays may start at a negative `t_min`).
pub(crate) const WIDEN: f32 = 4.0 * f32::EPSILON;
/// The SIMD box test's widening when `t_min >= 0`, in ULPs of each end (4 ε relative is
/// 4 to 8 ULPs, so this is at least as wide).
const WIDEN_ULPS: i32 = 8;

/// Eight child boxes (structure of arrays) and their child codes.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug)]
pub struct Node8 {
    pub(crate) lo: [[f32; 8]; 3],
    pub(crate) hi: [[f32; 8]; 3],
    pub(crate) child: [u32; 8],
}

const _: () = assert!(std::mem::size_of::<Node8>() == 224);

impl Node8 {
    /// No children: every lane's box inverted.
    const EMPTY: Node8 = Node8 { lo: [[f32::INFINITY; 8]; 3], hi: [[f32::NEG_INFINITY; 8]; 3], child: [EMPTY; 8] };

    fn set(&mut self, lane: usize, b: &crate::Aabb, code: u32) {
        for axis in 0..3 {
            self.lo[axis][lane] = b.min[axis];
            self.hi[axis][lane] = b.max[axis];
        }
        self.child[lane] = code;
    }
}

/// Four triangles ready for Möller–Trumbore, by component.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
pub struct Tri4 {
    pub(crate) v0: [[f32; 4]; 3],
    pub(crate) e1: [[f32; 4]; 3],
    pub(crate) e2: [[f32; 4]; 3],
    pub(crate) prim: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<Tri4>() == 160);

impl Tri4 {
    /// The block of triangles `prims` (`EMPTY` lanes are padding).
    fn new(mesh: &TriangleMesh, prims: &[u32; 4], watertight: bool) -> Tri4 {
        let mut t = Tri4 { v0: [[f32::NAN; 4]; 3], e1: [[f32::NAN; 4]; 3], e2: [[f32::NAN; 4]; 3], prim: [EMPTY; 4] };
        for (lane, &p) in prims.iter().enumerate().filter(|(_, &p)| p != EMPTY) {
            let [a, b, c] = mesh.triangle_vertices(p);
            // The same subtractions as `moller_trumbore`, so results are bit-identical.
            // The watertight test needs the exact vertices instead (the fields then hold
            // `v1` and `v2`).
            let (e1, e2) = if watertight { (b, c) } else { (b - a, c - a) };
            for axis in 0..3 {
                t.v0[axis][lane] = a[axis];
                t.e1[axis][lane] = e1[axis];
                t.e2[axis][lane] = e2[axis];
            }
            t.prim[lane] = p;
        }
        t
    }
}

/// Which code path traces rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimdLevel {
    /// Portable scalar code.
    Scalar,
    /// AVX2 and FMA (with POPCNT, BMI1 and LZCNT, which every AVX2 CPU has).
    Avx2,
    /// AVX-512 (F, VL, DQ, BW) besides the above.
    Avx512,
}

impl SimdLevel {
    /// Every level this CPU can run, scalar first.
    #[must_use]
    pub fn available() -> Vec<SimdLevel> {
        let mut v = vec![SimdLevel::Scalar];
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx2")
                && is_x86_feature_detected!("fma")
                && is_x86_feature_detected!("popcnt")
                && is_x86_feature_detected!("bmi1")
                && is_x86_feature_detected!("lzcnt")
            {
                v.push(SimdLevel::Avx2);
                if is_x86_feature_detected!("avx512f")
                    && is_x86_feature_detected!("avx512vl")
                    && is_x86_feature_detected!("avx512dq")
                    && is_x86_feature_detected!("avx512bw")
                {
                    v.push(SimdLevel::Avx512);
                }
            }
        }
        v
    }

    /// The fastest level this CPU can run.
    #[must_use]
    pub fn best() -> SimdLevel {
        *Self::available().last().expect("scalar is always available")
    }

    /// Lower-case name, as printed by the tools.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            SimdLevel::Scalar => "scalar",
            SimdLevel::Avx2 => "avx2",
            SimdLevel::Avx512 => "avx512",
        }
    }
}

impl std::str::FromStr for SimdLevel {
    type Err = String;
    /// Parse `scalar`, `avx2` or `avx512` (whether this CPU runs it is checked apart).
    fn from_str(s: &str) -> Result<Self, String> {
        crate::parse_name(s, &[SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512], Self::name, "SIMD level")
    }
}

/// Counters of a traversal, for tree-quality figures (`isir trace`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraversalStats {
    /// Wide nodes whose eight boxes were tested.
    pub nodes: u64,
    /// Triangle lanes tested (four per block, padding included).
    pub triangles: u64,
}

impl std::ops::Add for TraversalStats {
    type Output = TraversalStats;
    fn add(self, o: TraversalStats) -> TraversalStats {
        TraversalStats { nodes: self.nodes + o.nodes, triangles: self.triangles + o.triangles }
    }
}

/// The wide BVH of a mesh.
#[derive(Clone, Debug)]
pub struct WideBvh {
    pub(crate) nodes: Vec<Node8>,
    pub(crate) tris: Vec<Tri4>,
    pub(crate) root: u32,
    /// Levels of wide nodes (bounded so the traversal stack cannot overflow).
    depth: usize,
    /// Blocks hold `v0, v1, v2` for the watertight test instead of `v0, e1, e2`.
    pub(crate) watertight: bool,
    level: SimdLevel,
    /// The tree's SAH cost as the collapse plan counts it.
    sah_cost: f32,
}

impl WideBvh {
    /// Collapse a binary BVH over `mesh`'s triangles.
    #[must_use]
    pub fn from_bvh(bvh: &Bvh, mesh: &TriangleMesh) -> WideBvh {
        use rayon::prelude::*;
        let watertight = mesh.triangle_test == TriangleTest::Watertight;
        let mut w =
            WideBvh { nodes: Vec::new(), tris: Vec::new(), root: EMPTY, depth: 0, watertight, level: SimdLevel::best(), sah_cost: 0.0 };
        if bvh.nodes.is_empty() {
            return w;
        }
        // The tree first, with the triangle numbers of every block; then the blocks, on
        // every core. PERF: gathering the vertices (random reads) was most of the
        // conversion: 9.5 -> 6.5 ms on the conference room. Collapsing the root's
        // subtrees in parallel was slower (one holds 70% of the nodes, and joining the
        // parts copies them).
        let mut c = Collapse { nodes: Vec::with_capacity(bvh.nodes.len() / 4 + 1), ..Collapse::default() };
        c.blocks.reserve(bvh.prim_indices.len() / 3 + 1);
        let plan = Plan::new(bvh);
        w.sah_cost = plan.cost / bvh.nodes[0].aabb().half_area().max(f32::MIN_POSITIVE);
        w.root = c.convert(bvh, &plan, 0, 1);
        assert!(c.depth * 7 + 8 <= STACK_SIZE, "wide BVH too deep ({}) for the traversal stack", c.depth);
        w.depth = c.depth;
        w.nodes = c.nodes;
        w.tris = c.blocks.par_iter().with_min_len(1024).map(|prims| Tri4::new(mesh, prims, watertight)).collect();
        w
    }

    /// The node at byte offset `code` in `nodes`.
    ///
    /// # Safety
    /// `code` must be an inner-node code written by `convert`.
    #[inline(always)]
    pub(crate) unsafe fn node_at(&self, code: u32) -> &Node8 {
        debug_assert!(
            (code as usize).is_multiple_of(std::mem::size_of::<Node8>()) && (code as usize) < std::mem::size_of_val(&self.nodes[..])
        );
        // SAFETY: the caller guarantees a byte offset of a node in `nodes`.
        unsafe { &*self.nodes.as_ptr().cast::<u8>().add(code as usize).cast::<Node8>() }
    }

    /// The expected cost of a ray that enters the root box, by the surface area
    /// heuristic: wide nodes tested plus blocks of four triangles tested (the weights the
    /// collapse optimises; computed by the collapse, free).
    #[must_use]
    pub fn sah_cost(&self) -> f32 {
        self.sah_cost
    }

    /// Number of wide nodes.
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes of nodes and triangle blocks.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node8>() + self.tris.len() * std::mem::size_of::<Tri4>()
    }

    /// The code path in use.
    #[must_use]
    pub fn level(&self) -> SimdLevel {
        self.level
    }

    /// Choose the code path.
    ///
    /// # Panics
    /// If this CPU cannot run `level`.
    pub fn set_level(&mut self, level: SimdLevel) {
        assert!(SimdLevel::available().contains(&level), "{level:?} is not available on this CPU");
        self.level = level;
    }

    /// The closest hit in `[t_min, t_max)`.
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<MeshHit> {
        self.intersect_stats::<false>(ray, t_min, t_max, &mut TraversalStats::default())
    }

    /// True when a triangle meets the ray in `[t_min, t_max)`.
    #[must_use]
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        self.occluded_stats::<false>(ray, t_min, t_max, &mut TraversalStats::default())
    }

    /// [`Self::intersect`], counting into `stats` when `STATS`.
    pub fn intersect_stats<const STATS: bool>(&self, ray: &Ray, t_min: f32, t_max: f32, stats: &mut TraversalStats) -> Option<MeshHit> {
        self.dispatch::<false, STATS>(ray, t_min, t_max, stats)
    }

    /// [`Self::occluded`], counting into `stats` when `STATS`.
    pub fn occluded_stats<const STATS: bool>(&self, ray: &Ray, t_min: f32, t_max: f32, stats: &mut TraversalStats) -> bool {
        self.dispatch::<true, STATS>(ray, t_min, t_max, stats).is_some()
    }

    /// The traversal for this BVH's code path.
    #[inline(always)]
    fn dispatch<const ANY: bool, const STATS: bool>(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        stats: &mut TraversalStats,
    ) -> Option<MeshHit> {
        if self.root == EMPTY || !ray.is_valid() {
            return None;
        }
        match self.level {
            SimdLevel::Scalar => self.traverse_scalar::<ANY, STATS>(ray, t_min, t_max, stats),
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `level` is only ever set to a level `SimdLevel::available` reported.
            SimdLevel::Avx2 => unsafe { self.traverse_avx2::<ANY, STATS>(ray, t_min, t_max, stats) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            SimdLevel::Avx512 => unsafe { self.traverse_avx512::<ANY, STATS>(ray, t_min, t_max, stats) },
            #[cfg(not(target_arch = "x86_64"))]
            _ => unreachable!(),
        }
    }

    /// The portable path. PERF: not inlined, so that `dispatch` stays a small function
    /// (inlined, the traversal stack of this path enlarged every call's frame).
    #[inline(never)]
    fn traverse_scalar<const ANY: bool, const STATS: bool>(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        stats: &mut TraversalStats,
    ) -> Option<MeshHit> {
        // SAFETY: the scalar instantiation runs no SIMD instruction beyond SSE2.
        unsafe { self.traverse::<false, ANY, STATS>(ray, t_min, t_max, stats) }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,lzcnt")]
    unsafe fn traverse_avx2<const ANY: bool, const STATS: bool>(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        stats: &mut TraversalStats,
    ) -> Option<MeshHit> {
        self.traverse::<true, ANY, STATS>(ray, t_min, t_max, stats)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,lzcnt,avx512f,avx512vl,avx512dq,avx512bw")]
    unsafe fn traverse_avx512<const ANY: bool, const STATS: bool>(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        stats: &mut TraversalStats,
    ) -> Option<MeshHit> {
        self.traverse::<true, ANY, STATS>(ray, t_min, t_max, stats)
    }

    /// The traversal loop. `SIMD` selects the x86 kernels (only inlined into functions
    /// compiled with AVX2); `ANY` stops at the first hit.
    ///
    /// # Safety
    /// With `SIMD`, the CPU must have what [`SimdLevel::Avx2`] names.
    #[inline(always)]
    unsafe fn traverse<const SIMD: bool, const ANY: bool, const STATS: bool>(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        stats: &mut TraversalStats,
    ) -> Option<MeshHit> {
        let pre = RayPre::new(ray);
        let watertight = self.watertight.then(|| WatertightRay::new(ray));
        let mut best: Option<MeshHit> = None;
        let mut t_best = t_max;
        // PERF: not zeroed; zeroing its 5 KB took 10% of the trace time.
        let mut stack = [const { std::mem::MaybeUninit::<(u32, f32)>::uninit() }; STACK_SIZE];
        let mut sp = 0usize;
        let mut cur = self.root;
        loop {
            if cur & LEAF == 0 {
                // ---- Inner node: test eight boxes, visit near to far ----
                // SAFETY: inner-node codes are byte offsets of nodes in `nodes`, written by
                // `convert`.
                let node = unsafe { self.node_at(cur) };
                if STATS {
                    stats.nodes += 1;
                }
                let mut dist = [0f32; 8];
                let mask = if SIMD {
                    box_test_avx2(node, &pre, t_min, t_best, &mut dist)
                } else {
                    box_test_scalar(node, &pre, t_min, t_best, &mut dist)
                };
                if mask != 0 {
                    // PERF: which child comes next is decided by branches wherever that
                    // lets the CPU guess, so that it loads the next node on the predicted
                    // path instead of waiting for the box test: the nearer of two, the
                    // nearest of more, and lane 0 (the largest box, the most often hit)
                    // whose child code sits at a constant offset. Each measured A/B:
                    // lane 0 alone +10% shadow, +9% primary; lane 0 first in any hit
                    // +13% shadow; see ARCHITECTURE.md.
                    if mask == 1 {
                        cur = node.child[0];
                        continue;
                    }
                    if mask & (mask - 1) == 0 {
                        cur = node.child[mask.trailing_zeros() as usize];
                        continue;
                    }
                    if ANY {
                        // Any hit will do: continue with the first lane (the largest
                        // box), push the others highest lane first so that they pop in
                        // lane order.
                        let mut m = mask & (mask - 1);
                        while m != 0 {
                            let lane = 31 - m.leading_zeros() as usize;
                            m &= !(1 << lane);
                            // SAFETY: as for the ordered pushes below.
                            unsafe { stack.get_unchecked_mut(sp).write((node.child[lane], dist[lane])) };
                            sp += 1;
                        }
                        if mask & 1 != 0 {
                            cur = node.child[0];
                            continue;
                        }
                        cur = node.child[mask.trailing_zeros() as usize];
                        continue;
                    }
                    let l0 = mask.trailing_zeros() as usize;
                    let rest = mask & (mask - 1);
                    if rest.is_power_of_two() {
                        // Two hits (the most common case): push the far one. On a tie the
                        // later lane goes first, as in the sort below.
                        let l1 = rest.trailing_zeros() as usize;
                        // PERF: a branch, not a select: the CPU goes on into the child it
                        // predicts without waiting for the distances.
                        if l0 == 0 && dist[l1] > dist[0] {
                            // The largest box nearer: its child at a constant offset.
                            // SAFETY: as for the pushes below.
                            unsafe { stack.get_unchecked_mut(sp).write((node.child[l1], dist[l1])) };
                            sp += 1;
                            cur = node.child[0];
                            continue;
                        }
                        if mask == 3 && dist[1] <= dist[0] {
                            // The two largest boxes, the second nearer: constant offsets.
                            // SAFETY: as for the pushes below.
                            unsafe { stack.get_unchecked_mut(sp).write((node.child[0], dist[0])) };
                            sp += 1;
                            cur = node.child[1];
                            continue;
                        }
                        if dist[l1] <= dist[l0] {
                            // SAFETY: as for the pushes below.
                            unsafe { stack.get_unchecked_mut(sp).write((node.child[l0], dist[l0])) };
                            sp += 1;
                            cur = node.child[l1];
                        } else {
                            // SAFETY: as for the pushes below.
                            unsafe { stack.get_unchecked_mut(sp).write((node.child[l1], dist[l1])) };
                            sp += 1;
                            cur = node.child[l0];
                        }
                        continue;
                    }
                    if SIMD {
                        // More hits: each lane's rank (how many hit lanes are nearer) is
                        // its place, far to near from `sp`, without a data-dependent
                        // branch; the nearest (rank 0) is continued with.
                        let n = mask.count_ones() as usize;
                        debug_assert!(sp + n <= STACK_SIZE);
                        // SAFETY: with `SIMD` the caller guarantees AVX2.
                        let keys = unsafe { sort_keys(&dist) };
                        let mut m = mask;
                        // SAFETY: as above.
                        if mask & 1 != 0 && unsafe { nearer_count(keys, 0, mask) } == 0 {
                            // The largest box nearest: its child at a constant offset.
                            cur = node.child[0];
                            m &= m - 1;
                        }
                        while m != 0 {
                            let lane = m.trailing_zeros() as usize;
                            m &= m - 1;
                            // SAFETY: as above.
                            let rank = unsafe { nearer_count(keys, lane, mask) };
                            if rank == 0 {
                                // PERF: a branch, so the CPU goes on into the child it
                                // predicts (as for two hits); reading it back from the
                                // stack waited for every rank: primary +6.5%, diffuse +2%.
                                cur = node.child[lane];
                            } else {
                                // SAFETY: sp + n <= STACK_SIZE: at most eight entries are
                                // written per level and `from_bvh` checks the depth.
                                unsafe { stack.get_unchecked_mut(sp + n - 1 - rank).write((node.child[lane], dist[lane])) };
                            }
                        }
                        sp += n - 1;
                        continue;
                    }
                    // More hits: push them far to near, continue with the nearest.
                    let mut order = [(0f32, 0u32); 8];
                    let mut n = 0;
                    let mut m = mask;
                    while m != 0 {
                        let lane = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let item = (dist[lane], node.child[lane]);
                        // Insertion sort, farthest first.
                        let mut j = n;
                        while j > 0 && order[j - 1].0 < item.0 {
                            order[j] = order[j - 1];
                            j -= 1;
                        }
                        order[j] = item;
                        n += 1;
                    }
                    debug_assert!(sp + n - 1 <= STACK_SIZE);
                    for &(d, c) in &order[..n - 1] {
                        // SAFETY: sp < STACK_SIZE: at most seven entries are pushed per level
                        // and `from_bvh` checks the depth against `STACK_SIZE`.
                        unsafe { stack.get_unchecked_mut(sp).write((c, d)) };
                        sp += 1;
                    }
                    cur = order[n - 1].1;
                    continue;
                }
            } else {
                // ---- Leaf: blocks of four triangles ----
                // `EMPTY` has the leaf bit set, but an empty lane's inverted box
                // (+inf..-inf) fails the slab test for every finite ray (NaN intervals fail
                // the ordered compare too), so an empty lane is never followed. PERF: a
                // release-mode check here cost ~3% of primary rays.
                debug_assert!(cur != EMPTY);
                let range = leaf_blocks(cur);
                debug_assert!(range.end <= self.tris.len());
                for b in range {
                    // SAFETY: leaf codes are written by `convert` and index `tris`.
                    let tri = unsafe { self.tris.get_unchecked(b) };
                    if STATS {
                        stats.triangles += 4;
                    }
                    let hit = if let Some(w) = &watertight {
                        tri4_watertight(tri, w, t_min, t_best)
                    } else if SIMD {
                        tri4_sse::<ANY>(tri, &pre, t_min, t_best)
                    } else {
                        tri4_scalar(tri, ray, t_min, t_best)
                    };
                    if let Some(h) = hit {
                        if ANY {
                            return Some(h);
                        }
                        t_best = h.t;
                        best = Some(h);
                    }
                }
            }
            // ---- Pop the next subtree still in front of the closest hit ----
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                // SAFETY: entries below the old `sp` were all written by a push.
                let (c, d) = unsafe { stack.get_unchecked(sp).assume_init() };
                if ANY || d < t_best {
                    cur = c;
                    break;
                }
            }
        }
    }
}

/// The cost of testing one wide node, relative to one block of four triangles, in the
/// SAH of the collapse.
const WIDE_NODE_COST: f32 = 1.0;
/// The collapse may merge a binary subtree of at most this many triangles into one leaf.
const WIDE_MAX_LEAF: u32 = 16;

/// The SAH-optimal collapse of a binary BVH into eight-wide nodes (the dynamic program of
/// Ylitie, Karras and Laine, "Efficient incoherent ray traversal on GPUs through
/// compressed wide BVHs", 2017). Bottom-up, each binary node gets the least SAH cost of
/// its subtree as at most `i` roots (leaves or wide nodes), for `i` in 1..=8; the plan
/// keeps, per node, how each is reached.
struct Plan {
    /// Per binary node: bits `3(i-1)..3i` hold how many of at most `i` roots come from
    /// the left child (0: the node itself is the one root); bit [`Plan::LEAF`]: as one
    /// root, the node is a leaf (else a wide node). Written once per node, by whichever
    /// thread plans it (atomics only to share the array; relaxed stores are plain stores).
    choice: Vec<std::sync::atomic::AtomicU32>,
    /// The SAH cost of the whole wide tree, as one root.
    cost: f32,
}

/// What the parent of a planned subtree needs: its costs as at most 1..=8 roots, and its
/// primitives in `prim_indices` (first, count; count `u32::MAX` when not contiguous, so
/// it cannot become one leaf).
struct Planned {
    cost: [f32; 8],
    first: u32,
    count: u32,
}

/// `shared[i]`: the least cost of at most `i` roots taken from two subtrees of costs `l`
/// and `r`, each giving at least one (`shared[0]`, `shared[1]`: infinite). PERF: a
/// branch-free, vectorized min-plus product (with the branchy loop the plan took 8 ms
/// on the conference room).
#[inline]
fn shared_roots(l: &[f32; 8], r: &[f32; 8]) -> [f32; 9] {
    // `rp[8 + j]`: the cost of `j >= 1` roots from `r`; infinite for `j <= 0`.
    let mut rp = [f32::INFINITY; 17];
    rp[9..].copy_from_slice(r);
    let mut shared = [f32::INFINITY; 9];
    for (a, &la) in l.iter().enumerate().take(7).map(|(k, c)| (k + 1, c)) {
        for (i, s) in shared.iter_mut().enumerate() {
            let c = la + rp[8 + i - a];
            *s = if c < *s { c } else { *s };
        }
    }
    shared
}

impl Plan {
    const LEAF: u32 = 24;
    /// Binary subtrees planned on both cores down to this depth.
    const PARALLEL_DEPTH: u32 = 6;

    fn new(bvh: &Bvh) -> Plan {
        let mut plan = Plan { choice: (0..bvh.nodes.len()).map(|_| std::sync::atomic::AtomicU32::new(0)).collect(), cost: 0.0 };
        plan.cost = plan.visit(bvh, 0, 0).cost[0];
        plan
    }

    /// Plan the subtree at `index`, children first.
    fn visit(&self, bvh: &Bvh, index: usize, depth: u32) -> Planned {
        let node = &bvh.nodes[index];
        let area = node.aabb().half_area();
        let blocks = |count: u32| count.div_ceil(4) as f32;
        if node.is_leaf() {
            return Planned { cost: [area * blocks(node.count); 8], first: node.left_first, count: node.count };
        }
        let l = node.left_first as usize;
        let (a, b) = if depth < Self::PARALLEL_DEPTH {
            rayon::join(|| self.visit(bvh, l, depth + 1), || self.visit(bvh, l + 1, depth + 1))
        } else {
            (self.visit(bvh, l, depth + 1), self.visit(bvh, l + 1, depth + 1))
        };
        let count = if a.count != u32::MAX && b.count != u32::MAX && a.first + a.count == b.first { a.count + b.count } else { u32::MAX };
        let shared = shared_roots(&a.cost, &b.cost);
        let wide = area * WIDE_NODE_COST + shared[8];
        let leaf = if count <= WIDE_MAX_LEAF { area * blocks(count) } else { f32::INFINITY };
        let single = wide.min(leaf);
        let mut choice = u32::from(leaf <= wide) << Self::LEAF;
        let cost = std::array::from_fn(|i| {
            if shared[i + 1] < single {
                // The first split reaching the minimum.
                let k = (1..=i).find(|&k| a.cost[k - 1] + b.cost[i - k] == shared[i + 1]).expect("the minimum is a sum");
                choice |= (k as u32) << (3 * i);
                shared[i + 1]
            } else {
                single
            }
        });
        self.choice[index].store(choice, std::sync::atomic::Ordering::Relaxed);
        Planned { cost, first: a.first, count }
    }

    /// Whether binary node `index`, as one root, is a leaf.
    fn is_leaf(&self, bvh: &Bvh, index: usize) -> bool {
        bvh.nodes[index].is_leaf() || self.choice[index].load(std::sync::atomic::Ordering::Relaxed) >> Self::LEAF & 1 != 0
    }

    /// How many of at most `i` roots of binary node `index` come from its left child (0:
    /// the node is the one root).
    fn split(&self, bvh: &Bvh, index: usize, i: usize) -> usize {
        if bvh.nodes[index].is_leaf() {
            return 0;
        }
        (self.choice[index].load(std::sync::atomic::Ordering::Relaxed) >> (3 * (i - 1)) & 7) as usize
    }

    /// The roots of binary node `index`'s subtree as at most `i` roots, appended to `out`.
    fn roots(&self, bvh: &Bvh, index: usize, i: usize, out: &mut [usize; 8], n: &mut usize) {
        match self.split(bvh, index, i) {
            0 => {
                out[*n] = index;
                *n += 1;
            }
            k => {
                let l = bvh.nodes[index].left_first as usize;
                self.roots(bvh, l, k, out, n);
                self.roots(bvh, l + 1, i - k, out, n);
            }
        }
    }
}

/// The primitives of binary node `index`'s subtree, contiguous in `prim_indices` (the
/// plan makes a leaf of a subtree only then): first, count.
fn subtree_prims(bvh: &Bvh, index: usize) -> (u32, u32) {
    let node = &bvh.nodes[index];
    if node.is_leaf() {
        return (node.left_first, node.count);
    }
    let l = node.left_first as usize;
    let ((first, a), (_, b)) = (subtree_prims(bvh, l), subtree_prims(bvh, l + 1));
    (first, a + b)
}

/// A wide tree (or part of one) being collapsed: nodes, and the triangle numbers of each
/// leaf block (`EMPTY` for padding).
#[derive(Default)]
struct Collapse {
    nodes: Vec<Node8>,
    blocks: Vec<[u32; 4]>,
    depth: usize,
}

impl Collapse {
    /// Convert the binary subtree at `index` as `plan` says, appending its wide nodes to
    /// `self.nodes` and its leaves' triangle numbers, four per block, to `self.blocks`.
    /// Returns its code.
    fn convert(&mut self, bvh: &Bvh, plan: &Plan, index: usize, depth: usize) -> u32 {
        if plan.is_leaf(bvh, index) {
            let (first, count) = subtree_prims(bvh, index);
            let prims = &bvh.prim_indices[first as usize..(first + count) as usize];
            let first = self.blocks.len() as u32;
            let count = prims.len().div_ceil(4);
            assert!(count <= MAX_BLOCKS && first <= FIRST_MASK, "leaf too large for the wide layout");
            self.blocks.extend(prims.chunks(4).map(|chunk| {
                let mut b = [EMPTY; 4];
                b[..chunk.len()].copy_from_slice(chunk);
                b
            }));
            return LEAF | ((count as u32 - 1) << BLOCKS_SHIFT) | first;
        }
        self.depth = self.depth.max(depth);
        let (mut kids, mut n) = ([0usize; 8], 0);
        let (l, k) = (bvh.nodes[index].left_first as usize, plan.split(bvh, index, 8));
        plan.roots(bvh, l, k, &mut kids, &mut n);
        plan.roots(bvh, l + 1, 8 - k, &mut kids, &mut n);
        let slot = self.nodes.len();
        self.nodes.push(Node8::EMPTY);
        let mut codes = [EMPTY; 8];
        for (code, &k) in codes.iter_mut().zip(&kids[..n]) {
            *code = self.convert(bvh, plan, k, depth + 1);
        }
        // Lanes by decreasing box area (stable): any-hit queries try lanes in order, and
        // a large box is the likeliest to hold an occluder. PERF: shadow rays +4%. The
        // subtrees stay in the order above, so the memory layout does not change.
        let areas: [f32; 8] = std::array::from_fn(|i| if i < n { bvh.nodes[kids[i]].aabb().half_area() } else { 0.0 });
        let mut lanes: [usize; 8] = std::array::from_fn(|i| i);
        lanes[..n].sort_by(|&a, &b| areas[b].total_cmp(&areas[a]));
        for (lane, &i) in lanes[..n].iter().enumerate() {
            self.nodes[slot].set(lane, &bvh.nodes[kids[i]].aabb(), codes[i]);
        }
        let code = slot * std::mem::size_of::<Node8>();
        assert!(code < LEAF as usize, "too many wide nodes for 31-bit node offsets");
        code as u32
    }
}

/// Sort keys of eight entry distances: the float bits made to compare as signed
/// integers (negative floats reversed), the lowest three bits replaced by `7 - lane` so
/// that keys are distinct and ties go to the higher lane, as the insertion sort orders
/// them (after Embree's sorting of hit children in vector registers).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn sort_keys(dist: &[f32; 8]) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::*;
    // SAFETY: the caller guarantees AVX2; the load reads the eight floats of `dist`.
    unsafe {
        let d = _mm256_loadu_si256(dist.as_ptr().cast());
        let sign = _mm256_srai_epi32::<31>(d);
        let ordered = _mm256_xor_si256(d, _mm256_and_si256(sign, _mm256_set1_epi32(0x7FFF_FFFF)));
        _mm256_or_si256(_mm256_and_si256(ordered, _mm256_set1_epi32(!7)), _mm256_setr_epi32(7, 6, 5, 4, 3, 2, 1, 0))
    }
}

/// How many lanes of `mask` have a smaller key than `lane`.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn nearer_count(keys: std::arch::x86_64::__m256i, lane: usize, mask: u32) -> usize {
    use std::arch::x86_64::*;
    // SAFETY: the caller guarantees AVX2.
    unsafe {
        let key = _mm256_permutevar8x32_epi32(keys, _mm256_set1_epi32(lane as i32));
        (_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(key, keys))) as u32 & mask).count_ones() as usize
    }
}

#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
unsafe fn sort_keys(dist: &[f32; 8]) -> [f32; 8] {
    *dist
}

#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
unsafe fn nearer_count(keys: [f32; 8], lane: usize, mask: u32) -> usize {
    (0..8).filter(|&j| mask & (1 << j) != 0 && (keys[j] < keys[lane] || (keys[j] == keys[lane] && j > lane))).count()
}

/// The triangle blocks a leaf's child code names.
#[inline(always)]
pub(crate) fn leaf_blocks(code: u32) -> std::ops::Range<usize> {
    let first = (code & FIRST_MASK) as usize;
    first..first + ((code >> BLOCKS_SHIFT) & 0x7) as usize + 1
}

/// What every box and triangle test of one ray shares.
struct RayPre {
    origin: Vec3,
    dir: Vec3,
    inv: Vec3,
    /// `origin · inv`, for the FMA form of the slab test.
    org_inv: Vec3,
    /// Per axis, whether the direction is negative (then the near plane is `hi`).
    neg: [bool; 3],
    /// Per axis, the byte offsets in a [`Node8`] of the near and the far plane (after
    /// Embree: no per-node select of the planes).
    near_far: [(usize, usize); 3],
}

impl RayPre {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let (inv, neg) = slab_inverse(ray.direction);
        let near_far = std::array::from_fn(|axis| {
            const PLANE: usize = std::mem::size_of::<[f32; 8]>();
            let (lo, hi) = (std::mem::offset_of!(Node8, lo) + PLANE * axis, std::mem::offset_of!(Node8, hi) + PLANE * axis);
            if neg[axis] {
                (hi, lo)
            } else {
                (lo, hi)
            }
        });
        Self { origin: ray.origin, dir: ray.direction, inv, org_inv: ray.origin * inv, neg, near_far }
    }
}

/// The inverse direction of the slab tests and the ray's octant (per axis, whether the
/// near plane is the box's upper one). Zero components become ±1e-30 first, keeping their
/// sign (also that of -0.0), so no slab test computes 0·∞; the octant is read from the
/// inverse so it always agrees with it.
#[inline(always)]
pub(crate) fn slab_inverse(d: Vec3) -> (Vec3, [bool; 3]) {
    let safe = |d: f32| if d.abs() < 1e-30 { 1e-30f32.copysign(d) } else { d };
    let inv = Vec3::new(1.0 / safe(d.x), 1.0 / safe(d.y), 1.0 / safe(d.z));
    (inv, [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0])
}

/// Widen a box interval by a few ULPs so rounding never culls a hit: by scaling when
/// `t_min >= 0` (then `near >= 0`, and a negative `far` fails anyway), by `|x|·WIDEN`
/// otherwise.
#[inline(always)]
fn widen(near: f32, far: f32, t_min: f32) -> (f32, f32) {
    if t_min >= 0.0 {
        (near * (1.0 - WIDEN), far * (1.0 + WIDEN))
    } else {
        (near - near.abs() * WIDEN, far + far.abs() * WIDEN)
    }
}

#[inline(always)]
#[allow(clippy::needless_range_loop)] // `lane` indexes six arrays at once
fn box_test_scalar(node: &Node8, pre: &RayPre, t_min: f32, t_max: f32, dist: &mut [f32; 8]) -> u32 {
    let mut mask = 0;
    for lane in 0..8 {
        let mut near = t_min;
        let mut far = t_max;
        for axis in 0..3 {
            let (n, f) =
                if pre.neg[axis] { (node.hi[axis][lane], node.lo[axis][lane]) } else { (node.lo[axis][lane], node.hi[axis][lane]) };
            near = near.max((n - pre.origin[axis]) * pre.inv[axis]);
            far = far.min((f - pre.origin[axis]) * pre.inv[axis]);
        }
        let (near, far) = widen(near, far, t_min);
        dist[lane] = near;
        if near <= far {
            mask |= 1 << lane;
        }
    }
    mask
}

/// A block's triangles one lane at a time: `test(a, b, c, t_min, t_max)` gets the three
/// stored vectors of a lane (`v0, e1, e2`, or `v0, v1, v2` in a watertight block). The
/// closest hit wins; on a tie the lower lane, as in the SIMD test.
#[inline(always)]
fn tri4_lanes(tri: &Tri4, t_min: f32, t_max: f32, test: impl Fn(Vec3, Vec3, Vec3, f32, f32) -> Option<TriangleHit>) -> Option<MeshHit> {
    let mut best: Option<MeshHit> = None;
    for lane in 0..4 {
        if tri.prim[lane] == EMPTY {
            continue;
        }
        let get = |a: &[[f32; 4]; 3]| Vec3::new(a[0][lane], a[1][lane], a[2][lane]);
        let limit = best.map_or(t_max, |b| b.t);
        if let Some(h) = test(get(&tri.v0), get(&tri.e1), get(&tri.e2), t_min, limit) {
            best = Some(MeshHit { t: h.t, prim: tri.prim[lane], u: h.u, v: h.v });
        }
    }
    best
}

/// Möller–Trumbore on a block, scalar.
#[inline(always)]
fn tri4_scalar(tri: &Tri4, ray: &Ray, t_min: f32, t_max: f32) -> Option<MeshHit> {
    tri4_lanes(tri, t_min, t_max, |v0, e1, e2, t0, t1| moller_trumbore_edges(ray, v0, e1, e2, t0, t1))
}

/// The watertight test on a block built with exact vertices.
#[inline(always)]
fn tri4_watertight(tri: &Tri4, w: &WatertightRay, t_min: f32, t_max: f32) -> Option<MeshHit> {
    tri4_lanes(tri, t_min, t_max, |v0, v1, v2, t0, t1| w.intersect(v0, v1, v2, t0, t1))
}

/// The slab test of one ray against a node's eight boxes.
///
/// # Safety
/// The CPU must have AVX2 and FMA, and `pre` must come from [`RayPre::new`] (its
/// `near_far` offsets name planes of a `Node8`).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn box_test_avx2(node: &Node8, pre: &RayPre, t_min: f32, t_max: f32, dist: &mut [f32; 8]) -> u32 {
    use std::arch::x86_64::*;
    // SAFETY: the caller guarantees AVX2 and FMA. `near_far` holds offsets of planes
    // (`[f32; 8]` at multiples of 32 bytes) inside the 32-byte aligned `Node8`, so the
    // aligned loads read within the node.
    unsafe {
        let base = std::ptr::from_ref(node).cast::<u8>();
        let mut near = _mm256_set1_ps(t_min);
        let mut far = _mm256_set1_ps(t_max);
        for axis in 0..3 {
            let (n, f) = pre.near_far[axis];
            debug_assert!([n, f].iter().all(|&o| o % 32 == 0 && o + 32 <= std::mem::offset_of!(Node8, child)));
            let inv = _mm256_set1_ps(pre.inv[axis]);
            let oi = _mm256_set1_ps(pre.org_inv[axis]);
            let tn = _mm256_fmsub_ps(_mm256_load_ps(base.add(n).cast()), inv, oi);
            let tf = _mm256_fmsub_ps(_mm256_load_ps(base.add(f).cast()), inv, oi);
            near = _mm256_max_ps(near, tn);
            far = _mm256_min_ps(far, tf);
        }
        if t_min >= 0.0 {
            // Widened in ULPs, on the float bits: `near` (>= 0, or -0.0) moves down by
            // WIDEN_ULPS, `far` up by as many when >= 0. Adding to the bits of a
            // non-negative float moves it that many ULPs; a negative `far` fails anyway,
            // except -0.0, accepted as the float compare would. -0.0's bits are
            // `i32::MIN`, so a -0.0 `near` accepts: conservative. PERF: integer adds and
            // compares instead of two multiplies and a float compare on the path from
            // the node's loads to the next node: primary +3.7%, diffuse +1.8%, shadow +1.8%.
            let (ni, fi) = (_mm256_castps_si256(near), _mm256_castps_si256(far));
            let ulps = _mm256_set1_epi32(WIDEN_ULPS);
            let too_far = _mm256_cmpgt_epi32(ni, _mm256_add_epi32(fi, _mm256_add_epi32(ulps, ulps)));
            let neg_zero = _mm256_cmpeq_epi32(fi, _mm256_set1_epi32(i32::MIN));
            let lowered = _mm256_sub_epi32(_mm256_max_epi32(ni, ulps), ulps);
            _mm256_storeu_si256(dist.as_mut_ptr().cast(), lowered);
            let reject = _mm256_movemask_ps(_mm256_castsi256_ps(too_far)) as u32;
            return (!reject & 0xFF) | _mm256_movemask_ps(_mm256_castsi256_ps(neg_zero)) as u32;
        } else {
            let widen = _mm256_set1_ps(WIDEN);
            let sign = _mm256_set1_ps(-0.0);
            near = _mm256_fnmadd_ps(_mm256_andnot_ps(sign, near), widen, near);
            far = _mm256_fmadd_ps(_mm256_andnot_ps(sign, far), widen, far);
        }
        _mm256_storeu_ps(dist.as_mut_ptr(), near);
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32
    }
}

#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
unsafe fn box_test_avx2(node: &Node8, pre: &RayPre, t_min: f32, t_max: f32, dist: &mut [f32; 8]) -> u32 {
    box_test_scalar(node, pre, t_min, t_max, dist)
}

/// Möller–Trumbore on four triangles with SSE, operation for operation as
/// [`moller_trumbore_edges`].
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn tri4_sse<const ANY: bool>(tri: &Tri4, pre: &RayPre, t_min: f32, t_max: f32) -> Option<MeshHit> {
    use std::arch::x86_64::*;
    // SAFETY: SSE is part of x86-64; `Tri4` is 16-byte aligned so the aligned loads are valid.
    unsafe {
        let ld = |a: &[f32; 4]| _mm_load_ps(a.as_ptr());
        let (dx, dy, dz) = (_mm_set1_ps(pre.dir.x), _mm_set1_ps(pre.dir.y), _mm_set1_ps(pre.dir.z));
        let (e1x, e1y, e1z) = (ld(&tri.e1[0]), ld(&tri.e1[1]), ld(&tri.e1[2]));
        let (e2x, e2y, e2z) = (ld(&tri.e2[0]), ld(&tri.e2[1]), ld(&tri.e2[2]));
        let mul = |a, b| _mm_mul_ps(a, b);
        let sub = |a, b| _mm_sub_ps(a, b);
        let add = |a, b| _mm_add_ps(a, b);
        // p = d × e2
        let px = sub(mul(dy, e2z), mul(dz, e2y));
        let py = sub(mul(dz, e2x), mul(dx, e2z));
        let pz = sub(mul(dx, e2y), mul(dy, e2x));
        let det = add(add(mul(e1x, px), mul(e1y, py)), mul(e1z, pz));
        let inv = _mm_div_ps(_mm_set1_ps(1.0), det);
        // s = o - v0
        let sx = sub(_mm_set1_ps(pre.origin.x), ld(&tri.v0[0]));
        let sy = sub(_mm_set1_ps(pre.origin.y), ld(&tri.v0[1]));
        let sz = sub(_mm_set1_ps(pre.origin.z), ld(&tri.v0[2]));
        let u = mul(add(add(mul(sx, px), mul(sy, py)), mul(sz, pz)), inv);
        // q = s × e1
        let qx = sub(mul(sy, e1z), mul(sz, e1y));
        let qy = sub(mul(sz, e1x), mul(sx, e1z));
        let qz = sub(mul(sx, e1y), mul(sy, e1x));
        let v = mul(add(add(mul(dx, qx), mul(dy, qy)), mul(dz, qz)), inv);
        let t = mul(add(add(mul(e2x, qx), mul(e2y, qy)), mul(e2z, qz)), inv);
        let zero = _mm_setzero_ps();
        let one = _mm_set1_ps(1.0);
        let mut m = _mm_cmpneq_ps(det, zero);
        m = _mm_and_ps(m, _mm_cmpge_ps(u, zero));
        m = _mm_and_ps(m, _mm_cmple_ps(u, one));
        m = _mm_and_ps(m, _mm_cmpge_ps(v, zero));
        m = _mm_and_ps(m, _mm_cmple_ps(add(u, v), one));
        m = _mm_and_ps(m, _mm_cmpge_ps(t, _mm_set1_ps(t_min)));
        m = _mm_and_ps(m, _mm_cmplt_ps(t, _mm_set1_ps(t_max)));
        let mut mask = _mm_movemask_ps(m) as u32;
        if mask == 0 {
            return None;
        }
        let (mut ts, mut us, mut vs) = ([0f32; 4], [0f32; 4], [0f32; 4]);
        _mm_storeu_ps(ts.as_mut_ptr(), t);
        _mm_storeu_ps(us.as_mut_ptr(), u);
        _mm_storeu_ps(vs.as_mut_ptr(), v);
        let mut lane = mask.trailing_zeros() as usize;
        if ANY {
            // Any hit will do: the first lane, without picking the closest.
            return Some(MeshHit { t: ts[lane], prim: tri.prim[lane], u: us[lane], v: vs[lane] });
        }
        mask &= mask - 1;
        while mask != 0 {
            let l = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            if ts[l] < ts[lane] {
                lane = l;
            }
        }
        Some(MeshHit { t: ts[lane], prim: tri.prim[lane], u: us[lane], v: vs[lane] })
    }
}

#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn tri4_sse<const ANY: bool>(tri: &Tri4, pre: &RayPre, t_min: f32, t_max: f32) -> Option<MeshHit> {
    tri4_scalar(tri, &Ray::new(pre.origin, pre.dir), t_min, t_max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::MeshAccel;
    use crate::scene::Accel;
    use rand::{Rng, SeedableRng};

    /// Random small triangles in a cube, a few of them degenerate.
    fn random_mesh(n: usize, seed: u64) -> TriangleMesh {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
        let mut vertices = Vec::new();
        for i in 0..n {
            let c = Vec3::new(rng.random_range(-10.0..10.0), rng.random_range(-10.0..10.0), rng.random_range(-10.0..10.0));
            let mut v = || c + Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            let (a, b) = (v(), v());
            // Every 50th triangle has two equal vertices: zero area, left out.
            let c2 = if i % 50 == 0 { b } else { v() };
            vertices.extend([a, b, c2]);
        }
        let triangles = (0..n as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        TriangleMesh::new(vertices, Vec::new(), triangles)
    }

    /// The SAH cost of a wide tree as the plan counts it: wide nodes and leaves by the
    /// half area of their box.
    fn wide_sah_cost(w: &WideBvh, root_area: f32) -> f32 {
        let lane_area = |n: &Node8, lane: usize| {
            crate::Aabb::new(Vec3::new(n.lo[0][lane], n.lo[1][lane], n.lo[2][lane]), Vec3::new(n.hi[0][lane], n.hi[1][lane], n.hi[2][lane]))
                .half_area()
        };
        let mut cost = if w.root & LEAF == 0 { root_area * WIDE_NODE_COST } else { root_area * leaf_blocks(w.root).len() as f32 };
        for n in &w.nodes {
            for (lane, &code) in n.child.iter().enumerate().filter(|(_, &c)| c != EMPTY) {
                let per_area = if code & LEAF == 0 { WIDE_NODE_COST } else { leaf_blocks(code).len() as f32 };
                cost += lane_area(n, lane) * per_area;
            }
        }
        cost
    }

    /// The SAH cost of the greedy collapse (each wide node opens its largest interior
    /// child until it has eight), the one the plan replaced.
    fn greedy_cost(bvh: &Bvh, index: usize) -> f32 {
        let node = &bvh.nodes[index];
        let area = |k: usize| bvh.nodes[k].aabb().half_area();
        if node.is_leaf() {
            return area(index) * node.count.div_ceil(4) as f32;
        }
        let first = node.left_first as usize;
        let mut kids = vec![first, first + 1];
        while kids.len() < 8 {
            let open = kids.iter().enumerate().filter(|(_, &k)| !bvh.nodes[k].is_leaf()).max_by(|a, b| area(*a.1).total_cmp(&area(*b.1)));
            let Some((i, &k)) = open else { break };
            let c = bvh.nodes[k].left_first as usize;
            kids[i] = c;
            kids.push(c + 1);
        }
        area(index) * WIDE_NODE_COST + kids.iter().map(|&k| greedy_cost(bvh, k)).sum::<f32>()
    }

    #[test]
    fn the_collapse_builds_the_planned_tree_and_beats_the_greedy_one() {
        for (n, seed) in [(3, 1), (40, 2), (5_000, 3), (20_000, 4)] {
            let mesh = random_mesh(n, seed);
            let valid: Vec<u32> = (0..n as u32).filter(|i| i % 50 != 0).collect();
            let bvh = Bvh::build_sah(&valid, |i| {
                let [a, b, c] = mesh.triangle_vertices(i);
                crate::Aabb::new(a.min(b).min(c), a.max(b).max(c))
            });
            let plan = Plan::new(&bvh);
            let w = WideBvh::from_bvh(&bvh, &mesh);
            let root_area = bvh.nodes[0].aabb().half_area();
            let built = wide_sah_cost(&w, root_area);
            assert!((built - plan.cost).abs() <= 1e-4 * plan.cost, "{n} triangles: built {built}, planned {}", plan.cost);
            assert!((w.sah_cost() * root_area - built).abs() <= 1e-4 * built, "{n} triangles: reported {}", w.sah_cost());
            let greedy = greedy_cost(&bvh, 0);
            assert!(plan.cost <= greedy * (1.0 + 1e-5), "{n} triangles: planned {} > greedy {greedy}", plan.cost);
            if n >= 5_000 {
                assert!(plan.cost < 0.99 * greedy, "{n} triangles: planned {} not below greedy {greedy}", plan.cost);
            }
        }
    }

    /// Rays starting on a triangle (t = 0) that lies on a face of its leaf's box: the ULP
    /// widening must keep the box when its far distance is -0.0 (origin x -0.0, going
    /// down x out of the box) and its near one +0.0.
    #[test]
    fn rays_starting_on_an_axis_aligned_triangle_hit_it_at_zero_on_every_level() {
        // A triangle in the plane x = 0 with one at x = 0.5 beside it (one leaf, its box
        // from x = 0 to 0.5), and far ones so the tree has inner nodes.
        let vertices = vec![
            Vec3::new(0.0, -1.0, -1.0),
            Vec3::new(0.0, 1.0, -1.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.5, 2.0, 2.0),
            Vec3::new(0.5, 3.0, 2.0),
            Vec3::new(0.5, 2.0, 3.0),
        ];
        let mut vertices = vertices;
        let mut rng = rand_pcg::Pcg32::seed_from_u64(5);
        for _ in 0..60 {
            let c = Vec3::new(rng.random_range(5.0..20.0), rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0));
            vertices.extend([c, c + Vec3::X, c + Vec3::Y]);
        }
        let triangles = (0..vertices.len() as u32 / 3).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        let mut mesh = TriangleMesh::new(vertices, Vec::new(), triangles);
        mesh.build_accel(Accel::BvhSah);
        let MeshAccel::Wide(w) = mesh.accel() else { panic!("bvh-sah builds a wide BVH") };
        assert!(w.root & LEAF == 0, "the test needs box tests");
        let mut checked = 0;
        for ox in [0.0f32, -0.0] {
            for dx in [1.0f32, -1.0, 1e-3, -1e-3] {
                for t_min in [0.0f32, -0.0] {
                    let ray = Ray::new(Vec3::new(ox, 0.0, 0.0), Vec3::new(dx, 0.25, 0.5));
                    let want = mesh.intersect_brute_force(&ray, t_min, f32::INFINITY);
                    assert!(want.is_some_and(|h| h.t == 0.0 && h.prim == 0), "brute force hits triangle 0 at t = 0");
                    for level in SimdLevel::available() {
                        let mut w = w.clone();
                        w.set_level(level);
                        let got = w.intersect(&ray, t_min, f32::INFINITY);
                        assert_eq!(got.map(|h| (h.t, h.prim)), Some((0.0, 0)), "{level:?}, origin x {ox:?}, dx {dx:?}, t_min {t_min:?}");
                        assert!(w.occluded(&ray, t_min, f32::INFINITY));
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked >= 32);
    }

    #[test]
    fn collapsed_nodes_bound_their_children_in_decreasing_area_order() {
        let mut mesh = random_mesh(20_000, 9);
        mesh.build_accel(Accel::BvhSah);
        let MeshAccel::Wide(w) = mesh.accel() else { panic!("bvh-sah builds a wide BVH") };
        let lane_box = |n: &Node8, lane: usize| {
            crate::Aabb::new(Vec3::new(n.lo[0][lane], n.lo[1][lane], n.lo[2][lane]), Vec3::new(n.hi[0][lane], n.hi[1][lane], n.hi[2][lane]))
        };
        let contains = |outer: &crate::Aabb, p: Vec3| outer.min.cmple(p).all() && outer.max.cmpge(p).all();
        let mut seen = vec![0u32; 20_000];
        for node in &w.nodes {
            let used = node.child.iter().take_while(|&&c| c != EMPTY).count();
            assert!(used >= 2 && node.child[used..].iter().all(|&c| c == EMPTY), "children first: {:?}", node.child);
            for lane in 1..used {
                assert!(lane_box(node, lane - 1).half_area() >= lane_box(node, lane).half_area(), "lanes by decreasing area");
            }
            for lane in used..8 {
                assert!(lane_box(node, lane).min.x > lane_box(node, lane).max.x, "empty lanes hold an inverted box");
            }
            for lane in 0..used {
                let b = lane_box(node, lane);
                let code = node.child[lane];
                if code & LEAF == 0 {
                    let kid = &w.nodes[code as usize / std::mem::size_of::<Node8>()];
                    for k in kid.child.iter().enumerate().filter(|(_, &c)| c != EMPTY).map(|(k, _)| k) {
                        let kb = lane_box(kid, k);
                        assert!(contains(&b, kb.min) && contains(&b, kb.max), "a child box outside its parent's lane");
                    }
                } else {
                    for block in &w.tris[leaf_blocks(code)] {
                        for (l, &p) in block.prim.iter().enumerate().filter(|(_, &p)| p != EMPTY) {
                            seen[p as usize] += 1;
                            let v0 = Vec3::new(block.v0[0][l], block.v0[1][l], block.v0[2][l]);
                            assert!(mesh.triangle_vertices(p).iter().all(|&v| contains(&b, v)) && contains(&b, v0));
                        }
                    }
                }
            }
        }
        for (p, &count) in seen.iter().enumerate() {
            assert_eq!(count, u32::from(p % 50 != 0), "triangle {p}: degenerate ones never, the others once");
        }
    }
}
