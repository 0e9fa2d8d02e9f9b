//! The renderer: tiles in parallel (rayon), `spp` jittered samples per pixel, each sample's
//! random numbers seeded from `(seed, pixel, sample)`, so the image is the same on any
//! number of threads.

use crate::camera::Camera;
use crate::integrators::{Integrator, RayCounters};
use crate::io::image::Image;
use crate::math::color::Color;
use crate::math::ray::{RayLanes, LANES};
use crate::math::sampling::{pixel_rng, Sampler};
use crate::scene::Scene;
use rayon::prelude::*;
use std::time::Instant;

/// Pixel samples whose value was not a radiance (pbrt reports them too): a NaN or an
/// infinity is dropped from its pixel (the pixel averages its other samples; black if it
/// has none), so one bad sample cannot poison an image; a negative one is kept, counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SampleCounts {
    /// Samples with a NaN component (dropped).
    pub nan: u64,
    /// Samples with an infinite component and no NaN (dropped).
    pub inf: u64,
    /// Finite samples with a negative component (kept).
    pub negative: u64,
}

impl SampleCounts {
    /// Count `c`; true when it may be added to its pixel (it is finite).
    #[inline]
    pub fn check(&mut self, c: Color) -> bool {
        // The usual sample, finite and non-negative, decided by one branch (a NaN fails
        // every comparison). PERF: three branches before, on every sample.
        if (c.x >= 0.0) & (c.y >= 0.0) & (c.z >= 0.0) & (c.x < f32::INFINITY) & (c.y < f32::INFINITY) & (c.z < f32::INFINITY) {
            return true;
        }
        if c.is_nan() {
            self.nan += 1;
            false
        } else if !c.is_finite() {
            self.inf += 1;
            false
        } else {
            if c.min_element() < 0.0 {
                self.negative += 1;
            }
            true
        }
    }

    /// True when every sample was a finite, non-negative radiance.
    #[must_use]
    pub fn all_good(&self) -> bool {
        self.nan == 0 && self.inf == 0 && self.negative == 0
    }

    /// The sum of two counts.
    #[must_use]
    pub fn add(&self, o: &SampleCounts) -> SampleCounts {
        SampleCounts { nan: self.nan + o.nan, inf: self.inf + o.inf, negative: self.negative + o.negative }
    }
}

/// Figures of a finished render.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Rays traced, by kind.
    pub rays: RayCounters,
    /// Samples that were not a radiance (NaN, infinite, negative).
    pub samples: SampleCounts,
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
    /// pixel centre; more are jittered uniformly over the pixel. 0 renders as 1.
    pub spp: u32,
    /// Seed of every random number of the render.
    pub seed: u64,
    /// Tile edge in pixels.
    pub tile: u32,
    /// Trace up to [`LANES`] samples together ([`Integrator::li_lanes`]) where the
    /// integrator can; `false`: one sample at a time. The same image either way.
    pub lanes: bool,
}

impl Renderer {
    /// A renderer for `width × height` images, one sample per pixel, seed 0.
    #[must_use]
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, spp: 1, seed: 0, tile: 16, lanes: true }
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
    ///
    /// # Panics
    /// If the image is larger than [`crate::io::image::MAX_PIXELS`] (check the size first
    /// with [`crate::io::image::check_size`], as the `isir` command does): a render takes
    /// about 15 bytes a pixel, and more than that would fail to allocate.
    #[must_use]
    pub fn render(&self, scene: &Scene, camera: &Camera, integrator: &Integrator) -> (Image, RenderStats) {
        let pixels = u64::from(self.width) * u64::from(self.height);
        assert!(
            pixels <= crate::io::image::MAX_PIXELS,
            "{}x{}: more pixels than the {} a render may have (io::image::check_size)",
            self.width,
            self.height,
            crate::io::image::MAX_PIXELS
        );
        if self.spp == 0 {
            // Set through the field, past `spp()`'s clamp: no sample gave a black image.
            return Renderer { spp: 1, ..self.clone() }.render(scene, camera, integrator);
        }
        self.render_with_progress(scene, camera, integrator, &|_| {})
    }

    /// Render, calling `progress(pixels)` each time a tile of `pixels` pixels is done.
    ///
    /// The image is the only full-size buffer: it is cut into bands of one row of tiles,
    /// the bands rendered in parallel, and in each band its tiles in parallel into buffers
    /// of one tile, copied into the band as they come. So the memory of a render is the
    /// image's 12 bytes per pixel and a few bands (see [`crate::io::image::MAX_PIXELS`]).
    pub fn render_with_progress(
        &self,
        scene: &Scene,
        camera: &Camera,
        integrator: &Integrator,
        progress: &(dyn Fn(u64) + Sync),
    ) -> (Image, RenderStats) {
        let start = Instant::now();
        let (w, h, ts) = (self.width, self.height, self.tile.max(1));
        let mut image = Image::new(w, h);
        if w == 0 || h == 0 {
            return (image, RenderStats { seconds: start.elapsed().as_secs_f64(), ..RenderStats::default() });
        }
        let tiles_x = w.div_ceil(ts);
        let band_len = ts as usize * w as usize;
        let (rays, samples) = image
            .pixels
            .par_chunks_mut(band_len)
            .enumerate()
            .map(|(ty, band)| {
                let y0 = ty as u32 * ts;
                let y1 = (y0 + ts).min(h);
                (0..tiles_x)
                    .into_par_iter()
                    .map(|tx| {
                        let (x0, x1) = (tx * ts, (tx * ts + ts).min(w));
                        let mut counters = (RayCounters::default(), SampleCounts::default());
                        let pixels = if self.lanes {
                            self.tile_in_lanes(scene, camera, integrator, (x0, x1, y0, y1), &mut counters)
                        } else {
                            let mut pixels = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
                            for y in y0..y1 {
                                for x in x0..x1 {
                                    pixels.push(self.pixel(scene, camera, integrator, x, y, &mut counters));
                                }
                            }
                            pixels
                        };
                        progress(pixels.len() as u64);
                        (x0, pixels, counters)
                    })
                    // Tiles go into the band in any order: each pixel has its own place.
                    .collect::<Vec<_>>()
                    .into_iter()
                    .fold((RayCounters::default(), SampleCounts::default()), |(rays, samples), (x0, pixels, counters)| {
                        let tw = pixels.len() / (y1 - y0) as usize;
                        for (row, src) in pixels.chunks_exact(tw).enumerate() {
                            let i = row * w as usize + x0 as usize;
                            band[i..i + tw].copy_from_slice(src);
                        }
                        (rays.add(&counters.0), samples.add(&counters.1))
                    })
            })
            .reduce(|| (RayCounters::default(), SampleCounts::default()), |a, b| (a.0.add(&b.0), a.1.add(&b.1)));
        (image, RenderStats { seconds: start.elapsed().as_secs_f64(), rays, samples })
    }

    /// The pixels of the tile `x0..x1 × y0..y1`, row by row, as [`Renderer::pixel`] gives
    /// them: the tile's samples, pixel by pixel and sample by sample, go [`LANES`] at a time
    /// through [`Integrator::li_lanes`], and each pixel sums its samples in their order.
    fn tile_in_lanes(
        &self,
        scene: &Scene,
        camera: &Camera,
        integrator: &Integrator,
        (x0, x1, y0, y1): (u32, u32, u32, u32),
        (counters, samples): &mut (RayCounters, SampleCounts),
    ) -> Vec<Color> {
        let tw = (x1 - x0) as usize;
        let mut sums = vec![(Color::ZERO, 0u32); tw * (y1 - y0) as usize];
        let mut samplers: Vec<Sampler> = Vec::with_capacity(LANES);
        let (mut sx, mut sy, mut slot) = ([0.0f32; LANES], [0.0f32; LANES], [0usize; LANES]);
        let mut rays = RayLanes::new(&[]);
        let mut out = [Color::ZERO; LANES];
        let mut flush = |samplers: &mut Vec<Sampler>, sx: &[f32; LANES], sy: &[f32; LANES], slot: &[usize], sums: &mut [(Color, u32)]| {
            let n = samplers.len();
            camera.generate_lanes(sx, sy, n, &mut rays);
            integrator.li_lanes(scene, &rays, samplers, counters, &mut out);
            // Each pixel's run of samples summed in a local, in sample order, and stored
            // once. PERF: added in place, each sample's sum waited on the store of the one
            // before it (store-to-load forwarding): tp4-bunny at 64 spp 0.976, tp4-sphere
            // 0.980, tp5-phong 0.982 (9 runs).
            let mut k = 0;
            while k < n {
                let (mut sum, mut kept) = sums[slot[k]];
                let start = k;
                while k < n && slot[k] == slot[start] {
                    if samples.check(out[k]) {
                        sum += out[k];
                        kept += 1;
                    }
                    k += 1;
                }
                sums[slot[start]] = (sum, kept);
            }
            samplers.clear();
        };
        for y in y0..y1 {
            for x in x0..x1 {
                let pixel_index = u64::from(y) * u64::from(self.width) + u64::from(x);
                for s in 0..self.spp {
                    let k = samplers.len();
                    let (rng, screen) = self.camera_sample(x, y, pixel_index, s);
                    (sx[k], sy[k]) = (screen.x, screen.y);
                    slot[k] = (y - y0) as usize * tw + (x - x0) as usize;
                    samplers.push(rng);
                    if samplers.len() == LANES {
                        flush(&mut samplers, &sx, &sy, &slot, &mut sums);
                    }
                }
            }
        }
        if !samplers.is_empty() {
            flush(&mut samplers, &sx, &sy, &slot, &mut sums);
        }
        sums.into_iter().map(|(sum, kept)| average(sum, kept)).collect()
    }

    /// Sample `s` of pixel `(x, y)` (row-major index `pixel_index`): its random numbers
    /// after the jitter is drawn, and its screen point (the pixel centre at 1 spp, a
    /// jittered point otherwise).
    #[inline]
    fn camera_sample(&self, x: u32, y: u32, pixel_index: u64, s: u32) -> (Sampler, glam::Vec2) {
        let mut rng = pixel_rng(self.seed, pixel_index, s);
        let jitter = if self.spp == 1 { glam::Vec2::splat(0.5) } else { rng.next_2d() };
        let screen = glam::Vec2::new((x as f32 + jitter.x) / self.width as f32, (y as f32 + jitter.y) / self.height as f32);
        (rng, screen)
    }

    /// The average of the pixel's finite samples (see [`SampleCounts`]).
    fn pixel(
        &self,
        scene: &Scene,
        camera: &Camera,
        integrator: &Integrator,
        x: u32,
        y: u32,
        (counters, samples): &mut (RayCounters, SampleCounts),
    ) -> Color {
        let pixel_index = u64::from(y) * u64::from(self.width) + u64::from(x);
        let mut sum = Color::ZERO;
        let mut kept = 0u32;
        for s in 0..self.spp {
            let (mut rng, screen) = self.camera_sample(x, y, pixel_index, s);
            let ray = camera.generate_ray(screen.x, screen.y);
            let c = integrator.li(scene, &ray, 0.0, f32::INFINITY, &mut rng, counters);
            if samples.check(c) {
                sum += c;
                kept += 1;
            }
        }
        average(sum, kept)
    }
}

/// A pixel's value: the average of its `kept` finite samples, black if it has none.
#[inline]
fn average(sum: Color, kept: u32) -> Color {
    if kept == 0 {
        Color::ZERO
    } else {
        sum / kept as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicU64, Ordering};

    /// The render in bands is the image of its pixels one by one (each pixel's samples
    /// seeded by its index), at sizes that are not multiples of the tile, on any pool.
    #[test]
    fn bands_of_tiles_give_every_pixel_its_own_samples() {
        let desc = crate::scenes::builtin("tp4-conference").unwrap();
        let scene = desc.build(crate::Accel::BvhSah).unwrap();
        for (w, h, tile) in [(37, 21, 16), (16, 16, 16), (5, 40, 7), (1, 1, 16), (33, 2, 1)] {
            let r = Renderer { tile, ..Renderer::new(w, h).spp(2).seed(11) };
            let camera = desc.camera.build(r.aspect());
            let integrator = Integrator::DirectLighting { light_samples: 2 };
            let mut expected = Image::new(w, h);
            let mut rays = (RayCounters::default(), SampleCounts::default());
            for y in 0..h {
                for x in 0..w {
                    expected.set(x, y, r.pixel(&scene, &camera, &integrator, x, y, &mut rays));
                }
            }
            for threads in [1, 3] {
                let done = AtomicU64::new(0);
                let calls = AtomicU64::new(0);
                let (image, stats) = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| {
                    r.render_with_progress(&scene, &camera, &integrator, &|n| {
                        done.fetch_add(n, Ordering::Relaxed);
                        calls.fetch_add(1, Ordering::Relaxed);
                    })
                });
                assert_eq!(image.pixels, expected.pixels, "{w}x{h}, tile {tile}, {threads} threads");
                assert_eq!((stats.rays, stats.samples), rays);
                assert_eq!(done.into_inner(), u64::from(w) * u64::from(h), "progress counts every pixel once");
                assert_eq!(calls.into_inner(), u64::from(w.div_ceil(tile) * h.div_ceil(tile)), "one call per tile");
            }
        }
    }

    /// The image `r` renders one sample at a time, after checking that samples in lanes
    /// give it pixel for pixel, with the same ray and sample counts (`what` names the case).
    fn lanes_match_one_at_a_time(
        desc: &crate::scenes::SceneDescription,
        scene: &Scene,
        integrator: &Integrator,
        r: Renderer,
        what: &str,
    ) -> Image {
        let one = Renderer { lanes: false, ..r };
        let camera = desc.camera.build(one.aspect());
        let many = Renderer { lanes: true, ..one.clone() };
        let (a, sa) = one.render(scene, &camera, integrator);
        let (b, sb) = many.render(scene, &camera, integrator);
        assert!(a.pixels == b.pixels, "{what}, {integrator:?}, {} spp", one.spp);
        assert_eq!((sa.rays, sa.samples), (sb.rays, sb.samples), "{what}, {integrator:?}");
        a
    }

    /// Whitted's mirror and glass recursion in lanes (breadth first, then summed depth
    /// first) gives the image of one sample at a time where branches leave the scene (the
    /// background), stop at `max_depth` (1 and 2) or are pruned by their weight: the TP6
    /// glass room without its walls and floor.
    #[test]
    fn whitted_lanes_match_one_at_a_time_where_rays_leave_the_scene() {
        let mut desc = crate::scenes::builtin("tp6-glass").unwrap();
        desc.objects.retain(|o| !matches!(o.shape, crate::scenes::ShapeDesc::Plane(_)));
        desc.background = Color::new(0.2, 0.3, 0.4);
        let scene = desc.build(crate::Accel::BvhSah).unwrap();
        let mut background = 0;
        for (max_depth, spp) in [(1, 3), (2, 5), (5, 16)] {
            let integrator = Integrator::Whitted { light_samples: 1, max_depth };
            let image = lanes_match_one_at_a_time(&desc, &scene, &integrator, Renderer::new(41, 29).spp(spp).seed(9), "whitted");
            background += image.pixels.iter().filter(|p| **p == desc.background).count();
        }
        assert!(background > 100, "{background} background pixels");
    }

    /// Samples in lanes give the image of one sample at a time, pixel for pixel, and the
    /// same counts: every built-in scene with its own integrator and with each of the four,
    /// at sample counts that fill lanes partly (1, 3), exactly (16) and across pixels (5),
    /// on meshes at this CPU's best SIMD level.
    #[test]
    fn lanes_render_the_image_of_one_sample_at_a_time() {
        let mut scenes = 0;
        for (name, _) in crate::scenes::list() {
            let desc = crate::scenes::builtin(name).unwrap();
            let integrators = [
                desc.integrator,
                Integrator::RayCast,
                Integrator::DirectLighting { light_samples: 3 },
                // Quad lights' one to three samples sample by sample in lanes.
                Integrator::DirectLighting { light_samples: 1 },
                // Quad lights' samples two lanes to a stream (four to eight samples).
                Integrator::DirectLighting { light_samples: 6 },
                // Two lanes' whole batches to a stream (nine to sixteen samples).
                Integrator::DirectLighting { light_samples: 11 },
                Integrator::Whitted { light_samples: 3, max_depth: 4 },
                Integrator::Path { light_samples: 3, max_depth: 4 },
            ];
            let scene = desc.build(crate::Accel::BvhSah).unwrap();
            scenes += 1;
            for (i, integrator) in integrators.into_iter().enumerate() {
                let spp = [1, 3, 16, 5, 7, 2, 4][(i + name.len()) % 7];
                lanes_match_one_at_a_time(&desc, &scene, &integrator, Renderer::new(37, 23).spp(spp).seed(4), name);
            }
        }
        assert!(scenes >= 30, "{scenes} scenes");
    }
}
