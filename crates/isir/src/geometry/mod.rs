//! The course's geometries: [`Sphere`], infinite [`Plane`], [`TriangleMesh`], and the
//! surface interaction [`Hit`] that everything above the seam reads (its point computed
//! on the surface with an error bound, pbrt-v4 §6.8).

mod hit;
mod plane;
mod sphere;
mod triangle_mesh;

pub use crate::accel::MeshHit;
pub use hit::{Hit, MaterialId};
pub use plane::Plane;
pub use sphere::Sphere;
pub use triangle_mesh::{MeshAccel, MeshStats, Shading, TriangleMesh, OVERLAP_WARNING};

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
