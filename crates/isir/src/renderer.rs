//! The renderer: tiles in parallel (rayon), `spp` jittered samples per pixel, each sample's
//! random numbers seeded from `(seed, pixel, sample)`, so the image is the same on any
//! number of threads.

use crate::camera::Camera;
use crate::color::Color;
use crate::image::Image;
use crate::integrator::{Integrator, RayCounters};
use crate::sampling::pixel_rng;
use crate::scene::Scene;
use rayon::prelude::*;
use std::time::Instant;

/// Figures of a finished render.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Rays traced, by kind.
    pub rays: RayCounters,
}

impl RenderStats {
    /// Millions of rays per second.
    #[must_use]
    pub fn mrays_per_second(&self) -> f64 {
        self.rays.total() as f64 / self.seconds.max(1e-9) * 1e-6
    }
}

/// Renders images of a scene.
#[derive(Clone, Debug)]
pub struct Renderer {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel (the course's `nbPixelSamples`). One sample goes through the
    /// pixel centre; more are jittered uniformly over the pixel.
    pub spp: u32,
    /// Seed of every random number of the render.
    pub seed: u64,
    /// Tile edge in pixels.
    pub tile: u32,
}

impl Renderer {
    /// A renderer for `width × height` images, one sample per pixel, seed 0.
    #[must_use]
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, spp: 1, seed: 0, tile: 16 }
    }

    /// Set the samples per pixel.
    #[must_use]
    pub fn spp(mut self, spp: u32) -> Self {
        self.spp = spp.max(1);
        self
    }

    /// Set the seed.
    #[must_use]
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Width / height.
    #[must_use]
    pub fn aspect(&self) -> f32 {
        self.width as f32 / self.height.max(1) as f32
    }

    /// Render on the current rayon pool.
    #[must_use]
    pub fn render(&self, scene: &Scene, camera: &Camera, integrator: &Integrator) -> (Image, RenderStats) {
        self.render_with_progress(scene, camera, integrator, &|_| {})
    }

    /// Render, calling `progress(pixels)` each time a tile of `pixels` pixels is done.
    pub fn render_with_progress(
        &self,
        scene: &Scene,
        camera: &Camera,
        integrator: &Integrator,
        progress: &(dyn Fn(u64) + Sync),
    ) -> (Image, RenderStats) {
        let start = Instant::now();
        let (w, h, ts) = (self.width, self.height, self.tile.max(1));
        let tiles_x = w.div_ceil(ts);
        let tiles: Vec<(u32, u32)> = (0..h.div_ceil(ts)).flat_map(|ty| (0..tiles_x).map(move |tx| (tx, ty))).collect();
        let done: Vec<(u32, u32, Vec<Color>, RayCounters)> = tiles
            .par_iter()
            .map(|&(tx, ty)| {
                let (x0, y0) = (tx * ts, ty * ts);
                let (x1, y1) = ((x0 + ts).min(w), (y0 + ts).min(h));
                let mut counters = RayCounters::default();
                let mut pixels = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
                for y in y0..y1 {
                    for x in x0..x1 {
                        pixels.push(self.pixel(scene, camera, integrator, x, y, &mut counters));
                    }
                }
                progress(pixels.len() as u64);
                (x0, y0, pixels, counters)
            })
            .collect();
        let mut image = Image::new(w, h);
        let mut rays = RayCounters::default();
        for (x0, y0, pixels, counters) in done {
            let tw = (x0 + ts).min(w) - x0;
            for (i, c) in pixels.into_iter().enumerate() {
                let (x, y) = (x0 + i as u32 % tw, y0 + i as u32 / tw);
                image.set(x, y, c);
            }
            rays.primary += counters.primary;
            rays.shadow += counters.shadow;
        }
        (image, RenderStats { seconds: start.elapsed().as_secs_f64(), rays })
    }

    /// The average of the pixel's samples.
    fn pixel(&self, scene: &Scene, camera: &Camera, integrator: &Integrator, x: u32, y: u32, counters: &mut RayCounters) -> Color {
        let pixel_index = u64::from(y) * u64::from(self.width) + u64::from(x);
        let mut sum = Color::ZERO;
        for s in 0..self.spp {
            let mut rng = pixel_rng(self.seed, pixel_index, s);
            let jitter = if self.spp == 1 { glam::Vec2::splat(0.5) } else { rng.next_2d() };
            let sx = (x as f32 + jitter.x) / self.width as f32;
            let sy = (y as f32 + jitter.y) / self.height as f32;
            let ray = camera.generate_ray(sx, sy);
            sum += integrator.li(scene, &ray, 0.0, f32::INFINITY, &mut rng, counters);
        }
        sum / self.spp as f32
    }
}
