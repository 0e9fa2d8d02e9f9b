//! The course's reflectance formulas (TP5), each a function of the shading normal and the
//! two directions (unit, away from the surface), and the densities of the directions the
//! path tracer draws for them.
//!
//! - Oren–Nayar (1994), the course's `MatteMaterial`: `A = 1 - 0.5σ²/(σ²+0.33)`,
//!   `B = 0.45σ²/(σ²+0.09)`, `kd/π·(A + B·max(0, cos(φi-φo))·sin α·tan β)`,
//!   `α = max(θi, θo)`, `β = min(θi, θo)`.
//! - Phong, the course's `PlasticMaterial`: `0.7·kd/π + 0.3·ks·cos(α)^s / cos θi`, `α`
//!   between `ωo` and the mirror of `ωi`; Blinn–Phong: `α` between `n` and the half vector.
//! - Cook–Torrance (the course's `CookTorranceMaterial`): GGX `D` with `α = roughness²`,
//!   Schlick–GGX `G` with `k = (roughness+1)²/8` for each direction, Schlick `F`,
//!   `spec = D·F·G / (4(ωo·n)(ωi·n))`.
//! - GGX visible-normal sampling: Heitz, "Sampling the GGX distribution of visible
//!   normals", JCGT 2018.

use crate::math::color::Color;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// Smallest cosine divided by (grazing directions): keeps formulas finite.
const MIN_COS: f32 = 1e-4;
/// Smallest GGX `α` (a perfectly smooth GGX lobe is a delta, which this is not).
pub(super) const MIN_ALPHA: f32 = 1e-3;

/// The Oren–Nayar BRDF (no cosine).
#[must_use]
pub fn oren_nayar(kd: Color, sigma: f32, n: Vec3, wo: Vec3, wi: Vec3) -> Color {
    let (cos_i, cos_o) = (n.dot(wi), n.dot(wo));
    if cos_i <= 0.0 || cos_o <= 0.0 {
        return Color::ZERO;
    }
    let s2 = sigma * sigma;
    let a = 1.0 - 0.5 * s2 / (s2 + 0.33);
    let b = 0.45 * s2 / (s2 + 0.09);
    // cos(φi - φo): the cosine between the directions projected on the tangent plane.
    let (ti, to) = (wi - n * cos_i, wo - n * cos_o);
    let (li, lo) = (ti.length(), to.length());
    let cos_phi = if li > 1e-6 && lo > 1e-6 { (ti.dot(to) / (li * lo)).max(0.0) } else { 0.0 };
    // α = max(θi, θo) has the smaller cosine, β = min(θi, θo) the larger.
    let (cos_alpha, cos_beta) = (cos_i.min(cos_o).min(1.0), cos_i.max(cos_o).min(1.0));
    let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
    let tan_beta = (1.0 - cos_beta * cos_beta).max(0.0).sqrt() / cos_beta.max(MIN_COS);
    kd * FRAC_1_PI * (a + b * cos_phi * sin_alpha * tan_beta)
}

/// [`oren_nayar`] for `N` incoming directions at once (`wi[axis][j]`), into `out[axis][j]`:
/// the same operations in the same order on each lane, so the same floats, as straight-line
/// loops the compiler vectorises (the caller decides for which instruction set).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // one index into many arrays: the loops vectorise
pub fn oren_nayar_lanes<const N: usize>(kd: Color, sigma: f32, n: Vec3, wo: Vec3, wi: &[[f32; N]; 3], out: &mut [[f32; N]; 3]) {
    let cos_o = n.dot(wo);
    let s2 = sigma * sigma;
    let a = 1.0 - 0.5 * s2 / (s2 + 0.33);
    let b = 0.45 * s2 / (s2 + 0.09);
    let to = wo - n * cos_o;
    let lo = to.length();
    let kd_pi = (kd * FRAC_1_PI).to_array();
    // `sin` and `tan` of `θo`, as `oren_nayar` computes them for `α` or `β` when `θo` is
    // that angle.
    let co = cos_o.min(1.0);
    let sin_o = (1.0 - co * co).max(0.0).sqrt();
    let tan_o = sin_o / co.max(MIN_COS);
    // Lane `j`'s factor and whether it is lit.
    let lane = |j: usize| {
        let (x, y, z) = (wi[0][j], wi[1][j], wi[2][j]);
        let cos_i = n.x * x + n.y * y + n.z * z;
        let (tx, ty, tz) = (x - n.x * cos_i, y - n.y * cos_i, z - n.z * cos_i);
        let li = (tx * tx + ty * ty + tz * tz).sqrt();
        let dot = tx * to.x + ty * to.y + tz * to.z;
        let cos_phi = if li > 1e-6 && lo > 1e-6 { (dot / (li * lo)).max(0.0) } else { 0.0 };
        // One of `α` and `β` is `θo`: `sin α` is `θi`'s only when `cos θi < cos θo`, `tan β`
        // only when `cos θi > cos θo`; equal cosines give equal values, and a NaN `cos θi`
        // (which `min` and `max` drop) gives `θo`'s for both, as in `oren_nayar`.
        // PERF: one square root per lane instead of two (with the grey lights' single
        // quotient in `QuadBatch::fill`, tp6-glass-quad 0.962 of the CPU time).
        let ci = cos_i.min(1.0);
        let sin_i = (1.0 - ci * ci).max(0.0).sqrt();
        let sin_alpha = if cos_i < cos_o { sin_i } else { sin_o };
        let tan_beta = if cos_i > cos_o { sin_i / ci.max(MIN_COS) } else { tan_o };
        (a + b * cos_phi * sin_alpha * tan_beta, !(cos_i <= 0.0 || cos_o <= 0.0))
    };
    if kd_pi.iter().all(|c| c.is_finite() && c.is_sign_positive()) {
        // An unlit lane's factor zero, then the products: `kd_pi · +0` is `+0` for these
        // `kd_pi`, the same bits as the select below.
        // PERF: the select of the products became masked stores (`vmaskmovps`, slow on
        // AMD): tp6-matte-quad 0.920 this way (medians of 7, the same image).
        for j in 0..N {
            let (f, lit) = lane(j);
            let g = if lit { f } else { 0.0 };
            for k in 0..3 {
                out[k][j] = kd_pi[k] * g;
            }
        }
    } else {
        for j in 0..N {
            let (f, lit) = lane(j);
            for k in 0..3 {
                out[k][j] = if lit { kd_pi[k] * f } else { 0.0 };
            }
        }
    }
}

/// The cosine of the course's Phong angle: between `ωo` and the mirror of `ωi` (Phong),
/// or between `n` and the half vector (Blinn–Phong).
#[must_use]
pub fn phong_cos(blinn: bool, n: Vec3, wo: Vec3, wi: Vec3) -> f32 {
    if blinn {
        n.dot((wi + wo).normalize_or_zero()).max(0.0)
    } else {
        (2.0 * n.dot(wi) * n - wi).dot(wo).max(0.0)
    }
}

/// The course's Plastic BRDF (no cosine): `0.7·kd/π + 0.3·ks·cos(α)^s / cos θi`.
#[must_use]
pub fn plastic(kd: Color, ks: Color, shininess: f32, blinn: bool, n: Vec3, wo: Vec3, wi: Vec3) -> Color {
    let cos_i = n.dot(wi);
    if cos_i <= 0.0 || n.dot(wo) <= 0.0 {
        return Color::ZERO;
    }
    0.7 * kd * FRAC_1_PI + 0.3 * ks * phong_cos(blinn, n, wo, wi).powf(shininess) / cos_i.max(MIN_COS)
}

/// [`plastic`] for `N` light directions at once (`wi[axis][j]`, each unit), into `out`
/// (`[channel][j]`; `+0` where a lane is unlit): the same operations in the same order on
/// each lane, so the same floats. The Phong or Blinn–Phong cosines are computed as
/// straight-line loops the compiler vectorises (the caller decides for which instruction
/// set), the powers one lane at a time by the same `powf`, and the sums again as loops.
#[inline(always)]
#[allow(clippy::needless_range_loop, clippy::too_many_arguments)] // one index into many arrays: the loops vectorise
pub fn plastic_lanes<const N: usize>(
    kd: Color,
    ks: Color,
    shininess: f32,
    blinn: bool,
    n: Vec3,
    wo: Vec3,
    wi: &[[f32; N]; 3],
    out: &mut [[f32; N]; 3],
) {
    let cos_o = n.dot(wo);
    let diffuse = (0.7 * kd * FRAC_1_PI).to_array();
    let glossy = (0.3 * ks).to_array();
    // `n · wi` and `phong_cos` per lane, in `Vec3::dot`'s and `normalize_or_zero`'s
    // operations and order.
    let (mut cos_i, mut cos) = ([0f32; N], [0f32; N]);
    for j in 0..N {
        let (x, y, z) = (wi[0][j], wi[1][j], wi[2][j]);
        cos_i[j] = n.x * x + n.y * y + n.z * z;
    }
    if blinn {
        for j in 0..N {
            let h = half_vector(wi[0][j], wi[1][j], wi[2][j], wo);
            cos[j] = (n.x * h[0] + n.y * h[1] + n.z * h[2]).max(0.0);
        }
    } else {
        for j in 0..N {
            let t = 2.0 * cos_i[j];
            let (rx, ry, rz) = (t * n.x - wi[0][j], t * n.y - wi[1][j], t * n.z - wi[2][j]);
            cos[j] = (rx * wo.x + ry * wo.y + rz * wo.z).max(0.0);
        }
    }
    let lit = |j: usize| !(cos_i[j] <= 0.0 || cos_o <= 0.0);
    // The powers: libm's, lane by lane (an unlit lane's is not needed).
    let mut power = [0f32; N];
    for j in 0..N {
        if lit(j) {
            power[j] = cos[j].powf(shininess);
        }
    }
    for j in 0..N {
        let lit = lit(j);
        let m = cos_i[j].max(MIN_COS);
        for k in 0..3 {
            out[k][j] = if lit { diffuse[k] + glossy[k] * power[j] / m } else { 0.0 };
        }
    }
}

/// The density of the Phong lobe's directions (`Material::glossy_pdf` of a plastic of
/// `shininess`, Phong's or Blinn–Phong's) for `N` directions at once (`wi[axis][j]`), into
/// `out[j]`: the same operations in the same order on each lane, so the same floats (the
/// reflection or half vectors as straight-line loops, then [`phong_lobe_pdf`] lane by
/// lane, its power being libm's `powf`).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // one index into many arrays: the loops vectorise
pub fn phong_pdf_lanes<const N: usize>(shininess: f32, blinn: bool, n: Vec3, wo: Vec3, wi: &[[f32; N]; 3], out: &mut [f32; N]) {
    if blinn {
        // `h = (wi + wo).normalize_or_zero()`, `wo · h` and `n · h`.
        let (mut c, mut nh) = ([0f32; N], [0f32; N]);
        for j in 0..N {
            let h = half_vector(wi[0][j], wi[1][j], wi[2][j], wo);
            c[j] = wo.x * h[0] + wo.y * h[1] + wo.z * h[2];
            nh[j] = n.x * h[0] + n.y * h[1] + n.z * h[2];
        }
        for j in 0..N {
            out[j] = if c[j] <= 0.0 { 0.0 } else { phong_lobe_pdf(shininess, nh[j]) / (4.0 * c[j]) };
        }
    } else {
        // `wi · reflect(wo, n)`.
        let r = 2.0 * n.dot(wo) * n - wo;
        let mut cos = [0f32; N];
        for j in 0..N {
            cos[j] = wi[0][j] * r.x + wi[1][j] * r.y + wi[2][j] * r.z;
        }
        for j in 0..N {
            out[j] = phong_lobe_pdf(shininess, cos[j]);
        }
    }
}

/// A lane's half vector, `(wi + wo).normalize_or_zero()` with `wi = (x, y, z)`, in its
/// operations: times the reciprocal of the length where that is finite and positive,
/// else zero.
#[inline(always)]
fn half_vector(x: f32, y: f32, z: f32, wo: Vec3) -> [f32; 3] {
    let s = [x + wo.x, y + wo.y, z + wo.z];
    let rcp = 1.0 / (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
    if rcp.is_finite() & (rcp > 0.0) {
        [s[0] * rcp, s[1] * rcp, s[2] * rcp]
    } else {
        [0.0; 3]
    }
}

/// GGX normal distribution `D(h)` for `α`, with `cos_h = n·h`.
#[must_use]
pub fn ggx_d(alpha: f32, cos_h: f32) -> f32 {
    if cos_h <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = cos_h * cos_h * (a2 - 1.0) + 1.0;
    a2 / (PI * t * t)
}

/// Schlick–GGX masking of one direction, `k = (roughness+1)²/8` (the course's `G1`).
#[must_use]
pub fn schlick_ggx(roughness: f32, cos: f32) -> f32 {
    let k = (roughness + 1.0) * (roughness + 1.0) / 8.0;
    cos / (cos * (1.0 - k) + k)
}

/// Schlick's Fresnel approximation.
#[must_use]
pub fn schlick_fresnel(f0: Color, cos: f32) -> Color {
    f0 + (Color::ONE - f0) * (1.0 - cos.clamp(0.0, 1.0)).powi(5)
}

/// The Cook–Torrance specular term `D·F·G / (4(ωo·n)(ωi·n))` (no cosine).
#[must_use]
pub fn cook_torrance_spec(f0: Color, roughness: f32, n: Vec3, wo: Vec3, wi: Vec3) -> Color {
    let (cos_i, cos_o) = (n.dot(wi), n.dot(wo));
    if cos_i <= 0.0 || cos_o <= 0.0 {
        return Color::ZERO;
    }
    let h = (wi + wo).normalize_or_zero();
    let alpha = ggx_alpha(roughness);
    let d = ggx_d(alpha, n.dot(h));
    let g = schlick_ggx(roughness, cos_o) * schlick_ggx(roughness, cos_i);
    let f = schlick_fresnel(f0, h.dot(wo));
    f * (d * g / (4.0 * cos_o.max(MIN_COS) * cos_i.max(MIN_COS)))
}

/// The course's Cook–Torrance BRDF, `(1 - m)·oren_nayar(kd, σ = roughness) +
/// m·cook_torrance_spec(f0, roughness)` (`m` the metalness clamped to `[0, 1]`, what
/// `Material::CookTorrance`'s BRDF is), for `N` incoming directions at once (`wi[axis][j]`)
/// into `out[axis][j]`, with the half vector's `GGX D` of each lane into `d[j]` (zero where
/// `n · h <= 0`) and `h · wo` into `c[j]`, for the pdf of visible normals
/// ([`visible_pdf`]): the same operations in the same order on
/// each lane, so the same floats, as straight-line loops the compiler vectorises (the
/// caller decides for which instruction set).
#[inline(always)]
#[allow(clippy::needless_range_loop, clippy::too_many_arguments)] // one index into many arrays: the loops vectorise
pub fn cook_torrance_lanes<const N: usize>(
    kd: Color,
    f0: Color,
    roughness: f32,
    metalness: f32,
    n: Vec3,
    wo: Vec3,
    wi: &[[f32; N]; 3],
    out: &mut [[f32; N]; 3],
    d: &mut [f32; N],
    c: &mut [f32; N],
) {
    // The diffuse part first, into `out`.
    oren_nayar_lanes(kd, roughness, n, wo, wi, out);
    let m = metalness.clamp(0.0, 1.0);
    let cos_o = n.dot(wo);
    let alpha = ggx_alpha(roughness);
    let a2 = alpha * alpha;
    let g_o = schlick_ggx(roughness, cos_o);
    let (f0, one_minus_f0) = (f0.to_array(), (Color::ONE - f0).to_array());
    for j in 0..N {
        let (x, y, z) = (wi[0][j], wi[1][j], wi[2][j]);
        let cos_i = n.x * x + n.y * y + n.z * z;
        let h = half_vector(x, y, z, wo);
        // `ggx_d(alpha, n · h)`.
        let cos_h = n.x * h[0] + n.y * h[1] + n.z * h[2];
        let t = cos_h * cos_h * (a2 - 1.0) + 1.0;
        d[j] = if cos_h <= 0.0 { 0.0 } else { a2 / (PI * t * t) };
        let g = g_o * schlick_ggx(roughness, cos_i);
        // `schlick_fresnel(f0, h · wo)`'s power.
        c[j] = h[0] * wo.x + h[1] * wo.y + h[2] * wo.z;
        let p5 = (1.0 - c[j].clamp(0.0, 1.0)).powi(5);
        let q = d[j] * g / (4.0 * cos_o.max(MIN_COS) * cos_i.max(MIN_COS));
        let lit = !(cos_i <= 0.0 || cos_o <= 0.0);
        for k in 0..3 {
            let spec = if lit { (f0[k] + one_minus_f0[k] * p5) * q } else { 0.0 };
            out[k][j] = (1.0 - m) * out[k][j] + m * spec;
        }
    }
}

/// GGX's `α` of a roughness: `roughness²`, at least `MIN_ALPHA` (10⁻³).
#[inline(always)]
#[must_use]
pub fn ggx_alpha(roughness: f32) -> f32 {
    (roughness * roughness).max(MIN_ALPHA)
}

/// The local frame of `n`: `(t, b, n)`, right-handed.
fn frame(n: Vec3) -> (Vec3, Vec3) {
    n.any_orthonormal_pair()
}

/// Smith's exact masking for GGX (what visible-normal sampling is normalised by).
fn smith_g1(alpha: f32, cos: f32) -> f32 {
    let c2 = cos * cos;
    2.0 * cos / (cos + (alpha * alpha + (1.0 - alpha * alpha) * c2).sqrt())
}

/// A half vector drawn from GGX's distribution of normals visible from `wo` (Heitz 2018).
#[must_use]
pub fn sample_ggx_visible(alpha: f32, n: Vec3, wo: Vec3, u: Vec2) -> Vec3 {
    let (t, b) = frame(n);
    let v = Vec3::new(wo.dot(t), wo.dot(b), wo.dot(n));
    // The view direction stretched to the hemisphere configuration.
    let vh = Vec3::new(alpha * v.x, alpha * v.y, v.z).normalize();
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len2 > 0.0 { Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt() } else { Vec3::X };
    let t2 = vh.cross(t1);
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    let m = Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize();
    (m.x * t + m.y * b + m.z * n).normalize()
}

/// The solid-angle pdf of the half vector `h` under [`sample_ggx_visible`].
#[must_use]
pub fn ggx_visible_pdf(alpha: f32, n: Vec3, wo: Vec3, h: Vec3) -> f32 {
    visible_pdf(alpha, n.dot(wo), wo.dot(h), ggx_d(alpha, n.dot(h)))
}

/// [`ggx_visible_pdf`] from `cos_o = n · wo`, `wo_h = wo · h` and `d = ggx_d(alpha, n · h)`
/// (what [`cook_torrance_lanes`] gives per lane).
#[inline(always)]
#[must_use]
pub fn visible_pdf(alpha: f32, cos_o: f32, wo_h: f32, d: f32) -> f32 {
    if cos_o <= 0.0 {
        return 0.0;
    }
    smith_g1(alpha, cos_o) * wo_h.max(0.0) * d / cos_o
}

/// A direction about `axis` with density `(s+1)/(2π)·cos^s` (the Phong lobe).
#[must_use]
pub fn sample_phong_lobe(axis: Vec3, s: f32, u: Vec2) -> Vec3 {
    let cos = u.x.powf(1.0 / (s + 1.0));
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    let (t, b) = frame(axis);
    (sin * phi.cos() * t + sin * phi.sin() * b + cos * axis).normalize()
}

/// The density of [`sample_phong_lobe`] at a direction of cosine `cos` to the axis.
#[must_use]
pub fn phong_lobe_pdf(s: f32, cos: f32) -> f32 {
    if cos <= 0.0 {
        0.0
    } else {
        (s + 1.0) / (2.0 * PI) * cos.powf(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sampling::Sampler;

    /// Lane `j` of `out` holds `expected`'s bits.
    fn assert_lane_is<const N: usize>(out: &[[f32; N]; 3], j: usize, expected: Color, round: usize) {
        for k in 0..3 {
            assert_eq!(out[k][j].to_bits(), expected[k].to_bits(), "round {round}, lane {j}: {} against {}", out[k][j], expected[k]);
        }
    }

    /// A random unit normal, and `wo` along it, against it, or random (by `round`).
    fn normal_and_wo(round: usize, r: &mut impl FnMut() -> f32) -> (Vec3, Vec3) {
        let n = Vec3::new(r(), r(), r()).normalize_or(Vec3::Y);
        let wo = match round % 5 {
            0 => n,
            1 => -n,
            _ => Vec3::new(r(), r(), r()).normalize_or(n),
        };
        (n, wo)
    }

    /// `N` directions as lanes (`[axis][j]`): `special` first, then random unit vectors
    /// (`n` where one is too short to normalise).
    fn directions<const N: usize>(special: &[Vec3], n: Vec3, r: &mut impl FnMut() -> f32) -> [[f32; N]; 3] {
        let mut wi = [[0f32; N]; 3];
        for j in 0..N {
            let w = special.get(j).copied().unwrap_or_else(|| Vec3::new(r(), r(), r()).normalize_or(n));
            for (k, row) in wi.iter_mut().enumerate() {
                row[j] = w[k];
            }
        }
        wi
    }

    /// `oren_nayar_lanes` gives `oren_nayar`'s bits lane by lane, unlit lanes `+0`, on
    /// directions chosen to meet its cases: `cos θi` below, equal to and above `cos θo`,
    /// above 1, below the surface, and NaN.
    #[test]
    #[allow(clippy::needless_range_loop)] // one index into several arrays
    fn oren_nayar_lanes_are_oren_nayar() {
        const N: usize = 16;
        let mut rng = Sampler::from_seed(5);
        let mut r = || rng.next_f32() * 2.0 - 1.0;
        let (mut below, mut above, mut equal) = (0, 0, 0);
        for round in 0..4000 {
            let n = Vec3::new(r(), r(), r()).normalize_or(Vec3::Y);
            let wo = match round % 5 {
                0 => n,
                1 => (n * 1.0000001).normalize_or(n) * 1.0000002,
                _ => Vec3::new(r(), r(), r()).normalize_or(n),
            };
            let wi = directions::<N>(&[wo, n, Vec3::splat(f32::NAN), (wo - 2.0 * n * n.dot(wo)).normalize_or(n), n * 1.0000002], n, &mut r);
            let (kd, sigma) = (Color::new(r().abs(), 0.5, r().abs() * 3.0), [0.0, 0.3, 0.6, 1.5][round % 4]);
            let mut out = [[0f32; N]; 3];
            oren_nayar_lanes(kd, sigma, n, wo, &wi, &mut out);
            for j in 0..N {
                let w = Vec3::new(wi[0][j], wi[1][j], wi[2][j]);
                let expected = oren_nayar(kd, sigma, n, wo, w);
                let (ci, co) = (n.dot(w), n.dot(wo));
                if ci > 0.0 && co > 0.0 {
                    (below, above, equal) = (below + usize::from(ci < co), above + usize::from(ci > co), equal + usize::from(ci == co));
                }
                assert_lane_is(&out, j, expected, round);
            }
        }
        assert!(below > 5_000 && above > 5_000 && equal > 500, "{below} {above} {equal}");
    }

    /// `plastic_lanes` gives `plastic`'s bits lane by lane, Phong and Blinn–Phong, on
    /// directions chosen to meet its cases: the mirror direction, no half vector, below
    /// the surface, NaN.
    #[test]
    #[allow(clippy::needless_range_loop)] // one index into several arrays
    fn plastic_lanes_are_plastic() {
        const N: usize = 16;
        let mut rng = Sampler::from_seed(7);
        let mut r = || rng.next_f32() * 2.0 - 1.0;
        let (mut lit, mut unlit, mut specular) = (0, 0, 0);
        for round in 0..4000 {
            let (n, wo) = normal_and_wo(round, &mut r);
            // Its mirror direction (the Phong peak), `-wo` (no half vector), NaN.
            let mirror = (2.0 * n.dot(wo) * n - wo).normalize_or(n);
            let wi = directions::<N>(&[wo, n, Vec3::splat(f32::NAN), -wo, mirror], n, &mut r);
            let (kd, ks) = (Color::new(r().abs(), 0.5, r().abs() * 3.0), Color::new(1.0, r().abs(), 0.25));
            let shininess = [1.0, 3.0, 8.0, 32.0, 64.5, 0.0][round % 6];
            let blinn = round % 2 == 1;
            let mut out = [[0f32; N]; 3];
            plastic_lanes(kd, ks, shininess, blinn, n, wo, &wi, &mut out);
            for j in 0..N {
                let w = Vec3::new(wi[0][j], wi[1][j], wi[2][j]);
                let expected = plastic(kd, ks, shininess, blinn, n, wo, w);
                assert_lane_is(&out, j, expected, round);
                if expected == Color::ZERO {
                    unlit += 1;
                } else {
                    lit += 1;
                    specular += usize::from(phong_cos(blinn, n, wo, w) > 0.5);
                }
            }
        }
        assert!(lit > 15_000 && unlit > 10_000 && specular > 2_000, "{lit} {unlit} {specular}");
    }

    /// `cook_torrance_lanes` gives `Material::CookTorrance`'s BRDF bits lane by lane, and
    /// `ggx_d` and `wo · h` of each lane's half vector, on directions meeting its cases (below the
    /// surface, along the normal, opposite `wo`, grazing, NaN), every metalness kind
    /// (0, between, 1, past both ends) and roughness down to 0.
    #[test]
    #[allow(clippy::needless_range_loop)] // one index into several arrays
    fn cook_torrance_lanes_are_the_brdf() {
        const N: usize = 16;
        let mut rng = Sampler::from_seed(6);
        let mut r = || rng.next_f32() * 2.0 - 1.0;
        let (mut lit, mut unlit) = (0, 0);
        for round in 0..4000 {
            let (n, wo) = normal_and_wo(round, &mut r);
            let wi = directions::<N>(&[wo, n, Vec3::splat(f32::NAN), -wo, (wo - 2.0 * n * n.dot(wo)).normalize_or(n)], n, &mut r);
            let kd = Color::new(r().abs(), 0.5, r().abs() * 3.0);
            let f0 = Color::new(1.0, 0.85 * r().abs(), 0.57);
            let roughness = [0.0, 0.01, 0.3, 0.7, 1.0][round % 5];
            let metalness = [0.0, 0.5, 1.0, 1.5, -0.5, r().abs()][round % 6];
            let material = crate::materials::Material::CookTorrance { kd, f0, roughness, metalness };
            // `Material::shade`'s BRDF, the one the lanes are, with the `wo` it computes.
            let ray = crate::math::ray::Ray::new(wo * 3.0, -wo);
            let wo = -ray.direction.normalize_or_zero();
            let (mut out, mut d, mut c) = ([[0f32; N]; 3], [0f32; N], [0f32; N]);
            cook_torrance_lanes(kd, f0, roughness, metalness, n, wo, &wi, &mut out, &mut d, &mut c);
            for j in 0..N {
                let w = Vec3::new(wi[0][j], wi[1][j], wi[2][j]);
                let hit = crate::geometry::Hit { normal: n, ..crate::geometry::Hit::ZERO };
                let light = crate::lights::LightSample { direction: w, distance: 1.0, point: Vec3::ZERO, radiance: Color::ONE, pdf: 1.0 };
                let expected = material.shade(&ray, &hit, &light);
                let h = (w + wo).normalize_or_zero();
                let alpha = (roughness * roughness).max(MIN_ALPHA);
                assert_eq!(d[j].to_bits(), ggx_d(alpha, n.dot(h)).to_bits(), "round {round}, lane {j}");
                assert_eq!(c[j].to_bits(), wo.dot(h).to_bits(), "round {round}, lane {j}");
                assert_lane_is(&out, j, expected, round);
                if expected == Color::ZERO {
                    unlit += 1;
                } else {
                    lit += 1;
                }
            }
        }
        assert!(lit > 15_000 && unlit > 10_000, "{lit} {unlit}");
    }
}
