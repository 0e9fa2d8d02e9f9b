//! Materials: `shade` returns the BRDF value for a light sample.

use crate::color::Color;
use crate::light::LightSample;
use crate::ray::Ray;
use crate::scene::Hit;

/// Index of a material in its [`crate::Scene`].
pub type MaterialId = u32;

/// The materials of the course (a closed set, dispatched by `match`).
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    /// The course's `ColorMaterial`: returns its colour as the BRDF, without 1/π.
    Color(Color),
    /// Lambertian diffuse: `kd / π`.
    Lambert(Color),
}

impl Material {
    /// The colour shown by the ray-cast integrator.
    #[must_use]
    pub fn flat_color(&self) -> Color {
        match self {
            Material::Color(c) | Material::Lambert(c) => *c,
        }
    }

    /// The BRDF value for light arriving along `light.direction` and leaving towards the
    /// ray's origin.
    #[must_use]
    pub fn shade(&self, _ray: &Ray, _hit: &Hit, _light: &LightSample) -> Color {
        match self {
            Material::Color(c) => *c,
            Material::Lambert(kd) => *kd * std::f32::consts::FRAC_1_PI,
        }
    }
}
