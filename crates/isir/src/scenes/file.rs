//! Scene files: TOML (`docs/scene-format.md`) read with serde into a [`SceneDescription`].
//! Paths of mesh files are relative to the scene file; every key has the course's default.
//! An error names the file, the line and the column, quotes the line, and for an unknown
//! key or material name suggests the nearest valid one.

use super::description::{CameraDesc, MeshSource, ObjectDesc, SceneDescription, ShapeDesc, Transform};
use crate::error::{Error, Result};
use crate::geometry::{Plane, Sdf, Shading, Sphere};
use crate::integrators::{Integrator, DEFAULT_MAX_DEPTH, MAX_DEPTH_LIMIT};
use crate::io::image::Display;
use crate::io::input::{self, ReadLimits};
use crate::lights::Light;
use crate::materials::Material;
use crate::math::color::GREY;
use glam::Vec3;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;
use toml::Spanned;

/// A scene file's scene, and the image size it asks for.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneFile {
    /// The scene.
    pub description: SceneDescription,
    /// `[render] width`, if given.
    pub width: Option<u32>,
    /// `[render] height`, if given.
    pub height: Option<u32>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct File {
    #[serde(default)]
    render: RenderSection,
    camera: Option<Spanned<CameraSection>>,
    #[serde(default)]
    materials: BTreeMap<String, Spanned<MaterialSpec>>,
    #[serde(default)]
    objects: Vec<Spanned<ObjectSpec>>,
    #[serde(default)]
    lights: Vec<Spanned<LightSpec>>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RenderSection {
    width: Option<Spanned<u32>>,
    height: Option<Spanned<u32>>,
    spp: Option<Spanned<u32>>,
    integrator: Option<Spanned<String>>,
    light_samples: Option<Spanned<u32>>,
    max_depth: Option<Spanned<u32>>,
    display: Option<Spanned<String>>,
    background: Option<[f32; 3]>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct CameraSection {
    position: Option<[f32; 3]>,
    look_at: Option<[f32; 3]>,
    up: Option<[f32; 3]>,
    fovy: Option<f32>,
}

fn white() -> [f32; 3] {
    [1.0, 1.0, 1.0]
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
enum MaterialSpec {
    Color {
        #[serde(default = "white")]
        color: [f32; 3],
    },
    Lambert {
        #[serde(default = "white")]
        color: [f32; 3],
    },
    Matte {
        #[serde(default = "white")]
        color: [f32; 3],
        #[serde(default)]
        sigma: f32,
    },
    Plastic {
        #[serde(default = "white")]
        color: [f32; 3],
        #[serde(default = "white")]
        specular: [f32; 3],
        #[serde(default = "default_shininess")]
        shininess: f32,
        #[serde(default)]
        blinn: bool,
    },
    CookTorrance {
        #[serde(default = "white")]
        color: [f32; 3],
        f0: Option<[f32; 3]>,
        #[serde(default = "default_roughness")]
        roughness: f32,
        #[serde(default)]
        metalness: f32,
    },
    Mirror {},
    Transparent {
        #[serde(default = "default_ior")]
        ior: f32,
    },
}

fn default_shininess() -> f32 {
    32.0
}
fn default_roughness() -> f32 {
    0.5
}
fn default_ior() -> f32 {
    1.3
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
enum ObjectSpec {
    Plane {
        name: Option<String>,
        #[serde(default)]
        point: [f32; 3],
        #[serde(default = "up")]
        normal: [f32; 3],
        material: Option<String>,
    },
    Sphere {
        name: Option<String>,
        #[serde(default)]
        center: [f32; 3],
        #[serde(default = "one")]
        radius: f32,
        material: Option<String>,
    },
    Implicit {
        name: Option<String>,
        sdf: SdfSpec,
        material: Option<String>,
    },
    Mesh {
        name: Option<String>,
        file: Option<String>,
        model: Option<String>,
        #[serde(default)]
        flat: bool,
        material: Option<String>,
        transform: Option<TransformSpec>,
    },
}

fn up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}
fn one() -> f32 {
    1.0
}

/// A signed distance function as an inline table tree (`docs/scene-format.md`).
#[derive(Deserialize)]
#[serde(tag = "sdf", rename_all = "kebab-case", deny_unknown_fields)]
enum SdfSpec {
    Sphere {
        radius: f32,
    },
    Torus {
        major: f32,
        minor: f32,
    },
    Box {
        half: [f32; 3],
    },
    RoundedBox {
        half: [f32; 3],
        radius: f32,
    },
    Capsule {
        a: [f32; 3],
        b: [f32; 3],
        radius: f32,
    },
    HalfSpace {
        normal: [f32; 3],
        offset: f32,
    },
    Union {
        a: Box<SdfSpec>,
        b: Box<SdfSpec>,
    },
    Intersection {
        a: Box<SdfSpec>,
        b: Box<SdfSpec>,
    },
    Subtraction {
        a: Box<SdfSpec>,
        b: Box<SdfSpec>,
    },
    SmoothUnion {
        a: Box<SdfSpec>,
        b: Box<SdfSpec>,
        k: f32,
    },
    Transform {
        of: Box<SdfSpec>,
        #[serde(default)]
        translate: [f32; 3],
        /// A unit quaternion `[x, y, z, w]` (exact), or
        rotation: Option<[f32; 4]>,
        /// angles in degrees about x, then y, then z.
        rotate: Option<[f32; 3]>,
        #[serde(default = "one")]
        scale: f32,
    },
}

impl SdfSpec {
    fn to_sdf(&self) -> Sdf {
        let v = Vec3::from;
        let b = |s: &SdfSpec| Box::new(s.to_sdf());
        match self {
            SdfSpec::Sphere { radius } => Sdf::Sphere { radius: *radius },
            SdfSpec::Torus { major, minor } => Sdf::Torus { major: *major, minor: *minor },
            SdfSpec::Box { half } => Sdf::Box { half: v(*half) },
            SdfSpec::RoundedBox { half, radius } => Sdf::RoundedBox { half: v(*half), radius: *radius },
            SdfSpec::Capsule { a, b: bb, radius } => Sdf::Capsule { a: v(*a), b: v(*bb), radius: *radius },
            SdfSpec::HalfSpace { normal, offset } => Sdf::Plane { normal: v(*normal), offset: *offset },
            SdfSpec::Union { a, b: bb } => Sdf::Union(b(a), b(bb)),
            SdfSpec::Intersection { a, b: bb } => Sdf::Intersection(b(a), b(bb)),
            SdfSpec::Subtraction { a, b: bb } => Sdf::Subtraction(b(a), b(bb)),
            SdfSpec::SmoothUnion { a, b: bb, k } => Sdf::SmoothUnion(b(a), b(bb), *k),
            SdfSpec::Transform { of, translate, rotation, rotate, scale } => {
                let rotation = match (rotation, rotate) {
                    (Some(q), _) => glam::Quat::from_array(*q),
                    (None, Some(r)) => {
                        let r = v(*r) * (std::f32::consts::PI / 180.0);
                        glam::Quat::from_rotation_z(r.z) * glam::Quat::from_rotation_y(r.y) * glam::Quat::from_rotation_x(r.x)
                    }
                    (None, None) => glam::Quat::IDENTITY,
                };
                Sdf::Transform { inner: b(of), translation: v(*translate), rotation, scale: *scale }
            }
        }
    }
}

/// An SDF tree as the inline table [`SdfSpec`] reads.
fn sdf_toml(s: &Sdf, f: &dyn Fn(f32) -> String) -> String {
    let v = |a: Vec3| format!("[{}, {}, {}]", f(a.x), f(a.y), f(a.z));
    match s {
        Sdf::Sphere { radius } => format!("{{ sdf = \"sphere\", radius = {} }}", f(*radius)),
        Sdf::Torus { major, minor } => format!("{{ sdf = \"torus\", major = {}, minor = {} }}", f(*major), f(*minor)),
        Sdf::Box { half } => format!("{{ sdf = \"box\", half = {} }}", v(*half)),
        Sdf::RoundedBox { half, radius } => format!("{{ sdf = \"rounded-box\", half = {}, radius = {} }}", v(*half), f(*radius)),
        Sdf::Capsule { a, b, radius } => format!("{{ sdf = \"capsule\", a = {}, b = {}, radius = {} }}", v(*a), v(*b), f(*radius)),
        Sdf::Plane { normal, offset } => format!("{{ sdf = \"half-space\", normal = {}, offset = {} }}", v(*normal), f(*offset)),
        Sdf::Union(a, b) => format!("{{ sdf = \"union\", a = {}, b = {} }}", sdf_toml(a, f), sdf_toml(b, f)),
        Sdf::Intersection(a, b) => format!("{{ sdf = \"intersection\", a = {}, b = {} }}", sdf_toml(a, f), sdf_toml(b, f)),
        Sdf::Subtraction(a, b) => format!("{{ sdf = \"subtraction\", a = {}, b = {} }}", sdf_toml(a, f), sdf_toml(b, f)),
        Sdf::SmoothUnion(a, b, k) => format!("{{ sdf = \"smooth-union\", a = {}, b = {}, k = {} }}", sdf_toml(a, f), sdf_toml(b, f), f(*k)),
        Sdf::Transform { inner, translation, rotation, scale } => format!(
            "{{ sdf = \"transform\", of = {}, translate = {}, rotation = [{}, {}, {}, {}], scale = {} }}",
            sdf_toml(inner, f),
            v(*translation),
            f(rotation.x),
            f(rotation.y),
            f(rotation.z),
            f(rotation.w),
            f(*scale)
        ),
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TransformSpec {
    #[serde(default)]
    translate: [f32; 3],
    #[serde(default)]
    rotate: [f32; 3],
    #[serde(default = "one")]
    scale: f32,
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
enum LightSpec {
    Point {
        position: [f32; 3],
        #[serde(default = "white")]
        color: [f32; 3],
        #[serde(default = "default_power")]
        power: f32,
    },
    Quad {
        corner: [f32; 3],
        u: [f32; 3],
        v: [f32; 3],
        #[serde(default = "white")]
        color: [f32; 3],
        #[serde(default = "default_power")]
        power: f32,
    },
}

fn default_power() -> f32 {
    100.0
}

/// The Levenshtein distance of two short words: what the suggestions of scene-file errors
/// (and of the `isir` command's) measure a typo by.
#[must_use]
pub fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for j in 0..b.len() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != b[j])).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// The nearest of `choices` to `word`, if near enough to be a typo.
fn nearest<'a>(word: &str, choices: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    choices.into_iter().map(|c| (edit_distance(word, c), c)).filter(|&(d, c)| d <= (c.len().max(2) / 2).max(1)).min().map(|(_, c)| c)
}

/// Read and parse the scene file `path` (within the input limit).
///
/// # Errors
/// The file cannot be read, or is not a valid scene (see [`parse_scene`]).
pub fn load_scene_file(path: &Path) -> Result<SceneFile> {
    let limits = ReadLimits::from_env().map_err(|message| Error::Input { path: path.to_path_buf(), message })?;
    let bytes = input::read_file(path, &limits)?;
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        // Where, as a line and column (the bytes before it are text).
        let before = &bytes[..e.valid_up_to()];
        let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
        let line_start = before.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        let col = String::from_utf8_lossy(&before[line_start..]).chars().count() + 1;
        let byte = bytes[e.valid_up_to()];
        Error::Input {
            path: path.to_path_buf(),
            message: format!("line {line}, column {col}: byte 0x{byte:02x} is not UTF-8 text (save the file as UTF-8)"),
        }
    })?;
    parse_scene(path, text)
}

/// Parse the text of a scene file; `path` names it in errors and mesh files are looked up
/// beside it.
///
/// # Errors
/// Not TOML, an unknown key or value, a wrong type, a material name not defined: the
/// error names the file, line and column, quotes the line and suggests the nearest key.
pub fn parse_scene(path: &Path, text: &str) -> Result<SceneFile> {
    let at = |span: Option<std::ops::Range<usize>>, message: String| {
        let (line, col, quoted) = match span {
            Some(s) => {
                let start = s.start.min(text.len());
                let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
                let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
                let line = text[..start].matches('\n').count() + 1;
                let col = text[line_start..start].chars().count() + 1;
                let quoted: String = text[line_start..line_end].trim_end().chars().take(100).collect();
                (Some(line), col, format!(" — `{quoted}`"))
            }
            None => (None, 0, String::new()),
        };
        let position = line.map_or(String::new(), |l| format!(":{l}:{col}"));
        Error::Scene(format!("{}{position}: {message}{quoted}", path.display()))
    };
    let file: File = toml::from_str(text).map_err(|e| {
        let mut message = e.message().trim().replace('\n', " ");
        let mut span = e.span();
        // serde: "unknown field `colour`, expected one of `type`, `color`": suggest, and
        // point at the key itself (inside a tagged table serde only knows the table).
        if let Some(rest) = message.strip_prefix("unknown field `") {
            if let Some((word, expected)) = rest.split_once('`') {
                let choices: Vec<&str> = expected.split('`').skip(1).step_by(2).collect();
                let hint = nearest(word, choices).map(|n| format!(" (did you mean `{n}`?)"));
                let from = span.as_ref().map_or(0, |s| s.start.min(text.len()));
                let mut offset = from;
                for line in text[from..].split_inclusive('\n') {
                    let key = line.trim_start();
                    if key.starts_with(word) && key[word.len()..].trim_start().starts_with('=') {
                        let at = offset + (line.len() - key.len());
                        span = Some(at..at + word.len());
                        break;
                    }
                    offset += line.len();
                }
                if let Some(h) = hint {
                    message.push_str(&h);
                }
            }
        }
        if let Some(rest) = message.strip_prefix("unknown variant `") {
            if let Some((word, expected)) = rest.split_once('`') {
                let choices: Vec<&str> = expected.split('`').skip(1).step_by(2).collect();
                if let Some(n) = nearest(word, choices) {
                    message.push_str(&format!(" (did you mean `{n}`?)"));
                }
            }
        }
        at(span, message)
    })?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let c = |a: [f32; 3]| Vec3::from(a);
    let name = path.file_stem().map_or_else(|| "scene".to_string(), |s| s.to_string_lossy().into_owned());
    let default_camera = CameraSection::default();
    let cam = file.camera.as_ref().map_or(&default_camera, Spanned::get_ref);
    let mut camera = CameraDesc::new(c(cam.position.unwrap_or([0.0, 0.0, 0.0])), c(cam.look_at.unwrap_or([0.0, 0.0, 1.0])));
    if let Some(u) = cam.up {
        camera.up = c(u);
    }
    if let Some(f) = cam.fovy {
        camera.fovy = f;
    }
    let mut d = SceneDescription::new(&name, camera);
    d.summary = format!("scene file {}", path.display());
    let r = &file.render;
    // The numbers `render` and the CLI refuse, refused here with their line (`isir check`
    // too): a bounce limit of billions ran a mirror corridor out of memory.
    let value = |v: &Option<Spanned<u32>>| v.as_ref().map(|v| *v.get_ref());
    for (key, v) in [("spp", &r.spp), ("light_samples", &r.light_samples)] {
        if let Some(v) = v.as_ref().filter(|v| *v.get_ref() == 0) {
            return Err(at(Some(v.span()), format!("{key} 0: must be at least 1")));
        }
    }
    if let Some(v) = r.max_depth.as_ref().filter(|v| !(1..=MAX_DEPTH_LIMIT).contains(v.get_ref())) {
        let message = format!("max_depth {}: must be between 1 and {MAX_DEPTH_LIMIT} (bounces along a path)", v.get_ref());
        return Err(at(Some(v.span()), message));
    }
    let (width, height) = (value(&r.width), value(&r.height));
    if let Err(Error::Scene(message)) = crate::io::image::check_size(width.unwrap_or(600), height.unwrap_or(400)) {
        return Err(at(r.width.as_ref().or(r.height.as_ref()).map(Spanned::span), message));
    }
    d.spp = value(&r.spp).unwrap_or(1);
    d.background = r.background.map_or(GREY, c);
    if let Some(display) = &r.display {
        d.display = match display.get_ref().as_str() {
            "srgb" => Display::Srgb,
            "linear-clamp" => Display::LinearClamp,
            other => {
                let hint = nearest(other, ["srgb", "linear-clamp"]).map_or(String::new(), |n| format!(" (did you mean `{n}`?)"));
                return Err(at(Some(display.span()), format!("display `{other}`: expected `srgb` or `linear-clamp`{hint}")));
            }
        };
    }
    let light_samples = value(&r.light_samples).unwrap_or(1);
    let max_depth = value(&r.max_depth).unwrap_or(DEFAULT_MAX_DEPTH);
    d.integrator = match r.integrator.as_ref().map(|s| (s.get_ref().as_str(), s.span())) {
        None | Some(("direct", _)) => Integrator::DirectLighting { light_samples },
        Some(("ray-cast", _)) => Integrator::RayCast,
        Some(("whitted", _)) => Integrator::Whitted { light_samples, max_depth },
        Some(("path", _)) => Integrator::Path { light_samples, max_depth },
        Some((other, span)) => {
            let names = ["ray-cast", "direct", "whitted", "path"];
            let hint = nearest(other, names).map_or(String::new(), |n| format!(" (did you mean `{n}`?)"));
            return Err(at(Some(span), format!("integrator `{other}`: expected one of ray-cast, direct, whitted, path{hint}")));
        }
    };
    if let Err(Error::Scene(message)) = d.camera.validate() {
        return Err(at(file.camera.as_ref().map(Spanned::span), message));
    }
    for (n, m) in &file.materials {
        let material = match *m.get_ref() {
            MaterialSpec::Color { color } => Material::Color(c(color)),
            MaterialSpec::Lambert { color } => Material::Lambert(c(color)),
            MaterialSpec::Matte { color, sigma } => Material::Matte { kd: c(color), sigma },
            MaterialSpec::Plastic { color, specular, shininess, blinn } => {
                Material::Plastic { kd: c(color), ks: c(specular), shininess, blinn }
            }
            MaterialSpec::CookTorrance { color, f0, roughness, metalness } => {
                Material::CookTorrance { kd: c(color), f0: f0.map_or(c(color), c), roughness, metalness }
            }
            MaterialSpec::Mirror {} => Material::Mirror,
            MaterialSpec::Transparent { ior } => Material::Transparent { ior },
        };
        if let Err(why) = material.check() {
            return Err(at(Some(m.span()), format!("material `{n}`: {why}")));
        }
        d.materials.push((n.clone(), material));
    }
    // Where `key = "value"` is written (serde keeps no spans inside tagged tables).
    let span_of = |key: &str, value: &str| {
        let quoted = format!("\"{value}\"");
        let mut offset = 0;
        for line in text.split_inclusive('\n') {
            if line.trim_start().starts_with(key) || line.contains(&format!("{key} =")) || line.contains(&format!("{key}=")) {
                if let Some(i) = line.find(&quoted) {
                    return Some(offset + i..offset + i + quoted.len());
                }
            }
            offset += line.len();
        }
        None
    };
    let material_ref = |m: &Option<String>| -> Result<Option<String>> {
        let Some(m) = m else { return Ok(None) };
        if file.materials.contains_key(m) {
            return Ok(Some(m.clone()));
        }
        let hint = nearest(m, file.materials.keys().map(String::as_str)).map_or(String::new(), |n| format!(" (did you mean `{n}`?)"));
        Err(at(span_of("material", m), format!("material `{m}` is not defined in [materials]{hint}")))
    };
    for (i, o) in file.objects.iter().enumerate() {
        let (name, shape, material) = match o.get_ref() {
            ObjectSpec::Plane { name, point, normal, material } => {
                // The normal as written (`Plane::new` normalises it: too short, it is NaN).
                if !(c(*normal).is_finite() && c(*normal).length_squared().is_normal()) {
                    let name = name.clone().unwrap_or_else(|| format!("object{}", i + 1));
                    return Err(at(Some(o.span()), format!("object '{name}': a plane's normal {normal:?} cannot be normalised")));
                }
                (name.clone(), ShapeDesc::Plane(Plane::new(c(*point), c(*normal))), material_ref(material)?)
            }
            ObjectSpec::Sphere { name, center, radius, material } => {
                (name.clone(), ShapeDesc::Sphere(Sphere::new(c(*center), *radius)), material_ref(material)?)
            }
            ObjectSpec::Implicit { name, sdf, material } => (name.clone(), ShapeDesc::Implicit(sdf.to_sdf()), material_ref(material)?),
            ObjectSpec::Mesh { name, file: mesh_file, model, flat, material, transform } => {
                let source = match (mesh_file, model) {
                    (Some(f), None) => MeshSource::File(dir.join(f)),
                    (None, Some(m)) => {
                        let models = super::builtin_models();
                        match models.iter().find(|&&b| b == m) {
                            Some(&b) => MeshSource::Builtin(b),
                            None => {
                                let hint = nearest(m, models.iter().copied()).map_or(String::new(), |n| format!(" (did you mean `{n}`?)"));
                                return Err(at(span_of("model", m), format!("no built-in model `{m}` ({}){hint}", models.join(", "))));
                            }
                        }
                    }
                    _ => return Err(Error::Scene(format!("{}: object {}: a mesh needs either `file` or `model`", path.display(), i + 1))),
                };
                let shading = if *flat { Shading::Flat } else { Shading::Smooth };
                let shape = match transform {
                    None => ShapeDesc::Mesh { source, shading },
                    Some(t) => ShapeDesc::MeshInstance {
                        source,
                        shading,
                        transform: Transform { translate: c(t.translate), rotate: c(t.rotate), scale: t.scale },
                    },
                };
                (name.clone(), shape, material_ref(material)?)
            }
        };
        let object = ObjectDesc { name: name.unwrap_or_else(|| format!("object{}", i + 1)), shape, material };
        if let Err(why) = object.shape.check() {
            return Err(at(Some(o.span()), format!("object '{}': {why}", object.name)));
        }
        d.objects.push(object);
    }
    for (i, l) in file.lights.iter().enumerate() {
        let light = match *l.get_ref() {
            LightSpec::Point { position, color, power } => Light::Point { position: c(position), color: c(color), power },
            LightSpec::Quad { corner, u, v, color, power } => Light::Quad { corner: c(corner), u: c(u), v: c(v), color: c(color), power },
        };
        if let Err(why) = light.check() {
            return Err(at(Some(l.span()), format!("light {}: {why}", i + 1)));
        }
        d.lights.push(light);
    }
    Ok(SceneFile { description: d, width, height })
}

/// The scene file of a description (what [`parse_scene`] reads back to the same scene),
/// for `size` = `(width, height)`; `None` when the scene holds what files cannot say yet
/// (mesh files given by path, textured materials: built-in models only).
#[must_use]
pub fn to_toml(d: &SceneDescription, size: (u32, u32)) -> Option<String> {
    // Shortest round-trip form of each float, in TOML syntax.
    let f = |x: f32| {
        let s = format!("{x:?}");
        // Integers as integers (`2`, not `2.0`), but -0.0 keeps its sign.
        if x == 0.0 && x.is_sign_negative() {
            return s;
        }
        s.strip_suffix(".0").map_or(s.clone(), str::to_string)
    };
    let v = |a: Vec3| format!("[{}, {}, {}]", f(a.x), f(a.y), f(a.z));
    let mut out = format!("# {}\n# {}\n\n[render]\n", d.name, d.summary);
    out += &format!("width = {}\nheight = {}\nspp = {}\n", size.0, size.1, d.spp);
    let (integrator, ls, depth) = match d.integrator {
        Integrator::RayCast => ("ray-cast", None, None),
        Integrator::DirectLighting { light_samples } => ("direct", Some(light_samples), None),
        Integrator::Whitted { light_samples, max_depth } => ("whitted", Some(light_samples), Some(max_depth)),
        Integrator::Path { light_samples, max_depth } => ("path", Some(light_samples), Some(max_depth)),
    };
    out += &format!("integrator = \"{integrator}\"\n");
    if let Some(n) = ls {
        out += &format!("light_samples = {n}\n");
    }
    if let Some(n) = depth {
        out += &format!("max_depth = {n}\n");
    }
    out += &format!(
        "display = \"{}\"\nbackground = {}\n\n",
        if d.display == Display::Srgb { "srgb" } else { "linear-clamp" },
        v(d.background)
    );
    let c = &d.camera;
    out += &format!(
        "[camera]\nposition = {}\nlook_at = {}\nup = {}\nfovy = {}\n\n[materials]\n",
        v(c.position),
        v(c.look_at),
        v(c.up),
        f(c.fovy)
    );
    for (n, m) in &d.materials {
        let spec = match m {
            Material::Color(k) => format!("type = \"color\", color = {}", v(*k)),
            Material::Lambert(k) => format!("type = \"lambert\", color = {}", v(*k)),
            Material::Matte { kd, sigma } => format!("type = \"matte\", color = {}, sigma = {}", v(*kd), f(*sigma)),
            Material::Plastic { kd, ks, shininess, blinn } => {
                format!("type = \"plastic\", color = {}, specular = {}, shininess = {}, blinn = {blinn}", v(*kd), v(*ks), f(*shininess))
            }
            Material::CookTorrance { kd, f0, roughness, metalness } => format!(
                "type = \"cook-torrance\", color = {}, f0 = {}, roughness = {}, metalness = {}",
                v(*kd),
                v(*f0),
                f(*roughness),
                f(*metalness)
            ),
            Material::Mirror => "type = \"mirror\"".to_string(),
            Material::Transparent { ior } => format!("type = \"transparent\", ior = {}", f(*ior)),
            Material::Textured { .. } => return None,
        };
        out += &format!("{n} = {{ {spec} }}\n");
    }
    for o in &d.objects {
        out += &format!("\n[[objects]]\nname = \"{}\"\n", o.name);
        match &o.shape {
            ShapeDesc::Plane(p) => out += &format!("type = \"plane\"\npoint = {}\nnormal = {}\n", v(p.point), v(p.normal)),
            ShapeDesc::Sphere(s) => out += &format!("type = \"sphere\"\ncenter = {}\nradius = {}\n", v(s.center), f(s.radius)),
            ShapeDesc::Implicit(sdf) => out += &format!("type = \"implicit\"\nsdf = {}\n", sdf_toml(sdf, &f)),
            ShapeDesc::Mesh { source: MeshSource::Builtin(m), shading } => {
                out += &format!("type = \"mesh\"\nmodel = \"{m}\"\n");
                if *shading == Shading::Flat {
                    out += "flat = true\n";
                }
            }
            _ => return None,
        }
        if let Some(m) = &o.material {
            out += &format!("material = \"{m}\"\n");
        }
    }
    for l in &d.lights {
        out += &match *l {
            Light::Point { position, color, power } => {
                format!("\n[[lights]]\ntype = \"point\"\nposition = {}\ncolor = {}\npower = {}\n", v(position), v(color), f(power))
            }
            Light::Quad { corner, u, v: w, color, power } => format!(
                "\n[[lights]]\ntype = \"quad\"\ncorner = {}\nu = {}\nv = {}\ncolor = {}\npower = {}\n",
                v(corner),
                v(u),
                v(w),
                v(color),
                f(power)
            ),
        };
    }
    Some(out)
}
