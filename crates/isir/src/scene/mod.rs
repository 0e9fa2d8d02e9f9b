//! The scene: objects, materials and lights, and the seam between the textbook code and
//! the fast code: [`Scene::intersect`] (closest hit) and [`Scene::occluded`] (any hit).
//!
//! Above the seam ([`crate::integrators`], [`crate::materials`], [`crate::lights`]) the
//! code reads like the course; below it ([`crate::accel`]) it is laid out for speed. A
//! scene is built from a [`crate::SceneDescription`] ([`crate::scenes`]).

use crate::accel::wide::TraversalStats;
use crate::geometry::{Geometry, Hit, TriangleMesh};
use crate::lights::Light;
use crate::materials::{Material, MaterialId};
use crate::math::color::Color;
use crate::math::ray::Ray;
use glam::Vec3;

/// An object: a geometry and the materials of its parts (one, or one per mesh material).
#[derive(Clone, Debug)]
pub struct Object {
    /// Name, as the course names objects.
    pub name: String,
    /// Shape.
    pub geometry: Geometry,
    /// Materials by slot (meshes have one slot per file material).
    pub materials: Vec<MaterialId>,
}

/// A built scene, ready to trace.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Objects.
    pub objects: Vec<Object>,
    /// Materials, indexed by [`MaterialId`].
    pub materials: Vec<Material>,
    /// Lights.
    pub lights: Vec<Light>,
    /// Colour of rays that hit nothing.
    pub background: Color,
    /// What loading found odd but could handle (degenerate triangles, missing files of
    /// materials...), one line each.
    pub warnings: Vec<String>,
}

impl Scene {
    /// The closest hit in `[t_min, t_max)`. Invalid rays (NaN, zero direction) hit nothing.
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        if !ray.is_valid() {
            return None;
        }
        // Phase 1: the closest (object, t, prim, u, v), nothing else.
        let mut best: Option<(usize, f32, u32, f32, f32)> = None;
        let mut t_best = t_max;
        for (i, o) in self.objects.iter().enumerate() {
            let found = match &o.geometry {
                Geometry::Sphere(s) => s.intersect(ray, t_min, t_best).map(|t| (t, 0, 0.0, 0.0)),
                Geometry::Plane(p) => p.intersect(ray, t_min, t_best).map(|t| (t, 0, 0.0, 0.0)),
                Geometry::Mesh(m) => m.intersect(ray, t_min, t_best).map(|h| (h.t, h.prim, h.u, h.v)),
                Geometry::Implicit(s) => s.intersect(ray, t_min, t_best).map(|t| (t, 0, 0.0, 0.0)),
            };
            if let Some((t, prim, u, v)) = found {
                t_best = t;
                best = Some((i, t, prim, u, v));
            }
        }
        // Phase 2: the surface interaction of that one hit.
        let (i, t, prim, u, v) = best?;
        let o = &self.objects[i];
        let ((point, point_error), normal, geometric, slot) = match &o.geometry {
            Geometry::Sphere(s) => {
                let (p, e) = s.surface_point(ray, t);
                ((p, e), s.normal(p), s.normal(p), 0)
            }
            Geometry::Plane(p) => (p.surface_point(ray, t), p.normal, p.normal, 0),
            Geometry::Mesh(m) => {
                (m.surface_point(prim, u, v), m.shading_normal(prim, u, v), m.face_normal(prim), m.material_slots[prim as usize] as usize)
            }
            Geometry::Implicit(s) => {
                let (p, e) = s.surface_point(ray, t);
                let n = s.normal(p);
                ((p, e), n, n, 0)
            }
        };
        let face = |n: Vec3| if ray.direction.dot(n) > 0.0 { -n } else { n };
        Some(Hit {
            t,
            point,
            point_error,
            normal: face(normal),
            geometric_normal: face(geometric),
            front_face: ray.direction.dot(geometric) <= 0.0,
            object: i as u32,
            prim,
            u,
            v,
            uv: match &o.geometry {
                Geometry::Mesh(m) => m.texture_uv(prim, u, v),
                _ => glam::Vec2::ZERO,
            },
            material: o.materials[slot.min(o.materials.len() - 1)],
        })
    }

    /// True when anything meets the ray in `[t_min, t_max)` (the shadow-ray query).
    #[must_use]
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        ray.is_valid()
            && self.objects.iter().any(|o| match &o.geometry {
                Geometry::Sphere(s) => s.intersect(ray, t_min, t_max).is_some(),
                Geometry::Plane(p) => p.intersect(ray, t_min, t_max).is_some(),
                Geometry::Mesh(m) => m.occluded(ray, t_min, t_max),
                Geometry::Implicit(s) => s.intersect(ray, t_min, t_max).is_some(),
            })
    }

    /// What the closest-hit query along `ray` costs: nodes visited and primitives tested
    /// (a sphere, a plane or an implicit surface is one test), summed over the objects as
    /// [`Scene::intersect`] meets them (`--aov cost`).
    #[must_use]
    pub fn cost(&self, ray: &Ray, t_min: f32, t_max: f32) -> TraversalStats {
        let mut total = TraversalStats::default();
        if !ray.is_valid() {
            return total;
        }
        let mut t_best = t_max;
        for o in &self.objects {
            let t = match &o.geometry {
                Geometry::Sphere(s) => {
                    total.triangles += 1;
                    s.intersect(ray, t_min, t_best)
                }
                Geometry::Plane(p) => {
                    total.triangles += 1;
                    p.intersect(ray, t_min, t_best)
                }
                Geometry::Implicit(s) => {
                    // Counted as one test (its box and its march), like a sphere.
                    total.triangles += 1;
                    s.intersect(ray, t_min, t_best)
                }
                Geometry::Mesh(m) => {
                    let (h, c) = m.intersect_cost(ray, t_min, t_best);
                    total = total + c;
                    h.map(|h| h.t)
                }
            };
            if let Some(t) = t {
                t_best = t;
            }
        }
        total
    }

    /// The material of a hit.
    #[must_use]
    pub fn material(&self, hit: &Hit) -> &Material {
        &self.materials[hit.material as usize]
    }

    /// The meshes of the scene.
    pub fn meshes(&self) -> impl Iterator<Item = (&str, &TriangleMesh)> {
        self.objects.iter().filter_map(|o| match &o.geometry {
            Geometry::Mesh(m) => Some((o.name.as_str(), m.as_ref())),
            _ => None,
        })
    }
}
