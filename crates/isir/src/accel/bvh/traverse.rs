//! Traversal of the binary BVH, near child first, with a closure per primitive.

use super::*;

impl Bvh {
    /// Closest-hit traversal, near child first. `hit_prim(prim, t_max)` intersects one
    /// primitive and returns its `t` when it is in `[t_min, t_max)`; the returned value
    /// becomes the new `t_max`. Returns the final `t_max`.
    #[inline]
    pub fn intersect<F: FnMut(u32, f32) -> Option<f32>>(&self, ray: &Ray, t_min: f32, mut t_max: f32, mut hit_prim: F) -> f32 {
        self.walk(ray, t_min, &mut t_max, |prim, t_max| {
            if let Some(t) = hit_prim(prim, *t_max) {
                *t_max = t;
            }
            false
        });
        t_max
    }

    /// [`Bvh::intersect`], counting the nodes visited into `nodes` (the cost shown by
    /// `--aov cost`).
    #[inline]
    pub fn intersect_counting<F: FnMut(u32, f32) -> Option<f32>>(
        &self,
        ray: &Ray,
        t_min: f32,
        mut t_max: f32,
        nodes: &mut u64,
        mut hit_prim: F,
    ) -> f32 {
        self.walk_counting(ray, t_min, &mut t_max, nodes, |prim, t_max| {
            if let Some(t) = hit_prim(prim, *t_max) {
                *t_max = t;
            }
            false
        });
        t_max
    }

    /// Any-hit traversal: true as soon as `hit_prim(prim, t_max)` says a primitive blocks
    /// the ray.
    #[inline]
    pub fn occluded<F: FnMut(u32, f32) -> bool>(&self, ray: &Ray, t_min: f32, t_max: f32, mut hit_prim: F) -> bool {
        let mut t = t_max;
        self.walk(ray, t_min, &mut t, |prim, t_max| hit_prim(prim, *t_max))
    }

    /// The traversal loop shared by both queries; `visit` returns true to stop.
    #[inline(always)]
    fn walk<F: FnMut(u32, &mut f32) -> bool>(&self, ray: &Ray, t_min: f32, t_max: &mut f32, visit: F) -> bool {
        // The count goes to a local that is never read: optimised away.
        self.walk_counting(ray, t_min, t_max, &mut 0, visit)
    }

    /// [`Bvh::walk`], adding one to `nodes` for every node entered.
    #[inline(always)]
    fn walk_counting<F: FnMut(u32, &mut f32) -> bool>(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: &mut f32,
        nodes: &mut u64,
        mut visit: F,
    ) -> bool {
        if self.nodes.is_empty() || !ray.is_valid() {
            return false;
        }
        let inv = ray.direction.recip();
        let slab = |n: &BvhNode, t_max: f32| -> Option<f32> {
            let a = (Vec3::from(n.min) - ray.origin) * inv;
            let b = (Vec3::from(n.max) - ray.origin) * inv;
            let t0 = a.min(b).max_element().max(t_min);
            let t1 = a.max(b).min_element().min(t_max);
            (t0 <= t1).then_some(t0)
        };
        if slab(&self.nodes[0], *t_max).is_none() {
            return false;
        }
        let mut stack = [0u32; STACK_SIZE];
        let mut sp = 0;
        let mut node = &self.nodes[0];
        loop {
            *nodes += 1;
            if node.is_leaf() {
                let first = node.left_first as usize;
                for &prim in &self.prim_indices[first..first + node.count as usize] {
                    if visit(prim, t_max) {
                        return true;
                    }
                }
            } else {
                let c = node.left_first as usize;
                let (l, r) = (&self.nodes[c], &self.nodes[c + 1]);
                match (slab(l, *t_max), slab(r, *t_max)) {
                    (Some(tl), Some(tr)) => {
                        let (near, far) = if tl <= tr { (c, c + 1) } else { (c + 1, c) };
                        stack[sp] = far as u32;
                        sp += 1;
                        node = &self.nodes[near];
                        continue;
                    }
                    (Some(_), None) => {
                        node = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = r;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            // Pop the next node whose box is still in front of the closest hit.
            loop {
                if sp == 0 {
                    return false;
                }
                sp -= 1;
                let n = &self.nodes[stack[sp] as usize];
                if slab(n, *t_max).is_some() {
                    node = n;
                    break;
                }
            }
        }
    }
}
