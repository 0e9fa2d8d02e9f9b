//! The body of an ASCII PLY file read straight from its text.
//!
//! `ply-rs-bw` matches every line against its grammar and builds a record per line
//! through trait calls, a `Vec` per face: the Stanford dragon's 871,414 triangles took
//! 270 ms. Here the lines are found once and the vertex lines parsed on every thread.
//! The tokens are those the grammar accepts (`[-+]?digits(.digits)?([eE][-+]?digits)?`
//! between spaces and tabs), each parsed with the same `FromStr` for its property's type,
//! so the values are the record reader's (`mod.rs`).
//!
//! Anything else gets `None` and the record reader reads the file, naming its problem:
//! binary files, a token the grammar or its type rejects, a line with too few tokens, a
//! body with fewer lines than the header says, bytes that are not ASCII, a lone carriage
//! return, list properties on vertices, a second index list, a face index out of range,
//! a line with more values than the header declares (which the record reader would
//! ignore: `mod.rs` looks for them as it reads, [`values_past_the_declared`]).

use super::{Body, Vertex};
use ply_rs_bw::ply::{ElementDef, Encoding, Header, PropertyType, ScalarType};
use rayon::prelude::*;
use std::ops::Range;

/// A token as the grammar's `any_number` accepts it.
fn is_number(t: &[u8]) -> bool {
    let digits = |t: &[u8], i: &mut usize| {
        let start = *i;
        while *i < t.len() && t[*i].is_ascii_digit() {
            *i += 1;
        }
        *i > start
    };
    let mut i = usize::from(matches!(t.first(), Some(b'-' | b'+')));
    if !digits(t, &mut i) {
        return false;
    }
    if t.get(i) == Some(&b'.') {
        i += 1;
        if !digits(t, &mut i) {
            return false;
        }
    }
    if matches!(t.get(i), Some(b'e' | b'E')) {
        i += 1;
        if matches!(t.get(i), Some(b'-' | b'+')) {
            i += 1;
        }
        if !digits(t, &mut i) {
            return false;
        }
    }
    i == t.len()
}

/// The tokens of one line (without its `\n`): `None` unless the grammar takes the line.
fn tokens(line: &[u8]) -> Option<Vec<&str>> {
    // One line break at the end: `\r\n` (its `\n` already cut) or `\r`; any other `\r`
    // is in a token, which then fails `is_number`.
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    if !line.is_ascii() {
        return None;
    }
    let mut out = Vec::with_capacity(8);
    for t in line.split(|&b| b == b' ' || b == b'\t').filter(|t| !t.is_empty()) {
        if !is_number(t) {
            return None;
        }
        // ASCII, checked above.
        out.push(std::str::from_utf8(t).ok()?);
    }
    Some(out)
}

/// A token as a value of scalar type `t`, parsed as the record reader parses it, then
/// converted as a vertex converts it.
fn as_f32(t: &ScalarType, s: &str) -> Option<f32> {
    Some(match t {
        ScalarType::Char => f32::from(s.parse::<i8>().ok()?),
        ScalarType::UChar => f32::from(s.parse::<u8>().ok()?),
        ScalarType::Short => f32::from(s.parse::<i16>().ok()?),
        ScalarType::UShort => f32::from(s.parse::<u16>().ok()?),
        ScalarType::Int => s.parse::<i32>().ok()? as f32,
        ScalarType::UInt => s.parse::<u32>().ok()? as f32,
        ScalarType::Float => s.parse::<f32>().ok()?,
        ScalarType::Double => s.parse::<f64>().ok()? as f32,
    })
}

/// A token as an integer of type `t`; `None` for floats or what the type rejects.
fn as_i64(t: &ScalarType, s: &str) -> Option<i64> {
    Some(match t {
        ScalarType::Char => s.parse::<i8>().ok()?.into(),
        ScalarType::UChar => s.parse::<u8>().ok()?.into(),
        ScalarType::Short => s.parse::<i16>().ok()?.into(),
        ScalarType::UShort => s.parse::<u16>().ok()?.into(),
        ScalarType::Int => s.parse::<i32>().ok()?.into(),
        ScalarType::UInt => s.parse::<u32>().ok()?.into(),
        ScalarType::Float | ScalarType::Double => return None,
    })
}

/// Whether the record reader takes token `s` as a value of type `t`.
fn parses(t: &ScalarType, s: &str) -> bool {
    match t {
        ScalarType::Float | ScalarType::Double => s.parse::<f64>().is_ok(),
        t => as_i64(t, s).is_some(),
    }
}

/// The next `count` lines of `body` from `at`: their ranges (without `\n`), and `at`
/// past them; `None` when the body ends first.
fn lines(body: &[u8], at: &mut usize, count: usize) -> Option<Vec<Range<usize>>> {
    let mut out = Vec::with_capacity(count.min(body.len().saturating_sub(*at) / 2 + 1));
    for _ in 0..count {
        if *at >= body.len() {
            return None;
        }
        let end = body[*at..].iter().position(|&b| b == b'\n').map_or(body.len(), |i| *at + i);
        out.push(*at..end);
        *at = (end + 1).min(body.len());
    }
    Some(out)
}

/// The body of an ASCII file, or `None` (see the module's documentation).
pub(super) fn read(header: &Header, body: &[u8]) -> Option<Body> {
    if header.encoding != Encoding::Ascii {
        return None;
    }
    let vertex_count = header.elements.get("vertex")?.count;
    let mut at = 0usize;
    let mut out = Body::default();
    for def in header.elements.values() {
        let lines = lines(body, &mut at, def.count)?;
        match def.name.as_str() {
            "vertex" => read_vertices(def, body, &lines, &mut out)?,
            "face" => read_faces(def, body, &lines, vertex_count, &mut out)?,
            _ => {
                for l in &lines {
                    let t = tokens(&body[l.clone()])?;
                    check_record(def, &t)?;
                }
            }
        }
    }
    Some(out)
}

/// Whether the tokens of a line make a record of `def` (every value parsed, as the record
/// reader parses the properties of elements it skips).
fn check_record(def: &ElementDef, t: &[&str]) -> Option<()> {
    let mut it = t.iter();
    for p in def.properties.values() {
        match &p.data_type {
            PropertyType::Scalar(s) => parses(s, it.next()?).then_some(())?,
            PropertyType::List(_, item) => {
                let n: usize = it.next()?.parse().ok()?;
                for _ in 0..n {
                    parses(item, it.next()?).then_some(())?;
                }
            }
        }
    }
    it.next().is_none().then_some(())
}

/// The first of element `def`'s lines (from `*at` in `body`, line `*line` of the file the
/// first, up to line `until`) that holds more values than the header declares, which
/// the record reader would ignore: its line and the problem. `*at` and `*line` move past
/// the lines looked at. Lines too short to count are the record reader's to name.
pub(super) fn values_past_the_declared(
    def: &ElementDef,
    body: &[u8],
    at: &mut usize,
    line: &mut usize,
    until: usize,
) -> Option<(usize, String)> {
    for _ in 0..def.count {
        if *at >= body.len() || *line >= until {
            return None;
        }
        let end = body[*at..].iter().position(|&b| b == b'\n').map_or(body.len(), |i| *at + i);
        let text = &body[*at..end];
        let text = text.strip_suffix(b"\r").unwrap_or(text);
        let t: Vec<&[u8]> = text.split(|&b| b == b' ' || b == b'\t').filter(|t| !t.is_empty()).collect();
        let here = *line;
        *at = (end + 1).min(body.len());
        *line += 1;
        // The values the header declares for this line, and the last list's (name,
        // count, first value) when it is the last property.
        let mut declared = 0usize;
        let mut last_list = None;
        let mut countable = true;
        for p in def.properties.values() {
            match &p.data_type {
                PropertyType::Scalar(_) => {
                    declared += 1;
                    last_list = None;
                }
                PropertyType::List(..) => {
                    let n = t.get(declared).and_then(|c| std::str::from_utf8(c).ok()?.parse::<usize>().ok());
                    let Some(n) = n.filter(|&n| n < t.len()) else {
                        countable = false;
                        break;
                    };
                    last_list = Some((&p.name, n, declared + 1));
                    declared += 1 + n;
                }
            }
        }
        if countable && t.len() > declared {
            let problem = match last_list {
                Some((name, n, first)) => format!("the list '{name}' says {n} values, the line holds {}", t.len() - first),
                None => format!("{} values where the header declares {declared}", t.len()),
            };
            return Some((here, problem));
        }
    }
    None
}

/// The `vertex` element's lines into `out`, as the record reader keeps them.
fn read_vertices(def: &ElementDef, body: &[u8], lines: &[Range<usize>], out: &mut Body) -> Option<()> {
    let mut plan = Vec::new();
    let mut present = 0u8;
    for p in def.properties.values() {
        let PropertyType::Scalar(t) = &p.data_type else { return None };
        let slot = Vertex::slot(&p.name);
        if let Some(slot) = slot {
            present |= 1 << slot;
        }
        plan.push((t, slot));
    }
    if !lines.is_empty() && present & 0b111 != 0b111 {
        return None;
    }
    let read = |l: &Range<usize>| -> Option<Vertex> {
        let t = tokens(&body[l.clone()])?;
        let mut v = Vertex::default();
        let mut it = t.iter();
        for &(ty, slot) in &plan {
            let s = it.next()?;
            match slot {
                Some(slot) => v.put(slot, as_f32(ty, s)?),
                None => parses(ty, s).then_some(())?,
            }
        }
        it.next().is_none().then_some(v)
    };
    let records: Vec<Vertex> = lines.par_iter().with_min_len(1 << 12).map(read).collect::<Option<_>>()?;
    out.set_vertices(&records);
    Some(())
}

/// Faces per chunk read on one thread.
pub(super) const FACE_CHUNK: usize = 1 << 14;

/// The `face` element's lines into `out`: fans of indices below `vertex_count`, faces of
/// fewer than three vertices counted.
fn read_faces(def: &ElementDef, body: &[u8], lines: &[Range<usize>], vertex_count: usize, out: &mut Body) -> Option<()> {
    let is_index = |name: &str| name == "vertex_indices" || name == "vertex_index";
    let index_lists = def.properties.values().filter(|p| is_index(&p.name) && matches!(p.data_type, PropertyType::List(..))).count();
    if index_lists > 1 {
        return None;
    }
    // A face's indices, checked; `None` where the record reader reports a problem or
    // would take the list as no indices (float items).
    let read = |l: &Range<usize>, face: &mut Vec<u32>| -> Option<()> {
        let t = tokens(&body[l.clone()])?;
        let mut it = t.iter();
        face.clear();
        for p in def.properties.values() {
            match &p.data_type {
                PropertyType::Scalar(s) => parses(s, it.next()?).then_some(())?,
                PropertyType::List(_, item) => {
                    let n: usize = it.next()?.parse().ok()?;
                    let indices = is_index(&p.name);
                    for _ in 0..n {
                        let s = it.next()?;
                        if indices {
                            let i = as_i64(item, s)?;
                            face.push(u32::try_from(i).ok().filter(|&i| (i as usize) < vertex_count)?);
                        } else {
                            parses(item, s).then_some(())?;
                        }
                    }
                }
            }
        }
        it.next().is_none().then_some(())
    };
    // Chunks of faces on every thread, each read into a body of its own, then in order.
    let chunks: Vec<Option<Body>> = lines
        .par_chunks(FACE_CHUNK)
        .enumerate()
        .map(|(c, ls)| {
            let mut chunk = Body { triangles: Vec::with_capacity(ls.len()), ..Body::default() };
            let mut face = Vec::new();
            for (k, l) in ls.iter().enumerate() {
                read(l, &mut face)?;
                chunk.add_face(c * FACE_CHUNK + k, &face);
            }
            Some(chunk)
        })
        .collect();
    out.triangles.reserve(lines.len());
    for chunk in chunks {
        out.append_faces(chunk?);
    }
    Some(())
}
