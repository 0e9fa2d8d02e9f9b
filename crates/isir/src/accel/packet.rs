//! Packets: sixteen coherent rays traced together through the [`WideBvh`] with AVX-512,
//! one lane per ray (Wald et al.'s packet traversal, on eight-wide nodes as in Embree's
//! stream mode). Each node's boxes and each triangle are fetched once for the sixteen.
//! A packet whose rays leave from one point (a camera's) first tests a node's eight boxes
//! against its frustum (Reshetov et al.'s multi-level ray tracing culls the same way), so
//! that a child no ray can enter costs one test for the packet instead of one per ray.
//!
//! Used for the closest hits of coherent rays: those given as a slice
//! ([`WideBvh::intersect_packet`], the ray files' packets) and the renderer's lanes of at
//! least [`PACKET_LANES_FROM`] rays ([`WideBvh::intersect_lanes`]: a pixel's camera samples).
//! Rays whose direction signs differ within the packet or a watertight BVH fall back to
//! the AVX2 stream (`accel/wide/stream.rs`), as do all rays on a CPU with AVX2 but not
//! AVX-512; without AVX2, one ray at a time. Möller–Trumbore is computed operation for
//! operation as in [`crate::accel::triangle::moller_trumbore`], so packets return the
//! hits of single rays, except where a ray meets two triangles at exactly its closest
//! distance: the renderer's lanes then trace it again alone (the single ray's triangle,
//! so the same images), a ray file's packets report either.
//!
//! Any-hit queries take the AVX2 stream on AVX-512 CPUs too. PERF, on the AVX-512 machine
//! (Xeon, 2 cores), 16 spp: the
//! conference room's shadow rays as 32-ray streams instead of sixteen-ray packets per
//! octant, 2.11 -> 1.39 s; tp4-bunny 0.211 -> 0.191 s, the same images. Primary rays from
//! a ray file stay packets there: 41 Mrays/s against the streams' 29.

#[cfg(target_arch = "x86_64")]
use crate::accel::wide::stream::{LanePair, LanesUpTo, MaskedLanes};
use crate::accel::wide::{Cut, SimdLevel, WideBvh, SMALL_STACK};
use crate::accel::MeshHit;
use crate::math::ray::{lanes_of, RayLanes, RaySegment, LANES};
use glam::Vec3;

/// Rays per packet.
pub const PACKET: usize = 16;

/// An AVX-512 packet's leaf that at most this many of its rays reach is tested ray by ray.
const LEAF_ALONE: u32 = 6;

/// The renderer's lanes of closest-hit rays go as an AVX-512 packet from this many rays
/// (fewer take the AVX2 stream).
/// PERF: a pixel's sixteen camera samples as a packet instead of a stream, 2 cores: the
/// conference room 0.977 of the CPU time at 16 spp, tp4-bunny 0.975 at 64 spp (9 paired
/// runs each; the same images); the path tracer's bounces (mostly of several octants,
/// which fall back to the stream) 1.000 and 1.002.
pub const PACKET_LANES_FROM: u32 = 8;

impl WideBvh {
    /// Closest hits of up to [`PACKET`] rays (`out[i]` for `rays[i]`): those of
    /// [`WideBvh::intersect`], except that where two triangles meet a ray at exactly the
    /// same distance an AVX-512 packet may report the other one (AVX2 streams, single rays
    /// and [`WideBvh::intersect_lanes`] report the same one).
    /// PERF: the renderer's exact ties (`EXACT`) here made these packets 3-4% slower
    /// (`isir trace --packets`, the conference room's primary rays, one thread).
    ///
    /// # Panics
    /// If `rays` holds more than [`PACKET`] rays or `out` is shorter than `rays`.
    pub fn intersect_packet(&self, rays: &[RaySegment], out: &mut [Option<MeshHit>]) {
        assert!(rays.len() <= PACKET && out.len() >= rays.len());
        #[cfg(target_arch = "x86_64")]
        if self.packet_closest(rays, out) {
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if self.level() >= SimdLevel::Avx2 && !self.watertight {
            // SAFETY: the level is only ever Avx2 or Avx512 when the CPU reported AVX2; not watertight.
            unsafe { self.stream_avx2::<false, _>(rays, out, None) };
            return;
        }
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = self.intersect(&r.ray(), r.t_min, r.t_max);
        }
    }

    /// The closest hits of `rays` (at most [`PACKET`]) as an AVX-512 packet, where this
    /// tree and CPU take one and the rays share an octant: false (nothing written)
    /// otherwise. Ties are not checked (see [`WideBvh::intersect_packet`]).
    #[cfg(target_arch = "x86_64")]
    fn packet_closest(&self, rays: &[RaySegment], out: &mut [Option<MeshHit>]) -> bool {
        if self.takes_packets() {
            // PERF: the small stack where the tree fits it (nearly every tree): the full
            // one's frame is probed page by page (a store per 4 KB) at every call, one call
            // per packet: the conference room's primary packets 9% slower (23.5 -> 25.7
            // Mrays/s, one thread), the dragon's 10%.
            // SAFETY: the level is only ever Avx512 when the CPU reported AVX-512, and each
            // stack holds the `7 · depth + 8` entries of this tree (`from_bvh` checked it
            // against `STACK_SIZE`).
            return if self.fits_small_stack() {
                unsafe { self.packet_avx512::<SMALL_STACK, false>(rays, out) }
            } else {
                unsafe { self.packet_avx512::<{ crate::accel::wide::STACK_SIZE }, false>(rays, out) }
            };
        }
        false
    }

    /// Whether this tree takes AVX-512 packets: the CPU has AVX-512 (the tree's level), and
    /// the tree is neither watertight (the packets have only Möller–Trumbore) nor empty.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn takes_packets(&self) -> bool {
        self.level() == SimdLevel::Avx512 && !self.watertight && self.root != crate::accel::wide::EMPTY
    }

    /// Which of up to [`PACKET`] rays meet a triangle in their interval: bit `i` set when
    /// `rays[i]` is occluded, the answer [`WideBvh::occluded`] gives it. For the shadow
    /// rays of one point towards an area light: traced together in an AVX2 stream (on
    /// AVX-512 CPUs too), each ray retired at its first hit.
    ///
    /// # Panics
    /// If `rays` holds more than [`PACKET`] rays.
    #[must_use]
    pub fn occluded_packet(&self, rays: &[RaySegment]) -> u32 {
        assert!(rays.len() <= PACKET);
        let single = |r: &RaySegment| self.occluded(&r.ray(), r.t_min, r.t_max);
        #[cfg(target_arch = "x86_64")]
        if self.level() >= SimdLevel::Avx2 && !self.watertight && rays.len() > 1 {
            // PERF: a stream of eight shadow rays of one point (conference room, 8 light
            // samples): 0.77x the render time of single rays.
            // SAFETY: the level is only ever Avx2 or Avx512 when the CPU reported AVX2; not watertight.
            return unsafe { self.stream_avx2::<true, _>(rays, &mut [], None) };
        }
        rays.iter().enumerate().fold(0, |m, (i, r)| m | u32::from(single(r)) << i)
    }

    /// [`WideBvh::intersect`] for the lanes `mask` of `rays`, each up to its own `t_max[k]`
    /// instead of the lanes' (the closest hit so far in a scene of several objects):
    /// `out[k]` for lane `k`, `None` outside `mask`. The same answers as one `intersect`
    /// per lane: from [`PACKET_LANES_FROM`] lanes an AVX-512 packet where the CPU has it
    /// and the rays share an octant, otherwise an AVX2 stream reading the rays from their
    /// lanes.
    pub fn intersect_lanes(&self, rays: &RayLanes, t_max: &[f32; LANES], mask: u32, out: &mut [Option<MeshHit>; LANES]) {
        const { assert!(LANES == PACKET) };
        let mask = mask & (u32::MAX >> (32 - LANES));
        #[cfg(target_arch = "x86_64")]
        if self.takes_packets() && mask.count_ones() >= PACKET_LANES_FROM {
            // SAFETY: the level is only ever Avx512 when the CPU reported AVX-512, and each
            // stack holds the `7 · depth + 8` entries of this tree (`from_bvh` checked it
            // against `STACK_SIZE`).
            let done = if self.fits_small_stack() {
                unsafe { self.packet_lanes_avx512::<SMALL_STACK>(rays, t_max, mask, out) }
            } else {
                unsafe { self.packet_lanes_avx512::<{ crate::accel::wide::STACK_SIZE }>(rays, t_max, mask, out) }
            };
            if done {
                return;
            }
        }
        #[cfg(target_arch = "x86_64")]
        if self.level() >= SimdLevel::Avx2 && !self.watertight && mask.count_ones() > 1 {
            out.fill(None);
            // SAFETY: the level is only ever Avx2 or Avx512 when the CPU reported AVX2; not watertight.
            unsafe { self.stream_avx2::<false, _>(&LanesUpTo(rays, t_max, mask), out, None) };
            return;
        }
        for (k, o) in out.iter_mut().enumerate() {
            *o = if mask & (1 << k) != 0 { self.intersect(&rays.ray(k), rays.t_min[k], t_max[k]) } else { None };
        }
    }

    /// [`WideBvh::occluded_packet`] for the lanes `mask` of `rays`: bit `k` set when lane
    /// `k` is in `mask` and its ray is occluded. An AVX2 stream reads the rays from their
    /// lanes; otherwise they are gathered into a packet.
    #[must_use]
    pub fn occluded_lanes(&self, rays: &RayLanes, mask: u32) -> u32 {
        let mask = mask & (u32::MAX >> (32 - LANES));
        #[cfg(target_arch = "x86_64")]
        if self.level() >= SimdLevel::Avx2 && !self.watertight && mask.count_ones() > 1 {
            // SAFETY: the level is only ever Avx2 or Avx512 when the CPU reported AVX2; not watertight.
            return unsafe { self.stream_avx2::<true, _>(&MaskedLanes(rays, mask), &mut [], None) };
        }
        let mut group = [RaySegment { origin: Vec3::ZERO, t_min: 0.0, direction: Vec3::ZERO, t_max: 0.0 }; PACKET];
        let mut index = [0usize; PACKET];
        let mut n = 0;
        for k in lanes_of(mask) {
            (group[n], index[n]) = (rays.segment(k), k);
            n += 1;
        }
        lanes_of(self.occluded_packet(&group[..n])).fold(0, |m, g| m | 1 << index[g])
    }

    /// [`WideBvh::occluded_lanes`] for two batches at once, `[first's, second's]`: on
    /// AVX2, their rays as one stream of up to 32 (the nodes fetched and tested once for
    /// all of them); otherwise batch by batch.
    #[must_use]
    pub fn occluded_lane_pair(&self, rays: [&RayLanes; 2], mask: [u32; 2]) -> [u32; 2] {
        self.occluded_lane_pair_from(None, rays, mask)
    }

    /// [`WideBvh::occluded_lane_pair`], the stream starting at `start` instead of the root
    /// when given and cut from this tree: the same answers for rays that enter no node
    /// outside the cut's subtrees (a shaft's rays, [`crate::accel::shaft::Cell::Entry`]).
    /// (From the root where there is no stream.)
    #[must_use]
    pub(crate) fn occluded_lane_pair_from(&self, start: Option<&Cut>, rays: [&RayLanes; 2], mask: [u32; 2]) -> [u32; 2] {
        let mask = mask.map(|m| m & (u32::MAX >> (32 - LANES)));
        #[cfg(target_arch = "x86_64")]
        if self.level() >= SimdLevel::Avx2 && !self.watertight && (mask[0].count_ones() + mask[1].count_ones()) > 1 {
            let start = start.and_then(|c| c.node_in(self));
            // SAFETY: the level is only ever Avx2 or Avx512 when the CPU reported AVX2; not
            // watertight; `start` is a cut of this tree (`node_in`).
            let hit = unsafe { self.stream_avx2::<true, _>(&LanePair(rays, mask), &mut [], start) };
            return [hit & (u32::MAX >> (32 - LANES)), hit >> LANES];
        }
        [self.occluded_lanes(rays[0], mask[0]), self.occluded_lanes(rays[1], mask[1])]
    }

    /// The AVX-512 packet traversal of closest hits; false (nothing written) when the rays'
    /// direction signs differ, which the octant-ordered box test cannot handle. With
    /// `EXACT`, ties are seen and traced again alone (see below).
    ///
    /// # Safety
    /// The CPU must have AVX-512 (F, VL, DQ, BW), and `STACK` must be at least
    /// the tree's [`WideBvh::stack_entries`] (at most seven pushes per level).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma")]
    unsafe fn packet_avx512<const STACK: usize, const EXACT: bool>(&self, rays: &[RaySegment], out: &mut [Option<MeshHit>]) -> bool {
        // ---- Load the packet as structure of arrays ----
        let mut a = [[0f32; PACKET]; 11];
        let Some((active, neg)) = packet_rows(rays, &mut a) else { return false };
        out[..rays.len()].fill(None);
        if let Some(neg) = neg {
            // SAFETY: the caller's guarantees.
            unsafe { self.packet_rows_avx512::<STACK, EXACT>(&a, active, neg, out) };
        }
        true
    }

    /// [`WideBvh::packet_avx512`] of the lanes `mask` of `rays`, each up to its own
    /// `t_max[k]`, with `EXACT` ties (the renderer's lanes): their rows made from the lanes
    /// directly. False (nothing written) when their octants differ.
    ///
    /// # Safety
    /// As for [`WideBvh::packet_avx512`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma")]
    unsafe fn packet_lanes_avx512<const STACK: usize>(
        &self,
        rays: &RayLanes,
        t_max: &[f32; LANES],
        mask: u32,
        out: &mut [Option<MeshHit>; LANES],
    ) -> bool {
        let mut a = [[0f32; PACKET]; 11];
        let Some((active, neg)) = lane_rows_avx512(rays, t_max, mask, &mut a) else { return false };
        out.fill(None);
        if let Some(neg) = neg {
            // SAFETY: the caller's guarantees.
            unsafe { self.packet_rows_avx512::<STACK, true>(&a, active, neg, out) };
        }
        true
    }

    /// The packet traversal of the rays `active` of rows `a` (see [`packet_rows`]), all of
    /// the octant `neg`: each active ray's closest hit written to `out[i]` (which the caller
    /// cleared).
    ///
    /// # Safety
    /// As for [`WideBvh::packet_avx512`]; `out` holds a slot for every active ray.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma")]
    unsafe fn packet_rows_avx512<const STACK: usize, const EXACT: bool>(
        &self,
        a: &Rows,
        active: u16,
        neg: [bool; 3],
        out: &mut [Option<MeshHit>],
    ) {
        use crate::accel::wide::{leaf_blocks, EMPTY, LEAF};
        use std::arch::x86_64::*;
        // SAFETY: AVX-512 is enabled for this function (the caller checked the CPU) and the
        // unaligned loads read arrays of exactly 16 floats.
        let ld = |x: &[f32; PACKET]| _mm512_loadu_ps(x.as_ptr());
        let (ox, oy, oz) = (ld(&a[0]), ld(&a[1]), ld(&a[2]));
        let (dx, dy, dz) = (ld(&a[3]), ld(&a[4]), ld(&a[5]));
        // SAFETY: AVX-512 is enabled for this function.
        let slabs = unsafe { Slabs::of(a) };
        let t_min = ld(&a[9]);
        let mut t_best = ld(&a[10]);
        let mut prim = _mm512_set1_epi32(-1);
        let mut hu = _mm512_setzero_ps();
        let mut hv = _mm512_setzero_ps();
        // With `EXACT`: the rays with a hit so far, and those that met a second triangle at
        // exactly their closest distance: traced again alone at the end, so that each reports the
        // triangle its single ray visits first (the packet visits in another order). For
        // that the triangle tests accept `t` up to and including the closest so far, and a
        // popped node is kept while its entry is no farther than that (the box tests widen
        // entries down, so one at exactly that distance is rare; kept all the same).
        let mut has: u16 = 0;
        let mut tied: u16 = 0;
        let nonneg_tmin = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(active, t_min, _mm512_setzero_ps()) == 0;
        // SAFETY: AVX-512 is enabled for this function.
        let frustum = unsafe { Frustum::of(a, active) };

        // The stack keeps, per entry, the node, the rays that entered its box and their
        // entry distances, to cull rays whose closest hit has moved in front since.
        let mut codes = [0u32; STACK];
        let mut masks = [0u16; STACK];
        let mut nears = [const { std::mem::MaybeUninit::<__m512>::uninit() }; STACK];
        let mut sp = 0usize;
        let mut cur = self.root;
        let mut cur_mask = active;
        'walk: loop {
            if cur & LEAF == 0 {
                // ---- Inner node: eight boxes, each against sixteen rays ----
                // SAFETY: inner-node codes are written by `convert`.
                let node = self.node_at(cur);
                // The hit children's entry distances (of their first ray) and lanes, sorted;
                // each child's rays and entry distances kept by lane. PERF: sorting whole
                // (distance, code, mask, 512-bit distances) items, the array's zeroing alone
                // (1 KB of stores per node) took 14% of the packets' time.
                let mut order = [(0f32, 0usize); 8];
                let mut lane_masks = [0u16; 8];
                let mut lane_nears = [const { std::mem::MaybeUninit::<__m512>::uninit() }; 8];
                let mut n = 0;
                // PERF: the children no ray can enter, culled for the whole packet first
                // (one test of the eight boxes): the conference room's camera rays 1.08
                // (the TP4 camera) to 1.17 (under the table) times as fast, one thread,
                // medians of 7; the Stanford dragon's 1.03.
                let mut kept = match &frustum {
                    // SAFETY: this function is compiled for AVX-512, AVX2 and FMA, and runs
                    // only where the CPU has them (`SimdLevel::Avx512`).
                    Some(f) => unsafe { f.children(node, neg) },
                    None => 0xff,
                };
                while kept != 0 {
                    let c = kept.trailing_zeros() as usize;
                    kept &= kept - 1;
                    let code = node.child[c];
                    if code == EMPTY {
                        continue;
                    }
                    // SAFETY: AVX-512 is enabled for this function.
                    let (m, near) = unsafe { slabs.enter(node, c, neg, t_min, t_best, nonneg_tmin, cur_mask) };
                    if m == 0 {
                        continue;
                    }
                    // Order by the entry distance of the first ray that enters.
                    let first = _mm512_cvtss_f32(_mm512_maskz_compress_ps(m, near));
                    lane_masks[c] = m;
                    lane_nears[c].write(near);
                    let item = (first, c);
                    let mut j = n;
                    while j > 0 && order[j - 1].0 < item.0 {
                        order[j] = order[j - 1];
                        j -= 1;
                    }
                    order[j] = item;
                    n += 1;
                }
                if n > 0 {
                    for &(_, c) in &order[..n - 1] {
                        // SAFETY: sp < STACK: at most seven pushes per level, and the caller
                        // guarantees `7 · depth + 8 <= STACK`; lane `c` was hit, so its
                        // entry distances were written above.
                        debug_assert!(sp < STACK);
                        *codes.get_unchecked_mut(sp) = node.child[c];
                        // PERF: the pushed child asked for now, so that it is in the cache
                        // when popped (a hint; one thread, best of 3-5, three runs each): the
                        // 10M-triangle mesh's primary packets 14.8 -> 16.1 Mrays/s, the
                        // Stanford dragon's 30.4 -> 32.3, the conference room's 1.004.
                        crate::accel::wide::prefetch(self, node.child[c]);
                        *masks.get_unchecked_mut(sp) = lane_masks[c];
                        nears.get_unchecked_mut(sp).write(lane_nears[c].assume_init());
                        sp += 1;
                    }
                    let c = order[n - 1].1;
                    cur = node.child[c];
                    cur_mask = lane_masks[c];
                    continue;
                }
            } else {
                // ---- Leaf: each triangle against the rays that reached it ----
                // (Empty lanes are skipped when children are pushed.)
                debug_assert!(cur != EMPTY);
                // PERF: a leaf that few of the rays reach is tested ray by ray, four
                // triangles at a time (the single rays' SSE test, the same floats), rather
                // than triangle by triangle against sixteen lanes mostly idle: primary
                // packets +4.5% from at most three to eight rays (six kept), slower from ten.
                if cur_mask.count_ones() <= LEAF_ALONE {
                    let mut ts = [0f32; PACKET];
                    _mm512_storeu_ps(ts.as_mut_ptr(), t_best);
                    let mut m = cur_mask;
                    while m != 0 {
                        let i = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let r = row_segment(a, i);
                        // With `EXACT`, up to and including the closest so far: a tie is seen.
                        let limit = if EXACT { ts[i].next_up() } else { ts[i] };
                        if let Some(h) = self.leaf_closest_sse(cur, &r.ray(), r.t_min, limit) {
                            let lane = 1u16 << i;
                            if EXACT {
                                if h.t >= ts[i] {
                                    tied |= lane & has;
                                    continue;
                                }
                                has |= lane;
                            }
                            t_best = _mm512_mask_mov_ps(t_best, lane, _mm512_set1_ps(h.t));
                            hu = _mm512_mask_mov_ps(hu, lane, _mm512_set1_ps(h.u));
                            hv = _mm512_mask_mov_ps(hv, lane, _mm512_set1_ps(h.v));
                            prim = _mm512_mask_mov_epi32(prim, lane, _mm512_set1_epi32(h.prim as i32));
                        }
                    }
                } else {
                    for b in leaf_blocks(cur) {
                        // SAFETY: leaf codes index `tris` (`Collapse::convert` wrote them).
                        let tri = self.tris.get_unchecked(b);
                        for lane in 0..4 {
                            let id = tri.prim[lane];
                            if id == EMPTY {
                                break;
                            }
                            let s = |x: &[[f32; 4]; 3], k: usize| _mm512_set1_ps(x[k][lane]);
                            let (e1x, e1y, e1z) = (s(&tri.e1, 0), s(&tri.e1, 1), s(&tri.e1, 2));
                            let (e2x, e2y, e2z) = (s(&tri.e2, 0), s(&tri.e2, 1), s(&tri.e2, 2));
                            let mul = |x, y| _mm512_mul_ps(x, y);
                            let sub = |x, y| _mm512_sub_ps(x, y);
                            let add = |x, y| _mm512_add_ps(x, y);
                            // p = d × e2
                            let px = sub(mul(dy, e2z), mul(dz, e2y));
                            let py = sub(mul(dz, e2x), mul(dx, e2z));
                            let pz = sub(mul(dx, e2y), mul(dy, e2x));
                            let det = add(add(mul(e1x, px), mul(e1y, py)), mul(e1z, pz));
                            // s = o - v0
                            let sx = sub(ox, s(&tri.v0, 0));
                            let sy = sub(oy, s(&tri.v0, 1));
                            let sz = sub(oz, s(&tri.v0, 2));
                            let u_raw = add(add(mul(sx, px), mul(sy, py)), mul(sz, pz));
                            // q = s × e1
                            let qx = sub(mul(sy, e1z), mul(sz, e1y));
                            let qy = sub(mul(sz, e1x), mul(sx, e1z));
                            let qz = sub(mul(sx, e1y), mul(sy, e1x));
                            let v_raw = add(add(mul(dx, qx), mul(dy, qy)), mul(dz, qz));
                            // PERF: a 512-bit division costs ~16 cycles; skip it when no ray can
                            // pass. The filter is implied by the exact test below (signs folded
                            // with det's, margins of 2^-20·|det| far above the rounding and
                            // underflow of `x / det`), so no hit is lost and results stay those
                            // of `moller_trumbore`.
                            let abs_det = _mm512_abs_ps(det);
                            let sign = _mm512_and_si512(_mm512_castps_si512(det), _mm512_set1_epi32(i32::MIN));
                            let fold = |x: __m512| _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(x), sign));
                            let margin = mul(abs_det, _mm512_set1_ps(1.0 / 1_048_576.0));
                            let neg_margin = _mm512_sub_ps(_mm512_setzero_ps(), margin);
                            let (fu, fv) = (fold(u_raw), fold(v_raw));
                            let mut pre = _mm512_mask_cmp_ps_mask::<_CMP_GE_OQ>(cur_mask, fu, neg_margin);
                            pre = _mm512_mask_cmp_ps_mask::<_CMP_GE_OQ>(pre, fv, neg_margin);
                            pre = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(pre, add(fu, fv), add(abs_det, margin));
                            if pre == 0 {
                                continue;
                            }
                            let inv_det = _mm512_div_ps(_mm512_set1_ps(1.0), det);
                            let u = mul(u_raw, inv_det);
                            let v = mul(v_raw, inv_det);
                            let t = mul(add(add(mul(e2x, qx), mul(e2y, qy)), mul(e2z, qz)), inv_det);
                            let zero = _mm512_setzero_ps();
                            let one = _mm512_set1_ps(1.0);
                            let mut m = _mm512_mask_cmp_ps_mask::<_CMP_NEQ_OQ>(pre, det, zero);
                            m = _mm512_mask_cmp_ps_mask::<_CMP_GE_OQ>(m, u, zero);
                            m = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(m, u, one);
                            m = _mm512_mask_cmp_ps_mask::<_CMP_GE_OQ>(m, v, zero);
                            m = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(m, add(u, v), one);
                            m = _mm512_mask_cmp_ps_mask::<_CMP_GE_OQ>(m, t, t_min);
                            if EXACT {
                                let within = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(m, t, t_best);
                                m = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(within, t, t_best);
                                tied |= within & !m & has;
                                has |= m;
                            } else {
                                m = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(m, t, t_best);
                            }
                            if m != 0 {
                                t_best = _mm512_mask_mov_ps(t_best, m, t);
                                hu = _mm512_mask_mov_ps(hu, m, u);
                                hv = _mm512_mask_mov_ps(hv, m, v);
                                prim = _mm512_mask_mov_epi32(prim, m, _mm512_set1_epi32(id as i32));
                            }
                        }
                    }
                }
            }
            // ---- Pop a node some of whose rays still enter by their closest hit ----
            loop {
                if sp == 0 {
                    break 'walk;
                }
                sp -= 1;
                // SAFETY: every entry below the old `sp` was written by a push.
                let near = nears.get_unchecked(sp).assume_init();
                let m = if EXACT {
                    _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(*masks.get_unchecked(sp), near, t_best)
                } else {
                    _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(*masks.get_unchecked(sp), near, t_best)
                };
                if m != 0 {
                    cur = *codes.get_unchecked(sp);
                    cur_mask = m;
                    break;
                }
            }
        }
        let (mut ts, mut us, mut vs, mut ps) = ([0f32; PACKET], [0f32; PACKET], [0f32; PACKET], [0u32; PACKET]);
        _mm512_storeu_ps(ts.as_mut_ptr(), t_best);
        _mm512_storeu_ps(us.as_mut_ptr(), hu);
        _mm512_storeu_ps(vs.as_mut_ptr(), hv);
        _mm512_storeu_si512(ps.as_mut_ptr().cast(), prim);
        for i in lanes_of(u32::from(active)) {
            if ps[i] != EMPTY {
                out[i] = Some(MeshHit { t: ts[i], prim: ps[i], u: us[i], v: vs[i] });
            }
        }
        if EXACT && tied != 0 {
            self.retrace_packet(a, tied, out);
        }
    }
}

impl WideBvh {
    /// The rays `tied` of an `EXACT` packet (those that met two triangles at exactly
    /// their closest distance) traced again alone, so that each gets the single ray's
    /// triangle. Rare, so cold and out of line.
    #[cfg(target_arch = "x86_64")]
    #[cold]
    #[inline(never)]
    fn retrace_packet(&self, a: &Rows, tied: u16, out: &mut [Option<MeshHit>]) {
        for i in lanes_of(u32::from(tied)) {
            let r = row_segment(a, i);
            out[i] = self.intersect(&r.ray(), r.t_min, r.t_max);
        }
    }
}

/// Ray `i` of a packet's rows, as it was given.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn row_segment(a: &Rows, i: usize) -> RaySegment {
    RaySegment {
        origin: Vec3::new(a[0][i], a[1][i], a[2][i]),
        t_min: a[9][i],
        direction: Vec3::new(a[3][i], a[4][i], a[5][i]),
        t_max: a[10][i],
    }
}

/// [`packet_rows`] of the lanes `mask` of `rays`, lane `k` up to `t_max[k]`.
/// (The reference of [`lane_rows_avx512`], which the renderer's packets use.)
#[cfg(all(target_arch = "x86_64", test))]
#[inline(always)]
fn lane_rows(rays: &RayLanes, t_max: &[f32; LANES], mask: u32, a: &mut Rows) -> Option<(u16, Option<[bool; 3]>)> {
    let lanes = lanes_of(mask & (u32::MAX >> (32 - LANES)));
    rows_of(lanes.map(|k| (k, RaySegment { t_max: t_max[k], ..rays.segment(k) })), a)
}

/// `lane_rows` (the tests' reference) sixteen lanes at a time, the same floats and
/// answers (each inverse one IEEE division, as `slab_inverse`'s), where the CPU has
/// AVX-512. The rows of lanes not in `mask` or of invalid rays are zero (`lane_rows`
/// leaves them as they were: zero in every caller's rows).
/// PERF: ray by ray, the 48 scalar divisions and the 176 single-float stores (read back
/// as 512-bit rows right after) were about a sixth of the renderer's packets' time.
/// Compiled for AVX-512 (F, VL, DQ, BW): called from code compiled so.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw")]
#[inline]
fn lane_rows_avx512(rays: &RayLanes, t_max: &[f32; LANES], mask: u32, a: &mut Rows) -> Option<(u16, Option<[bool; 3]>)> {
    use std::arch::x86_64::*;
    const { assert!(LANES == PACKET) };
    // SAFETY: AVX-512 F is enabled here; each load reads an array of sixteen floats.
    let ld = |x: &[f32; LANES]| unsafe { _mm512_loadu_ps(x.as_ptr()) };
    let o = [ld(&rays.o[0]), ld(&rays.o[1]), ld(&rays.o[2])];
    let d = [ld(&rays.d[0]), ld(&rays.d[1]), ld(&rays.d[2])];
    let zero = _mm512_setzero_ps();
    // `Ray::is_valid`: finite origin and direction (not NaN, not ±∞: classes 0x99), the
    // direction not zero.
    let mut valid = (mask & 0xffff) as u16;
    for x in o.iter().chain(&d) {
        valid &= !_mm512_fpclass_ps_mask::<0x99>(*x);
    }
    valid &= _mm512_cmp_ps_mask::<_CMP_NEQ_OQ>(d[0], zero)
        | _mm512_cmp_ps_mask::<_CMP_NEQ_OQ>(d[1], zero)
        | _mm512_cmp_ps_mask::<_CMP_NEQ_OQ>(d[2], zero);
    if valid == 0 {
        return Some((0, None));
    }
    // `slab_inverse`: 1 / d, a component smaller than 1e-30 taken as ±1e-30; the valid
    // rays' octants all that of the first.
    let tiny = _mm512_set1_ps(1e-30);
    let mut inv = [zero; 3];
    let mut neg = [false; 3];
    for k in 0..3 {
        let small = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(_mm512_abs_ps(d[k]), tiny);
        let signed_tiny = _mm512_or_ps(tiny, _mm512_and_ps(d[k], _mm512_set1_ps(-0.0)));
        inv[k] = _mm512_div_ps(_mm512_set1_ps(1.0), _mm512_mask_blend_ps(small, d[k], signed_tiny));
        let negative = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(valid, inv[k], zero);
        if negative != 0 && negative != valid {
            return None;
        }
        neg[k] = negative != 0;
    }
    let rows = [o[0], o[1], o[2], d[0], d[1], d[2], inv[0], inv[1], inv[2], ld(&rays.t_min), ld(t_max)];
    for (row, v) in a.iter_mut().zip(rows) {
        // SAFETY: AVX-512 F is enabled here; each row holds sixteen floats.
        unsafe { _mm512_storeu_ps(row.as_mut_ptr(), _mm512_maskz_mov_ps(valid, v)) };
    }
    Some((valid, Some(neg)))
}

/// A packet's rays as rows of sixteen floats: `ox oy oz dx dy dz ix iy iz tmin tmax`.
#[cfg(target_arch = "x86_64")]
type Rows = [[f32; PACKET]; 11];

/// Writes the rows of a packet into `a` (`ox oy oz dx dy dz ix iy iz tmin tmax`, each
/// ray's inverse direction that of the single-ray box test; the lanes of invalid rays left
/// as they were) and returns the valid rays as a mask and their octant (`None` when no ray
/// is valid); `None` when the valid rays' octants differ.
/// PERF: into the caller's rows: returned by value, their copy made the packets 3% slower.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn packet_rows(rays: &[RaySegment], a: &mut Rows) -> Option<(u16, Option<[bool; 3]>)> {
    rows_of(rays.iter().enumerate().map(|(i, r)| (i, *r)), a)
}

/// [`packet_rows`] of the rays `(i, ray i)` (each `i` below [`PACKET`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn rows_of(rays: impl Iterator<Item = (usize, RaySegment)>, a: &mut Rows) -> Option<(u16, Option<[bool; 3]>)> {
    let mut active: u16 = 0;
    let mut neg: Option<[bool; 3]> = None;
    for (i, r) in rays {
        if !r.ray().is_valid() {
            continue;
        }
        let d = r.direction;
        // The same inverse and octant as the single-ray box test.
        let (inv, signs) = crate::accel::wide::slab_inverse(d);
        match neg {
            None => neg = Some(signs),
            Some(n) if n != signs => return None,
            _ => {}
        }
        let v = [r.origin.x, r.origin.y, r.origin.z, d.x, d.y, d.z, inv.x, inv.y, inv.z, r.t_min, r.t_max];
        for (k, x) in v.into_iter().enumerate() {
            a[k][i] = x;
        }
        active |= 1 << i;
    }
    Some((active, neg))
}

/// What a packet's slab tests share: its inverse directions and `origin · inv` moved by
/// its rounding, as for single rays (see `RayPre`), sixteen rays to a register.
#[cfg(target_arch = "x86_64")]
struct Slabs {
    inv: [std::arch::x86_64::__m512; 3],
    oinv_near: [std::arch::x86_64::__m512; 3],
    oinv_far: [std::arch::x86_64::__m512; 3],
}

#[cfg(target_arch = "x86_64")]
impl Slabs {
    /// The slabs of a packet's rows ([`packet_rows`]).
    ///
    /// # Safety
    /// The CPU must have AVX-512 F.
    #[inline(always)]
    unsafe fn of(a: &Rows) -> Slabs {
        use std::arch::x86_64::*;
        // SAFETY: the caller guarantees AVX-512 F; the loads read rows of 16 floats.
        unsafe {
            let ld = |x: &[f32; PACKET]| _mm512_loadu_ps(x.as_ptr());
            let inv = [ld(&a[6]), ld(&a[7]), ld(&a[8])];
            let slack = _mm512_set1_ps(crate::accel::wide::FMA_SLACK);
            let oinv = [_mm512_mul_ps(ld(&a[0]), inv[0]), _mm512_mul_ps(ld(&a[1]), inv[1]), _mm512_mul_ps(ld(&a[2]), inv[2])];
            let (mut oinv_near, mut oinv_far) = (oinv, oinv);
            for axis in 0..3 {
                oinv_near[axis] = _mm512_fmadd_ps(_mm512_abs_ps(oinv[axis]), slack, oinv[axis]);
                oinv_far[axis] = _mm512_fnmadd_ps(_mm512_abs_ps(oinv[axis]), slack, oinv[axis]);
            }
            Slabs { inv, oinv_near, oinv_far }
        }
    }

    /// The rays of `mask` that enter child `c` of `node` within `[t_min, t_best]`, and their
    /// entry distances; `neg` the packet's octant, `nonneg_tmin` whether no ray's `t_min`
    /// is negative (the widening of the single-ray test).
    ///
    /// # Safety
    /// The CPU must have AVX-512 F.
    #[inline(always)]
    #[allow(clippy::too_many_arguments, clippy::needless_range_loop)] // `axis` indexes four arrays
    unsafe fn enter(
        &self,
        node: &crate::accel::wide::Node8,
        c: usize,
        neg: [bool; 3],
        t_min: std::arch::x86_64::__m512,
        t_best: std::arch::x86_64::__m512,
        nonneg_tmin: bool,
        mask: u16,
    ) -> (u16, std::arch::x86_64::__m512) {
        use crate::accel::wide::WIDEN;
        use std::arch::x86_64::*;
        // SAFETY: the caller guarantees AVX-512 F.
        unsafe {
            let mut near = t_min;
            let mut far = t_best;
            for axis in 0..3 {
                let (nb, fb) = if neg[axis] { (node.hi[axis][c], node.lo[axis][c]) } else { (node.lo[axis][c], node.hi[axis][c]) };
                near = _mm512_max_ps(near, _mm512_fmsub_ps(_mm512_set1_ps(nb), self.inv[axis], self.oinv_near[axis]));
                far = _mm512_min_ps(far, _mm512_fmsub_ps(_mm512_set1_ps(fb), self.inv[axis], self.oinv_far[axis]));
            }
            // Widened as in the single-ray test.
            if nonneg_tmin {
                near = _mm512_mul_ps(near, _mm512_set1_ps(1.0 - WIDEN));
                far = _mm512_mul_ps(far, _mm512_set1_ps(1.0 + WIDEN));
            } else {
                let widen = _mm512_set1_ps(WIDEN);
                near = _mm512_fnmadd_ps(_mm512_abs_ps(near), widen, near);
                far = _mm512_fmadd_ps(_mm512_abs_ps(far), widen, far);
            }
            (_mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(mask, near, far), near)
        }
    }
}

/// The frustum of a packet whose rays all leave from one point (a pinhole camera's): per
/// axis the origin and the bounds of the rays' inverse directions (of one sign: a packet
/// has one octant), and the bounds of their intervals. A child box that the frustum
/// misses, with margins past the rounding of every ray's own slab test, is entered by no
/// ray of the packet, so its sixteen ray tests are skipped: the rays' answers unchanged.
#[cfg(target_arch = "x86_64")]
struct Frustum {
    origin: [f32; 3],
    inv_lo: [f32; 3],
    inv_hi: [f32; 3],
    t_lo: f32,
    t_hi: f32,
    /// The absolute margin: many times the rounding of `origin · inv` that the rays' FMA
    /// slab test moves its distances by (`FMA_SLACK`).
    margin: f32,
}

#[cfg(target_arch = "x86_64")]
impl Frustum {
    /// Relative margin of the frustum's distances: far above the rays' widening
    /// (`WIDEN`, 2^-21) and the rounding of the frustum's own products.
    const REL: f32 = 1.0 / 65_536.0;

    /// The frustum of the active rays of a packet loaded as `a` (`ox oy oz dx dy dz ix iy
    /// iz tmin tmax` rows), or `None` when their origins differ (bit for bit), an interval
    /// bound is NaN, or the origin, the inverse directions, the least `t_min` or the margin
    /// is not finite (the greatest `t_max` may be infinite).
    /// PERF: AVX-512 reductions over the rows. Made by a loop over the lanes, this set-up
    /// took a tenth of a packet's time: the packets ran at 0.90–0.92 of their speed with
    /// these reductions (the conference room's four views and the Stanford dragon, whose
    /// packets mostly miss it at the root).
    ///
    /// # Safety
    /// The CPU must have AVX-512 F.
    #[inline(always)]
    unsafe fn of(a: &Rows, active: u16) -> Option<Frustum> {
        use std::arch::x86_64::*;
        let first = active.trailing_zeros() as usize;
        if first >= PACKET {
            return None;
        }
        let origin = [a[0][first], a[1][first], a[2][first]];
        // SAFETY: the caller guarantees AVX-512 F; the loads read rows of 16 floats.
        unsafe {
            let ld = |x: &[f32; PACKET]| _mm512_loadu_ps(x.as_ptr());
            let mut same = active;
            for k in 0..3 {
                let bits = _mm512_castps_si512(ld(&a[k]));
                same &= _mm512_mask_cmpeq_epi32_mask(active, bits, _mm512_set1_epi32(origin[k].to_bits() as i32));
            }
            let (t_min, t_max) = (ld(&a[9]), ld(&a[10]));
            let nan = _mm512_mask_cmp_ps_mask::<_CMP_UNORD_Q>(active, t_min, t_max);
            if same != active || nan != 0 {
                return None;
            }
            let (mut inv_lo, mut inv_hi) = ([0f32; 3], [0f32; 3]);
            let mut margin = 0f32;
            for k in 0..3 {
                let inv = ld(&a[6 + k]);
                (inv_lo[k], inv_hi[k]) = (_mm512_mask_reduce_min_ps(active, inv), _mm512_mask_reduce_max_ps(active, inv));
                margin = margin.max(origin[k].abs() * inv_lo[k].abs().max(inv_hi[k].abs()));
            }
            let (t_lo, t_hi) = (_mm512_mask_reduce_min_ps(active, t_min), _mm512_mask_reduce_max_ps(active, t_max));
            // At least the smallest normal float: a bound below it would underflow to
            // nothing where the distances themselves are subnormal.
            margin = (margin * (1.0 / 262_144.0)).max(f32::MIN_POSITIVE);
            let finite = origin.iter().chain(&inv_lo).chain(&inv_hi).all(|x| x.is_finite()) && t_lo.is_finite() && margin.is_finite();
            finite.then_some(Frustum { origin, inv_lo, inv_hi, t_lo, t_hi, margin })
        }
    }

    /// The children of `node` (lanes, as a mask) that a ray of the frustum may enter;
    /// `neg` the packet's octant.
    ///
    /// # Safety
    /// The CPU must have AVX and FMA.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // `k` indexes six arrays
    unsafe fn children(&self, node: &crate::accel::wide::Node8, neg: [bool; 3]) -> u32 {
        use std::arch::x86_64::*;
        // SAFETY: the caller guarantees AVX and FMA; the loads read rows of eight floats.
        unsafe {
            let b = _mm256_set1_ps;
            let mut lo = b(self.t_lo);
            let mut hi = b(self.t_hi);
            for k in 0..3 {
                let (near, far) = if neg[k] { (&node.hi[k], &node.lo[k]) } else { (&node.lo[k], &node.hi[k]) };
                let o = b(self.origin[k]);
                let (i0, i1) = (b(self.inv_lo[k]), b(self.inv_hi[k]));
                let dn = _mm256_sub_ps(_mm256_loadu_ps(near.as_ptr()), o);
                let df = _mm256_sub_ps(_mm256_loadu_ps(far.as_ptr()), o);
                lo = _mm256_max_ps(lo, _mm256_min_ps(_mm256_mul_ps(dn, i0), _mm256_mul_ps(dn, i1)));
                hi = _mm256_min_ps(hi, _mm256_max_ps(_mm256_mul_ps(df, i0), _mm256_mul_ps(df, i1)));
            }
            let abs = |x| _mm256_andnot_ps(b(-0.0), x);
            let (rel, m) = (b(Self::REL), b(self.margin));
            let lo = _mm256_sub_ps(_mm256_fnmadd_ps(abs(lo), rel, lo), m);
            let hi = _mm256_add_ps(_mm256_fmadd_ps(abs(hi), rel, hi), m);
            // Kept unless surely empty (`!(lo > hi)`: unordered keeps).
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_NGT_UQ>(lo, hi)) as u32
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "x86_64")]
    use super::*;
    #[cfg(target_arch = "x86_64")]
    use crate::accel::wide::STACK_SIZE;

    /// The renderer's packets' rows in AVX-512 are [`lane_rows`]' (bit for bit, the same
    /// mask, octant or refusal): lanes of random rays, of one octant or of several, with
    /// NaN, infinite and zero origins and directions, zero and tiny direction components
    /// (either sign of zero), any mask.
    #[test]
    #[cfg(target_arch = "x86_64")]
    #[allow(clippy::needless_range_loop)] // `k` indexes the lanes of seven arrays
    fn lane_rows_in_avx512_are_the_lanes_rows() {
        use crate::math::sampling::Sampler;
        if SimdLevel::best() != SimdLevel::Avx512 {
            eprintln!("no AVX-512 on this CPU: lane_rows_avx512 not run (it serves AVX-512 packets only)");
            return;
        }
        let mut rng = Sampler::from_seed(77);
        let odd = [0.0, -0.0, 1e-31, -1e-31, 1e-30, -1e-30, 3e-38, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1.0, -2.5];
        let (mut refused, mut empty, mut some) = (0, 0, 0);
        for round in 0..20_000 {
            let mut rays = RayLanes::EMPTY;
            let mut t_max = [0f32; LANES];
            let base = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5);
            for k in 0..LANES {
                for axis in 0..3 {
                    rays.o[axis][k] = (rng.next_f32() - 0.5) * 100.0;
                    // One octant mostly (a small spread around `base`), several now and then.
                    let spread = if round % 4 == 0 { 1.0 } else { 0.01 };
                    rays.d[axis][k] = base[axis] + (rng.next_f32() - 0.5) * spread;
                    if rng.next_f32() < 0.03 {
                        rays.d[axis][k] = odd[(rng.next_f32() * odd.len() as f32) as usize % odd.len()];
                    }
                    if rng.next_f32() < 0.01 {
                        rays.o[axis][k] = odd[(rng.next_f32() * odd.len() as f32) as usize % odd.len()];
                    }
                }
                rays.t_min[k] = if rng.next_f32() < 0.2 { -1.0 } else { 0.0 };
                t_max[k] = rng.next_f32() * 1e3;
            }
            let mask = match round % 5 {
                0 => u32::MAX,
                1 => 0,
                _ => (rng.next_f32() * 65536.0) as u32 | (1 << 20),
            };
            let (mut a, mut b) = ([[0f32; PACKET]; 11], [[0f32; PACKET]; 11]);
            let want = lane_rows(&rays, &t_max, mask, &mut a);
            // SAFETY: the CPU has AVX-512 (checked above).
            let got = unsafe { lane_rows_avx512(&rays, &t_max, mask, &mut b) };
            assert_eq!(got, want, "round {round}");
            match want {
                None => refused += 1,
                Some((0, _)) => empty += 1,
                Some(_) => {
                    some += 1;
                    assert_eq!(a.map(|r| r.map(f32::to_bits)), b.map(|r| r.map(f32::to_bits)), "round {round}");
                }
            }
        }
        assert!(refused > 1000 && empty > 1000 && some > 5000, "{refused} {empty} {some}");
    }

    /// The frustum of a packet of one origin keeps every child box that one of its rays
    /// enters by the packet's own slab test (`Slabs::enter`, widening included): packets
    /// from origins near and far from the world's origin (the rounding of `origin · inv`
    /// grows with it), narrow and wide, with negative and bounded intervals, against boxes
    /// through points of their rays (some flat or a single point, where the slab test's
    /// margins decide), boxes beside them and anywhere, empty lanes; and packets with a
    /// zero direction component (its inverse ±10³⁰). Removing either margin makes it fail.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn the_frustum_keeps_every_box_a_ray_enters() {
        use crate::accel::wide::Node8;
        use crate::math::sampling::Sampler;
        use std::arch::x86_64::_mm512_loadu_ps;
        if SimdLevel::best() != SimdLevel::Avx512 {
            eprintln!("no AVX-512 on this CPU: the packets' frustum not run (it serves AVX-512 packets only)");
            return;
        }
        let mut rng = Sampler::from_seed(41);
        let unit = |rng: &mut Sampler| Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5);
        let (mut entered, mut culled, mut packets, mut zero_axis) = (0, 0, 0, 0);
        for round in 0..4000 {
            let scale = [1.0, 300.0, 2.0e4, 3.0e6][round % 4];
            // Some at the world's origin, where only the relative margin covers the widening.
            let origin = if round % 7 == 0 { Vec3::ZERO } else { unit(&mut rng) * 2.0 * scale };
            let mut base = unit(&mut rng).normalize_or(Vec3::X);
            if round % 11 == 0 {
                // Every ray parallel to one axis's planes (one sign of zero: one octant).
                base[round % 3] = 0.0;
            }
            let spread = [1e-4, 1e-2, 0.2][round % 3];
            let (t_min, t_max) = match round % 5 {
                0 => (-0.5 * scale, f32::INFINITY),
                1 => (0.0, scale * rng.next_f32()),
                _ => (0.0, f32::INFINITY),
            };
            let rays: Vec<RaySegment> = (0..PACKET)
                .map(|_| {
                    let mut direction = base + unit(&mut rng) * spread;
                    if round % 11 == 0 {
                        direction[round % 3] = 0.0;
                    }
                    RaySegment { origin, t_min, direction, t_max }
                })
                .collect();
            let mut a = [[0f32; PACKET]; 11];
            let Some((active, Some(neg))) = packet_rows(&rays, &mut a) else { continue };
            // SAFETY: the CPU has AVX-512 (checked above).
            let Some(frustum) = (unsafe { Frustum::of(&a, active) }) else { continue };
            packets += 1;
            zero_axis += usize::from(round % 11 == 0);
            let mut node = Node8::EMPTY;
            // One lane in five left empty (its box inverted, no child).
            for c in (0..8).filter(|c| (round + c) % 5 != 0) {
                let r = &rays[(rng.next_f32() * PACKET as f32) as usize % PACKET];
                // Some near the origin, where `origin · inv` is large beside the distance;
                // some behind it, within a negative `t_min`.
                let t = match c % 3 {
                    0 => 1e-4 * rng.next_f32(),
                    1 if t_min < 0.0 => -0.4 * rng.next_f32(),
                    _ => 0.01 + 2.0 * rng.next_f32(),
                };
                let p = r.origin + r.direction * (scale * t);
                let size = scale * [0.0, 1e-7, 1e-3, 0.1][c % 4];
                let (lo, hi) = match c % 3 {
                    // Through the point.
                    0 => (p - unit(&mut rng).abs() * size, p + unit(&mut rng).abs() * size),
                    // A face through it, flat on one axis.
                    1 => {
                        let mut hi = p + unit(&mut rng).abs() * size;
                        hi[round % 3] = p[round % 3];
                        (p, hi)
                    }
                    // Beside it.
                    _ => {
                        let q = p + unit(&mut rng) * scale * 0.05;
                        (q, q + unit(&mut rng).abs() * scale * 0.02)
                    }
                };
                for k in 0..3 {
                    (node.lo[k][c], node.hi[k][c]) = (lo[k], hi[k]);
                }
                node.child[c] = c as u32;
            }
            // SAFETY (the three blocks): the CPU has AVX-512 (checked above), hence AVX and
            // FMA; the loads read rows of 16 floats.
            let kept = unsafe { frustum.children(&node, neg) };
            let (t_min, t_max) = unsafe { (_mm512_loadu_ps(a[9].as_ptr()), _mm512_loadu_ps(a[10].as_ptr())) };
            let slabs = unsafe { Slabs::of(&a) };
            let nonneg = rays.iter().all(|r| r.t_min >= 0.0);
            for c in 0..8 {
                // SAFETY: as above.
                let (m, _) = unsafe { slabs.enter(&node, c, neg, t_min, t_max, nonneg, active) };
                if node.child[c] == crate::accel::wide::EMPTY {
                    assert_eq!(m, 0, "round {round}: an empty lane entered");
                    continue;
                }
                if m != 0 {
                    entered += 1;
                    assert!(kept & (1 << c) != 0, "round {round}, child {c}: rays {m:#06x} enter it, the frustum culled it");
                } else {
                    culled += u32::from(kept & (1 << c) == 0);
                }
            }
        }
        assert!(packets > 2000 && zero_axis > 100, "{packets} packets of one octant, {zero_axis} with a zero component");
        assert!(entered > 4 * packets && culled > packets, "{entered} boxes entered, {culled} culled: both cases seen");
    }

    /// Both stacks of the AVX-512 packets give the hits of single rays (the large one is
    /// for trees deeper than the course's and the scanned models', which the small one
    /// serves: checked here for the conference room).
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn both_packet_stacks_give_the_single_rays_hits() {
        if SimdLevel::best() != SimdLevel::Avx512 {
            eprintln!("no AVX-512 on this CPU: the packets' stacks not run (the AVX2 streams serve packets, tested elsewhere)");
            return;
        }
        let desc = crate::scenes::builtin("tp4-conference").expect("a built-in scene");
        let scene = desc.build(crate::accel::Accel::BvhSah).expect("the conference room builds");
        let (_, mesh) = scene.meshes().next().expect("one mesh");
        let crate::geometry::MeshAccel::Wide(w) = mesh.accel() else { panic!("bvh-sah builds a wide BVH") };
        assert!(w.fits_small_stack(), "the conference room's tree ({} stack entries) takes the small stack", w.stack_entries());
        let camera = desc.camera.build(1.5);
        let rays = crate::rays::generate(&scene, &camera, 48, 32, crate::rays::RayKind::Primary, 1).expect("camera rays");
        let (mut checked, mut packets) = (0, 0);
        for chunk in rays.chunks(PACKET) {
            let segments: Vec<RaySegment> =
                chunk.iter().map(|r| RaySegment { origin: r.origin, t_min: r.t_min, direction: r.direction, t_max: r.t_max }).collect();
            let mut small = [None; PACKET];
            let mut large = [None; PACKET];
            // SAFETY: the CPU has AVX-512 (checked above), and both stacks hold the tree's
            // `7 · depth + 8` entries (asserted above; `from_bvh` checks `STACK_SIZE`).
            let (a, b) = unsafe {
                (w.packet_avx512::<SMALL_STACK, true>(&segments, &mut small), w.packet_avx512::<STACK_SIZE, true>(&segments, &mut large))
            };
            assert_eq!(a, b, "both stacks take or leave the same packets");
            if !a {
                // Rays of several octants (the middle of the image): the streams' case.
                continue;
            }
            packets += 1;
            for (i, s) in segments.iter().enumerate() {
                let want = w.intersect(&s.ray(), s.t_min, s.t_max).map(|h| (h.t, h.prim));
                assert_eq!(small[i].map(|h| (h.t, h.prim)), want, "small stack, ray {i}");
                assert_eq!(large[i].map(|h| (h.t, h.prim)), want, "large stack, ray {i}");
                checked += usize::from(want.is_some());
            }
        }
        assert!(packets > rays.len() / PACKET / 2, "{packets} packets traced");
        assert!(checked > rays.len() / 4, "{checked} hits: the test sees the mesh");
    }
}
