//! The layering of `crates/isir/src`: every `crate::` path in a module's code points to a
//! layer below its own (or its own), never up, so the module graph has no cycle and the
//! seam (`scene/`) never imports the integrators, descriptions or files above it.
//! Comments (doc links) and test code (`tests.rs`, `mod tests`) are not imports.

use std::path::Path;

/// Layers from the top; a module may import its own layer and those after it.
const LAYERS: &[&[&str]] = &[
    &["renderer", "aov"],
    &["scenes"],
    &["io"],
    &["integrators"],
    &["scene"],
    &["materials"],
    &["lights"],
    &["geometry"],
    &["camera"],
    &["accel"],
    &["math"],
    &["kept", "error"],
];

fn layer(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

/// The code of a file without comments and without its `#[cfg(test)] mod tests { ... }`.
fn code(text: &str) -> String {
    let text = match text.find("#[cfg(test)]\nmod tests {") {
        Some(i) => &text[..i],
        None => text,
    };
    text.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n")
}

/// The top-level modules named by `crate::x` and `crate::{x, y::z}` in `code`.
fn imports(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        rest = &rest[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find("};").unwrap_or(group.len());
            let mut depth = 0;
            let mut item = String::new();
            for ch in group[..end].chars().chain(std::iter::once(',')) {
                match ch {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        let name: String = item.trim().chars().take_while(|c| c.is_ascii_lowercase() || *c == '_').collect();
                        if !name.is_empty() {
                            out.push(name);
                        }
                        item.clear();
                        continue;
                    }
                    _ => {}
                }
                item.push(ch);
            }
        } else {
            let name: String = rest.chars().take_while(|c| c.is_ascii_lowercase() || *c == '_').collect();
            if !name.is_empty() {
                out.push(name);
            }
        }
    }
    out
}

fn files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") && p.file_name().unwrap() != "tests.rs" {
            out.push(p);
        }
    }
}

#[test]
fn imports_point_down_the_layers() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut all = Vec::new();
    files(&src, &mut all);
    let mut checked = 0;
    let mut wrong = Vec::new();
    for path in &all {
        let rel = path.strip_prefix(&src).unwrap();
        let top = rel.components().next().unwrap().as_os_str().to_str().unwrap().trim_end_matches(".rs").to_string();
        if top == "lib" {
            continue; // the crate root re-exports everything
        }
        let own = layer(&top).unwrap_or_else(|| panic!("{} is in no layer: add `{top}` to LAYERS", rel.display()));
        for name in imports(&code(&std::fs::read_to_string(path).unwrap())) {
            if name == "parse_name" {
                continue; // a crate-root helper
            }
            let to = layer(&name).unwrap_or_else(|| panic!("{} imports crate::{name}, in no layer", rel.display()));
            checked += 1;
            if to < own {
                wrong.push(format!("{} imports crate::{name} (layer {to} is above {top}, layer {own})", rel.display()));
            }
        }
    }
    assert!(checked > 50, "only {checked} imports found: the scan is broken");
    assert!(wrong.is_empty(), "imports pointing up:\n{}", wrong.join("\n"));
}

#[test]
fn the_scan_sees_grouped_and_nested_imports() {
    let found = imports("use crate::{a::B, c::{D, e::F}, g};\nlet x = crate::h::i();");
    assert_eq!(found, ["a", "c", "g", "h"]);
    assert!(imports(&code("//! see [`crate::up`]\nfn f() {}")).is_empty());
}
