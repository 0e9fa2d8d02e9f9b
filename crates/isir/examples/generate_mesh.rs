//! A large deterministic test mesh for `isir bench`: a sphere displaced by a few octaves of
//! waves, as a binary little-endian PLY of about N triangles (a grid of rings × segments,
//! two triangles per cell; the poles closed by fans).
//!
//! ```sh
//! cargo run --release -p isir --example generate_mesh -- 10000000 /tmp/gen10m.ply
//! target/release/isir bench /tmp/gen10m.ply --repeat 1
//! ```
//!
//! The surface is smooth at large scale and rough at small scale, like a scanned model, so
//! that the BVH sees neither a uniform grid nor random triangle soup. The file is written
//! whole or not at all (a temporary file beside it, then a rename).

use std::f64::consts::PI;
use std::io::{BufWriter, Write};

fn main() {
    let mut args = std::env::args().skip(1);
    let (Some(n), Some(out)) = (args.next(), args.next()) else {
        eprintln!("usage: generate_mesh TRIANGLES OUT.ply");
        std::process::exit(2);
    };
    let n: u64 = match n.replace('_', "").parse() {
        Ok(n) if (8..=200_000_000).contains(&n) => n,
        _ => {
            eprintln!("generate_mesh: TRIANGLES must be a whole number from 8 to 200000000, not {n:?}");
            std::process::exit(2);
        }
    };
    // rings × segments cells, segments = 2 rings: 2 · rings · segments ≈ n.
    let rings = ((n as f64 / 4.0).sqrt().round() as u64).max(2);
    let segments = 2 * rings;
    let vertex_count = (rings - 1) * segments + 2;
    let triangle_count = 2 * (rings - 2) * segments + 2 * segments;
    let radius = |theta: f64, phi: f64| {
        1.0 + 0.08 * (5.0 * theta).sin() * (7.0 * phi).cos()
            + 0.02 * (23.0 * theta + 1.0).sin() * (31.0 * phi + 2.0).sin()
            + 0.004 * (97.0 * theta).cos() * (131.0 * phi + 0.5).sin()
    };
    let point = |theta: f64, phi: f64| {
        let r = radius(theta, phi);
        [(r * theta.sin() * phi.cos()) as f32, (r * theta.cos()) as f32, (r * theta.sin() * phi.sin()) as f32]
    };
    let tmp = format!("{out}.tmp-{}", std::process::id());
    let result = (|| -> std::io::Result<()> {
        let mut w = BufWriter::with_capacity(1 << 22, std::fs::File::create(&tmp)?);
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment isir generate_mesh {n}\nelement vertex {vertex_count}\n\
             property float x\nproperty float y\nproperty float z\nelement face {triangle_count}\n\
             property list uchar uint vertex_indices\nend_header\n"
        )?;
        let put = |p: [f32; 3], w: &mut BufWriter<std::fs::File>| -> std::io::Result<()> {
            for c in p {
                w.write_all(&c.to_le_bytes())?;
            }
            Ok(())
        };
        put(point(0.0, 0.0), &mut w)?;
        for i in 1..rings {
            let theta = PI * i as f64 / rings as f64;
            for j in 0..segments {
                put(point(theta, 2.0 * PI * j as f64 / segments as f64), &mut w)?;
            }
        }
        put(point(PI, 0.0), &mut w)?;
        let ring = |i: u64, j: u64| (1 + (i - 1) * segments + j % segments) as u32;
        let tri = |a: u32, b: u32, c: u32, w: &mut BufWriter<std::fs::File>| -> std::io::Result<()> {
            w.write_all(&[3])?;
            for v in [a, b, c] {
                w.write_all(&v.to_le_bytes())?;
            }
            Ok(())
        };
        for j in 0..segments {
            tri(0, ring(1, j + 1), ring(1, j), &mut w)?;
        }
        for i in 1..rings - 1 {
            for j in 0..segments {
                tri(ring(i, j), ring(i, j + 1), ring(i + 1, j), &mut w)?;
                tri(ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j), &mut w)?;
            }
        }
        let last = (vertex_count - 1) as u32;
        for j in 0..segments {
            tri(last, ring(rings - 1, j), ring(rings - 1, j + 1), &mut w)?;
        }
        w.into_inner().map_err(std::io::IntoInnerError::into_error)?.sync_all()?;
        std::fs::rename(&tmp, &out)
    })();
    if let Err(e) = result {
        std::fs::remove_file(&tmp).ok();
        eprintln!("generate_mesh: {out}: {e}");
        std::process::exit(1);
    }
    println!("{out}: {triangle_count} triangles, {vertex_count} vertices");
}
