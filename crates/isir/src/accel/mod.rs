//! Below the seam: the data-oriented code that finds hits fast. Triangle tests
//! (Möller–Trumbore, 1997; the watertight test of Woop, Benthin and Wald, 2013), the binary
//! [`bvh::Bvh`] (the course's midpoint build, and binned SAH after Wald 2007), the wide
//! [`wide::WideBvh`] traced with SIMD (after Embree's BVH8 and Fuetterling et al. 2017)
//! and 16-ray packets ([`packet`]).
//!
//! Nothing here knows what a scene, a material or a mesh file is: a mesh is seen through
//! [`Triangles`], hits come back as [`MeshHit`] (triangle, distance, barycentrics), and the
//! surface interaction is built above, in [`crate::geometry`].

pub mod bvh;
mod memory;
pub mod packet;
pub mod shaft;
pub mod triangle;
pub mod wide;

use glam::Vec3;
use triangle::TriangleTest;

/// How meshes are accelerated: the four steps of the TP4 lesson.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Accel {
    /// Every triangle for every ray.
    None,
    /// The mesh's bounding box first, then every triangle.
    Aabb,
    /// The course's BVH: largest-axis midpoint split, 8 triangles per leaf, depth 32.
    BvhMid,
    /// Binned SAH BVH in the wide SIMD layout (the default).
    #[default]
    BvhSah,
}

impl Accel {
    /// Every choice, in lesson order.
    pub const ALL: [Accel; 4] = [Accel::None, Accel::Aabb, Accel::BvhMid, Accel::BvhSah];

    /// The command-line name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Accel::None => "none",
            Accel::Aabb => "aabb",
            Accel::BvhMid => "bvh-mid",
            Accel::BvhSah => "bvh-sah",
        }
    }
}

impl std::str::FromStr for Accel {
    type Err = String;
    /// Parse a command-line name (`none`, `aabb`, `bvh-mid`, `bvh-sah`).
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        crate::parse_name(s, &Self::ALL, Self::name, "acceleration structure")
    }
}

/// A closest hit on a mesh: distance, triangle and Möller–Trumbore barycentrics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshHit {
    /// Ray parameter.
    pub t: f32,
    /// Triangle index.
    pub prim: u32,
    /// Weight of the triangle's second vertex.
    pub u: f32,
    /// Weight of its third vertex.
    pub v: f32,
}

/// What the acceleration structures read of a triangle mesh: the vertices of each
/// triangle and which test to run. [`crate::TriangleMesh`] implements it, so the code
/// below the seam never names the course's mesh type.
pub trait Triangles: Sync {
    /// The three vertices of triangle `prim`.
    fn vertices_of(&self, prim: u32) -> [Vec3; 3];
    /// The ray–triangle test the mesh is traced with.
    fn test(&self) -> TriangleTest;
}
