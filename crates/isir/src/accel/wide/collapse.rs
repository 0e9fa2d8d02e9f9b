//! The collapse of the binary SAH BVH into eight-wide nodes and blocks of four triangles.

use super::*;

/// The cost of testing one wide node, relative to one block of four triangles, in the
/// SAH of the collapse.
pub(super) const WIDE_NODE_COST: f32 = 1.0;
/// The collapse may merge a binary subtree of at most this many triangles into one leaf.
pub(super) const WIDE_MAX_LEAF: u32 = 16;

/// The SAH-optimal collapse of a binary BVH into eight-wide nodes (the dynamic program of
/// Ylitie, Karras and Laine, "Efficient incoherent ray traversal on GPUs through
/// compressed wide BVHs", 2017). Bottom-up, each binary node gets the least SAH cost of
/// its subtree as at most `i` roots (leaves or wide nodes), for `i` in 1..=8; the plan
/// keeps, per node, how each is reached.
pub(super) struct Plan {
    /// Per binary node: bits `3(i-1)..3i` hold how many of at most `i` roots come from
    /// the left child (0: the node itself is the one root); bit [`Plan::LEAF`]: as one
    /// root, the node is a leaf (else a wide node). Written once per node, by whichever
    /// thread plans it (atomics only to share the array; relaxed stores are plain stores).
    pub(super) choice: Vec<std::sync::atomic::AtomicU32>,
    /// The SAH cost of the whole wide tree, as one root.
    pub(super) cost: f32,
}

/// What the parent of a planned subtree needs: its costs as at most 1..=8 roots, and its
/// primitives in `prim_indices` (first, count; count `u32::MAX` when not contiguous, so
/// it cannot become one leaf).
pub(super) struct Planned {
    pub(super) cost: [f32; 8],
    pub(super) first: u32,
    pub(super) count: u32,
}

/// `shared[i]`: the least cost of at most `i` roots taken from two subtrees of costs `l`
/// and `r`, each giving at least one (`shared[0]`, `shared[1]`: infinite). PERF: a
/// branch-free, vectorized min-plus product (with the branchy loop the plan took 8 ms
/// on the conference room).
#[inline]
pub(super) fn shared_roots(l: &[f32; 8], r: &[f32; 8]) -> [f32; 9] {
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
    pub(super) const LEAF: u32 = 24;
    /// Binary subtrees planned on both cores down to this depth.
    pub(super) const PARALLEL_DEPTH: u32 = 6;

    pub(super) fn new(bvh: &Bvh) -> Plan {
        let mut plan = Plan { choice: (0..bvh.nodes.len()).map(|_| std::sync::atomic::AtomicU32::new(0)).collect(), cost: 0.0 };
        plan.cost = plan.visit(bvh, 0, 0).cost[0];
        plan
    }

    /// Plan the subtree at `index`, children first.
    pub(super) fn visit(&self, bvh: &Bvh, index: usize, depth: u32) -> Planned {
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
    pub(super) fn is_leaf(&self, bvh: &Bvh, index: usize) -> bool {
        bvh.nodes[index].is_leaf() || self.choice[index].load(std::sync::atomic::Ordering::Relaxed) >> Self::LEAF & 1 != 0
    }

    /// How many of at most `i` roots of binary node `index` come from its left child (0:
    /// the node is the one root).
    pub(super) fn split(&self, bvh: &Bvh, index: usize, i: usize) -> usize {
        if bvh.nodes[index].is_leaf() {
            return 0;
        }
        (self.choice[index].load(std::sync::atomic::Ordering::Relaxed) >> (3 * (i - 1)) & 7) as usize
    }

    /// The roots of binary node `index`'s subtree as at most `i` roots, appended to `out`.
    pub(super) fn roots(&self, bvh: &Bvh, index: usize, i: usize, out: &mut [usize; 8], n: &mut usize) {
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
pub(super) fn subtree_prims(bvh: &Bvh, index: usize) -> (u32, u32) {
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
pub(super) struct Collapse {
    pub(super) nodes: Vec<Node8>,
    pub(super) blocks: Vec<[u32; 4]>,
    pub(super) depth: usize,
    /// At most this many nodes ([`MAX_NODES`], or fewer in tests).
    pub(super) max_nodes: usize,
    /// Set when the tree needed more nodes than `max_nodes` or more blocks than a leaf
    /// code can number: the codes are then wrong and the tree is dropped.
    pub(super) too_large: bool,
}

impl Collapse {
    /// Convert the binary subtree at `index` as `plan` says, appending its wide nodes to
    /// `self.nodes` and its leaves' triangle numbers, four per block, to `self.blocks`.
    /// Returns its code.
    pub(super) fn convert(&mut self, bvh: &Bvh, plan: &Plan, index: usize, depth: usize) -> u32 {
        if self.too_large {
            return EMPTY;
        }
        if plan.is_leaf(bvh, index) {
            let (first, count) = subtree_prims(bvh, index);
            let prims = &bvh.prim_indices[first as usize..(first + count) as usize];
            let first = self.blocks.len() as u32;
            let count = prims.len().div_ceil(4);
            assert!(count <= MAX_BLOCKS, "the plan makes leaves of at most {MAX_BLOCKS} blocks");
            if first > FIRST_MASK {
                self.too_large = true;
                return EMPTY;
            }
            self.blocks.extend(prims.chunks(4).map(|chunk| {
                let mut b = [EMPTY; 4];
                b[..chunk.len()].copy_from_slice(chunk);
                b
            }));
            return LEAF | ((count as u32 - 1) << BLOCKS_SHIFT) | first;
        }
        if self.nodes.len() >= self.max_nodes {
            self.too_large = true;
            return EMPTY;
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
            let next = next_code(&self.nodes, codes[i]);
            self.nodes[slot].set(lane, &bvh.nodes[kids[i]].aabb(), codes[i], next);
        }
        (slot * std::mem::size_of::<Node8>()) as u32 // below LEAF: `max_nodes` is at most MAX_NODES
    }
}
