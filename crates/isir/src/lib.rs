//! isir: a CPU ray tracer for the ISIR ray-tracing course.
//!
//! The course's nouns name the code: [`Camera`], [`Scene`], [`Sphere`], [`Plane`],
//! [`TriangleMesh`], [`Aabb`], [`Bvh`], [`Material`], [`Light`], [`Integrator`],
//! [`Renderer`]. Above the [`Scene::intersect`] / [`Scene::occluded`] seam the code reads
//! like the course; below it ([`bvh`], [`wide`]) it is laid out for speed.
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

pub mod aabb;
pub mod bvh;
pub mod camera;
pub mod color;
pub mod error;
pub mod geometry;
pub mod image;
pub mod input;
pub mod integrator;
pub mod light;
pub mod material;
pub mod obj;
pub mod output;
pub mod packet;
pub mod ray;
pub mod rays;
pub mod renderer;
pub mod sampling;
pub mod scene;
pub mod scenes;
pub mod triangle;
pub mod wide;

pub use aabb::Aabb;
pub use bvh::{Bvh, BvhNode, BvhQuality};
pub use camera::Camera;
pub use color::Color;
pub use error::{Error, Result};
pub use geometry::{Geometry, Plane, Sphere, TriangleMesh};
pub use image::{Display, Image};
pub use integrator::Integrator;
pub use light::Light;
pub use material::Material;
pub use ray::Ray;
pub use renderer::{RenderStats, Renderer};
pub use scene::{Accel, Hit, Scene, SceneDescription};

/// Parse one of a closed set of named choices (their command-line names), or say which
/// names exist: the one `FromStr` behind [`Accel`], [`rays::RayKind`] and
/// [`wide::SimdLevel`].
pub(crate) fn parse_name<T: Copy>(s: &str, all: &[T], name: fn(T) -> &'static str, what: &str) -> std::result::Result<T, String> {
    all.iter().copied().find(|&x| name(x) == s).ok_or_else(|| {
        let names: Vec<&str> = all.iter().map(|&x| name(x)).collect();
        format!("unknown {what} '{s}' (expected {})", names.join(", "))
    })
}

/// Re-exported so users of the library need not depend on `glam` themselves.
pub use glam::{Vec2, Vec3};
