//! Instances: one [`TriangleMesh`] (loaded and its BVH built once, shared by `Arc`) placed
//! in the world by an affine transform. Rays are carried into the mesh's space (the
//! parameter `t` is the same in both, the direction not being renormalised); the hit
//! point is computed there from the barycentrics and carried back with its error bound
//! (pbrt-v4 §6.8.6, transforming a point with error), normals by the inverse transpose.

use crate::accel::wide::TraversalStats;
use crate::accel::MeshHit;
use crate::geometry::TriangleMesh;
use crate::math::aabb::Aabb;
use crate::math::ray::{gamma, Ray, RayLanes, LANES};
use glam::{Affine3A, Mat3, Vec2, Vec3};
use std::sync::Arc;

/// A shared mesh and where it stands.
#[derive(Clone, Debug)]
pub struct Instance {
    /// The mesh, in its own space.
    pub mesh: Arc<TriangleMesh>,
    to_world: Affine3A,
    to_object: Affine3A,
    normal_to_world: Mat3,
    bounds: Aabb,
}

impl Instance {
    /// `mesh` placed by `to_world`; `None` when the transform is not finite or not
    /// invertible (a zero scale).
    #[must_use]
    pub fn new(mesh: Arc<TriangleMesh>, to_world: Affine3A) -> Option<Self> {
        let det = to_world.matrix3.determinant();
        if !to_world.is_finite() || !det.is_normal() {
            return None;
        }
        let to_object = to_world.inverse();
        let normal_to_world = Mat3::from(to_world.matrix3).inverse().transpose();
        let b = mesh.aabb();
        let mut bounds = Aabb::EMPTY;
        if !b.is_empty() {
            for i in 0..8 {
                let corner = Vec3::new(
                    if i & 1 == 0 { b.min.x } else { b.max.x },
                    if i & 2 == 0 { b.min.y } else { b.max.y },
                    if i & 4 == 0 { b.min.z } else { b.max.z },
                );
                bounds = bounds.union(&Aabb::new(to_world.transform_point3(corner), to_world.transform_point3(corner)));
            }
            // The corners' own rounding: widen by a few ULPs of their magnitude.
            let pad = (bounds.min.abs().max(bounds.max.abs())) * (4.0 * f32::EPSILON);
            bounds = Aabb::new(bounds.min - pad, bounds.max + pad);
        }
        Some(Instance { mesh, to_world, to_object, normal_to_world, bounds })
    }

    /// The world box of the mesh (empty when the mesh is).
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The transform from the mesh's space to the world.
    #[must_use]
    pub fn to_world(&self) -> Affine3A {
        self.to_world
    }

    fn object_ray(&self, ray: &Ray) -> Ray {
        Ray::new(self.to_object.transform_point3(ray.origin), self.to_object.transform_vector3(ray.direction))
    }

    /// The rays of `rays` carried into the mesh's space, lane by lane as
    /// [`Instance::intersect`] carries one (the same floats), their intervals unchanged.
    #[must_use]
    pub(crate) fn object_lanes(&self, rays: &RayLanes) -> RayLanes {
        let mut local = *rays;
        for k in 0..LANES {
            let r = self.object_ray(&rays.ray(k));
            for axis in 0..3 {
                local.o[axis][k] = r.origin[axis];
                local.d[axis][k] = r.direction[axis];
            }
        }
        local
    }

    /// The closest hit in `[t_min, t_max)` (the same `t` as along the world ray).
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<MeshHit> {
        self.mesh.intersect(&self.object_ray(ray), t_min, t_max)
    }

    /// True when a triangle meets the ray in `[t_min, t_max)`.
    #[must_use]
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        self.mesh.occluded(&self.object_ray(ray), t_min, t_max)
    }

    /// [`TriangleMesh::intersect_cost`] through the transform.
    #[must_use]
    pub fn intersect_cost(&self, ray: &Ray, t_min: f32, t_max: f32) -> (Option<MeshHit>, TraversalStats) {
        self.mesh.intersect_cost(&self.object_ray(ray), t_min, t_max)
    }

    /// The world hit point at barycentrics `(u, v)` of triangle `prim`, and its error
    /// bound: the mesh's bound carried through the transform, plus the transform's own
    /// rounding (pbrt-v4: `γ3·(|m|·|p| + |t|) + (γ3 + 1)·|m|·err`).
    #[must_use]
    pub fn surface_point(&self, prim: u32, u: f32, v: f32) -> (Vec3, Vec3) {
        let (p, err) = self.mesh.surface_point(prim, u, v);
        let m = self.to_world.matrix3;
        let abs = Mat3::from_cols(m.x_axis.abs().into(), m.y_axis.abs().into(), m.z_axis.abs().into());
        let world = self.to_world.transform_point3(p);
        let rounding = gamma(3) * (abs * p.abs() + Vec3::from(self.to_world.translation.abs()));
        (world, rounding + (gamma(3) + 1.0) * (abs * err))
    }

    /// The world shading normal (unit, not yet facing the ray).
    #[must_use]
    pub fn shading_normal(&self, prim: u32, u: f32, v: f32) -> Vec3 {
        (self.normal_to_world * self.mesh.shading_normal(prim, u, v)).normalize_or_zero()
    }

    /// The world geometric normal of triangle `prim` (unit).
    #[must_use]
    pub fn face_normal(&self, prim: u32) -> Vec3 {
        (self.normal_to_world * self.mesh.face_normal(prim)).normalize_or_zero()
    }

    /// The texture coordinates at barycentrics `(u, v)` of triangle `prim`.
    #[must_use]
    pub fn texture_uv(&self, prim: u32, u: f32, v: f32) -> Vec2 {
        self.mesh.texture_uv(prim, u, v)
    }
}
