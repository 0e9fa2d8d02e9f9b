//! Materials: what each returns to the course's integrators (`shade`, the BRDF value for a
//! light sample) and to the path tracer (`eval`, `sample`, `pdf`, in one stated
//! contract below). Each kind documents exactly what it returns.
//!
//! # The path tracer's contract (pbrt-v4 `BSDF`, Mitsuba 3 `BSDF`)
//! All directions are unit vectors pointing away from the surface: `wo` towards where
//! the light goes (the previous vertex), `wi` towards where it comes from. The shading
//! normal is `hit.normal`, which faces `wo`'s side.
//! - [`Material::eval`]`(hit, wo, wi)` is the BRDF `f(wo, wi)` (no cosine); zero for the
//!   delta lobes of [`Material::Mirror`] and [`Material::Transparent`].
//! - [`Material::pdf`]`(hit, wo, wi)` is the solid-angle density with which
//!   [`Material::sample`] returns `wi`; zero for delta lobes.
//! - [`Material::sample`]`(hit, wo, u_lobe, u)` draws `wi` and returns
//!   [`BsdfSample::weight`] `= f(wo, wi)·|cos θi| / pdf(wi)` (for a delta lobe: the
//!   lobe's reflectance or transmittance, e.g. 1 for the mirror), or `None` when no
//!   direction is drawn (the path ends).

mod lobes;
mod texture;

pub use texture::{srgb_to_linear, Texture, MAX_TEXELS};

pub use lobes::{
    cook_torrance_lanes, cook_torrance_spec, ggx_alpha, ggx_d, ggx_visible_pdf, oren_nayar, oren_nayar_lanes, phong_cos, phong_lobe_pdf,
    phong_pdf_lanes, plastic, plastic_lanes, sample_ggx_visible, sample_phong_lobe, schlick_fresnel, schlick_ggx, visible_pdf,
};

use crate::geometry::Hit;
use crate::lights::LightSample;
use crate::math::color::{Color, BLACK, WHITE};
use crate::math::ray::Ray;
use crate::math::sampling::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

pub use crate::geometry::MaterialId;

/// The materials of the course (a closed set, dispatched by `match`).
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    /// The course's `ColorMaterial`: returns its colour as the BRDF, without 1/π (so it is
    /// not energy conserving). The path tracer treats it as [`Material::Lambert`] with
    /// albedo = colour (`eval` = colour/π).
    Color(Color),
    /// Lambertian diffuse: `kd / π`.
    Lambert(Color),
    /// A file's material with a colour texture (`map_Kd`, glTF's base-colour texture): the
    /// course's `ColorMaterial` whose colour is `tint × texture(uv)` at each hit (`Kd`
    /// multiplies `map_Kd`, as MTL says). The path tracer treats it as Lambert with that
    /// albedo, like [`Material::Color`].
    Textured {
        /// The texture.
        texture: std::sync::Arc<Texture>,
        /// What the texture is multiplied by.
        tint: Color,
    },
    /// The course's `MatteMaterial`: Oren–Nayar of roughness `sigma` (radians, the
    /// standard deviation of the facet slopes), [`oren_nayar`]. `sigma` 0 is Lambert.
    Matte {
        /// Diffuse colour.
        kd: Color,
        /// Roughness σ.
        sigma: f32,
    },
    /// The course's `PlasticMaterial`: `0.7·kd/π + 0.3·ks·cos(α)^s / cos θi` ([`plastic`]),
    /// `α` between `ωo` and the mirror of `ωi` (Phong) or between `n` and the half vector
    /// (`blinn`). The `1/cos θi` (the course's) makes it reflect more than it receives at
    /// grazing light: not energy conserving, and not reciprocal.
    Plastic {
        /// Diffuse colour.
        kd: Color,
        /// Specular colour.
        ks: Color,
        /// The exponent `s`.
        shininess: f32,
        /// Blinn–Phong (half vector) instead of Phong (mirror direction).
        blinn: bool,
    },
    /// The course's `CookTorranceMaterial`: `(1 - metalness)·OrenNayar(kd, σ = roughness)`
    /// plus `metalness·D·F·G / (4(ωo·n)(ωi·n))`, with GGX `D` (`α = roughness²`), Schlick–GGX
    /// `G` (`k = (roughness+1)²/8`) and Schlick `F` from `f0` ([`cook_torrance_spec`]). The
    /// course leaves the diffuse part's σ open: isir uses the roughness, so metalness 0 is
    /// exactly Oren–Nayar with σ = roughness.
    CookTorrance {
        /// Diffuse colour.
        kd: Color,
        /// Reflectance at normal incidence.
        f0: Color,
        /// Roughness (GGX `α = roughness²`).
        roughness: f32,
        /// Mix between the diffuse (0) and the specular (1) parts.
        metalness: f32,
    },
    /// A perfect mirror: all light along the reflection `2(n·wo)n - wo`. The course's
    /// `MirrorMaterial`, handled by the Whitted integrator (its `shade` is black).
    Mirror,
    /// A smooth dielectric of index `ior` (outside: 1): reflection with probability given
    /// by Fresnel `kr = (Rs + Rp)/2`, refraction otherwise, total internal reflection past
    /// the critical angle. The course's `TransparentMaterial` (ior 1.3), handled by the
    /// Whitted integrator (its `shade` is black). Radiance is not scaled by `η²` on
    /// refraction, as the course does not.
    Transparent {
        /// Index of refraction inside.
        ior: f32,
    },
}

/// A direction drawn by [`Material::sample`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// The incoming direction (unit, away from the surface).
    pub wi: Vec3,
    /// `f(wo, wi)·|cos θi| / pdf`; for a delta lobe, its reflectance or transmittance.
    pub weight: Color,
    /// The solid-angle pdf of `wi`; 0 for a delta lobe.
    pub pdf: f32,
    /// True for a delta lobe (mirror, glass): no light sampling can find this direction.
    pub delta: bool,
}

impl Material {
    /// What a material must be to shade: finite colours that are not negative, and
    /// parameters in their ranges (`sigma`, `shininess` at least 0; `roughness`, `ior`
    /// above 0; `metalness` from 0 to 1). Outside them a material shades NaN, infinite
    /// or unphysical values (a negative `ior` reflected 500 times the light).
    ///
    /// # Errors
    /// Which parameter is out of its range, in words.
    pub fn check(&self) -> std::result::Result<(), String> {
        let colour = |what: &str, c: Color| {
            if c.is_finite() && c.min_element() >= 0.0 {
                Ok(())
            } else {
                Err(format!("{what} {c} must be finite and not negative"))
            }
        };
        let within = |what: &str, x: f32, lo: f32, hi: f32, lo_open: bool| {
            let above = if lo_open { x > lo } else { x >= lo };
            match (above && x <= hi, hi == f32::MAX, lo_open) {
                (true, _, _) => Ok(()),
                (false, true, true) => Err(format!("{what} {x} must be finite and above {lo}")),
                (false, true, false) => Err(format!("{what} {x} must be finite and at least {lo}")),
                (false, false, _) => Err(format!("{what} {x} must be between {lo} and {hi}")),
            }
        };
        match *self {
            Material::Color(c) | Material::Lambert(c) => colour("color", c),
            Material::Textured { tint, .. } => colour("color", tint),
            Material::Matte { kd, sigma } => colour("color", kd).and(within("sigma", sigma, 0.0, f32::MAX, false)),
            Material::Plastic { kd, ks, shininess, .. } => {
                colour("color", kd).and(colour("specular", ks)).and(within("shininess", shininess, 0.0, f32::MAX, false))
            }
            Material::CookTorrance { kd, f0, roughness, metalness } => colour("color", kd)
                .and(colour("f0", f0))
                .and(within("roughness", roughness, 0.0, f32::MAX, true).map_err(|e| format!("{e} (a mirror is `type = \"mirror\"`)")))
                .and(within("metalness", metalness, 0.0, 1.0, false)),
            Material::Mirror => Ok(()),
            Material::Transparent { ior } => within("ior", ior, 0.0, f32::MAX, true),
        }
    }

    /// The colour shown by the ray-cast integrator.
    #[must_use]
    pub fn flat_color(&self) -> Color {
        match self {
            Material::Color(c) | Material::Lambert(c) => *c,
            Material::Textured { tint, .. } => *tint,
            Material::Matte { kd, .. } | Material::Plastic { kd, .. } | Material::CookTorrance { kd, .. } => *kd,
            Material::Mirror | Material::Transparent { .. } => WHITE,
        }
    }

    /// The colour shown by the ray-cast integrator at `hit` (textures looked up there).
    #[must_use]
    pub fn color_at(&self, hit: &Hit) -> Color {
        match self {
            Material::Textured { texture, tint } => *tint * texture.sample(hit.uv),
            m => m.flat_color(),
        }
    }

    /// The course's `shade(ray, hit, lightSample)`: the BRDF value for light arriving along
    /// `light.direction` and leaving towards the ray's origin.
    #[must_use]
    pub fn shade(&self, ray: &Ray, hit: &Hit, light: &LightSample) -> Color {
        self.shade_from(ray, hit, light.direction)
    }

    /// [`Material::shade`] for light arriving along `wi` (all it needs of the sample).
    #[inline]
    fn shade_from(&self, ray: &Ray, hit: &Hit, wi: Vec3) -> Color {
        self.shade_any_direction(hit).unwrap_or_else(|| self.brdf(hit.normal, -ray.direction.normalize_or_zero(), wi))
    }

    /// [`Material::shade`]'s value where it is the same for every light direction (the
    /// course's colours, textures, Lambert, and mirror and glass, which shade black):
    /// `None` for the materials that need the direction.
    #[inline]
    #[must_use]
    pub fn shade_any_direction(&self, hit: &Hit) -> Option<Color> {
        match self {
            Material::Color(c) => Some(*c),
            Material::Textured { .. } => Some(self.color_at(hit)),
            Material::Lambert(kd) => Some(*kd * FRAC_1_PI),
            Material::Mirror | Material::Transparent { .. } => Some(BLACK),
            _ => None,
        }
    }

    /// [`Material::shade`] for `N` light samples at once, by their directions
    /// (`wi[axis][j]`), into `out[axis][j]`: the same floats. Oren–Nayar in straight-line
    /// loops the compiler vectorises (for the instruction set of the caller), materials
    /// that do not depend on the direction once, Phong and Cook–Torrance one sample after
    /// another (a quad light's batch takes Cook–Torrance's and Phong's lanes itself,
    /// `QuadBatch::shade_into`).
    #[inline(always)]
    pub fn shade_lanes<const N: usize>(&self, ray: &Ray, hit: &Hit, wi: &[[f32; N]; 3], out: &mut [[f32; N]; 3]) {
        if let Some(c) = self.shade_any_direction(hit) {
            // The same for every direction (no `wo` needed).
            let c = c.to_array();
            for k in 0..3 {
                out[k] = [c[k]; N];
            }
            return;
        }
        let wo = -ray.direction.normalize_or_zero();
        if let Material::Matte { kd, sigma } = *self {
            oren_nayar_lanes(kd, sigma, hit.normal, wo, wi, out);
            return;
        }
        // `shade_from` of the materials left: their BRDF, `wo` computed once.
        for j in 0..N {
            let c = self.brdf(hit.normal, wo, Vec3::new(wi[0][j], wi[1][j], wi[2][j]));
            (out[0][j], out[1][j], out[2][j]) = (c.x, c.y, c.z);
        }
    }

    /// The BRDF of the glossy and rough kinds, by the course's formulas.
    fn brdf(&self, n: Vec3, wo: Vec3, wi: Vec3) -> Color {
        match *self {
            Material::Color(c) | Material::Lambert(c) => lambert(c, n, wo, wi),
            Material::Matte { kd, sigma } => oren_nayar(kd, sigma, n, wo, wi),
            Material::Plastic { kd, ks, shininess, blinn } => plastic(kd, ks, shininess, blinn, n, wo, wi),
            Material::CookTorrance { kd, f0, roughness, metalness } => {
                let m = metalness.clamp(0.0, 1.0);
                (1.0 - m) * oren_nayar(kd, roughness, n, wo, wi) + m * cook_torrance_spec(f0, roughness, n, wo, wi)
            }
            // Needs the hit's texture coordinates: [`Material::eval`] looks it up.
            Material::Textured { tint, .. } => tint * FRAC_1_PI,
            Material::Mirror | Material::Transparent { .. } => BLACK,
        }
    }

    /// The probability that [`Material::sample`] draws from the glossy lobe.
    fn glossy_probability(&self) -> f32 {
        match *self {
            Material::Plastic { .. } => 0.5,
            Material::CookTorrance { metalness, .. } => metalness.clamp(0.0, 1.0),
            _ => 0.0,
        }
    }

    /// The density of the glossy lobe's directions (see [`Material::sample`]).
    fn glossy_pdf(&self, n: Vec3, wo: Vec3, wi: Vec3) -> f32 {
        match *self {
            Material::Plastic { shininess, blinn: false, .. } => phong_lobe_pdf(shininess, wi.dot(reflect(wo, n))),
            Material::Plastic { shininess, blinn: true, .. } => {
                let h = (wi + wo).normalize_or_zero();
                let c = wo.dot(h);
                if c <= 0.0 {
                    0.0
                } else {
                    phong_lobe_pdf(shininess, n.dot(h)) / (4.0 * c)
                }
            }
            Material::CookTorrance { roughness, .. } => {
                let h = (wi + wo).normalize_or_zero();
                let c = wo.dot(h);
                let alpha = ggx_alpha(roughness);
                if c <= 0.0 {
                    0.0
                } else {
                    ggx_visible_pdf(alpha, n, wo, h) / (4.0 * c)
                }
            }
            _ => 0.0,
        }
    }

    /// The albedo of a material whose BRDF is Lambert's `albedo / π` and whose
    /// [`Material::pdf`] is the cosine lobe's (the course's colours, Lambert's), for the
    /// path tracer's next-event estimation in lanes; `None` for the others.
    #[must_use]
    pub fn lambert_albedo(&self) -> Option<Color> {
        match *self {
            Material::Color(c) | Material::Lambert(c) => Some(c),
            _ => None,
        }
    }

    /// True when every lobe is a delta (mirror, glass): `eval` and `pdf` are zero and only
    /// `sample` finds the light.
    #[must_use]
    pub fn is_delta(&self) -> bool {
        matches!(self, Material::Mirror | Material::Transparent { .. })
    }

    /// The BRDF `f(wo, wi)` (see the module's contract).
    #[must_use]
    #[inline]
    pub fn eval(&self, hit: &Hit, wo: Vec3, wi: Vec3) -> Color {
        let n = hit.normal;
        if n.dot(wo) <= 0.0 || n.dot(wi) <= 0.0 {
            return BLACK;
        }
        match *self {
            Material::Textured { .. } => self.color_at(hit) * FRAC_1_PI,
            // PERF: inline: through the call to `brdf`, the normal went by the stack and
            // was read back before its stores had retired (the path tracer's next-event
            // estimation stalled there).
            Material::Color(c) | Material::Lambert(c) => lambert(c, n, wo, wi),
            _ => self.brdf(n, wo, wi),
        }
    }

    /// The solid-angle pdf with which [`Material::sample`] draws `wi`.
    #[must_use]
    pub fn pdf(&self, hit: &Hit, wo: Vec3, wi: Vec3) -> f32 {
        let n = hit.normal;
        if n.dot(wo) <= 0.0 {
            return 0.0;
        }
        match self {
            Material::Mirror | Material::Transparent { .. } => 0.0,
            _ => {
                if n.dot(wi) <= 0.0 {
                    return 0.0;
                }
                let p = self.glossy_probability();
                let glossy = if p > 0.0 { self.glossy_pdf(n, wo, wi) } else { 0.0 };
                (1.0 - p) * square_to_cosine_hemisphere_pdf(n, wi) + p * glossy
            }
        }
    }

    /// True for the materials whose [`Material::sample`] draws from the cosine lobe alone
    /// (Lambert's, the course's colours, textures).
    #[must_use]
    pub fn samples_cosine_lobe(&self) -> bool {
        matches!(self, Material::Color(_) | Material::Lambert(_) | Material::Textured { .. })
    }

    /// [`Material::sample`]'s answer for a material that [`Material::samples_cosine_lobe`],
    /// given the lobe's direction `wi` and its pdf (those of
    /// [`square_to_cosine_hemisphere`], drawn for many hits at once by
    /// [`crate::math::sampling::cosine_hemisphere_lanes`]): `None` when `wo` is below the
    /// surface or the pdf is not positive.
    #[must_use]
    pub fn cosine_lobe_sample_from(&self, hit: &Hit, wo: Vec3, wi: Vec3, pdf: f32) -> Option<BsdfSample> {
        if hit.normal.dot(wo) <= 0.0 {
            return None;
        }
        self.cosine_lobe_sample(hit, wi, pdf)
    }

    #[inline(always)]
    fn cosine_lobe_sample(&self, hit: &Hit, wi: Vec3, pdf: f32) -> Option<BsdfSample> {
        // f·cos/pdf = (c/π)·cos / (cos/π) = c.
        (pdf > 0.0).then_some(BsdfSample { wi, weight: self.color_at(hit), pdf, delta: false })
    }

    /// Draw `wi` from `u_lobe` (which lobe) and `u` (where in it), uniform in `[0, 1)`.
    #[must_use]
    #[inline]
    pub fn sample(&self, hit: &Hit, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let n = hit.normal;
        let cos_o = n.dot(wo);
        if cos_o <= 0.0 {
            return None;
        }
        match self {
            Material::Color(_) | Material::Lambert(_) | Material::Textured { .. } => {
                let wi = square_to_cosine_hemisphere(n, u);
                self.cosine_lobe_sample(hit, wi, square_to_cosine_hemisphere_pdf(n, wi))
            }
            Material::Matte { .. } | Material::Plastic { .. } | Material::CookTorrance { .. } => {
                // A mixture: the cosine lobe, or the glossy one with probability p
                // (Phong's lobe about the mirror direction, Blinn–Phong's about n for the
                // half vector, GGX's visible normals); the pdf is the mixture's.
                let p = self.glossy_probability();
                let wi = if u_lobe < p {
                    match *self {
                        Material::Plastic { shininess, blinn: false, .. } => sample_phong_lobe(reflect(wo, n), shininess, u),
                        Material::Plastic { shininess, blinn: true, .. } => reflect(wo, sample_phong_lobe(n, shininess, u)),
                        Material::CookTorrance { roughness, .. } => reflect(wo, sample_ggx_visible(ggx_alpha(roughness), n, wo, u)),
                        _ => unreachable!("only the glossy kinds have p > 0"),
                    }
                } else {
                    square_to_cosine_hemisphere(n, u)
                };
                let cos_i = n.dot(wi);
                let pdf = self.pdf(hit, wo, wi);
                if cos_i <= 0.0 || pdf <= 0.0 || !pdf.is_finite() {
                    return None;
                }
                let weight = self.brdf(n, wo, wi) * cos_i / pdf;
                weight.is_finite().then_some(BsdfSample { wi, weight, pdf, delta: false })
            }
            Material::Mirror => Some(BsdfSample { wi: reflect(wo, n), weight: WHITE, pdf: 0.0, delta: true }),
            Material::Transparent { ior } => {
                // The relative index across the surface, as the ray crosses it.
                let eta = if hit.front_face { *ior } else { 1.0 / *ior };
                let kr = fresnel_dielectric(cos_o, eta);
                match refract(wo, n, eta) {
                    Some(wt) if u_lobe >= kr => Some(BsdfSample { wi: wt, weight: WHITE, pdf: 0.0, delta: true }),
                    _ => Some(BsdfSample { wi: reflect(wo, n), weight: WHITE, pdf: 0.0, delta: true }),
                }
            }
        }
    }
}

/// The Lambert BRDF of colour `c`: `c/π` where `wo` and `wi` are both above the surface.
#[inline(always)]
fn lambert(c: Color, n: Vec3, wo: Vec3, wi: Vec3) -> Color {
    if n.dot(wo) > 0.0 && n.dot(wi) > 0.0 {
        c * FRAC_1_PI
    } else {
        BLACK
    }
}

/// The mirror direction of `wo` about `n`: `2(n·wo)n - wo`.
#[must_use]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * n.dot(wo) * n - wo
}

/// The direction refracted from `wo` (on `n`'s side, unit) into a medium whose index,
/// relative to `wo`'s side, is `eta` (Snell: `sin θt = sin θo / eta`); `None` past the
/// critical angle (total internal reflection).
#[must_use]
pub fn refract(wo: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_o = n.dot(wo);
    let sin2_t = (1.0 - cos_o * cos_o).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-wo / eta + (cos_o / eta - cos_t) * n).normalize())
}

/// The unpolarised Fresnel reflectance of a smooth dielectric, `kr = (Rs + Rp) / 2`, for
/// light arriving at `cos_i` (> 0) from the side whose relative index to the other is
/// `eta` (other / this); 1 past the critical angle.
#[must_use]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_at_normal_incidence_and_past_the_critical_angle() {
        // ((n - 1)/(n + 1))² at normal incidence: 0.04 for n = 1.5.
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        // From glass (1.5) to air the critical angle is asin(1/1.5) = 41.8°.
        let eta = 1.0 / 1.5;
        assert!(fresnel_dielectric(30f32.to_radians().cos(), eta) < 1.0);
        assert_eq!(fresnel_dielectric(45f32.to_radians().cos(), eta), 1.0);
        assert!(refract(Vec3::new(45f32.to_radians().sin(), 45f32.to_radians().cos(), 0.0), Vec3::Y, eta).is_none());
        // Grazing incidence reflects everything.
        assert!(fresnel_dielectric(1e-4, 1.5) > 0.99);
    }

    #[test]
    fn refraction_obeys_snell() {
        let n = Vec3::Y;
        let theta_o = 35f32.to_radians();
        let wo = Vec3::new(theta_o.sin(), theta_o.cos(), 0.0);
        let wt = refract(wo, n, 1.3).unwrap();
        let sin_t = (wt - wt.dot(n) * n).length();
        assert!((theta_o.sin() - 1.3 * sin_t).abs() < 1e-5, "sin θo = η sin θt");
        assert!(wt.dot(n) < 0.0 && wt.x < 0.0, "through the surface, on the other side of the normal");
        assert!((wt.length() - 1.0).abs() < 1e-6);
        // The reversed path: a ray travelling along -wt leaves along wo.
        let back = refract(wt, -n, 1.0 / 1.3).unwrap();
        assert!((back - wo).length() < 1e-5, "{back} vs {wo}");
    }
}
