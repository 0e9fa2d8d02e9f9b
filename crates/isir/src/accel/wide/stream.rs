//! Streams: up to sixteen rays walked down the tree together, each node's eight boxes
//! tested with AVX2 against one ray at a time (after Embree's stream mode). The rays
//! share every node fetch, every push and pop and every leaf visit, and the box tests of
//! different rays do not wait on one another, where a single ray waits on each node's
//! load before it can choose the next. Each ray keeps its own interval; a bit mask per
//! stack entry says which rays entered that subtree.
//!
//! The box and triangle tests are the single-ray kernels, so a stream's any-hit answers
//! are exactly those of [`WideBvh::occluded`], and its closest hits those of
//! [`WideBvh::intersect`]. Where two triangles meet a ray at exactly the same distance
//! (coincident triangles, an edge), the single ray reports the one it visits first, and
//! a stream visits in another order: the stream notices every such tie (its triangle
//! tests accept `t` up to and including the best so far) and traces those rays again
//! alone, so that they get the single ray's answer.

// The streams are AVX2 code: elsewhere only their ray sources are compiled.
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]

use super::kernels::*;
use super::traverse::{nearer_count, sort_keys};
use super::*;
use crate::math::ray::{lanes_of, RayLanes, RaySegment, LANES};

/// Row `i`: ray `i`'s bit in all eight lanes (one aligned load instead of a shift and a
/// broadcast).
#[repr(C, align(32))]
struct LaneBits([u32; 8]);

static RAY_BITS: [LaneBits; STREAM] = {
    let mut t = [const { LaneBits([0; 8]) }; STREAM];
    let mut i = 0;
    while i < STREAM {
        t[i] = LaneBits([1 << i; 8]);
        i += 1;
    }
    t
};

/// Rays per stream (the width of the masks): two batches of [`LANES`] lanes.
/// PERF: the conference room's shadow rays, four hits' eight light samples to a stream
/// instead of two hits': 1.628 -> 1.547 s at 16 spp (streams of sixteen as fast as before).
pub(crate) const STREAM: usize = 2 * LANES;

/// Where a stream's rays come from: ray `i` and its interval, or `None` for a ray not to
/// trace (its answer is a miss).
pub(crate) trait StreamRays {
    /// How many rays (indices `0..count`).
    fn count(&self) -> usize;
    /// Ray `i` with its `t_min` and `t_max`.
    fn get(&self, i: usize) -> Option<(Ray, f32, f32)>;
}

impl StreamRays for [RaySegment] {
    #[inline(always)]
    fn count(&self) -> usize {
        self.len()
    }

    #[inline(always)]
    fn get(&self, i: usize) -> Option<(Ray, f32, f32)> {
        let r = &self[i];
        Some((r.ray(), r.t_min, r.t_max))
    }
}

/// The lanes of a [`RayLanes`] whose bits are set in the mask.
pub(crate) struct MaskedLanes<'a>(pub(crate) &'a RayLanes, pub(crate) u32);

/// The lanes of a [`RayLanes`] whose bits are set in the mask, each up to its own `t_max`
/// (the closest hit so far in a scene of several objects) instead of the lanes' own.
pub(crate) struct LanesUpTo<'a>(pub(crate) &'a RayLanes, pub(crate) &'a [f32; LANES], pub(crate) u32);

impl StreamRays for LanesUpTo<'_> {
    #[inline(always)]
    fn count(&self) -> usize {
        (32 - self.2.leading_zeros() as usize).min(LANES)
    }

    #[inline(always)]
    fn get(&self, i: usize) -> Option<(Ray, f32, f32)> {
        (self.2 & (1 << i) != 0).then(|| (self.0.ray(i), self.0.t_min[i], self.1[i]))
    }
}

/// Two batches of lanes, each with the mask of its lanes to trace, as one stream: rays
/// `0..LANES` are the first batch's lanes, `LANES..2 * LANES` the second's.
pub(crate) struct LanePair<'a>(pub(crate) [&'a RayLanes; 2], pub(crate) [u32; 2]);

impl StreamRays for LanePair<'_> {
    #[inline(always)]
    fn count(&self) -> usize {
        let used = |m: u32| (32 - m.leading_zeros() as usize).min(LANES);
        if self.1[1] != 0 {
            LANES + used(self.1[1])
        } else {
            used(self.1[0])
        }
    }

    #[inline(always)]
    fn get(&self, i: usize) -> Option<(Ray, f32, f32)> {
        let (b, k) = (i / LANES, i % LANES);
        let rays = self.0[b];
        (self.1[b] & (1 << k) != 0).then(|| (rays.ray(k), rays.t_min[k], rays.t_max[k]))
    }
}

impl StreamRays for MaskedLanes<'_> {
    #[inline(always)]
    fn count(&self) -> usize {
        (32 - self.1.leading_zeros() as usize).min(LANES)
    }

    #[inline(always)]
    fn get(&self, i: usize) -> Option<(Ray, f32, f32)> {
        (self.1 & (1 << i) != 0).then(|| (self.0.ray(i), self.0.t_min[i], self.0.t_max[i]))
    }
}

impl WideBvh {
    /// Trace up to [`STREAM`] rays. Closest hits: `out[i]` gets ray `i`'s, `None` for
    /// invalid rays (see [`Ray::is_valid`]). With `ANY`, each ray stops at its first hit,
    /// `out` is not written (it may be empty) and the returned mask has bit `i` set when
    /// ray `i` hit.
    ///
    /// `start`, when given, is the node the walk begins with instead of the root: a node
    /// whose lanes hold every subtree of this tree the rays may enter (a shaft's cut of
    /// the tree, [`crate::accel::shaft::ShaftGrid`]), so that the rays skip the tests
    /// above it.
    ///
    /// # Safety
    /// The CPU must have what [`SimdLevel::Avx2`] names, and the tree must not be
    /// watertight (the stream has only the Möller–Trumbore block test). `start`'s lanes
    /// must hold this tree's codes (or [`EMPTY`]) with their boxes.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,lzcnt")]
    pub(crate) unsafe fn stream_avx2<const ANY: bool, R: StreamRays + ?Sized>(
        &self,
        rays: &R,
        out: &mut [Option<MeshHit>],
        start: Option<&Node8>,
    ) -> u32 {
        use std::arch::x86_64::*;
        debug_assert!(rays.count() <= STREAM && (ANY || out.len() >= rays.count()) && !self.watertight);
        let mut pre: [std::mem::MaybeUninit<RayPre>; STREAM] = [const { std::mem::MaybeUninit::uninit() }; STREAM];
        let mut t_min = [0f32; STREAM];
        let mut t_best = [0f32; STREAM];
        let mut live: u32 = 0;
        // The rays that hit, for `ANY`.
        let mut hit_rays: u32 = 0;
        // Closest hits: the rays that met two triangles at one distance, traced again alone.
        let mut tied: u32 = 0;
        // What a triangle test accepts: `t < t_lim`, `t_best` itself with `ANY`, otherwise
        // the next float up (`t <= t_best`), so that ties are seen. PERF: kept beside
        // `t_best`, not computed per test (the stream 5% slower).
        let mut t_lim = [0f32; STREAM];
        let limit = |t: f32| if ANY { t } else { t.next_up() };
        for i in 0..rays.count() {
            if !ANY {
                out[i] = None;
            }
            let Some((ray, r_min, r_max)) = rays.get(i) else { continue };
            if self.root == EMPTY || !ray.is_valid() {
                continue;
            }
            pre[i].write(RayPre::new(&ray));
            (t_min[i], t_best[i], t_lim[i]) = (r_min, r_max, limit(r_max));
            live |= 1 << i;
        }
        if live == 0 {
            // No valid ray, or an empty tree (whose root code `EMPTY` is no leaf).
            return 0;
        }
        // SAFETY: read only for rays in `live`, which were all written above.
        let pre = |i: usize| unsafe { pre.get_unchecked(i).assume_init_ref() };
        // When every ray has the octant of the first, each node's planes are loaded once.
        let first = live.trailing_zeros() as usize;
        let one_octant = lanes_of(live).all(|i| same_octant(pre(i), pre(first)));
        // Rays of one origin (a camera's, one point's shadow rays) share the part of each
        // block's test that depends on the origin, computed once per block. PERF: primary
        // streams (conference room, one thread) 14.7 -> 15.5 Mrays/s. Two hits' shadow rays
        // side by side (two origins) gain nothing: per block and origin only about three
        // rays meet, and sharing per origin made the conference room 3% slower.
        let one_origin = lanes_of(live).all(|i| same_origin(pre(i), pre(first)));
        let mut stack = [const { std::mem::MaybeUninit::<(u32, u32)>::uninit() }; STACK_SIZE];
        let mut sp = 0usize;
        // With a start node, the first node is that one (code 0 only stands for "inner").
        let mut first_node = start;
        let mut cur = if start.is_some() { 0 } else { self.root };
        let mut cur_mask = live;
        'walk: loop {
            if cur & LEAF == 0 {
                // ---- Inner node: each ray's test of the eight boxes ----
                let node = match first_node.take() {
                    Some(n) => n,
                    // SAFETY: inner-node codes are byte offsets of nodes, written by `convert`.
                    None => unsafe { self.node_at(cur) },
                };
                // Per child: the rays that enter it (bit i for ray i), and the nearest of
                // their entry distances, by which the children are ordered.
                // SAFETY: the CPU has AVX2 (this function's features).
                let (mut rays_in, mut nearest) = (_mm256_setzero_si256(), _mm256_set1_ps(f32::INFINITY));
                let mut m = cur_mask;
                let mut add = |(near, entered, missed): (__m256, __m256i, __m256)| {
                    rays_in = _mm256_or_si256(rays_in, entered);
                    if !ANY {
                        nearest = _mm256_min_ps(nearest, _mm256_blendv_ps(near, _mm256_set1_ps(f32::INFINITY), missed));
                    }
                };
                // SAFETY: `RAY_BITS` holds 32-byte aligned rows of eight `u32`s.
                let bit = |i: usize| unsafe { _mm256_load_si256(RAY_BITS[i].0.as_ptr().cast()) };
                if one_octant {
                    // The node's planes loaded once for all the rays.
                    // SAFETY: AVX2 and FMA are enabled here; `pre(first)` comes from
                    // `RayPre::new`, and every ray shares its octant.
                    let planes = unsafe { node_planes_avx2(node, pre(first)) };
                    while m != 0 {
                        let i = m.trailing_zeros() as usize;
                        m &= m - 1;
                        // SAFETY: as above.
                        add(unsafe { box_planes_stream_avx2(&planes, pre(i), t_min[i], t_best[i], bit(i)) });
                    }
                } else {
                    while m != 0 {
                        let i = m.trailing_zeros() as usize;
                        m &= m - 1;
                        // SAFETY: AVX2 and FMA are enabled here; `pre(i)` comes from
                        // `RayPre::new`.
                        add(unsafe { box_lanes_stream_avx2(node, pre(i), t_min[i], t_best[i], bit(i)) });
                    }
                }
                // The children some ray entered (bit 31 is a ray too: not a signed compare).
                let entered = _mm256_cmpeq_epi32(rays_in, _mm256_setzero_si256());
                let children = !(_mm256_movemask_ps(_mm256_castsi256_ps(entered)) as u32) & 0xff;
                // No child entered: on to the pop.
                if children != 0 {
                    let mut masks = [0u32; 8];
                    // SAFETY: eight `u32`s.
                    unsafe { _mm256_storeu_si256(masks.as_mut_ptr().cast(), rays_in) };
                    if children.is_power_of_two() {
                        let lane = children.trailing_zeros() as usize;
                        cur = node.child[lane];
                        cur_mask = masks[lane];
                        continue;
                    }
                    let n = children.count_ones() as usize;
                    debug_assert!(sp + n <= STACK_SIZE);
                    if ANY {
                        // Any hit will do: the largest box first, the others in lane order.
                        let mut c = children & (children - 1);
                        while c != 0 {
                            let lane = 31 - c.leading_zeros() as usize;
                            c &= !(1 << lane);
                            // SAFETY: sp + n <= STACK_SIZE: at most eight entries per level
                            // and `from_bvh` checks the depth.
                            unsafe { stack.get_unchecked_mut(sp).write((node.child[lane], masks[lane])) };
                            sp += 1;
                        }
                        let lane = children.trailing_zeros() as usize;
                        cur = node.child[lane];
                        cur_mask = masks[lane];
                        continue;
                    }
                    let mut dist = [0f32; 8];
                    // SAFETY: eight floats.
                    unsafe { _mm256_storeu_ps(dist.as_mut_ptr(), nearest) };
                    // SAFETY: the CPU has AVX2.
                    let keys = unsafe { sort_keys(&dist) };
                    let mut c = children;
                    while c != 0 {
                        let lane = c.trailing_zeros() as usize;
                        c &= c - 1;
                        // SAFETY: as above.
                        let rank = unsafe { nearer_count(keys, lane, children) };
                        if rank == 0 {
                            cur = node.child[lane];
                            cur_mask = masks[lane];
                        } else {
                            // SAFETY: as for the pushes above; far to near from `sp`.
                            unsafe { stack.get_unchecked_mut(sp + n - 1 - rank).write((node.child[lane], masks[lane])) };
                        }
                    }
                    sp += n - 1;
                    continue;
                }
            } else {
                // ---- Leaf: each block against each ray that reached it ----
                debug_assert!(cur != EMPTY);
                for b in leaf_blocks(cur) {
                    // SAFETY: leaf codes are written by `convert` and index `tris`.
                    let tri = unsafe { self.tris.get_unchecked(b) };
                    let mut m = cur_mask;
                    // SAFETY: the CPU has AVX2 (this function's features).
                    let part = (one_origin && m & (m - 1) != 0).then(|| unsafe { origin_part_avx2(tri, pre(first).origin_avx()) });
                    while m != 0 {
                        let i = m.trailing_zeros() as usize;
                        m &= m - 1;
                        if m == 0 {
                            // The last ray alone.
                            if let Some(h) = tri4_sse::<ANY>(tri, pre(i), t_min[i], t_lim[i]) {
                                if !ANY {
                                    if h.t < t_best[i] {
                                        t_best[i] = h.t;
                                        t_lim[i] = limit(h.t);
                                        out[i] = Some(h);
                                    } else if out[i].is_some() {
                                        tied |= 1 << i;
                                    }
                                }
                                if ANY {
                                    hit_rays |= 1 << i;
                                    live &= !(1 << i);
                                    cur_mask &= !(1 << i);
                                }
                            }
                            break;
                        }
                        // Two rays at once, one per half of the AVX registers.
                        let j = m.trailing_zeros() as usize;
                        m &= m - 1;
                        // SAFETY: the CPU has AVX2 (this function's features).
                        let (hits, tuv) = unsafe {
                            match &part {
                                Some(part) => tri4x2_from_avx2(tri, part, pre(i), pre(j), [t_min[i], t_min[j]], [t_lim[i], t_lim[j]]),
                                None => tri4x2_avx2(tri, pre(i), pre(j), [t_min[i], t_min[j]], [t_lim[i], t_lim[j]]),
                            }
                        };
                        if hits == 0 {
                            continue;
                        }
                        if ANY {
                            let both = u32::from(hits & 0xf != 0) << i | u32::from(hits >> 4 != 0) << j;
                            hit_rays |= both;
                            live &= !both;
                            cur_mask &= !both;
                            continue;
                        }
                        let mut lanes = [[0f32; 8]; 3];
                        for (l, x) in lanes.iter_mut().zip(tuv) {
                            // SAFETY: eight floats.
                            unsafe { _mm256_storeu_ps(l.as_mut_ptr(), x) };
                        }
                        for (ray, half) in [(i, 0), (j, 4)] {
                            let hits = hits >> half & 0xf;
                            if hits != 0 {
                                let lane = pick_lane::<ANY>(hits, &lanes[0][half..half + 4]);
                                let h = MeshHit {
                                    t: lanes[0][half + lane],
                                    prim: tri.prim[lane],
                                    u: lanes[1][half + lane],
                                    v: lanes[2][half + lane],
                                };
                                if h.t < t_best[ray] {
                                    t_best[ray] = h.t;
                                    t_lim[ray] = limit(h.t);
                                    out[ray] = Some(h);
                                } else if out[ray].is_some() {
                                    tied |= 1 << ray;
                                }
                            }
                        }
                    }
                    if ANY && cur_mask == 0 {
                        if live == 0 {
                            break 'walk;
                        }
                        break;
                    }
                }
            }
            // ---- Pop the next subtree some live ray entered ----
            loop {
                if sp == 0 {
                    break 'walk;
                }
                sp -= 1;
                // SAFETY: entries below the old `sp` were all written by a push.
                let (c, m) = unsafe { stack.get_unchecked(sp).assume_init() };
                let m = if ANY { m & live } else { m };
                if m != 0 {
                    cur = c;
                    cur_mask = m;
                    break;
                }
            }
        }
        if !ANY && tied != 0 {
            // SAFETY: this function's own requirements.
            unsafe { self.retrace(rays, tied, out) };
        }
        hit_rays
    }

    /// The rays `tied` of a stream (valid rays) traced again alone: where two triangles
    /// meet a ray at one distance, the single ray's answer depends on its own visiting
    /// order. Rare, so cold and out of line; the stream runs only at the AVX2 level, so
    /// this calls the AVX2 traversal directly.
    ///
    /// # Safety
    /// As for [`WideBvh::stream_avx2`].
    #[cfg(target_arch = "x86_64")]
    #[cold]
    #[inline(never)]
    unsafe fn retrace<R: StreamRays + ?Sized>(&self, rays: &R, tied: u32, out: &mut [Option<MeshHit>]) {
        let mut m = tied;
        while m != 0 {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            if let Some((ray, r_min, r_max)) = rays.get(i) {
                // SAFETY: the caller guarantees AVX2; the stream traced only valid rays of
                // a non-empty tree, as `dispatch` requires.
                out[i] = unsafe { self.traverse_avx2::<false, false>(&ray, r_min, r_max, &mut TraversalStats::default()) };
            }
        }
    }
}
