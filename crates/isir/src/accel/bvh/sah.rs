//! The binned SAH build (MacDonald and Booth 1990; Wald, "On fast construction of SAH-based
//! BVHs", 2007), parallel over the top of the tree.

use super::*;
use glam::Vec3A;

// PERF: the build works on 32-byte primitive records partitioned in place, so every level
// streams through memory instead of gathering boxes through an index array, does its box
// arithmetic with SIMD (`Vec3A`), and gets both children's bounds from the partition pass
// itself. Measured on the conference room (331k triangles, 2 threads): 146 ms with the
// index-array version, see the closing note of the speed issue for this one.

/// A primitive's box and number, as the build moves it around.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(super) struct PrimRef {
    pub(super) min: [f32; 3],
    pub(super) index: u32,
    pub(super) max: [f32; 3],
    pub(super) _pad: u32,
}

impl PrimRef {
    /// The record of primitive `index` with box `b`.
    #[inline(always)]
    pub(super) fn new(index: u32, b: &Aabb) -> Self {
        PrimRef { min: b.min.into(), index, max: b.max.into(), _pad: 0 }
    }

    #[inline(always)]
    pub(super) fn lo(&self) -> Vec3A {
        Vec3A::from_array(self.min)
    }
    #[inline(always)]
    pub(super) fn hi(&self) -> Vec3A {
        Vec3A::from_array(self.max)
    }
    /// The record as two SIMD registers, `min` and `max`: on x86-64 each one aligned load
    /// with its fourth lane (the index's bits, the padding) cleared, as index bits read as
    /// a float are denormal, which would slow the arithmetic down; elsewhere `lo()` and
    /// `hi()`.
    /// PERF: `lo()` and `hi()` gather three floats each (four instructions per vector):
    /// binning a record 5.3 -> 4.1 ns.
    #[inline(always)]
    pub(super) fn halves(&self) -> [Vec3A; 2] {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{__m128, _mm_and_ps, _mm_castsi128_ps, _mm_set_epi32};
            const { assert!(std::mem::size_of::<PrimRef>() == 2 * std::mem::size_of::<__m128>()) };
            // SAFETY: `PrimRef` is `repr(C)`, 32 bytes aligned to 16: two 16-byte halves of
            // plain `f32`/`u32` data, any bits of which make a valid `__m128`; SSE2 is part
            // of x86-64.
            unsafe {
                let halves = std::mem::transmute::<PrimRef, [__m128; 2]>(*self);
                let xyz = _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1));
                halves.map(|h| Vec3A::from(_mm_and_ps(h, xyz)))
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        [self.lo(), self.hi()]
    }

    /// Twice the centroid: binning only needs it up to scale.
    #[inline(always)]
    pub(super) fn c2(&self) -> Vec3A {
        self.lo() + self.hi()
    }
}

/// Box and centroid box of a set of records, in SIMD registers.
#[derive(Clone, Copy)]
pub(super) struct Bounds {
    pub(super) lo: Vec3A,
    pub(super) hi: Vec3A,
    pub(super) clo: Vec3A,
    pub(super) chi: Vec3A,
}

impl Bounds {
    pub(super) const EMPTY: Bounds =
        Bounds { lo: Vec3A::INFINITY, hi: Vec3A::NEG_INFINITY, clo: Vec3A::INFINITY, chi: Vec3A::NEG_INFINITY };

    #[inline(always)]
    pub(super) fn grow(&mut self, p: &PrimRef) {
        // The fourth lanes carry the record's index and padding: nothing reads them.
        let [lo, hi] = p.halves();
        self.lo = self.lo.min(lo);
        self.hi = self.hi.max(hi);
        let c = lo + hi;
        self.clo = self.clo.min(c);
        self.chi = self.chi.max(c);
    }

    pub(super) fn merge(mut self, o: &Bounds) -> Bounds {
        self.lo = self.lo.min(o.lo);
        self.hi = self.hi.max(o.hi);
        self.clo = self.clo.min(o.clo);
        self.chi = self.chi.max(o.chi);
        self
    }

    pub(super) fn of(prims: &[PrimRef]) -> Bounds {
        use rayon::prelude::*;
        let seq = |chunk: &[PrimRef]| {
            let mut b = Bounds::EMPTY;
            chunk.iter().for_each(|p| b.grow(p));
            b
        };
        if prims.len() < PARALLEL_BINNING {
            seq(prims)
        } else {
            prims.par_chunks(16384).map(seq).reduce(|| Bounds::EMPTY, |a, b| a.merge(&b))
        }
    }

    pub(super) fn aabb(&self) -> Aabb {
        Aabb::new(self.lo.into(), self.hi.into())
    }
}

#[inline(always)]
pub(super) fn half_area(lo: Vec3A, hi: Vec3A) -> f32 {
    let d = (hi - lo).max(Vec3A::ZERO);
    d.x * d.y + d.y * d.z + d.z * d.x
}

#[derive(Clone, Copy)]
pub(super) struct Bin {
    pub(super) lo: Vec3A,
    pub(super) hi: Vec3A,
    pub(super) count: u32,
}

pub(super) const EMPTY_BIN: Bin = Bin { lo: Vec3A::INFINITY, hi: Vec3A::NEG_INFINITY, count: 0 };

impl Bin {
    /// Take `o`'s records in: the union of the boxes, the sum of the counts.
    #[inline(always)]
    pub(super) fn add(&mut self, o: &Bin) {
        self.lo = self.lo.min(o.lo);
        self.hi = self.hi.max(o.hi);
        self.count += o.count;
    }
}

/// Bins per axis; `NB` is the node's [`bin_count`], so a small node only initialises and
/// sweeps the bins it uses.
pub(super) type Bins<const NB: usize> = [[Bin; NB]; 3];

/// Maps a record's doubled centroid to its bin on each axis.
#[derive(Clone, Copy)]
pub(super) struct Binner {
    pub(super) origin: Vec3A,
    pub(super) scale: Vec3A,
    pub(super) count: usize,
}

/// PERF: the sweep over the bins costs the same for 5 primitives as for 5 million; small
/// nodes, the vast majority, get fewer bins.
pub(super) fn bin_count(n: usize) -> usize {
    if n >= 256 {
        SAH_BINS
    } else if n >= 32 {
        16
    } else {
        8
    }
}

impl Binner {
    pub(super) fn new(b: &Bounds, n: usize) -> Self {
        let count = bin_count(n);
        let extent = b.chi - b.clo;
        let scale = Vec3A::select(extent.cmpgt(Vec3A::ZERO), Vec3A::splat(count as f32 * (1.0 - 1e-6)) / extent, Vec3A::ZERO);
        Self { origin: b.clo, scale, count }
    }

    /// True when the record falls in a bin before `k` on `axis`. The same arithmetic as
    /// [`Self::bins`] without the clamp and the conversion: `floor(x) < k` is `x < k`
    /// (and a clamped `x` lands on the same side of `k`, as `1 <= k < count`).
    #[inline(always)]
    pub(super) fn before(&self, p: &PrimRef, axis: usize, k: usize) -> bool {
        let c2 = p.min[axis] + p.max[axis];
        (c2 - self.origin[axis]) * self.scale[axis] < k as f32
    }

    /// The bin on each axis of a record whose doubled centroid is `c2` (its fourth lane
    /// ignored).
    #[inline(always)]
    pub(super) fn bins(&self, c2: Vec3A) -> [usize; 3] {
        let r = ((c2 - self.origin) * self.scale).clamp(Vec3A::ZERO, Vec3A::splat(self.count as f32 - 1.0));
        // PERF: one truncating SIMD conversion instead of three saturating `as` casts.
        // The value is clamped to [0, count - 1] above, so truncation is exact.
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{__m128, _mm_cvttps_epi32, _mm_storeu_si128};
            let mut k = [0i32; 4];
            // SAFETY: SSE2 is part of x86-64; `k` has room for the four lanes stored.
            unsafe { _mm_storeu_si128(k.as_mut_ptr().cast(), _mm_cvttps_epi32(__m128::from(r))) };
            [k[0] as usize, k[1] as usize, k[2] as usize]
        }
        #[cfg(not(target_arch = "x86_64"))]
        [r.x as usize, r.y as usize, r.z as usize]
    }
}

/// Cost of intersecting `n` primitives, in blocks of [`SAH_BLOCK`].
#[inline(always)]
pub(super) fn blocks(n: u32) -> f32 {
    n.div_ceil(SAH_BLOCK as u32) as f32
}

pub(super) fn merge_bins<const NB: usize>(mut a: Bins<NB>, b: &Bins<NB>) -> Bins<NB> {
    for axis in 0..3 {
        for k in 0..NB {
            a[axis][k].add(&b[axis][k]);
        }
    }
    a
}

/// Add one record to its bin on each axis.
#[inline(always)]
pub(super) fn bin_record<const NB: usize>(bins: &mut Bins<NB>, binner: &Binner, p: &PrimRef) {
    const { assert!(NB.is_power_of_two()) };
    let [lo, hi] = p.halves();
    let k = binner.bins(lo + hi);
    for axis in 0..3 {
        // `k < NB` (`bins` clamps it below the bin count, which is `NB`): the mask keeps
        // the index, and spares the bounds check.
        let bin = &mut bins[axis][k[axis] & (NB - 1)];
        bin.lo = bin.lo.min(lo);
        bin.hi = bin.hi.max(hi);
        bin.count += 1;
    }
}

/// Nodes from this many records are binned into two sets of bins (see [`bin_prims`]).
const BIN_TWICE_FROM: usize = 64;

pub(super) fn bin_prims<const NB: usize>(prims: &[PrimRef], binner: &Binner) -> Bins<NB> {
    debug_assert_eq!(binner.count, NB);
    let add = |bins: &mut Bins<NB>, p: &PrimRef| bin_record(bins, binner, p);
    let fill = |chunk: &[PrimRef]| {
        let mut bins = [[EMPTY_BIN; NB]; 3];
        if chunk.len() < BIN_TWICE_FROM {
            chunk.iter().for_each(|p| add(&mut bins, p));
            return bins;
        }
        // PERF: every other record into a second set of bins, merged at the end: two
        // records in one bin (neighbours often are) no longer wait for each other's
        // store. Min, max and counts do not depend on the order: the same bins.
        let mut odd = [[EMPTY_BIN; NB]; 3];
        let mut pairs = chunk.chunks_exact(2);
        for pair in &mut pairs {
            add(&mut bins, &pair[0]);
            add(&mut odd, &pair[1]);
        }
        pairs.remainder().iter().for_each(|p| add(&mut bins, p));
        merge_bins(bins, &odd)
    };
    if prims.len() < PARALLEL_BINNING {
        fill(prims)
    } else {
        use rayon::prelude::*;
        // Boxes merge by min/max and counts by addition: the result does not depend on
        // how the work was split, so the build is deterministic.
        prims.par_chunks(16384).map(fill).reduce(|| [[EMPTY_BIN; NB]; 3], |a, b| merge_bins(a, &b))
    }
}

/// The best binned split: `(axis, first bin of the right side, cost)`: the first
/// minimum in the order axis by axis, plane by plane (the answer of the tests'
/// reference, `best_split_scalar`, bit for bit). The three axes are swept together, one
/// per SIMD lane, as Embree's binner does.
/// PERF: one sweep for the three axes, without a branch per plane (10M-triangle mesh:
/// the build 2% faster).
pub(super) fn best_split<const NB: usize>(bins: &Bins<NB>) -> Option<(usize, usize, f32)> {
    use glam::{BVec4A, Vec4};
    // The half areas of three boxes (one per axis), lane by lane: `half_area`'s operations
    // in its order, so the same floats.
    #[inline(always)]
    fn half_areas(acc: &[Bin; 3]) -> Vec4 {
        let d: [Vec3A; 3] = std::array::from_fn(|a| (acc[a].hi - acc[a].lo).max(Vec3A::ZERO));
        let x = Vec4::new(d[0].x, d[1].x, d[2].x, 0.0);
        let y = Vec4::new(d[0].y, d[1].y, d[2].y, 0.0);
        let z = Vec4::new(d[0].z, d[1].z, d[2].z, 0.0);
        x * y + y * z + z * x
    }
    #[inline(always)]
    fn blocks3(acc: &[Bin; 3]) -> Vec4 {
        Vec4::new(blocks(acc[0].count), blocks(acc[1].count), blocks(acc[2].count), 0.0)
    }
    #[inline(always)]
    fn nonzero(acc: &[Bin; 3]) -> BVec4A {
        BVec4A::new(acc[0].count != 0, acc[1].count != 0, acc[2].count != 0, false)
    }
    #[inline(always)]
    fn add(acc: &mut [Bin; 3], bins: [&Bin; 3]) {
        for (a, b) in acc.iter_mut().zip(bins) {
            a.add(b);
        }
    }
    // Right-to-left sweep: area × count of the right side of every plane, on each axis.
    let mut right_cost = [Vec4::ZERO; NB];
    let mut right_used = [BVec4A::FALSE; NB];
    let mut acc = [EMPTY_BIN; 3];
    for k in (1..NB).rev() {
        add(&mut acc, [&bins[0][k], &bins[1][k], &bins[2][k]]);
        right_cost[k] = half_areas(&acc) * blocks3(&acc);
        right_used[k] = nonzero(&acc);
    }
    // Left-to-right: each axis's first minimum (strictly less replaces), with a flag for
    // the axes that have any valid plane, and the plane as a float (exact: `k < NB`).
    // NaN costs (an infinite extent times a flat one) cannot make the lanes differ from the
    // sequential rule: an infinite extent stays in every later plane's left or right box,
    // so after a NaN an axis has only NaN or infinite costs, which replace nothing.
    let (mut best, mut best_k, mut found) = (Vec4::ZERO, Vec4::ZERO, BVec4A::FALSE);
    let mut left = [EMPTY_BIN; 3];
    for k in 1..NB {
        add(&mut left, [&bins[0][k - 1], &bins[1][k - 1], &bins[2][k - 1]]);
        let cost = half_areas(&left) * blocks3(&left) + right_cost[k];
        let valid = nonzero(&left) & right_used[k];
        let take = valid & (!found | cost.cmplt(best));
        best = Vec4::select(take, cost, best);
        best_k = Vec4::select(take, Vec4::splat(k as f32), best_k);
        found |= valid;
    }
    let (found, best, best_k) = (found.bitmask(), best.to_array(), best_k.to_array());
    // The axes in order, strictly less replacing: the first minimum, as the sequential rule.
    let mut out: Option<(usize, usize, f32)> = None;
    for axis in (0..3).filter(|&a| found & (1 << a) != 0) {
        if out.is_none_or(|(_, _, c)| best[axis] < c) {
            out = Some((axis, best_k[axis] as usize, best[axis]));
        }
    }
    out
}

/// [`best_split`] axis by axis, plane by plane: the reference its lanes reproduce.
#[cfg(test)]
pub(super) fn best_split_scalar<const NB: usize>(bins: &Bins<NB>) -> Option<(usize, usize, f32)> {
    let mut best: Option<(usize, usize, f32)> = None;
    for (axis, bins) in bins.iter().enumerate() {
        // Right-to-left sweep: area × count of the right side of every plane.
        let mut right_cost = [0.0f32; NB];
        let mut right_count = [0u32; NB];
        let mut acc = EMPTY_BIN;
        for k in (1..NB).rev() {
            acc.add(&bins[k]);
            right_cost[k] = half_area(acc.lo, acc.hi) * blocks(acc.count);
            right_count[k] = acc.count;
        }
        let mut left = EMPTY_BIN;
        for k in 1..NB {
            left.add(&bins[k - 1]);
            if left.count == 0 || right_count[k] == 0 {
                continue;
            }
            let cost = half_area(left.lo, left.hi) * blocks(left.count) + right_cost[k];
            if best.is_none_or(|(_, _, c)| cost < c) {
                best = Some((axis, k, cost));
            }
        }
    }
    best
}

/// Nodes of at most this many records are partitioned without branches on the records
/// ([`partition_flags`]); larger ones, which do not fit in the cache, in one pass.
/// (Flags at every size: the 10M-triangle build 1.07x slower; up to 2^18 records: within
/// noise.)
const FLAGS_UP_TO: usize = 16384;

/// Partition `prims` so those for which `left` holds come first, and return the count on
/// the left and the bounds of both sides: the records in the order, and the bounds bit
/// for bit (signed zeros included), of [`partition_hoare`].
/// PERF: the sides' bits of a node of up to 256 records (most nodes) in a 32-byte array,
/// not in the 2 KB one zeroed for every node before: dragon build 145 -> 134 ms (medians
/// of 7; the conference room and the 10M mesh 0.99 and 0.98).
pub(super) fn partition_bounds(prims: &mut [PrimRef], left: impl Fn(&PrimRef) -> bool) -> (usize, Bounds, Bounds) {
    let words = prims.len().div_ceil(64);
    if words <= 4 {
        partition_flags(prims, left, &mut [0u64; 4][..words])
    } else if prims.len() <= FLAGS_UP_TO {
        partition_flags(prims, left, &mut [0u64; FLAGS_UP_TO / 64][..words])
    } else {
        partition_hoare(prims, left)
    }
}

/// [`partition_hoare`] without a branch on each record's side: the sides as a bit mask
/// first, then the same swaps (the `j`-th right record from the start with the `j`-th
/// left record from the end, while they are on the wrong sides), then each side's bounds
/// grown in the order Hoare's scans grow them (the left side forwards, the right side
/// backwards), so the signed zeros of the bounds are the same too.
/// PERF: the side of a record is a coin toss to the branch predictor.
/// `flags` holds one bit per record (`prims.len().div_ceil(64)` words).
fn partition_flags(prims: &mut [PrimRef], left: impl Fn(&PrimRef) -> bool, flags: &mut [u64]) -> (usize, Bounds, Bounds) {
    let n = prims.len();
    debug_assert_eq!(flags.len(), n.div_ceil(64));
    if n == 0 {
        return (0, Bounds::EMPTY, Bounds::EMPTY);
    }
    for (word, chunk) in flags.iter_mut().zip(prims.chunks(64)) {
        let mut bits = 0u64;
        for (b, p) in chunk.iter().enumerate() {
            bits |= u64::from(left(p)) << b;
        }
        *word = bits;
    }
    let words = n.div_ceil(64);
    let k: usize = flags[..words].iter().map(|w| w.count_ones() as usize).sum();
    // Bits of the positions below `k` in word `w`.
    let below = |w: usize| -> u64 {
        if (w + 1) * 64 <= k {
            !0
        } else if w * 64 >= k {
            0
        } else {
            (1u64 << (k - w * 64)) - 1
        }
    };
    // Right records before `k`, from the start; left records from `k` on, from the end.
    let (mut lw, mut rw) = (0usize, words - 1);
    let (mut lbits, mut rbits) = (!flags[0] & below(0), flags[rw] & !below(rw));
    'swaps: loop {
        while lbits == 0 {
            lw += 1;
            if lw * 64 >= k {
                break 'swaps;
            }
            lbits = !flags[lw] & below(lw);
        }
        let i = lw * 64 + lbits.trailing_zeros() as usize;
        lbits &= lbits - 1;
        // As many left records lie from `k` on as right records before it.
        while rbits == 0 {
            rw -= 1;
            rbits = flags[rw] & !below(rw);
        }
        let top = 63 - rbits.leading_zeros() as usize;
        rbits &= !(1u64 << top);
        prims.swap(i, rw * 64 + top);
    }
    let (mut lb, mut rb) = (Bounds::EMPTY, Bounds::EMPTY);
    prims[..k].iter().for_each(|p| lb.grow(p));
    prims[k..].iter().rev().for_each(|p| rb.grow(p));
    (k, lb, rb)
}

/// Partition `prims` so those for which `left` holds come first (Hoare's scans from both
/// ends), accumulating the bounds of each side as every record is placed. Returns the
/// count on the left and both bounds. The reference [`partition_flags`] reproduces.
pub(super) fn partition_hoare(prims: &mut [PrimRef], left: impl Fn(&PrimRef) -> bool) -> (usize, Bounds, Bounds) {
    let (mut lb, mut rb) = (Bounds::EMPTY, Bounds::EMPTY);
    let (mut i, mut j) = (0, prims.len());
    loop {
        while i < j && left(&prims[i]) {
            lb.grow(&prims[i]);
            i += 1;
        }
        while i < j && !left(&prims[j - 1]) {
            rb.grow(&prims[j - 1]);
            j -= 1;
        }
        if i >= j {
            break;
        }
        prims.swap(i, j - 1);
        lb.grow(&prims[i]);
        rb.grow(&prims[j - 1]);
        i += 1;
        j -= 1;
    }
    (i, lb, rb)
}

/// Split at the median doubled centroid along `axis`.
pub(super) fn median_split_refs(prims: &mut [PrimRef], axis: usize) -> (usize, Bounds, Bounds) {
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |a, b| a.c2()[axis].total_cmp(&b.c2()[axis]));
    let (l, r) = prims.split_at(mid);
    (mid, Bounds::of(l), Bounds::of(r))
}

/// How to split a node: `None` makes a leaf; otherwise the count that goes left (after
/// partitioning `prims`) and the bounds of both sides.
pub(super) fn sah_split(prims: &mut [PrimRef], b: &Bounds, depth: u32) -> Option<(usize, Bounds, Bounds)> {
    let n = prims.len();
    if n <= 1 {
        return None;
    }
    let extent = b.chi - b.clo;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    if depth >= SAH_MAX_DEPTH || extent.max_element() <= 0.0 {
        // Too deep, or all centroids in one point: binning cannot separate them.
        return (n > SAH_MAX_LEAF).then(|| median_split_refs(prims, axis));
    }
    if n <= SAH_BLOCK {
        return None; // one block: no split can cost less
    }
    let binner = Binner::new(b, n);
    let best = match binner.count {
        SAH_BINS => best_split(&bin_prims::<SAH_BINS>(prims, &binner)),
        16 => best_split(&bin_prims::<16>(prims, &binner)),
        8 => best_split(&bin_prims::<8>(prims, &binner)),
        n => unreachable!("no bin array of {n} bins"),
    };
    let Some((axis, k, cost)) = best else {
        // Every centroid in one bin (e.g. doubled centroids overflowing to infinity):
        // the median keeps leaves within the limit the wide layout relies on.
        return (n > SAH_MAX_LEAF).then(|| median_split_refs(prims, axis));
    };
    let split_cost = SAH_BUILD_TRAVERSAL_COST + SAH_INTERSECTION_COST * cost / half_area(b.lo, b.hi).max(f32::MIN_POSITIVE);
    let leaf_cost = SAH_INTERSECTION_COST * blocks(n as u32);
    if n <= SAH_MAX_LEAF && leaf_cost <= split_cost {
        return None;
    }
    let split = partition_bounds(prims, |p| binner.before(p, axis, k));
    if split.0 == 0 || split.0 == n {
        return Some(median_split_refs(prims, axis));
    }
    Some(split)
}

/// Sequential SAH build of the subtree in `slot`, appending its nodes to `nodes`.
pub(super) fn build_sah_into(nodes: &mut Vec<BvhNode>, slot: usize, prims: &mut [PrimRef], b: &Bounds, first: u32, depth: u32) {
    match sah_split(prims, b, depth) {
        None => nodes[slot] = BvhNode::leaf(&b.aabb(), first, prims.len() as u32),
        Some((k, lb, rb)) => {
            let child = nodes.len();
            nodes[slot] = BvhNode::interior(&b.aabb(), child as u32);
            nodes.push(BvhNode::default());
            nodes.push(BvhNode::default());
            let (l, r) = prims.split_at_mut(k);
            build_sah_into(nodes, child, l, &lb, first, depth + 1);
            build_sah_into(nodes, child + 1, r, &rb, first + k as u32, depth + 1);
        }
    }
}

/// The top of a parallel SAH build: splits made while subtrees are large, and below them
/// subtrees built sequentially into their own node arrays.
pub(super) enum Part {
    Split(Aabb, Box<(Part, Part)>),
    Built(Vec<BvhNode>),
}

impl Part {
    pub(super) fn node_count(&self) -> usize {
        match self {
            Part::Split(_, kids) => 1 + kids.0.node_count() + kids.1.node_count(),
            Part::Built(nodes) => nodes.len(),
        }
    }

    /// Write every node of this part but its root into `rest`, whose first node is node
    /// `first` of the whole tree, children pairs first (`[left root, right root, rest of
    /// left, rest of right]` below a split), and return the root, for the caller to place.
    /// The two sides of a split are written on both cores, each into its own slice.
    /// PERF: copied on one core, the 10M-triangle tree took ~105 ms, much of it the kernel
    /// faulting the fresh array in.
    pub(super) fn write_rest(self, rest: &mut [std::mem::MaybeUninit<BvhNode>], first: usize) -> BvhNode {
        match self {
            Part::Split(b, kids) => {
                let (l, r) = *kids;
                let (pair, tail) = rest.split_at_mut(2);
                let (l_rest, r_rest) = tail.split_at_mut(l.node_count() - 1);
                let r_first = first + 2 + l_rest.len();
                let (l_root, r_root) = rayon::join(|| l.write_rest(l_rest, first + 2), || r.write_rest(r_rest, r_first));
                pair[0].write(l_root);
                pair[1].write(r_root);
                BvhNode::interior(&b, first as u32)
            }
            Part::Built(nodes) => {
                // The part's node `i > 0` lands at `first - 1 + i`.
                let base = first as u32 - 1;
                assert_eq!(rest.len(), nodes.len() - 1, "a part's room is its size");
                for (out, n) in rest.iter_mut().zip(&nodes[1..]) {
                    out.write(n.relocated(base));
                }
                nodes[0].relocated(base)
            }
        }
    }
}

/// Parallel SAH build: subtrees larger than [`PARALLEL_THRESHOLD`] are split on both
/// cores; smaller ones are built sequentially, each into its own array.
/// PERF: copying every finished subtree into its parent's array at each parallel level
/// was 5% of the build; [`Part::write_rest`] writes each node once.
pub(super) fn build_sah_parallel(prims: &mut [PrimRef], b: &Bounds, first: u32, depth: u32) -> Part {
    if prims.len() <= PARALLEL_THRESHOLD {
        // At most 2n - 1 nodes: reserved so the array never grows (and copies).
        let mut nodes = Vec::with_capacity(2 * prims.len());
        nodes.push(BvhNode::default());
        build_sah_into(&mut nodes, 0, prims, b, first, depth);
        return Part::Built(nodes);
    }
    let Some((k, lb, rb)) = sah_split(prims, b, depth) else {
        return Part::Built(vec![BvhNode::leaf(&b.aabb(), first, prims.len() as u32)]);
    };
    let (l, r) = prims.split_at_mut(k);
    let kids = rayon::join(|| build_sah_parallel(l, &lb, first, depth + 1), || build_sah_parallel(r, &rb, first + k as u32, depth + 1));
    Part::Split(b.aabb(), Box::new(kids))
}

/// The SAH build from primitive boxes (only the valid ones are passed in `indices`).
pub(super) fn build_sah(indices: &[u32], box_of: impl Fn(u32) -> Aabb + Sync) -> (Vec<BvhNode>, Vec<u32>) {
    build_sah_in::<PrimRef>(indices, box_of, &mut Vec::new())
}

/// [`build_sah`] with its records (32 bytes per primitive) in the spare capacity of
/// `storage`, grown if it is short, and left there (`storage` stays empty): a caller that
/// then fills `storage` reuses memory the records have already faulted in.
/// PERF: the wide tree's triangle blocks are written there (`WideBvh::from_bvh_in`): on
/// the 2-core Zen 4 VM a fresh page cost far more than writing it (10M triangles: the
/// blocks' 421 MB took ~0.5 s of a 2.4 s build, most of it in the kernel zeroing pages).
/// `S` must be aligned at least as a record and a whole number of records long: a
/// compile-time check.
pub(crate) fn build_sah_in<S>(indices: &[u32], box_of: impl Fn(u32) -> Aabb + Sync, storage: &mut Vec<S>) -> (Vec<BvhNode>, Vec<u32>) {
    use rayon::prelude::*;
    use std::mem::{align_of, size_of, MaybeUninit};
    const { assert!(align_of::<S>() >= align_of::<PrimRef>() && size_of::<S>().is_multiple_of(size_of::<PrimRef>()) && size_of::<S>() > 0) };
    const { assert!(size_of::<PrimRef>() == super::RECORD_BYTES) };
    // PERF: the records on the pages the caller gave (`storage`: huge pages when the wide
    // tree's blocks follow them there, 10M-triangle build 0.88x the time), the binary
    // nodes on ordinary pages. A huge page first touched can cost the kernel a compaction
    // (THP `defrag` set to `madvise`, the common default) or, in a VM, the host's fault
    // on fresh memory: with the records and nodes on ordinary pages and the wide tree in
    // fresh memory of its own, the sixteenth session's 10M build took 2.42 -> 2.19 s.
    storage.clear();
    storage.reserve((indices.len() * size_of::<PrimRef>()).div_ceil(size_of::<S>()));
    let spare = storage.spare_capacity_mut();
    // SAFETY: the spare capacity holds at least `indices.len()` records' bytes (reserved
    // above), suitably aligned (checked at compile time), and is viewed as uninitialised
    // records, which are written before they are read.
    let records: &mut [MaybeUninit<PrimRef>] = unsafe { std::slice::from_raw_parts_mut(spare.as_mut_ptr().cast(), indices.len()) };
    records.par_iter_mut().zip(indices.par_iter()).with_min_len(4096).for_each(|(r, &i)| {
        r.write(PrimRef::new(i, &box_of(i)));
    });
    // SAFETY: every record was written just above.
    let prims: &mut [PrimRef] = unsafe { &mut *(std::ptr::from_mut(records) as *mut [PrimRef]) };
    let bounds = Bounds::of(prims);
    let top = build_sah_parallel(prims, &bounds, 0, 0);
    let total = top.node_count();
    let mut nodes = Vec::with_capacity(total);
    let (root, rest) = nodes.spare_capacity_mut()[..total].split_at_mut(1);
    root[0].write(top.write_rest(rest, 1));
    // SAFETY: `write_rest` wrote every node of `rest` (the part's nodes but its root, as
    // many as it holds) and the root is written above: all `total` are initialised.
    unsafe { nodes.set_len(total) };
    (nodes, prims.iter().map(|p| p.index).collect())
}
