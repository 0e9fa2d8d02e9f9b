//! isir: a CPU ray tracer for the ISIR ray-tracing course.
//!
//! The course's nouns name the code: [`Camera`], [`Scene`], [`Sphere`], [`Plane`],
//! [`TriangleMesh`], [`Aabb`], [`Bvh`], [`Material`], [`Light`], [`Integrator`],
//! [`Renderer`]. Above the [`Scene::intersect`] / [`Scene::occluded`] seam the code reads
//! like the course; below it ([`accel`]: [`accel::bvh`], [`accel::wide`]) it is laid out
//! for speed. `ARCHITECTURE.md` maps the folders.
//!
//! ```no_run
//! use isir::{scenes, Accel, Renderer};
//! let desc = scenes::builtin("tp4-bunny").unwrap();
//! let scene = desc.build(Accel::BvhSah).unwrap();
//! let renderer = Renderer::new(600, 400).spp(desc.spp);
//! let camera = desc.camera.build(renderer.aspect());
//! let (image, stats) = renderer.render(&scene, &camera, &desc.integrator);
//! image.save("bunny.png", desc.display).unwrap();
//! println!("{:.1} Mrays/s", stats.mrays_per_second());
//! ```
#![warn(missing_docs)]

// The course's nouns, above the seam.
pub mod aov;
pub mod camera;
pub mod integrators;
pub mod lights;
pub mod materials;
pub mod renderer;
pub mod scene;
pub mod scenes;
// The shapes and the surface interaction.
pub mod geometry;
// Below the seam, and the mathematics under everything.
pub mod accel;
mod kept;
pub mod math;
// Files in and out.
pub mod error;
pub mod io;

pub use accel::bvh::{Bvh, BvhNode, BvhQuality};
pub use accel::Accel;
pub use camera::Camera;
pub use error::{Error, Result};
pub use geometry::{Geometry, Hit, Plane, Sphere, TriangleMesh};
pub use integrators::Integrator;
pub use io::image::{Display, Image};
pub use lights::Light;
pub use materials::Material;
pub use math::aabb::Aabb;
pub use math::color::Color;
pub use math::ray::Ray;
pub use renderer::{RenderStats, Renderer};
pub use scene::Scene;
pub use scenes::{CameraDesc, SceneDescription};

// The module paths of the flat layout before the folders (`isir::rays::RayRecord`,
// `isir::wide::SimdLevel`...), so code written against them still compiles.
pub use accel::{bvh, packet, triangle, wide};
pub use integrators as integrator;
pub use io::{image, input, obj, output, rays};
pub use lights as light;
pub use materials as material;
pub use math::{aabb, color, ray, sampling};

/// Parse one of a closed set of named choices (their command-line names), or say which
/// names exist: the one `FromStr` behind [`Accel`], [`io::rays::RayKind`] and
/// [`accel::wide::SimdLevel`].
pub(crate) fn parse_name<T: Copy>(s: &str, all: &[T], name: fn(T) -> &'static str, what: &str) -> std::result::Result<T, String> {
    all.iter().copied().find(|&x| name(x) == s).ok_or_else(|| {
        let names: Vec<&str> = all.iter().map(|&x| name(x)).collect();
        format!("unknown {what} '{s}' (expected {})", names.join(", "))
    })
}

/// Re-exported so users of the library need not depend on `glam` themselves.
pub use glam::{Vec2, Vec3};
