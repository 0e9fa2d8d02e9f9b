//! Images of linear RGB floats, written as PNG (8-bit) or OpenEXR (linear float).

use crate::color::Color;
use crate::error::{Error, Result};
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

/// The largest image (in pixels) the tools accept: 16384 × 16384, 3 GiB of floats.
pub const MAX_PIXELS: u64 = 1 << 28;

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
        return Err(Error::Scene(format!("image size {width}x{height}: {n} pixels, more than the {MAX_PIXELS} allowed")));
    }
    Ok(())
}

/// Check that `path` names a format [`Image::save`] writes (before spending a render on it).
///
/// # Errors
/// An extension other than `.png` or `.exr`.
pub fn check_output_path(path: &Path) -> Result<()> {
    output_format(path).map(|_| ())
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

    fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// The pixel at column `x`, row `y`.
    #[must_use]
    pub fn get(&self, x: u32, y: u32) -> Color {
        self.pixels[self.index(x, y)]
    }

    /// Set the pixel at column `x`, row `y`.
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
    /// `display`.
    ///
    /// # Errors
    /// An unsupported extension, or a file that cannot be written.
    pub fn save(&self, path: impl AsRef<Path>, display: Display) -> Result<()> {
        let path = path.as_ref();
        let fail = |message: String| Error::Image { path: path.to_path_buf(), message };
        match output_format(path)? {
            Format::Exr => {
                let w = self.width as usize;
                exr::prelude::write_rgb_file(path, w, self.height as usize, |x, y| {
                    let c = self.pixels[y * w + x];
                    (c.x, c.y, c.z)
                })
                .map_err(|e| fail(e.to_string()))
            }
            Format::Png => image::save_buffer(path, &self.to_rgb8(display), self.width, self.height, image::ExtendedColorType::Rgb8)
                .map_err(|e| fail(e.to_string())),
        }
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
}
