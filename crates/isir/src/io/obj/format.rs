//! What a file is before it is parsed: mesh formats named by extension or content, and
//! text decoding (UTF-8, a BOM skipped, Latin-1 bytes kept, UTF-16 refused).

use super::*;

/// Mesh formats isir does not read, by file name ending (before any `.gz`).
pub(super) const UNSUPPORTED: [(&str, &str); 15] = [
    ("ply", "PLY"),
    ("stl", "STL"),
    ("gltf", "glTF"),
    ("glb", "glTF (binary .glb)"),
    ("fbx", "FBX"),
    ("dae", "COLLADA"),
    ("3ds", "3DS"),
    ("usd", "USD"),
    ("usda", "USD"),
    ("usdc", "USD"),
    ("usdz", "USD"),
    ("abc", "Alembic"),
    ("off", "OFF"),
    ("x3d", "X3D"),
    ("wrl", "VRML"),
];

pub(super) fn unsupported(format: &str) -> String {
    if format == "PLY" || format.starts_with("glTF") {
        // Read by `io::mesh::load_mesh` (and the isir command), not by the OBJ reader.
        return format!("{format} meshes are not OBJ: read them with isir::io::mesh::load_mesh");
    }
    format!(
        "{format} meshes are not supported yet (isir reads Wavefront OBJ, PLY and glTF: .obj, .ply, .gltf, .glb, the first two \
         optionally gzip-compressed)"
    )
}

/// `s`, or its first and last 80 characters around a `…` when it is long: a message
/// naming a file keeps its reason, at the end, however long the name.
pub(super) fn excerpt_ends(s: &str) -> String {
    pub(super) const END: usize = 80;
    let n = s.chars().count();
    if n <= 2 * END + 1 {
        return s.to_string();
    }
    let tail = s.char_indices().nth(n - END).map_or(s.len(), |(i, _)| i);
    format!("{}…{}", excerpt(s).trim_end_matches('…'), &s[tail..])
}

/// The unsupported mesh format `path`'s name says, if any.
pub(super) fn format_by_name(path: &Path) -> Option<&'static str> {
    let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    let ext = name.rsplit_once('.')?.1;
    UNSUPPORTED.iter().find(|(e, _)| *e == ext).map(|(_, f)| *f)
}

/// Why `bytes` are not OBJ text, if their first bytes say so: another mesh format, or
/// compressed data the name does not announce.
pub(super) fn format_by_content(bytes: &[u8]) -> Option<String> {
    let magic: [(&[u8], &str); 6] = [
        (b"ply\n", "PLY"),
        (b"ply\r\n", "PLY"),
        (b"glTF", "glTF (binary .glb)"),
        (b"Kaydara FBX Binary", "FBX"),
        (b"; FBX", "FBX"),
        (b"#VRML", "VRML"),
    ];
    if let Some((_, format)) = magic.iter().find(|(m, _)| bytes.starts_with(m)) {
        return Some(unsupported(format));
    }
    // Binary STL: an 80-byte header, a triangle count, 50 bytes per triangle.
    if let Some(count) = bytes.get(80..84) {
        let count = u64::from(u32::from_le_bytes([count[0], count[1], count[2], count[3]]));
        if 84 + 50 * count == bytes.len() as u64 {
            return Some(unsupported("STL (binary)"));
        }
    }
    let compressed: [(&[u8], &str); 5] = [
        (&[0x1f, 0x8b], "gzip-compressed data: name the file with a .gz ending (model.obj.gz) to have it decompressed"),
        (b"PK\x03\x04", "a ZIP archive: extract the OBJ file from it"),
        (&[0xfd, b'7', b'z', b'X', b'Z', 0], "xz-compressed data: isir decompresses gzip (.gz) only"),
        (&[0x28, 0xb5, 0x2f, 0xfd], "zstd-compressed data: isir decompresses gzip (.gz) only"),
        (b"BZh", "bzip2-compressed data: isir decompresses gzip (.gz) only"),
    ];
    if let Some((_, what)) = compressed.iter().find(|(m, _)| bytes.starts_with(m)) {
        return Some((*what).to_string());
    }
    let text = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes).trim_ascii_start();
    if text.starts_with(b"{") {
        let head = &text[..text.len().min(4096)];
        let gltf = head.windows(7).any(|w| w == b"\"asset\"");
        return Some(if gltf { unsupported("glTF") } else { "JSON data, not an OBJ mesh".into() });
    }
    if text.starts_with(b"solid") && text.get(5).is_none_or(u8::is_ascii_whitespace) {
        return Some(unsupported("STL (ASCII)"));
    }
    None
}

/// The text of an OBJ or MTL file: UTF-8 without its byte-order mark (which would hide the
/// first keyword from tobj), bytes that are not UTF-8 read as Latin-1 (one `é` in a comment
/// must not fail a valid file); UTF-16 and binary data refused with the reason.
pub(super) fn decode_text(bytes: &[u8]) -> std::result::Result<Cow<'_, str>, String> {
    let head = &bytes[..bytes.len().min(1024) & !1];
    let zeros = |parity: usize| head.iter().skip(parity).step_by(2).filter(|&&b| b == 0).count();
    let (even, odd) = (zeros(0), zeros(1));
    let utf16 = if bytes.starts_with(&[0xff, 0xfe]) || bytes.starts_with(&[0xfe, 0xff]) {
        Some("UTF-16 text (it starts with a UTF-16 byte-order mark)")
    } else if head.len() >= 2 && (odd * 4 >= head.len() && even == 0 || even * 4 >= head.len() && odd == 0) {
        // ASCII in UTF-16 puts a NUL byte beside every character.
        Some("UTF-16 text (NUL bytes between its characters)")
    } else {
        None
    };
    if let Some(what) = utf16 {
        return Err(format!("{what}: isir reads UTF-8 or ASCII; save the file as UTF-8"));
    }
    if let Some(at) = head.iter().position(|&b| b == 0) {
        return Err(format!("binary data (a NUL byte at offset {at}), not a text file"));
    }
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    Ok(match std::str::from_utf8(bytes) {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => {
            let mut s = String::with_capacity(bytes.len() + bytes.len() / 16);
            for chunk in bytes.utf8_chunks() {
                s.push_str(chunk.valid());
                s.extend(chunk.invalid().iter().map(|&b| char::from(b)));
            }
            Cow::Owned(s)
        }
    })
}
