//! Scene files (docs/scene-format.md): the example of the documentation renders as
//! written, every built-in scene's file renders its pixels, errors name the file, line and
//! column with the nearest valid word, and no input makes the parser panic.

use isir::scenes::{self, parse_scene, to_toml};
use isir::{Accel, Renderer};
use proptest::prelude::*;
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn render(desc: &isir::SceneDescription) -> Vec<isir::Color> {
    let scene = desc.build(Accel::BvhSah).unwrap();
    let r = Renderer::new(48, 32).spp(1);
    r.render(&scene, &desc.camera.build(r.aspect()), &desc.integrator).0.pixels
}

#[test]
fn every_builtin_scene_file_is_its_export_and_renders_its_pixels() {
    let mut checked = 0;
    for (name, _) in scenes::list() {
        let desc = scenes::builtin(name).unwrap();
        let Some(text) = to_toml(&desc, (600, 400)) else { continue };
        let path = repo().join("scenes").join(format!("{name}.toml"));
        let shipped = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (cargo run -p isir --example export_scenes)", path.display()));
        assert_eq!(shipped, text, "{name}.toml differs from its built-in scene: re-run the export_scenes example");
        let file = parse_scene(&path, &shipped).unwrap();
        assert_eq!((file.width, file.height), (Some(600), Some(400)));
        assert_eq!(file.description.objects, desc.objects, "{name}");
        assert_eq!(file.description.lights, desc.lights, "{name}");
        assert_eq!(file.description.integrator, desc.integrator, "{name}");
        assert_eq!(render(&file.description), render(&desc), "{name}: the file renders other pixels than the built-in scene");
        checked += 1;
    }
    assert_eq!(checked, scenes::list().len(), "every built-in scene is expressible as a file");
}

#[test]
fn the_documented_example_renders_as_written() {
    let path = repo().join("scenes/example.toml");
    let file = scenes::load_scene_file(&path).unwrap();
    let d = &file.description;
    assert_eq!((file.width, file.height, d.spp), (Some(600), Some(400), 16));
    assert_eq!(d.integrator, isir::Integrator::Path { light_samples: 8, max_depth: 5 });
    assert_eq!(d.display, isir::Display::Srgb);
    assert_eq!((d.objects.len(), d.materials.len(), d.lights.len()), (3, 4, 2));
    assert!(matches!(d.objects[2].shape, isir::scenes::ShapeDesc::MeshInstance { .. }));
    let pixels = render(d);
    assert!(pixels.iter().all(|c| c.is_finite()));
    // The example of the documentation is this file.
    let doc = std::fs::read_to_string(repo().join("docs/scene-format.md")).unwrap();
    assert!(doc.contains("type = \"cook-torrance\", color = [1, 0.85, 0.57], roughness = 0.3, metalness = 1"));
}

/// The views of `tools/bench-views/` (other rays than the TP4 camera's for `isir bench`)
/// are the conference room under its TP4 light, seen from elsewhere, and render.
#[test]
fn the_bench_views_are_the_conference_room_seen_from_elsewhere() {
    let tp4 = scenes::builtin("tp4-conference").unwrap();
    let mut views = 0;
    for entry in std::fs::read_dir(repo().join("tools/bench-views")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let file = scenes::load_scene_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let d = &file.description;
        assert_eq!(d.objects, tp4.objects, "{}", path.display());
        assert_eq!(d.lights, tp4.lights, "{}", path.display());
        assert_ne!(d.camera.position, tp4.camera.position, "{}", path.display());
        // Pixels that show the room: neither the background (rays that miss) nor black.
        let pixels = render(d);
        let lit = pixels.iter().filter(|c| **c != d.background && c.max_element() > 0.0).count();
        assert!(lit > pixels.len() / 4, "{}: {lit} of {} pixels show the lit room", path.display(), pixels.len());
        views += 1;
    }
    assert_eq!(views, 3);
}

#[test]
fn a_missing_key_takes_the_course_default() {
    let f = parse_scene(Path::new("empty.toml"), "").unwrap();
    let d = &f.description;
    assert_eq!((f.width, f.height), (None, None));
    assert_eq!(d.camera.fovy, 60.0);
    assert_eq!(d.camera.position, isir::Vec3::ZERO);
    assert_eq!(d.background, isir::Vec3::splat(0.5));
    assert_eq!(d.display, isir::Display::LinearClamp);
    let f = parse_scene(Path::new("s.toml"), "[[objects]]\ntype = \"sphere\"\n").unwrap();
    assert_eq!(f.description.objects[0].shape, isir::scenes::ShapeDesc::Sphere(isir::Sphere::new(isir::Vec3::ZERO, 1.0)));
}

#[test]
fn errors_name_the_file_line_and_column_and_suggest_the_nearest_word() {
    let ok = "[materials]\nglass = { type = \"transparent\" }\n\n[[objects]]\ntype = \"sphere\"\nmaterial = \"glass\"\n";
    assert!(parse_scene(Path::new("s.toml"), ok).is_ok());
    let cases = [
        (ok.replace("type = \"sphere\"", "type = \"sphere\"\nradious = 2"), "s.toml:6:1", "did you mean `radius`?"),
        (
            ok.replace("material = \"glass\"", "material = \"glas\""),
            "s.toml:6:12",
            "material `glas` is not defined in [materials] (did you mean `glass`?)",
        ),
        (ok.replace("\"transparent\"", "\"transparant\""), "s.toml:2:", "did you mean `transparent`?"),
        (format!("[render]\nintegrator = \"whited\"\n{ok}"), "s.toml:2:14", "(did you mean `whitted`?)"),
        (ok.replace("type = \"sphere\"", "type = \"sphere\"\nradius = \"big\""), "s.toml:", "invalid type"),
        ("[render\nwidth = 3".to_string(), "s.toml:1:", ""),
        ("[[objects]]\ntype = \"mesh\"\nmodel = \"bunny\"\n".to_string(), "s.toml:3:9", "(did you mean `Bunny`?)"),
    ];
    for (text, place, hint) in cases {
        let e = parse_scene(Path::new("s.toml"), &text).unwrap_err().to_string();
        assert!(e.contains(place) && e.contains(hint), "expected '{place}' and '{hint}' in: {e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}

/// What `render` or the CLI would refuse, or render as nonsense, is refused with its line
/// (so `isir check` says so too): the render numbers, the camera, each material, object
/// and light. A bounce limit of billions ran a mirror corridor out of memory.
#[test]
fn values_out_of_range_are_refused_with_their_line() {
    let ok = "[render]\nspp = 4\n\n[camera]\nfovy = 50\n\n[materials]\nm = { type = \"transparent\", ior = 1.5 }\n\n\
              [[objects]]\ntype = \"sphere\"\nradius = 1\nmaterial = \"m\"\n\n[[lights]]\ntype = \"point\"\nposition = [0, 2, 0]\npower = 10\n";
    if let Err(e) = parse_scene(Path::new("s.toml"), ok) {
        panic!("{e}");
    }
    let cases = [
        ("spp = 4", "spp = 0", "s.toml:2:7", "spp 0: must be at least 1"),
        ("spp = 4", "light_samples = 0", "s.toml:2:17", "light_samples 0: must be at least 1"),
        ("spp = 4", "max_depth = 4000000000", "s.toml:2:13", "max_depth 4000000000: must be between 1 and 256"),
        ("spp = 4", "max_depth = 0", "s.toml:2:13", "must be between 1 and 256"),
        ("spp = 4", "width = 0", "s.toml:2:9", "width and height must be at least 1"),
        ("spp = 4", "width = 100000\nheight = 100000", "s.toml:2:9", "more than the 268435456"),
        ("fovy = 50", "fovy = 0", "s.toml:4:1", "camera: fovy 0 must be between 0 and 180"),
        ("ior = 1.5", "ior = nan", "s.toml:8:5", "material `m`: ior NaN must be finite and above 0"),
        (
            "type = \"transparent\", ior = 1.5",
            "type = \"cook-torrance\", roughness = 0",
            "s.toml:8:",
            "roughness 0 must be finite and above 0",
        ),
        (
            "type = \"transparent\", ior = 1.5",
            "type = \"cook-torrance\", metalness = 2",
            "s.toml:8:",
            "metalness 2 must be between 0 and 1",
        ),
        (
            "type = \"transparent\", ior = 1.5",
            "type = \"lambert\", color = [1, -1, 1]",
            "s.toml:8:",
            "color [1, -1, 1] must be finite and not negative",
        ),
        (
            "type = \"transparent\", ior = 1.5",
            "type = \"plastic\", shininess = inf",
            "s.toml:8:",
            "shininess inf must be finite and at least 0",
        ),
        ("radius = 1", "radius = 0", "s.toml:10:1", "object 'object1': a sphere needs a finite centre and a positive radius"),
        (
            "type = \"sphere\"\nradius = 1",
            "type = \"plane\"\nnormal = [0, 1e-30, 0]",
            "s.toml:10:1",
            "a plane's normal [0.0, 1e-30, 0.0] cannot be normalised",
        ),
        ("power = 10", "power = -5", "s.toml:15:1", "light 1: power -5 and colour [1, 1, 1] must not be negative"),
        (
            "type = \"point\"\nposition = [0, 2, 0]",
            "type = \"quad\"\ncorner = [0, 2, 0]\nu = [0, 0, 0]\nv = [1, 0, 0]",
            "s.toml:15:1",
            "span no area",
        ),
    ];
    for (from, to, place, message) in cases {
        assert!(ok.contains(from), "{from}");
        let text = ok.replacen(from, to, 1);
        let e = parse_scene(Path::new("s.toml"), &text).unwrap_err().to_string();
        assert!(e.contains(place) && e.contains(message), "expected '{place}' and '{message}' in: {e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}

/// A scene file that is not UTF-8 (Latin-1 from an old editor) is refused at the line and
/// column of its first such byte.
#[test]
fn a_file_not_in_utf8_names_the_line_and_column() {
    let dir = std::env::temp_dir().join(format!("isir-latin1-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("latin.toml");
    std::fs::write(&path, b"[render]\nspp = 4\n# caf\xe9\n").unwrap();
    let e = scenes::load_scene_file(&path).unwrap_err().to_string();
    assert!(e.contains("latin.toml") && e.contains("line 3, column 6: byte 0xe9 is not UTF-8"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn random_and_mutated_scene_files_never_panic(edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 0..6), cut in any::<usize>()) {
        let mut bytes = std::fs::read(repo().join("scenes/tp6-glass.toml")).unwrap();
        for (at, b) in edits {
            let i = at % bytes.len();
            bytes[i] = b;
        }
        bytes.truncate(cut % (bytes.len() + 1));
        let text = String::from_utf8_lossy(&bytes);
        if let Ok(f) = parse_scene(Path::new("m.toml"), &text) {
            // Whatever parses either builds or says why.
            let _ = f.description.build(Accel::BvhSah);
        }
    }
}

#[test]
fn the_documented_implicit_object_parses_and_renders() {
    let doc = std::fs::read_to_string(repo().join("docs/scene-format.md")).unwrap();
    let line = doc.lines().find(|l| l.starts_with("sdf = { sdf = \"transform\"")).expect("the example line");
    let text = format!(
        "[camera]\nposition = [0, 0, -3]\nlook_at = [0, -2, 5]\n[materials]\nred = {{ type = \"lambert\", color = [1, 0, 0] }}\n\
         [[objects]]\ntype = \"implicit\"\nmaterial = \"red\"\n{line}\n[[lights]]\ntype = \"point\"\nposition = [0, 3, -3]\n"
    );
    let f = parse_scene(Path::new("i.toml"), &text).unwrap();
    let pixels = render(&f.description);
    let red = pixels.iter().filter(|c| c.x > 0.01 && c.y == 0.0).count();
    let other = pixels.iter().filter(|c| **c != f.description.background).count();
    assert!(red > 20, "the red shape is seen: {red} red pixels, {other} not background");
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    // Arrays and inline tables nested 100,000 deep, and an SDF tree 10,000 deep.
    for (open, close) in [("[", "]"), ("{ a = ", " }")] {
        let text = format!("[render]\nbackground = {}1{}\n", open.repeat(100_000), close.repeat(100_000));
        assert!(parse_scene(Path::new("deep.toml"), &text).is_err());
    }
    let sdf = format!("{}{{ sdf = \"sphere\", radius = 1 }}{}", "{ sdf = \"transform\", of = ".repeat(10_000), " }".repeat(10_000));
    let text = format!("[[objects]]\ntype = \"implicit\"\nsdf = {sdf}\n");
    match parse_scene(Path::new("deep.toml"), &text) {
        Err(_) => {}
        Ok(f) => assert!(f.description.build(Accel::BvhSah).is_err(), "a 10,000-deep tree is refused"),
    }
}
