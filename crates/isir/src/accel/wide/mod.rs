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
//! - [`Node8`] (256 bytes, four cache lines): the eight child boxes as structure of
//!   arrays (`lo[axis][lane]`, `hi[axis][lane]`) so one AVX load fetches one plane of eight
//!   boxes, eight `u32` child codes, and per child the code to prefetch as a ray goes into
//!   it (`next`: an inner child's lane 0). Empty lanes hold an inverted box (`+∞..-∞`) that no
//!   ray enters, so the box test needs no lane mask.
//! - Child code: an inner node's byte offset in the node array, or
//!   `LEAF | (blocks - 1) << 28 | first block`.
//! - [`Tri4`] (160 bytes): four triangles as `v0`, `e1 = v1 - v0`, `e2 = v2 - v0` by
//!   component, and their triangle numbers. Unused lanes are NaN and never hit.
//!
//! # Paths
//! [`SimdLevel`] picks the code path at run time (`is_x86_feature_detected!`): plain
//! scalar Rust (the tested fallback, and the only path off x86-64), AVX2+FMA, and the
//! same kernels compiled for AVX-512. The triangle test computes exactly what
//! [`crate::accel::triangle::moller_trumbore`] computes, operation for operation, so every path
//! returns bit-identical distances and barycentrics.

mod collapse;
mod interleave;
mod kernels;
pub(crate) mod stream;
#[cfg(test)]
mod tests;
mod traverse;
pub(crate) use interleave::prefetch;
pub use interleave::Interleave;
pub use interleave::IN_FLIGHT;

use crate::accel::bvh::Bvh;
use crate::accel::triangle::TriangleTest;
use crate::accel::{MeshHit, Triangles};
use crate::math::ray::Ray;
use collapse::{Collapse, Plan};
use glam::Vec3;
#[cfg(target_arch = "x86_64")]
pub(crate) use kernels::origin_part_avx2;
pub(crate) use kernels::{slab_inverse, FMA_SLACK};

/// No child in this lane.
pub(crate) const EMPTY: u32 = u32::MAX;
/// Set in a child code for a leaf.
pub(crate) const LEAF: u32 = 1 << 31;
pub(crate) const BLOCKS_SHIFT: u32 = 28;
pub(crate) const FIRST_MASK: u32 = (1 << BLOCKS_SHIFT) - 1;
/// Leaves hold at most this many blocks of four triangles.
const MAX_BLOCKS: usize = 8;
/// At most this many wide nodes in a tree: inner codes are byte offsets below `LEAF`,
/// 8,388,608 nodes of 256 bytes (about 175 million triangles).
pub const MAX_NODES: usize = LEAF as usize / std::mem::size_of::<Node8>();

/// A binary BVH too large to collapse into a [`WideBvh`]: more than [`MAX_NODES`] wide
/// nodes, or more than 2^28 blocks of four triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TooLarge;

impl std::fmt::Display for TooLarge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "the wide BVH holds at most {MAX_NODES} nodes (about 175 million triangles)")
    }
}

impl std::error::Error for TooLarge {}

/// Traversal stack entries: at most seven pushes per level.
pub(crate) const STACK_SIZE: usize = stack_entries(crate::accel::bvh::STACK_SIZE);
/// The stack of trees at most 16 wide nodes deep (`7 · 16 + 8` entries), nearly every
/// tree ([`WideBvh::fits_small_stack`]): the AVX-512 packets' (7.7 KB of entry distances
/// instead of 43.5 KB, `accel::packet`) and each interleaved ray's (`interleave`).
pub(crate) const SMALL_STACK: usize = stack_entries(16);
/// Box distances are widened by a few ULPs so that rounding in the box test never culls a
/// triangle the exact test would hit (the conservative traversal of pbrt and Embree).
/// The interval `[near, far]` becomes `[near - |near|·WIDEN, far + |far|·WIDEN]`, wider
/// whatever the signs (rays may start at a negative `t_min`).
pub(crate) const WIDEN: f32 = 4.0 * f32::EPSILON;
/// The SIMD box test's widening when `t_min >= 0`, in ULPs of each end (4 ε relative is
/// 4 to 8 ULPs, so this is at least as wide).
const WIDEN_ULPS: i32 = 8;

/// Eight child boxes (structure of arrays), their child codes, and per child what a walk
/// into it likely visits next.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
pub struct Node8 {
    pub(crate) lo: [[f32; 8]; 3],
    pub(crate) hi: [[f32; 8]; 3],
    pub(crate) child: [u32; 8],
    /// Per lane, [`next_code`] of the child: an inner child's own lane 0 (its largest
    /// box, the child a ray entering it most often enters next), else the child's code.
    /// The single ray prefetches it as it goes into the child, so that the child's wait on
    /// the cache and its likeliest child's overlap.
    pub(crate) next: [u32; 8],
}

const _: () = assert!(std::mem::size_of::<Node8>() == 256);

/// What a [`Node8`] keeps in `next` for its child `code`, in a tree whose nodes are
/// `nodes` (the child's own node written already): an inner child's lane 0, else `code`.
pub(crate) fn next_code(nodes: &[Node8], code: u32) -> u32 {
    if code & LEAF == 0 {
        nodes[code as usize / std::mem::size_of::<Node8>()].child[0]
    } else {
        code
    }
}

impl Node8 {
    /// No children: every lane's box inverted.
    pub(crate) const EMPTY: Node8 =
        Node8 { lo: [[f32::INFINITY; 8]; 3], hi: [[f32::NEG_INFINITY; 8]; 3], child: [EMPTY; 8], next: [EMPTY; 8] };

    /// Lane `lane` made the child `code` with box `b`, and `next` its [`next_code`].
    fn set(&mut self, lane: usize, b: &crate::math::aabb::Aabb, code: u32, next: u32) {
        for axis in 0..3 {
            self.lo[axis][lane] = b.min[axis];
            self.hi[axis][lane] = b.max[axis];
        }
        self.child[lane] = code;
        self.next[lane] = next;
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
    /// A block of padding only: NaN vectors that no ray hits, `EMPTY` numbers.
    pub(crate) const EMPTY: Tri4 = Tri4 { v0: [[f32::NAN; 4]; 3], e1: [[f32::NAN; 4]; 3], e2: [[f32::NAN; 4]; 3], prim: [EMPTY; 4] };

    /// The block of triangles `prims` (`EMPTY` lanes are padding).
    fn new(mesh: &impl Triangles, prims: &[u32; 4], watertight: bool) -> Tri4 {
        let mut t = Tri4::EMPTY;
        for (lane, &p) in prims.iter().enumerate().filter(|(_, &p)| p != EMPTY) {
            let [a, b, c] = mesh.vertices_of(p);
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

    /// The three stored vectors of `lane`: `v0, e1, e2` (`v0, v1, v2` in a watertight
    /// block).
    #[inline(always)]
    pub(crate) fn lane(&self, lane: usize) -> [Vec3; 3] {
        let get = |a: &[[f32; 4]; 3]| Vec3::new(a[0][lane], a[1][lane], a[2][lane]);
        [get(&self.v0), get(&self.e1), get(&self.e2)]
    }

    /// Lane `lane` made a copy of lane `from_lane` of `from`.
    pub(crate) fn copy_lane(&mut self, lane: usize, from: &Tri4, from_lane: usize) {
        for a in 0..3 {
            self.v0[a][lane] = from.v0[a][from_lane];
            self.e1[a][lane] = from.e1[a][from_lane];
            self.e2[a][lane] = from.e2[a][from_lane];
        }
        self.prim[lane] = from.prim[from_lane];
    }
}

/// Which code path traces rays. The levels are ordered: each CPU that runs one runs
/// those before it (an AVX-512 CPU takes the AVX2 streams, `accel/packet.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
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
    /// When batches of rays are interleaved.
    interleave: Interleave,
}

impl WideBvh {
    /// Collapse a binary BVH over `mesh`'s triangles.
    ///
    /// # Errors
    /// [`TooLarge`] when the tree needs more than [`MAX_NODES`] wide nodes (a mesh of
    /// about 175 million triangles or more): trace the binary BVH then.
    pub fn from_bvh(bvh: &Bvh, mesh: &impl Triangles) -> Result<WideBvh, TooLarge> {
        WideBvh::from_bvh_in(bvh, mesh, Vec::new(), MAX_NODES)
    }

    /// Room for the blocks of a tree of `triangles` triangles (an estimate: three to a
    /// block), on huge pages: the storage [`Bvh::build_sah_in`] and
    /// [`WideBvh::from_bvh_in`] share.
    pub(crate) fn block_storage(triangles: usize) -> Vec<Tri4> {
        crate::accel::memory::vec_on_huge_pages(triangles / 3 + 1)
    }

    /// [`WideBvh::from_bvh`] with the blocks written into `storage` (its capacity reused,
    /// grown if short): the memory the SAH build's records have faulted in
    /// ([`Bvh::build_sah_in`]); at most `max_nodes` nodes (at most [`MAX_NODES`]; fewer
    /// in tests, which cannot build a tree that large).
    pub(crate) fn from_bvh_in(bvh: &Bvh, mesh: &impl Triangles, storage: Vec<Tri4>, max_nodes: usize) -> Result<WideBvh, TooLarge> {
        use rayon::prelude::*;
        let watertight = mesh.test() == TriangleTest::Watertight;
        let mut w = WideBvh {
            nodes: Vec::new(),
            tris: Vec::new(),
            root: EMPTY,
            depth: 0,
            watertight,
            level: SimdLevel::best(),
            sah_cost: 0.0,
            interleave: Interleave::Auto,
        };
        if bvh.nodes.is_empty() {
            return Ok(w);
        }
        // The tree first, with the triangle numbers of every block; then the blocks, on
        // every core. PERF: gathering the vertices (random reads) was most of the
        // conversion: 9.5 -> 6.5 ms on the conference room. Collapsing the root's
        // subtrees in parallel was slower (one holds 70% of the nodes, and joining the
        // parts copies them).
        // On huge pages, as Embree's trees (see `accel::memory`).
        let mut c = Collapse {
            nodes: crate::accel::memory::vec_on_huge_pages((bvh.nodes.len() / 4 + 1).min(max_nodes)),
            max_nodes: max_nodes.min(MAX_NODES),
            ..Collapse::default()
        };
        c.blocks.reserve(bvh.prim_indices.len() / 3 + 1);
        let plan = Plan::new(bvh);
        w.sah_cost = plan.cost / bvh.nodes[0].aabb().half_area().max(f32::MIN_POSITIVE);
        // The conversion runs on one core; the other faults in meanwhile what will surely
        // be written next: the blocks' triangle numbers, and the blocks beyond the records'
        // part of `storage` (at least a block per four triangles). The kernel only faults
        // pages in, never changing them, so the conversion may write the blocks' numbers
        // meanwhile (and if their vector outgrows its estimate and moves, faulting its old
        // pages is merely wasted). PERF: 10M triangles,
        // one build in a fresh process, 2.06 -> 1.97 s (medians of 8 interleaved). Faulting
        // the wide nodes in a little ahead of the conversion, following its progress, was
        // slower (2.07 s).
        let prims = bvh.prim_indices.len();
        let (blocks, tail) = (
            crate::accel::memory::spare_range(&c.blocks, 0, prims / 4),
            crate::accel::memory::spare_range(
                &storage,
                (prims * crate::accel::bvh::RECORD_BYTES).div_ceil(std::mem::size_of::<Tri4>()),
                prims / 4,
            ),
        );
        let (root, ()) = rayon::join(
            || c.convert(bvh, &plan, 0, 1),
            || {
                crate::accel::memory::populate(blocks);
                crate::accel::memory::populate(tail);
            },
        );
        if c.too_large {
            return Err(TooLarge);
        }
        w.root = root;
        assert!(stack_entries(c.depth) <= STACK_SIZE, "wide BVH too deep ({}) for the traversal stack", c.depth);
        w.depth = c.depth;
        w.nodes = c.nodes;
        w.tris = storage;
        if w.tris.capacity() < c.blocks.len() {
            w.tris = crate::accel::memory::vec_on_huge_pages(c.blocks.len());
        }
        c.blocks.par_iter().with_min_len(1024).map(|prims| Tri4::new(mesh, prims, watertight)).collect_into_vec(&mut w.tris);
        Ok(w)
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
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<MeshHit> {
        self.intersect_stats::<false>(ray, t_min, t_max, &mut TraversalStats::default())
    }

    /// True when a triangle meets the ray in `[t_min, t_max)`.
    #[must_use]
    #[inline]
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        self.occluded_stats::<false>(ray, t_min, t_max, &mut TraversalStats::default())
    }

    /// [`Self::intersect`], counting into `stats` when `STATS`.
    #[inline]
    pub fn intersect_stats<const STATS: bool>(&self, ray: &Ray, t_min: f32, t_max: f32, stats: &mut TraversalStats) -> Option<MeshHit> {
        self.dispatch::<false, STATS>(ray, t_min, t_max, stats)
    }

    /// [`Self::occluded`], counting into `stats` when `STATS`.
    #[inline]
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
}

impl WideBvh {
    /// Asks for the node, or the first 256 bytes of the leaf's blocks, that `code` names
    /// (a [`Node8::next`]) to be brought into the cache: a hint, no effect on what any
    /// load returns. Which of the two is a select, not a branch.
    /// PERF: prefetched as a single ray goes into a child (`traverse`): conference ray
    /// files, one thread, medians of 10-12 paired runs, random 1.038, diffuse 1.015,
    /// shadow 1.000, primary 0.991 of the old rays per second; two lines instead of four,
    /// or the leaves' second block instead of their first, no better. A leaf child's own
    /// code is prefetched again (redundant, cheaper than a branch around it).
    #[inline(always)]
    pub(crate) fn prefetch_next(&self, code: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let node = self.nodes.as_ptr().cast::<i8>().wrapping_add(code as usize);
            let leaf = self.tris.as_ptr().cast::<i8>().wrapping_add((code & FIRST_MASK) as usize * std::mem::size_of::<Tri4>());
            let p = if code & LEAF == 0 { node } else { leaf };
            for off in [0, 64, 128, 192] {
                // SAFETY: a prefetch never faults, whatever the address (SSE, part of
                // x86-64).
                unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(off)) };
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = code;
    }

    /// The closest hit of one ray among the triangles of the leaf `code`, in
    /// `[t_min, t_max)`: the single rays' SSE block test (the AVX-512 packets' leaves that
    /// few rays reach).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn leaf_closest_sse(&self, code: u32, ray: &Ray, t_min: f32, t_max: f32) -> Option<MeshHit> {
        let mut best = None;
        let mut t_best = t_max;
        for b in leaf_blocks(code) {
            // SAFETY: leaf codes index `tris` (`Collapse::convert` wrote them).
            let tri = unsafe { self.tris.get_unchecked(b) };
            if let Some(h) = kernels::tri4_sse_from::<false>(tri, ray.origin, ray.direction, t_min, t_best) {
                t_best = h.t;
                best = Some(h);
            }
        }
        best
    }
}

/// A cut of a tree: up to eight of its subtrees below the root, their boxes and codes as
/// the lanes of one node, where a walk may start instead of at the root when those
/// subtrees hold every node its rays can enter (a shaft's cut, `accel::shaft`: rays from
/// one cell towards one light). Made by `WideBvh::cut`, and used only on the tree it was
/// cut from (the tree's arrays are its stamp), so its codes are always that tree's.
#[derive(Clone, Debug)]
pub struct Cut {
    node: Node8,
    tree: [usize; 4],
}

impl Cut {
    /// The cut's node, when `bvh` is the tree it was cut from.
    #[inline(always)]
    pub(crate) fn node_in(&self, bvh: &WideBvh) -> Option<&Node8> {
        (self.tree == bvh.stamp()).then_some(&self.node)
    }
}

impl WideBvh {
    /// What a [`Cut`] of this tree is stamped with: its arrays' addresses and lengths.
    fn stamp(&self) -> [usize; 4] {
        [self.nodes.as_ptr() as usize, self.nodes.len(), self.tris.as_ptr() as usize, self.tris.len()]
    }

    /// The cut whose lanes are `lanes` (child code, box low and high corners), at most
    /// eight, in that order: `None` when there are more, or when a code is not that of a
    /// node or leaf of this tree below its root (so the walk from the cut keeps within the
    /// stack of the tree's depth).
    pub(crate) fn cut(&self, lanes: &[(u32, Vec3, Vec3)]) -> Option<Cut> {
        let size = std::mem::size_of::<Node8>();
        let valid = |code: u32| {
            code != self.root
                && if code & LEAF != 0 {
                    leaf_blocks(code).end <= self.tris.len()
                } else {
                    (code as usize).is_multiple_of(size) && (code as usize) < self.nodes.len() * size
                }
        };
        if lanes.len() > 8 || !lanes.iter().all(|l| valid(l.0)) {
            return None;
        }
        let mut node = Node8::EMPTY;
        for (lane, &(code, lo, hi)) in lanes.iter().enumerate() {
            node.set(lane, &crate::math::aabb::Aabb::new(lo, hi), code, next_code(&self.nodes, code));
        }
        Some(Cut { node, tree: self.stamp() })
    }
}

/// The traversal stack entries a tree of `depth` levels of wide nodes needs: at most seven
/// pushed per level, and eight by the last.
pub(crate) const fn stack_entries(depth: usize) -> usize {
    7 * depth + 8
}

impl WideBvh {
    /// The traversal stack entries this tree needs ([`stack_entries`] of its depth).
    pub(crate) fn stack_entries(&self) -> usize {
        stack_entries(self.depth)
    }

    /// True when [`SMALL_STACK`] holds this tree's traversal stack.
    pub(crate) fn fits_small_stack(&self) -> bool {
        self.stack_entries() <= SMALL_STACK
    }
}

/// The triangle blocks a leaf's child code names.
#[inline(always)]
pub(crate) fn leaf_blocks(code: u32) -> std::ops::Range<usize> {
    let first = (code & FIRST_MASK) as usize;
    first..first + ((code >> BLOCKS_SHIFT) & 0x7) as usize + 1
}

/// True when a triangle of block `tri` meets `ray` in `[t_min, t_max)`: the tree's own
/// triangle test (the same floats on every path).
#[inline(always)]
pub(crate) fn block_any_hit(tri: &Tri4, ray: &Ray, t_min: f32, t_max: f32) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        kernels::tri4_sse_from::<true>(tri, ray.origin, ray.direction, t_min, t_max).is_some()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        kernels::tri4_scalar(tri, ray, t_min, t_max).is_some()
    }
}
