//! Implicit surfaces (TP7): a signed distance function ([`Sdf`]) rendered by sphere
//! tracing (Hart 1996), inside its bounding box.
//!
//! From where the ray enters the box, step along it by the distance the function gives:
//! no surface is nearer, so no step crosses one. Stop at a hit when the distance falls
//! below [`hit_threshold`] (the course's minimum distance 1e-4, scaled up with the
//! coordinates so that float rounding cannot keep it from being reached), at a miss when
//! the ray leaves the box or after [`MAX_STEPS`] steps. A ray starting inside the solid
//! marches on `-f` to the surface it leaves by (what a refracted ray needs).

mod sdf;
#[cfg(test)]
mod tests;

pub use sdf::{smooth_min, Sdf, MAX_DEPTH, MAX_NODES};

use crate::math::aabb::Aabb;
use crate::math::ray::{gamma, Ray};
use glam::Vec3;

/// The course's minimum distance: a ray within it of the surface has hit.
pub const MIN_DISTANCE: f32 = 1e-4;

/// Most marching steps of one ray: grazing rays creep along a silhouette in ever smaller
/// steps, and are counted as missing after this many.
pub const MAX_STEPS: u32 = 512;

/// The distance under which a point at `p` counts as on the surface: [`MIN_DISTANCE`], or
/// `2⁻²⁰·|p|∞` (16 ULPs of the point's largest coordinate) far from the origin, where the
/// evaluation of `f` is not precise to 1e-4 and a ray would never get that close.
#[inline]
#[must_use]
pub fn hit_threshold(p: Vec3) -> f32 {
    MIN_DISTANCE.max(p.abs().max_element() * (1.0 / 1_048_576.0))
}

/// An implicit surface: its function and a bounding box, computed once.
#[derive(Clone, Debug, PartialEq)]
pub struct Implicit {
    sdf: Sdf,
    bounds: Aabb,
}

impl Implicit {
    /// The surface of `sdf`, bounded by [`Sdf::bounds`] grown by the hit threshold.
    ///
    /// # Errors
    /// Why the tree is refused ([`Sdf::check`]), or that its box is not finite (a lone
    /// half-space, or one under a rotation): the caller names the object.
    pub fn new(sdf: Sdf) -> Result<Self, String> {
        sdf.check()?;
        let b = sdf.bounds();
        if b.is_empty() {
            return Ok(Self { sdf, bounds: b });
        }
        if !(b.min.is_finite() && b.max.is_finite()) {
            return Err(format!("the surface is unbounded (box {} to {}): intersect half-spaces with a bounded shape", b.min, b.max));
        }
        let grow = Vec3::splat(2.0 * hit_threshold(b.min.abs().max(b.max.abs())));
        Ok(Self { sdf, bounds: Aabb::new(b.min - grow, b.max + grow) })
    }

    /// The function.
    #[must_use]
    pub fn sdf(&self) -> &Sdf {
        &self.sdf
    }

    /// The box holding the surface (empty when the surface is: an intersection of shapes
    /// that do not meet).
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The nearest `t` in `[t_min, t_max)` where the ray reaches the surface, by sphere
    /// tracing inside the bounding box. At most [`MAX_STEPS`] evaluations; invalid rays
    /// (NaN, zero direction) and NaN intervals meet nothing.
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        if !ray.is_valid() || t_min.is_nan() || t_max.is_nan() {
            return None;
        }
        let (enter, exit) = self.bounds.intersect(ray, t_min, t_max)?;
        let speed = ray.direction.length();
        let mut t = enter;
        // The side of the surface the ray starts on: it marches to the surface from there.
        let mut side = 0.0;
        for _ in 0..MAX_STEPS {
            let p = ray.at(t);
            let d = self.sdf.distance(p);
            if side == 0.0 {
                side = if d < 0.0 { -1.0 } else { 1.0 };
            }
            let d = side * d;
            if d < hit_threshold(p) {
                return (t < t_max).then_some(t);
            }
            t += d / speed;
            if t > exit || d.is_nan() {
                return None;
            }
        }
        None
    }

    /// The point where the ray meets the surface at `t`, and a bound on its error per
    /// axis. The point is `o + t·d`, within the hit threshold of the surface (the march
    /// stops there) plus the rounding of the point itself (`γ(3)·|p|` per axis, the
    /// product and sum). The bound is three thresholds: [`crate::geometry::Hit::spawn_ray`]
    /// moves a leaving ray at least that far along the normal, so it starts at least two
    /// thresholds from the surface (one where the blend of a smooth union halves the
    /// gradient) and its first step cannot count as a hit.
    #[must_use]
    pub fn surface_point(&self, ray: &Ray, t: f32) -> (Vec3, Vec3) {
        let p = ray.at(t);
        (p, Vec3::splat(3.0 * hit_threshold(p)) + gamma(3) * (p.abs() + (t * ray.direction).abs()))
    }

    /// Outward unit normal at `p`: the gradient of the function by the tetrahedron
    /// technique (four evaluations at `p + h·k` for the corners `k` of a tetrahedron,
    /// `Σ k·f(p + h·k)`), `h` the hit threshold. Where the gradient vanishes (the centre of a
    /// sphere), `+y`.
    #[must_use]
    pub fn normal(&self, p: Vec3) -> Vec3 {
        let h = hit_threshold(p);
        let g = [Vec3::new(1.0, -1.0, -1.0), Vec3::new(-1.0, -1.0, 1.0), Vec3::new(-1.0, 1.0, -1.0), Vec3::ONE]
            .into_iter()
            .map(|k| k * self.sdf.distance(p + h * k))
            .sum::<Vec3>();
        // Scaled to its largest component first, so small gradients do not underflow.
        let m = g.abs().max_element();
        if m > 0.0 && m.is_finite() {
            (g / m).normalize()
        } else {
            Vec3::Y
        }
    }
}
