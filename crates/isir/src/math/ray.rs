//! A ray: origin and direction. Parameter `t` is measured in units of the direction's length.

use glam::Vec3;

/// A half-line `origin + t·direction`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts.
    pub origin: Vec3,
    /// Where it goes; need not be normalized (cameras and integrators normalize theirs).
    pub direction: Vec3,
}

impl Ray {
    /// A ray from `origin` along `direction`.
    #[inline]
    #[must_use]
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        Self { origin, direction }
    }

    /// The point at parameter `t`.
    #[inline]
    #[must_use]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.direction
    }

    /// True when origin and direction are finite and the direction is not zero:
    /// other rays can hit nothing.
    #[inline]
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite() && self.direction.is_finite() && self.direction != Vec3::ZERO
    }
}

/// A ray with its interval `[t_min, t_max)`: what the packet tracer takes, and the fields
/// of a ray file's record, which are the first 32 bytes of Embree's `RTCRay`
/// ([`crate::io::rays::RayRecord`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RaySegment {
    /// Origin.
    pub origin: Vec3,
    /// Start of the interval.
    pub t_min: f32,
    /// Direction (not necessarily normalized).
    pub direction: Vec3,
    /// End of the interval (may be +∞).
    pub t_max: f32,
}

impl RaySegment {
    /// The ray.
    #[must_use]
    pub fn ray(&self) -> Ray {
        Ray::new(self.origin, self.direction)
    }
}

/// Lanes in a [`RayLanes`].
pub const LANES: usize = 16;

/// Up to [`LANES`] rays as structure of arrays, for tests of one shape against many rays
/// in straight-line loops the compiler vectorises (unused lanes hold zero rays).
#[derive(Clone, Copy, Debug)]
pub struct RayLanes {
    /// Origins by component.
    pub o: [[f32; LANES]; 3],
    /// Directions by component.
    pub d: [[f32; LANES]; 3],
    /// Starts of the intervals.
    pub t_min: [f32; LANES],
    /// Ends of the intervals.
    pub t_max: [f32; LANES],
}

impl RayLanes {
    /// Zero rays in every lane (invalid: they meet nothing).
    pub const EMPTY: RayLanes = RayLanes { o: [[0.0; LANES]; 3], d: [[0.0; LANES]; 3], t_min: [0.0; LANES], t_max: [0.0; LANES] };

    /// The rays `rays` (at most [`LANES`]).
    ///
    /// # Panics
    /// If there are more than [`LANES`] rays.
    #[must_use]
    pub fn new(rays: &[RaySegment]) -> Self {
        assert!(rays.len() <= LANES);
        let mut l = RayLanes::EMPTY;
        for (k, r) in rays.iter().enumerate() {
            l.set(k, r.origin, r.direction, r.t_min, r.t_max);
        }
        l
    }

    /// Lane `k` becomes the ray from `origin` along `direction` in `[t_min, t_max)`.
    #[inline(always)]
    pub fn set(&mut self, k: usize, origin: Vec3, direction: Vec3, t_min: f32, t_max: f32) {
        for axis in 0..3 {
            self.o[axis][k] = origin[axis];
            self.d[axis][k] = direction[axis];
        }
        (self.t_min[k], self.t_max[k]) = (t_min, t_max);
    }

    /// Lanes `at..at + n` become lanes `0..n` of `from` (whole components, not ray by ray).
    #[inline(always)]
    pub fn copy_lanes(&mut self, at: usize, from: &RayLanes, n: usize) {
        for axis in 0..3 {
            self.o[axis][at..at + n].copy_from_slice(&from.o[axis][..n]);
            self.d[axis][at..at + n].copy_from_slice(&from.d[axis][..n]);
        }
        self.t_min[at..at + n].copy_from_slice(&from.t_min[..n]);
        self.t_max[at..at + n].copy_from_slice(&from.t_max[..n]);
    }

    /// Lane `k`'s ray with its interval.
    #[inline(always)]
    #[must_use]
    pub fn segment(&self, k: usize) -> RaySegment {
        let ray = self.ray(k);
        RaySegment { origin: ray.origin, t_min: self.t_min[k], direction: ray.direction, t_max: self.t_max[k] }
    }
}

impl RayLanes {
    /// Lane `k`'s ray.
    #[inline(always)]
    #[must_use]
    pub fn ray(&self, k: usize) -> Ray {
        Ray::new(Vec3::new(self.o[0][k], self.o[1][k], self.o[2][k]), Vec3::new(self.d[0][k], self.d[1][k], self.d[2][k]))
    }
}

impl RayLanes {
    /// Each lane's `-d.normalize()` (glam's: `d` times `1 / length`, then negated): the
    /// direction back along the ray, `ωo` at its hit. Bit for bit the scalar expression,
    /// eight lanes wide where the CPU has AVX2 (lanes of zero rays give NaN).
    /// PERF: lane by lane in the path tracer, the square roots and divisions were 3% of
    /// its time.
    #[must_use]
    pub fn outgoing(&self) -> [[f32; LANES]; 3] {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            #[target_feature(enable = "avx2")]
            fn avx2(rays: &RayLanes) -> [[f32; LANES]; 3] {
                rays.outgoing_portable()
            }
            // SAFETY: the CPU has AVX2, which is all `avx2` is compiled for.
            return unsafe { avx2(self) };
        }
        self.outgoing_portable()
    }

    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    fn outgoing_portable(&self) -> [[f32; LANES]; 3] {
        let mut wo = [[0f32; LANES]; 3];
        let d = &self.d;
        for k in 0..LANES {
            let r = 1.0 / ((d[0][k] * d[0][k]) + (d[1][k] * d[1][k]) + (d[2][k] * d[2][k])).sqrt();
            for axis in 0..3 {
                wo[axis][k] = -(d[axis][k] * r);
            }
        }
        wo
    }

    /// The lanes whose ray [`Ray::is_valid`]: finite origin and direction, direction not
    /// zero.
    #[inline(always)]
    #[must_use]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    pub fn valid_mask(&self) -> u32 {
        let mut valid = [false; LANES];
        for k in 0..LANES {
            let finite = (0..3).fold(true, |f, a| f & self.o[a][k].is_finite() & self.d[a][k].is_finite());
            let nonzero = (self.d[0][k] != 0.0) | (self.d[1][k] != 0.0) | (self.d[2][k] != 0.0);
            valid[k] = finite & nonzero;
        }
        lane_mask(&valid)
    }

    /// The lanes whose origin is lane `first`'s (compared as `Vec3`s compare).
    #[inline(always)]
    #[must_use]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    pub fn same_origin_mask(&self, first: usize) -> u32 {
        let o = [self.o[0][first], self.o[1][first], self.o[2][first]];
        let mut same = [false; LANES];
        for k in 0..LANES {
            same[k] = (self.o[0][k] == o[0]) & (self.o[1][k] == o[1]) & (self.o[2][k] == o[2]);
        }
        lane_mask(&same)
    }
}

/// The lanes whose bits are set in `mask`, in increasing order.
#[inline]
pub fn lanes_of(mask: u32) -> impl Iterator<Item = usize> {
    let mut m = mask;
    std::iter::from_fn(move || {
        (m != 0).then(|| {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            k
        })
    })
}

/// The bits `0..LANES` of the lanes where `hit` holds.
#[inline]
#[must_use]
pub fn lane_mask(hit: &[bool; LANES]) -> u32 {
    const { assert!(LANES == 16) };
    // Eight flags (bytes of 0 or 1) at a time into eight bits: the product puts byte `i`'s
    // bit at bit `56 + i`, every term on its own bit, so nothing carries.
    // PERF: a fold of shifts, sixteen dependent ors, was 10% of `Scene::occluded_lanes`
    // on tp6-glass-quad.
    let gather = |b: &[bool]| {
        let mut x = 0u64;
        for (i, &h) in b.iter().enumerate() {
            x |= u64::from(h) << (8 * i);
        }
        (x.wrapping_mul(0x0102_0408_1020_4080) >> 56) as u32
    };
    gather(&hit[..8]) | gather(&hit[8..]) << 8
}

/// `γ(n) = n·u / (1 - n·u)` with `u` half an ULP of 1: a bound on the relative rounding
/// error of `n` chained float operations (Higham; pbrt-v4 §6.8.1 `gamma`).
#[inline]
#[must_use]
pub const fn gamma(n: u32) -> f32 {
    let nu = n as f32 * (f32::EPSILON * 0.5);
    nu / (1.0 - nu)
}

/// The next float above `x` (`+∞` and NaN stay; `-0.0` goes to the smallest positive
/// float). Written with selects, not branches, so that lane loops vectorise it.
#[inline(always)]
#[must_use]
pub fn next_float_up(x: f32) -> f32 {
    let z = if x == 0.0 { 0.0 } else { x };
    let bits = z.to_bits();
    let up = f32::from_bits(if z >= 0.0 { bits.wrapping_add(1) } else { bits.wrapping_sub(1) });
    if x == f32::INFINITY || x.is_nan() {
        x
    } else {
        up
    }
}

/// The next float below `x`.
#[inline(always)]
#[must_use]
pub fn next_float_down(x: f32) -> f32 {
    -next_float_up(-x)
}

/// `po` rounded one float further in the direction of `side`'s sign (unchanged where
/// `side` is 0): one coordinate of [`offset_ray_origin`]'s rounding, shared with the lane
/// loops that compute the same origins.
#[inline(always)]
#[must_use]
pub(crate) fn round_away(po: f32, side: f32) -> f32 {
    if side > 0.0 {
        next_float_up(po)
    } else if side < 0.0 {
        next_float_down(po)
    } else {
        po
    }
}

/// Offset a surface point so that rays leaving it along `w` do not hit its surface again
/// (pbrt-v4, §6.8.6 "Robust spawned ray origins", `OffsetRayOrigin`).
///
/// `p` is the computed point, `p_error` a conservative bound on its error on each axis
/// (see [`crate::geometry::Hit::point_error`]): the true surface lies within that box of `p`.
/// The origin moves along the geometric normal `n` (either orientation) to the side of `w`
/// by `dot(|n|, p_error)`, which takes it out of the box, and each moved coordinate is then
/// rounded one float further away, so that the rounding of `p + offset` cannot undo it.
#[must_use]
pub fn offset_ray_origin(p: Vec3, p_error: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(p_error);
    // The normal on the side of `w`: the rounding goes that way even when the offset is
    // 0 (a point computed exactly, e.g. on a plane through the origin), so the origin
    // always leaves the surface.
    let side = if w.dot(n) < 0.0 { -n } else { n };
    offset_along(p, d, side)
}

/// `p` moved by `d` along `side`, each moved coordinate rounded one float further.
#[inline]
fn offset_along(p: Vec3, d: f32, side: Vec3) -> Vec3 {
    let po = p + d * side;
    Vec3::new(round_away(po.x, side.x), round_away(po.y, side.y), round_away(po.z, side.z))
}

/// The ray leaving surface point `p` (error bound `p_error`, geometric normal `ng`) in
/// direction `w` (pbrt-v4 `SpawnRay`): from the offset origin, `t` from 0.
#[must_use]
pub fn spawn_ray(p: Vec3, p_error: Vec3, ng: Vec3, w: Vec3) -> Ray {
    Ray::new(offset_ray_origin(p, p_error, ng, w), w)
}

/// The surface points a [`spawn_lanes`] leaves from, in lanes: points, error bounds and
/// geometric normals by component.
#[derive(Clone, Copy, Debug, Default)]
pub struct SurfaceLanes {
    /// Points.
    pub p: [[f32; LANES]; 3],
    /// Their error bounds.
    pub p_error: [[f32; LANES]; 3],
    /// Geometric normals.
    pub ng: [[f32; LANES]; 3],
}

/// [`spawn_ray`] from each lane's surface point along `w[axis][k]`, for the lanes in
/// `mask`, into `rays` (`t` from 0 to ∞); the other lanes get zero rays (which meet
/// nothing). Bit for bit the rays of [`spawn_ray`], eight lanes wide where the CPU has
/// AVX2.
pub fn spawn_lanes(s: &SurfaceLanes, w: &[[f32; LANES]; 3], mask: u32, rays: &mut RayLanes) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2, which is all `spawn_lanes_avx2` is compiled for.
        unsafe { spawn_lanes_avx2(s, w, mask, rays) };
        return;
    }
    spawn_lanes_portable(s, w, mask, rays);
}

/// [`spawn_lanes`] compiled for AVX2, its rows written whole with AND masks in intrinsics.
/// PERF: as the portable loop's selects of 0.0, LLVM wrote every row twice, as two masked
/// stores (`vmaskmovps`, slow on AMD): half of `spawn_lanes`' time in the path tracer.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn spawn_lanes_avx2(s: &SurfaceLanes, w: &[[f32; LANES]; 3], mask: u32, rays: &mut RayLanes) {
    use std::arch::x86_64::{
        __m256, _mm256_and_ps, _mm256_and_si256, _mm256_castsi256_ps, _mm256_cmpeq_epi32, _mm256_loadu_ps, _mm256_set1_epi32,
        _mm256_set1_ps, _mm256_setr_epi32, _mm256_setzero_ps, _mm256_storeu_ps,
    };
    let origins = spawn_origins(s, w);
    let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    for half in 0..LANES / 8 {
        let at = 8 * half;
        // All ones in the lanes of `mask`, zeros elsewhere.
        let live = _mm256_set1_epi32(((mask >> at) & 0xff) as i32);
        let keep = _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(live, bits), bits));
        // SAFETY: every row has LANES floats and `at + 8 <= LANES`: each load and store
        // touches eight floats inside its row (unaligned access is allowed).
        unsafe {
            let store = |row: &mut [f32; LANES], v: __m256| _mm256_storeu_ps(row[at..].as_mut_ptr(), _mm256_and_ps(v, keep));
            for axis in 0..3 {
                store(&mut rays.o[axis], _mm256_loadu_ps(origins[axis][at..].as_ptr()));
                store(&mut rays.d[axis], _mm256_loadu_ps(w[axis][at..].as_ptr()));
            }
            store(&mut rays.t_min, _mm256_setzero_ps());
            store(&mut rays.t_max, _mm256_set1_ps(f32::INFINITY));
        }
    }
}

/// The offset origins of [`spawn_lanes`], every lane's.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
fn spawn_origins(s: &SurfaceLanes, w: &[[f32; LANES]; 3]) -> [[f32; LANES]; 3] {
    let mut origins = [[0f32; LANES]; 3];
    for k in 0..LANES {
        let (p, e, n) = (&s.p, &s.p_error, &s.ng);
        // `offset_ray_origin`'s operations, in its order.
        let d = n[0][k].abs() * e[0][k] + n[1][k].abs() * e[1][k] + n[2][k].abs() * e[2][k];
        let below = w[0][k] * n[0][k] + w[1][k] * n[1][k] + w[2][k] * n[2][k] < 0.0;
        for axis in 0..3 {
            // `-n` where `below`, as a flip of the sign bit. PERF: as a select, LLVM split
            // the loop's body on `below` and wrote the origins with masked stores
            // (`vmaskmovps`, slow on AMD).
            let side = f32::from_bits(n[axis][k].to_bits() ^ (u32::from(below) << 31));
            origins[axis][k] = round_away(p[axis][k] + d * side, side);
        }
    }
    origins
}

#[allow(clippy::needless_range_loop)] // one index into many arrays
fn spawn_lanes_portable(s: &SurfaceLanes, w: &[[f32; LANES]; 3], mask: u32, rays: &mut RayLanes) {
    let origins = spawn_origins(s, w);
    for k in 0..LANES {
        let live = mask & (1 << k) != 0;
        for axis in 0..3 {
            rays.o[axis][k] = if live { origins[axis][k] } else { 0.0 };
            rays.d[axis][k] = if live { w[axis][k] } else { 0.0 };
        }
        rays.t_min[k] = 0.0;
        rays.t_max[k] = if live { f32::INFINITY } else { 0.0 };
    }
}

/// The shadow ray from surface point `p` (error bound `p_error`, geometric normal `ng`) to
/// `target` (pbrt-v4 `SpawnRayTo`): from the origin offset towards the target, with a unit
/// direction and the `t_max` that stops it just short of the target (`1 - 1e-4` of the way,
/// pbrt's `ShadowEpsilon`). `None` when the target is the origin itself or is not finite.
#[must_use]
pub fn spawn_ray_to(p: Vec3, p_error: Vec3, ng: Vec3, target: Vec3) -> Option<(Ray, f32)> {
    let origin = offset_ray_origin(p, p_error, ng, target - p);
    let to = target - origin;
    let dist = to.length();
    (dist > 0.0 && dist.is_finite()).then(|| (Ray::new(origin, to / dist), dist * (1.0 - 1e-4)))
}

/// Shadow rays from one surface point to many targets (the samples of an area light): the
/// rays of [`spawn_ray_to`], bit for bit, with the offset origin on each side of the
/// surface computed once rather than per ray.
#[derive(Clone, Copy, Debug)]
pub struct ShadowRays {
    p: Vec3,
    n: Vec3,
    d: f32,
    /// The offset origin on the side of `n`, then of `-n`, once computed.
    origins: [Option<Vec3>; 2],
}

impl ShadowRays {
    /// Rays leaving surface point `p` (error bound `p_error`, geometric normal `ng`).
    #[must_use]
    pub fn new(p: Vec3, p_error: Vec3, ng: Vec3) -> Self {
        Self { p, n: ng, d: ng.abs().dot(p_error), origins: [None; 2] }
    }

    /// The surface point the rays leave from and its geometric normal.
    #[must_use]
    pub fn surface(&self) -> (Vec3, Vec3) {
        (self.p, self.n)
    }

    /// The two offset origins: on the side of the normal (targets `y` with
    /// `(y - p)·n >= 0`), and on the other side. [`ShadowRays::to`] uses one of them.
    #[must_use]
    #[inline(always)]
    pub fn both_origins(&self) -> [Vec3; 2] {
        [offset_along(self.p, self.d, self.n), offset_along(self.p, self.d, -self.n)]
    }

    /// [`ShadowRays::both_origins`] in AVX2: the six coordinates in one register, each
    /// `round_away` as selects, the same floats.
    /// PERF: as two `offset_along`s, six branches on the normal's signs and about 75
    /// instructions of each quad batch's set-up.
    ///
    /// # Safety
    /// Call it only where the CPU has AVX2 (`is_x86_feature_detected!("avx2")`).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    #[must_use]
    pub(crate) fn both_origins_avx2(&self) -> [Vec3; 2] {
        use std::arch::x86_64::{
            __m256, _mm256_add_epi32, _mm256_add_ps, _mm256_blendv_epi8, _mm256_blendv_ps, _mm256_castps_si256, _mm256_castsi256_ps,
            _mm256_cmp_ps, _mm256_mul_ps, _mm256_or_ps, _mm256_set1_epi32, _mm256_set1_ps, _mm256_setr_ps, _mm256_setzero_ps,
            _mm256_storeu_ps, _mm256_xor_ps, _CMP_EQ_OQ, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LT_OQ, _CMP_UNORD_Q,
        };
        let (p, n) = (self.p, self.n);
        let side = _mm256_setr_ps(n.x, n.y, n.z, -n.x, -n.y, -n.z, 0.0, 0.0);
        let at = _mm256_setr_ps(p.x, p.y, p.z, p.x, p.y, p.z, 0.0, 0.0);
        let (zero, sign, inf) = (_mm256_setzero_ps(), _mm256_set1_ps(-0.0), _mm256_set1_ps(f32::INFINITY));
        // `next_float_up`, lane by lane.
        let up = |x: __m256| {
            let z = _mm256_blendv_ps(x, zero, _mm256_cmp_ps::<_CMP_EQ_OQ>(x, zero));
            let step =
                _mm256_blendv_epi8(_mm256_set1_epi32(-1), _mm256_set1_epi32(1), _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GE_OQ>(z, zero)));
            let next = _mm256_castsi256_ps(_mm256_add_epi32(_mm256_castps_si256(z), step));
            let keep = _mm256_or_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(x, inf), _mm256_cmp_ps::<_CMP_UNORD_Q>(x, x));
            _mm256_blendv_ps(next, x, keep)
        };
        let po = _mm256_add_ps(at, _mm256_mul_ps(_mm256_set1_ps(self.d), side));
        // `round_away`: up where `side > 0`, down (`-next_float_up(-po)`) where `side < 0`.
        let down = _mm256_xor_ps(up(_mm256_xor_ps(po, sign)), sign);
        let o = _mm256_blendv_ps(po, down, _mm256_cmp_ps::<_CMP_LT_OQ>(side, zero));
        let o = _mm256_blendv_ps(o, up(po), _mm256_cmp_ps::<_CMP_GT_OQ>(side, zero));
        let mut out = [0f32; 8];
        // SAFETY: an eight-float store into an eight-float array.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), o) };
        [Vec3::new(out[0], out[1], out[2]), Vec3::new(out[3], out[4], out[5])]
    }

    /// The shadow ray towards `target` and its `t_max`, as [`spawn_ray_to`].
    /// PERF: not inlined: inlined into `direct_lighting` (as the compiler chose once the
    /// crate grew), it made point-light scenes 25% slower (tp2-plane-point 0.59 -> 0.77 s).
    #[inline(never)]
    pub fn to(&mut self, target: Vec3) -> Option<(Ray, f32)> {
        self.to_inline(target)
    }

    /// [`ShadowRays::to`], inlined into the caller.
    #[inline(always)]
    pub fn to_inline(&mut self, target: Vec3) -> Option<(Ray, f32)> {
        let back = (target - self.p).dot(self.n) < 0.0;
        // PERF: the origin computed into a local, then cached: read back from the cache
        // just written (float by float), it stalled on store forwarding.
        let slot = &mut self.origins[usize::from(back)];
        let origin = match *slot {
            Some(origin) => origin,
            None => {
                let origin = offset_along(self.p, self.d, if back { -self.n } else { self.n });
                *slot = Some(origin);
                origin
            }
        };
        let to = target - origin;
        let dist = to.length();
        (dist > 0.0 && dist.is_finite()).then(|| (Ray::new(origin, to / dist), dist * (1.0 - 1e-4)))
    }
}

/// Rays for the tests of a shape's lane kernels against its one-ray test: random rays from
/// inside, outside and on the surface of a shape near `(0, 0, 3)`, grazing ones, zero and
/// NaN directions, empty and negative intervals, 1 to [`LANES`] per round.
#[cfg(test)]
fn lane_test_rounds() -> impl Iterator<Item = Vec<RaySegment>> {
    let mut rng = crate::math::sampling::Sampler::from_seed(9);
    (0..4000).map(move |round| {
        let mut r = || rng.next_f32() * 6.0 - 3.0;
        let mut rays = Vec::new();
        for k in 0..1 + round % LANES {
            let origin = Vec3::new(r(), r(), r() + 3.0);
            let mut direction = Vec3::new(r(), r(), r());
            let (mut t_min, mut t_max) = (0.0, if k % 3 == 0 { f32::INFINITY } else { r().abs() * 4.0 });
            match (round + k) % 11 {
                0 => direction = Vec3::ZERO,
                1 => direction.x = f32::NAN,
                2 => t_max = 0.0,
                3 => t_min = -1.0,
                _ => {}
            }
            rays.push(RaySegment { origin, t_min, direction, t_max });
        }
        rays
    })
}

/// The test of a shape's `hit_lanes` against its `intersect`, lane by lane, on the rays of
/// [`lane_test_rounds`]; both answers must occur often. Shared by
/// [`crate::geometry::Sphere`] and [`crate::geometry::Plane`].
#[cfg(test)]
pub(crate) fn check_hit_lanes(hit_lanes: impl Fn(&RayLanes) -> u32, intersects: impl Fn(&Ray, f32, f32) -> bool) {
    let (mut hits, mut total) = (0, 0);
    for rays in lane_test_rounds() {
        let mask = hit_lanes(&RayLanes::new(&rays));
        for (k, ray) in rays.iter().enumerate() {
            let expected = intersects(&ray.ray(), ray.t_min, ray.t_max);
            assert_eq!(mask & (1 << k) != 0, expected, "{ray:?}");
            hits += usize::from(expected);
            total += 1;
        }
        // Unused lanes (zero rays) hit nothing.
        assert_eq!(mask >> rays.len(), 0);
    }
    assert!(hits > total / 10 && hits < total * 9 / 10, "{hits} of {total}");
}

/// The test of a shape's `closest_lanes` against its `intersect`, lane by lane, on the rays
/// of [`lane_test_rounds`]: the same `t`, bit for bit, where `intersect` finds one and the
/// lane's `t_best` (its `t_max`) unchanged where it does not.
#[cfg(test)]
pub(crate) fn check_closest_lanes(
    closest_lanes: impl Fn(&RayLanes, &mut [f32; LANES]) -> u32,
    intersect: impl Fn(&Ray, f32, f32) -> Option<f32>,
) {
    let (mut hits, mut total) = (0, 0);
    for rays in lane_test_rounds() {
        let lanes = RayLanes::new(&rays);
        let mut t_best = lanes.t_max;
        let mask = closest_lanes(&lanes, &mut t_best);
        for (k, ray) in rays.iter().enumerate() {
            let expected = intersect(&ray.ray(), ray.t_min, ray.t_max);
            assert_eq!(mask & (1 << k) != 0, expected.is_some(), "{ray:?}");
            assert_eq!(t_best[k].to_bits(), expected.unwrap_or(ray.t_max).to_bits(), "{ray:?}");
            hits += usize::from(expected.is_some());
            total += 1;
        }
        assert_eq!(mask >> rays.len(), 0);
    }
    assert!(hits > total / 10 && hits < total * 9 / 10, "{hits} of {total}");
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every one of the 65536 sets of flags gives its own mask.
    #[test]
    fn lane_mask_sets_the_bit_of_each_flag() {
        for mask in 0..1u32 << LANES {
            let flags: [bool; LANES] = std::array::from_fn(|k| mask & (1 << k) != 0);
            assert_eq!(lane_mask(&flags), mask);
        }
    }

    #[test]
    fn a_point_known_exactly_still_moves_off_its_surface() {
        // A plane through the origin gives its points with no error at all: the offset is
        // 0, and a ray spawned there must still leave the plane (it met it at t = -0).
        let plane = crate::geometry::Plane::new(Vec3::ZERO, Vec3::Y);
        for (n, w) in [(Vec3::Y, -Vec3::Y), (-Vec3::Y, Vec3::Y), (Vec3::Y, Vec3::new(0.3, -1.0, 0.0).normalize())] {
            let r = spawn_ray(Vec3::ZERO, Vec3::ZERO, n, w);
            assert!(r.origin.y * w.y > 0.0, "{r:?}: on the side of w");
            assert!(plane.intersect(&r, 0.0, f32::INFINITY).is_none(), "{r:?} hits the plane it leaves");
        }
    }

    #[test]
    fn offset_leaves_the_error_box_on_the_side_of_w() {
        for p in [Vec3::ZERO, Vec3::new(1000.0, -250.0, 3.0), Vec3::new(-1e-3, 5.0, -7.0), Vec3::new(3e7, -1e-30, 2.5)] {
            for n in [Vec3::X, -Vec3::Y, Vec3::new(0.6, 0.0, -0.8)] {
                let err = p.abs() * gamma(7) + Vec3::splat(1e-30);
                for w in [n, -n, n + Vec3::new(0.1, 0.2, 0.3)] {
                    let q = offset_ray_origin(p, err, n, w);
                    let side = if w.dot(n) < 0.0 { -n } else { n };
                    // Past the error box along the normal, whatever the rounding.
                    let moved = (q - p).dot(side);
                    assert!(moved >= n.abs().dot(err) * 0.999, "p={p} n={n} q={q} moved={moved}");
                    assert!((q - p).length() < 1e-5 * (1.0 + p.length()));
                }
            }
        }
    }

    #[test]
    fn next_floats() {
        assert_eq!(next_float_up(1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_float_down(1.0), 1.0 - f32::EPSILON / 2.0);
        assert!(next_float_up(-0.0) > 0.0 && next_float_up(0.0) > 0.0);
        assert!(next_float_down(0.0) < 0.0);
        assert_eq!(next_float_up(-1.0), -1.0 + f32::EPSILON / 2.0);
        assert_eq!(next_float_up(f32::INFINITY), f32::INFINITY);
        assert_eq!(next_float_up(f32::MAX), f32::INFINITY);
        assert!(next_float_up(f32::NAN).is_nan() && next_float_down(f32::NAN).is_nan());
        assert_eq!(next_float_up(f32::NEG_INFINITY), f32::MIN);
        assert_eq!(next_float_down(f32::NEG_INFINITY), f32::NEG_INFINITY);
        assert_eq!(next_float_up(-f32::from_bits(1)).to_bits(), (-0.0f32).to_bits());
        assert_eq!((round_away(1.0, 2.0), round_away(1.0, -2.0), round_away(1.0, 0.0)), (next_float_up(1.0), next_float_down(1.0), 1.0));
        assert!(gamma(3) > 3.0 * f32::EPSILON / 2.0 && gamma(3) < 3.1 * f32::EPSILON / 2.0);
    }

    #[test]
    fn shadow_rays_leave_on_the_light_side_and_stop_short() {
        let p = Vec3::new(3.0, -3.0, 1.0);
        let light = Vec3::new(0.0, 3.0, -5.0);
        let err = p.abs() * gamma(7);
        for ng in [Vec3::Y, -Vec3::Y] {
            let (r, t_max) = spawn_ray_to(p, err, ng, light).unwrap();
            assert!(r.origin.y > p.y, "offset towards the light's side");
            assert!((r.direction.length() - 1.0).abs() < 1e-6);
            assert!(t_max < (light - r.origin).length() && r.at(t_max).distance(light) < 1e-2);
        }
        assert!(spawn_ray_to(p, err, Vec3::Y, Vec3::new(f32::INFINITY, 0.0, 0.0)).is_none());
    }

    #[test]
    fn invalid_rays_are_reported() {
        assert!(Ray::new(Vec3::ZERO, Vec3::X).is_valid());
        assert!(!Ray::new(Vec3::ZERO, Vec3::ZERO).is_valid());
        assert!(!Ray::new(Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 1.0)).is_valid());
        assert!(!Ray::new(Vec3::splat(f32::INFINITY), Vec3::X).is_valid());
    }

    #[test]
    fn shadow_rays_from_one_point_are_those_of_spawn_ray_to() {
        let mut rng = crate::math::sampling::Sampler::from_seed(7);
        for _ in 0..200 {
            let mut r = || rng.next_f32() * 20.0 - 10.0;
            let p = Vec3::new(r(), r(), r());
            let err = Vec3::new(r().abs(), r().abs(), r().abs()) * 1e-5;
            let ng = Vec3::new(r(), r(), r()).normalize();
            let mut rays = ShadowRays::new(p, err, ng);
            for _ in 0..8 {
                let target = Vec3::new(r(), r(), r());
                assert_eq!(rays.to(target), spawn_ray_to(p, err, ng, target));
            }
            assert_eq!(rays.to(p), spawn_ray_to(p, err, ng, p));
            assert_eq!(rays.to(Vec3::splat(f32::NAN)), None);
        }
    }

    /// `both_origins_avx2` gives `both_origins`' two offset origins bit for bit: normals
    /// with zero and signed-zero components, points at zero, huge, infinite and NaN,
    /// error bounds zero and not.
    #[test]
    fn both_origins_in_avx2_are_both_origins() {
        #[cfg(target_arch = "x86_64")]
        {
            if !std::arch::is_x86_feature_detected!("avx2") {
                eprintln!("no AVX2 on this CPU: the portable path is the one that runs");
                return;
            }
            let mut rng = crate::math::sampling::Sampler::from_seed(17);
            let special = [0.0, -0.0, 1.0, -1.0, 3.0e38, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 1e-42, -1e-42];
            let mut moved = 0;
            for round in 0..20_000 {
                let mut r = |k: usize| {
                    let x = rng.next_f32() * 20.0 - 10.0;
                    if (round + k).is_multiple_of(4) {
                        special[(round / 4 + k) % special.len()]
                    } else {
                        x
                    }
                };
                let p = Vec3::new(r(0), r(1), r(2));
                let ng = Vec3::new(r(3), r(4), r(5));
                let err = if round % 3 == 0 { Vec3::ZERO } else { Vec3::new(r(6).abs(), r(7).abs(), r(8).abs()) * 1e-5 };
                let rays = ShadowRays::new(p, err, ng);
                // SAFETY: the CPU has AVX2.
                let got = unsafe { rays.both_origins_avx2() };
                let expected = rays.both_origins();
                for (a, b) in got.iter().zip(&expected) {
                    for i in 0..3 {
                        assert!(
                            a[i].to_bits() == b[i].to_bits() || (a[i].is_nan() && b[i].is_nan()),
                            "{p} {ng} {err}: {got:?} {expected:?}"
                        );
                    }
                }
                moved += usize::from(expected[0] != p);
            }
            assert!(moved > 10_000, "{moved}");
        }
    }

    /// `outgoing` is `-d.normalize()` lane by lane, bit for bit, in the AVX2 build and the
    /// portable one: tiny, huge, axis-aligned, zero and NaN directions.
    #[test]
    fn outgoing_is_the_reversed_unit_direction() {
        let mut rng = crate::math::sampling::Sampler::from_seed(21);
        for round in 0..500 {
            let mut lanes = RayLanes::EMPTY;
            for k in 0..LANES {
                let scale = [1.0, 1e-20, 1e20, 3.0][(round + k) % 4];
                let mut d = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5) * scale;
                match (round + k) % 9 {
                    0 => d = Vec3::ZERO,
                    1 => d.y = f32::NAN,
                    2 => d = Vec3::new(0.0, -scale, 0.0),
                    _ => {}
                }
                for axis in 0..3 {
                    lanes.d[axis][k] = d[axis];
                }
            }
            let (got, portable) = (lanes.outgoing(), lanes.outgoing_portable());
            for k in 0..LANES {
                let want = (-Vec3::new(lanes.d[0][k], lanes.d[1][k], lanes.d[2][k]).normalize()).to_array().map(f32::to_bits);
                assert_eq!([got[0][k], got[1][k], got[2][k]].map(f32::to_bits), want, "lane {k}");
                assert_eq!([portable[0][k], portable[1][k], portable[2][k]].map(f32::to_bits), want, "lane {k}");
            }
        }
    }

    /// `spawn_lanes` gives `spawn_ray`'s rays bit for bit in the lanes asked for (both code
    /// paths where the CPU has AVX2: points known exactly, directions along the surface,
    /// on either side), zero rays in the others.
    #[test]
    fn spawned_lanes_are_the_rays_of_spawn_ray() {
        let mut rng = crate::math::sampling::Sampler::from_seed(11);
        for round in 0..2000u32 {
            let mut r = || rng.next_f32() * 20.0 - 10.0;
            let (mut from, mut w) = (SurfaceLanes::default(), [[0f32; LANES]; 3]);
            let mut want = Vec::new();
            #[allow(clippy::needless_range_loop)] // one index into several arrays
            for k in 0..LANES {
                let p = if k % 5 == 0 { Vec3::ZERO } else { Vec3::new(r(), r(), r()) };
                let err = if k % 5 == 0 { Vec3::ZERO } else { Vec3::new(r().abs(), r().abs(), r().abs()) * 1e-5 };
                let ng = Vec3::new(r(), r(), r()).normalize();
                let dir = if k % 7 == 0 { ng.cross(Vec3::X).normalize() } else { Vec3::new(r(), r(), r()).normalize() };
                for axis in 0..3 {
                    (from.p[axis][k], from.p_error[axis][k], from.ng[axis][k], w[axis][k]) = (p[axis], err[axis], ng[axis], dir[axis]);
                }
                want.push(spawn_ray(p, err, ng, dir));
            }
            let mask = round.wrapping_mul(0x9e37_79b9) & 0xffff;
            // Both start from rays of 7s: the lanes left out must be written too.
            let sevens = RayLanes { o: [[7.0; LANES]; 3], d: [[7.0; LANES]; 3], t_min: [7.0; LANES], t_max: [7.0; LANES] };
            let (mut lanes, mut portable) = (sevens, sevens);
            spawn_lanes(&from, &w, mask, &mut lanes);
            spawn_lanes_portable(&from, &w, mask, &mut portable);
            assert!((0..LANES).all(|k| lanes.segment(k) == portable.segment(k)));
            for (k, ray) in want.iter().enumerate() {
                if mask & (1 << k) != 0 {
                    assert_eq!(
                        lanes.segment(k),
                        RaySegment { origin: ray.origin, t_min: 0.0, direction: ray.direction, t_max: f32::INFINITY }
                    );
                } else {
                    assert_eq!(lanes.segment(k), RaySegment { origin: Vec3::ZERO, t_min: 0.0, direction: Vec3::ZERO, t_max: 0.0 });
                }
            }
        }
    }
}
