//! Shadow rays towards one quad light, answered from short lists of triangles: a light
//! buffer (Haines and Greenberg 1986) made of shafts (Haines and Wallace 1994).
//!
//! The mesh's box is cut into cubic cells. A shadow ray from a point of a cell to a point
//! of the light stays inside the *shaft* of that cell: the convex hull of the cell and the
//! light. A triangle that lies outside the shaft can never block such a ray, so the ray
//! only needs the triangles that meet the shaft — often none or a handful, against a walk
//! down the whole tree. The first ray from a cell finds its list by walking the tree with
//! the shaft instead of a ray ([`ShaftGrid::cell`]); a cell whose shaft meets more than
//! [`MAX_TRIANGLES`] triangles keeps instead a cut of the tree ([`Cell::Entry`]): the
//! subtrees the shaft meets, where its rays' walks start.
//!
//! The lists hold copies of the tree's own blocks' triangles, and a ray is tested against
//! them with the tree's own triangle test, so a ray gets exactly the tree's answer from
//! every triangle it is tested against. A triangle is left out only when a plane separates
//! it from the shaft with room to spare: more than the rounding of the triangle test
//! could ever bridge (the bound is `ShaftGrid::triangle_margin`).

use super::wide::{block_any_hit, leaf_blocks, Cut, Node8, Tri4, WideBvh, BLOCKS_SHIFT, EMPTY, LEAF};
use crate::math::aabb::Aabb;
use crate::math::ray::{lanes_of, Ray, RayLanes, LANES};
use glam::Vec3;
use std::sync::OnceLock;

/// Cells along the longest side of the mesh's box.
pub const CELLS_ALONG: usize = 80;
/// A cell whose shaft meets more triangles than this takes the tree.
/// PERF: the conference room at 32 spp, 128 cells along: 12, 24 and 48 triangles 4.64,
/// 4.70 and 5.02 s of CPU (96 cells along and 16 triangles 4.67; 256 and 24, 4.93). Tuned
/// again in the forty-first session, against 128 cells and 24 triangles, CPU time at
/// 64 spp (paired medians of five): 80 cells and 16 triangles 0.973, 12 triangles 0.971;
/// 96 and 12, 0.974; 128 and 12, 0.975; 128 and 8, 0.978; 64 and 16, 0.980; 128 and 32,
/// 1.009. With 80 and 16: 16 light samples 0.968, the scene's own 4 spp 0.936.
pub const MAX_TRIANGLES: usize = 16;
/// At most this many cells in a scene, shared by its quad lights (32 bytes each until
/// asked for): 16 MB.
pub const MAX_CELLS: usize = 1 << 19;
/// How far short of the light a shadow ray stops: `t_max` is `1 - SHADOW_EPSILON` of the
/// distance ([`crate::math::ray::spawn_ray_to`]).
const SHADOW_EPSILON: f32 = 1e-4;

/// The cells of one mesh towards one quad light, each cell's list made when first asked.
#[derive(Clone, Debug)]
pub struct ShaftGrid {
    /// The mesh's box the grid covers.
    bounds: Aabb,
    /// A cell's side.
    cell: f32,
    /// Its inverse.
    inv_cell: f32,
    /// Cells along x, y and z.
    dims: [usize; 3],
    /// The light's four corners.
    quad: [Vec3; 4],
    /// The largest coordinate magnitude of the mesh, the light and the grid: the scale of
    /// the triangle test's rounding.
    scale: f32,
    /// Each cell's triangles, or where its rays enter the tree.
    cells: Box<[OnceLock<Cell>]>,
}

/// What a cell's shadow rays are answered from.
#[derive(Clone, Debug)]
pub enum Cell {
    /// The triangles its shaft meets (at most [`MAX_TRIANGLES`]), in blocks as the tree
    /// holds them.
    List(Box<[Tri4]>),
    /// More than [`MAX_TRIANGLES`]: a cut of the tree through every subtree the shaft meets
    /// (at most eight of them), where the cell's rays start their walk instead of at the
    /// root (they skip the tests above the cut).
    Entry(Box<Cut>),
    /// The tree from its root (a watertight or empty tree, or a root that is a leaf).
    Tree,
}

/// A plane `n·x = d` with unit `n`; the shaft lies on the side `n·x <= d`.
type HalfSpace = (Vec3, f32);

impl ShaftGrid {
    /// The grid of a mesh whose triangles lie in `bounds`, towards the light whose points
    /// are `corner + s·u + t·v` (`s`, `t` in `[0, 1]`), in at most `max_cells` cells (the
    /// scene's share of [`MAX_CELLS`] for this light). `None` when the box is empty or
    /// anything is not finite.
    #[must_use]
    pub fn new(bounds: &Aabb, corner: Vec3, u: Vec3, v: Vec3, max_cells: usize) -> Option<ShaftGrid> {
        let quad = [corner, corner + u, corner + v, corner + u + v];
        if !(bounds.min.is_finite() && bounds.max.is_finite() && quad.iter().all(|q| q.is_finite())) {
            return None;
        }
        let extent = bounds.max - bounds.min;
        if extent.min_element() < 0.0 || extent.max_element() <= 0.0 {
            return None;
        }
        // Cells of side `longest / CELLS_ALONG`, or larger where that would make more than
        // `max_cells` (a mesh whose box is nearly a cube).
        let volume = extent.max(Vec3::splat(extent.max_element() / CELLS_ALONG as f32));
        let mut cell = (extent.max_element() / CELLS_ALONG as f32).max((volume.x * volume.y * volume.z / max_cells.max(1) as f32).cbrt());
        let dims_of = |cell: f32| [0, 1, 2].map(|a| ((extent[a] / cell).floor() as usize + 1).min(CELLS_ALONG));
        // The cells of the box's far faces can overshoot the count: larger cells then.
        // (A side that rounds to zero or overflows has no grid: no loop without an end.)
        if !(cell > 0.0 && cell.is_finite()) {
            return None;
        }
        while dims_of(cell).iter().product::<usize>() > max_cells.max(1) {
            cell *= 1.05;
            if !cell.is_finite() {
                return None;
            }
        }
        let dims = dims_of(cell);
        let scale = quad.iter().chain([&bounds.min, &bounds.max]).fold(0f32, |m, p| m.max(p.abs().max_element()));
        let count = dims[0] * dims[1] * dims[2];
        Some(ShaftGrid {
            bounds: *bounds,
            cell,
            inv_cell: 1.0 / cell,
            dims,
            quad,
            scale,
            cells: (0..count).map(|_| OnceLock::new()).collect(),
        })
    }

    /// The box the grid covers (the mesh's, when made).
    #[must_use]
    pub fn bounds(&self) -> &Aabb {
        &self.bounds
    }

    /// The cell holding point `p`, or `None` outside the grid (or not finite).
    #[inline(always)]
    #[must_use]
    pub fn cell_of(&self, p: Vec3) -> Option<usize> {
        // A point within rounding of a cell's face may be given the cell beside it: the
        // shafts' slack covers that much.
        let c = (p - self.bounds.min) * self.inv_cell;
        let mut index = 0;
        for a in (0..3).rev() {
            // Not `c >= 0 && c < dims` negated: NaN fails both.
            if !(c[a] >= 0.0 && c[a] < self.dims[a] as f32) {
                return None;
            }
            index = index * self.dims[a] + c[a] as usize;
        }
        Some(index)
    }

    /// The box of cell `index`.
    fn cell_box(&self, index: usize) -> (Vec3, Vec3) {
        let (x, y, z) = (index % self.dims[0], index / self.dims[0] % self.dims[1], index / (self.dims[0] * self.dims[1]));
        let lo = self.bounds.min + Vec3::new(x as f32, y as f32, z as f32) * self.cell;
        (lo, lo + Vec3::splat(self.cell))
    }

    /// What cell `index`'s rays are answered from: the list of the triangles of `bvh` that
    /// a shadow ray from a point of the cell to the light may meet, or, past
    /// [`MAX_TRIANGLES`] of them, the cut of the tree where its rays' walks start. Made on
    /// the first call for the cell; the same on every call and every thread.
    #[must_use]
    pub fn cell<'a>(&'a self, bvh: &WideBvh, index: usize) -> &'a Cell {
        self.cells[index].get_or_init(|| self.make_cell(bvh, index))
    }

    /// How far a triangle must lie from a shaft for no shadow ray in the shaft to meet it
    /// in the triangle test's floats: Möller–Trumbore's `u`, `v` and `t` are products of
    /// the ray's offset from `v0` (at most twice [`ShaftGrid::scale`] in each coordinate),
    /// the edges and the direction, divided by the determinant, so their rounding, as a
    /// distance in the triangle's plane or along the ray, is a few units in the last place
    /// of `|s|·|e1|·|e2| / |e1 × e2|` (pbrt-v4 §6.8's bound is eight). Given 64 of those
    /// units, and infinite (the triangle is always kept) when the edges' cross product is
    /// zero in floats.
    fn triangle_margin(&self, e1: Vec3, e2: Vec3) -> f32 {
        let area2 = e1.cross(e2).length();
        let s = 4.0 * self.scale;
        let m = 64.0 * f32::EPSILON * s * e1.length() * e2.length() / area2;
        if m.is_finite() {
            m
        } else {
            f32::INFINITY
        }
    }

    /// Walks `bvh` with the shaft of cell `index` and gathers the triangles it meets; past
    /// [`MAX_TRIANGLES`], finds the cut of the tree where the cell's rays enter it.
    fn make_cell(&self, bvh: &WideBvh, index: usize) -> Cell {
        if bvh.watertight || bvh.root == EMPTY {
            return Cell::Tree;
        }
        let (lo, hi) = self.cell_box(index);
        // Where the shadow rays stop: `(1 - ε)·q + ε·o` for `q` on the light and `o` in the
        // cell, within `ε·|o - centre|` of `(1 - ε)·q + ε·centre`.
        let centre = (lo + hi) * 0.5;
        let ends = self.quad.map(|q| q * (1.0 - SHADOW_EPSILON) + centre * SHADOW_EPSILON);
        let points = hull_points(lo, hi, ends);
        // Slack for everything approximated: the ends' spread, the rounding of the cell's
        // and the shaft's own arithmetic (a few units in the last place of the scale).
        let slack = SHADOW_EPSILON * (hi - lo).length() + 64.0 * f32::EPSILON * self.scale;
        let planes = hull_planes(&points, slack);
        let (pmin, pmax) = points.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), p| (a.min(*p), b.max(*p)));
        // A triangle whose box lies beyond the hull's box by `m` is out (the hull's planes
        // are tried on its vertices below; nodes' boxes go through `lanes_within`).
        let box_out = |bmin: Vec3, bmax: Vec3, m: f32| (bmin - pmax).max_element() > m || (pmin - bmax).max_element() > m;
        // Whether lane `lane` of block `b` may meet the shaft: not out by its margin.
        let meets = |b: usize, lane: usize| {
            let t = &bvh.tris[b];
            if t.prim[lane] == EMPTY {
                return false;
            }
            let [v0, e1, e2] = t.lane(lane);
            let m = slack + self.triangle_margin(e1, e2);
            let (v1, v2) = (v0 + e1, v0 + e2);
            let out = m.is_finite() && {
                let (tmin, tmax) = (v0.min(v1).min(v2), v0.max(v1).max(v2));
                box_out(tmin, tmax, m) || planes.iter().any(|&(n, d)| [v0, v1, v2].iter().all(|p| n.dot(*p) - d > m)) || {
                    // The triangle's own plane, the shaft all on one side.
                    let n = e1.cross(e2).normalize_or_zero();
                    let d = n.dot(v0);
                    n != Vec3::ZERO && (points.iter().all(|p| n.dot(*p) - d > m) || points.iter().all(|p| n.dot(*p) - d < -m))
                }
            };
            !out
        };
        let mut found: Vec<(usize, usize)> = Vec::new();
        let mut stack = vec![bvh.root];
        while let Some(code) = stack.pop() {
            if code & LEAF != 0 {
                for b in leaf_blocks(code) {
                    for lane in (0..4).filter(|&l| meets(b, l)) {
                        if found.len() == MAX_TRIANGLES {
                            let block_meets = |b: usize| (0..4).any(|l| meets(b, l));
                            return entry(bvh, &planes, pmin, pmax, slack, block_meets).map_or(Cell::Tree, Cell::Entry);
                        }
                        found.push((b, lane));
                    }
                }
                continue;
            }
            // Inner-node codes are byte offsets of nodes.
            let node = &bvh.nodes[code as usize / std::mem::size_of::<Node8>()];
            // A box out by the slack is never entered by a ray of the shaft (the tree's
            // box test widens by a few units in the last place), so the tree never tests
            // its triangles either, whatever their margins.
            let mut kept = lanes_within(node, &planes, pmin, pmax, slack);
            while kept != 0 {
                let lane = kept.trailing_zeros() as usize;
                kept &= kept - 1;
                stack.push(node.child[lane]);
            }
        }
        let mut blocks = Vec::with_capacity(found.len().div_ceil(4));
        for group in found.chunks(4) {
            let mut t = Tri4::EMPTY;
            for (lane, &(b, l)) in group.iter().enumerate() {
                t.copy_lane(lane, &bvh.tris[b], l);
            }
            blocks.push(t);
        }
        Cell::List(blocks.into_boxed_slice())
    }
}

/// The cut of `bvh` through every subtree that the shaft (bounded by `planes` and the box
/// `pmin..pmax`, out by more than `m`) meets: every node a ray of the shaft enters lies
/// below one of its lanes (a box out of the shaft is never entered, see [`lanes_within`]),
/// so a walk from the cut gives the ray the tree's answer while skipping the tests above
/// it. Grown from the root's lanes in the shaft by opening, largest box first (the
/// likeliest to be entered), each inner lane whose own lanes in the shaft still fit in
/// eight. Then a leaf lane keeps only its runs of blocks with a triangle that may meet
/// the shaft (`block_meets`), each run a lane where lanes are left: the rays would test
/// the others for nothing. `None` when the root is a leaf.
fn entry(bvh: &WideBvh, planes: &[HalfSpace], pmin: Vec3, pmax: Vec3, m: f32, block_meets: impl Fn(usize) -> bool) -> Option<Box<Cut>> {
    if bvh.root & LEAF != 0 {
        return None;
    }
    // A leaf's runs of blocks with a triangle that may meet the shaft.
    let runs_of = |code: u32| {
        let mut runs: Vec<(usize, usize)> = Vec::new();
        for b in leaf_blocks(code).filter(|&b| block_meets(b)) {
            match runs.last_mut() {
                Some(run) if run.1 == b => run.1 = b + 1,
                _ => runs.push((b, b + 1)),
            }
        }
        runs
    };
    let leaf = |(first, end): (usize, usize)| LEAF | ((end - first - 1) as u32) << BLOCKS_SHIFT | first as u32;
    // A node's lanes in the shaft: (code, box, area, whether opening it was tried); a leaf
    // with no block in the shaft left out, one with a single run of them cut to it.
    let kept_lanes = |code: u32| {
        let node = &bvh.nodes[code as usize / std::mem::size_of::<Node8>()];
        let mut kept = lanes_within(node, planes, pmin, pmax, m);
        let mut out = Vec::new();
        while kept != 0 {
            let l = kept.trailing_zeros() as usize;
            kept &= kept - 1;
            let mut child = node.child[l];
            if child & LEAF != 0 {
                match runs_of(child)[..] {
                    [] => continue,
                    [run] => child = leaf(run),
                    _ => {}
                }
            }
            let lo = Vec3::new(node.lo[0][l], node.lo[1][l], node.lo[2][l]);
            let hi = Vec3::new(node.hi[0][l], node.hi[1][l], node.hi[2][l]);
            let e = hi - lo;
            out.push((child, lo, hi, e.x * e.y + e.y * e.z + e.z * e.x, false));
        }
        out
    };
    let mut cut = kept_lanes(bvh.root);
    // The largest inner lane not tried yet, opened if its lanes fit.
    while let Some(i) = (0..cut.len()).filter(|&i| cut[i].0 & LEAF == 0 && !cut[i].4).max_by(|&a, &b| cut[a].3.total_cmp(&cut[b].3)) {
        let below = kept_lanes(cut[i].0);
        if cut.len() - 1 + below.len() <= 8 {
            cut.swap_remove(i);
            cut.extend(below);
        } else {
            cut[i].4 = true;
        }
    }
    // The leaves' runs of blocks in the shaft, the largest leaves first.
    // PERF: on the conference room a third of the streams' block tests were of blocks with
    // no triangle in the shaft, nearly all of them in leaves that are lanes of the cut
    // (large leaves high in the tree: the room's walls, floor and table).
    cut.sort_by(|a, b| b.3.total_cmp(&a.3));
    let mut i = 0;
    while i < cut.len() {
        let (code, lo, hi, area, _) = cut[i];
        if code & LEAF == 0 {
            i += 1;
            continue;
        }
        let blocks = leaf_blocks(code);
        let runs = runs_of(code);
        if runs.len() == 1 && runs[0] == (blocks.start, blocks.end) || cut.len() - 1 + runs.len() > 8 {
            i += 1;
            continue;
        }
        cut.remove(i);
        for (n, &run) in runs.iter().enumerate() {
            cut.insert(i + n, (leaf(run), lo, hi, area, true));
        }
        i += runs.len();
    }
    let lanes: Vec<(u32, Vec3, Vec3)> = cut.iter().map(|&(code, lo, hi, _, _)| (code, lo, hi)).collect();
    bvh.cut(&lanes).map(Box::new)
}

/// The lanes of `node` with a child whose box is not out of the shaft (bounded by
/// `planes` and by the box `pmin..pmax`) by more than `m`, the eight boxes at once (loops
/// over the node's rows that the compiler vectorises).
/// PERF: the conference room's 11,093 lists at 16 spp took 123–141 ms of one core box by
/// box, 117–128 ms eight at once (three runs each).
// `!(x > m)` on purpose: a NaN distance keeps its box.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn lanes_within(node: &Node8, planes: &[HalfSpace], pmin: Vec3, pmax: Vec3, m: f32) -> u32 {
    let mut keep = [true; 8];
    for a in 0..3 {
        for (l, k) in keep.iter_mut().enumerate() {
            *k &= !(node.lo[a][l] - pmax[a] > m) & !(pmin[a] - node.hi[a][l] > m);
        }
    }
    for &(n, d) in planes {
        // Each box's corner nearest the inside of the plane: its low or high plane per axis.
        let row = |a: usize| if n[a] >= 0.0 { &node.lo[a] } else { &node.hi[a] };
        let (x, y, z) = (row(0), row(1), row(2));
        for (l, k) in keep.iter_mut().enumerate() {
            *k &= !(n.x * x[l] + n.y * y[l] + n.z * z[l] - d > m);
        }
    }
    (0..8).filter(|&l| keep[l] && node.child[l] != EMPTY).fold(0, |mask, l| mask | 1 << l)
}

/// The points whose convex hull is a cell's shaft: the box `lo..hi`'s eight corners (`x`
/// in bit 0 of their number, `y` in bit 1, `z` in bit 2), then the light's four corners
/// `ends` (pulled towards the cell, see [`ShaftGrid::make_cell`]).
fn hull_points(lo: Vec3, hi: Vec3, ends: [Vec3; 4]) -> [Vec3; 12] {
    let mut points = [Vec3::ZERO; 12];
    for (i, p) in points.iter_mut().take(8).enumerate() {
        *p = Vec3::new(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z });
    }
    points[8..].copy_from_slice(&ends);
    points
}

/// The box's twelve edges, as pairs of corner numbers (`x` in bit 0, `y` in bit 1, `z` in
/// bit 2): corners that differ in one bit.
const BOX_EDGES: [(usize, usize); 12] = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)];
/// The light's four edges and one triangle of its plane, as numbers of `points` in
/// [`hull_planes`] (its corners `corner`, `+u`, `+v`, `+u+v` are points 8 to 11).
const QUAD_EDGES: [(usize, usize); 4] = [(8, 9), (8, 10), (9, 11), (10, 11)];

/// The planes of the convex hull of a cell and the light, `points` being the cell's eight
/// corners then the light's four, facing out, each moved out past the farthest point, to
/// within `slack`. The hull's faces are the box's (which the hull's bounding box holds),
/// the light's own plane, and faces through a box edge and a light corner or through a
/// light edge and a box corner: the candidates tried, each kept when every point lies on
/// one side of it.
/// PERF: every plane through three of the twelve points, normalised before its sides were
/// tested, was most of the making of a cell's list: the conference room's 11,093 lists at
/// 16 spp took 117–128 ms of one core; the triples with a light corner only, unnormalised
/// (squared lengths against the squared slack), 78–90 ms; these 81 candidates 51–60 ms.
/// At the scene's own 4 spp the lists then no longer cost more than they save. The twelve
/// points' sides are then found for all the candidates at once, candidate by candidate
/// in a loop the compiler vectorises (the same floats as one candidate at a time,
/// `hull_planes_one_by_one` in the tests): 38% of the cells' instructions were that
/// loop, one candidate at a time.
fn hull_planes(points: &[Vec3; 12], slack: f32) -> Vec<HalfSpace> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        #[target_feature(enable = "avx2")]
        fn avx2(points: &[Vec3; 12], slack: f32) -> Vec<HalfSpace> {
            hull_planes_portable(points, slack)
        }
        // SAFETY: the CPU has AVX2, which is all `avx2` is compiled for.
        return unsafe { avx2(points, slack) };
    }
    hull_planes_portable(points, slack)
}

/// [`hull_planes`]' body, compiled for AVX2 where the CPU has it (no FMA contraction: the
/// same floats).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // one index into many rows: the loops vectorise
fn hull_planes_portable(points: &[Vec3; 12], slack: f32) -> Vec<HalfSpace> {
    let mut planes: Vec<HalfSpace> = Vec::new();
    let (xs, ys, zs): ([f32; 12], [f32; 12], [f32; 12]) = (points.map(|p| p.x), points.map(|p| p.y), points.map(|p| p.z));
    let slack2 = slack * slack;
    // Each candidate's normal (unnormalised), its squared length and offset, as rows; a
    // degenerate one keeps zeros, and its row is never read.
    let mut n = [[0f32; CANDIDATE_ROWS]; 3];
    let mut d = [0f32; CANDIDATE_ROWS];
    let mut len2 = [0f32; CANDIDATE_ROWS];
    for (c, &(i, j, k)) in HULL_CANDIDATES.iter().enumerate() {
        let nc = (points[j] - points[i]).cross(points[k] - points[i]);
        len2[c] = nc.length_squared();
        if len2[c] > 0.0 && len2[c].is_finite() {
            (n[0][c], n[1][c], n[2][c]) = (nc.x, nc.y, nc.z);
            d[c] = nc.dot(points[i]);
        }
    }
    // The points' signed distances (times the normal's length), least and greatest.
    let (mut lo, mut hi) = ([0f32; CANDIDATE_ROWS], [0f32; CANDIDATE_ROWS]);
    for p in 0..12 {
        let (x, y, z) = (xs[p], ys[p], zs[p]);
        for c in 0..CANDIDATE_ROWS {
            let s = n[0][c] * x + n[1][c] * y + n[2][c] * z - d[c];
            lo[c] = lo[c].min(s);
            hi[c] = hi[c].max(s);
        }
    }
    // Which side each candidate faces out to, if any (a loop the compiler vectorises): every
    // point on the inner side, within the slack (`hi <= slack·|n|`, squared), or every
    // point on the outer side (the plane then turned over).
    let (mut out, mut flip) = ([false; CANDIDATE_ROWS], [false; CANDIDATE_ROWS]);
    for c in 0..CANDIDATE_ROWS {
        let valid = len2[c] > 0.0 && len2[c].is_finite();
        out[c] = valid & (hi[c] <= 0.0 || hi[c] * hi[c] <= slack2 * len2[c]);
        flip[c] = valid & !out[c] & (lo[c] >= 0.0 || lo[c] * lo[c] <= slack2 * len2[c]);
    }
    for c in (0..HULL_CANDIDATES.len()).filter(|&c| out[c] | flip[c]) {
        let nc = Vec3::new(n[0][c], n[1][c], n[2][c]);
        // Moved out past the farthest point so that the plane holds them all.
        let len = len2[c].sqrt();
        let plane = if out[c] { (nc / len, (d[c] + hi[c]) / len) } else { (-nc / len, (-d[c] - lo[c]) / len) };
        if !planes.iter().any(|(m, e)| m.dot(plane.0) > 1.0 - 1e-6 && (e - plane.1).abs() <= slack) {
            planes.push(plane);
        }
    }
    planes
}

/// The hull's candidate faces as numbers of [`hull_planes`]' points: a box edge and a
/// light corner, a light edge and a box corner, and the light's plane.
const HULL_CANDIDATES: [(usize, usize, usize); 81] = {
    let (out, n) = edges_with(([(0, 0, 0); 81], 0), &BOX_EDGES, 8..12);
    let (mut out, n) = edges_with((out, n), &QUAD_EDGES, 0..8);
    out[n] = (8, 9, 10);
    assert!(n + 1 == 81);
    out
};

/// `faces` (its first `n` written) followed by every edge of `edges` with every point of
/// `points`, edge by edge.
const fn edges_with(
    (mut faces, mut n): ([(usize, usize, usize); 81], usize),
    edges: &[(usize, usize)],
    points: std::ops::Range<usize>,
) -> ([(usize, usize, usize); 81], usize) {
    let mut e = 0;
    while e < edges.len() {
        let mut p = points.start;
        while p < points.end {
            faces[n] = (edges[e].0, edges[e].1, p);
            n += 1;
            p += 1;
        }
        e += 1;
    }
    (faces, n)
}

/// [`HULL_CANDIDATES`] rounded up to whole rows of eight lanes.
const CANDIDATE_ROWS: usize = HULL_CANDIDATES.len().div_ceil(8) * 8;

/// True when a triangle of `list` meets `ray` in `[t_min, t_max)`, by the tree's own
/// triangle test.
#[inline]
#[must_use]
pub fn occluded_by(list: &[Tri4], ray: &Ray, t_min: f32, t_max: f32) -> bool {
    list.iter().any(|t| block_any_hit(t, ray, t_min, t_max))
}

/// The lanes of `mask` (rays of `rays` that all leave from `origin`, bit for bit) that a
/// triangle of `list` meets within their intervals: [`occluded_by`] for each, the same
/// answers, with what depends on the origin alone (`s = o - v0`, `q = s × e1`, `e2·q`)
/// computed once per triangle rather than per ray.
#[must_use]
pub fn fan_occluded(list: &[Tri4], origin: Vec3, rays: &RayLanes, mask: u32) -> u32 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { fan_occluded_avx2(list, origin, rays, mask) };
    }
    lanes_of(mask).filter(|&k| occluded_by(list, &rays.ray(k), rays.t_min[k], rays.t_max[k])).fold(0, |m, k| m | 1 << k)
}

/// [`fan_occluded`] eight lanes at a time: Möller–Trumbore as the tree's kernels compute
/// it (the same products and sums in the same order, no fused multiply-adds), so the same
/// floats and the same answers.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn fan_occluded_avx2(list: &[Tri4], o: Vec3, rays: &RayLanes, mask: u32) -> u32 {
    use super::wide::origin_part_avx2;
    use std::arch::x86_64::*;
    let mut blocked = 0u32;
    for half in 0..LANES / 8 {
        let open = (mask >> (8 * half)) & 0xff;
        if open == 0 {
            continue;
        }
        // SAFETY: eight-float loads from eight-float slices of the lanes' rows.
        let ld = |row: &[f32; LANES]| unsafe { _mm256_loadu_ps(row[8 * half..].as_ptr()) };
        let (dx, dy, dz) = (ld(&rays.d[0]), ld(&rays.d[1]), ld(&rays.d[2]));
        let (t_min, t_max) = (ld(&rays.t_min), ld(&rays.t_max));
        let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
        let mut hit = 0u32;
        let (mul, sub, add) = (|a, b| _mm256_mul_ps(a, b), |a, b| _mm256_sub_ps(a, b), |a, b| _mm256_add_ps(a, b));
        let origin = [_mm256_set1_ps(o.x), _mm256_set1_ps(o.y), _mm256_set1_ps(o.z)];
        'tris: for tri in list {
            // The origin's part of the block's four triangles at once, as the streams
            // compute it for rays of one origin: the same operations, so the same floats.
            // PERF: with the triangles' values broadcast from memory (one load each) instead
            // of a lane's vectors gathered by shuffles, the fans' share of the conference
            // room fell from 7% to 5.6%: 0.955 and 0.988 of the CPU time (32 and 64 spp, 9
            // and 7 pairs). Skipping the division when no lane can pass (the packets'
            // filter) gained nothing more (1.011).
            // SAFETY: AVX2 (and so AVX) is enabled here.
            let (s, q, t_num) = unsafe { origin_part_avx2(tri, origin).low_rows() };
            for l in (0..4).filter(|&l| tri.prim[l] != EMPTY) {
                // Broadcasts straight from memory: one load each, no shuffles.
                let b = |x: &f32| _mm256_broadcast_ss(x);
                let (e1, e2) = (&tri.e1, &tri.e2);
                // p = d × e2
                let px = sub(mul(dy, b(&e2[2][l])), mul(dz, b(&e2[1][l])));
                let py = sub(mul(dz, b(&e2[0][l])), mul(dx, b(&e2[2][l])));
                let pz = sub(mul(dx, b(&e2[1][l])), mul(dy, b(&e2[0][l])));
                let det = add(add(mul(b(&e1[0][l]), px), mul(b(&e1[1][l]), py)), mul(b(&e1[2][l]), pz));
                let inv = _mm256_div_ps(one, det);
                let u = mul(add(add(mul(b(&s[0][l]), px), mul(b(&s[1][l]), py)), mul(b(&s[2][l]), pz)), inv);
                let v = mul(add(add(mul(dx, b(&q[0][l])), mul(dy, b(&q[1][l]))), mul(dz, b(&q[2][l]))), inv);
                let t = mul(b(&t_num[l]), inv);
                let mut m = _mm256_cmp_ps::<_CMP_NEQ_UQ>(det, zero);
                m = _mm256_and_ps(m, _mm256_cmp_ps::<_CMP_GE_OQ>(u, zero));
                m = _mm256_and_ps(m, _mm256_cmp_ps::<_CMP_LE_OQ>(u, one));
                m = _mm256_and_ps(m, _mm256_cmp_ps::<_CMP_GE_OQ>(v, zero));
                m = _mm256_and_ps(m, _mm256_cmp_ps::<_CMP_LE_OQ>(add(u, v), one));
                m = _mm256_and_ps(m, _mm256_cmp_ps::<_CMP_GE_OQ>(t, t_min));
                m = _mm256_and_ps(m, _mm256_cmp_ps::<_CMP_LT_OQ>(t, t_max));
                hit |= _mm256_movemask_ps(m) as u32 & open;
                if hit == open {
                    break 'tris;
                }
            }
        }
        blocked |= hit << (8 * half);
    }
    blocked
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Accel;
    use crate::geometry::{MeshAccel, TriangleMesh};
    use crate::math::ray::RaySegment;
    use crate::math::sampling::Sampler;

    /// Small triangles (a few of them slivers) scattered over a floor, under a quad light:
    /// the mesh, its tree and the light's corner and edges.
    fn room(seed: u64) -> (TriangleMesh, Vec3, Vec3, Vec3) {
        let mut rng = Sampler::from_seed(seed);
        let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
        let mut vertices =
            vec![Vec3::new(-10.0, 0.0, -10.0), Vec3::new(10.0, 0.0, -10.0), Vec3::new(-10.0, 0.0, 10.0), Vec3::new(10.0, 0.0, 10.0)];
        let mut triangles = vec![[0, 2, 1], [1, 2, 3]];
        for i in 0..1500u32 {
            let c = Vec3::new(r(-9.0, 9.0), r(0.2, 6.0), r(-9.0, 9.0));
            let a = c + Vec3::new(r(-0.6, 0.6), r(-0.6, 0.6), r(-0.6, 0.6));
            let b = c + Vec3::new(r(-0.6, 0.6), r(-0.6, 0.6), r(-0.6, 0.6));
            // Every tenth a sliver: its third vertex all but on the line of the first two.
            let d =
                if i % 10 == 0 { a + (b - a) * 0.37 + Vec3::splat(1e-6) } else { c + Vec3::new(r(-0.6, 0.6), r(-0.6, 0.6), r(-0.6, 0.6)) };
            let n = vertices.len() as u32;
            vertices.extend([a, b, d]);
            triangles.push([n, n + 1, n + 2]);
        }
        let mut mesh = TriangleMesh::new(vertices, Vec::new(), triangles);
        mesh.build_accel(Accel::BvhSah);
        (mesh, Vec3::new(-4.0, 8.0, -3.0), Vec3::new(8.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 6.0))
    }

    /// [`room`] and the grid of its light.
    fn room_and_grid(seed: u64) -> (TriangleMesh, ShaftGrid, [Vec3; 3]) {
        let (mesh, corner, u, v) = room(seed);
        let grid = ShaftGrid::new(&mesh.aabb(), corner, u, v, MAX_CELLS).unwrap();
        (mesh, grid, [corner, u, v])
    }

    /// A point of [`room`]: on the floor in even rounds, in the air among the triangles in
    /// odd ones.
    fn origin_in_room(rng: &mut Sampler, round: usize) -> Vec3 {
        let y = if round.is_multiple_of(2) { 1e-3 } else { 6.0 * rng.next_f32() };
        Vec3::new(20.0 * rng.next_f32() - 10.0, y, 20.0 * rng.next_f32() - 10.0)
    }

    fn wide(mesh: &TriangleMesh) -> &WideBvh {
        let MeshAccel::Wide(w) = mesh.accel() else { panic!("the SAH build is a wide tree") };
        w
    }

    /// Sixteen shadow rays from `origin` to points of the light, as `spawn_ray_to` makes
    /// them, a few of them invalid or empty.
    fn fan(origin: Vec3, corner: Vec3, u: Vec3, v: Vec3, rng: &mut Sampler, round: usize) -> Vec<RaySegment> {
        (0..LANES)
            .map(|k| {
                let target = corner + u * rng.next_f32() + v * rng.next_f32();
                let to = target - origin;
                let mut direction = to.normalize();
                let mut t_max = to.length() * (1.0 - 1e-4);
                match (round + k) % 29 {
                    0 => direction = Vec3::ZERO,
                    1 => direction.x = f32::NAN,
                    2 => t_max = -1.0,
                    _ => {}
                }
                RaySegment { origin, t_min: 0.0, direction, t_max }
            })
            .collect()
    }

    #[test]
    fn lists_answer_as_the_tree() {
        for seed in [1, 2] {
            let (mesh, grid, [corner, u, v]) = room_and_grid(seed);
            let bvh = wide(&mesh);
            let mut rng = Sampler::from_seed(seed + 10);
            let (mut listed, mut traced, mut blocked, mut open) = (0, 0, 0, 0);
            for round in 0..4500 {
                let origin = origin_in_room(&mut rng, round);
                let rays = fan(origin, corner, u, v, &mut rng, round);
                let Some(Cell::List(list)) = grid.cell_of(origin).map(|c| grid.cell(bvh, c)) else {
                    traced += 1;
                    continue;
                };
                listed += 1;
                assert!(list.len() * 4 <= MAX_TRIANGLES.next_multiple_of(4));
                let lanes = RayLanes::new(&rays);
                let mask = if round % 3 == 0 { u32::MAX >> (32 - LANES) } else { (rng.next_f32().to_bits() >> 5) & 0xffff };
                let got = fan_occluded(list, origin, &lanes, mask);
                for (k, r) in rays.iter().enumerate() {
                    let tree = bvh.occluded(&r.ray(), r.t_min, r.t_max);
                    assert_eq!(occluded_by(list, &r.ray(), r.t_min, r.t_max), tree, "seed {seed}, round {round}, ray {k}: {r:?}");
                    assert_eq!(got & (1 << k) != 0, mask & (1 << k) != 0 && tree, "fan, seed {seed}, round {round}, ray {k}");
                    if mask & (1 << k) != 0 && r.ray().is_valid() && r.t_max > 0.0 {
                        *(if tree { &mut blocked } else { &mut open }) += 1;
                    }
                }
            }
            assert!(listed > 300 && traced > 300, "seed {seed}: {listed} fans from listed cells, {traced} from cells that trace");
            assert!(blocked > 500 && open > 500, "seed {seed}: {blocked} blocked, {open} open");
        }
    }

    /// The cells whose shafts meet too many triangles start their rays' walks at a cut of
    /// the tree: every ray gets the tree's answer from the root, in streams of one to four
    /// origins, and the cuts go below the root's own lanes (else they would skip nothing).
    /// A cut is used only on the tree it was cut from.
    #[test]
    fn cuts_answer_as_the_tree() {
        for seed in [3, 4] {
            let (mesh, grid, [corner, u, v]) = room_and_grid(seed);
            let bvh = wide(&mesh);
            let root = &bvh.nodes[bvh.root as usize / std::mem::size_of::<Node8>()];
            let mut rng = Sampler::from_seed(seed + 20);
            let (mut streams, mut deeper, mut blocked, mut open) = (0, 0, 0, 0);
            for round in 0..3000 {
                // A cell with a cut, and up to four origins in it.
                let origin = origin_in_room(&mut rng, round);
                let Some(c) = grid.cell_of(origin) else { continue };
                let Cell::Entry(cut) = grid.cell(bvh, c) else { continue };
                let node = cut.node_in(bvh).expect("cut from this tree");
                deeper += usize::from(node.child.iter().any(|&code| code != EMPTY && !root.child.contains(&code)));
                let origins: Vec<Vec3> = (0..1 + round % 4)
                    .map(|i| if i == 0 { origin } else { origin + Vec3::new(1e-3, 0.0, 1e-3) * i as f32 })
                    .filter(|&o| grid.cell_of(o) == Some(c))
                    .collect();
                // Two batches of sixteen, each lane from one of the origins.
                let batches: [Vec<RaySegment>; 2] = std::array::from_fn(|b| {
                    let mut rays = Vec::new();
                    for (i, &o) in origins.iter().enumerate() {
                        rays.extend(fan(o, corner, u, v, &mut rng, round + i + b).into_iter().take(LANES / 2));
                    }
                    let first = rays[0];
                    rays.resize(LANES, first);
                    let n = rays.len();
                    rays.rotate_left(b * LANES / 2 % n);
                    rays
                });
                let lanes = [RayLanes::new(&batches[0]), RayLanes::new(&batches[1])];
                let mask = [0xffff, if round % 3 == 0 { 0 } else { (rng.next_f32().to_bits() >> 5) & 0xffff }];
                let got = bvh.occluded_lane_pair_from(Some(cut), [&lanes[0], &lanes[1]], mask);
                streams += 1;
                for b in 0..2 {
                    for (k, r) in batches[b].iter().enumerate() {
                        let tree = bvh.occluded(&r.ray(), r.t_min, r.t_max);
                        assert_eq!(
                            got[b] & (1 << k) != 0,
                            mask[b] & (1 << k) != 0 && tree,
                            "seed {seed}, round {round}, batch {b}, ray {k}: {r:?}"
                        );
                        if mask[b] & (1 << k) != 0 && r.ray().is_valid() && r.t_max > 0.0 {
                            *(if tree { &mut blocked } else { &mut open }) += 1;
                        }
                    }
                }
            }
            assert!(
                streams > 300 && deeper > streams / 2,
                "seed {seed}: {streams} streams from cuts, {deeper} of them below the root's lanes"
            );
            assert!(blocked > 1000 && open > 1000, "seed {seed}: {blocked} blocked, {open} open");
            // Another tree (a copy: other arrays) does not take the cut.
            let copy = bvh.clone();
            let cut = (0..grid.cells.len()).find_map(|c| match grid.cells[c].get() {
                Some(Cell::Entry(cut)) => Some(cut),
                _ => None,
            });
            assert!(cut.unwrap().node_in(&copy).is_none() && cut.unwrap().node_in(bvh).is_some());
            // No cut of codes that are not this tree's below its root, or of more than eight.
            let (lo, hi) = (Vec3::ZERO, Vec3::ONE);
            let child = *root.child.iter().find(|&&c| c != EMPTY).unwrap();
            assert!(bvh.cut(&[(child, lo, hi)]).is_some());
            assert!(bvh.cut(&[(child, lo, hi); 9]).is_none());
            assert!(bvh.cut(&[(bvh.root, lo, hi)]).is_none());
            assert!(bvh.cut(&[(EMPTY, lo, hi)]).is_none());
            assert!(bvh.cut(&[(LEAF | bvh.tris.len() as u32, lo, hi)]).is_none());
            assert!(bvh.cut(&[((bvh.nodes.len() * std::mem::size_of::<Node8>()) as u32, lo, hi)]).is_none());
            assert!(bvh.cut(&[(child + 4, lo, hi)]).is_none() || child & LEAF != 0);
        }
    }

    #[test]
    fn fans_in_avx2_answer_as_one_ray_at_a_time() {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            let (mesh, corner, u, v) = room(3);
            let bvh = wide(&mesh);
            let mut rng = Sampler::from_seed(4);
            for round in 0..2000 {
                // Lists of the tree's own blocks, one to six of them.
                let first = (rng.next_f32() * (bvh.tris.len() - 6) as f32) as usize;
                let list = &bvh.tris[first..first + 1 + round % 6];
                let origin = Vec3::new(20.0 * rng.next_f32() - 10.0, 6.0 * rng.next_f32(), 20.0 * rng.next_f32() - 10.0);
                let rays = fan(origin, corner, u, v, &mut rng, round);
                let lanes = RayLanes::new(&rays);
                let mask = (rng.next_f32().to_bits() >> 5) & 0xffff;
                // SAFETY: the CPU has AVX2 (checked above).
                let got = unsafe { fan_occluded_avx2(list, origin, &lanes, mask) };
                let one_by_one =
                    lanes_of(mask).filter(|&k| occluded_by(list, &rays[k].ray(), rays[k].t_min, rays[k].t_max)).fold(0, |m, k| m | 1 << k);
                assert_eq!(got, one_by_one, "round {round}");
            }
        }
    }

    /// A fan's rays each aimed at a triangle of the list and ending exactly where the
    /// single ray's first hit stops counting (its `t` and the float just past it): the
    /// fan's `t` must be the single ray's to the last bit, or one of the two answers
    /// differs. (Fails with `e2·q` summed in another order.) Through [`fan_occluded`]: the
    /// AVX2 kernel where the CPU has it.
    #[test]
    fn fans_end_exactly_where_single_rays_do() {
        let (mesh, _, _, _) = room(5);
        let bvh = wide(&mesh);
        let mut rng = Sampler::from_seed(6);
        let (mut at, mut past) = (0, 0);
        for round in 0..400 {
            let first = (rng.next_f32() * (bvh.tris.len() - 4) as f32) as usize;
            let list = &bvh.tris[first..first + 1 + round % 4];
            let origin = Vec3::new(20.0 * rng.next_f32() - 10.0, 6.0 * rng.next_f32(), 20.0 * rng.next_f32() - 10.0);
            let mut rays = Vec::new();
            for k in 0..LANES {
                let tri = &list[k % list.len()];
                let l = (k / list.len()) % 4;
                if tri.prim[l] == EMPTY {
                    continue;
                }
                let [v0, e1, e2] = tri.lane(l);
                let (a, b) = (0.1 + 0.4 * rng.next_f32(), 0.1 + 0.4 * rng.next_f32());
                let ray = RaySegment { origin, t_min: 0.0, direction: v0 + e1 * a + e2 * b - origin, t_max: f32::INFINITY };
                if !occluded_by(list, &ray.ray(), 0.0, f32::INFINITY) {
                    continue;
                }
                // The least `t_max` for which the single ray is blocked (it needs `t < t_max`).
                let (mut lo, mut hi) = (0u32, f32::INFINITY.to_bits());
                while hi - lo > 1 {
                    let mid = lo + (hi - lo) / 2;
                    if occluded_by(list, &ray.ray(), 0.0, f32::from_bits(mid)) {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                let end = if k % 2 == 0 { hi } else { lo };
                rays.push(RaySegment { t_max: f32::from_bits(end), ..ray });
            }
            if rays.len() < 2 {
                continue;
            }
            let lanes = RayLanes::new(&rays);
            let mask = u32::MAX >> (32 - rays.len());
            let got = fan_occluded(list, origin, &lanes, mask);
            for (k, r) in rays.iter().enumerate() {
                let one = occluded_by(list, &r.ray(), r.t_min, r.t_max);
                assert_eq!(got & (1 << k) != 0, one, "round {round}, ray {k}: {r:?}");
                *(if one { &mut past } else { &mut at }) += 1;
            }
        }
        assert!(at > 1000 && past > 1000, "{at} rays ending at their hit, {past} just past it");
    }

    #[test]
    fn grids_refuse_what_they_cannot_cover() {
        let (corner, u, v) = (Vec3::new(0.0, 5.0, 0.0), Vec3::X, Vec3::Z);
        assert!(ShaftGrid::new(&Aabb::EMPTY, corner, u, v, MAX_CELLS).is_none());
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert!(ShaftGrid::new(&b, Vec3::splat(f32::NAN), u, v, MAX_CELLS).is_none());
        assert!(ShaftGrid::new(&Aabb::new(Vec3::ZERO, Vec3::new(f32::INFINITY, 1.0, 1.0)), corner, u, v, MAX_CELLS).is_none());
        // A cube is cut into at most `max_cells` cells; a flat box into one layer.
        for max in [MAX_CELLS, 1000, 1] {
            let g = ShaftGrid::new(&b, corner, u, v, max).unwrap();
            assert!(g.cells.len() <= max, "{} cells for at most {max}", g.cells.len());
        }
        // Boxes too small or too large for a cell size in floats: none, and no hang.
        assert!(ShaftGrid::new(&Aabb::new(Vec3::ZERO, Vec3::splat(1e-44)), corner, u, v, MAX_CELLS).is_none());
        assert!(ShaftGrid::new(&Aabb::new(Vec3::splat(-3e38), Vec3::splat(3e38)), corner, u, v, MAX_CELLS).is_none());
        let tiny = ShaftGrid::new(&Aabb::new(Vec3::ZERO, Vec3::splat(1e-20)), corner, u, v, MAX_CELLS).unwrap();
        assert!(tiny.cells.len() <= MAX_CELLS && tiny.cell_of(Vec3::splat(5e-21)).is_some());
        let flat = ShaftGrid::new(&Aabb::new(Vec3::ZERO, Vec3::new(4.0, 0.0, 2.0)), corner, u, v, MAX_CELLS).unwrap();
        assert_eq!(flat.dims, [CELLS_ALONG, 1, CELLS_ALONG / 2 + 1]);
        let g = ShaftGrid::new(&b, corner, u, v, MAX_CELLS).unwrap();
        for p in [Vec3::splat(-0.01), Vec3::splat(1.5), Vec3::new(0.5, f32::NAN, 0.5), Vec3::splat(f32::INFINITY)] {
            assert_eq!(g.cell_of(p), None, "{p}");
        }
        for p in [Vec3::ZERO, Vec3::splat(0.5), Vec3::splat(0.999)] {
            let c = g.cell_of(p).unwrap();
            let (lo, hi) = g.cell_box(c);
            assert!((lo - Vec3::splat(1e-5)).cmple(p).all() && p.cmple(hi + Vec3::splat(1e-5)).all(), "{p} in {lo}..{hi}");
        }
    }

    /// [`hull_planes`] one candidate at a time, the candidates listed by iterators (the
    /// form before the rows and [`HULL_CANDIDATES`]): the reference its rows must match
    /// float for float.
    fn hull_planes_one_by_one(points: &[Vec3; 12], slack: f32) -> Vec<HalfSpace> {
        let mut planes: Vec<HalfSpace> = Vec::new();
        let slack2 = slack * slack;
        // The candidates as the one-by-one form listed them.
        let candidates = BOX_EDGES
            .iter()
            .flat_map(|&(a, b)| (8..12).map(move |q| (a, b, q)))
            .chain(QUAD_EDGES.iter().flat_map(|&(a, b)| (0..8).map(move |c| (a, b, c))))
            .chain(std::iter::once((8, 9, 10)));
        for (i, j, k) in candidates {
            let n = (points[j] - points[i]).cross(points[k] - points[i]);
            let len2 = n.length_squared();
            if !(len2 > 0.0 && len2.is_finite()) {
                continue;
            }
            let d = n.dot(points[i]);
            let (mut lo, mut hi) = (0f32, 0f32);
            for p in points {
                let s = n.x * p.x + n.y * p.y + n.z * p.z - d;
                lo = lo.min(s);
                hi = hi.max(s);
            }
            let plane = if hi <= 0.0 || hi * hi <= slack2 * len2 {
                let len = len2.sqrt();
                (n / len, (d + hi) / len)
            } else if lo >= 0.0 || lo * lo <= slack2 * len2 {
                let len = len2.sqrt();
                (-n / len, (-d - lo) / len)
            } else {
                continue;
            };
            if !planes.iter().any(|(m, e)| m.dot(plane.0) > 1.0 - 1e-6 && (e - plane.1).abs() <= slack) {
                planes.push(plane);
            }
        }
        planes
    }

    #[test]
    fn hull_planes_are_those_found_one_by_one() {
        let bits = |planes: &[HalfSpace]| planes.iter().map(|(n, d)| (n.to_array().map(f32::to_bits), d.to_bits())).collect::<Vec<_>>();
        let mut rng = Sampler::from_seed(7);
        let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
        let mut kept = 0;
        for round in 0..2000 {
            // Cells of every size about a light of every size and slant; some cells touch
            // or straddle the light's plane, some lights are lines or points.
            let size = [1e-3, 0.1, 1.0, 30.0][round % 4];
            let lo = Vec3::new(r(-5.0, 5.0), r(-5.0, 5.0), r(-5.0, 5.0));
            let hi = lo + Vec3::new(r(0.0, size), r(0.0, size), r(0.0, size));
            let corner = Vec3::new(r(-8.0, 8.0), r(-2.0, 9.0), r(-8.0, 8.0));
            let u = if round % 7 == 0 { Vec3::ZERO } else { Vec3::new(r(-4.0, 4.0), r(-0.5, 0.5), r(-4.0, 4.0)) };
            let v = if round % 11 == 0 { u * 0.5 } else { Vec3::new(r(-4.0, 4.0), r(-0.5, 0.5), r(-4.0, 4.0)) };
            let points = hull_points(lo, hi, [corner, corner + u, corner + v, corner + u + v]);
            let slack = [0.0, 1e-6, 1e-3][round % 3];
            let (rows, one) = (hull_planes(&points, slack), hull_planes_one_by_one(&points, slack));
            assert_eq!(bits(&rows), bits(&one), "round {round}");
            assert_eq!(bits(&hull_planes_portable(&points, slack)), bits(&one), "round {round}, portable");
            kept += rows.len();
        }
        // The hulls have faces: the comparison compared planes.
        assert!(kept > 2000 * 5, "{kept} planes");
    }
}
