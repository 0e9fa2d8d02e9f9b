//! Materials: `shade` returns the BRDF value for a light sample (the course's
//! `Material::shade`); each kind documents exactly what it returns.

use crate::geometry::Hit;
use crate::lights::LightSample;
use crate::math::color::Color;
use crate::math::ray::Ray;

pub use crate::geometry::MaterialId;

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
