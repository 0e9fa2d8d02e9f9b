//! A contact sheet of every built-in scene, each at its own integrator, samples and
//! display, labelled with its name; and, with `--times`, each scene's render time at its
//! defaults (600×400).
//!
//! ```sh
//! cargo run --release --example contact_sheet -- docs/contact-sheet.png
//! cargo run --release --example contact_sheet -- /tmp/sheet.png --times
//! ```

use font8x8::UnicodeFonts;
use isir::{scenes, Accel, Image, Renderer};
use std::time::Instant;

const TILE_W: u32 = 240;
const TILE_H: u32 = 160;
const LABEL_H: u32 = 14;
const COLUMNS: u32 = 5;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = args.iter().find(|a| !a.starts_with("--")).cloned().unwrap_or_else(|| "contact-sheet.png".into());
    let times = args.iter().any(|a| a == "--times");
    let list = scenes::list();
    let rows = (list.len() as u32).div_ceil(COLUMNS);
    let (w, h) = (COLUMNS * TILE_W, rows * (TILE_H + LABEL_H));
    let mut sheet = vec![255u8; (w * h * 3) as usize];
    if times {
        println!("| scene | integrator | spp | render time at 600×400 (s) |\n| --- | --- | --- | --- |");
    }
    for (i, (name, _)) in list.iter().enumerate() {
        let desc = scenes::builtin(name)?;
        let scene = desc.build(Accel::BvhSah)?;
        let renderer = Renderer::new(TILE_W, TILE_H).spp(desc.spp);
        let (tile, _) = renderer.render(&scene, &desc.camera.build(renderer.aspect()), &desc.integrator);
        let (x0, y0) = ((i as u32 % COLUMNS) * TILE_W, (i as u32 / COLUMNS) * (TILE_H + LABEL_H));
        blit(&mut sheet, w, &tile, &tile.to_rgb8(desc.display), x0, y0);
        label(&mut sheet, w, name, x0 + 4, y0 + TILE_H + 3);
        if times {
            let full = Renderer::new(600, 400).spp(desc.spp);
            let camera = desc.camera.build(full.aspect());
            let start = Instant::now();
            let _ = full.render(&scene, &camera, &desc.integrator);
            println!("| `{name}` | {:?} | {} | {:.3} |", desc.integrator, desc.spp, start.elapsed().as_secs_f64());
        }
    }
    image::save_buffer(&out, &sheet, w, h, image::ColorType::Rgb8)?;
    eprintln!("wrote {out} ({} scenes)", list.len());
    Ok(())
}

fn blit(sheet: &mut [u8], width: u32, tile: &Image, rgb: &[u8], x0: u32, y0: u32) {
    for y in 0..tile.height {
        let src = &rgb[(y * tile.width * 3) as usize..((y + 1) * tile.width * 3) as usize];
        let at = (((y0 + y) * width + x0) * 3) as usize;
        sheet[at..at + src.len()].copy_from_slice(src);
    }
}

/// Black 8×8 text (font8x8, public domain) on the white label strip.
fn label(sheet: &mut [u8], width: u32, text: &str, x0: u32, y0: u32) {
    for (k, ch) in text.chars().enumerate() {
        let Some(glyph) = font8x8::BASIC_FONTS.get(ch) else { continue };
        for (dy, row) in glyph.iter().enumerate() {
            for dx in 0..8u32 {
                let x = x0 + k as u32 * 8 + dx;
                if row & (1 << dx) != 0 && x < width {
                    let at = (((y0 + dy as u32) * width + x) * 3) as usize;
                    sheet[at..at + 3].copy_from_slice(&[0, 0, 0]);
                }
            }
        }
    }
}
