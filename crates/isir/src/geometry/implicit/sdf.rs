//! Signed distance functions (Inigo Quilez's formulas), as a small tree dispatched by
//! `match`. Negative inside, positive outside, zero on the surface.
//!
//! Sphere tracing needs only a *bound*: `|f(p)|` never more than the true distance to the
//! surface (a 1-Lipschitz function), so a step of `f(p)` cannot cross it. Each node says
//! whether it is *exact* (the Euclidean distance) or a bound.

use crate::math::aabb::Aabb;
use glam::{Quat, Vec2, Vec3, Vec3Swizzles};

/// Deepest tree accepted ([`Sdf::check`]): evaluation recurses, so depth is bounded.
pub const MAX_DEPTH: usize = 64;
/// Most nodes accepted in one tree: each node is evaluated at every marching step.
pub const MAX_NODES: usize = 1024;

/// A signed distance function. Primitives sit at the origin; place them with
/// [`Sdf::Transform`] (or [`Sdf::translated`], [`Sdf::transformed`]).
#[derive(Clone, Debug, PartialEq)]
pub enum Sdf {
    /// Sphere of `radius` about the origin: `|p| - r`. Exact.
    Sphere {
        /// Radius (> 0).
        radius: f32,
    },
    /// Torus around the y axis, in the xz plane: `|(|p.xz| - R, p.y)| - r`. Exact.
    Torus {
        /// Distance from the centre to the centre of the tube (> 0).
        major: f32,
        /// Radius of the tube (> 0).
        minor: f32,
    },
    /// Box from `-half` to `half`: with `q = |p| - half`,
    /// `|max(q, 0)| + min(max(q.x, q.y, q.z), 0)`. Exact.
    Box {
        /// Half its size on each axis (> 0).
        half: Vec3,
    },
    /// Box from `-half` to `half` with edges rounded by `radius`: with
    /// `q = |p| - half + r`, `|max(q, 0)| + min(max(q.x, q.y, q.z), 0) - r`. Exact.
    RoundedBox {
        /// Half its size on each axis, the rounding included (> 0).
        half: Vec3,
        /// Radius of the rounded edges (0 < r ≤ the smallest half size).
        radius: f32,
    },
    /// Capsule: the points within `radius` of the segment `a`–`b`. With `h` the clamped
    /// projection `clamp(dot(p-a, b-a) / |b-a|², 0, 1)`, `|p - a - h·(b-a)| - r`. Exact.
    Capsule {
        /// One end of the segment.
        a: Vec3,
        /// The other end (may equal `a`: a sphere).
        b: Vec3,
        /// Radius (> 0).
        radius: f32,
    },
    /// Half-space below the plane `dot(p, n) = offset` (the solid is where
    /// `dot(p, n) < offset`, `n` unit, pointing out): `dot(p, n) - offset`. Exact. Unbounded:
    /// an object needs it intersected with a bounded shape.
    Plane {
        /// Unit normal, pointing out of the solid.
        normal: Vec3,
        /// Signed distance of the plane from the origin along `normal`.
        offset: f32,
    },
    /// Union: `min(a, b)`. Exact outside, a bound inside.
    Union(Box<Sdf>, Box<Sdf>),
    /// Intersection: `max(a, b)`. A bound.
    Intersection(Box<Sdf>, Box<Sdf>),
    /// Subtraction, the first minus the second: `max(a, -b)`. A bound.
    Subtraction(Box<Sdf>, Box<Sdf>),
    /// Smooth union with blend radius `k` (Quilez's polynomial smooth minimum):
    /// `h = max(k - |a - b|, 0) / k`, `min(a, b) - h²·k/4`. Equals `min(a, b)` where
    /// `|a - b| ≥ k`, never above it, at most `k/4` below. A bound.
    SmoothUnion(Box<Sdf>, Box<Sdf>, f32),
    /// The inner shape rotated by `rotation`, scaled by `scale` (uniform) then moved by
    /// `translation`: `s · f(R⁻¹(p - t) / s)`. The factor `s` scales the local distance
    /// back to world units, so the node is exact when its child is.
    Transform {
        /// The shape in its own frame.
        inner: Box<Sdf>,
        /// Translation.
        translation: Vec3,
        /// Unit quaternion.
        rotation: Quat,
        /// Uniform scale (> 0).
        scale: f32,
    },
}

impl Sdf {
    /// A sphere of `radius` about `center`.
    #[must_use]
    pub fn sphere(center: Vec3, radius: f32) -> Self {
        Sdf::Sphere { radius }.translated(center)
    }

    /// The half-space `dot(p, normal) < offset` (`normal` normalized here).
    #[must_use]
    pub fn plane(normal: Vec3, offset: f32) -> Self {
        Sdf::Plane { normal: normal.normalize_or_zero(), offset }
    }

    /// `self ∪ other`.
    #[must_use]
    pub fn union(self, other: Sdf) -> Self {
        Sdf::Union(Box::new(self), Box::new(other))
    }

    /// `self ∩ other`.
    #[must_use]
    pub fn intersection(self, other: Sdf) -> Self {
        Sdf::Intersection(Box::new(self), Box::new(other))
    }

    /// `self` minus `other`.
    #[must_use]
    pub fn subtract(self, other: Sdf) -> Self {
        Sdf::Subtraction(Box::new(self), Box::new(other))
    }

    /// `self ∪ other` blended over `k`.
    #[must_use]
    pub fn smooth_union(self, other: Sdf, k: f32) -> Self {
        Sdf::SmoothUnion(Box::new(self), Box::new(other), k)
    }

    /// `self` moved by `t`.
    #[must_use]
    pub fn translated(self, t: Vec3) -> Self {
        self.transformed(t, Quat::IDENTITY, 1.0)
    }

    /// `self` rotated (the quaternion is normalized here), scaled, then translated.
    #[must_use]
    pub fn transformed(self, translation: Vec3, rotation: Quat, scale: f32) -> Self {
        Sdf::Transform { inner: Box::new(self), translation, rotation: rotation.normalize(), scale }
    }

    /// The signed distance (or its bound, see each node) at `p`.
    #[must_use]
    pub fn distance(&self, p: Vec3) -> f32 {
        match self {
            Sdf::Sphere { radius } => p.length() - radius,
            Sdf::Torus { major, minor } => Vec2::new(p.xz().length() - major, p.y).length() - minor,
            Sdf::Box { half } => box_distance(p, *half),
            Sdf::RoundedBox { half, radius } => box_distance(p, *half - Vec3::splat(*radius)) - radius,
            Sdf::Capsule { a, b, radius } => {
                let (pa, ba) = (p - *a, *b - *a);
                let len2 = ba.length_squared();
                let h = if len2 > 0.0 { (pa.dot(ba) / len2).clamp(0.0, 1.0) } else { 0.0 };
                (pa - ba * h).length() - radius
            }
            Sdf::Plane { normal, offset } => p.dot(*normal) - offset,
            Sdf::Union(a, b) => a.distance(p).min(b.distance(p)),
            Sdf::Intersection(a, b) => a.distance(p).max(b.distance(p)),
            Sdf::Subtraction(a, b) => a.distance(p).max(-b.distance(p)),
            Sdf::SmoothUnion(a, b, k) => smooth_min(a.distance(p), b.distance(p), *k),
            Sdf::Transform { inner, translation, rotation, scale } => {
                scale * inner.distance(rotation.inverse() * (p - *translation) / *scale)
            }
        }
    }

    /// A box that holds the surface and the inside (infinite for a lone half-space):
    /// primitives' analytic boxes, the union of boxes for a union, their intersection for
    /// an intersection, the left box for a subtraction, the union grown by `k` for a smooth
    /// union (the blend adds at most `k/4`), the box of the transformed corners for a
    /// transform.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        match self {
            Sdf::Sphere { radius } => Aabb::new(Vec3::splat(-radius), Vec3::splat(*radius)),
            Sdf::Torus { major, minor } => {
                let e = Vec3::new(major + minor, *minor, major + minor);
                Aabb::new(-e, e)
            }
            Sdf::Box { half } | Sdf::RoundedBox { half, .. } => Aabb::new(-*half, *half),
            Sdf::Capsule { a, b, radius } => Aabb::new(a.min(*b) - Vec3::splat(*radius), a.max(*b) + Vec3::splat(*radius)),
            Sdf::Plane { normal, offset } => {
                // Axis-aligned: the half-space is a box unbounded on five sides.
                let mut b = Aabb::new(Vec3::NEG_INFINITY, Vec3::INFINITY);
                if let Some(axis) = (0..3).find(|&i| normal[i].abs() == 1.0) {
                    if normal[axis] > 0.0 {
                        b.max[axis] = *offset;
                    } else {
                        b.min[axis] = -offset;
                    }
                }
                b
            }
            Sdf::Union(a, b) => a.bounds().union(&b.bounds()),
            Sdf::Intersection(a, b) => {
                let (a, b) = (a.bounds(), b.bounds());
                Aabb::new(a.min.max(b.min), a.max.min(b.max))
            }
            Sdf::Subtraction(a, _) => a.bounds(),
            Sdf::SmoothUnion(a, b, k) => {
                let u = a.bounds().union(&b.bounds());
                Aabb::new(u.min - Vec3::splat(*k), u.max + Vec3::splat(*k))
            }
            Sdf::Transform { inner, translation, rotation, scale } => {
                let b = inner.bounds();
                if b.is_empty() {
                    return Aabb::EMPTY;
                }
                if *rotation == Quat::IDENTITY {
                    return Aabb::new(b.min * *scale + *translation, b.max * *scale + *translation);
                }
                if !(b.min.is_finite() && b.max.is_finite()) {
                    return Aabb::new(Vec3::NEG_INFINITY, Vec3::INFINITY);
                }
                let mut out = Aabb::EMPTY;
                for i in 0..8 {
                    let corner = Vec3::new(
                        if i & 1 == 0 { b.min.x } else { b.max.x },
                        if i & 2 == 0 { b.min.y } else { b.max.y },
                        if i & 4 == 0 { b.min.z } else { b.max.z },
                    );
                    out.extend(*rotation * (corner * *scale) + *translation);
                }
                out
            }
        }
    }

    /// Why the tree cannot be traced, if it cannot: a parameter that is not finite, a
    /// radius, size or scale that is not positive, a rounding larger than its box, a
    /// normal or rotation that is not unit, or a tree deeper than [`MAX_DEPTH`] or larger
    /// than [`MAX_NODES`].
    ///
    /// # Errors
    /// The first problem found, naming the node.
    pub fn check(&self) -> Result<(), String> {
        let mut nodes = 0;
        self.check_at(0, &mut nodes)
    }

    fn check_at(&self, depth: usize, nodes: &mut usize) -> Result<(), String> {
        *nodes += 1;
        if depth >= MAX_DEPTH {
            return Err(format!("the tree is deeper than {MAX_DEPTH} levels"));
        }
        if *nodes > MAX_NODES {
            return Err(format!("the tree has more than {MAX_NODES} nodes"));
        }
        let positive = |x: f32| x.is_finite() && x > 0.0;
        let fail = |what: String| Err(what);
        match self {
            Sdf::Sphere { radius } if !positive(*radius) => fail(format!("sphere: radius {radius} must be finite and positive")),
            Sdf::Torus { major, minor } if !(positive(*major) && positive(*minor)) => {
                fail(format!("torus: radii {major} and {minor} must be finite and positive"))
            }
            Sdf::Box { half } if !(positive(half.x) && positive(half.y) && positive(half.z)) => {
                fail(format!("box: half sizes {half} must be finite and positive"))
            }
            Sdf::RoundedBox { half, radius } => {
                if !(positive(half.x) && positive(half.y) && positive(half.z)) {
                    fail(format!("rounded box: half sizes {half} must be finite and positive"))
                } else if !(positive(*radius) && *radius <= half.min_element()) {
                    fail(format!(
                        "rounded box: rounding radius {radius} must be positive and at most the smallest half size {}",
                        half.min_element()
                    ))
                } else {
                    Ok(())
                }
            }
            Sdf::Capsule { a, b, radius } if !(a.is_finite() && b.is_finite() && positive(*radius)) => {
                fail(format!("capsule: ends {a}, {b} must be finite and radius {radius} positive"))
            }
            Sdf::Plane { normal, offset } if !(normal.is_finite() && offset.is_finite() && (normal.length() - 1.0).abs() < 1e-3) => {
                fail(format!("plane: normal {normal} must be a finite unit vector and offset {offset} finite"))
            }
            Sdf::Union(a, b) | Sdf::Intersection(a, b) | Sdf::Subtraction(a, b) => {
                a.check_at(depth + 1, nodes)?;
                b.check_at(depth + 1, nodes)
            }
            Sdf::SmoothUnion(a, b, k) => {
                if !positive(*k) {
                    return fail(format!("smooth union: blend radius {k} must be finite and positive"));
                }
                a.check_at(depth + 1, nodes)?;
                b.check_at(depth + 1, nodes)
            }
            Sdf::Transform { inner, translation, rotation, scale } => {
                if !(translation.is_finite() && rotation.is_finite() && (rotation.length() - 1.0).abs() < 1e-3 && positive(*scale)) {
                    return fail(format!(
                        "transform: translation {translation} must be finite, rotation {rotation} a unit quaternion, scale {scale} positive"
                    ));
                }
                inner.check_at(depth + 1, nodes)
            }
            _ => Ok(()),
        }
    }
}

/// Exact distance to the box from `-half` to `half`.
#[inline]
fn box_distance(p: Vec3, half: Vec3) -> f32 {
    let q = p.abs() - half;
    q.max(Vec3::ZERO).length() + q.max_element().min(0.0)
}

/// Quilez's quadratic polynomial smooth minimum: `min(a, b) - h²·k/4` with
/// `h = max(k - |a - b|, 0) / k`.
#[inline]
#[must_use]
pub fn smooth_min(a: f32, b: f32, k: f32) -> f32 {
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k * 0.25
}
