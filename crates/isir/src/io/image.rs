//! Images of linear RGB floats, written as PNG (8-bit) or OpenEXR (linear float).

use crate::error::{Error, Result};
use crate::math::color::Color;
use std::path::Path;

/// How linear colours become 8-bit pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Display {
    /// The course's output: each channel clamped to `[0, 1]`, times 255, truncated; no gamma.
    /// The course scenes use it so they look like the course's images.
    #[default]
    LinearClamp,
    /// The sRGB transfer curve, rounded: what image viewers expect of new scenes.
    Srgb,
}

impl Display {
    /// The 8-bit value of one linear channel.
    #[must_use]
    pub fn encode(self, c: f32) -> u8 {
        let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
        match self {
            Display::LinearClamp => (c * 255.0) as u8,
            Display::Srgb => {
                let s = if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
                (s * 255.0).round() as u8
            }
        }
    }
}

/// A `width × height` image, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Pixels, row by row from the top-left.
    pub pixels: Vec<Color>,
}

/// The largest image (in pixels) the tools accept: 16384 × 16384.
///
/// Peak memory of a render is about 15 bytes per pixel, 4 GB at this limit: the image's
/// 12 bytes of floats (tiles are rendered into it in place, no second copy), the 3 bytes
/// of the 8-bit copy a PNG is encoded from, and the compressed PNG, which the encoder
/// holds whole (0.05 to 1.5 bytes per pixel on the course's scenes). Measured with
/// `/usr/bin/time -v isir render tp4-sphere --spp 1 --integrator ray-cast`: 15.1 bytes per
/// pixel at 8192 × 8192 (0.99 GB) and at 16384 × 16384 (3.95 GB); 12.1 bytes per pixel
/// writing OpenEXR. A ray set of this many rays is written as it is generated (72 MB
/// peak for 16384 × 16384 diffuse rays, an 8 GiB file); tracing it holds the rays and
/// their hits, 48 bytes per ray.
pub const MAX_PIXELS: u64 = 1 << 28;

/// The peak memory of a render, per pixel (see [`MAX_PIXELS`]).
const RENDER_BYTES_PER_PIXEL: u64 = 15;

/// Check an image size: both sides at least 1, at most [`MAX_PIXELS`] pixels.
///
/// # Errors
/// A side of 0, or too many pixels.
pub fn check_size(width: u32, height: u32) -> Result<()> {
    let n = u64::from(width) * u64::from(height);
    if width == 0 || height == 0 {
        return Err(Error::Scene(format!("image size {width}x{height}: width and height must be at least 1")));
    }
    if n > MAX_PIXELS {
        return Err(Error::Scene(format!(
            "image size {width}x{height}: {n} pixels, more than the {MAX_PIXELS} (16384x16384) allowed (a render takes about \
             {RENDER_BYTES_PER_PIXEL} bytes per pixel: {:.1} GB at the limit, {:.1} GB for this one)",
            (MAX_PIXELS * RENDER_BYTES_PER_PIXEL) as f64 * 1e-9,
            (n * RENDER_BYTES_PER_PIXEL) as f64 * 1e-9
        )));
    }
    Ok(())
}

/// Check that [`Image::save`] can write `path` (before spending a render on it): a format
/// it writes, in a directory where a file can be created
/// ([`crate::io::output::check_writable`]).
///
/// # Errors
/// An extension other than `.png` or `.exr`; a directory that does not exist or cannot be
/// written; a path that names a directory or a file that cannot be written.
pub fn check_output_path(path: &Path) -> Result<()> {
    output_format(path)?;
    crate::io::output::check_writable(path)
}

/// The file formats [`Image::save`] writes.
enum Format {
    Png,
    Exr,
}

fn output_format(path: &Path) -> Result<Format> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    match ext.as_str() {
        "png" => Ok(Format::Png),
        "exr" => Ok(Format::Exr),
        _ => Err(Error::Image { path: path.to_path_buf(), message: format!("unsupported image format '.{ext}' (use .png or .exr)") }),
    }
}

impl Image {
    /// A black image.
    #[must_use]
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, pixels: vec![Color::ZERO; width as usize * height as usize] }
    }

    /// # Panics
    /// If `(x, y)` is outside the image (an `x` past the width would name another row's
    /// pixel).
    fn index(&self, x: u32, y: u32) -> usize {
        assert!(x < self.width && y < self.height, "pixel ({x}, {y}) outside the {}x{} image", self.width, self.height);
        y as usize * self.width as usize + x as usize
    }

    /// The pixel at column `x`, row `y`.
    #[must_use]
    ///
    /// # Panics
    /// If `(x, y)` is outside the image.
    pub fn get(&self, x: u32, y: u32) -> Color {
        self.pixels[self.index(x, y)]
    }

    /// Set the pixel at column `x`, row `y`.
    ///
    /// # Panics
    /// If `(x, y)` is outside the image.
    pub fn set(&mut self, x: u32, y: u32, c: Color) {
        let i = self.index(x, y);
        self.pixels[i] = c;
    }

    /// 8-bit RGB bytes, row by row.
    #[must_use]
    pub fn to_rgb8(&self, display: Display) -> Vec<u8> {
        self.pixels.iter().flat_map(|c| [display.encode(c.x), display.encode(c.y), display.encode(c.z)]).collect()
    }

    /// Write to `path`: linear float OpenEXR when it ends in `.exr`, otherwise PNG through
    /// `display`. The file is written whole or not at all (see [`crate::io::output`]): a
    /// failed write leaves the file that was there intact.
    ///
    /// # Errors
    /// An unsupported extension, or a file that cannot be written (every write, the flush
    /// and the sync are checked).
    pub fn save(&self, path: impl AsRef<Path>, display: Display) -> Result<()> {
        let path = path.as_ref();
        let format = output_format(path)?;
        let message = if self.width == 0 || self.height == 0 {
            // (exr's writer asserts on an empty image.)
            format!("a {}x{} image has no pixel to save", self.width, self.height)
        } else if self.pixels.len() as u64 != u64::from(self.width) * u64::from(self.height) {
            format!("{} pixels for a {}x{} image", self.pixels.len(), self.width, self.height)
        } else {
            String::new()
        };
        if !message.is_empty() {
            return Err(Error::Image { path: path.to_path_buf(), message });
        }
        crate::io::output::write_atomically(path, |w| match format {
            Format::Exr => {
                use exr::prelude::{Encoding, LineOrder, SpecificChannels, Vec2, WritableImage};
                let width = self.width as usize;
                let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
                    let c: Color = self.pixels[y * width + x];
                    (c.x, c.y, c.z)
                });
                // The image `exr::prelude::write_rgb_file` writes (RLE, 64x64 tiles), into our
                // file, its tiles in increasing order: the same image, the same bytes (they
                // are compressed on several threads, and were written as they finished).
                let encoding = Encoding { line_order: LineOrder::Increasing, ..Encoding::FAST_LOSSLESS };
                let image = exr::prelude::Image::from_encoded_channels((width, self.height as usize), encoding, channels);
                image.write().to_buffered(&mut *w).map_err(|e| match e {
                    exr::error::Error::Io(e) => e,
                    e => crate::io::output::other(e),
                })
            }
            Format::Png => {
                use image::ImageEncoder;
                // The same encoder and settings as `image::save_buffer`, into our file.
                image::codecs::png::PngEncoder::new(&mut *w)
                    .write_image(&self.to_rgb8(display), self.width, self.height, image::ExtendedColorType::Rgb8)
                    .map_err(|e| match e {
                        image::ImageError::IoError(e) => e,
                        e => crate::io::output::other(e),
                    })
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encodings() {
        assert_eq!(Display::LinearClamp.encode(0.5), 127);
        assert_eq!(Display::LinearClamp.encode(2.0), 255);
        assert_eq!(Display::LinearClamp.encode(-1.0), 0);
        assert_eq!(Display::LinearClamp.encode(f32::NAN), 0);
        assert_eq!(Display::Srgb.encode(0.5), 188);
        assert_eq!(Display::Srgb.encode(1.0), 255);
    }

    #[test]
    fn sizes_beyond_the_limit_say_what_they_would_take() {
        check_size(16384, 16384).unwrap();
        let e = check_size(16385, 16384).unwrap_err().to_string();
        assert!(e.contains("16385x16384") && e.contains("15 bytes per pixel") && e.contains("4.0 GB at the limit"), "{e}");
        assert!(check_size(0, 5).unwrap_err().to_string().contains("at least 1"));
    }

    #[test]
    fn png_and_exr_round_trip() {
        let dir = std::env::temp_dir().join(format!("isir-image-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut img = Image::new(3, 2);
        img.set(2, 1, Color::new(1.0, 0.5, 0.25));
        img.save(dir.join("a.png"), Display::LinearClamp).unwrap();
        let png = image::open(dir.join("a.png")).unwrap().to_rgb8();
        assert_eq!(png.get_pixel(2, 1).0, [255, 127, 63]);
        img.save(dir.join("a.exr"), Display::LinearClamp).unwrap();
        let exr = exr::prelude::read_first_rgba_layer_from_file(
            dir.join("a.exr"),
            |res, _| vec![vec![(0f32, 0f32, 0f32); res.width()]; res.height()],
            |px, pos, (r, g, b, _a): (f32, f32, f32, f32)| px[pos.y()][pos.x()] = (r, g, b),
        )
        .unwrap();
        assert_eq!(exr.layer_data.channel_data.pixels[1][2], (1.0, 0.5, 0.25));
        assert!(img.save(dir.join("a.bmp"), Display::Srgb).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn an_exr_is_the_same_bytes_each_time() {
        // Its tiles are compressed on several threads: written as they finished, the file's
        // bytes changed from one save to the next (the pixels did not).
        let dir = std::env::temp_dir().join(format!("isir-image-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut img = Image::new(600, 400);
        let mut state = 1u32;
        for c in &mut img.pixels {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            *c = Color::splat((state >> 8) as f32 / (1 << 24) as f32);
        }
        let first = dir.join("first.exr");
        img.save(&first, Display::LinearClamp).unwrap();
        let first = std::fs::read(first).unwrap();
        for k in 0..8 {
            let p = dir.join(format!("again{k}.exr"));
            img.save(&p, Display::LinearClamp).unwrap();
            assert!(std::fs::read(&p).unwrap() == first, "save {k} wrote other bytes");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    fn temporaries(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir).unwrap().filter_map(|e| e.ok()?.file_name().into_string().ok()).filter(|n| n.contains(".tmp-")).collect()
    }

    #[test]
    fn a_failed_save_keeps_the_old_file() {
        let dir = std::env::temp_dir().join(format!("isir-image-fail-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut good = Image::new(4, 4);
        good.set(1, 1, Color::new(1.0, 0.0, 0.0));
        for name in ["a.png", "a.exr"] {
            let p = dir.join(name);
            good.save(&p, Display::Srgb).unwrap();
            let before = std::fs::read(&p).unwrap();
            // Images that cannot be saved are refused (not a panic), the old file intact.
            // (A write that fails half-way: `output`'s tests and the command's.)
            let e = Image::new(0, 3).save(&p, Display::Srgb).unwrap_err();
            assert!(e.to_string().starts_with(&p.display().to_string()) && e.to_string().contains("0x3"), "{e}");
            let bad = Image { width: 5, height: 5, pixels: vec![Color::ZERO; 3] };
            assert!(bad.save(&p, Display::Srgb).unwrap_err().to_string().contains("3 pixels for a 5x5 image"));
            assert_eq!(std::fs::read(&p).unwrap(), before, "{name}: the old file changed");
        }
        assert_eq!(temporaries(&dir), Vec::<String>::new());
        // A directory that does not exist: an error naming the file, nothing created.
        let missing = dir.join("missing").join("x.png");
        assert!(good.save(&missing, Display::Srgb).unwrap_err().to_string().contains("missing/x.png"));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn concurrent_saves_of_one_file_never_mix() {
        let dir = std::env::temp_dir().join(format!("isir-image-race-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("race.png");
        // Images of different sizes and contents: a mix of two shows as a broken PNG.
        let images: Vec<Image> = (0..4u32)
            .map(|i| {
                let mut img = Image::new(40 + 13 * i, 30 + 7 * i);
                for (k, c) in img.pixels.iter_mut().enumerate() {
                    *c = Color::new((k % 7) as f32 / 7.0, i as f32 / 4.0, (k % 11) as f32 / 11.0);
                }
                img
            })
            .collect();
        images[0].save(&p, Display::LinearClamp).unwrap();
        let done = std::sync::atomic::AtomicBool::new(false);
        let reads = std::thread::scope(|s| {
            let reader = s.spawn(|| {
                let mut reads = 0;
                while !done.load(std::sync::atomic::Ordering::Relaxed) {
                    let bytes = std::fs::read(&p).unwrap();
                    let png = image::load_from_memory(&bytes).expect("a whole PNG at every moment").to_rgb8();
                    assert!(images.iter().any(|i| i.to_rgb8(Display::LinearClamp) == png.as_raw().as_slice()), "a mixed image");
                    reads += 1;
                }
                reads
            });
            let writers: Vec<_> = images
                .iter()
                .map(|img| {
                    s.spawn(|| {
                        for _ in 0..15 {
                            img.save(&p, Display::LinearClamp).unwrap();
                        }
                    })
                })
                .collect();
            writers.into_iter().for_each(|w| w.join().unwrap());
            done.store(true, std::sync::atomic::Ordering::Relaxed);
            reader.join().unwrap()
        });
        assert!(reads > 0);
        let last = image::open(&p).unwrap().to_rgb8();
        assert!(images.iter().any(|i| i.to_rgb8(Display::LinearClamp) == last.as_raw().as_slice()));
        assert_eq!(temporaries(&dir), Vec::<String>::new());
        std::fs::remove_dir_all(&dir).ok();
    }
}
