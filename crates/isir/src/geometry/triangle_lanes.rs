//! The geometry of sixteen triangle hits at once: each lane's
//! [`TriangleMesh::face_normal`] and [`TriangleMesh::surface_point`], the same floats, in
//! straight-line loops over the lanes that the compiler turns into SIMD (AVX2 where the
//! CPU has it: divisions and square roots eight lanes at a time, four in `f64`).
//!
//! PERF: one hit at a time, the face normal's and the error bound's divisions and square
//! roots were 5.5% of the conference room's render.

use super::TriangleMesh;
use crate::math::ray::{gamma, LANES};
use glam::Vec3;

/// Per lane (`[axis][lane]`): the face normal, the surface point and its error bound.
pub(crate) struct TriangleLanes {
    pub(crate) face: [[f32; LANES]; 3],
    pub(crate) point: [[f32; LANES]; 3],
    pub(crate) error: [[f32; LANES]; 3],
}

impl TriangleLanes {
    /// Lane `k`'s face normal, point and error bound.
    #[inline(always)]
    pub(crate) fn lane(&self, k: usize) -> (Vec3, Vec3, Vec3) {
        let at = |a: &[[f32; LANES]; 3]| Vec3::new(a[0][k], a[1][k], a[2][k]);
        (at(&self.face), at(&self.point), at(&self.error))
    }

    /// The triangles with vertices `p[vertex][axis][lane]` at barycentrics `(u, v)`.
    pub(crate) fn new(p: &[[[f32; LANES]; 3]; 3], u: &[f32; LANES], v: &[f32; LANES]) -> Self {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            #[target_feature(enable = "avx2")]
            fn new_avx2(p: &[[[f32; LANES]; 3]; 3], u: &[f32; LANES], v: &[f32; LANES]) -> TriangleLanes {
                TriangleLanes::portable(p, u, v)
            }
            // SAFETY: the CPU has AVX2, which is all `new_avx2` is compiled for.
            return unsafe { new_avx2(p, u, v) };
        }
        Self::portable(p, u, v)
    }

    /// The operations of `face_normal` and `surface_point` (and of glam's `cross`, `dot`,
    /// `max_element`, `normalize_or_zero` and `length` inside them) in their order, each
    /// stage a loop over the lanes, branches as selects.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loops vectorise
    fn portable(p: &[[[f32; LANES]; 3]; 3], u: &[f32; LANES], v: &[f32; LANES]) -> Self {
        let mut out = TriangleLanes { face: [[0.0; LANES]; 3], point: [[0.0; LANES]; 3], error: [[0.0; LANES]; 3] };
        let [p0, p1, p2] = p;
        // ---- face_normal: (b - a) × (c - a), scaled by its largest component, normalised ----
        let mut e1 = [[0f32; LANES]; 3];
        let mut e2 = [[0f32; LANES]; 3];
        for k in 0..3 {
            for j in 0..LANES {
                e1[k][j] = p1[k][j] - p0[k][j];
                e2[k][j] = p2[k][j] - p0[k][j];
            }
        }
        // The normal's lanes kept (all bits set) or zeroed (a degenerate triangle's).
        // PERF: an AND with bits the compiler cannot see are all or nothing (`black_box`):
        // as a select of 0.0 it wrote every row as two masked stores (`vmaskmovps`, slow on
        // AMD).
        let mut normal_kept = [0u32; LANES];
        for j in 0..LANES {
            let n = [
                e1[1][j] * e2[2][j] - e2[1][j] * e1[2][j],
                e1[2][j] * e2[0][j] - e2[2][j] * e1[0][j],
                e1[0][j] * e2[1][j] - e2[0][j] * e1[1][j],
            ];
            let max = |a: f32, b: f32| if a > b { a } else { b };
            let m = max(n[0].abs(), max(n[1].abs(), n[2].abs()));
            let s = [n[0] / m, n[1] / m, n[2] / m];
            let rcp = 1.0 / ((s[0] * s[0]) + (s[1] * s[1]) + (s[2] * s[2])).sqrt();
            normal_kept[j] = all_bits(rcp.is_finite() & (rcp > 0.0));
            for k in 0..3 {
                out.face[k][j] = s[k] * rcp;
            }
        }
        let normal_kept = std::hint::black_box(normal_kept);
        for k in 0..3 {
            for j in 0..LANES {
                out.face[k][j] = kept(out.face[k][j], normal_kept[j]);
            }
        }
        // ---- surface_point: the point from the barycentrics, its rounding bound, and the
        // height of the band a leaving ray must clear ----
        let (g7, g8) = (gamma(7), f64::from(gamma(8)));
        for j in 0..LANES {
            let (u, v) = (u[j], v[j]);
            let b0 = 1.0 - u - v;
            for k in 0..3 {
                let (a, b, c) = (b0 * p0[k][j], u * p1[k][j], v * p2[k][j]);
                out.point[k][j] = a + b + c;
                out.error[k][j] = g7 * (a.abs() + b.abs() + c.abs());
            }
        }
        // The band's height added to the bound on each axis, except on a flat triangle's
        // lanes (zeroed as the normal's above: `+ 0.0` leaves the bound, never -0, bit for
        // bit). PERF: as a select of the old bound, LLVM wrote the sums with masked loads
        // and stores.
        let (mut along, mut band_kept) = ([[0f32; LANES]; 3], [0u32; LANES]);
        for j in 0..LANES {
            let d1 = [f64::from(e1[0][j]), f64::from(e1[1][j]), f64::from(e1[2][j])];
            let d2 = [f64::from(e2[0][j]), f64::from(e2[1][j]), f64::from(e2[2][j])];
            let c = [d1[1] * d2[2] - d2[1] * d1[2], d1[2] * d2[0] - d2[2] * d1[0], d1[0] * d2[1] - d2[0] * d1[1]];
            let area2 = ((c[0] * c[0]) + (c[1] * c[1]) + (c[2] * c[2])).sqrt();
            band_kept[j] = all_bits((area2 != 0.0) & area2.is_finite());
            let l1 = ((d1[0] * d1[0]) + (d1[1] * d1[1]) + (d1[2] * d1[2])).sqrt();
            let l2 = ((d2[0] * d2[0]) + (d2[1] * d2[1]) + (d2[2] * d2[2])).sqrt();
            let height = g8 * 2.0 * l1.max(l2) * (l1 / area2) * l2;
            for k in 0..3 {
                along[k][j] = ((c[k] / area2).abs() * height) as f32;
            }
        }
        let band_kept = std::hint::black_box(band_kept);
        for k in 0..3 {
            for j in 0..LANES {
                out.error[k][j] += kept(along[k][j], band_kept[j]);
            }
        }
        out
    }
}

/// All bits set where `keep`, none elsewhere: a lane's mask for [`kept`].
#[inline(always)]
fn all_bits(keep: bool) -> u32 {
    0u32.wrapping_sub(u32::from(keep))
}

/// `x` where `mask` has all its bits set, `+0.0` where it has none.
#[inline(always)]
fn kept(x: f32, mask: u32) -> f32 {
    f32::from_bits(x.to_bits() & mask)
}

impl TriangleMesh {
    /// Write triangle `prim`'s vertices into lane `k` of `p` (`[vertex][axis][lane]`).
    #[inline(always)]
    pub(crate) fn vertices_into_lane(&self, prim: u32, p: &mut [[[f32; LANES]; 3]; 3], k: usize) {
        for (lane, v) in p.iter_mut().zip(self.triangle_vertices(prim)) {
            for axis in 0..3 {
                lane[axis][k] = v[axis];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sampling::Sampler;

    /// Every lane's face normal, point and error bound are [`TriangleMesh::face_normal`]'s
    /// and [`TriangleMesh::surface_point`]'s, bit for bit: ordinary, long thin, tiny, huge,
    /// degenerate (zero area, a repeated vertex) and axis-aligned triangles.
    #[test]
    fn lanes_are_face_normal_and_surface_point_bit_for_bit() {
        let mut rng = Sampler::from_seed(5);
        let mut r = |scale: f32| (rng.next_f32() - 0.5) * scale;
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        for t in 0..(256 * LANES as u32) {
            let scale = [1.0, 1e-3, 1e3, 1e7, 1e12][t as usize % 5];
            let a = Vec3::new(r(scale), r(scale), r(scale));
            let (b, c) = match t % 7 {
                0 => (a, a + Vec3::X * scale),                                         // repeated vertex
                1 => (a + Vec3::X * scale, a + Vec3::X * 2.0 * scale),                 // collinear
                2 => (a + Vec3::new(scale, 0.0, 0.0), a + Vec3::new(0.0, scale, 0.0)), // axis-aligned
                3 => (a + Vec3::new(scale, 1e-6 * scale, 0.0), a + Vec3::new(2.0 * scale, 0.0, 1e-5 * scale)), // sliver
                _ => (Vec3::new(r(scale), r(scale), r(scale)), Vec3::new(r(scale), r(scale), r(scale))),
            };
            let base = vertices.len() as u32;
            vertices.extend([a, b, c]);
            triangles.push([base, base + 1, base + 2]);
        }
        let mesh = TriangleMesh::new(vertices, Vec::new(), triangles);
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        for first in (0..mesh.triangles.len()).step_by(LANES) {
            let mut p = [[[0f32; LANES]; 3]; 3];
            let (mut u, mut v) = ([0f32; LANES], [0f32; LANES]);
            for k in 0..LANES {
                mesh.vertices_into_lane((first + k) as u32, &mut p, k);
                (u[k], v[k]) = match k % 4 {
                    0 => (0.0, 0.0),
                    1 => (1.0, 0.0),
                    _ => {
                        let (x, y) = (r(1.0) + 0.5, r(1.0) + 0.5);
                        if x + y > 1.0 {
                            (1.0 - x, 1.0 - y)
                        } else {
                            (x, y)
                        }
                    }
                };
            }
            let lanes = TriangleLanes::new(&p, &u, &v);
            for k in 0..LANES {
                let prim = (first + k) as u32;
                let (face, point, error) = lanes.lane(k);
                let (want_point, want_error) = mesh.surface_point(prim, u[k], v[k]);
                assert_eq!(bits(face), bits(mesh.face_normal(prim)), "triangle {prim}: face normal");
                assert_eq!(bits(point), bits(want_point), "triangle {prim}: point");
                assert_eq!(bits(error), bits(want_error), "triangle {prim}: error bound");
            }
        }
    }
}
