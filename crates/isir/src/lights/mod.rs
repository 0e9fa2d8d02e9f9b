//! Lights: a point light and the course's quad (area) light.

use crate::math::color::Color;
use glam::{Vec2, Vec3};

/// A light sample seen from a point `x`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from `x` towards the sampled point of the light (`wi`).
    pub direction: Vec3,
    /// Distance from `x` to it.
    pub distance: f32,
    /// The sampled point of the light (where shadow rays aim).
    pub point: Vec3,
    /// Incoming radiance at `x` divided by the sample's pdf.
    pub radiance: Color,
    /// The pdf of the sample (solid angle for area lights; 1 for point lights).
    pub pdf: f32,
}

/// The lights of the course.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// `PointLight(position, colour, power)`: radiance `colour·power / d²`.
    Point {
        /// Position.
        position: Vec3,
        /// Colour.
        color: Color,
        /// Power.
        power: f32,
    },
    /// `QuadLight(corner, u, v, colour, power)`: points `corner + ξ1·u + ξ2·v`, normal
    /// `normalize(u × v)`. It lights the side where `dot(n, wi) > 0` seen from the
    /// receiver, i.e. it shines towards `-(u × v)`, as in the course.
    Quad {
        /// One corner.
        corner: Vec3,
        /// First edge.
        u: Vec3,
        /// Second edge.
        v: Vec3,
        /// Colour.
        color: Color,
        /// Power.
        power: f32,
    },
}

impl Light {
    /// True for lights with an area (sampled `nbLightSamples` times).
    #[must_use]
    pub fn is_surface(&self) -> bool {
        matches!(self, Light::Quad { .. })
    }

    /// Sample the light from point `x`; `xi` in `[0,1)²` picks the point on an area light.
    #[must_use]
    pub fn sample(&self, x: Vec3, xi: Vec2) -> LightSample {
        match *self {
            Light::Point { position, color, power } => {
                let to = position - x;
                let d = to.length();
                LightSample { direction: to / d, distance: d, point: position, radiance: color * power / (d * d), pdf: 1.0 }
            }
            Light::Quad { corner, u, v, color, power } => {
                let y = corner + xi.x * u + xi.y * v;
                let to = y - x;
                let d = to.length();
                let wi = to / d;
                // A parallelogram: area |u × v| (the course's quads are rectangles, where it
                // is |u|·|v|).
                let c = u.cross(v);
                let area = c.length();
                let n = c / area;
                let cos = n.dot(wi);
                if cos.is_nan() || cos <= 0.0 {
                    // The back of the light: nothing.
                    return LightSample { direction: wi, distance: d, point: y, radiance: Color::ZERO, pdf: 0.0 };
                }
                let pdf = d * d / (area * cos);
                LightSample { direction: wi, distance: d, point: y, radiance: color * power / pdf, pdf }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_light_falls_off_with_distance_squared() {
        let l = Light::Point { position: Vec3::new(0.0, 10.0, 0.0), color: Vec3::ONE, power: 100.0 };
        let s = l.sample(Vec3::ZERO, Vec2::ZERO);
        assert_eq!(s.direction, Vec3::Y);
        assert_eq!(s.distance, 10.0);
        assert_eq!(s.radiance, Vec3::ONE);
    }

    #[test]
    fn quad_light_area_is_that_of_the_parallelogram() {
        // u × v = (2,0,0) × (1,0,2) = (0,-4,0): area 4 (not |u|·|v| = 4.47), n = -y, so it
        // lights points above it. Straight above the centre at distance 5: radiance =
        // power · area · cos / d² = 10 · 4 / 25.
        let l = Light::Quad { corner: Vec3::ZERO, u: Vec3::new(2.0, 0.0, 0.0), v: Vec3::new(1.0, 0.0, 2.0), color: Vec3::ONE, power: 10.0 };
        let centre = Vec3::new(1.5, 0.0, 1.0);
        let s = l.sample(centre + Vec3::new(0.0, 5.0, 0.0), Vec2::splat(0.5));
        assert!((s.radiance.x - 1.6).abs() < 1e-5, "{s:?}");
    }

    #[test]
    fn quad_light_shines_towards_minus_u_cross_v() {
        // u × v = (-2,0,0) × (0,0,2) = (0, 4, 0): n = +y, so it lights points below it.
        let l = Light::Quad {
            corner: Vec3::new(1.0, 10.0, 2.0),
            u: Vec3::new(-2.0, 0.0, 0.0),
            v: Vec3::new(0.0, 0.0, 2.0),
            color: Vec3::ONE,
            power: 40.0,
        };
        let below = l.sample(Vec3::new(0.0, 0.0, 3.0), Vec2::splat(0.5));
        assert!(below.radiance.x > 0.0);
        // Straight below the centre at distance 10: pdf = 100 / (4 · 1), radiance = 40 / 25.
        assert!((below.radiance.x - 1.6).abs() < 1e-5, "{below:?}");
        let above = l.sample(Vec3::new(0.0, 20.0, 3.0), Vec2::splat(0.5));
        assert_eq!(above.radiance, Vec3::ZERO);
    }
}
