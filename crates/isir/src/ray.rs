//! A ray: origin and direction. Parameter `t` is measured in units of the direction's length.

use glam::Vec3;

/// A half-line `origin + t·direction`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts.
    pub origin: Vec3,
    /// Where it goes; need not be normalized (cameras and integrators normalize theirs).
    pub direction: Vec3,
}

impl Ray {
    /// A ray from `origin` along `direction`.
    #[inline]
    #[must_use]
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        Self { origin, direction }
    }

    /// The point at parameter `t`.
    #[inline]
    #[must_use]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.direction
    }

    /// True when origin and direction are finite and the direction is not zero:
    /// other rays can hit nothing.
    #[inline]
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite() && self.direction.is_finite() && self.direction != Vec3::ZERO
    }
}

/// Offset a ray origin off a surface so that rays leaving it do not hit it again
/// (Wächter, Binder: "A fast and robust method for avoiding self-intersection", RT Gems 2019).
///
/// `p` is the hit point, `n` the geometric normal on the side the new ray leaves towards.
/// The offset is a few ULPs of `p` scaled by the normal, plus a small absolute offset near
/// the origin where ULPs are tiny, so it works at the bunny's scale and the conference
/// room's alike.
#[must_use]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let of_i = (n * INT_SCALE).as_ivec3();
    let step = |p: f32, o: i32| -> f32 {
        let bits = p.to_bits() as i32;
        let moved = if p < 0.0 { bits.wrapping_sub(o) } else { bits.wrapping_add(o) };
        f32::from_bits(moved as u32)
    };
    let p_i = Vec3::new(step(p.x, of_i.x), step(p.y, of_i.y), step(p.z, of_i.z));
    let pick = |p: f32, pi: f32, n: f32| if p.abs() < ORIGIN { p + FLOAT_SCALE * n } else { pi };
    Vec3::new(pick(p.x, p_i.x, n.x), pick(p.y, p_i.y, n.y), pick(p.z, p_i.z, n.z))
}

/// The shadow ray from surface point `p` (geometric normal `ng`, either side) to the point
/// `distance` away along unit direction `wi`: its origin offset off the surface on the
/// light's side, aimed at that point, its `t_max` just short of it (directions unit, so
/// `t` is a distance). `None` when the offset origin is the target itself, or the
/// distance is not finite.
#[must_use]
pub fn shadow_ray(p: Vec3, ng: Vec3, wi: Vec3, distance: f32) -> Option<(Ray, f32)> {
    let side = if ng.dot(wi) >= 0.0 { ng } else { -ng };
    let origin = offset_ray_origin(p, side);
    let to = p + wi * distance - origin;
    let dist = to.length();
    (dist > 0.0 && dist.is_finite()).then(|| (Ray::new(origin, to / dist), dist * (1.0 - 1e-4)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_moves_to_the_normal_side() {
        for p in [Vec3::ZERO, Vec3::new(1000.0, -250.0, 3.0), Vec3::new(-1e-3, 5.0, -7.0)] {
            for n in [Vec3::X, -Vec3::Y, Vec3::new(0.6, 0.0, -0.8)] {
                let q = offset_ray_origin(p, n);
                assert!((q - p).dot(n) > 0.0, "p={p} n={n} q={q}");
                assert!((q - p).length() < 1e-2 * (1.0 + p.length()));
            }
        }
    }

    #[test]
    fn shadow_rays_leave_on_the_light_side_and_stop_short() {
        let p = Vec3::new(3.0, -3.0, 1.0);
        let light = Vec3::new(0.0, 3.0, -5.0);
        let wi = (light - p).normalize();
        for ng in [Vec3::Y, -Vec3::Y] {
            let (r, t_max) = shadow_ray(p, ng, wi, (light - p).length()).unwrap();
            assert!(r.origin.y > p.y, "offset towards the light's side");
            assert!((r.direction.length() - 1.0).abs() < 1e-6);
            assert!(t_max < (light - r.origin).length() && r.at(t_max).distance(light) < 1e-2);
        }
    }

    #[test]
    fn invalid_rays_are_reported() {
        assert!(Ray::new(Vec3::ZERO, Vec3::X).is_valid());
        assert!(!Ray::new(Vec3::ZERO, Vec3::ZERO).is_valid());
        assert!(!Ray::new(Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 1.0)).is_valid());
        assert!(!Ray::new(Vec3::splat(f32::INFINITY), Vec3::X).is_valid());
    }
}
