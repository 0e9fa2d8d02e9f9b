//! Random numbers for rendering, seeded from `(seed, pixel, sample)` so that every pixel
//! sample draws the same numbers whichever thread renders it: renders are reproducible
//! on any number of threads.

use crate::math::ray::LANES;

/// SplitMix64's finaliser: spreads nearby integers over all 64 bits.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The generator of sample `sample` of pixel `pixel` (row-major index) for render seed `seed`.
#[must_use]
pub fn pixel_rng(seed: u64, pixel: u64, sample: u32) -> Sampler {
    let state = mix(seed ^ mix(pixel.wrapping_add(0x9e37_79b9_7f4a_7c15)));
    // `rand_pcg::Pcg32::new(state, stream)`: the stream's increment is odd.
    Sampler::from_state_incr(state, (u64::from(sample) << 1) | 1)
}

/// PCG32's multiplier (O'Neill's `PCG32`, XSH RR output on a 64-bit LCG).
const MUL: u64 = 6_364_136_223_846_793_005;

/// `MUL^k` and `1 + MUL + … + MUL^(k-1)`: `k` steps of the LCG are
/// `s ↦ MUL^k·s + inc·SUM_k` (all mod 2⁶⁴).
const fn jump(k: u32) -> (u64, u64) {
    let (mut m, mut sum, mut i) = (1u64, 0u64, 0);
    while i < k {
        sum = sum.wrapping_add(m);
        m = m.wrapping_mul(MUL);
        i += 1;
    }
    (m, sum)
}

/// A per-sample random number generator: PCG32 (`rand_pcg::Pcg32`, O'Neill 2014), the
/// same numbers as `rand_pcg`'s generator and `rand`'s `f32` (tested), written here for
/// [`Sampler::fill_2d`], which needs the state.
/// PERF: a hit's sixteen light samples drew their 32 numbers through one chain of
/// dependent multiplies (8% of tp6-glass-quad's render); `fill_2d` runs four chains.
/// `repr(C)`: [`Sampler::draw_lanes`] loads sixteen generators as (state, increment)
/// pairs of `u64`s.
#[derive(Clone, Debug)]
#[repr(C)]
pub struct Sampler {
    state: u64,
    inc: u64,
}

impl Sampler {
    /// `rand_pcg`'s `from_state_incr`: away from the initial value by one step.
    #[inline]
    fn from_state_incr(state: u64, inc: u64) -> Self {
        Sampler { state: step(state.wrapping_add(inc), inc), inc }
    }

    /// A generator from a plain seed (tools and tests): `Pcg32::seed_from_u64(seed)`.
    #[must_use]
    pub fn from_seed(seed: u64) -> Self {
        // `rand_core`'s `seed_from_u64`: four outputs of a fixed PCG32 as the 16-byte
        // seed, read as two little-endian `u64`s (state, increment).
        let mut state = seed;
        let mut word = || {
            state = step(state, 11_634_580_027_462_260_723);
            u64::from(output(state))
        };
        let (a, b, c, d) = (word(), word(), word(), word());
        Self::from_state_incr(a | b << 32, (c | d << 32) | 1)
    }

    /// A uniform number in `[0, 1)`.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        let s = self.state;
        self.state = step(s, self.inc);
        unit(output(s))
    }

    /// Two uniform numbers in `[0, 1)`.
    #[inline]
    pub fn next_2d(&mut self) -> glam::Vec2 {
        glam::Vec2::new(self.next_f32(), self.next_f32())
    }

    /// `out.len()` pairs of numbers, those of as many calls to [`Sampler::next_2d`], and
    /// the generator left where those calls leave it. The states come from several
    /// chains (`s ↦ MUL⁴·s + inc·SUM₄` on four scalar chains; on eight in one AVX-512
    /// register from four pairs on, where the CPU has AVX-512 DQ and VL), so several
    /// multiplies are in flight instead of one.
    #[inline(always)]
    pub fn fill_2d(&mut self, out: &mut [glam::Vec2]) {
        #[cfg(target_arch = "x86_64")]
        if out.len() >= 4 && Self::has_avx512_fill() {
            // SAFETY: the CPU has AVX-512 DQ and VL (and so F), which is all
            // `fill_2d_avx512` is compiled for.
            unsafe { self.fill_2d_avx512(out) };
            return;
        }
        self.fill_2d_portable(out);
    }

    /// Whether this CPU runs [`Sampler::fill_2d_avx512`] and [`Sampler::draw_lanes_avx512`]
    /// (AVX-512 F, DQ and VL).
    #[cfg(target_arch = "x86_64")]
    #[inline]
    fn has_avx512_fill() -> bool {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512dq")
            && std::arch::is_x86_feature_detected!("avx512vl")
    }

    /// [`Sampler::fill_2d`] on eight chains of eight steps (`s ↦ MUL⁸·s + inc·SUM₈`), the
    /// eight states one AVX-512 register: the multiplies (`vpmullq`), the outputs' shifts
    /// and rotations (`vprorvd`) and the conversions eight at a time.
    /// PERF: the four scalar chains were 10% of tp6-matte-quad's Whitted render (sixteen
    /// light samples a hit).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl")]
    fn fill_2d_avx512(&mut self, out: &mut [glam::Vec2]) {
        use std::arch::x86_64::{
            _mm256_storeu_ps, _mm512_add_epi64, _mm512_castsi512_si128, _mm512_loadu_si512, _mm512_mullo_epi64, _mm512_set1_epi64,
            _mm512_storeu_si512, _mm_cvtsi128_si64,
        };
        const J: [(u64, u64); 9] = [jump(0), jump(1), jump(2), jump(3), jump(4), jump(5), jump(6), jump(7), jump(8)];
        const J_MUL: [u64; 8] = [J[0].0, J[1].0, J[2].0, J[3].0, J[4].0, J[5].0, J[6].0, J[7].0];
        const J_SUM: [u64; 8] = [J[0].1, J[1].1, J[2].1, J[3].1, J[4].1, J[5].1, J[6].1, J[7].1];
        // PERF: the eight chains' states set up and read back in registers (written as
        // arrays, LLVM assembled them lane by lane: half of the function's instructions
        // for sixteen pairs).
        // SAFETY: 64-byte loads from eight-`u64` arrays.
        let (j_mul, j_sum) = unsafe { (_mm512_loadu_si512(J_MUL.as_ptr().cast()), _mm512_loadu_si512(J_SUM.as_ptr().cast())) };
        let inc = _mm512_set1_epi64(self.inc as i64);
        // Chain `k` starts `k` steps on: `MUL^k·s + inc·SUM_k`.
        let mut st = _mm512_add_epi64(_mm512_mullo_epi64(_mm512_set1_epi64(self.state as i64), j_mul), _mm512_mullo_epi64(inc, j_sum));
        let (m8, c8) = (_mm512_set1_epi64(J[8].0 as i64), _mm512_set1_epi64(self.inc.wrapping_mul(J[8].1) as i64));
        let mut fours = out.chunks_exact_mut(4);
        for four in &mut fours {
            // SAFETY: this function has AVX-512 F and VL; `four` is four `Vec2`s, eight
            // contiguous `f32`s (`Vec2` is `repr(C)` x then y): pair `i` gets chains `2i`
            // and `2i + 1`.
            unsafe { _mm256_storeu_ps(four.as_mut_ptr().cast(), unit8(st)) };
            st = _mm512_add_epi64(_mm512_mullo_epi64(st, m8), c8);
        }
        let rest = fours.into_remainder();
        if rest.is_empty() {
            self.state = _mm_cvtsi128_si64(_mm512_castsi512_si128(st)) as u64;
            return;
        }
        let mut lanes = [0u64; 8];
        // SAFETY: a 64-byte store into an eight-`u64` array.
        unsafe { _mm512_storeu_si512(lanes.as_mut_ptr().cast(), st) };
        for (i, pair) in rest.iter_mut().enumerate() {
            *pair = glam::Vec2::new(unit(output(lanes[2 * i])), unit(output(lanes[2 * i + 1])));
        }
        self.state = lanes[2 * rest.len()];
    }

    /// The generator moved on by `K` numbers, left where `K` calls of
    /// [`Sampler::next_f32`] leave it, in one jump (`s ↦ MUL^K·s + inc·SUM_K`): for numbers
    /// drawn only to keep every later number where it would be.
    #[inline]
    pub fn skip<const K: u32>(&mut self) {
        let (m, sum) = const { jump(K) };
        self.state = self.state.wrapping_mul(m).wrapping_add(self.inc.wrapping_mul(sum));
    }

    /// For each lane `k` of `mask` below `samplers.len()` (at most [`LANES`] generators),
    /// `N` numbers, those of `N` calls of `samplers[k].next_f32()`: `out[j][k]` is lane
    /// `k`'s `j`-th, and the generator is left where those calls leave it. Other lanes'
    /// generators are untouched and their entries of `out` hold anything.
    /// PERF: the path tracer's lanes drew their numbers lane by lane, each generator a
    /// chain of dependent 64-bit multiplies; with AVX-512 (DQ for `vpmullq`, VL) the
    /// sixteen generators step together, two registers of eight: the path tracer (Lambert,
    /// 64 spp) on tp6-glass-quad 0.976 and tp6-matte 0.975 of the CPU time (paired medians
    /// of 9 and 7 runs). Numbers drawn only to be thrown away are skipped instead
    /// ([`Sampler::skip`]): drawn here, the point-light scenes took 1.01 of the time.
    #[inline]
    pub fn draw_lanes<const N: usize>(samplers: &mut [Sampler], mask: u32, out: &mut [[f32; LANES]; N]) {
        let n = samplers.len().min(LANES);
        let mask = mask & ((1u32 << n) - 1);
        if mask == 0 {
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if Self::has_avx512_fill() {
            // SAFETY: the CPU has AVX-512 DQ and VL (and so F), which is all
            // `draw_lanes_avx512` is compiled for; `samplers` holds at least `n` generators.
            unsafe { Self::draw_lanes_avx512(&mut samplers[..n], mask, out) };
            return;
        }
        Self::draw_lanes_portable(samplers, mask, out);
    }

    /// [`Sampler::draw_lanes`] one lane at a time (`mask` within `samplers`).
    #[inline]
    fn draw_lanes_portable<const N: usize>(samplers: &mut [Sampler], mask: u32, out: &mut [[f32; LANES]; N]) {
        let mut m = mask;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            for row in out.iter_mut() {
                row[k] = samplers[k].next_f32();
            }
        }
    }

    /// [`Sampler::draw_lanes`] with the sixteen generators in two AVX-512 registers of
    /// eight states (and two of their increments), `mask` within `samplers` (at most
    /// [`LANES`] of them).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl")]
    fn draw_lanes_avx512<const N: usize>(samplers: &mut [Sampler], mask: u32, out: &mut [[f32; LANES]; N]) {
        use std::arch::x86_64::*;
        const _: () = assert!(LANES == 16 && std::mem::size_of::<Sampler>() == 16);
        let n = samplers.len();
        debug_assert!(n <= LANES && mask >> n == 0);
        let base = samplers.as_mut_ptr().cast::<i64>();
        // The `u64`s of generators `4c..4c + 4` that exist: two per generator.
        let words = |c: usize| -> __mmask8 {
            let have = n.saturating_sub(4 * c).min(4);
            ((1u32 << (2 * have)) - 1) as __mmask8
        };
        // SAFETY: masked loads read only the elements their mask selects, all inside
        // `samplers` (generator `4c + i` exists when its two bits are set); the pointer
        // arithmetic wraps, never dereferenced beyond the slice.
        let load = |c: usize| unsafe { _mm512_maskz_loadu_epi64(words(c), base.wrapping_add(8 * c).cast_const()) };
        let (a0, a1, a2, a3) = (load(0), load(1), load(2), load(3));
        let even = _mm512_set_epi64(14, 12, 10, 8, 6, 4, 2, 0);
        let odd = _mm512_set_epi64(15, 13, 11, 9, 7, 5, 3, 1);
        // Lanes 0..8 and 8..16: states and increments.
        let start = [_mm512_permutex2var_epi64(a0, even, a1), _mm512_permutex2var_epi64(a2, even, a3)];
        let inc = [_mm512_permutex2var_epi64(a0, odd, a1), _mm512_permutex2var_epi64(a2, odd, a3)];
        let mul = _mm512_set1_epi64(MUL as i64);
        let mut st = start;
        for row in out.iter_mut() {
            for h in 0..2 {
                // SAFETY: this function has AVX-512 F and VL; eight floats of a
                // sixteen-float row, at 0 or 8.
                unsafe { _mm256_storeu_ps(row.as_mut_ptr().add(8 * h), unit8(st[h])) };
                st[h] = _mm512_add_epi64(_mm512_mullo_epi64(st[h], mul), inc[h]);
            }
        }
        // The lanes drawn keep their new states; the others their old ones.
        let kept =
            [_mm512_mask_blend_epi64(mask as __mmask8, start[0], st[0]), _mm512_mask_blend_epi64((mask >> 8) as __mmask8, start[1], st[1])];
        // Back as (state, increment) pairs; only the states of existing generators stored.
        let first = _mm512_set_epi64(11, 3, 10, 2, 9, 1, 8, 0);
        let second = _mm512_set_epi64(15, 7, 14, 6, 13, 5, 12, 4);
        let pairs = [
            _mm512_permutex2var_epi64(kept[0], first, inc[0]),
            _mm512_permutex2var_epi64(kept[0], second, inc[0]),
            _mm512_permutex2var_epi64(kept[1], first, inc[1]),
            _mm512_permutex2var_epi64(kept[1], second, inc[1]),
        ];
        for (c, p) in pairs.into_iter().enumerate() {
            // SAFETY: as for the loads: only existing generators' states are written.
            unsafe { _mm512_mask_storeu_epi64(base.wrapping_add(8 * c), words(c) & 0x55, p) };
        }
    }

    /// [`Sampler::fill_2d`] without AVX-512: four chains of four steps.
    #[inline]
    fn fill_2d_portable(&mut self, out: &mut [glam::Vec2]) {
        const J: [(u64, u64); 5] = [jump(0), jump(1), jump(2), jump(3), jump(4)];
        let s = self.state;
        let mut st: [u64; 4] = std::array::from_fn(|k| J[k].0.wrapping_mul(s).wrapping_add(self.inc.wrapping_mul(J[k].1)));
        let c4 = self.inc.wrapping_mul(J[4].1);
        let mut pairs = out.chunks_exact_mut(2);
        for two in &mut pairs {
            two[0] = glam::Vec2::new(unit(output(st[0])), unit(output(st[1])));
            two[1] = glam::Vec2::new(unit(output(st[2])), unit(output(st[3])));
            st = st.map(|x| x.wrapping_mul(J[4].0).wrapping_add(c4));
        }
        if let [last] = pairs.into_remainder() {
            *last = glam::Vec2::new(unit(output(st[0])), unit(output(st[1])));
            self.state = st[2];
        } else {
            self.state = st[0];
        }
    }
}

/// [`unit()`] of [`output`] of eight states at once (AVX-512: XSH RR's shifts, the
/// narrowing and the rotation `vprorvd`, then the conversion), the same floats.
///
/// # Safety
/// The CPU must have AVX-512 F and VL.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn unit8(s: std::arch::x86_64::__m512i) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::*;
    // SAFETY: the caller guarantees AVX-512 F and VL.
    unsafe {
        let xsh = _mm512_cvtepi64_epi32(_mm512_srli_epi64::<27>(_mm512_xor_si512(_mm512_srli_epi64::<18>(s), s)));
        let x = _mm256_rorv_epi32(xsh, _mm512_cvtepi64_epi32(_mm512_srli_epi64::<59>(s)));
        _mm256_mul_ps(_mm256_set1_ps(1.0 / (1u32 << 24) as f32), _mm256_cvtepi32_ps(_mm256_srli_epi32::<8>(x)))
    }
}

/// One step of PCG's LCG: `s ↦ MUL·s + inc` (mod 2⁶⁴).
#[inline(always)]
fn step(s: u64, inc: u64) -> u64 {
    s.wrapping_mul(MUL).wrapping_add(inc)
}

/// PCG's XSH RR output of the state `s`.
#[inline(always)]
fn output(s: u64) -> u32 {
    let xsh = (((s >> 18) ^ s) >> 27) as u32;
    xsh.rotate_right((s >> 59) as u32)
}

/// `rand`'s `f32` in `[0, 1)`: the top 24 bits times 2⁻²⁴.
#[inline(always)]
fn unit(x: u32) -> f32 {
    (1.0 / (1u32 << 24) as f32) * (x >> 8) as f32
}

/// `(sin 2πu, cos 2πu)`: the sine and cosine of `u` turns, without a branch or a call,
/// so that a loop over lanes of it is SIMD code (the library's `sinf`/`cosf` are one call
/// per lane). Exact range reduction in quarter turns (`4u` minus its nearest integer is
/// exact in `f32`), then Taylor polynomials on `[-π/4, π/4]` (truncation below 2e-9),
/// then the quadrant's swap and signs. Within 2.4e-7 of the true values for `u` in
/// `[0, 1)` (tested), where `2π·u` rounded to `f32` before `sin` was off by up to that
/// much already; NaN for a NaN or infinite `u`.
/// PERF: path tracer, Lambert, tp6-matte at 16 spp: `sincosf` was 12% of the render.
#[inline(always)]
#[must_use]
pub fn sin_cos_turns(u: f32) -> (f32, f32) {
    let t = u * 4.0;
    let q = t.round_ties_even();
    let x = (t - q) * std::f32::consts::FRAC_PI_2;
    let x2 = x * x;
    let s = x * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0)))));
    let c = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0 + x2 * (-1.0 / 3_628_800.0)))));
    // The quadrant, 0 to 3 (exact: `q` is an integer).
    let k = q - 4.0 * (q * 0.25).floor();
    let (s, c) = if k == 1.0 || k == 3.0 { (c, s) } else { (s, c) };
    let sin = if k >= 2.0 { -s } else { s };
    let cos = if k == 1.0 || k == 2.0 { -c } else { c };
    (sin, cos)
}

/// Cosine-distributed direction about `n` (unit), from two uniform numbers
/// (Malley's method: a uniform disk point lifted to the hemisphere).
#[must_use]
pub fn square_to_cosine_hemisphere(n: glam::Vec3, xi: glam::Vec2) -> glam::Vec3 {
    let r = xi.x.sqrt();
    let (sin, cos) = sin_cos_turns(xi.y);
    let (x, y) = (r * cos, r * sin);
    let z = (1.0 - xi.x).max(0.0).sqrt();
    let (t, b) = n.any_orthonormal_pair();
    (x * t + y * b + z * n).normalize()
}

/// The pdf (solid angle) of [`square_to_cosine_hemisphere`].
#[must_use]
pub fn square_to_cosine_hemisphere_pdf(n: glam::Vec3, w: glam::Vec3) -> f32 {
    n.dot(w).max(0.0) * std::f32::consts::FRAC_1_PI
}

/// [`square_to_cosine_hemisphere`] and [`square_to_cosine_hemisphere_pdf`] for
/// [`LANES`] normals side by side (`n[axis][k]`, uniform numbers
/// `xi[k]`): the directions (`wi[axis][k]`) and their pdfs, bit for bit the scalar
/// functions' (the same operations in the same order, [`sin_cos_turns`] included). The
/// loops run eight lanes wide where the CPU has AVX2.
#[must_use]
pub fn cosine_hemisphere_lanes(n: &[[f32; LANES]; 3], xi: &[glam::Vec2; LANES]) -> ([[f32; LANES]; 3], [f32; LANES]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        #[target_feature(enable = "avx2")]
        fn avx2(n: &[[f32; LANES]; 3], xi: &[glam::Vec2; LANES]) -> ([[f32; LANES]; 3], [f32; LANES]) {
            cosine_hemisphere_lanes_portable(n, xi)
        }
        // SAFETY: the CPU has AVX2, which is all `avx2` is compiled for.
        return unsafe { avx2(n, xi) };
    }
    cosine_hemisphere_lanes_portable(n, xi)
}

#[inline(always)]
#[allow(clippy::needless_range_loop)] // one index into many arrays: the loops vectorise
fn cosine_hemisphere_lanes_portable(n: &[[f32; LANES]; 3], xi: &[glam::Vec2; LANES]) -> ([[f32; LANES]; 3], [f32; LANES]) {
    let (mut r, mut z) = ([0f32; LANES], [0f32; LANES]);
    let (mut cos, mut sin) = ([0f32; LANES], [0f32; LANES]);
    for k in 0..LANES {
        r[k] = xi[k].x.sqrt();
        (sin[k], cos[k]) = sin_cos_turns(xi[k].y);
        z[k] = (1.0 - xi[k].x).max(0.0).sqrt();
    }
    let mut wi = [[0f32; LANES]; 3];
    let mut pdf = [0f32; LANES];
    for k in 0..LANES {
        let (nx, ny, nz) = (n[0][k], n[1][k], n[2][k]);
        let (x, y) = (r[k] * cos[k], r[k] * sin[k]);
        // `Vec3::any_orthonormal_pair` (Duff et al.), as glam writes it.
        let sign = if nz.is_nan() { f32::NAN } else { 1f32.copysign(nz) };
        let a = -1.0 / (sign + nz);
        let b = nx * ny * a;
        let t = [1.0 + sign * nx * nx * a, sign * b, -sign * nx];
        let bb = [b, sign + ny * ny * a, -ny];
        let nn = [nx, ny, nz];
        // No `array::map` here: out of line, it would keep the loop scalar.
        let mut w = [0f32; 3];
        for i in 0..3 {
            w[i] = x * t[i] + y * bb[i] + z[k] * nn[i];
        }
        // `Vec3::normalize`: times the reciprocal of the length.
        let recip = 1.0 / (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        for i in 0..3 {
            w[i] *= recip;
            wi[i][k] = w[i];
        }
        pdf[k] = (nx * w[0] + ny * w[1] + nz * w[2]).max(0.0) * std::f32::consts::FRAC_1_PI;
    }
    (wi, pdf)
}

/// A direction uniform on the unit sphere, from two uniform numbers (Archimedes: `z`
/// uniform in [-1, 1]).
#[must_use]
pub fn square_to_uniform_sphere(xi: glam::Vec2) -> glam::Vec3 {
    let z = 1.0 - 2.0 * xi.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * xi.y;
    glam::Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// The pdf (solid angle) of [`square_to_uniform_sphere`]: `1/(4π)`.
#[must_use]
pub fn square_to_uniform_sphere_pdf() -> f32 {
    0.25 * std::f32::consts::FRAC_1_PI
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The lanes' cosine-lobe samples are the scalar functions', bit for bit (both code
    /// paths where the CPU has AVX2), normals of every orientation, poles included.
    #[test]
    fn cosine_hemisphere_lanes_are_the_scalar_samples() {
        let mut rng = Sampler::from_seed(3);
        for round in 0..2000 {
            let mut normals = [[0f32; LANES]; 3];
            let mut xi = [glam::Vec2::ZERO; LANES];
            for k in 0..LANES {
                let n = match (round + k) % 7 {
                    0 => Vec3::Z,
                    1 => -Vec3::Z,
                    2 => Vec3::new(1e-9, 0.0, -1.0).normalize(),
                    _ => Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize(),
                };
                for i in 0..3 {
                    normals[i][k] = n[i];
                }
                xi[k] = rng.next_2d();
            }
            let lanes = cosine_hemisphere_lanes(&normals, &xi);
            assert_eq!(cosine_hemisphere_lanes_portable(&normals, &xi), lanes);
            for k in 0..LANES {
                let n = Vec3::new(normals[0][k], normals[1][k], normals[2][k]);
                let w = square_to_cosine_hemisphere(n, xi[k]);
                let bits = |v: [f32; 3]| v.map(f32::to_bits);
                assert_eq!(bits([lanes.0[0][k], lanes.0[1][k], lanes.0[2][k]]), bits(w.to_array()), "{n} {:?}", xi[k]);
                assert_eq!(lanes.1[k].to_bits(), square_to_cosine_hemisphere_pdf(n, w).to_bits());
            }
        }
    }

    /// Against `f64`'s sine and cosine: every 2⁻²⁰ of a turn, the numbers just below 1,
    /// and the quarter turns exactly (signs and zeros in the right place).
    #[test]
    fn sin_cos_turns_is_within_its_bound() {
        let mut worst = 0f64;
        let below_one = (1..=64).map(|i| f32::from_bits(1f32.to_bits() - i));
        for u in (0..1 << 20).map(|i| i as f32 / (1 << 20) as f32).chain(below_one) {
            let (s, c) = sin_cos_turns(u);
            let a = std::f64::consts::TAU * f64::from(u);
            worst = worst.max((f64::from(s) - a.sin()).abs()).max((f64::from(c) - a.cos()).abs());
        }
        assert!(worst < 2.4e-7, "worst error {worst}");
        assert_eq!(sin_cos_turns(0.0), (0.0, 1.0));
        assert_eq!(sin_cos_turns(0.25), (1.0, 0.0));
        assert_eq!(sin_cos_turns(0.5), (0.0, -1.0));
        assert_eq!(sin_cos_turns(0.75), (-1.0, 0.0));
        assert_eq!(sin_cos_turns(-0.25), (-1.0, 0.0));
        assert_eq!(sin_cos_turns(1e9), (0.0, 1.0));
        let nan = |(s, c): (f32, f32)| s.is_nan() && c.is_nan();
        assert!(nan(sin_cos_turns(f32::NAN)) && nan(sin_cos_turns(f32::INFINITY)));
    }

    /// The numbers of `rand_pcg`'s PCG32 and `rand`'s `f32`, from both constructors, one
    /// at a time and by `fill_2d` (every length up to 33 pairs, then on one at a time):
    /// the portable four chains, and the AVX-512 eight where the CPU has AVX-512 DQ and VL.
    #[test]
    fn the_generator_draws_rand_pcgs_numbers() {
        type Fill = fn(&mut Sampler, &mut [glam::Vec2]);
        let mut fills: Vec<(&str, Fill)> = vec![("fill_2d", Sampler::fill_2d), ("portable", Sampler::fill_2d_portable)];
        #[cfg(target_arch = "x86_64")]
        if Sampler::has_avx512_fill() {
            // SAFETY: the CPU has AVX-512 DQ and VL, which is all `fill_2d_avx512` needs.
            fills.push(("avx512", |s, out| unsafe { s.fill_2d_avx512(out) }));
        }
        for (name, fill) in fills {
            draws_rand_pcgs_numbers(name, fill);
        }
    }

    fn draws_rand_pcgs_numbers(name: &str, fill: fn(&mut Sampler, &mut [glam::Vec2])) {
        use rand::{Rng, SeedableRng};
        for seed in [0, 1, 7, u64::MAX, 0x1234_5678_9abc_def0] {
            for sample in [0, 1, 5, u32::MAX] {
                let state = mix(seed ^ mix(seed.wrapping_add(0x9e37_79b9_7f4a_7c15)));
                let pairs = [(pixel_rng(seed, seed, sample), rand_pcg::Pcg32::new(state, u64::from(sample)))];
                let seeded = [(Sampler::from_seed(seed ^ u64::from(sample)), rand_pcg::Pcg32::seed_from_u64(seed ^ u64::from(sample)))];
                for (mut ours, mut theirs) in pairs.into_iter().chain(seeded) {
                    for n in 0..34 {
                        let mut out = vec![glam::Vec2::ZERO; n];
                        fill(&mut ours, &mut out);
                        for v in out {
                            let (x, y) = (theirs.random::<f32>(), theirs.random::<f32>());
                            assert_eq!((v.x.to_bits(), v.y.to_bits()), (x.to_bits(), y.to_bits()), "{name}: {n} pairs");
                        }
                        assert_eq!(ours.next_f32().to_bits(), theirs.random::<f32>().to_bits());
                    }
                }
            }
        }
    }

    /// Lanes' draws are each generator's own `next_f32` calls, bit for bit, and leave the
    /// generators where those calls leave them: every count of generators up to sixteen,
    /// masks with lanes past the count, one to three numbers, the portable loop and the
    /// AVX-512 registers where the CPU has them.
    #[test]
    fn lanes_draw_each_generators_own_numbers() {
        type Draw<const N: usize> = fn(&mut [Sampler], u32, &mut [[f32; LANES]; N]);
        fn check<const N: usize>(name: &str, draw: Draw<N>, round: u32) {
            let mut masks = Sampler::from_seed(u64::from(round));
            for n in 0..=LANES {
                // Each generator its own stream (increment), sixteen of them, the first
                // `n` given to the draw: those past it must stay as they are.
                let mut all: Vec<Sampler> = (0..LANES).map(|k| pixel_rng(u64::from(round), k as u64, round * 16 + k as u32)).collect();
                let untouched = all[n..].to_vec();
                let mut theirs = all[..n].to_vec();
                for step in 0..6 {
                    let mask = match step {
                        0 => u32::MAX,
                        1 => 0,
                        _ => masks.next_f32().to_bits() ^ (masks.next_f32().to_bits() << 9),
                    };
                    let mut out = [[f32::NAN; LANES]; N];
                    let ours = &mut all[..n];
                    draw(ours, mask, &mut out);
                    for k in 0..n {
                        if mask & (1 << k) != 0 {
                            for (j, row) in out.iter().enumerate() {
                                assert_eq!(
                                    row[k].to_bits(),
                                    theirs[k].next_f32().to_bits(),
                                    "{name}: {n} generators, lane {k}, number {j}"
                                );
                            }
                        }
                        assert_eq!((ours[k].state, ours[k].inc), (theirs[k].state, theirs[k].inc), "{name}: lane {k} left elsewhere");
                    }
                    for (a, b) in all[n..].iter().zip(&untouched) {
                        assert_eq!((a.state, a.inc), (b.state, b.inc), "{name}: a generator past the {n} given was changed");
                    }
                }
            }
        }
        // The two paths called directly, the mask cut to the generators as `draw_lanes` cuts it.
        fn portable<const N: usize>(s: &mut [Sampler], m: u32, o: &mut [[f32; LANES]; N]) {
            Sampler::draw_lanes_portable(s, m & ((1 << s.len()) - 1), o);
        }
        #[cfg(target_arch = "x86_64")]
        fn avx512<const N: usize>(s: &mut [Sampler], m: u32, o: &mut [[f32; LANES]; N]) {
            // SAFETY: only pushed below where the CPU has AVX-512 F, DQ and VL.
            unsafe { Sampler::draw_lanes_avx512(s, m & ((1 << s.len()) - 1), o) };
        }
        let mut paths: Vec<(&str, Draw<1>, Draw<2>, Draw<3>)> =
            vec![("draw_lanes", Sampler::draw_lanes, Sampler::draw_lanes, Sampler::draw_lanes), ("portable", portable, portable, portable)];
        #[cfg(target_arch = "x86_64")]
        if Sampler::has_avx512_fill() {
            paths.push(("avx512", avx512, avx512, avx512));
        } else {
            eprintln!("no AVX-512 DQ/VL on this CPU: draw_lanes runs its portable loop, tested here");
        }
        for (name, one, two, three) in paths {
            for round in 0..20 {
                check(name, one, round);
                check(name, two, round);
                check(name, three, round);
            }
        }
    }

    /// A skip of `K` numbers leaves the generator where `K` draws do.
    #[test]
    fn skips_leave_the_generator_where_draws_do() {
        for seed in 0..50 {
            let mut a = pixel_rng(seed, seed * 7, seed as u32);
            let mut b = a.clone();
            a.skip::<2>();
            b.next_2d();
            assert_eq!((a.state, a.inc), (b.state, b.inc));
            a.skip::<1>();
            b.next_f32();
            a.skip::<0>();
            assert_eq!(a.next_f32().to_bits(), b.next_f32().to_bits());
            a.skip::<5>();
            for _ in 0..5 {
                b.next_f32();
            }
            assert_eq!((a.state, a.inc), (b.state, b.inc));
        }
    }

    #[test]
    fn same_pixel_same_numbers_other_pixels_differ() {
        let a: Vec<f32> = (0..4).map(|_| 0).scan(pixel_rng(1, 10, 0), |r, _| Some(r.next_f32())).collect();
        let b: Vec<f32> = (0..4).map(|_| 0).scan(pixel_rng(1, 10, 0), |r, _| Some(r.next_f32())).collect();
        let c: Vec<f32> = (0..4).map(|_| 0).scan(pixel_rng(1, 11, 0), |r, _| Some(r.next_f32())).collect();
        let d: Vec<f32> = (0..4).map(|_| 0).scan(pixel_rng(1, 10, 1), |r, _| Some(r.next_f32())).collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, d);
    }

    #[test]
    fn cosine_hemisphere_matches_its_pdf() {
        // Chi-square over 8 bins of cos θ: the histogram must follow the pdf.
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mut rng = Sampler::from_seed(3);
        let samples = 200_000;
        let bins = 8;
        let mut hist = vec![0f64; bins];
        for _ in 0..samples {
            let w = square_to_cosine_hemisphere(n, rng.next_2d());
            assert!((w.length() - 1.0).abs() < 1e-4 && n.dot(w) >= -1e-6);
            let cos = n.dot(w).clamp(0.0, 1.0 - 1e-7);
            hist[(cos * bins as f32) as usize] += 1.0;
        }
        // With pdf cos/π, P(cos θ < c) = c².
        let chi2: f64 = (0..bins)
            .map(|k| {
                let (a, b) = (k as f64 / bins as f64, (k + 1) as f64 / bins as f64);
                let expected = (b * b - a * a) * samples as f64;
                (hist[k] - expected).powi(2) / expected
            })
            .sum();
        assert!(chi2 < 24.3, "chi2 = {chi2} (7 degrees of freedom, p = 0.001)");
        let w = square_to_cosine_hemisphere(n, glam::Vec2::new(0.3, 0.7));
        assert!((square_to_cosine_hemisphere_pdf(n, w) - n.dot(w) / std::f32::consts::PI).abs() < 1e-6);
    }
}
