//! The planes that cannot block a quad light's shadow rays from a point, proved for all
//! of that point's rays at once instead of tested ray by ray. In the TP3 and TP6 rooms,
//! every wall used to be tested against every shadow ray, and from a point inside the room
//! towards a light inside it, none can block. The proof comes in three steps:
//! - a table per quad light and scene ([`QuadPlanes`], made by `Scene::prepare`);
//! - per box of origins (a pixel's hits), which planes the light is far enough from
//!   ([`QuadPlanes::for_box`]);
//! - per origin, which side of each plane it is on ([`QuadPlanes::clear`], eight planes
//!   in one register).
//!
//! The proof is about the floats of [`Plane::hit_lanes`] for the rays that
//! [`ShadowRays::to`] makes from an origin `o` towards points `q = corner + x·u + y·v` of
//! the light (`x`, `y` in `[0, 1]`, computed in `f32` as `LightSampler::sample` does). A
//! lane's `t` is `num / denom`: `num = (p - o) · n` is the same for every ray from `o`,
//! and `denom = d · n`, `d` the ray's unit direction. The lane meets the plane when
//! `denom != 0`, `t >= t_min` (0) and `t < t_max` (`1 - 10⁻⁴` of the distance to `q`).
//!
//! Let `g` be the signed distance to the plane, positive on `o`'s side as `num`'s sign
//! says, and let `G`, the least `g` of the light's corners, exceed `E·reach + 2·(err +
//! jitter)`. Here `E` bounds `denom`'s error, `reach` bounds `|q - o|`, `err` bounds
//! `num`'s error as `-g(o)`, and `jitter` bounds the light points' distance from the exact
//! quad. Then for each ray, one of two things holds.
//! - `g(q) - g(o) ≥ E·|q - o|`. Then `denom` has the sign that makes `t` negative (`|num|`
//!   is at least 10⁻³⁰, so `t` is not ±0).
//! - Otherwise `g(o)` is positive, and where the float `t` is not negative it is at least
//!   `(1 - ε)·|num|·|q - o| / (g(o) - g(q) + E·|q - o|)`. With `|num| ≥ g(o) - err` and
//!   `g(q) ≥ G - jitter`, that is at least `(1 - ε)·|q - o|`, beyond `t_max`.
//!
//! The bounds are loose on purpose:
//! - `E = 10⁻⁵`: `denom`'s error is at most nine rounding units of a unit vector.
//! - `err = 10⁻⁶` of the sum of `p`'s and `o`'s coordinates' magnitudes (four units).
//! - `jitter = 10⁻⁶` of the light's coordinates' sum (three units).
//! - `t_max` is at most `0.9999006` of `|q - o|`.
//!
//! `G` and the bounds are computed in `f64`, then rounded towards "not proved". For a box
//! of origins, `reach` and `err` are taken at their largest over the box. `num` is computed
//! per origin by the lane test's own operations. The tests in `integrators::shadow` check
//! the proofs against the lane tests of many rays.
//!
//! [`ShadowRays::to`]: crate::math::ray::ShadowRays::to

use crate::geometry::{Geometry, Plane};
use crate::lights::Light;
use glam::{DVec3, Vec3};

use super::Object;

/// The planes a table holds, at most (the first ones of the scene's first 64 objects).
const PLANES: usize = 8;
/// `num`'s error as the origin's distance to the plane, over the sum of the magnitudes
/// of `p`'s and `o`'s coordinates (at most four rounding units, 4.8·10⁻⁷).
const NUM_ERROR: f64 = 1e-6;
/// `denom`'s error bound (at most nine rounding units, 1.1·10⁻⁶).
const DENOM_ERROR: f64 = 1e-5;

/// One quad light's table: its planes' points and normals side by side, and what does not
/// depend on the origin.
#[derive(Clone, Debug)]
pub(crate) struct QuadPlanes {
    /// The light's corner and edges, as the table was made for them.
    light: [Vec3; 3],
    /// The number of objects when the table was made.
    objects: usize,
    /// The quad's centre, and half its longer diagonal with the jitter, raised by 10⁻⁴
    /// (so that `|q - o| ≤ |o - centre|₁ + reach` as computed in `f32`).
    center: [f32; 3],
    reach: f32,
    /// The planes: how many, their object indices (the first when they follow each
    /// other), points and normals by axis.
    count: usize,
    object: [u8; PLANES],
    first: Option<u8>,
    point: [[f32; PLANES]; 3],
    normal: [[f32; PLANES]; 3],
    /// Per plane, `G - 2·(err + jitter)` but for the origin's terms, rounded down: for an
    /// origin on the plane's front (`num < 0`), then on its back.
    least: [[f32; PLANES]; 2],
}

/// [`QuadPlanes::for_box`]: a box of origins and, per side of each plane (front, back),
/// the planes (bit `j` for the table's plane `j`) proved clear for the origins of the
/// box on that side.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BoxProof {
    lo: [f32; 3],
    hi: [f32; 3],
    side: [u32; 2],
}

/// `x` rounded towards −∞ to an `f32` (NaN stays NaN).
fn down(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) > x {
        f.next_down()
    } else {
        f
    }
}

/// `x` rounded towards +∞ to an `f32` (NaN stays NaN).
fn up(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) < x {
        f.next_up()
    } else {
        f
    }
}

impl QuadPlanes {
    /// The tables of `lights`' quad lights, for the first [`PLANES`] planes among the
    /// first 64 of `objects`; none without a plane there.
    pub(crate) fn of(lights: &[Light], objects: &[Object]) -> Vec<QuadPlanes> {
        let planes: Vec<(usize, Plane)> = objects
            .iter()
            .enumerate()
            .take(64)
            .filter_map(|(i, o)| if let Geometry::Plane(p) = o.geometry { Some((i, p)) } else { None })
            .take(PLANES)
            .collect();
        if planes.is_empty() {
            return Vec::new();
        }
        let l1 = |a: DVec3| a.x.abs() + a.y.abs() + a.z.abs();
        lights
            .iter()
            .filter_map(|light| {
                let Light::Quad { corner, u, v, .. } = *light else { return None };
                let (c, ud, vd) = (corner.as_dvec3(), u.as_dvec3(), v.as_dvec3());
                let jitter = 1e-6 * (l1(c) + l1(ud) + l1(vd));
                let center = c + 0.5 * (ud + vd);
                let reach = 0.5 * (ud + vd).length().max((ud - vd).length()) + jitter;
                let first = planes[0].0;
                let mut table = QuadPlanes {
                    light: [corner, u, v],
                    objects: objects.len(),
                    center: center.to_array().map(|x| x as f32),
                    // The centre's rounding to `f32` is in the reach.
                    reach: up((reach + 1e-6 * l1(center)) * (1.0 + 1e-4)),
                    count: planes.len(),
                    object: [0; PLANES],
                    first: planes.iter().enumerate().all(|(j, &(i, _))| i == first + j).then_some(first as u8),
                    point: [[0.0; PLANES]; 3],
                    normal: [[0.0; PLANES]; 3],
                    least: [[f32::NAN; PLANES]; 2],
                };
                for (j, &(i, plane)) in planes.iter().enumerate() {
                    let (p, n) = (plane.point.as_dvec3(), plane.normal.as_dvec3());
                    let (cn, un, vn) = ((c - p).dot(n), ud.dot(n), vd.dot(n));
                    // The corners' least distance on either side, less what is not the
                    // origin's: the light points' jitter and `num`'s error from `p`, twice,
                    // and `f64`'s roundings.
                    let slack = 2.0 * (jitter + NUM_ERROR * l1(p)) + 1e-12 * (l1(c) + l1(ud) + l1(vd) + l1(p));
                    let front = cn + un.min(0.0) + vn.min(0.0);
                    let back = -cn + (-un).min(0.0) + (-vn).min(0.0);
                    table.object[j] = i as u8;
                    for axis in 0..3 {
                        table.point[axis][j] = plane.point[axis];
                        table.normal[axis][j] = plane.normal[axis];
                    }
                    table.least[0][j] = down(front - slack);
                    table.least[1][j] = down(back - slack);
                }
                (center.is_finite() && table.reach.is_finite()).then_some(table)
            })
            .collect()
    }

    /// Whether this table is for the quad light `[corner, u, v]` and a scene of `objects`
    /// objects (as for the scene's other arrays, a scene whose objects changed must be
    /// prepared again).
    #[inline(always)]
    pub(crate) fn is_for(&self, light: [Vec3; 3], objects: usize) -> bool {
        let bits = |l: [Vec3; 3]| -> [u32; 9] { std::array::from_fn(|i| l[i / 3][i % 3].to_bits()) };
        let (a, b) = (bits(self.light), bits(light));
        (0..9).fold(self.objects == objects, |same, i| same & (a[i] == b[i]))
    }

    /// What [`QuadPlanes::clear`] needs for the origins inside the box `lo..=hi`: per
    /// side of a plane, the planes whose corners' least distance exceeds `E·reach +
    /// 2·err` for every origin of the box (the farthest from the light's centre and from
    /// the world's origin), computed once for many origins (a pixel's hits).
    pub(crate) fn for_box(&self, lo: Vec3, hi: Vec3) -> BoxProof {
        let (mut far, mut size) = (f64::from(self.reach), 0.0);
        for axis in 0..3 {
            let (l, h, c) = (f64::from(lo[axis]), f64::from(hi[axis]), f64::from(self.center[axis]));
            far += (l - c).abs().max((h - c).abs());
            size += l.abs().max(h.abs());
        }
        let need = up((DENOM_ERROR * far + 2.0 * NUM_ERROR * size) * (1.0 + 1e-9));
        BoxProof {
            lo: lo.to_array(),
            hi: hi.to_array(),
            side: std::array::from_fn(|s| (0..self.count).fold(0, |m, j| m | u32::from(self.least[s][j] >= need) << j)),
        }
    }

    /// The planes (bit `i` for object `i`) that none of the shadow rays from `origin`
    /// towards the light can meet (see the module's comment), when `origin` lies in
    /// `proof`'s box (else none). Compiled into the caller (for AVX2 in `quad_light`'s:
    /// the eight planes in one register).
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    pub(crate) fn clear(&self, proof: &BoxProof, origin: Vec3) -> u64 {
        let o = origin.to_array();
        let inside = (0..3).fold(true, |inside, a| inside & (proof.lo[a] <= o[a]) & (o[a] <= proof.hi[a]));
        if !inside {
            return 0;
        }
        let (p, n) = (&self.point, &self.normal);
        let mut num = [0f32; PLANES];
        for j in 0..PLANES {
            // Every lane's numerator, bit for bit.
            num[j] = (p[0][j] - o[0]) * n[0][j] + (p[1][j] - o[1]) * n[1][j] + (p[2][j] - o[2]) * n[2][j];
        }
        // The origin's side of each plane, and the planes it is not on (zero or nearly: a
        // `t` of ±0 counts as a hit; or NaN), as masks (`vmovmskps`).
        let back = (0..PLANES).fold(0u32, |m, j| m | u32::from(num[j] > 0.0) << j);
        let away = (0..PLANES).fold(0u32, |m, j| m | u32::from(num[j].abs() >= 1e-30) << j);
        let mask = u64::from(away & ((back & proof.side[1]) | (!back & proof.side[0])));
        match self.first {
            // The planes are objects `first..first + count`.
            Some(first) => mask << first,
            None => (0..self.count).fold(0, |clear, j| clear | (mask >> j & 1) << self.object[j]),
        }
    }
}
