//! The scene: objects, materials and lights, and the seam between the textbook code and
//! the fast code: [`Scene::intersect`] (closest hit) and [`Scene::occluded`] (any hit).
//!
//! Above the seam ([`crate::integrators`], [`crate::materials`], [`crate::lights`]) the
//! code reads like the course; below it ([`crate::accel`]) it is laid out for speed. A
//! scene is built from a [`crate::SceneDescription`] ([`crate::scenes`]).

use crate::accel::bvh::{Bvh, BvhQuality};
use crate::accel::shaft::{ShaftGrid, MAX_CELLS};
use crate::accel::wide::{TraversalStats, WideBvh};
use crate::geometry::{Geometry, Hit, MeshAccel, TriangleMesh};
use crate::lights::Light;
use crate::materials::{Material, MaterialId};
use crate::math::aabb::Aabb;
use crate::math::color::Color;
use crate::math::ray::{Ray, RayLanes, RaySegment};
use glam::Vec3;
use std::sync::OnceLock;

mod flat;
mod lanes;
mod quad_planes;
use flat::FlatObjects;
pub use lanes::{LaneHits, NO_OBJECT};
pub(crate) use quad_planes::{BoxProof, QuadPlanes};

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
    /// Objects. After changing them, call [`Scene::prepare`].
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
    /// The files the scene's meshes were read from and what those read (material
    /// libraries, textures, glTF buffers and images), for a caller that must not write
    /// over an input; empty for a scene made in code.
    pub inputs: Vec<std::path::PathBuf>,
    /// A BVH over the bounded objects' world boxes, when there are many of them (see
    /// [`Scene::build_top_level`]); `None`: the objects are tried one by one.
    pub top_level: Option<TopLevel>,
    /// Spheres and planes only: their tests side by side (built by [`Scene::new`] and
    /// [`Scene::prepare`]; ignored once the object count has changed).
    flat: Option<FlatObjects>,
    /// Per light: a quad light's shadow-ray cells in a scene of one mesh (set up by
    /// [`Scene::prepare`] with the light they are for and their share of [`MAX_CELLS`],
    /// made when first asked for), else `None`.
    shafts: Vec<Option<LightShafts>>,
    /// Per quad light, the table of [`Scene::quad_planes`] for its planes (set up
    /// by [`Scene::prepare`] in a scene with planes and without `top_level`).
    quad_planes: Vec<QuadPlanes>,
}

/// A quad light's shadow-ray cells: the light they are for, their share of [`MAX_CELLS`],
/// and the grid once made (`None` inside when the mesh's box has none).
type LightShafts = (Light, usize, OnceLock<Option<ShaftGrid>>);

/// The scene's own BVH (the SAH build of [`crate::accel::bvh`] over the objects' world
/// boxes), and the unbounded objects (planes) tried after it.
#[derive(Clone, Debug)]
pub struct TopLevel {
    bvh: Bvh,
    /// Object index of each BVH primitive.
    bounded: Vec<u32>,
    /// Objects without a finite box.
    unbounded: Vec<u32>,
}

/// Objects with a finite box from which [`SceneDescription`](crate::SceneDescription)
/// builds a top-level BVH. Below it the objects are looped over (the course's scenes have
/// a handful), which keeps their images bit for bit as they were.
pub const TOP_LEVEL_MIN_OBJECTS: usize = 16;

/// The fewest shadow rays a mesh traces together ([`Scene::occluded_packet`]; the mesh's
/// BVH then chooses how, see [`crate::accel::wide::WideBvh::occluded_packet`]).
/// PERF: AVX2 streams of four rays of one point beat four single rays (conference room,
/// 4 light samples: 0.95× the time; 8 samples 0.77×).
pub const MESH_PACKET_FROM: usize = 4;

impl Scene {
    /// A scene of these objects (`materials` indexed by their [`MaterialId`]s), lights and
    /// background, prepared for tracing ([`Scene::prepare`]).
    #[must_use]
    pub fn new(objects: Vec<Object>, materials: Vec<Material>, lights: Vec<Light>, background: Color) -> Scene {
        let mut scene = Scene {
            objects,
            materials,
            lights,
            background,
            warnings: Vec::new(),
            inputs: Vec::new(),
            top_level: None,
            flat: None,
            shafts: Vec::new(),
            quad_planes: Vec::new(),
        };
        scene.check();
        scene.prepare();
        scene
    }

    /// What [`Scene::new`] finds wrong in what it was given, made safe and said in
    /// `warnings`: an object with no material, or a material id past `materials`, gets
    /// the course's white `ColorMaterial` (they made the renderer index out of bounds);
    /// a sphere, plane, light or material that cannot be traced or shaded is named (a
    /// [`crate::SceneDescription`] refuses them before they get here).
    fn check(&mut self) {
        let mut default = None;
        for o in &mut self.objects {
            let ids = o.materials.len();
            let bad = o.materials.iter().filter(|&&m| m as usize >= self.materials.len()).count();
            if ids == 0 || bad > 0 {
                let id = *default.get_or_insert_with(|| {
                    self.materials.push(Material::Color(crate::math::color::WHITE));
                    (self.materials.len() - 1) as MaterialId
                });
                let known = self.materials.len() - 1;
                if ids == 0 {
                    o.materials.push(id);
                    self.warnings.push(format!("object '{}': no material; the course's white ColorMaterial is used", o.name));
                } else {
                    for m in &mut o.materials {
                        if *m as usize >= known {
                            *m = id;
                        }
                    }
                    self.warnings.push(format!(
                        "object '{}': {bad} material ids past the {known} materials; the course's white ColorMaterial is used",
                        o.name
                    ));
                }
            }
            let never = match &o.geometry {
                Geometry::Sphere(s) if !s.is_traceable() => Some(format!("a sphere of centre {} and radius {}", s.center, s.radius)),
                Geometry::Plane(p) if !(p.point.is_finite() && p.normal.is_finite() && (p.normal.length() - 1.0).abs() < 1e-3) => {
                    Some(format!("a plane through {} whose normal {} is not of length 1", p.point, p.normal))
                }
                _ => None,
            };
            if let Some(what) = never {
                self.warnings.push(format!("object '{}': {what} is never hit or shaded right", o.name));
            }
        }
        for (i, m) in self.materials.iter().enumerate() {
            if let Err(why) = m.check() {
                self.warnings.push(format!("material {i}: {why}"));
            }
        }
        for (i, l) in self.lights.iter().enumerate() {
            if let Err(why) = l.check() {
                self.warnings.push(format!("light {}: {why}", i + 1));
            }
        }
    }

    /// Build what speeds up the queries over the objects, as they are now: the top-level
    /// BVH from [`TOP_LEVEL_MIN_OBJECTS`] objects with a box, else, for spheres and planes
    /// only, their arrays. Call it again after changing `objects`.
    pub fn prepare(&mut self) {
        let bounded = (0..self.objects.len()).filter(|&i| self.object_bounds(i).is_some()).count();
        self.top_level = None;
        self.flat = None;
        if bounded >= TOP_LEVEL_MIN_OBJECTS {
            self.build_top_level();
        } else {
            self.flat = FlatObjects::new(&self.objects);
        }
        self.quad_planes = if self.top_level.is_none() { QuadPlanes::of(&self.lights, &self.objects) } else { Vec::new() };
        let quads = self.lights.iter().filter(|l| l.is_surface()).count();
        self.shafts = match self.pair_mesh() {
            Some(_) => {
                self.lights.iter().map(|light| light.is_surface().then(|| (light.clone(), MAX_CELLS / quads, OnceLock::new()))).collect()
            }
            None => Vec::new(),
        };
    }

    /// What proves, for the shadow rays towards points of the quad light `[corner, u,
    /// v]`, that planes cannot block them ([`QuadPlanes::for_box`], then
    /// [`QuadPlanes::clear`] per origin, for [`Scene::occluded_lanes_except`]); none for a
    /// light the scene was not prepared with, or a scene without planes.
    #[inline]
    pub(crate) fn quad_planes(&self, light: [Vec3; 3]) -> Option<&QuadPlanes> {
        self.quad_planes.iter().find(|t| t.is_for(light, self.objects.len()))
    }

    /// The shadow-ray cells of quad light `light` and the tree their lists come from: in
    /// a scene of one mesh traced by its wide BVH, while the light and the mesh's box are
    /// those the cells were made for (a scene changed without [`Scene::prepare`] traces
    /// every ray). The grid is made on the first call (PERF: its 8 MB of cells are not
    /// written for renders that never ask, nor by `isir trace` and `isir bench`).
    #[inline]
    pub(crate) fn shaft(&self, light: usize) -> Option<(&ShaftGrid, &WideBvh)> {
        let (made_for, max_cells, grid) = self.shafts.get(light)?.as_ref()?;
        let mesh = self.pair_mesh()?;
        let MeshAccel::Wide(bvh) = mesh.accel() else { return None };
        if self.lights.get(light) != Some(made_for) {
            return None;
        }
        let grid = grid
            .get_or_init(|| match *made_for {
                Light::Quad { corner, u, v, .. } => ShaftGrid::new(&mesh.aabb(), corner, u, v, *max_cells),
                Light::Point { .. } => None,
            })
            .as_ref()?;
        (grid.bounds() == &mesh.aabb()).then_some((grid, bvh))
    }

    /// The flat form of the objects, unless their count has changed since it was built.
    #[inline(always)]
    fn flat(&self) -> Option<&FlatObjects> {
        self.flat.as_ref().filter(|f| f.len() == self.objects.len())
    }

    /// The closest hit in `[t_min, t_max)`. Invalid rays (NaN, zero direction) hit nothing.
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        if !ray.is_valid() {
            return None;
        }
        // Phase 1: the closest (object, t, prim, u, v), nothing else.
        let (i, t, prim, u, v) = self.closest(ray, t_min, t_max)?;
        // Phase 2: the surface interaction of that one hit.
        Some(self.interaction(ray, i, t, prim, u, v))
    }

    /// Phase 1 of [`Scene::intersect`] for a valid ray: the closest (object, t, prim, u, v).
    #[inline]
    fn closest(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<(usize, f32, u32, f32, f32)> {
        let mut best: Option<(usize, f32, u32, f32, f32)> = None;
        match &self.top_level {
            None => {
                if let Some(flat) = self.flat() {
                    return flat.closest(ray, t_min, t_max).map(|(i, t)| (i, t, 0, 0.0, 0.0));
                }
                let mut t_best = t_max;
                for i in 0..self.objects.len() {
                    if let Some((t, prim, u, v)) = self.hit_object(i, ray, t_min, t_best) {
                        t_best = t;
                        best = Some((i, t, prim, u, v));
                    }
                }
            }
            Some(top) => {
                let mut t_best = top.bvh.intersect(ray, t_min, t_max, |k, t_now| {
                    let i = top.bounded[k as usize] as usize;
                    let (t, prim, u, v) = self.hit_object(i, ray, t_min, t_now)?;
                    best = Some((i, t, prim, u, v));
                    Some(t)
                });
                for &i in &top.unbounded {
                    if let Some((t, prim, u, v)) = self.hit_object(i as usize, ray, t_min, t_best) {
                        t_best = t;
                        best = Some((i as usize, t, prim, u, v));
                    }
                }
            }
        }
        best
    }

    /// Phase 2 of [`Scene::intersect`]: the surface interaction of object `i` hit by `ray`
    /// at `t` (`prim`, `u`, `v` on a mesh), built once, for the closest hit only.
    #[inline]
    pub(crate) fn interaction(&self, ray: &Ray, i: usize, t: f32, prim: u32, u: f32, v: f32) -> Hit {
        self.interaction_inline(ray, i, t, prim, u, v)
    }

    /// [`Scene::interaction`], inlined into the caller.
    #[inline(always)]
    pub(crate) fn interaction_inline(&self, ray: &Ray, i: usize, t: f32, prim: u32, u: f32, v: f32) -> Hit {
        self.interaction_given(ray, i, t, prim, u, v, None)
    }

    /// [`Scene::interaction_inline`], with a mesh triangle's face normal, point and error
    /// bound given when the caller has computed them (as [`crate::geometry::TriangleLanes`]
    /// does, the same floats).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn interaction_given(
        &self,
        ray: &Ray,
        i: usize,
        t: f32,
        prim: u32,
        u: f32,
        v: f32,
        given: Option<(Vec3, Vec3, Vec3)>,
    ) -> Hit {
        let o = &self.objects[i];
        let ((point, point_error), normal, geometric, slot) = match &o.geometry {
            Geometry::Sphere(s) => {
                let (p, e) = s.surface_point(ray, t);
                ((p, e), s.normal(p), s.normal(p), 0)
            }
            Geometry::Plane(p) => (p.surface_point(ray, t), p.normal, p.normal, 0),
            Geometry::Mesh(m) => {
                let (face, point) = match given {
                    Some((face, p, e)) => (face, (p, e)),
                    None => (m.face_normal(prim), m.surface_point(prim, u, v)),
                };
                (point, m.shading_normal_or(prim, u, v, || face), face, m.material_slots[prim as usize] as usize)
            }
            Geometry::Implicit(s) => {
                let (p, e) = s.surface_point(ray, t);
                let n = s.normal(p);
                ((p, e), n, n, 0)
            }
            Geometry::Instance(m) => (
                m.surface_point(prim, u, v),
                m.shading_normal(prim, u, v),
                m.face_normal(prim),
                m.mesh.material_slots[prim as usize] as usize,
            ),
        };
        let face = |n: Vec3| if ray.direction.dot(n) > 0.0 { -n } else { n };
        Hit {
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
                Geometry::Instance(m) => m.texture_uv(prim, u, v),
                _ => glam::Vec2::ZERO,
            },
            material: o.materials[slot.min(o.materials.len() - 1)],
        }
    }

    /// The mesh of a scene that is exactly one mesh (the conference room), whose lanes
    /// take the paths made for it.
    #[inline]
    pub(crate) fn only_mesh(&self) -> Option<&TriangleMesh> {
        match self.objects.as_slice() {
            [Object { geometry: Geometry::Mesh(m), .. }] => Some(m),
            _ => None,
        }
    }

    /// True when anything meets the ray in `[t_min, t_max)` (the shadow-ray query).
    #[must_use]
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        if !ray.is_valid() {
            return false;
        }
        match &self.top_level {
            None => match self.flat() {
                Some(flat) => flat.any(ray, t_min, t_max),
                None => (0..self.objects.len()).any(|i| self.blocks(i, ray, t_min, t_max)),
            },
            Some(top) => {
                top.bvh.occluded(ray, t_min, t_max, |k, t| self.blocks(top.bounded[k as usize] as usize, ray, t_min, t))
                    || top.unbounded.iter().any(|&i| self.blocks(i as usize, ray, t_min, t_max))
            }
        }
    }

    /// [`Scene::occluded`] for up to [`crate::accel::packet::PACKET`] rays (the shadow
    /// rays of one point): bit `i` set when `rays[i]` is occluded, the answers of one
    /// [`Scene::occluded`] per ray: the rays put in lanes, then [`Scene::occluded_lanes`].
    ///
    /// # Panics
    /// If there are more than [`crate::accel::packet::PACKET`] rays.
    #[must_use]
    pub fn occluded_packet(&self, rays: &[RaySegment]) -> u32 {
        assert!(rays.len() <= crate::accel::packet::PACKET);
        self.occluded_lanes(&RayLanes::new(rays), (1 << rays.len()) - 1)
    }

    /// The closest hit of object `i` in `[t_min, t_max)`: `(t, prim, u, v)`.
    /// PERF: always inlined into the loops over objects (out of line, it was 28% of the
    /// path tracer's time on the TP6 room, call and dispatch included).
    #[inline(always)]
    fn hit_object(&self, i: usize, ray: &Ray, t_min: f32, t_max: f32) -> Option<(f32, u32, f32, f32)> {
        match &self.objects[i].geometry {
            Geometry::Sphere(s) => s.intersect(ray, t_min, t_max).map(|t| (t, 0, 0.0, 0.0)),
            Geometry::Plane(p) => p.intersect(ray, t_min, t_max).map(|t| (t, 0, 0.0, 0.0)),
            Geometry::Mesh(m) => m.intersect(ray, t_min, t_max).map(|h| (h.t, h.prim, h.u, h.v)),
            Geometry::Implicit(s) => s.intersect(ray, t_min, t_max).map(|t| (t, 0, 0.0, 0.0)),
            Geometry::Instance(m) => m.intersect(ray, t_min, t_max).map(|h| (h.t, h.prim, h.u, h.v)),
        }
    }

    /// True when object `i` meets the ray in `[t_min, t_max)`.
    #[inline]
    fn blocks(&self, i: usize, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        match &self.objects[i].geometry {
            Geometry::Mesh(m) => m.occluded(ray, t_min, t_max),
            Geometry::Instance(m) => m.occluded(ray, t_min, t_max),
            _ => self.hit_object(i, ray, t_min, t_max).is_some(),
        }
    }

    /// The world box of object `i`, when it has a finite one.
    #[must_use]
    pub fn object_bounds(&self, i: usize) -> Option<Aabb> {
        let b = match &self.objects[i].geometry {
            Geometry::Sphere(s) => Aabb::new(s.center - Vec3::splat(s.radius), s.center + Vec3::splat(s.radius)),
            Geometry::Plane(_) => return None,
            Geometry::Mesh(m) => m.aabb(),
            Geometry::Implicit(s) => s.bounds(),
            Geometry::Instance(m) => m.bounds(),
        };
        b.is_finite_nonempty().then_some(b)
    }

    /// Build the top-level BVH over the objects' world boxes (SAH), the unbounded ones
    /// (planes) kept aside; queries then visit only the objects along each ray. Objects
    /// with an empty box (an empty mesh) can never be hit and are left out.
    pub fn build_top_level(&mut self) {
        let (mut boxes, mut bounded, mut unbounded) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..self.objects.len() {
            match self.object_bounds(i) {
                Some(b) => {
                    boxes.push(b);
                    bounded.push(i as u32);
                }
                None if matches!(self.objects[i].geometry, Geometry::Plane(_)) => unbounded.push(i as u32),
                None => {}
            }
        }
        let bvh = Bvh::build(&boxes, BvhQuality::Sah);
        self.top_level = Some(TopLevel { bvh, bounded, unbounded });
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
                Geometry::Instance(m) => {
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

    /// Every mesh of the scene where it stands: plain meshes and those placed by a
    /// transform (instances: a scene file's mesh with a `transform`, a glTF file's nodes),
    /// in object order.
    pub fn placed_meshes(&self) -> impl Iterator<Item = PlacedMesh<'_>> {
        self.objects.iter().filter_map(|o| match &o.geometry {
            Geometry::Mesh(m) => Some(PlacedMesh { object: o, mesh: m.as_ref(), to_world: None, bounds: m.aabb() }),
            Geometry::Instance(i) => {
                Some(PlacedMesh { object: o, mesh: i.mesh.as_ref(), to_world: Some(i.to_world()), bounds: i.bounds() })
            }
            _ => None,
        })
    }
}

/// A mesh of a scene and where it stands ([`Scene::placed_meshes`]).
#[derive(Clone, Copy, Debug)]
pub struct PlacedMesh<'a> {
    /// The object that holds it.
    pub object: &'a Object,
    /// The mesh, in its own space.
    pub mesh: &'a TriangleMesh,
    /// From its space to the world's; `None` for a mesh given in world space.
    pub to_world: Option<glam::Affine3A>,
    /// A box holding it in the world (an instance's: its mesh's box, moved).
    pub bounds: Aabb,
}
