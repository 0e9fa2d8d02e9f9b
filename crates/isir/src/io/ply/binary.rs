//! The body of a binary PLY file read straight from its bytes.
//!
//! `ply-rs-bw` reads any PLY, one property at a time through a trait call, and gives
//! every face its own `Vec`: a 10-million-triangle binary file took 1.3 s to load, most
//! of it in `malloc` and `free`. Binary records are fixed layouts, so here each element's
//! layout is planned once from the header and its records are read with plain loads, the
//! vertices on every thread. The values are those of the record reader (`mod.rs`): the
//! same conversions to `f32` and `i64`, the same fans, the same order.
//!
//! Anything else gets `None` and the record reader reads the file, naming its problem:
//! ASCII files, list properties other than a face's integer `vertex_indices` (or
//! `vertex_index`) and the lists of elements isir skips, a negative list length, a
//! body shorter than the header says, a vertex without `x y z`, a face index out of range.

use super::{Body, Vertex};
use ply_rs_bw::ply::{ElementDef, Encoding, Header, PropertyType, ScalarType};
use rayon::prelude::*;

/// A scalar type (`ply-rs-bw`'s, which is not `Copy`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    Char,
    UChar,
    Short,
    UShort,
    Int,
    UInt,
    Float,
    Double,
}

impl From<&ScalarType> for Scalar {
    fn from(t: &ScalarType) -> Self {
        match t {
            ScalarType::Char => Scalar::Char,
            ScalarType::UChar => Scalar::UChar,
            ScalarType::Short => Scalar::Short,
            ScalarType::UShort => Scalar::UShort,
            ScalarType::Int => Scalar::Int,
            ScalarType::UInt => Scalar::UInt,
            ScalarType::Float => Scalar::Float,
            ScalarType::Double => Scalar::Double,
        }
    }
}

/// A property's type: a scalar, or a list's count and item types.
fn kind(t: &PropertyType) -> (Scalar, Option<Scalar>) {
    match t {
        PropertyType::Scalar(t) => (t.into(), None),
        PropertyType::List(count, item) => (count.into(), Some(item.into())),
    }
}

/// Bytes of a scalar.
fn size(t: Scalar) -> usize {
    match t {
        Scalar::Char | Scalar::UChar => 1,
        Scalar::Short | Scalar::UShort => 2,
        Scalar::Int | Scalar::UInt | Scalar::Float => 4,
        Scalar::Double => 8,
    }
}

/// A scalar of type `t` at the start of `b` (at least `size(t)` bytes), as `ply-rs-bw`
/// gives it to a vertex: floats as they are, doubles rounded, integers converted.
fn as_f32(t: Scalar, b: &[u8], big: bool) -> f32 {
    macro_rules! read {
        ($ty:ty) => {{
            let a = b[..std::mem::size_of::<$ty>()].try_into().expect("the scalar's bytes");
            if big {
                <$ty>::from_be_bytes(a)
            } else {
                <$ty>::from_le_bytes(a)
            }
        }};
    }
    match t {
        Scalar::Char => f32::from(read!(i8)),
        Scalar::UChar => f32::from(read!(u8)),
        Scalar::Short => f32::from(read!(i16)),
        Scalar::UShort => f32::from(read!(u16)),
        Scalar::Int => read!(i32) as f32,
        Scalar::UInt => read!(u32) as f32,
        Scalar::Float => read!(f32),
        Scalar::Double => read!(f64) as f32,
    }
}

/// An integer scalar of type `t` at the start of `b`, as `i64`; `None` for floats.
fn as_i64(t: Scalar, b: &[u8], big: bool) -> Option<i64> {
    macro_rules! read {
        ($ty:ty) => {{
            let a = b[..std::mem::size_of::<$ty>()].try_into().expect("the scalar's bytes");
            i64::from(if big { <$ty>::from_be_bytes(a) } else { <$ty>::from_le_bytes(a) })
        }};
    }
    Some(match t {
        Scalar::Char => read!(i8),
        Scalar::UChar => read!(u8),
        Scalar::Short => read!(i16),
        Scalar::UShort => read!(u16),
        Scalar::Int => read!(i32),
        Scalar::UInt => read!(u32),
        Scalar::Float | Scalar::Double => return None,
    })
}

/// The body of a binary file, or `None` (see the module's documentation).
pub(super) fn read(header: &Header, body: &[u8]) -> Option<Body> {
    let big = match header.encoding {
        Encoding::BinaryLittleEndian => false,
        Encoding::BinaryBigEndian => true,
        Encoding::Ascii => return None,
    };
    // Face indices are checked against the declared vertex count: a body that holds
    // fewer vertices fails when they are read.
    let vertex_count = header.elements.get("vertex")?.count;
    let mut at = 0usize;
    let mut out = Body::default();
    for def in header.elements.values() {
        match def.name.as_str() {
            "vertex" => read_vertices(def, body.get(at..)?, big, &mut out, &mut at)?,
            "face" => read_faces(def, body.get(at..)?, big, vertex_count, &mut out, &mut at)?,
            _ => at += skip(def, body.get(at..)?, big)?,
        }
    }
    Some(out)
}

/// The `vertex` element's records into `out` (positions, normals, texture coordinates as
/// the record reader keeps them), and `at` past it.
fn read_vertices(def: &ElementDef, bytes: &[u8], big: bool, out: &mut Body, at: &mut usize) -> Option<()> {
    // Each property: its offset, type and slot (see `Vertex::slot`).
    let mut plan = Vec::new();
    let mut record = 0usize;
    let mut present = 0u8;
    for p in def.properties.values() {
        let (t, None) = kind(&p.data_type) else { return None };
        if let Some(slot) = Vertex::slot(&p.name) {
            plan.push((record, t, slot));
            present |= 1 << slot;
        }
        record += size(t);
    }
    let n = def.count;
    let bytes = bytes.get(..n.checked_mul(record)?)?;
    if n > 0 && present & 0b111 != 0b111 {
        return None;
    }
    let read = |r: &[u8]| {
        let mut v = Vertex::default();
        for &(offset, t, slot) in &plan {
            v.put(slot, as_f32(t, &r[offset..], big));
        }
        v
    };
    let records: Vec<Vertex> =
        if record == 0 { vec![Vertex::default(); n] } else { bytes.par_chunks_exact(record).with_min_len(1 << 14).map(read).collect() };
    out.set_vertices(&records);
    *at += bytes.len();
    Some(())
}

/// The `face` element's fans into `out` (each index below `vertex_count`, faces of
/// fewer than three vertices counted), and `at` past the element.
fn read_faces(def: &ElementDef, bytes: &[u8], big: bool, vertex_count: usize, out: &mut Body, at: &mut usize) -> Option<()> {
    // Each property: a scalar to step over, or a list (the index list, or one to skip).
    enum Step {
        Skip(usize),
        List { count: Scalar, item: Scalar, indices: bool },
    }
    let mut steps = Vec::new();
    let mut index_lists = 0;
    for p in def.properties.values() {
        steps.push(match kind(&p.data_type) {
            (t, None) => Step::Skip(size(t)),
            (count, Some(item)) => {
                let indices = p.name == "vertex_indices" || p.name == "vertex_index";
                if indices && matches!(item, Scalar::Float | Scalar::Double) {
                    return None;
                }
                index_lists += usize::from(indices);
                Step::List { count, item, indices }
            }
        });
    }
    if index_lists > 1 {
        return None;
    }
    // Records without properties take no bytes: faces without indices, all short.
    if steps.is_empty() {
        out.add_short(0, def.count);
        return Some(());
    }
    // Every record now takes at least a byte, so the loop below ends with the body.
    // Nothing allocated for faces the file does not hold: at least 13 bytes a triangle.
    out.triangles.reserve(def.count.min(bytes.len() / 13));
    let mut face = Vec::new();
    let mut p = 0usize;
    for f in 0..def.count {
        face.clear();
        for step in &steps {
            match *step {
                Step::Skip(s) => p += s,
                Step::List { count, item, indices } => {
                    let n = usize::try_from(as_i64(count, bytes.get(p..p + size(count))?, big)?).ok()?;
                    p += size(count);
                    let items = bytes.get(p..p.checked_add(n.checked_mul(size(item))?)?)?;
                    p += items.len();
                    if indices {
                        for b in items.chunks_exact(size(item)) {
                            let i = as_i64(item, b, big)?;
                            // Out of range: the record reader names the face.
                            face.push(u32::try_from(i).ok().filter(|&i| (i as usize) < vertex_count)?);
                        }
                    }
                }
            }
        }
        if p > bytes.len() {
            return None;
        }
        out.add_face(f, &face);
    }
    *at += p;
    Some(())
}

/// The bytes of an element isir does not read; `None` past the end of the body.
fn skip(def: &ElementDef, bytes: &[u8], big: bool) -> Option<usize> {
    let mut p = 0usize;
    let fixed: Option<usize> =
        def.properties.values().map(|prop| if let (t, None) = kind(&prop.data_type) { Some(size(t)) } else { None }).sum();
    if let Some(record) = fixed {
        p = def.count.checked_mul(record)?;
    } else {
        for _ in 0..def.count {
            for prop in def.properties.values() {
                match kind(&prop.data_type) {
                    (t, None) => p += size(t),
                    (count, Some(item)) => {
                        let n = usize::try_from(as_i64(count, bytes.get(p..p + size(count))?, big)?).ok()?;
                        p += size(count) + n.checked_mul(size(item))?;
                    }
                }
            }
            if p > bytes.len() {
                return None;
            }
        }
    }
    (p <= bytes.len()).then_some(p)
}
