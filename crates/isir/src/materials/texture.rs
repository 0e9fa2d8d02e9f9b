//! Image textures: decoded once to linear RGB (sRGB-encoded images, as colour textures
//! are, decoded by the sRGB transfer function), sampled bilinearly with repeat wrapping.
//! Texture coordinates follow OBJ's convention (`v` up: `(0, 0)` is the image's
//! bottom-left corner); the glTF reader flips its `v` to match.

use crate::math::color::Color;
use glam::Vec2;

/// A texture of linear RGB texels, row 0 at the top of the image.
#[derive(Clone, PartialEq)]
pub struct Texture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    texels: Vec<Color>,
}

impl std::fmt::Debug for Texture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Texture({}x{})", self.width, self.height)
    }
}

/// The largest texture accepted, in texels (64 Mi: 768 MiB of linear texels).
pub const MAX_TEXELS: u64 = 1 << 26;

/// sRGB-encoded `c` (0..=255) to linear.
#[must_use]
pub fn srgb_to_linear(c: u8) -> f32 {
    let c = f32::from(c) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

impl Texture {
    /// A texture from linear texels, row by row from the top.
    ///
    /// # Panics
    /// If `texels` does not hold `width × height` colours, or a side is 0.
    #[must_use]
    pub fn new(width: u32, height: u32, texels: Vec<Color>) -> Self {
        assert!(width > 0 && height > 0 && texels.len() == width as usize * height as usize);
        Texture { width, height, texels }
    }

    /// Decode an encoded image (PNG or JPEG), its colours as sRGB.
    ///
    /// # Errors
    /// Not an image isir decodes, or over [`MAX_TEXELS`] (the size is checked before the
    /// pixels are decoded).
    pub fn decode(bytes: &[u8]) -> Result<Texture, String> {
        let reader = image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format().map_err(|e| e.to_string())?;
        let (w, h) = reader.into_dimensions().map_err(|e| e.to_string())?;
        if w == 0 || h == 0 || u64::from(w) * u64::from(h) > MAX_TEXELS {
            return Err(format!("{w}x{h} texels: textures may hold 1 to {MAX_TEXELS}"));
        }
        let img = image::load_from_memory(bytes).map_err(|e| e.to_string())?.to_rgb8();
        let texels = img.pixels().map(|p| Color::new(srgb_to_linear(p[0]), srgb_to_linear(p[1]), srgb_to_linear(p[2]))).collect();
        Ok(Texture { width: w, height: h, texels })
    }

    fn texel(&self, x: i64, y: i64) -> Color {
        let (w, h) = (i64::from(self.width), i64::from(self.height));
        self.texels[(y.rem_euclid(h) * w + x.rem_euclid(w)) as usize]
    }

    /// The bilinear colour at `uv` (repeat wrapping; texel centres at half-integers).
    #[must_use]
    pub fn sample(&self, uv: Vec2) -> Color {
        if !uv.is_finite() {
            return self.texels[0];
        }
        // OBJ's v points up; image rows go down.
        let x = uv.x.rem_euclid(1.0) * self.width as f32 - 0.5;
        let y = (1.0 - uv.y.rem_euclid(1.0)) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.texel(x0, y0).lerp(self.texel(x0 + 1, y0), fx);
        let bottom = self.texel(x0, y0 + 1).lerp(self.texel(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_decoding_is_the_standard_curve() {
        assert_eq!(srgb_to_linear(0), 0.0);
        assert_eq!(srgb_to_linear(255), 1.0);
        assert!((srgb_to_linear(128) - 0.215_860_5).abs() < 1e-6);
        assert!((srgb_to_linear(10) - 10.0 / 255.0 / 12.92).abs() < 1e-7);
    }

    #[test]
    fn bilinear_sampling_with_repeat() {
        // 2×2: top row red, green; bottom row blue, white.
        let (r, g, b, w) = (Color::X, Color::Y, Color::Z, Color::ONE);
        let t = Texture::new(2, 2, vec![r, g, b, w]);
        // Texel centres: u 0.25/0.75, v 0.75 (top) / 0.25 (bottom).
        assert_eq!(t.sample(Vec2::new(0.25, 0.75)), r);
        assert_eq!(t.sample(Vec2::new(0.75, 0.75)), g);
        assert_eq!(t.sample(Vec2::new(0.25, 0.25)), b);
        assert_eq!(t.sample(Vec2::new(0.75, 0.25)), w);
        // Half-way between the two top texels.
        assert!((t.sample(Vec2::new(0.5, 0.75)) - (r + g) * 0.5).length() < 1e-6);
        // Repeat: one period away is the same.
        assert!((t.sample(Vec2::new(1.25, -0.25)) - r).length() < 1e-6);
        assert!(t.sample(Vec2::new(f32::NAN, 0.0)).is_finite());
    }

    #[test]
    fn images_decode_and_huge_claims_are_refused_before_decoding() {
        let mut png = Vec::new();
        image::RgbImage::from_pixel(3, 2, image::Rgb([255, 128, 0]))
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        let t = Texture::decode(&png).unwrap();
        assert_eq!((t.width, t.height), (3, 2));
        assert!((t.sample(Vec2::new(0.5, 0.5)) - Color::new(1.0, srgb_to_linear(128), 0.0)).length() < 1e-6);
        assert!(Texture::decode(b"not an image").is_err());
        // A PNG header claiming 2^20 × 2^20 pixels.
        let mut huge = png.clone();
        huge[16..20].copy_from_slice(&(1u32 << 20).to_be_bytes());
        huge[20..24].copy_from_slice(&(1u32 << 20).to_be_bytes());
        let mut crc = flate2::Crc::new();
        crc.update(&huge[12..29]);
        huge[29..33].copy_from_slice(&crc.sum().to_be_bytes());
        let e = Texture::decode(&huge).unwrap_err();
        assert!(e.contains("texels"), "{e}");
    }
}
