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
mod textures;

/// `buf` cut into consecutive pieces of the lengths `lens` (their sum at most `buf`'s
/// length), for threads to fill side by side: the inflated members of a BGZF file
/// ([`input::gunzip`]), the parallel OBJ reader's chunks joined.
pub(crate) fn pieces_mut<T>(buf: &mut [T], lens: impl IntoIterator<Item = usize>) -> Vec<&mut [T]> {
    let mut rest = buf;
    lens.into_iter()
        .map(|len| {
            let (piece, after) = std::mem::take(&mut rest).split_at_mut(len);
            rest = after;
            piece
        })
        .collect()
}
