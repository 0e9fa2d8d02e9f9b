//! The geometry of an OBJ file read in parallel, with tobj's answer.
//!
//! tobj reads one line at a time on one thread and looks every face vertex up in a hash
//! map: the conference room's 12 MB took 115 ms of its 4 s render. Its geometry lines
//! (`v`, `vt`, `vn`, `f`) are most of any file and independent of one another, so they
//! are read here in chunks on every thread, and the rest of the file (materials, groups,
//! comments) still goes through tobj, which so decides what it always decided: the
//! material libraries it loads, the models it splits the faces into and their
//! materials. Each face run then stands in that *skeleton* as one face `f 1 1 1`, and
//! the models tobj makes of the skeleton say which runs each model holds.
//!
//! The result is tobj's, value for value: the same floats (the same `f32::from_str`),
//! each model's vertices numbered in the order tobj numbers them (first use, one number
//! per distinct position/texture/normal triple), polygons fanned as tobj fans them,
//! weights divided by. tobj checks a model's indices, and decides whether it has texture
//! coordinates and normals, when the model ends, with the lines read by then: each run
//! keeps the counts at its end, and what would depend on where its model ends is
//! declined. A file outside the plain subset read here (relative or signed indices,
//! colours on some vertices only, non-ASCII geometry lines, an index out of range,
//! anything tobj would reject) gets `None`, and tobj reads the whole file as before, so
//! that its answer, or its error, is unchanged. Tests compare the two readers on
//! generated files.

use super::scan::is_space;
use rayon::prelude::*;
use std::collections::HashMap;
use std::ops::Range;

/// An index a face element leaves out (`1//3` has no texture index).
const MISSING: u32 = u32::MAX;

/// A face element: position, texture and normal indices, from 0, [`MISSING`] if absent.
type Element = [u32; 3];

/// What the geometry lines of a file hold, before tobj's models split it.
#[derive(Debug, Default)]
pub(super) struct Geometry {
    positions: Vec<f32>,
    texcoords: Vec<f32>,
    normals: Vec<f32>,
    /// Every face's elements, face after face.
    elements: Vec<Element>,
    /// Every face's element count.
    arities: Vec<u32>,
    /// The other lines, for tobj: each line's byte range (without its newline), how
    /// many faces came before it, and the positions, texture coordinates and normals.
    others: Vec<(Range<usize>, usize, Counts)>,
    /// `v` lines with a colour.
    colored: usize,
}

/// How many positions, texture coordinates and normals.
type Counts = [usize; 3];

/// A run of faces between two other lines: tobj's model holding them ends at the first
/// or a later one, and checks their indices against what was read by then, at least
/// the `counts` at the end of the run.
#[derive(Clone, Debug)]
pub(super) struct Run {
    faces: Range<usize>,
    counts: Counts,
}

/// At least this many bytes per chunk: below it a file is read on one thread.
const MIN_CHUNK: usize = 256 * 1024;

/// Read the geometry lines of `text` in parallel chunks; `None` when the file is outside
/// the plain subset (see the module's documentation).
pub(super) fn read_geometry(text: &str) -> Option<Geometry> {
    let chunks = (text.len() / MIN_CHUNK).clamp(1, 8 * rayon::current_num_threads());
    read_geometry_in(text, chunks)
}

/// [`read_geometry`] in about `chunks` chunks (tests use many small ones).
pub(super) fn read_geometry_in(text: &str, chunks: usize) -> Option<Geometry> {
    let bytes = text.as_bytes();
    let chunks = chunks.max(1);
    // Chunk boundaries just after a newline, so that every line is in one chunk.
    let mut cuts = vec![0];
    for k in 1..chunks {
        let at = (bytes.len() * k / chunks).max(*cuts.last()?);
        let next = bytes[at..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |i| at + i + 1);
        if next > *cuts.last()? && next < bytes.len() {
            cuts.push(next);
        }
    }
    cuts.push(bytes.len());
    let parts: Vec<Geometry> = cuts.par_windows(2).map(|w| read_chunk(text, w[0]..w[1])).collect::<Option<_>>()?;
    if parts.len() == 1 {
        return checked(parts.into_iter().next()?);
    }
    // PERF: the chunks' arrays joined on every thread, into arrays allocated zeroed (whose
    // pages the copies fault in): the conference room's 15 MB took 9 ms on one thread.
    let mut all = Geometry {
        positions: joined(&parts, |g| &g.positions),
        texcoords: joined(&parts, |g| &g.texcoords),
        normals: joined(&parts, |g| &g.normals),
        elements: joined(&parts, |g| &g.elements),
        arities: joined(&parts, |g| &g.arities),
        ..Geometry::default()
    };
    let (mut faces, mut before) = (0, [0; 3]);
    for part in parts {
        let counts = part.counts();
        all.others.extend(part.others.into_iter().map(|(r, f, c)| (r, f + faces, [0, 1, 2].map(|k| c[k] + before[k]))));
        all.colored += part.colored;
        faces += part.arities.len();
        before = [0, 1, 2].map(|k| before[k] + counts[k]);
    }
    checked(all)
}

/// The arrays `array` of `parts` one after the other, copied on every thread.
fn joined<T: Copy + Default + Send + Sync>(parts: &[Geometry], array: impl Fn(&Geometry) -> &Vec<T> + Sync) -> Vec<T> {
    let mut all = vec![T::default(); parts.iter().map(|g| array(g).len()).sum()];
    let pieces = crate::io::pieces_mut(&mut all, parts.iter().map(|g| array(g).len()));
    pieces.into_par_iter().zip(parts).for_each(|(piece, g)| piece.copy_from_slice(array(g)));
    all
}

/// `all`, or `None` when tobj's answer could differ from the reader's (see [`read_geometry`]).
fn checked(all: Geometry) -> Option<Geometry> {
    // Colours on some vertices only: tobj may then fail on a face (its colour array
    // shorter than its positions); its to read.
    if all.colored != 0 && all.colored != all.positions.len() / 3 {
        return None;
    }
    Some(all)
}

/// The words of one ASCII line, split as `split_whitespace` splits it.
fn words(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|&b| is_space(b)).filter(|w| !w.is_empty())
}

/// A float as tobj parses it (`f32::from_str`).
fn float(word: &[u8]) -> Option<f32> {
    std::str::from_utf8(word).ok()?.parse().ok()
}

/// A face element's index: 1 to 9 decimal digits, no sign, not 0; from 0.
fn index(digits: &[u8]) -> Option<u32> {
    if digits.is_empty() || digits.len() > 9 {
        return None;
    }
    let mut n = 0u32;
    for &d in digits {
        let d = d.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        n = n * 10 + u32::from(d);
    }
    n.checked_sub(1)
}

/// A face element, `v`, `v/vt`, `v//vn` or `v/vt/vn`.
fn element(word: &[u8]) -> Option<Element> {
    let mut e = [MISSING; 3];
    let mut parts = word.split(|&b| b == b'/');
    e[0] = index(parts.next()?)?;
    for slot in &mut e[1..] {
        match parts.next() {
            None => break,
            Some([]) => {}
            Some(p) => *slot = index(p)?,
        }
    }
    parts.next().is_none().then_some(e)
}

/// The geometry lines of `text[range]` (whole lines), the others noted for tobj.
fn read_chunk(text: &str, range: Range<usize>) -> Option<Geometry> {
    let bytes = text.as_bytes();
    let mut g = Geometry::default();
    // About one line in 30 bytes, most of them faces or vertices.
    let guess = (range.end - range.start) / 30;
    g.elements.reserve(guess * 2);
    g.arities.reserve(guess / 2);
    g.positions.reserve(guess);
    let mut start = range.start;
    while start < range.end {
        let end = bytes[start..range.end].iter().position(|&b| b == b'\n').map_or(range.end, |i| start + i);
        let line = &bytes[start..end];
        let line_range = start..end;
        start = end + 1;
        let mut w = words(line);
        let Some(key) = w.next() else { continue };
        match key {
            // A comment to tobj too, whatever follows (its first word starts with `#`).
            [b'#', ..] | b"s" => {}
            b"v" | b"vt" | b"vn" | b"f" if !line.is_ascii() => return None,
            b"v" => {
                let mut p = [0f32; 3];
                for x in &mut p {
                    *x = float(w.next()?)?;
                }
                match (w.next(), w.next(), w.next(), w.next()) {
                    (None, ..) => {}
                    // A weight: tobj divides by it (and refuses 0).
                    (Some(weight), None, ..) => {
                        let weight = float(weight).filter(|&w| w != 0.0)?;
                        p = p.map(|x| x / weight);
                    }
                    // A colour, which isir does not keep; tobj stops at a colour that is
                    // not a number and may then fail later: its to read.
                    (Some(r), Some(gr), Some(b), None) if [r, gr, b].into_iter().all(|c| float(c).is_some()) => g.colored += 1,
                    _ => return None,
                }
                g.positions.extend_from_slice(&p);
            }
            b"vt" => {
                for _ in 0..2 {
                    g.texcoords.push(float(w.next()?)?);
                }
            }
            b"vn" => {
                for _ in 0..3 {
                    g.normals.push(float(w.next()?)?);
                }
            }
            b"f" => {
                let before = g.elements.len();
                for word in w {
                    g.elements.push(element(word)?);
                }
                let n = g.elements.len() - before;
                if n == 0 {
                    return None;
                }
                g.arities.push(n as u32);
            }
            // Lines tobj reads as geometry in its own way.
            b"l" | b"p" => return None,
            // The first word of another line must read the same to tobj, which splits
            // words at any Unicode whitespace.
            _ if !key.is_ascii() => return None,
            _ => g.others.push((line_range, g.arities.len(), g.counts())),
        }
    }
    Some(g)
}

impl Geometry {
    /// Positions, texture coordinates and normals read so far.
    fn counts(&self) -> Counts {
        [self.positions.len() / 3, self.texcoords.len() / 2, self.normals.len() / 3]
    }

    /// The skeleton for tobj: one vertex, then the other lines in file order, each run of
    /// faces between them as one face `f 1 1 1`; and those runs.
    pub(super) fn skeleton(&self, text: &str) -> (String, Vec<Run>) {
        let mut s = String::from("v 0 0 0\n");
        let mut runs = Vec::new();
        let mut faces = 0;
        let mut run_to = |s: &mut String, upto: usize, counts: Counts| {
            if upto > faces {
                s.push_str("f 1 1 1\n");
                runs.push(Run { faces: faces..upto, counts });
                faces = upto;
            }
        };
        for (range, before, counts) in &self.others {
            run_to(&mut s, *before, *counts);
            s.push_str(&text[range.clone()]);
            s.push('\n');
        }
        run_to(&mut s, self.arities.len(), self.counts());
        (s, runs)
    }

    /// tobj's models of this geometry, given the models it made of the skeleton (each
    /// holding one face per run) and the runs; `None` where tobj would fail (an index out
    /// of range) or the skeleton's models do not match the runs.
    pub(super) fn models(&self, skeleton_models: Vec<tobj::Model>, runs: &[Run]) -> Option<Vec<tobj::Model>> {
        // Where each face's elements start, for the runs' first faces.
        let mut first_element = Vec::with_capacity(self.arities.len() + 1);
        let mut at = 0usize;
        first_element.push(0);
        for &n in &self.arities {
            at += n as usize;
            first_element.push(at);
        }
        let mut numbering = Numbering::new(self.positions.len() / 3);
        let mut next_run = 0;
        let mut models = Vec::with_capacity(skeleton_models.len());
        for model in skeleton_models {
            let m = &model.mesh;
            if m.indices.len() % 3 != 0 || !m.face_arities.is_empty() {
                return None;
            }
            let count = m.indices.len() / 3;
            let mine = runs.get(next_run..next_run + count)?;
            next_run += count;
            let mesh = self.export(mine, &first_element, m.material_id, &mut numbering)?;
            models.push(tobj::Model::new(mesh, model.name));
        }
        (next_run == runs.len()).then_some(models)
    }

    /// One model's mesh, as tobj's `export_faces` makes it: vertices numbered in order of
    /// first use, triangles fanned from each face's first element, faces of fewer than
    /// three elements left out (points and lines are ignored). `None` where what tobj
    /// reads depends on where the model ends: an index past what its run's end had read
    /// (tobj may fail), or texture coordinates or normals none at a run's end but some
    /// later (tobj may leave them out).
    fn export(&self, runs: &[Run], first_element: &[usize], material_id: Option<usize>, numbering: &mut Numbering) -> Option<tobj::Mesh> {
        let mut mesh = tobj::Mesh { material_id, ..Default::default() };
        numbering.restart();
        let total = self.counts();
        for run in runs {
            let [v_max, vt_max, vn_max] = run.counts;
            if (vt_max == 0) != (total[1] == 0) || (vn_max == 0) != (total[2] == 0) {
                return None;
            }
            let within = |e: &Element| {
                (e[0] as usize) < v_max
                    && (e[1] == MISSING || vt_max == 0 || (e[1] as usize) < vt_max)
                    && (e[2] == MISSING || vn_max == 0 || (e[2] as usize) < vn_max)
            };
            for f in run.faces.clone() {
                let elements = &self.elements[first_element[f]..first_element[f + 1]];
                if elements.len() < 3 {
                    continue;
                }
                // The fan's triangles as its elements are numbered. PERF: not from an
                // array of the face's numbers, whose pairs, read back as one load right
                // after two stores, waited on store forwarding (45% of this function's
                // time; its share of the conference room's load 3.1% -> 2.1%).
                let (mut first, mut previous) = (0, 0);
                for (k, e) in elements.iter().enumerate() {
                    if !within(e) {
                        return None;
                    }
                    let id = numbering.number(e, || self.add_vertex(&mut mesh, e))?;
                    match k {
                        0 => first = id,
                        1 => {}
                        _ => mesh.indices.extend([first, previous, id]),
                    }
                    previous = id;
                }
            }
        }
        Some(mesh)
    }

    /// A new vertex's position, texture coordinates and normal pushed as tobj's
    /// `add_vertex` pushes them; `None` for an index out of range (tobj's error).
    fn add_vertex(&self, mesh: &mut tobj::Mesh, e: &Element) -> Option<()> {
        let [v, vt, vn] = e.map(|i| i as usize);
        mesh.positions.extend_from_slice(self.positions.get(3 * v..3 * v + 3)?);
        if !self.texcoords.is_empty() && e[1] != MISSING {
            mesh.texcoords.extend_from_slice(self.texcoords.get(2 * vt..2 * vt + 2)?);
        }
        if !self.normals.is_empty() && e[2] != MISSING {
            mesh.normals.extend_from_slice(self.normals.get(3 * vn..3 * vn + 3)?);
        }
        Some(())
    }
}

/// Vertex numbers of one model: the first element seen with each position index in an
/// array (most files use one texture and normal index per position), any other in a map.
/// Stamped per model, so that the array is allocated once for all of a file's models.
struct Numbering {
    stamp: Vec<u32>,
    first: Vec<(u32, [u32; 2])>,
    others: HashMap<Element, u32>,
    model: u32,
    count: u32,
}

impl Numbering {
    fn new(positions: usize) -> Self {
        Numbering { stamp: vec![0; positions], first: vec![(0, [0; 2]); positions], others: HashMap::new(), model: 0, count: 0 }
    }

    fn restart(&mut self) {
        self.model += 1;
        self.count = 0;
        self.others.clear();
    }

    /// The number of element `e`, a new one (after `add`, which pushes its vertex) when
    /// this model has not seen it; `None` when `add` fails or `e`'s position is out of
    /// range.
    fn number(&mut self, e: &Element, add: impl FnOnce() -> Option<()>) -> Option<u32> {
        let v = e[0] as usize;
        let rest = [e[1], e[2]];
        let seen = *self.stamp.get(v)? == self.model;
        if seen {
            let (n, key) = self.first[v];
            if key == rest {
                return Some(n);
            }
            if let Some(&n) = self.others.get(e) {
                return Some(n);
            }
        }
        add()?;
        let n = self.count;
        self.count += 1;
        if seen {
            self.others.insert(*e, n);
        } else {
            self.stamp[v] = self.model;
            self.first[v] = (n, rest);
        }
        Some(n)
    }
}
