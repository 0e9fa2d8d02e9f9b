//! Lights: a point light and the course's quad (area) light.
//!
//! The course integrators only sample them ([`Light::sample`]). The path tracer also
//! needs the quad light as an emitting surface that a BSDF-sampled ray can meet
//! ([`Light::intersect`]): a one-sided rectangle of constant radiance
//! `L_e = colour·power` towards `-(u × v)`, which is exactly what the course's sample
//! `radiance = colour·power / pdf` estimates (`∫ L_e f cos dω ≈ L_e f cos / pdf`).

use crate::math::color::Color;
use crate::math::ray::Ray;
use glam::{Vec2, Vec3};

/// Where a ray meets an emitting surface (a quad light), seen from the ray's origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightHit {
    /// Ray parameter of the hit (in units of the ray's direction).
    pub t: f32,
    /// Radiance emitted towards the ray's origin (zero from the back).
    pub emitted: Color,
    /// Solid-angle pdf with which [`Light::sample`] would draw this point from the
    /// ray's origin (`d² / (area · cos)`); 0 from the back.
    pub pdf: f32,
}

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
        self.sampler().sample(x, xi)
    }

    /// What sampling this light needs that does not depend on the receiver (the quad's
    /// normal and area), computed once for many samples.
    #[must_use]
    pub fn sampler(&self) -> LightSampler {
        match *self {
            Light::Point { position, color, power } => LightSampler::Point { position, emitted: color * power },
            Light::Quad { corner, u, v, color, power } => {
                // A parallelogram: area |u × v| (the course's quads are rectangles, where it
                // is |u|·|v|).
                let c = u.cross(v);
                let area = c.length();
                LightSampler::Quad {
                    corner,
                    u,
                    v,
                    normal: c / area,
                    area,
                    emitted: color * power,
                    dual: [v.cross(c), c.cross(u)],
                    c2: c.dot(c),
                }
            }
        }
    }
}

/// A light ready to be sampled from many points ([`Light::sampler`]): the same samples as
/// [`Light::sample`], bit for bit, without recomputing the light's own geometry each time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightSampler {
    /// A point light: its position and `colour·power`.
    Point {
        /// Position.
        position: Vec3,
        /// `colour·power`.
        emitted: Color,
    },
    /// A quad light with its unit normal `(u × v)/|u × v|`, area and `colour·power`.
    Quad {
        /// One corner.
        corner: Vec3,
        /// First edge.
        u: Vec3,
        /// Second edge.
        v: Vec3,
        /// Unit normal.
        normal: Vec3,
        /// Area.
        area: f32,
        /// `colour·power`.
        emitted: Color,
        /// The dual basis of `(u, v)` in the quad's plane, times `|u × v|²` (`c2`): `v × c`
        /// and `c × u` with `c = u × v`. A point `p - corner` of the plane has coordinates
        /// `p·dual[0] / c2` along `u` and `p·dual[1] / c2` along `v`.
        dual: [Vec3; 2],
        /// `|u × v|²`.
        c2: f32,
    },
}

impl LightSampler {
    /// Sample the light from point `x`; `xi` in `[0,1)²` picks the point on an area light.
    #[inline]
    #[must_use]
    pub fn sample(&self, x: Vec3, xi: Vec2) -> LightSample {
        match *self {
            LightSampler::Point { position, emitted } => {
                let to = position - x;
                let d = to.length();
                LightSample { direction: to / d, distance: d, point: position, radiance: emitted / (d * d), pdf: 1.0 }
            }
            LightSampler::Quad { corner, u, v, normal, area, emitted, .. } => {
                let y = corner + xi.x * u + xi.y * v;
                let to = y - x;
                let d = to.length();
                let wi = to / d;
                let cos = normal.dot(wi);
                if cos.is_nan() || cos <= 0.0 {
                    // The back of the light: nothing.
                    return LightSample { direction: wi, distance: d, point: y, radiance: Color::ZERO, pdf: 0.0 };
                }
                let pdf = d * d / (area * cos);
                LightSample { direction: wi, distance: d, point: y, radiance: emitted / pdf, pdf }
            }
        }
    }
}

impl LightSampler {
    /// [`Light::intersect`], with the quad's own geometry computed once (the same floats).
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<LightHit> {
        let LightSampler::Quad { corner, normal: n, area, emitted, dual, c2, .. } = *self else { return None };
        if area.is_nan() || area <= 0.0 {
            return None;
        }
        let denom = n.dot(ray.direction);
        if denom == 0.0 || !denom.is_finite() {
            return None;
        }
        let t = n.dot(corner - ray.origin) / denom;
        if !(t > t_min && t < t_max) {
            return None;
        }
        // Coordinates of the hit in the (u, v) basis, through the dual basis.
        let p = ray.at(t) - corner;
        let a = p.dot(dual[0]) / c2;
        let b = p.dot(dual[1]) / c2;
        if !((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)) {
            return None;
        }
        let len = ray.direction.length();
        let cos = denom / len;
        if cos <= 0.0 {
            return Some(LightHit { t, emitted: Color::ZERO, pdf: 0.0 });
        }
        let d = t * len;
        Some(LightHit { t, emitted, pdf: d * d / (area * cos) })
    }
}

impl Light {
    /// The radiance `L_e` an area light emits from its front (`colour·power`): the
    /// course's sample radiance times the sample's pdf. Zero for point lights, which no
    /// ray can meet.
    #[must_use]
    pub fn emitted_radiance(&self) -> Color {
        match *self {
            Light::Point { .. } => Color::ZERO,
            Light::Quad { color, power, .. } => color * power,
        }
    }

    /// Where `ray` meets this light in `(t_min, t_max)`, if it is a quad light. The back
    /// of the quad (seen from where `dot(n, d) <= 0`) is met with no emission and pdf 0.
    /// A parallelogram `corner + a·u + b·v`, `a, b ∈ [0, 1]`.
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<LightHit> {
        self.sampler().intersect(ray, t_min, t_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ray_meets_the_quad_where_sampling_would_put_it_with_the_same_pdf() {
        let l = Light::Quad {
            corner: Vec3::new(1.0, 10.0, 2.0),
            u: Vec3::new(-2.0, 0.0, 0.0),
            v: Vec3::new(0.0, 0.0, 2.0),
            color: Vec3::new(1.0, 0.5, 0.25),
            power: 40.0,
        };
        let x = Vec3::new(0.3, 0.0, 2.5);
        for xi in [Vec2::new(0.5, 0.5), Vec2::new(0.1, 0.9), Vec2::new(0.99, 0.01)] {
            let s = l.sample(x, xi);
            let hit = l.intersect(&Ray::new(x, s.direction), 0.0, f32::INFINITY).expect("the sampled point is on the quad");
            assert!((hit.t - s.distance).abs() < 1e-4, "{hit:?} {s:?}");
            assert!((hit.pdf - s.pdf).abs() < 1e-4 * s.pdf, "{hit:?} {s:?}");
            // The sample's radiance is L_e / pdf.
            assert!((hit.emitted - s.radiance * s.pdf).abs().max_element() < 1e-3, "{hit:?} {s:?}");
            assert_eq!(hit.emitted, Vec3::new(40.0, 20.0, 10.0));
        }
        // Beside the quad, behind the origin, beyond t_max: nothing.
        assert!(l.intersect(&Ray::new(x, Vec3::new(1.0, 1.0, 0.0)), 0.0, f32::INFINITY).is_none());
        assert!(l.intersect(&Ray::new(x, -Vec3::Y), 0.0, f32::INFINITY).is_none());
        assert!(l.intersect(&Ray::new(x, Vec3::Y), 0.0, 5.0).is_none());
        // From above, the back: met, but dark.
        let back = l.intersect(&Ray::new(Vec3::new(0.0, 20.0, 3.0), -Vec3::Y), 0.0, f32::INFINITY).unwrap();
        assert_eq!((back.emitted, back.pdf), (Vec3::ZERO, 0.0));
        // Point lights are never met.
        let p = Light::Point { position: Vec3::Y, color: Vec3::ONE, power: 1.0 };
        assert!(p.intersect(&Ray::new(Vec3::ZERO, Vec3::Y), 0.0, f32::INFINITY).is_none());
    }

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
