//! The surface interaction: what every integrator and material reads of a hit.

use crate::math::ray::{spawn_ray, spawn_ray_to, Ray, ShadowRays, SurfaceLanes, LANES};
use glam::Vec3;

/// Index of a material in its [`crate::Scene`].
pub type MaterialId = u32;

/// A surface interaction: built once, for the closest hit only.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Ray parameter.
    pub t: f32,
    /// Hit point, computed on the surface (from the barycentrics on a triangle, reprojected
    /// on spheres and planes), not as `o + t·d`, whose error grows with `t`.
    pub point: Vec3,
    /// A conservative bound on the error of `point` on each axis: the true surface point
    /// lies within `point ± point_error`. Rays leaving the surface start outside that box
    /// ([`Hit::spawn_ray`], [`Hit::spawn_ray_to`]; pbrt-v4 §6.8).
    pub point_error: Vec3,
    /// Shading normal, facing the incoming ray.
    pub normal: Vec3,
    /// Geometric normal, facing the incoming ray.
    pub geometric_normal: Vec3,
    /// True when the ray arrived on the side the surface's own normal points to (the
    /// outside of a sphere or of a consistently wound closed mesh): a ray entering a
    /// transparent object, rather than leaving it.
    pub front_face: bool,
    /// Index of the object.
    pub object: u32,
    /// Triangle index within a mesh (0 for other geometries).
    pub prim: u32,
    /// Barycentrics on a triangle (0 otherwise).
    pub u: f32,
    /// Barycentrics on a triangle (0 otherwise).
    pub v: f32,
    /// Texture coordinates at the hit: interpolated from a mesh's per-vertex UVs, zero
    /// where there are none.
    pub uv: glam::Vec2,
    /// The material at the hit.
    pub material: MaterialId,
}

impl Hit {
    /// A hit of zeros everywhere (no surface): what lane loops read where a lane has no
    /// hit, instead of branching.
    pub const ZERO: Hit = Hit {
        t: 0.0,
        point: Vec3::ZERO,
        point_error: Vec3::ZERO,
        normal: Vec3::ZERO,
        geometric_normal: Vec3::ZERO,
        front_face: false,
        object: 0,
        prim: 0,
        u: 0.0,
        v: 0.0,
        uv: glam::Vec2::ZERO,
        material: 0,
    };

    /// The ray leaving the hit in direction `w`, its origin offset off the surface by the
    /// point's error bound (pbrt-v4 `SpawnRay`), `t` from 0: it cannot hit this surface at
    /// the hit point again.
    #[must_use]
    pub fn spawn_ray(&self, w: Vec3) -> Ray {
        spawn_ray(self.point, self.point_error, self.geometric_normal, w)
    }

    /// The shadow ray from the hit to `target` (pbrt-v4 `SpawnRayTo`): unit direction, and
    /// the `t_max` that stops it just short of the target. `None` when the target is not
    /// finite or is the origin itself.
    #[must_use]
    pub fn spawn_ray_to(&self, target: Vec3) -> Option<(Ray, f32)> {
        spawn_ray_to(self.point, self.point_error, self.geometric_normal, target)
    }

    /// Shadow rays from the hit to many targets ([`ShadowRays`]): those of
    /// [`Hit::spawn_ray_to`], with the offset origin computed once per side.
    #[must_use]
    pub fn shadow_rays(&self) -> ShadowRays {
        ShadowRays::new(self.point, self.point_error, self.geometric_normal)
    }
}

/// What the lanes' SIMD phases read of up to [`LANES`] hits, as rows (`[axis][lane]`):
/// points, error bounds, geometric and shading normals. A lane without a hit holds
/// zeros, what it reads of [`Hit::ZERO`].
/// PERF: the path tracer's light samples, BSDF samples and next rays read these rows;
/// gathered from the [`Hit`]s by each of them, the gathers were a part of every phase.
#[derive(Clone, Copy, Debug, Default)]
pub struct HitRows {
    /// Points, their error bounds and geometric normals: where rays leave from.
    pub surface: SurfaceLanes,
    /// Shading normals.
    pub normal: [[f32; LANES]; 3],
    /// The lanes with a hit.
    pub mask: u32,
}

impl HitRows {
    /// The rows of `hits`.
    #[must_use]
    #[inline(always)]
    pub fn of(hits: &[Option<Hit>; LANES]) -> HitRows {
        let mut rows = HitRows::default();
        for (k, hit) in hits.iter().enumerate() {
            // A lane without a hit reads one of zeros. PERF: a pointer chosen instead of a
            // branch on each lane's hit, which mispredicted where paths had ended.
            let h = hit.as_ref().unwrap_or(&Hit::ZERO);
            rows.mask |= u32::from(hit.is_some()) << k;
            for axis in 0..3 {
                rows.surface.p[axis][k] = h.point[axis];
                rows.surface.p_error[axis][k] = h.point_error[axis];
                rows.surface.ng[axis][k] = h.geometric_normal[axis];
                rows.normal[axis][k] = h.normal[axis];
            }
        }
        rows
    }
}
