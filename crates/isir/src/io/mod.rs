//! Files in and out: bounded reading of inputs ([`input`]), Wavefront OBJ/MTL meshes
//! ([`obj`]), images ([`image`], PNG and OpenEXR), ray and hit files ([`rays`]), all
//! written whole or not at all ([`output`]).

pub mod image;
pub mod input;
pub mod obj;
pub mod output;
pub mod rays;
