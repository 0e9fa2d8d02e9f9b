//! Interleaved traversal: [`IN_FLIGHT`] independent rays walked down the tree by one
//! thread, one node of each in turn, each ray's next node prefetched before the thread
//! moves on to the others. A single ray waits on every node it loads; on a tree larger
//! than the last-level cache those waits are most of its time, and rays that share
//! nothing (random, diffuse rays) cannot share node fetches as a stream's rays do.
//! Interleaved, the waits of many rays overlap (after Kocberber et al.'s asynchronous
//! memory access chaining, 2015). On a tree that fits in the cache the single ray is
//! faster (the CPU predicts its next node and goes on), so [`Interleave::Auto`] chooses by
//! the tree's size.
//!
//! Each ray visits the same nodes in the same order as the single ray of
//! [`WideBvh::intersect`] and [`WideBvh::occluded`] on the same code path (the same box
//! and triangle kernels, the same child order, ties included), so the answers are the
//! single ray's, bit for bit.

use super::kernels::*;
use super::traverse::{nearer_count, sort_keys};
use super::*;
use crate::accel::triangle::WatertightRay;
use crate::math::ray::RaySegment;

/// Rays in flight per thread. PERF: dragon (871k triangles, one thread, random rays):
/// one at a time 2.9 Mrays/s, 8 in flight 6.0, 16 6.3, 32 6.3.
pub const IN_FLIGHT: usize = 16;

/// When the rays of a batch ([`WideBvh::intersect_batch`], [`WideBvh::occluded_batch`])
/// are interleaved.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Interleave {
    /// When the tree is larger than the CPU's last-level cache (its size read from
    /// `sysfs` on Linux; 32 MiB where it cannot be read).
    #[default]
    Auto,
    /// Always (trees up to 16 levels deep).
    Always,
    /// Never: one ray after the other.
    Never,
}

impl Interleave {
    /// Lower-case name, as the tools take it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Interleave::Auto => "auto",
            Interleave::Always => "always",
            Interleave::Never => "never",
        }
    }
}

impl std::str::FromStr for Interleave {
    type Err = String;
    /// Parse `auto`, `always` or `never`.
    fn from_str(s: &str) -> Result<Self, String> {
        crate::parse_name(s, &[Interleave::Auto, Interleave::Always, Interleave::Never], Self::name, "interleave setting")
    }
}

/// One ray in flight.
struct Slot {
    ray: Ray,
    pre: RayPre,
    watertight: Option<WatertightRay>,
    t_min: f32,
    t_best: f32,
    best: Option<MeshHit>,
    /// The node or leaf to visit next.
    cur: u32,
    sp: usize,
    /// The ray's index in the batch.
    index: usize,
}

/// A ray in flight's stack: trees up to 16 levels deep (nearly all; deeper ones are
/// traced one ray at a time).
type SlotStack = [std::mem::MaybeUninit<(u32, f32)>; SMALL_STACK];

impl WideBvh {
    /// When this tree's batches are interleaved.
    pub fn set_interleave(&mut self, interleave: Interleave) {
        self.interleave = interleave;
    }

    /// True when this tree's batches are traced [`IN_FLIGHT`] rays at a time.
    #[must_use]
    pub fn interleaves(&self) -> bool {
        let fits = self.fits_small_stack() && self.root != EMPTY;
        fits && match self.interleave {
            Interleave::Auto => self.bytes() > crate::accel::memory::last_level_cache_bytes(),
            Interleave::Always => true,
            Interleave::Never => false,
        }
    }

    /// The closest hit of each ray of `rays` in its interval: `out[i]` is what
    /// [`WideBvh::intersect`] returns for ray `i`.
    ///
    /// # Panics
    /// If `out` is shorter than `rays`.
    pub fn intersect_batch(&self, rays: &[RaySegment], out: &mut [Option<MeshHit>]) {
        assert!(out.len() >= rays.len(), "one answer per ray");
        self.batch::<false>(rays, |_| true, |i, h| out[i] = h);
    }

    /// Whether each ray of `rays` is blocked in its interval: `out[i]` is what
    /// [`WideBvh::occluded`] returns for ray `i`.
    ///
    /// # Panics
    /// If `out` is shorter than `rays`.
    pub fn occluded_batch(&self, rays: &[RaySegment], out: &mut [bool]) {
        assert!(out.len() >= rays.len(), "one answer per ray");
        self.batch::<true>(rays, |_| true, |i, h| out[i] = h.is_some());
    }

    /// The rays of a batch, each answer given to `put(i, hit)`; rays for which `may_hit`
    /// is false (a filter that only rules out rays that surely miss) are answered `None`
    /// without a traversal.
    pub(crate) fn batch<const ANY: bool>(
        &self,
        rays: &[RaySegment],
        may_hit: impl Fn(&RaySegment) -> bool,
        put: impl FnMut(usize, Option<MeshHit>),
    ) {
        let mut put = put;
        if !self.interleaves() {
            for (i, r) in rays.iter().enumerate() {
                let hit = may_hit(r).then(|| self.dispatch::<ANY, false>(&r.ray(), r.t_min, r.t_max, &mut TraversalStats::default()));
                put(i, hit.flatten());
            }
            return;
        }
        match self.level {
            SimdLevel::Scalar => self.interleaved_scalar::<ANY>(rays, &may_hit, &mut put),
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `level` is only ever set to a level `SimdLevel::available` reported.
            SimdLevel::Avx2 => unsafe { self.interleaved_avx2::<ANY>(rays, &may_hit, &mut put) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            SimdLevel::Avx512 => unsafe { self.interleaved_avx512::<ANY>(rays, &may_hit, &mut put) },
            #[cfg(not(target_arch = "x86_64"))]
            _ => unreachable!(),
        }
    }

    #[inline(never)]
    fn interleaved_scalar<const ANY: bool>(
        &self,
        rays: &[RaySegment],
        may_hit: &impl Fn(&RaySegment) -> bool,
        put: &mut impl FnMut(usize, Option<MeshHit>),
    ) {
        // SAFETY: the scalar instantiation runs no SIMD instruction beyond SSE.
        unsafe { self.interleaved::<false, ANY>(rays, may_hit, put) }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,lzcnt")]
    unsafe fn interleaved_avx2<const ANY: bool>(
        &self,
        rays: &[RaySegment],
        may_hit: &impl Fn(&RaySegment) -> bool,
        put: &mut impl FnMut(usize, Option<MeshHit>),
    ) {
        // SAFETY: this function's features are what `interleaved::<true, _>` needs.
        unsafe { self.interleaved::<true, ANY>(rays, may_hit, put) }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,lzcnt,avx512f,avx512vl,avx512dq,avx512bw")]
    unsafe fn interleaved_avx512<const ANY: bool>(
        &self,
        rays: &[RaySegment],
        may_hit: &impl Fn(&RaySegment) -> bool,
        put: &mut impl FnMut(usize, Option<MeshHit>),
    ) {
        // SAFETY: as above.
        unsafe { self.interleaved::<true, ANY>(rays, may_hit, put) }
    }

    /// The interleaved loop: up to [`IN_FLIGHT`] slots, each stepped one node at a time in
    /// turn; a slot whose ray is done takes the batch's next ray.
    ///
    /// # Safety
    /// With `SIMD`, the CPU must have what [`SimdLevel::Avx2`] names. The tree must be at
    /// most 16 levels deep and not empty ([`WideBvh::interleaves`]).
    #[inline(always)]
    unsafe fn interleaved<const SIMD: bool, const ANY: bool>(
        &self,
        rays: &[RaySegment],
        may_hit: &impl Fn(&RaySegment) -> bool,
        put: &mut impl FnMut(usize, Option<MeshHit>),
    ) {
        debug_assert!(self.fits_small_stack() && self.root != EMPTY);
        let mut stacks = [[const { std::mem::MaybeUninit::<(u32, f32)>::uninit() }; SMALL_STACK]; IN_FLIGHT];
        let mut slots: [Option<Slot>; IN_FLIGHT] = [const { None }; IN_FLIGHT];
        let mut next = 0usize;
        // The batch's next valid ray as a slot (invalid rays answered `None` on the way).
        let mut take = |put: &mut dyn FnMut(usize, Option<MeshHit>)| -> Option<Slot> {
            while let Some(r) = rays.get(next) {
                let (index, ray) = (next, r.ray());
                next += 1;
                if !ray.is_valid() || !may_hit(r) {
                    put(index, None);
                    continue;
                }
                let watertight = self.watertight.then(|| WatertightRay::new(&ray));
                let pre = RayPre::new(&ray);
                return Some(Slot { ray, pre, watertight, t_min: r.t_min, t_best: r.t_max, best: None, cur: self.root, sp: 0, index });
            }
            None
        };
        let mut busy = 0u32;
        for (s, slot) in slots.iter_mut().enumerate() {
            *slot = take(put);
            if slot.is_some() {
                busy |= 1 << s;
            }
        }
        while busy != 0 {
            let mut m = busy;
            while m != 0 {
                let s = m.trailing_zeros() as usize;
                m &= m - 1;
                // SAFETY: `s < IN_FLIGHT`, and slots in `busy` hold a ray.
                let (slot, stack) = unsafe { (slots.get_unchecked_mut(s).as_mut().unwrap_unchecked(), stacks.get_unchecked_mut(s)) };
                // SAFETY: this function's requirements.
                if unsafe { self.step::<SIMD, ANY>(slot, stack) } {
                    put(slot.index, slot.best);
                    match take(put) {
                        Some(new) => *slot = new,
                        None => busy &= !(1 << s),
                    }
                }
            }
        }
    }

    /// One node of `slot`'s ray: its box test (the children it enters pushed, the nearest
    /// taken next) or its leaf's triangles, then the next node popped if needed and
    /// prefetched. True when the ray is done (its answer in `slot.best`).
    ///
    /// # Safety
    /// As for [`WideBvh::interleaved`]; `stack` holds `slot`'s pushed entries.
    #[inline(always)]
    unsafe fn step<const SIMD: bool, const ANY: bool>(&self, slot: &mut Slot, stack: &mut SlotStack) -> bool {
        let cur = slot.cur;
        let mut sp = slot.sp;
        if cur & LEAF == 0 {
            // SAFETY: inner-node codes are byte offsets of nodes, written by `convert`.
            let node = unsafe { self.node_at(cur) };
            let mut dist = [0f32; 8];
            let mask = if SIMD {
                // SAFETY: with `SIMD` the caller guarantees AVX2 and FMA.
                unsafe { box_test_avx2(node, &slot.pre, slot.t_min, slot.t_best, &mut dist) }
            } else {
                box_test_scalar(node, &slot.pre, slot.t_min, slot.t_best, &mut dist)
            };
            if mask != 0 {
                // SAFETY: at most seven entries pushed per level and the tree is at most
                // 16 levels deep, so `sp` stays within `SMALL_STACK`; the caller guarantees
                // AVX2 with `SIMD`.
                slot.cur = unsafe { push_children::<SIMD, ANY>(node, mask, &dist, stack, &mut sp) };
                slot.sp = sp;
                prefetch(self, slot.cur);
                return false;
            }
        } else {
            for b in leaf_blocks(cur) {
                // SAFETY: leaf codes are written by `convert` and index `tris`.
                let tri = unsafe { self.tris.get_unchecked(b) };
                let hit = tri4_test::<SIMD, ANY>(tri, slot.watertight.as_ref(), &slot.pre, &slot.ray, slot.t_min, slot.t_best);
                if let Some(h) = hit {
                    slot.best = Some(h);
                    if ANY {
                        return true;
                    }
                    slot.t_best = h.t;
                }
            }
        }
        // The next subtree still in front of the closest hit.
        while sp > 0 {
            sp -= 1;
            // SAFETY: entries below the old `sp` were all written by a push.
            let (c, d) = unsafe { stack.get_unchecked(sp).assume_init() };
            if ANY || d < slot.t_best {
                slot.cur = c;
                slot.sp = sp;
                prefetch(self, c);
                return false;
            }
        }
        true
    }
}

/// The children of `node` in `mask` (more than none) in the single ray's order: all but
/// the first pushed so that they pop in that order, the first returned. Any hit: the
/// first lane (the largest box) first, then lane order. Closest hit: nearest first, on a
/// tie the later lane (two children compared exactly, more by [`sort_keys`] with SIMD
/// and by an insertion sort without, as [`WideBvh::traverse`] orders them).
///
/// # Safety
/// `stack` must have room for `mask`'s children at `sp`; with `SIMD` the CPU must have AVX2.
#[inline(always)]
unsafe fn push_children<const SIMD: bool, const ANY: bool>(
    node: &Node8,
    mask: u32,
    dist: &[f32; 8],
    stack: &mut SlotStack,
    sp: &mut usize,
) -> u32 {
    let mut push = |lane: usize| {
        // SAFETY: the caller guarantees room.
        unsafe { stack.get_unchecked_mut(*sp).write((node.child[lane], dist[lane])) };
        *sp += 1;
    };
    let first = mask.trailing_zeros() as usize;
    let rest = mask & (mask - 1);
    if rest == 0 {
        return node.child[first];
    }
    if ANY {
        let mut m = rest;
        while m != 0 {
            let lane = 31 - m.leading_zeros() as usize;
            m &= !(1 << lane);
            push(lane);
        }
        return node.child[first];
    }
    if rest.is_power_of_two() {
        let second = rest.trailing_zeros() as usize;
        let (near, far) = if dist[second] <= dist[first] { (second, first) } else { (first, second) };
        push(far);
        return node.child[near];
    }
    let n = mask.count_ones() as usize;
    if SIMD {
        // SAFETY: the caller guarantees AVX2.
        let keys = unsafe { sort_keys(dist) };
        let mut next = EMPTY;
        let mut m = mask;
        while m != 0 {
            let lane = m.trailing_zeros() as usize;
            m &= m - 1;
            // SAFETY: as above.
            let rank = unsafe { nearer_count(keys, lane, mask) };
            if rank == 0 {
                next = node.child[lane];
            } else {
                // SAFETY: the caller guarantees room for all `n`; far to near from `sp`.
                unsafe { stack.get_unchecked_mut(*sp + n - 1 - rank).write((node.child[lane], dist[lane])) };
            }
        }
        *sp += n - 1;
        return next;
    }
    // Farthest first (insertion sort; the later lane after an equal one).
    let mut order = [(0f32, 0usize); 8];
    let mut count = 0;
    let mut m = mask;
    while m != 0 {
        let lane = m.trailing_zeros() as usize;
        m &= m - 1;
        let mut j = count;
        while j > 0 && order[j - 1].0 < dist[lane] {
            order[j] = order[j - 1];
            j -= 1;
        }
        order[j] = (dist[lane], lane);
        count += 1;
    }
    for &(_, lane) in &order[..n - 1] {
        push(lane);
    }
    node.child[order[n - 1].1]
}

/// Asks for the node or the leaf's first two blocks that `code` names to be brought into
/// the cache (a hint: no effect on what any load returns).
#[inline(always)]
pub(crate) fn prefetch(bvh: &WideBvh, code: u32) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let (p, bytes) = if code & LEAF == 0 {
            (bvh.nodes.as_ptr().cast::<i8>().wrapping_add(code as usize), std::mem::size_of::<Node8>())
        } else {
            let r = leaf_blocks(code);
            (bvh.tris.as_ptr().wrapping_add(r.start).cast::<i8>(), std::mem::size_of::<Tri4>() * r.len().min(2))
        };
        let mut off = 0;
        while off < bytes {
            // SAFETY: a prefetch never faults, whatever the address (SSE, part of x86-64).
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(off)) };
            off += 64;
        }
        // SAFETY: as above.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(bytes - 1)) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (bvh, code);
}
