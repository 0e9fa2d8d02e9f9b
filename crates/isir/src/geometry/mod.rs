//! The course's geometries: [`Sphere`], infinite [`Plane`], [`TriangleMesh`].

mod plane;
mod sphere;
mod triangle_mesh;

pub use plane::Plane;
pub use sphere::Sphere;
pub use triangle_mesh::{MeshAccel, MeshHit, MeshStats, Shading, TriangleMesh, OVERLAP_WARNING};

/// A closed set of kinds, dispatched with a `match` (no vtables).
#[derive(Clone, Debug)]
pub enum Geometry {
    /// A sphere.
    Sphere(Sphere),
    /// An infinite plane.
    Plane(Plane),
    /// A triangle mesh with its acceleration structure.
    Mesh(Box<TriangleMesh>),
}
