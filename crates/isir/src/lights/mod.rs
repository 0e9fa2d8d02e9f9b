//! Lights: a point light and the course's quad (area) light.
//!
//! The course integrators only sample them ([`Light::sample`]). The path tracer also
//! needs the quad light as an emitting surface that a BSDF-sampled ray can meet
//! ([`Light::intersect`]): a one-sided rectangle of constant radiance
//! `L_e = colour·power` towards `-(u × v)`, which is exactly what the course's sample
//! `radiance = colour·power / pdf` estimates (`∫ L_e f cos dω ≈ L_e f cos / pdf`).

use crate::math::color::Color;
use crate::math::ray::{lane_mask, Ray, RayLanes, LANES};
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
    /// What a light must be to light a scene: finite points, a finite colour and power
    /// that are not negative, and for a quad, edges spanning an area.
    ///
    /// # Errors
    /// Which of those fails, in words.
    pub fn check(&self) -> std::result::Result<(), String> {
        let (points, color, power) = match *self {
            Light::Point { position, color, power } => (vec![position], color, power),
            Light::Quad { corner, u, v, color, power } => (vec![corner, corner + u, corner + v, corner + u + v], color, power),
        };
        if !points.iter().all(|p| p.is_finite()) || !power.is_finite() {
            return Err("position and power must be finite".into());
        }
        if power < 0.0 || !color.is_finite() || color.min_element() < 0.0 {
            return Err(format!("power {power} and colour {color} must not be negative"));
        }
        if let Light::Quad { u, v, .. } = *self {
            if !u.cross(v).length_squared().is_normal() {
                return Err(format!("the quad's edges u {u} and v {v} span no area"));
            }
        }
        Ok(())
    }

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
    /// `colour·power`.
    #[must_use]
    pub fn emitted(&self) -> Color {
        match *self {
            LightSampler::Point { emitted, .. } | LightSampler::Quad { emitted, .. } => emitted,
        }
    }

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

/// Where each of up to [`LANES`] rays meets a quad light ([`LightSampler::intersect_lanes`]).
#[derive(Clone, Copy, Debug)]
pub struct LightHitLanes {
    /// Bit `k` set: ray `k` meets the light.
    pub met: u32,
    /// Per lane, where [`LightSampler::intersect`] gives a hit: that hit.
    pub t: [f32; LANES],
    /// Per lane: the emission is zero (the back of the quad).
    pub back: u32,
    /// Per lane: the hit's pdf (0 from the back).
    pub pdf: [f32; LANES],
}

impl LightHitLanes {
    /// Lane `k`'s hit, as [`LightSampler::intersect`] returns it (`emitted`: the light's).
    #[must_use]
    pub fn hit(&self, k: usize, emitted: Color) -> Option<LightHit> {
        (self.met & (1 << k) != 0).then(|| {
            if self.back & (1 << k) != 0 {
                LightHit { t: self.t[k], emitted: Color::ZERO, pdf: 0.0 }
            } else {
                LightHit { t: self.t[k], emitted, pdf: self.pdf[k] }
            }
        })
    }
}

impl LightSampler {
    /// [`LightSampler::intersect`] for the rays of `rays` whose bits are set in `mask`, ray
    /// `k` in `(rays.t_min[k], t_max[k])`: the same answers, the same floats, eight lanes
    /// wide where the CPU has AVX2. A point light meets nothing.
    #[must_use]
    pub fn intersect_lanes(&self, rays: &RayLanes, t_max: &[f32; LANES], mask: u32) -> LightHitLanes {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            #[target_feature(enable = "avx2")]
            fn avx2(l: &LightSampler, rays: &RayLanes, t_max: &[f32; LANES], mask: u32) -> LightHitLanes {
                l.intersect_lanes_portable(rays, t_max, mask)
            }
            // SAFETY: the CPU has AVX2, which is all `avx2` is compiled for.
            return unsafe { avx2(self, rays, t_max, mask) };
        }
        self.intersect_lanes_portable(rays, t_max, mask)
    }

    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    fn intersect_lanes_portable(&self, rays: &RayLanes, t_max: &[f32; LANES], mask: u32) -> LightHitLanes {
        let mut out = LightHitLanes { met: 0, t: [0.0; LANES], back: 0, pdf: [0.0; LANES] };
        let LightSampler::Quad { corner, normal: n, area, dual, c2, .. } = *self else { return out };
        if area.is_nan() || area <= 0.0 {
            return out;
        }
        let (c, n, d0, d1) = (corner.to_array(), n.to_array(), dual[0].to_array(), dual[1].to_array());
        let (mut met, mut back) = ([false; LANES], [false; LANES]);
        for k in 0..LANES {
            let (o, d) = ([rays.o[0][k], rays.o[1][k], rays.o[2][k]], [rays.d[0][k], rays.d[1][k], rays.d[2][k]]);
            // `LightSampler::intersect`'s operations, in its order.
            let denom = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
            let co = [c[0] - o[0], c[1] - o[1], c[2] - o[2]];
            let t = (n[0] * co[0] + n[1] * co[1] + n[2] * co[2]) / denom;
            let p = [o[0] + t * d[0] - c[0], o[1] + t * d[1] - c[1], o[2] + t * d[2] - c[2]];
            let a = (p[0] * d0[0] + p[1] * d0[1] + p[2] * d0[2]) / c2;
            let b = (p[0] * d1[0] + p[1] * d1[1] + p[2] * d1[2]) / c2;
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let cos = denom / len;
            let dd = t * len;
            // `&`, not `&&`: short-circuits would compile to branches, and the loop scalar.
            met[k] = (denom != 0.0)
                & denom.is_finite()
                & (t > rays.t_min[k])
                & (t < t_max[k])
                & (0.0..=1.0).contains(&a)
                & (0.0..=1.0).contains(&b);
            back[k] = cos <= 0.0;
            out.t[k] = t;
            out.pdf[k] = dd * dd / (area * cos);
        }
        // PERF: as masks, not a branch per lane (the path tracer's bounces, every vertex).
        out.met = lane_mask(&met) & mask;
        out.back = lane_mask(&back) & out.met;
        out
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

    /// The lanes' quad intersections are `intersect`'s, bit for bit, on both code paths:
    /// rays towards the quad, beside it, behind it, parallel to it, zero and NaN rays,
    /// short intervals, lanes left out of the mask; a point light meets nothing.
    #[test]
    fn intersect_lanes_answers_as_intersect() {
        let mut rng = crate::math::sampling::Sampler::from_seed(5);
        let quad = Light::Quad {
            corner: Vec3::new(-1.0, 3.0, -1.0),
            u: Vec3::new(2.0, 0.0, 0.0),
            v: Vec3::new(0.0, 0.5, 2.0),
            color: Vec3::ONE,
            power: 4.0,
        };
        let (mut met, mut back) = (0, 0);
        for round in 0..3000u32 {
            let light = if round % 10 == 0 { Light::Point { position: Vec3::Y, color: Vec3::ONE, power: 1.0 } } else { quad.clone() };
            let ls = light.sampler();
            let mut r = || rng.next_f32() * 6.0 - 3.0;
            let mut rays = RayLanes::EMPTY;
            let mut t_max = [0f32; LANES];
            #[allow(clippy::needless_range_loop)] // one index into several arrays
            for k in 0..LANES {
                let case = (round as usize + k) % 11;
                // Case 4: from above, down onto the quad's front.
                let o = if case == 4 { Vec3::new(r() * 0.3, 6.0, r() * 0.3 + 0.5) } else { Vec3::new(r(), r(), r()) };
                let d = match case {
                    4 => Vec3::new(r() * 0.1, -1.0, r() * 0.1),
                    0 => Vec3::ZERO,
                    1 => Vec3::splat(f32::NAN),
                    2 => Vec3::new(1.0, 0.0, 0.0),
                    3 => Vec3::new(r(), 3.5 - o.y + r() * 0.3, r()) * 3.0,
                    _ => Vec3::new(r(), r(), r()),
                };
                rays.set(k, o, d, r().abs() * 0.1, 0.0);
                t_max[k] = if k % 4 == 0 { r().abs() * 0.5 } else { f32::INFINITY };
            }
            let mask = round.wrapping_mul(0x9e37_79b9) >> 16;
            let lanes = ls.intersect_lanes(&rays, &t_max, mask);
            let portable = ls.intersect_lanes_portable(&rays, &t_max, mask);
            #[allow(clippy::needless_range_loop)] // one index into several arrays
            for k in 0..LANES {
                let want = if mask & (1 << k) != 0 { light.intersect(&rays.ray(k), rays.t_min[k], t_max[k]) } else { None };
                let bits = |h: Option<LightHit>| h.map(|h| (h.t.to_bits(), h.emitted.to_array().map(f32::to_bits), h.pdf.to_bits()));
                assert_eq!(bits(lanes.hit(k, ls.emitted())), bits(want), "{light:?} {:?}", rays.ray(k));
                assert_eq!(bits(portable.hit(k, ls.emitted())), bits(want));
                if let Some(h) = want {
                    met += 1;
                    back += usize::from(h.emitted == Color::ZERO);
                }
            }
        }
        assert!(met > 1000 && back > 100, "{met} {back}");
    }

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
