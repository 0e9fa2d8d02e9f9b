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
    /// The rays as two batches of lanes, each with the mask of its lanes to trace (each
    /// lane with its own interval; ray `i` is lane `i % LANES` of batch `i / LANES`),
    /// when they are such lanes: an any-hit stream then sets them up eight lanes at a time
    /// (`lanes_rows_avx2`).
    #[inline(always)]
    fn lanes(&self) -> Option<([&RayLanes; 2], [u32; 2])> {
        None
    }
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

    #[inline(always)]
    fn lanes(&self) -> Option<([&RayLanes; 2], [u32; 2])> {
        let low = u32::MAX >> (32 - LANES);
        Some((self.0, [self.1[0] & low, self.1[1] & low]))
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

    #[inline(always)]
    fn lanes(&self) -> Option<([&RayLanes; 2], [u32; 2])> {
        Some(([self.0, self.0], [self.1 & (u32::MAX >> (32 - LANES)), 0]))
    }
}

/// A stream's rays set up in rows, ray `i` in column `i`: what a [`RayPre`] holds, so that
/// eight rays' set-up is a few AVX2 stores; the kernels read a ray's column through
/// [`RowRay`].
/// PERF: one `RayPre` per ray (112 bytes, written field by field from the ray's lanes)
/// was a fifth of the shadow streams' time; made from rows eight at a time and copied
/// out to `RayPre`s, as much (1.008); read from the rows by the kernels, the conference
/// room took 0.945 of its CPU time.
#[repr(C, align(32))]
struct Rows {
    origin: [[f32; STREAM]; 3],
    dir: [[f32; STREAM]; 3],
    inv: [[f32; STREAM]; 3],
    near: [[f32; STREAM]; 3],
    far: [[f32; STREAM]; 3],
    /// Per axis, the rays whose direction is negative along it.
    neg: [u32; 3],
}

impl Rows {
    const ZERO: Rows = Rows {
        origin: [[0.0; STREAM]; 3],
        dir: [[0.0; STREAM]; 3],
        inv: [[0.0; STREAM]; 3],
        near: [[0.0; STREAM]; 3],
        far: [[0.0; STREAM]; 3],
        neg: [0; 3],
    };

    /// Ray `i`'s column from `ray` (its slabs as [`RayPre::new`] computes them).
    #[inline(always)]
    fn set(&mut self, i: usize, ray: &Ray) {
        let (inv, neg, near, far) = slabs_of(ray);
        for axis in 0..3 {
            self.origin[axis][i] = ray.origin[axis];
            self.dir[axis][i] = ray.direction[axis];
            self.inv[axis][i] = inv[axis];
            self.near[axis][i] = near[axis];
            self.far[axis][i] = far[axis];
            self.neg[axis] |= u32::from(neg[axis]) << i;
        }
    }

    /// Ray `i` (below [`STREAM`]).
    #[inline(always)]
    fn ray(&self, i: usize) -> RowRay<'_> {
        RowRay { rows: self, i: i % STREAM }
    }
}

/// Ray `i` of a stream's [`Rows`], as the kernels read it.
struct RowRay<'a> {
    rows: &'a Rows,
    i: usize,
}

impl RayView for RowRay<'_> {
    #[inline(always)]
    fn origin(&self) -> Vec3 {
        let (r, i) = (&self.rows.origin, self.i);
        Vec3::new(r[0][i], r[1][i], r[2][i])
    }

    #[inline(always)]
    fn dir(&self) -> Vec3 {
        let (r, i) = (&self.rows.dir, self.i);
        Vec3::new(r[0][i], r[1][i], r[2][i])
    }

    #[inline(always)]
    fn slab(&self, axis: usize) -> (f32, f32, f32) {
        let (r, i) = (self.rows, self.i);
        (r.inv[axis][i], r.near[axis][i], r.far[axis][i])
    }

    #[inline(always)]
    fn near_far(&self, axis: usize) -> (usize, usize) {
        plane_offsets(axis, self.rows.neg[axis] >> self.i & 1 != 0)
    }
}

/// The set-up of an any-hit stream's rays from two batches of lanes (ray `i` is lane
/// `i % LANES` of batch `i / LANES`, traced when its bit of that batch's mask is set),
/// eight lanes at a time, into `rows` (whose octant masks are zero; the columns of rays
/// not set up are left as they were) and `t_min`, `t_best`: the same floats as
/// [`RayPre::new`] (one division per axis for eight rays, each lane's the same IEEE
/// quotient). Returns the rays set up: the valid ones ([`Ray::is_valid`]).
///
/// # Safety
/// The CPU must have AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn lanes_rows_avx2(
    batches: [&RayLanes; 2],
    masks: [u32; 2],
    rows: &mut Rows,
    t_min: &mut [f32; STREAM],
    t_best: &mut [f32; STREAM],
) -> u32 {
    use std::arch::x86_64::*;
    const { assert!(LANES.is_multiple_of(8) && STREAM == 2 * LANES) };
    let mut live = 0u32;
    let zero = _mm256_setzero_ps();
    let sign = _mm256_set1_ps(-0.0);
    let abs = |x: __m256| _mm256_andnot_ps(sign, x);
    // Not NaN, not ±∞.
    let finite = |x: __m256| _mm256_cmp_ps::<_CMP_LT_OQ>(abs(x), _mm256_set1_ps(f32::INFINITY));
    for (b, (rays, mask)) in batches.into_iter().zip(masks).enumerate() {
        for base in (0..LANES).step_by(8) {
            let lanes = (mask >> base) & 0xff;
            if lanes == 0 {
                continue;
            }
            // SAFETY: eight floats from `base`, within the lanes.
            let ld = |x: &[f32; LANES]| unsafe { _mm256_loadu_ps(x.as_ptr().add(base)) };
            let o = [ld(&rays.o[0]), ld(&rays.o[1]), ld(&rays.o[2])];
            let d = [ld(&rays.d[0]), ld(&rays.d[1]), ld(&rays.d[2])];
            let nonzero = _mm256_or_ps(
                _mm256_or_ps(_mm256_cmp_ps::<_CMP_NEQ_OQ>(d[0], zero), _mm256_cmp_ps::<_CMP_NEQ_OQ>(d[1], zero)),
                _mm256_cmp_ps::<_CMP_NEQ_OQ>(d[2], zero),
            );
            let ok = [o[0], o[1], o[2], d[0], d[1], d[2]].into_iter().fold(nonzero, |ok, x| _mm256_and_ps(ok, finite(x)));
            let valid = _mm256_movemask_ps(ok) as u32 & lanes;
            if valid == 0 {
                continue;
            }
            let at = b * LANES + base;
            // SAFETY: eight floats from column `at`, within the rows of `STREAM`.
            let st = |row: &mut [f32; STREAM], v: __m256| unsafe { _mm256_storeu_ps(row.as_mut_ptr().add(at), v) };
            // `slab_inverse` and `origin · inv` moved each way, per axis, as `RayPre::new`.
            let tiny = _mm256_set1_ps(1e-30);
            for axis in 0..3 {
                let small = _mm256_cmp_ps::<_CMP_LT_OQ>(abs(d[axis]), tiny);
                let safe = _mm256_blendv_ps(d[axis], _mm256_or_ps(tiny, _mm256_and_ps(d[axis], sign)), small);
                let inv = _mm256_div_ps(_mm256_set1_ps(1.0), safe);
                let negative = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(inv, zero)) as u32;
                rows.neg[axis] |= (negative & valid) << at;
                let org_inv = _mm256_mul_ps(o[axis], inv);
                let slack = _mm256_mul_ps(abs(org_inv), _mm256_set1_ps(FMA_SLACK));
                st(&mut rows.origin[axis], o[axis]);
                st(&mut rows.dir[axis], d[axis]);
                st(&mut rows.inv[axis], inv);
                st(&mut rows.near[axis], _mm256_add_ps(org_inv, slack));
                st(&mut rows.far[axis], _mm256_sub_ps(org_inv, slack));
            }
            st(t_min, ld(&rays.t_min));
            st(t_best, ld(&rays.t_max));
            live |= valid << at;
        }
    }
    live
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
        thread_local! {
            static ROWS: std::cell::RefCell<Rows> = const { std::cell::RefCell::new(Rows::ZERO) };
        }
        ROWS.with_borrow_mut(|rows| {
            rows.neg = [0; 3];
            // SAFETY: the caller's guarantees.
            unsafe { self.stream_in_avx2::<ANY, R>(rays, out, start, rows) }
        })
    }

    /// [`WideBvh::stream_avx2`] with its rows' memory, kept per thread (its columns of
    /// rays not traced are never read; `neg` zero).
    ///
    /// # Safety
    /// As for [`WideBvh::stream_avx2`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,lzcnt")]
    unsafe fn stream_in_avx2<const ANY: bool, R: StreamRays + ?Sized>(
        &self,
        rays: &R,
        out: &mut [Option<MeshHit>],
        start: Option<&Node8>,
        rows: &mut Rows,
    ) -> u32 {
        use std::arch::x86_64::*;
        debug_assert!(rays.count() <= STREAM && (ANY || out.len() >= rays.count()) && !self.watertight);
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
        match rays.lanes() {
            Some((batches, masks)) if ANY => {
                if self.root != EMPTY {
                    // SAFETY: the CPU has AVX2 and FMA (this function's features).
                    live = unsafe { lanes_rows_avx2(batches, masks, rows, &mut t_min, &mut t_best) };
                    t_lim = t_best;
                }
            }
            _ => {
                for i in 0..rays.count() {
                    if !ANY {
                        out[i] = None;
                    }
                    let Some((ray, r_min, r_max)) = rays.get(i) else { continue };
                    if self.root == EMPTY || !ray.is_valid() {
                        continue;
                    }
                    rows.set(i, &ray);
                    (t_min[i], t_best[i], t_lim[i]) = (r_min, r_max, limit(r_max));
                    live |= 1 << i;
                }
            }
        }
        if live == 0 {
            // No valid ray, or an empty tree (whose root code `EMPTY` is no leaf).
            return 0;
        }
        let pre = |i: usize| rows.ray(i);
        // When every ray has the octant of the first, each node's planes are loaded once.
        let first = live.trailing_zeros() as usize;
        let one_octant = rows.neg.iter().all(|&n| n & live == 0 || n & live == live);
        // Rays of one origin (a camera's, one point's shadow rays) share the part of each
        // block's test that depends on the origin, computed once per block. PERF: primary
        // streams (conference room, one thread) 14.7 -> 15.5 Mrays/s. Two hits' shadow rays
        // side by side (two origins) gain nothing: per block and origin only about three
        // rays meet, and sharing per origin made the conference room 3% slower.
        let one_origin = lanes_of(live).all(|i| (0..3).all(|a| rows.origin[a][i].to_bits() == rows.origin[a][first].to_bits()));
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
                    // SAFETY: AVX2 and FMA are enabled here; `pre(first)`'s plane offsets
                    // come from `plane_offsets`, and every ray shares its octant.
                    let planes = unsafe { node_planes_avx2(node, &pre(first)) };
                    while m != 0 {
                        let i = m.trailing_zeros() as usize;
                        m &= m - 1;
                        // SAFETY: as above.
                        add(unsafe { box_planes_stream_avx2(&planes, &pre(i), t_min[i], t_best[i], bit(i)) });
                    }
                } else {
                    while m != 0 {
                        let i = m.trailing_zeros() as usize;
                        m &= m - 1;
                        // SAFETY: AVX2 and FMA are enabled here; `pre(i)`'s plane offsets
                        // come from `plane_offsets`.
                        add(unsafe { box_lanes_stream_avx2(node, &pre(i), t_min[i], t_best[i], bit(i)) });
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
                    let part = (one_origin && m & (m - 1) != 0).then(|| unsafe { origin_part_avx2(tri, origin_avx(&pre(first))) });
                    while m != 0 {
                        let i = m.trailing_zeros() as usize;
                        m &= m - 1;
                        if m == 0 {
                            // The last ray alone.
                            if let Some(h) = tri4_sse::<ANY, _>(tri, &pre(i), t_min[i], t_lim[i]) {
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
                                Some(part) => tri4x2_from_avx2(tri, part, &pre(i), &pre(j), [t_min[i], t_min[j]], [t_lim[i], t_lim[j]]),
                                None => tri4x2_avx2(tri, &pre(i), &pre(j), [t_min[i], t_min[j]], [t_lim[i], t_lim[j]]),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sampling::Sampler;

    /// The lanes' set-up in AVX2 gives the rows of the ray-by-ray set-up (`Rows::set`,
    /// `RayPre::new`'s arithmetic), bit for bit, and the same rays: lanes of random rays,
    /// with NaN, infinite and zero origins and directions, zero and tiny direction
    /// components (either sign of zero), any masks, in both batches.
    #[test]
    #[cfg(target_arch = "x86_64")]
    #[allow(clippy::needless_range_loop)] // `k` indexes the lanes of several arrays
    fn lanes_rows_in_avx2_are_the_rays_rows() {
        if !std::arch::is_x86_feature_detected!("avx2") || !std::arch::is_x86_feature_detected!("fma") {
            eprintln!("no AVX2 and FMA on this CPU: lanes_rows_avx2 not run (it serves the AVX2 streams only)");
            return;
        }
        let mut rng = Sampler::from_seed(5);
        let odd = [0.0, -0.0, 1e-31, -1e-31, 1e-30, -1e-30, 3e-38, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1.0, -2.5, 1e30];
        let pick = |rng: &mut Sampler| odd[(rng.next_f32() * odd.len() as f32) as usize % odd.len()];
        let (mut traced, mut refused) = (0u32, 0u32);
        for round in 0..5000 {
            let mut batches = [RayLanes::EMPTY, RayLanes::EMPTY];
            for rays in &mut batches {
                for k in 0..LANES {
                    for axis in 0..3 {
                        rays.o[axis][k] = (rng.next_f32() - 0.5) * [1.0, 1e3, 1e6][round % 3];
                        rays.d[axis][k] = rng.next_f32() - 0.5;
                        if rng.next_f32() < 0.05 {
                            rays.d[axis][k] = pick(&mut rng);
                        }
                        if rng.next_f32() < 0.02 {
                            rays.o[axis][k] = pick(&mut rng);
                        }
                    }
                    rays.t_min[k] = rng.next_f32();
                    rays.t_max[k] = rng.next_f32() * 100.0;
                }
            }
            let masks = [(rng.next_f32() * 65536.0) as u32, if round % 4 == 0 { 0 } else { (rng.next_f32() * 65536.0) as u32 }];
            let (mut want, mut got) = (Rows::ZERO, Rows::ZERO);
            let (mut want_t, mut got_t) = (([0f32; STREAM], [0f32; STREAM]), ([0f32; STREAM], [0f32; STREAM]));
            let mut want_live = 0u32;
            for i in 0..STREAM {
                let (rays, k) = (&batches[i / LANES], i % LANES);
                let ray = rays.ray(k);
                if masks[i / LANES] & (1 << k) != 0 && ray.is_valid() {
                    want.set(i, &ray);
                    (want_t.0[i], want_t.1[i]) = (rays.t_min[k], rays.t_max[k]);
                    want_live |= 1 << i;
                }
            }
            // SAFETY: the CPU has AVX2 and FMA (checked above).
            let live = unsafe { lanes_rows_avx2([&batches[0], &batches[1]], masks, &mut got, &mut got_t.0, &mut got_t.1) };
            assert_eq!(live, want_live, "round {round}");
            for i in lanes_of(live) {
                // Every value the kernels read of ray `i`, as bits.
                let column = |r: &Rows| {
                    let ray = r.ray(i);
                    let mut v: Vec<u32> = [ray.origin(), ray.dir()].iter().flat_map(|x| x.to_array()).map(f32::to_bits).collect();
                    for axis in 0..3 {
                        let (inv, near, far) = ray.slab(axis);
                        let (n, f) = ray.near_far(axis);
                        v.extend([inv.to_bits(), near.to_bits(), far.to_bits(), n as u32, f as u32]);
                    }
                    v
                };
                assert_eq!(column(&got), column(&want), "round {round}, ray {i}");
                assert_eq!((got_t.0[i].to_bits(), got_t.1[i].to_bits()), (want_t.0[i].to_bits(), want_t.1[i].to_bits()));
            }
            traced += live.count_ones();
            refused += (masks[0] | masks[1] << LANES).count_ones() - live.count_ones();
        }
        assert!(traced > 50_000 && refused > 2_000, "{traced} {refused}");
    }
}
