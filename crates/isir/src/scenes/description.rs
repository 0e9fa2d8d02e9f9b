//! Scene descriptions: plain data (camera, materials, objects, lights, the settings to
//! render with), then [`SceneDescription::build`] loads meshes and builds their
//! acceleration structures into a [`Scene`]. Parse, then build.

use crate::accel::triangle::TriangleTest;
use crate::accel::Accel;
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::geometry::{Geometry, Implicit, Instance, Plane, Sdf, Shading, Sphere, TriangleMesh};
use crate::integrators::Integrator;
use crate::io::image::Display;
use crate::io::mesh;
use crate::io::obj::FileMaterial;
use crate::lights::Light;
use crate::materials::{Material, MaterialId};
use crate::math::aabb::Aabb;
use crate::math::color::{Color, GREY, WHITE};
use crate::scene::{Object, Scene};
use glam::Vec3;
use std::path::PathBuf;

/// Where a camera stands and looks (the aspect ratio comes from the image).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraDesc {
    /// Position.
    pub position: Vec3,
    /// The point looked at.
    pub look_at: Vec3,
    /// Up vector.
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub fovy: f32,
}

impl CameraDesc {
    /// The course's camera: up = +y, 60° vertical field of view.
    #[must_use]
    pub fn new(position: Vec3, look_at: Vec3) -> Self {
        Self { position, look_at, up: Vec3::Y, fovy: 60.0 }
    }

    /// The camera for an image of this aspect ratio (width / height); unchecked, as
    /// [`Camera::new`] (see [`CameraDesc::validate`]).
    #[must_use]
    pub fn build(&self, aspect: f32) -> Camera {
        Camera::new(self.position, self.look_at, self.up, self.fovy, aspect)
    }

    /// A camera that sees the whole box `bounds` in a three-quarter view (from -z, the
    /// side the course's models face, and from +x and above, so that no axis-aligned flat
    /// model is seen edge-on), and a point light at the camera that lights what it sees:
    /// how a mesh file given alone is framed. Computed in double precision, so it is finite for any box within
    /// [`MAX_COORDINATE`].
    ///
    /// # Errors
    /// An empty box (nothing to look at) or one beyond [`MAX_COORDINATE`].
    pub fn framing(bounds: &Aabb) -> Result<(CameraDesc, Light)> {
        if bounds.is_empty() {
            return Err(Error::Scene("there is no triangle to look at".into()));
        }
        check_extent("the model", bounds.min.abs().max(bounds.max.abs()).max_element())?;
        let (min, max) = (bounds.min.as_dvec3(), bounds.max.as_dvec3());
        let (c, r) = ((min + max) * 0.5, (max - min).length().max(1e-6));
        let eye = c + glam::DVec3::new(0.6, 0.5, -1.0).normalize() * r * 1.1;
        let camera = CameraDesc::new(eye.as_vec3(), c.as_vec3());
        let light = Light::Point { position: eye.as_vec3(), color: WHITE, power: (1.2 * r * r) as f32 };
        Ok((camera, light))
    }

    /// Check that the camera can form rays: finite, looking somewhere, `up` not along the
    /// view, a field of view in (0°, 180°).
    ///
    /// # Errors
    /// Which of those fails.
    pub fn validate(&self) -> Result<()> {
        let bad = |why: String| Err(Error::Scene(format!("camera: {why}")));
        if !(self.position.is_finite() && self.look_at.is_finite() && self.up.is_finite()) {
            return bad(format!("position {}, look-at {} and up {} must be finite", self.position, self.look_at, self.up));
        }
        check_extent("the camera", self.position.abs().max(self.look_at.abs()).max_element())?;
        let w = self.position - self.look_at;
        if w.length_squared() == 0.0 || !w.length_squared().is_normal() {
            return bad(format!("position and look-at are the same point {}", self.position));
        }
        if self.up.cross(w.normalize()).length_squared() < 1e-12 {
            return bad(format!("up {} is along the viewing direction", self.up));
        }
        if !(self.fovy > 0.0 && self.fovy < 180.0) {
            return bad(format!("fovy {} must be between 0 and 180 degrees", self.fovy));
        }
        Ok(())
    }
}

/// The largest coordinate magnitude a scene may hold. isir traces in single precision:
/// beyond about 1e12 the products of Möller–Trumbore (`|s|·|e1|·|e2|`) and of the sphere
/// test (`|o - c|²`) overflow, and rays would silently miss. Scenes beyond it are rejected
/// with a message instead.
pub const MAX_COORDINATE: f32 = 1e12;

fn check_extent(what: &str, magnitude: f32) -> Result<()> {
    if magnitude <= MAX_COORDINATE {
        return Ok(());
    }
    Err(Error::Scene(format!(
        "{what} reaches coordinates of {magnitude:.1e}, beyond the ±{MAX_COORDINATE:.0e} isir traces in single precision \
         (ray–triangle products would overflow); scale it down"
    )))
}

/// A mesh's loading error, said of the object that names it: the file alone does not say
/// which object of the scene, nor that its path is the scene file's (relative to it).
fn in_object(what: &str, e: Error) -> Error {
    Error::Scene(format!("{what}: {e}"))
}

/// Where a mesh comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshSource {
    /// A mesh file: OBJ or PLY, optionally gzip-compressed (see [`crate::io::mesh`]).
    File(PathBuf),
    /// A model shipped inside the library (see [`crate::scenes::load_builtin_model`]).
    Builtin(&'static str),
}

/// The shape of an object.
#[derive(Clone, Debug, PartialEq)]
pub enum ShapeDesc {
    /// A sphere.
    Sphere(Sphere),
    /// An infinite plane.
    Plane(Plane),
    /// A triangle mesh from a file.
    Mesh {
        /// The file.
        source: MeshSource,
        /// Smooth or flat normals.
        shading: Shading,
    },
    /// An implicit surface (TP7), sphere traced: a tree of signed distance functions.
    Implicit(Sdf),
    /// A triangle mesh from a file, placed by a transform. Every object naming the same
    /// file (and shading) shares one copy of the mesh and its BVH: an instance.
    MeshInstance {
        /// The file.
        source: MeshSource,
        /// Smooth or flat normals.
        shading: Shading,
        /// Where the mesh stands.
        transform: Transform,
    },
}

impl ShapeDesc {
    /// What a sphere or a plane must be to be traced: a finite centre and a positive
    /// radius; a finite point and a normal that normalises. (Meshes and implicit surfaces
    /// are checked as they are built.)
    ///
    /// # Errors
    /// Which of those fails, in words.
    pub fn check(&self) -> std::result::Result<(), String> {
        match self {
            ShapeDesc::Sphere(s) if !s.is_traceable() => {
                Err(format!("a sphere needs a finite centre and a positive radius, not centre {} and radius {}", s.center, s.radius))
            }
            ShapeDesc::Plane(p) if !(p.point.is_finite() && p.normal.is_finite() && p.normal.length_squared().is_normal()) => Err(format!(
                "a plane needs a finite point and a finite normal long enough to normalise, not point {} and normal {}",
                p.point, p.normal
            )),
            _ => Ok(()),
        }
    }
}

/// Scale, then rotate (degrees about x, then y, then z, each about the world axis), then
/// translate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Translation.
    pub translate: Vec3,
    /// Rotation angles in degrees about x, y and z, applied in that order.
    pub rotate: Vec3,
    /// Uniform scale.
    pub scale: f32,
}

impl Default for Transform {
    fn default() -> Self {
        Transform { translate: Vec3::ZERO, rotate: Vec3::ZERO, scale: 1.0 }
    }
}

impl Transform {
    /// The affine map.
    #[must_use]
    pub fn to_affine(&self) -> glam::Affine3A {
        let r = self.rotate * (std::f32::consts::PI / 180.0);
        let q = glam::Quat::from_rotation_z(r.z) * glam::Quat::from_rotation_y(r.y) * glam::Quat::from_rotation_x(r.x);
        glam::Affine3A::from_scale_rotation_translation(Vec3::splat(self.scale), q, self.translate)
    }
}

/// An object of a description.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectDesc {
    /// Name.
    pub name: String,
    /// Shape.
    pub shape: ShapeDesc,
    /// Name of a material of the description; `None` keeps a mesh's own materials
    /// (one ColorMaterial per file material, from `Kd`) or gives the default white.
    pub material: Option<String>,
}

/// A scene as plain data, with the settings it is meant to be rendered with.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneDescription {
    /// Name (the built-in scenes are looked up by it).
    pub name: String,
    /// One line about it.
    pub summary: String,
    /// Camera.
    pub camera: CameraDesc,
    /// Named materials.
    pub materials: Vec<(String, Material)>,
    /// Objects.
    pub objects: Vec<ObjectDesc>,
    /// Lights.
    pub lights: Vec<Light>,
    /// Integrator (its light sample count is the default `--light-samples`).
    pub integrator: Integrator,
    /// Samples per pixel by default.
    pub spp: u32,
    /// How to write 8-bit images.
    pub display: Display,
    /// Colour of rays that hit nothing.
    pub background: Color,
}

impl SceneDescription {
    /// An empty description with the course's defaults: grey background, linear-clamp
    /// display, direct lighting.
    #[must_use]
    pub fn new(name: &str, camera: CameraDesc) -> Self {
        Self {
            name: name.to_string(),
            summary: String::new(),
            camera,
            materials: Vec::new(),
            objects: Vec::new(),
            lights: Vec::new(),
            integrator: Integrator::DirectLighting { light_samples: 1 },
            spp: 1,
            display: Display::LinearClamp,
            background: GREY,
        }
    }

    /// Load meshes and build the scene with acceleration `accel`.
    ///
    /// # Errors
    /// A mesh file that cannot be read or parsed, or a material name that is not defined.
    pub fn build(&self, accel: Accel) -> Result<Scene> {
        self.build_with(accel, TriangleTest::MollerTrumbore)
    }

    /// [`Self::build`] with a choice of ray–triangle test for the meshes.
    ///
    /// # Errors
    /// As [`Self::build`].
    pub fn build_with(&self, accel: Accel, triangle_test: TriangleTest) -> Result<Scene> {
        self.camera.validate()?;
        for (i, light) in self.lights.iter().enumerate() {
            light.check().map_err(|why| Error::Scene(format!("light {}: {why}", i + 1)))?;
            let points = match *light {
                Light::Point { position, .. } => vec![position],
                Light::Quad { corner, u, v, .. } => vec![corner, corner + u, corner + v, corner + u + v],
            };
            check_extent(&format!("light {}", i + 1), points.iter().map(|p| p.abs().max_element()).fold(0.0, f32::max))?;
        }
        let mut materials: Vec<Material> = vec![Material::Color(WHITE)]; // the default
        let mut by_name = std::collections::HashMap::new();
        for (name, m) in &self.materials {
            m.check().map_err(|why| Error::Scene(format!("material '{name}': {why}")))?;
            by_name.insert(name.as_str(), materials.len() as MaterialId);
            materials.push(m.clone());
        }
        let lookup = |name: &Option<String>| -> Result<Option<MaterialId>> {
            match name {
                None => Ok(None),
                Some(n) => {
                    by_name.get(n.as_str()).copied().map(Some).ok_or_else(|| Error::Scene(format!("object material '{n}' is not defined")))
                }
            }
        };
        let mut objects = Vec::new();
        let mut warnings = Vec::new();
        // The files the meshes were read from, and what those read (`Scene::inputs`).
        let mut inputs: Vec<std::path::PathBuf> = Vec::new();
        // Meshes placed by several instances: loaded and built once (the mesh, the file's
        // materials, their ids once pushed).
        type Shared = (std::sync::Arc<TriangleMesh>, Vec<FileMaterial>, Option<Vec<MaterialId>>);
        let mut shared: std::collections::HashMap<String, Shared> = std::collections::HashMap::new();
        for desc in &self.objects {
            let chosen = lookup(&desc.material)?;
            let what = format!("object '{}'", desc.name);
            desc.shape.check().map_err(|why| Error::Scene(format!("{what}: {why}")))?;
            let (geometry, mats) = match &desc.shape {
                ShapeDesc::Sphere(s) => {
                    check_extent(&what, s.center.abs().max_element() + s.radius)?;
                    (Geometry::Sphere(*s), vec![chosen.unwrap_or(0)])
                }
                ShapeDesc::Plane(p) => {
                    check_extent(&what, p.point.abs().max_element())?;
                    (Geometry::Plane(*p), vec![chosen.unwrap_or(0)])
                }
                ShapeDesc::Implicit(sdf) => {
                    let implicit = Implicit::new(sdf.clone()).map_err(|why| Error::Scene(format!("{what}: implicit surface: {why}")))?;
                    let b = implicit.bounds();
                    if b.is_empty() {
                        warnings.push(format!("{}: the implicit surface is empty (an intersection of shapes that do not meet)", desc.name));
                    } else {
                        check_extent(&what, b.min.abs().max(b.max.abs()).max_element())?;
                    }
                    (Geometry::Implicit(Box::new(implicit)), vec![chosen.unwrap_or(0)])
                }
                ShapeDesc::MeshInstance { source, shading, transform } => {
                    let key = format!("{source:?} {shading:?}");
                    if !shared.contains_key(&key) {
                        let (mesh, file_mats, notes) = self
                            .prepare_mesh(&desc.name, source, *shading, accel, triangle_test, &mut inputs)
                            .map_err(|e| in_object(&what, e))?;
                        warnings.extend(notes);
                        shared.insert(key.clone(), (std::sync::Arc::new(mesh), file_mats, None));
                    }
                    let entry = shared.get_mut(&key).expect("inserted above");
                    let mats = match chosen {
                        Some(id) => vec![id; entry.1.len() + 1],
                        None => entry.2.get_or_insert_with(|| file_material_ids(&mut materials, &entry.1)).clone(),
                    };
                    let instance = Instance::new(entry.0.clone(), transform.to_affine())
                        .ok_or_else(|| Error::Scene(format!("{what}: the transform must be finite with a non-zero scale")))?;
                    let b = instance.bounds();
                    if !b.is_empty() {
                        check_extent(&what, b.min.abs().max(b.max.abs()).max_element())?;
                    }
                    (Geometry::Instance(Box::new(instance)), mats)
                }
                ShapeDesc::Mesh { source, shading } => {
                    let loaded = match source {
                        MeshSource::File(path) => match mesh::load_mesh_file(path).map_err(|e| in_object(&what, e))? {
                            mesh::MeshFile::One(m) => {
                                inputs.push(path.clone());
                                inputs.extend(m.files.iter().cloned());
                                *m
                            }
                            mesh::MeshFile::Instances(meshes, placements) => {
                                inputs.push(path.clone());
                                inputs.extend(meshes.iter().flat_map(|m| m.files.iter().cloned()));
                                // glTF nodes sharing a mesh: each mesh built once, each node an instance.
                                let mut built = Vec::new();
                                let mut ids: Option<Vec<MaterialId>> = None;
                                for loaded in meshes {
                                    warnings.extend(loaded.warnings.iter().map(|w| format!("{}: {w}", desc.name)));
                                    let mats = match chosen {
                                        Some(id) => vec![id; loaded.materials.len() + 1],
                                        None => ids.get_or_insert_with(|| file_material_ids(&mut materials, &loaded.materials)).clone(),
                                    };
                                    let mut m = loaded.mesh;
                                    finish_mesh(&mut m, *shading, triangle_test, accel);
                                    built.push((std::sync::Arc::new(m), mats));
                                }
                                for (n, (k, affine)) in placements.into_iter().enumerate() {
                                    let (mesh, mats) = &built[k];
                                    let instance = Instance::new(mesh.clone(), affine).ok_or_else(|| {
                                        let why = "cannot be inverted (a zero scale, or not finite)";
                                        Error::Scene(format!(
                                            "{what}: the transform of the glTF node placing mesh {k} (placement {}) {why}",
                                            n + 1
                                        ))
                                    })?;
                                    let b = instance.bounds();
                                    if !b.is_empty() {
                                        check_extent(&what, b.min.abs().max(b.max.abs()).max_element())?;
                                    }
                                    objects.push(Object {
                                        name: format!("{}#{n}", desc.name),
                                        geometry: Geometry::Instance(Box::new(instance)),
                                        materials: mats.clone(),
                                    });
                                }
                                continue;
                            }
                        },
                        MeshSource::Builtin(name) => crate::scenes::load_builtin_model(name)?,
                    };
                    warnings.extend(loaded.warnings.iter().map(|w| format!("{}: {w}", desc.name)));
                    let mut mesh = loaded.mesh;
                    let b = mesh.aabb();
                    if !b.is_empty() {
                        check_extent(&what, b.min.abs().max(b.max.abs()).max_element())?;
                    }
                    let overlap = finish_mesh(&mut mesh, *shading, triangle_test, accel);
                    // Known facts about the shipped models are not warnings.
                    if matches!(source, MeshSource::File(_)) {
                        let stats = mesh.stats();
                        if stats.duplicates > 0 {
                            warnings.push(format!(
                                "{}: {} duplicate triangles (the same three vertices as an earlier one) are hit as that one",
                                desc.name, stats.duplicates
                            ));
                        }
                        if let Some((tests, at)) = overlap {
                            warnings.push(format!(
                                "{}: many triangles overlap near {at:.4} (coincident, nested or rotated copies): \
                                 a ray there tests {tests} triangles, rendering will be slow",
                                desc.name
                            ));
                        }
                    }
                    let mats = match chosen {
                        Some(id) => vec![id; loaded.materials.len() + 1],
                        None => file_material_ids(&mut materials, &loaded.materials),
                    };
                    (Geometry::Mesh(Box::new(mesh)), mats)
                }
            };
            objects.push(Object { name: desc.name.clone(), geometry, materials: mats });
        }
        let mut scene = Scene::new(objects, materials, self.lights.clone(), self.background);
        // The description's warnings first, then the scene's own (none when built from a
        // description, which refuses what `Scene::new` would warn about).
        warnings.append(&mut scene.warnings);
        scene.warnings = warnings;
        inputs.sort();
        inputs.dedup();
        scene.inputs = inputs;
        Ok(scene)
    }

    /// Load the mesh of an instance and build its acceleration structure: the mesh, the
    /// file's materials, and the warnings (named after `name`, the first object using it).
    fn prepare_mesh(
        &self,
        name: &str,
        source: &MeshSource,
        shading: Shading,
        accel: Accel,
        triangle_test: TriangleTest,
        inputs: &mut Vec<std::path::PathBuf>,
    ) -> Result<(TriangleMesh, Vec<FileMaterial>, Vec<String>)> {
        let loaded = match source {
            MeshSource::File(path) => {
                let loaded = mesh::load_mesh(path)?;
                inputs.push(path.clone());
                inputs.extend(loaded.files.iter().cloned());
                loaded
            }
            MeshSource::Builtin(model) => crate::scenes::load_builtin_model(model)?,
        };
        let mut notes: Vec<String> = loaded.warnings.iter().map(|w| format!("{name}: {w}")).collect();
        let mut m = loaded.mesh;
        finish_mesh(&mut m, shading, triangle_test, accel);
        notes.extend(m.stats().warning().map(|w| format!("{name}: {w}")));
        if matches!(source, MeshSource::File(_)) && m.stats().duplicates > 0 {
            notes.push(format!("{name}: {} duplicate triangles are hit as the first of each", m.stats().duplicates));
        }
        Ok((m, loaded.materials, notes))
    }
}

/// Give a loaded mesh its shading and triangle test, build its acceleration structure and
/// leave out its exact duplicate triangles; what the overlap probe still finds.
fn finish_mesh(m: &mut TriangleMesh, shading: Shading, triangle_test: TriangleTest, accel: Accel) -> Option<(u64, Vec3)> {
    m.shading = shading;
    m.triangle_test = triangle_test;
    m.build_accel(accel);
    m.remove_overlaps()
}

/// The material ids of a mesh's slots: one per file material (pushed), then the default
/// for faces without one.
fn file_material_ids(materials: &mut Vec<Material>, file: &[FileMaterial]) -> Vec<MaterialId> {
    let mut ids: Vec<MaterialId> = file.iter().map(|m| push_file_material(materials, m)).collect();
    ids.push(0); // faces without a material
    ids
}

/// The material of a file's material (a texture when it has one), pushed; its id.
fn push_file_material(materials: &mut Vec<Material>, m: &FileMaterial) -> MaterialId {
    materials.push(match &m.texture {
        Some(t) => Material::Textured { texture: t.clone(), tint: m.diffuse },
        None => Material::Color(m.diffuse),
    });
    materials.len() as MaterialId - 1
}
