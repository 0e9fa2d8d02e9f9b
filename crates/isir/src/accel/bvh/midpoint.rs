//! The course's BVH build (TP4 exercise 3): split at the middle of the largest axis of
//! the centroids' box, at most 8 primitives per leaf, depth at most 32.

use super::*;

/// The primitives' boxes and centroids.
pub(super) struct BuildInput<'a> {
    pub(super) boxes: &'a [Aabb],
    pub(super) centroids: Vec<Vec3>,
}

/// The box of a set of primitives.
pub(super) fn bounds_of(input: &BuildInput, indices: &[u32]) -> Aabb {
    indices.iter().fold(Aabb::EMPTY, |b, &i| b.union(&input.boxes[i as usize]))
}

/// Stable-enough in-place partition: primitives for which `left` holds come first.
/// Returns how many.
pub(super) fn partition(indices: &mut [u32], mut left: impl FnMut(u32) -> bool) -> usize {
    let mut k = 0;
    for i in 0..indices.len() {
        if left(indices[i]) {
            indices.swap(i, k);
            k += 1;
        }
    }
    k
}

/// Split at the median centroid along `axis` (the fallback when a split puts everything
/// on one side).
pub(super) fn median_split(input: &BuildInput, indices: &mut [u32], axis: usize) -> usize {
    let mid = indices.len() / 2;
    indices.select_nth_unstable_by(mid, |&a, &b| input.centroids[a as usize][axis].total_cmp(&input.centroids[b as usize][axis]));
    mid
}

pub(super) fn build_midpoint(input: &BuildInput, nodes: &mut Vec<BvhNode>, slot: usize, indices: &mut [u32], first: u32, depth: u32) {
    let bounds = bounds_of(input, indices);
    let n = indices.len();
    if n <= MIDPOINT_MAX_LEAF || depth >= MIDPOINT_MAX_DEPTH {
        nodes[slot] = BvhNode::leaf(&bounds, first, n as u32);
        return;
    }
    let axis = bounds.largest_axis();
    let middle = bounds.centroid()[axis];
    let mut k = partition(indices, |i| input.centroids[i as usize][axis] < middle);
    if k == 0 || k == n {
        k = median_split(input, indices, axis);
    }
    let child = nodes.len();
    nodes[slot] = BvhNode::interior(&bounds, child as u32);
    nodes.push(BvhNode::default());
    nodes.push(BvhNode::default());
    let (l, r) = indices.split_at_mut(k);
    build_midpoint(input, nodes, child, l, first, depth + 1);
    build_midpoint(input, nodes, child + 1, r, first + k as u32, depth + 1);
}
