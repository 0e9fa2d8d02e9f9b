//! The course's geometries: [`Sphere`], infinite [`Plane`], [`TriangleMesh`], [`Implicit`]
//! surfaces (TP7), and the
//! surface interaction [`Hit`] that everything above the seam reads (its point computed
//! on the surface with an error bound, pbrt-v4 §6.8).

mod hit;
pub mod implicit;
mod instance;
mod plane;
mod shape_lanes;
mod sphere;
mod triangle_lanes;
mod triangle_mesh;

pub use crate::accel::MeshHit;
pub use hit::{Hit, HitRows, MaterialId};
pub use implicit::{Implicit, Sdf};
pub use instance::Instance;
pub use plane::Plane;
pub(crate) use shape_lanes::ShapeLanes;
pub use sphere::Sphere;
pub(crate) use triangle_lanes::TriangleLanes;
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
    /// An implicit surface, sphere traced inside its bounding box.
    Implicit(Box<Implicit>),
    /// A shared mesh placed by a transform.
    Instance(Box<Instance>),
}
