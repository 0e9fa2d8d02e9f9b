//! The traversal: one ray down the eight-wide tree, children visited nearest first, the
//! same loop compiled for the scalar, AVX2 and AVX-512 paths.

use super::kernels::*;
use super::*;
use crate::accel::triangle::WatertightRay;

impl WideBvh {
    /// The portable path. PERF: not inlined, so that `dispatch` stays a small function
    /// (inlined, the traversal stack of this path enlarged every call's frame).
    #[inline(never)]
    pub(super) fn traverse_scalar<const ANY: bool, const STATS: bool>(
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
    pub(super) unsafe fn traverse_avx2<const ANY: bool, const STATS: bool>(
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
    pub(super) unsafe fn traverse_avx512<const ANY: bool, const STATS: bool>(
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
    pub(super) unsafe fn traverse<const SIMD: bool, const ANY: bool, const STATS: bool>(
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
                    // +13% shadow; see ARCHITECTURE.md. Whichever child is gone into,
                    // its `next` is prefetched (`prefetch_next`).
                    if mask == 1 {
                        cur = node.child[0];
                        self.prefetch_next(node.next[0]);
                        continue;
                    }
                    if mask & (mask - 1) == 0 {
                        cur = node.child[mask.trailing_zeros() as usize];
                        self.prefetch_next(node.next[mask.trailing_zeros() as usize]);
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
                            self.prefetch_next(node.next[0]);
                            continue;
                        }
                        cur = node.child[mask.trailing_zeros() as usize];
                        self.prefetch_next(node.next[mask.trailing_zeros() as usize]);
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
                            self.prefetch_next(node.next[0]);
                            continue;
                        }
                        if mask == 3 && dist[1] <= dist[0] {
                            // The two largest boxes, the second nearer: constant offsets.
                            // SAFETY: as for the pushes below.
                            unsafe { stack.get_unchecked_mut(sp).write((node.child[0], dist[0])) };
                            sp += 1;
                            cur = node.child[1];
                            self.prefetch_next(node.next[1]);
                            continue;
                        }
                        if dist[l1] <= dist[l0] {
                            // SAFETY: as for the pushes below.
                            unsafe { stack.get_unchecked_mut(sp).write((node.child[l0], dist[l0])) };
                            sp += 1;
                            cur = node.child[l1];
                            self.prefetch_next(node.next[l1]);
                        } else {
                            // SAFETY: as for the pushes below.
                            unsafe { stack.get_unchecked_mut(sp).write((node.child[l1], dist[l1])) };
                            sp += 1;
                            cur = node.child[l0];
                            self.prefetch_next(node.next[l0]);
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
                            self.prefetch_next(node.next[0]);
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
                                self.prefetch_next(node.next[lane]);
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
                    let mut order = [(0f32, 0u32, 0u32); 8];
                    let mut n = 0;
                    let mut m = mask;
                    while m != 0 {
                        let lane = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let item = (dist[lane], node.child[lane], node.next[lane]);
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
                    for &(d, c, _) in &order[..n - 1] {
                        // SAFETY: sp < STACK_SIZE: at most seven entries are pushed per level
                        // and `from_bvh` checks the depth against `STACK_SIZE`.
                        unsafe { stack.get_unchecked_mut(sp).write((c, d)) };
                        sp += 1;
                    }
                    cur = order[n - 1].1;
                    self.prefetch_next(order[n - 1].2);
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
                    let hit = tri4_test::<SIMD, ANY>(tri, watertight.as_ref(), &pre, ray, t_min, t_best);
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

/// Sort keys of eight entry distances: the float bits made to compare as signed
/// integers (negative floats reversed), the lowest three bits replaced by `7 - lane` so
/// that keys are distinct and ties go to the higher lane, as the insertion sort orders
/// them (after Embree's sorting of hit children in vector registers).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) unsafe fn sort_keys(dist: &[f32; 8]) -> std::arch::x86_64::__m256i {
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
pub(super) unsafe fn nearer_count(keys: std::arch::x86_64::__m256i, lane: usize, mask: u32) -> usize {
    use std::arch::x86_64::*;
    // SAFETY: the caller guarantees AVX2.
    unsafe {
        let key = _mm256_permutevar8x32_epi32(keys, _mm256_set1_epi32(lane as i32));
        (_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(key, keys))) as u32 & mask).count_ones() as usize
    }
}

#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub(super) unsafe fn sort_keys(dist: &[f32; 8]) -> [f32; 8] {
    *dist
}

#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub(super) unsafe fn nearer_count(keys: [f32; 8], lane: usize, mask: u32) -> usize {
    (0..8).filter(|&j| mask & (1 << j) != 0 && (keys[j] < keys[lane] || (keys[j] == keys[lane] && j > lane))).count()
}
