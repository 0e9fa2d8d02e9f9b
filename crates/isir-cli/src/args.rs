//! What a scene, mesh or output argument names, so that a file given to the wrong
//! command, a misspelt scene and an output that would replace an input are each said
//! plainly before any work.

use std::path::{Path, PathBuf};

/// What an argument is, by its extension, or by a built-in name when no such file exists.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A scene file (`.toml`).
    SceneFile,
    /// A mesh file (`.obj`, `.ply`, `.gltf`, `.glb`, optionally `.gz`).
    MeshFile,
    /// An image (`.png`, `.exr`, `.jpg`): an output of `isir render`.
    Image,
    /// A ray file (`.rays`): an output of `isir rays`.
    RayFile,
    /// A hit file (`.hits`): an output of `isir trace --hits`.
    HitFile,
    /// The name of a built-in scene (`isir scenes`), no file of that name existing.
    BuiltinScene,
    /// The name of a built-in model (`uvsphere`, `Bunny`, `conference`), no file of that
    /// name existing.
    BuiltinModel,
    /// None of these: a file of another or no extension, or a name that is nothing.
    Other,
}

/// The built-in scenes' names.
pub fn scene_names() -> Vec<&'static str> {
    isir::scenes::list().into_iter().map(|(n, _)| n).collect()
}

/// What `arg` names.
pub fn kind(arg: &str) -> Kind {
    let lower = arg.to_ascii_lowercase();
    let bare = lower.strip_suffix(".gz").unwrap_or(&lower);
    let has = |exts: &[&str]| exts.iter().any(|e| bare.ends_with(e));
    if has(&[".toml"]) && !lower.ends_with(".gz") {
        return Kind::SceneFile;
    }
    if has(&[".obj", ".ply", ".gltf", ".glb"]) {
        return Kind::MeshFile;
    }
    if has(&[".png", ".exr", ".jpg", ".jpeg"]) {
        return Kind::Image;
    }
    if has(&[".rays"]) {
        return Kind::RayFile;
    }
    if has(&[".hits"]) {
        return Kind::HitFile;
    }
    if !Path::new(arg).exists() {
        if scene_names().contains(&arg) {
            return Kind::BuiltinScene;
        }
        if isir::scenes::builtin_models().contains(&arg) {
            return Kind::BuiltinModel;
        }
    }
    Kind::Other
}

/// The nearest of `choices` to `word` (in any letters), if near enough to be a typo: at
/// most a third of its letters off (one at least, three at most).
pub fn nearest<'a>(word: &str, choices: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let word = word.to_lowercase();
    choices
        .into_iter()
        .map(|c| (isir::scenes::edit_distance(&word, &c.to_lowercase()), c))
        .filter(|&(d, c)| d <= (c.chars().count() / 3).clamp(1, 3))
        .min()
        .map(|(_, c)| c)
}

/// The built-in model `name` is, in these letters or others (`bunny` for `Bunny`).
fn builtin_model(name: &str) -> Option<&'static str> {
    isir::scenes::builtin_models().into_iter().find(|m| m.eq_ignore_ascii_case(name))
}

/// The built-in scenes that show the built-in model `model`.
fn scenes_with_model(model: &str) -> Vec<&'static str> {
    use isir::scenes::{MeshSource, ShapeDesc};
    scene_names()
        .into_iter()
        .filter(|n| {
            isir::scenes::builtin(n).is_ok_and(|d| {
                d.objects.iter().any(|o| match &o.shape {
                    ShapeDesc::Mesh { source: MeshSource::Builtin(m), .. }
                    | ShapeDesc::MeshInstance { source: MeshSource::Builtin(m), .. } => *m == model,
                    _ => false,
                })
            })
        })
        .collect()
}

/// "`a`", "`a` and `b`", "`a`, `b` and `c`".
fn both(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
    match quoted.split_last() {
        None => String::new(),
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
    }
}

/// The error for `name`, given where a scene is expected (`isir render`, `isir rays`,
/// `isir bench`) and found neither as a built-in scene nor as a file: a built-in model
/// says which scenes show it; a near miss says the scene meant.
pub fn unknown_scene(name: &str) -> anyhow::Error {
    if let Some(model) = builtin_model(name) {
        let scenes = scenes_with_model(model);
        let shown = match scenes.as_slice() {
            [] => String::new(),
            [one] => format!("the built-in scene `{one}` shows it (`isir render {one}`), and "),
            [first, ..] => format!("the built-in scenes {} show it (`isir render {first}`), and ", both(&scenes)),
        };
        return anyhow::anyhow!("'{name}' is a built-in model, not a scene: {shown}a scene file can place it with `model = \"{model}\"`");
    }
    match nearest(name, scene_names()) {
        Some(n) => anyhow::anyhow!("unknown scene '{name}' (did you mean `{n}`? `isir scenes` lists them)"),
        None => anyhow::anyhow!("unknown scene '{name}' (`isir scenes` lists them; or give a scene file, .toml, or a mesh file)"),
    }
}

/// Refuse, for a command that reads a mesh (`isir info`, `isir trace`), an argument that
/// is a scene file, a built-in scene or another command's output.
pub fn check_mesh_arg(arg: &str) -> anyhow::Result<()> {
    match kind(arg) {
        Kind::SceneFile => anyhow::bail!("{arg} is a scene file, not a mesh: `isir check` or `isir render` read it"),
        Kind::BuiltinScene => anyhow::bail!(
            "{arg} is a built-in scene, not a mesh: `isir render {arg}` renders it (the built-in models are {})",
            isir::scenes::builtin_models().join(", ")
        ),
        Kind::Image => anyhow::bail!("{arg} is an image, not a mesh (a mesh file is .obj, .ply, .gltf or .glb, optionally .gz)"),
        Kind::RayFile => anyhow::bail!("{arg} is a ray file, not a mesh: `isir trace MESH {arg}` traces it"),
        Kind::HitFile => anyhow::bail!("{arg} is a hit file (written by `isir trace --hits`), not a mesh"),
        Kind::MeshFile | Kind::BuiltinModel | Kind::Other => Ok(()),
    }
}

/// Refuse, for `isir check` (scene files only), a mesh file, a built-in scene or model, or
/// another command's output; and name the scene meant by a near miss that is no file.
pub fn check_scene_file_arg(arg: &str) -> anyhow::Result<()> {
    match kind(arg) {
        Kind::MeshFile => anyhow::bail!("{arg} is a mesh, not a scene file: `isir info` describes it, `isir render` renders it"),
        Kind::BuiltinScene => {
            anyhow::bail!("{arg} is a built-in scene, not a scene file: `isir render {arg}` renders it (`isir check` reads .toml files)")
        }
        Kind::BuiltinModel => anyhow::bail!("{arg} is a built-in model, not a scene file: `isir info {arg}` describes it"),
        Kind::Image => anyhow::bail!("{arg} is an image, not a scene file (.toml)"),
        Kind::RayFile => anyhow::bail!("{arg} is a ray file, not a scene file: `isir trace MESH {arg}` traces it"),
        Kind::HitFile => anyhow::bail!("{arg} is a hit file (written by `isir trace --hits`), not a scene file"),
        Kind::SceneFile => Ok(()),
        Kind::Other => {
            if !Path::new(arg).exists() {
                if let Some(model) = builtin_model(arg) {
                    anyhow::bail!(
                        "{arg}: no such file, and the built-in model '{model}' is no scene file: `isir info {model}` describes it"
                    );
                }
                if let Some(n) = nearest(arg, scene_names()) {
                    anyhow::bail!("{arg}: no such file (did you mean the built-in scene `{n}`? `isir render {n}` renders it)");
                }
            }
            Ok(())
        }
    }
}

/// Refuse, where a scene is expected (`isir render`, `isir rays`, `isir bench`), another
/// command's output (an image, a ray or hit file) given in its place.
pub fn check_scene_arg(arg: &str) -> anyhow::Result<()> {
    match kind(arg) {
        Kind::Image => anyhow::bail!("{arg} is an image, not a scene: give a built-in scene (`isir scenes`), a scene file or a mesh file"),
        Kind::RayFile => anyhow::bail!("{arg} is a ray file, not a scene: `isir trace MESH {arg}` traces it"),
        Kind::HitFile => anyhow::bail!("{arg} is a hit file (written by `isir trace --hits`), not a scene"),
        _ => Ok(()),
    }
}

/// The files a scene argument reads: a scene file and the mesh files it names, or a mesh
/// file; none for a built-in scene. Those that do not exist are left out.
///
/// # Errors
/// A scene file that cannot be read or parsed (the error the render would give).
pub fn scene_inputs(arg: &str) -> anyhow::Result<Vec<(String, PathBuf)>> {
    use isir::scenes::{MeshSource, ShapeDesc};
    let mut inputs = Vec::new();
    match kind(arg) {
        Kind::BuiltinScene | Kind::BuiltinModel => {}
        Kind::SceneFile => {
            inputs.push(("the scene file".to_string(), PathBuf::from(arg)));
            let file = isir::scenes::load_scene_file(Path::new(arg))?;
            for o in &file.description.objects {
                if let ShapeDesc::Mesh { source: MeshSource::File(p), .. } | ShapeDesc::MeshInstance { source: MeshSource::File(p), .. } =
                    &o.shape
                {
                    inputs.push(("the scene's mesh".to_string(), p.clone()));
                }
            }
        }
        _ => inputs.push(("the mesh".to_string(), PathBuf::from(arg))),
    }
    inputs.retain(|(_, p)| p.exists());
    Ok(inputs)
}

/// True when `a` and `b` are one existing file (the same device and inode: through a
/// symbolic or hard link, or another spelling of the path, too).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (std::fs::metadata(a), std::fs::metadata(b)) {
            (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        match (a.canonicalize(), b.canonicalize()) {
            (Ok(x), Ok(y)) => x == y,
            _ => false,
        }
    }
}

/// Refuse an output (`option` names it: `-o`, `--hits`) that is one of the inputs (`what`,
/// its path): writing it would replace the input.
/// `files` as inputs of [`check_not_an_input`], each "a file the `reader` reads" (what a
/// scene's or a mesh's loading read besides the mesh: material libraries, textures, glTF
/// buffers).
pub fn read_by(reader: &str, files: &[PathBuf]) -> Vec<(String, PathBuf)> {
    files.iter().map(|p| (format!("a file the {reader} reads,"), p.clone())).collect()
}

pub fn check_not_an_input(option: &str, output: &Path, inputs: &[(String, PathBuf)]) -> anyhow::Result<()> {
    for (what, input) in inputs {
        if same_file(output, input) {
            anyhow::bail!(
                "{option} {}: the same file as {what} {}: writing it would replace an input (choose another output file)",
                output.display(),
                input.display()
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_misses_are_suggested_and_far_ones_are_not() {
        let names = scene_names();
        assert_eq!(nearest("tp4-buny", names.iter().copied()), Some("tp4-bunny"));
        assert_eq!(nearest("TP4-Bunny", names.iter().copied()), Some("tp4-bunny"));
        assert_eq!(nearest("tp4-conferense", names.iter().copied()), Some("tp4-conference"));
        assert_eq!(nearest("tp5-nothing", names.iter().copied()), None);
        assert_eq!(nearest("x", names.iter().copied()), None);
    }

    #[test]
    fn arguments_are_told_apart_by_extension_and_built_in_names() {
        assert_eq!(kind("a/b.toml"), Kind::SceneFile);
        assert_eq!(kind("B.OBJ"), Kind::MeshFile);
        assert_eq!(kind("x.ply.gz"), Kind::MeshFile);
        assert_eq!(kind("x.glb"), Kind::MeshFile);
        assert_eq!(kind("out.png"), Kind::Image);
        assert_eq!(kind("p.rays"), Kind::RayFile);
        assert_eq!(kind("tp4-bunny"), Kind::BuiltinScene);
        assert_eq!(kind("Bunny"), Kind::BuiltinModel);
        assert_eq!(kind("something-else"), Kind::Other);
    }

    #[test]
    fn a_built_in_model_names_the_scenes_that_show_it() {
        let e = unknown_scene("Bunny").to_string();
        assert!(e.contains("built-in model") && e.contains("`isir render tp4-bunny`") && e.contains("model = \"Bunny\""), "{e}");
        let e = unknown_scene("uvsphere").to_string();
        assert!(e.contains("scenes `tp4-sphere-flat` and `tp4-sphere` show it"), "{e}");
        assert_eq!(both(&["a", "b", "c"]), "`a`, `b` and `c`");
    }
}
