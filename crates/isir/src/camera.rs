//! The course's perspective pinhole camera.
//!
//! Basis `w = normalize(position - look_at)`, `u = normalize(up × w)`, `v = w × u`;
//! viewport height `2·tan(fovy/2)·focal`, width `height·aspect`; screen coordinates
//! `(sx, sy) ∈ [0,1]²` with row 0 at the top. Looking down +z from (0,0,-6), world +x is on
//! the **left** of the image, as in the course.

use crate::math::ray::{Ray, RayLanes, LANES};
use glam::Vec3;

/// A perspective camera with focal distance 1.
#[derive(Clone, Debug)]
pub struct Camera {
    position: Vec3,
    /// The top-left corner of the viewport relative to the position: directions are formed
    /// without adding and subtracting the position, which would round them to its ULPs (a
    /// camera a few 1e7 units from the origin gave NaN rays).
    to_top_left: Vec3,
    viewport_u: Vec3,
    viewport_v: Vec3,
}

impl Camera {
    /// A camera at `position` looking at `look_at`, vertical field of view `fovy_degrees`,
    /// `aspect` = width / height. Not checked here: a NaN position, `look_at` at the
    /// position, `up` along the view or a field of view outside (0°, 180°) make rays that
    /// miss everything, an image of the background; [`crate::CameraDesc::validate`] says
    /// which (scene files and [`crate::SceneDescription::build`] call it).
    #[must_use]
    pub fn new(position: Vec3, look_at: Vec3, up: Vec3, fovy_degrees: f32, aspect: f32) -> Self {
        let focal = 1.0;
        // Scaled before normalizing: the squared length overflows beyond ~1e19.
        let to_eye = position - look_at;
        let w = (to_eye / to_eye.abs().max_element()).normalize();
        let u = up.cross(w).normalize();
        let v = w.cross(u);
        let height = 2.0 * (fovy_degrees.to_radians() * 0.5).tan() * focal;
        let width = height * aspect;
        let to_top_left = -w * focal + v * height * 0.5 - u * width * 0.5;
        Self { position, to_top_left, viewport_u: u * width, viewport_v: v * height }
    }

    /// The camera's position.
    #[must_use]
    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// The ray through screen coordinates `(sx, sy) ∈ [0,1]²`, row 0 at the top;
    /// its direction is normalized.
    #[inline]
    #[must_use]
    pub fn generate_ray(&self, sx: f32, sy: f32) -> Ray {
        let direction = self.to_top_left + sx * self.viewport_u - sy * self.viewport_v;
        Ray::new(self.position, direction.normalize())
    }

    /// The rays of [`Camera::generate_ray`] through the screen points `(sx[k], sy[k])`,
    /// bit for bit, computed as arrays ([`Camera::generate_lanes`]), into the lanes of `rays`
    /// (interval `[0, ∞)`); lanes from `sx.len()` on get zero rays, which meet nothing.
    ///
    /// # Panics
    /// If `sx` and `sy` differ in length or hold more than [`LANES`] points.
    pub fn generate_rays(&self, sx: &[f32], sy: &[f32], rays: &mut RayLanes) {
        assert!(sx.len() == sy.len() && sx.len() <= LANES);
        let (mut x, mut y) = ([0.0; LANES], [0.0; LANES]);
        x[..sx.len()].copy_from_slice(sx);
        y[..sy.len()].copy_from_slice(sy);
        self.generate_lanes(&x, &y, sx.len(), rays);
    }

    /// [`Camera::generate_rays`] of the first `n` points of `sx` and `sy` (the other lanes'
    /// points are not read): with AVX2 where the CPU has it (the same operations eight
    /// lanes at a time: the same floats).
    /// PERF: the portable loop stayed scalar (a square root and a division per lane, in
    /// turn); with AVX2, tp1-sphere at 256 spp took 0.96 of the CPU time (ARCHITECTURE.md,
    /// twenty-eighth session).
    #[inline]
    pub fn generate_lanes(&self, sx: &[f32; LANES], sy: &[f32; LANES], n: usize, rays: &mut RayLanes) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, which is all `generate_lanes_avx2` is compiled for.
            unsafe { self.generate_lanes_avx2(sx, sy, n, rays) };
            return;
        }
        self.generate_lanes_portable(sx, sy, n, rays);
    }

    /// [`Camera::generate_lanes`] with AVX2 intrinsics: `to_top_left + sx·u − sy·v` and
    /// `Vec3::normalize` (times the reciprocal of the length) in their order, no FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn generate_lanes_avx2(&self, sx: &[f32; LANES], sy: &[f32; LANES], n: usize, rays: &mut RayLanes) {
        use std::arch::x86_64::{
            _mm256_add_ps, _mm256_and_ps, _mm256_castsi256_ps, _mm256_cmpgt_epi32, _mm256_div_ps, _mm256_loadu_ps, _mm256_mul_ps,
            _mm256_set1_epi32, _mm256_set1_ps, _mm256_setr_epi32, _mm256_sqrt_ps, _mm256_storeu_ps, _mm256_sub_ps,
        };
        let (c, u, v, p) = (self.to_top_left, self.viewport_u, self.viewport_v, self.position);
        let splat = |a: Vec3| [_mm256_set1_ps(a.x), _mm256_set1_ps(a.y), _mm256_set1_ps(a.z)];
        let (c, u, v, p) = (splat(c), splat(u), splat(v), splat(p));
        let index = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        for half in 0..LANES / 8 {
            let at = 8 * half;
            // SAFETY: eight floats from `at` of sixteen-float arrays, in bounds.
            let (x, y) = unsafe { (_mm256_loadu_ps(sx.as_ptr().add(at)), _mm256_loadu_ps(sy.as_ptr().add(at))) };
            let d: [_; 3] = std::array::from_fn(|a| _mm256_sub_ps(_mm256_add_ps(c[a], _mm256_mul_ps(x, u[a])), _mm256_mul_ps(y, v[a])));
            let dot = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(d[0], d[0]), _mm256_mul_ps(d[1], d[1])), _mm256_mul_ps(d[2], d[2]));
            let r = _mm256_div_ps(_mm256_set1_ps(1.0), _mm256_sqrt_ps(dot));
            // Lanes from `n` on (`at + index >= n`): zero rays (all bits cleared: +0).
            let left = _mm256_set1_epi32(n.min(LANES) as i32 - at as i32);
            let live = _mm256_castsi256_ps(_mm256_cmpgt_epi32(left, index));
            for a in 0..3 {
                // SAFETY: eight floats from `at` of sixteen-float arrays, in bounds.
                unsafe {
                    _mm256_storeu_ps(rays.o[a].as_mut_ptr().add(at), _mm256_and_ps(live, p[a]));
                    _mm256_storeu_ps(rays.d[a].as_mut_ptr().add(at), _mm256_and_ps(live, _mm256_mul_ps(d[a], r)));
                }
            }
            // SAFETY: as above.
            unsafe {
                _mm256_storeu_ps(rays.t_min.as_mut_ptr().add(at), _mm256_set1_ps(0.0));
                _mm256_storeu_ps(rays.t_max.as_mut_ptr().add(at), _mm256_set1_ps(f32::INFINITY));
            }
        }
    }

    /// [`Camera::generate_lanes`] on any CPU.
    #[allow(clippy::needless_range_loop)] // one index into many arrays
    fn generate_lanes_portable(&self, x: &[f32; LANES], y: &[f32; LANES], n: usize, rays: &mut RayLanes) {
        let (c, u, v) = (self.to_top_left, self.viewport_u, self.viewport_v);
        // The operations of `to_top_left + sx·u − sy·v` and `Vec3::normalize` (times the
        // reciprocal of the length), in their order.
        for k in 0..LANES {
            let d = [c.x + x[k] * u.x - y[k] * v.x, c.y + x[k] * u.y - y[k] * v.y, c.z + x[k] * u.z - y[k] * v.z];
            let r = 1.0 / (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let live = k < n;
            for a in 0..3 {
                rays.o[a][k] = if live { self.position[a] } else { 0.0 };
                rays.d[a][k] = if live { d[a] * r } else { 0.0 };
            }
            rays.t_min[k] = 0.0;
            rays.t_max[k] = f32::INFINITY;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_at_target_and_plus_x_is_left() {
        let cam = Camera::new(Vec3::new(0.0, 0.0, -6.0), Vec3::new(0.0, 0.0, 79.0), Vec3::Y, 60.0, 1.5);
        let c = cam.generate_ray(0.5, 0.5);
        assert!((c.direction - Vec3::Z).length() < 1e-6);
        let left = cam.generate_ray(0.0, 0.5);
        assert!(left.direction.x > 0.0, "the left of the image looks towards +x");
        let top = cam.generate_ray(0.5, 0.0);
        assert!(top.direction.y > 0.0, "row 0 is the top");
        // Half the vertical field of view: 30 degrees.
        assert!((top.direction.y.atan2(top.direction.z).to_degrees() - 30.0).abs() < 1e-3);
    }

    /// The lanes hold the rays of `generate_ray`, bit for bit, and zero rays after them:
    /// through `generate_rays`, and through `generate_lanes` on the portable loop and
    /// (where this CPU has it) on AVX2, whose lanes from `n` on hold points that must not
    /// be read (NaN). Points off the screen and NaN points in live lanes too.
    #[test]
    fn generated_lanes_are_the_rays_of_generate_ray() {
        let mut rng = crate::math::sampling::Sampler::from_seed(5);
        #[cfg(target_arch = "x86_64")]
        let avx2 = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        if !avx2 {
            eprintln!("no AVX2 on this CPU: generate_lanes_avx2 not run");
        }
        for (i, far) in [0.0f32, 3.0, 1e4, 1e7].into_iter().enumerate() {
            let p = Vec3::new(far, -far * 0.5, 2.0 - far);
            let cam = Camera::new(p, p + Vec3::new(0.3, -0.2, 1.0), Vec3::Y, 30.0 + 20.0 * i as f32, 1.5);
            for n in 0..=LANES {
                let (mut sx, mut sy) = ([f32::NAN; LANES], [f32::NAN; LANES]);
                for k in 0..n {
                    (sx[k], sy[k]) = match (k + n) % 9 {
                        0 => (-0.5 + 2.0 * rng.next_f32(), 1.5),
                        1 => (f32::NAN, rng.next_f32()),
                        _ => (rng.next_f32(), rng.next_f32()),
                    };
                }
                let mut ways: Vec<(&str, RayLanes)> = Vec::new();
                let mut lanes = RayLanes::EMPTY;
                cam.generate_rays(&sx[..n], &sy[..n], &mut lanes);
                ways.push(("generate_rays", lanes));
                let mut lanes = RayLanes::EMPTY;
                cam.generate_lanes_portable(&sx, &sy, n, &mut lanes);
                ways.push(("portable", lanes));
                #[cfg(target_arch = "x86_64")]
                if avx2 {
                    let mut lanes = RayLanes::EMPTY;
                    // SAFETY: the CPU has AVX2 (checked above).
                    unsafe { cam.generate_lanes_avx2(&sx, &sy, n, &mut lanes) };
                    ways.push(("avx2", lanes));
                }
                let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                for (way, lanes) in &ways {
                    for k in 0..LANES {
                        let got = lanes.ray(k);
                        assert_eq!((lanes.t_min[k].to_bits(), lanes.t_max[k]), (0, f32::INFINITY), "{way}");
                        if k < n {
                            let want = cam.generate_ray(sx[k], sy[k]);
                            assert_eq!(bits(got.origin), bits(want.origin), "{way} {far} {k}");
                            assert_eq!(bits(got.direction), bits(want.direction), "{way} {far} {k}");
                        } else {
                            assert_eq!((bits(got.origin), bits(got.direction)), ([0; 3], [0; 3]), "{way} {far} {k}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn rays_stay_finite_and_distinct_far_from_the_origin() {
        for far in [1e7f32, 1e12, 1e20, 1e30] {
            let p = Vec3::new(far, -far, 0.5 * far);
            let cam = Camera::new(p, p + Vec3::new(1.0, 2.0, 3.0) * far * 1e-3, Vec3::Y, 60.0, 1.5);
            let (a, b) = (cam.generate_ray(0.5, 0.5), cam.generate_ray(0.501, 0.5));
            assert!(a.is_valid() && b.is_valid(), "{far}: {a:?}");
            assert!((a.direction - Vec3::new(1.0, 2.0, 3.0).normalize()).length() < 1e-3, "{far}: {a:?}");
            assert!(a.direction != b.direction, "{far}: neighbouring pixels share a direction");
        }
    }
}
