//! The line scan beside tobj: what tobj would drop or misread silently (short faces,
//! `l` and `p` lines, unknown `usemtl`, a truncated last face, malformed MTL lines), found
//! with its line so that it is counted in a warning or named in an error.

use super::*;

/// How many lines of a kind, and the first.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Tally {
    pub(super) count: usize,
    pub(super) first: usize,
}

impl Tally {
    pub(super) fn add(&mut self, line: usize) {
        if self.count == 0 {
            self.first = line;
        }
        self.count += 1;
    }
}

/// What one cheap pass over an OBJ's lines found, beside what tobj reads.
#[derive(Debug, Default)]
pub(super) struct ObjScan {
    /// `f` lines with fewer than 3 vertices (tobj drops them).
    pub(super) short_faces: Tally,
    /// `l` lines (tobj would make polygons of those with 3 points or more: hidden from it).
    pub(super) polylines: Tally,
    /// `p` lines (tobj ignores them).
    pub(super) points: Tally,
    /// The last line, when the file ends inside a face: its number, and whether the face
    /// is dropped (fewer than 3 vertices) rather than kept with a possibly cut last vertex.
    pub(super) truncated: Option<(usize, bool)>,
    /// `usemtl` lines: line number, byte offset, byte range of the name as tobj reads it.
    pub(super) usemtl: Vec<(usize, usize, std::ops::Range<usize>)>,
    /// Byte offsets of the `mtllib` lines.
    pub(super) mtllib: Vec<usize>,
    /// Byte offsets of the keywords of lines hidden from tobj: `l` lines and empty `f`
    /// lines (which tobj rejects as an invalid polygon, with no line number).
    pub(super) hide: Vec<usize>,
}

/// Rust's (and so tobj's) ASCII whitespace: ' ' and 9..=13, vertical tab included.
#[inline]
pub(super) fn is_space(b: u8) -> bool {
    b == b' ' || b.wrapping_sub(9) < 5
}

/// The shape of a face line's elements, found without parsing them.
pub(super) struct FaceShape {
    pub(super) words: usize,
    pub(super) ends_with_slash: bool,
    /// Worth a full check: a negative (relative) index or a number of 10 digits or more,
    /// on which tobj computes `index * 2` or `index * 3` unchecked (a panic, or a wrong
    /// normal read in silence); or non-ASCII text, where Unicode whitespace splits words.
    pub(super) suspicious: bool,
}

/// The shape of the face elements in `rest` (what follows `f`) up to the end of its line,
/// and the length of that line part.
pub(super) fn face_shape(rest: &str) -> (FaceShape, usize) {
    // This runs over every face of every mesh, in the same pass that finds the end of the
    // line: digits, the commonest bytes, go first.
    let bytes = rest.as_bytes();
    let (mut words, mut after_space, mut digits, mut suspicious, mut len) = (0, true, 0, false, bytes.len());
    for (i, &b) in bytes.iter().enumerate() {
        if b.is_ascii_digit() {
            digits += 1;
            suspicious |= digits == 10;
            if after_space {
                (words, after_space) = (words + 1, false);
            }
            continue;
        }
        digits = 0;
        if is_space(b) {
            if b == b'\n' {
                len = i;
                break;
            }
            after_space = true;
            continue;
        }
        if after_space {
            (words, after_space) = (words + 1, false);
        }
        suspicious |= b == b'-' || b >= 0x80;
    }
    let rest = &rest[..len];
    let shape = if suspicious && !rest.is_ascii() {
        // Unicode whitespace splits words too.
        let all: Vec<&str> = rest.split_whitespace().collect();
        FaceShape { words: all.len(), ends_with_slash: all.last().is_some_and(|w| w.ends_with('/')), suspicious }
    } else {
        FaceShape { words, ends_with_slash: rest.trim_ascii_end().ends_with('/'), suspicious }
    };
    (shape, len)
}

/// The name tobj reads on a `usemtl` line: everything after the first space, trimmed
/// (so `usemtl<TAB>name` and a line indented by spaces do not name what they seem to).
pub(super) fn tobj_usemtl_name(line: &str) -> &str {
    line.split_once(' ').map_or("", |(_, name)| name).trim()
}

/// One pass over the lines: counts what tobj drops, finds what it must not see, and checks
/// the few face elements tobj would mishandle (see [`FaceShape::suspicious`]).
pub(super) fn scan_obj(text: &str) -> std::result::Result<ObjScan, (usize, String)> {
    let mut s = ObjScan::default();
    let mut counts = [0usize; 3];
    let (mut start, mut lineno) = (0, 0);
    while start < text.len() {
        lineno += 1;
        // A face line (most of a mesh's bytes) is read once: its shape, and where it ends.
        let face_first = text[start..].starts_with("f ");
        let (face, end) = if face_first {
            let (face, len) = face_shape(&text[start + 1..]);
            (Some(face), start + 1 + len)
        } else {
            (None, text[start..].find('\n').map_or(text.len(), |i| start + i))
        };
        let next = end + 1;
        let ends_file = end == text.len();
        // As `BufRead::lines` gives it to tobj: without "\n" or "\r\n".
        let line = &text[start..end];
        let line = line.strip_suffix('\r').unwrap_or(line);
        let line_start = std::mem::replace(&mut start, next);
        // The other lines that make up nearly all of a mesh, without splitting them into words.
        match line.as_bytes() {
            [b'v', b' ', ..] => {
                counts[0] += 1;
                continue;
            }
            [b'v', b't' | b'n', b' ', ..] => {
                counts[usize::from(line.as_bytes()[1] == b'n') + 1] += 1;
                continue;
            }
            _ => {}
        }
        let (key, body) = if face_first {
            ("f", line)
        } else {
            let body = line.trim_start();
            let Some(key) = body.split_whitespace().next() else { continue };
            (key, body)
        };
        let key_at = line_start + (line.len() - body.len());
        match key {
            "v" => counts[0] += 1,
            "vt" => counts[1] += 1,
            "vn" => counts[2] += 1,
            "f" => {
                let rest = &body[1..];
                let face = face.unwrap_or_else(|| face_shape(rest).0);
                if face.words == 0 {
                    s.hide.push(key_at);
                }
                if ends_file && (face.words < 3 || face.ends_with_slash) {
                    s.truncated = Some((lineno, face.words < 3));
                } else if face.words < 3 {
                    s.short_faces.add(lineno);
                }
                if face.words >= 3 && face.suspicious {
                    if let Some(problem) = rest.split_whitespace().find_map(|w| check_face_element(w, Some(counts))) {
                        return Err((lineno, problem));
                    }
                }
            }
            "l" => {
                s.polylines.add(lineno);
                s.hide.push(key_at);
            }
            "p" => s.points.add(lineno),
            "usemtl" => {
                // An empty name is an error tobj reports (and `locate_error` finds).
                let name = tobj_usemtl_name(line);
                if !name.is_empty() {
                    let at = line_start + (name.as_ptr() as usize - line.as_ptr() as usize);
                    s.usemtl.push((lineno, line_start, at..at + name.len()));
                }
            }
            "mtllib" => s.mtllib.push(line_start),
            _ => {}
        }
    }
    Ok(s)
}

impl ObjScan {
    /// Whether [`ObjScan::neutralize`] leaves the text as it is.
    pub(super) fn hides_nothing(&self) -> bool {
        self.hide.is_empty()
    }

    /// `text` with the keywords of the lines tobj must not see turned into comments (same
    /// length, so offsets and line numbers hold); copied only when there are some.
    pub(super) fn neutralize<'a>(&self, text: Cow<'a, str>) -> Cow<'a, str> {
        if self.hide.is_empty() {
            return text;
        }
        let mut bytes = text.into_owned().into_bytes();
        for &at in &self.hide {
            bytes[at] = b'#'; // an ASCII `f` or `l` becomes an ASCII `#`: still UTF-8
        }
        Cow::Owned(String::from_utf8(bytes).expect("one ASCII byte replaced by another"))
    }

    /// The warnings: one line per kind of dropped element. `libraries` are the names each
    /// `mtllib` line defined (`None`: it failed, and was warned about). They do not name
    /// the OBJ file: the scene prefixes its warnings with the object's name.
    pub(super) fn warnings(&self, text: &str, libraries: &[Option<Vec<String>>]) -> Vec<String> {
        let mut w = Vec::new();
        for (tally, what) in [
            (self.short_faces, "with fewer than 3 vertices dropped"),
            (self.polylines, "ignored: polylines ('l') are not rendered"),
            (self.points, "ignored: points ('p') are not rendered"),
        ] {
            if tally.count > 0 {
                let noun = if what.starts_with("with") { "face" } else { "element" };
                w.push(format!("{} {what} (first at line {})", plural(tally.count, noun), tally.first));
            }
        }
        match self.truncated {
            Some((line, true)) => {
                w.push(format!("the file ends inside a face at line {line} (cut short?): that face is dropped"));
            }
            Some((line, false)) => {
                w.push(format!("the file ends inside a face at line {line} (cut short?): its last vertex may be incomplete"));
            }
            None => {}
        }
        // A library that failed was already warned about, with what its faces get.
        if libraries.iter().all(Option::is_some) {
            let mut known = std::collections::HashSet::new();
            let mut next_library = 0;
            let mut unknown = Tally::default();
            let mut first_name = "";
            for (line, at, name) in &self.usemtl {
                while next_library < self.mtllib.len() && self.mtllib[next_library] < *at {
                    known.extend(libraries.get(next_library).into_iter().flatten().flatten().map(String::as_str));
                    next_library += 1;
                }
                let name = &text[name.clone()];
                if !name.is_empty() && !known.contains(name) {
                    if unknown.count == 0 {
                        first_name = name;
                    }
                    unknown.add(*line);
                }
            }
            if unknown.count > 0 {
                w.push(format!(
                    "{} {} a material no material library defines (first at line {}: '{}'): their faces use the default material",
                    plural(unknown.count, "usemtl line"),
                    if unknown.count == 1 { "names" } else { "name" },
                    unknown.first,
                    excerpt(first_name),
                ));
            }
        }
        w
    }
}

/// What a scan of an MTL file found: the first line tobj would reject (or panic on), and
/// the `Kd` values that would not render.
#[derive(Debug, Default)]
pub(super) struct MtlScan {
    pub(super) error: Option<(usize, String)>,
    pub(super) negative_kd: MaterialTally,
    pub(super) nonfinite_kd: MaterialTally,
}

/// How many materials have a problem, and the first: its line and name.
#[derive(Debug, Default)]
pub(super) struct MaterialTally {
    pub(super) count: usize,
    pub(super) first: Option<(usize, String)>,
}

impl MaterialTally {
    pub(super) fn add(&mut self, line: usize, material: &str) {
        self.first.get_or_insert_with(|| (line, excerpt(material)));
        self.count += 1;
    }
}

/// Check an MTL file line by line as tobj reads it (its keywords, case-sensitive).
pub(super) fn scan_mtl(text: &str) -> MtlScan {
    let mut s = MtlScan::default();
    let mut material = "";
    for (i, line) in text.lines().enumerate() {
        let lineno = i + 1;
        let line = line.trim();
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        let quoted = || excerpt(line);
        let problem = match key {
            "newmtl" => {
                material = line[key.len()..].trim();
                material.is_empty().then(|| "newmtl without a material name".to_string())
            }
            "Ka" | "Kd" | "Ks" | "Ke" => {
                let vals: Vec<f32> = words.take(3).map_while(|w| w.parse().ok()).collect();
                if vals.len() < 3 {
                    Some(format!("bad {key} '{}': expected 3 numbers", quoted()))
                } else {
                    if key == "Kd" && vals.iter().any(|v| !v.is_finite()) {
                        s.nonfinite_kd.add(lineno, material);
                    } else if key == "Kd" && vals.iter().any(|&v| v < 0.0) {
                        s.negative_kd.add(lineno, material);
                    }
                    None
                }
            }
            "Ns" | "Ni" | "d" => {
                words.next().and_then(|w| w.parse::<f32>().ok()).is_none().then(|| format!("bad {key} '{}': expected a number", quoted()))
            }
            "illum" => words
                .next()
                .and_then(|w| w.parse::<u8>().ok())
                .is_none()
                .then(|| format!("bad illum '{}': expected an illumination model number (0 to 10)", quoted())),
            "map_Ka" | "map_Kd" | "map_Ks" | "map_Ns" | "map_ns" | "map_NS" | "map_d" | "map_Bump" | "map_bump" | "bump" => {
                line[key.len()..].trim().is_empty().then(|| format!("{key} without a file name"))
            }
            _ => None,
        };
        if let Some(p) = problem {
            s.error = Some((lineno, p));
            break;
        }
    }
    s
}

/// Check one face element `v`, `v/vt`, `v//vn` or `v/vt/vn` as tobj parses it; with the
/// vertex, texture-coordinate and normal counts so far, check its indices are in range too
/// (only for faces tobj keeps: it never looks up the indices of 1- and 2-vertex faces).
pub(super) fn check_face_element(w: &str, counts: Option<[usize; 3]>) -> Option<String> {
    pub(super) const KINDS: [&str; 3] = ["vertices", "texture coordinates", "normals"];
    for (k, part) in w.split('/').enumerate() {
        if part.is_empty() && k > 0 {
            continue; // `1//3`, or a trailing `/`: tobj skips empty parts
        }
        if k >= 3 {
            return Some(format!("bad face element '{}': more than 3 parts (v/vt/vn)", excerpt(w)));
        }
        let Ok(idx) = part.parse::<i64>() else { return Some(format!("bad face element '{}'", excerpt(w))) };
        let Some(counts) = counts else { continue };
        let n = counts[k] as u64;
        if k > 0 && (n == 0 || idx == 0) {
            continue; // tobj ignores texture and normal indices when there are none, and index 0
        }
        if idx == 0 || idx.unsigned_abs() > n {
            return Some(format!("face index {idx} out of range (there are {n} {})", KINDS[k]));
        }
    }
    None
}

/// Check a list of numbers as tobj reads it: the first `need` must be numbers (tobj
/// ignores what follows).
pub(super) fn check_floats(mut words: std::str::SplitWhitespace, need: usize, what: &str, line: &str) -> Option<String> {
    let ok = words.by_ref().take(need).filter(|w| w.parse::<f32>().is_ok()).count() == need;
    (!ok).then(|| format!("bad {what} '{}': expected {need} numbers", excerpt(line.trim())))
}

/// Find the first line tobj would reject, to name it in the error (run only when tobj
/// failed, so it may take its time).
pub(super) fn locate_error(text: &str) -> Option<(usize, String)> {
    let mut counts = [0usize; 3];
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        let problem = match key {
            "v" => {
                counts[0] += 1;
                // x y z, then nothing, a non-zero w, or r g b (tobj's rules).
                let rest: Vec<&str> = words.clone().skip(3).collect();
                check_floats(words, 3, "vertex", line).or_else(|| match rest.len() {
                    0 | 3 => None,
                    1 if rest[0].parse::<f32>().is_ok_and(|w| w != 0.0) => None,
                    _ => Some(format!("bad vertex '{}': expected x y z, x y z w (w not 0) or x y z r g b", excerpt(line.trim()))),
                })
            }
            "vt" => {
                counts[1] += 1;
                check_floats(words, 2, "texture coordinate", line)
            }
            "vn" => {
                counts[2] += 1;
                check_floats(words, 3, "normal", line)
            }
            "f" => {
                let elements: Vec<&str> = words.collect();
                let kept = (elements.len() >= 3).then_some(counts);
                elements.iter().find_map(|w| check_face_element(w, kept))
            }
            "usemtl" if tobj_usemtl_name(line).is_empty() => {
                Some("usemtl without a material name (tobj wants a space, not a tab, after 'usemtl')".to_string())
            }
            _ => None,
        };
        if let Some(p) = problem {
            return Some((i + 1, p));
        }
    }
    None
}
