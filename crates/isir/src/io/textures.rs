//! The colour textures of one mesh file, decoded once each and shared.
//!
//! Materials that name the same image (the same file beside an OBJ, the same glTF image)
//! share one decoded [`Texture`]: eight materials of an 82 KB PNG of 8192×8192 texels took
//! eight times 768 MiB. What all of a file's textures decode to is bounded too: their
//! texels (12 bytes each, linear RGB floats) may take at most the input limit
//! ([`ReadLimits::max_bytes`], 1 GiB by default), checked from each image's header before
//! its pixels are decoded. A texture past it is not decoded, and its material keeps its
//! flat colour with a warning, as for any texture that cannot be read.

use crate::io::input::ReadLimits;
use crate::materials::Texture;
use crate::math::color::Color;
use std::collections::HashMap;
use std::hash::Hash;
use std::sync::Arc;

/// A decoded texture, or why there is none (for the material's warning).
pub(crate) type Decoded = std::result::Result<Arc<Texture>, String>;

/// The textures of one file so far, by a key naming the image (its path, its index).
pub(crate) struct Textures<K> {
    decoded: HashMap<K, Decoded>,
    /// Bytes of texels decoded so far.
    bytes: u64,
    limits: ReadLimits,
}

impl<K: Hash + Eq> Textures<K> {
    /// None yet, within `limits`.
    pub(crate) fn new(limits: &ReadLimits) -> Self {
        Self { decoded: HashMap::new(), bytes: 0, limits: *limits }
    }

    /// The texture of the image `key`: the one decoded before for that key (or the same
    /// error), otherwise the image `read` gives, decoded.
    pub(crate) fn get(&mut self, key: K, read: impl FnOnce() -> std::result::Result<Vec<u8>, String>) -> Decoded {
        if let Some(known) = self.decoded.get(&key) {
            return known.clone();
        }
        let decoded = read().and_then(|bytes| self.decode(&bytes));
        self.decoded.insert(key, decoded.clone());
        decoded
    }

    /// Decode `bytes` when their texels fit in what is left of the limit.
    fn decode(&mut self, bytes: &[u8]) -> Decoded {
        let (w, h) = image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| e.to_string())?
            .into_dimensions()
            .map_err(|e| e.to_string())?;
        let size = u64::from(w) * u64::from(h) * std::mem::size_of::<Color>() as u64;
        if self.bytes.saturating_add(size) > self.limits.max_bytes {
            return Err(format!(
                "{w}x{h} texels would take the file's decoded textures ({} MiB before it) past {}",
                self.bytes >> 20,
                self.limits.described()
            ));
        }
        let texture = Texture::decode(bytes)?;
        self.bytes += size;
        Ok(Arc::new(texture))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    /// A `w × h` PNG, all one grey.
    fn png(w: u32, h: u32) -> Vec<u8> {
        let mut out = Vec::new();
        image::RgbImage::from_pixel(w, h, image::Rgb([128, 128, 128]))
            .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
            .unwrap();
        out
    }

    #[test]
    fn an_image_is_read_and_decoded_once_per_key() {
        let reads = Cell::new(0);
        let read = || {
            reads.set(reads.get() + 1);
            Ok(png(4, 2))
        };
        let mut t = Textures::new(&ReadLimits::default());
        let a = t.get("a.png", read).unwrap();
        let b = t.get("a.png", read).unwrap();
        assert!(Arc::ptr_eq(&a, &b));
        assert_eq!(reads.get(), 1);
        // Another key is another image, even with the same bytes.
        let c = t.get("c.png", read).unwrap();
        assert!(!Arc::ptr_eq(&a, &c));
        assert_eq!(reads.get(), 2);
        // A failure is remembered too, with its reason.
        let e = t.get("gone.png", || Err("not found".to_string())).unwrap_err();
        assert_eq!(e, "not found");
        assert_eq!(t.get("gone.png", || unreachable!()).unwrap_err(), "not found");
    }

    #[test]
    fn decoded_texels_stop_at_the_input_limit() {
        // 100 texels are 1200 bytes: two fit in 3000, a third does not.
        let mut t = Textures::new(&ReadLimits::new(3000));
        assert!(t.get(1, || Ok(png(10, 10))).is_ok());
        assert!(t.get(2, || Ok(png(10, 10))).is_ok());
        let e = t.get(3, || Ok(png(10, 10))).unwrap_err();
        assert!(
            e.starts_with("10x10 texels would take the file's decoded textures (0 MiB before it) past the input limit of 3000 bytes"),
            "{e}"
        );
        assert!(e.contains("ISIR_MAX_INPUT_BYTES"), "{e}");
        // Reusing a decoded one costs nothing.
        assert!(t.get(1, || unreachable!()).is_ok());
        assert_eq!(t.bytes, 2400);
    }
}
