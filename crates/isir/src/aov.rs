//! Arbitrary output variables: what each pixel's first hit is made of, written beside
//! the beauty render (`isir render --aov albedo|normal|depth|cost`). One ray through each
//! pixel's centre, no randomness, so an AOV is the same on any number of threads.
//!
//! `cost` is the TP4 lesson made visible: a heat map of the nodes visited plus the
//! primitives tested to find each pixel's closest hit, under the acceleration structure
//! the scene was built with (`--accel none|aabb|bvh-mid|bvh-sah`), with a colour bar.

use crate::camera::Camera;
use crate::io::image::Image;
use crate::math::color::{Color, BLACK, WHITE};
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

/// What an AOV shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aov {
    /// The flat colour of the hit material (the background where nothing is hit).
    Albedo,
    /// The shading normal facing the camera, `n·0.5 + 0.5` per axis (black: no hit).
    Normal,
    /// Distance to the hit over the farthest hit in the image: black near, white far
    /// (white also where nothing is hit).
    Depth,
    /// Nodes visited + primitives tested, as a heat map from 0 (dark blue) to the image's
    /// maximum (dark red), with a colour bar labelled 0 and the maximum below the image.
    Cost,
}

impl Aov {
    /// Every AOV.
    pub const ALL: [Aov; 4] = [Aov::Albedo, Aov::Normal, Aov::Depth, Aov::Cost];

    /// The command-line name (also the suffix of the file: `beauty.albedo.png`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Aov::Albedo => "albedo",
            Aov::Normal => "normal",
            Aov::Depth => "depth",
            Aov::Cost => "cost",
        }
    }
}

impl std::str::FromStr for Aov {
    type Err = String;
    /// Parse a command-line name (`albedo`, `normal`, `depth`, `cost`).
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        crate::parse_name(s, &Self::ALL, Self::name, "AOV")
    }
}

/// Figures of an AOV render.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AovStats {
    /// Camera rays traced (one per pixel).
    pub rays: u64,
    /// Average nodes visited per ray (for [`Aov::Cost`]).
    pub nodes_per_ray: f64,
    /// Average primitives tested per ray (for [`Aov::Cost`]).
    pub tests_per_ray: f64,
    /// The largest per-pixel cost, nodes + tests (the right end of the colour bar).
    pub max_cost: u64,
}

/// Rows of the colour bar under a cost image.
pub const COLOR_BAR_ROWS: u32 = 16;

/// Render `aov` at `width`×`height` (the cost image is [`COLOR_BAR_ROWS`] taller). The
/// values are ready for the linear-clamp display.
#[must_use]
pub fn render_aov(scene: &Scene, camera: &Camera, width: u32, height: u32, aov: Aov) -> (Image, AovStats) {
    // Per pixel: what was found (flat colour, normal, distance), and the cost of finding
    // it (nodes, tests).
    type Found = Option<(Color, Vec3, f32)>;
    let samples: Vec<(Found, u64, u64)> = (0..width * height)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let ray = camera.generate_ray((x as f32 + 0.5) / width as f32, (y as f32 + 0.5) / height as f32);
            let hit = scene.intersect(&ray, 0.0, f32::INFINITY).map(|h| (scene.material(&h).color_at(&h), h.normal, h.t));
            let (nodes, tests) = if aov == Aov::Cost {
                let c = scene.cost(&ray, 0.0, f32::INFINITY);
                (c.nodes, c.triangles)
            } else {
                (0, 0)
            };
            (hit, nodes, tests)
        })
        .collect();
    let rays = samples.len() as u64;
    let mut stats = AovStats { rays, ..AovStats::default() };
    let extra = if aov == Aov::Cost { COLOR_BAR_ROWS } else { 0 };
    let mut image = Image::new(width, height + extra);
    match aov {
        Aov::Albedo => {
            for (p, (hit, _, _)) in image.pixels.iter_mut().zip(&samples) {
                *p = hit.map_or(scene.background, |h| h.0);
            }
        }
        Aov::Normal => {
            for (p, (hit, _, _)) in image.pixels.iter_mut().zip(&samples) {
                *p = hit.map_or(BLACK, |h| h.1 * 0.5 + 0.5);
            }
        }
        Aov::Depth => {
            let far = samples.iter().filter_map(|s| s.0.map(|h| h.2)).fold(0.0f32, f32::max);
            for (p, (hit, _, _)) in image.pixels.iter_mut().zip(&samples) {
                *p = hit.map_or(WHITE, |h| Color::splat(if far > 0.0 { h.2 / far } else { 0.0 }));
            }
        }
        Aov::Cost => {
            let (nodes, tests): (u64, u64) = samples.iter().fold((0, 0), |(a, b), s| (a + s.1, b + s.2));
            stats.nodes_per_ray = nodes as f64 / rays.max(1) as f64;
            stats.tests_per_ray = tests as f64 / rays.max(1) as f64;
            stats.max_cost = samples.iter().map(|s| s.1 + s.2).max().unwrap_or(0);
            let scale = 1.0 / stats.max_cost.max(1) as f32;
            for (p, s) in image.pixels.iter_mut().zip(&samples) {
                *p = heat((s.1 + s.2) as f32 * scale);
            }
            color_bar(&mut image, height, stats.max_cost);
        }
    }
    (image, stats)
}

/// A heat colour for `x` in [0, 1]: dark blue, blue, cyan, green, yellow, red, dark red.
#[must_use]
pub fn heat(x: f32) -> Color {
    const STOPS: [Vec3; 7] = [
        Vec3::new(0.0, 0.0, 0.3),
        Vec3::new(0.0, 0.2, 1.0),
        Vec3::new(0.0, 0.9, 1.0),
        Vec3::new(0.1, 0.9, 0.1),
        Vec3::new(1.0, 0.95, 0.0),
        Vec3::new(1.0, 0.1, 0.0),
        Vec3::new(0.45, 0.0, 0.0),
    ];
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) } * (STOPS.len() - 1) as f32;
    let i = (x as usize).min(STOPS.len() - 2);
    STOPS[i].lerp(STOPS[i + 1], x - i as f32)
}

/// The bar under the image (rows `top..`): the heat scale left to right, `0` at the left
/// end and `max` at the right, in white digits.
fn color_bar(image: &mut Image, top: u32, max: u64) {
    let w = image.width;
    for y in top..image.height {
        for x in 0..w {
            image.set(x, y, heat(x as f32 / (w - 1).max(1) as f32));
        }
    }
    let label_y = top + (COLOR_BAR_ROWS - 2 * DIGIT_ROWS) / 2;
    draw_number(image, 0, 2, label_y);
    let text = max.to_string();
    let text_w = text.len() as u32 * (2 * DIGIT_COLS + 2);
    draw_number(image, max, w.saturating_sub(text_w + 2), label_y);
}

const DIGIT_ROWS: u32 = 5;
const DIGIT_COLS: u32 = 3;
/// Digits 0–9 in 3×5 pixels, one row per entry, the high bit at the left.
const DIGITS: [[u8; 5]; 10] = [
    [0b111, 0b101, 0b101, 0b101, 0b111],
    [0b010, 0b110, 0b010, 0b010, 0b111],
    [0b111, 0b001, 0b111, 0b100, 0b111],
    [0b111, 0b001, 0b111, 0b001, 0b111],
    [0b101, 0b101, 0b111, 0b001, 0b001],
    [0b111, 0b100, 0b111, 0b001, 0b111],
    [0b111, 0b100, 0b111, 0b101, 0b111],
    [0b111, 0b001, 0b001, 0b001, 0b001],
    [0b111, 0b101, 0b111, 0b101, 0b111],
    [0b111, 0b101, 0b111, 0b001, 0b111],
];

/// `n` in white digits twice the font's size, from `(x0, y0)` (clipped to the image).
fn draw_number(image: &mut Image, n: u64, x0: u32, y0: u32) {
    for (k, ch) in n.to_string().bytes().enumerate() {
        let glyph = DIGITS[(ch - b'0') as usize];
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..DIGIT_COLS {
                if bits & (1 << (DIGIT_COLS - 1 - col)) == 0 {
                    continue;
                }
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let x = x0 + k as u32 * (2 * DIGIT_COLS + 2) + 2 * col + dx;
                    let y = y0 + 2 * row as u32 + dy;
                    if x < image.width && y < image.height {
                        image.set(x, y, WHITE);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heat_runs_from_dark_blue_to_dark_red_and_clamps() {
        assert_eq!(heat(0.0), Vec3::new(0.0, 0.0, 0.3));
        assert_eq!(heat(1.0), Vec3::new(0.45, 0.0, 0.0));
        assert_eq!(heat(-3.0), heat(0.0));
        assert_eq!(heat(7.0), heat(1.0));
        assert_eq!(heat(f32::NAN), heat(0.0));
        assert!(heat(0.5).is_finite());
    }

    #[test]
    fn names_parse_and_unknown_ones_list_the_choices() {
        for a in Aov::ALL {
            assert_eq!(a.name().parse::<Aov>().unwrap(), a);
        }
        let e = "bogus".parse::<Aov>().unwrap_err();
        assert!(e.contains("albedo, normal, depth, cost"), "{e}");
    }

    #[test]
    fn numbers_are_drawn_in_white_where_they_fit() {
        let mut img = Image::new(40, 12);
        draw_number(&mut img, 1234567890, 0, 0);
        let white = img.pixels.iter().filter(|&&c| c == WHITE).count();
        assert!(white > 20, "{white}");
        // The '1' at the left: its stem (column 1 of the glyph, doubled) is lit on row 0.
        assert_eq!(img.get(2, 0), WHITE);
    }
}
