//! Files in and out: bounded reading of inputs ([`input`]), meshes of any format
//! ([`mesh`]: Wavefront OBJ/MTL [`obj`], PLY [`ply`], glTF [`gltf`]), images ([`image`], PNG and OpenEXR), ray and hit files ([`rays`]), all
//! written whole or not at all ([`output`]).

pub mod gltf;
pub mod image;
pub mod input;
pub mod mesh;
pub mod obj;
pub mod output;
pub mod ply;
pub mod rays;
