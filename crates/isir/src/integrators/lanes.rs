//! Camera samples in lanes: up to [`LANES`] samples traced together, stage by stage (a
//! small wavefront). Their closest hits come from one [`Scene::intersect_lanes`]; each
//! lane's surface interaction and shading is the course's code, one lane after another;
//! the shadow rays of all the lanes towards one point light go to one
//! [`Scene::occluded_lanes`]. Whitted's mirrors and glass recurse breadth first, every
//! lane's rays of one depth found together (`whitted::li_at_hits`); the
//! path tracer steps its paths side by side, each bounce's hits found in lanes. Every lane's colour is the
//! one [`Integrator::li`] returns for its ray and sampler, bit for bit: the same operations
//! on the same floats, only grouped differently.
//!
//! PERF: one sample at a time, the pipeline is a chain of latencies (a division to decide
//! a branch, a square root to normalise, a store read back): samples side by side let the
//! CPU overlap them, and spheres and planes are tested against all the lanes at once.

use super::direct::{quad_light, with_quad_scratch};
use super::path::{defers_shadow, light_samplers, DeferredShadow, Path};
use super::shadow::{divided, live_mask, LambertLanes, LightLanes, QuadBatch, BATCH, BATCH_FROM};
use super::{whitted, Integrator, RayCounters, MAX_DEPTH_LIMIT};
use crate::geometry::{Hit, HitRows};
use crate::kept::{Kept, Slot};
use crate::lights::{Light, LightSampler};
use crate::materials::Material;
use crate::math::color::Color;
use crate::math::ray::{lane_mask, lanes_of, spawn_lanes, RayLanes, LANES};
use crate::math::sampling::{cosine_hemisphere_lanes, Sampler};
use crate::scene::Scene;
use glam::{Vec2, Vec3};

impl Integrator {
    /// The radiance along each of the first `samplers.len()` rays of `rays` (camera rays:
    /// interval `[0, ∞)`), into `out`: `out[k]` is what [`Integrator::li`] returns for ray
    /// `k` and `samplers[k]`, bit for bit, and the counters add up the same.
    ///
    /// # Panics
    /// If there are more than [`LANES`] samplers or `out` is shorter than `samplers`.
    pub fn li_lanes(&self, scene: &Scene, rays: &RayLanes, samplers: &mut [Sampler], counters: &mut RayCounters, out: &mut [Color]) {
        let n = samplers.len();
        assert!(n <= LANES && out.len() >= n);
        counters.primary += n as u64;
        let closest = scene.intersect_lanes(rays, n);
        if let Integrator::Path { light_samples, max_depth } = *self {
            // The hits and their rows written where the bounces keep them.
            let (mut hits, mut rows) = ([None; LANES], HitRows::default());
            scene.lane_hit_rows_into(rays, &closest, n, &mut hits, &mut rows);
            return path_lanes(scene, rays, &mut hits, &mut rows, light_samples, max_depth.min(MAX_DEPTH_LIMIT), samplers, counters, out);
        }
        let mut hits = [None; LANES];
        scene.lane_hits_into(rays, &closest, n, &mut hits);
        match *self {
            Integrator::DirectLighting { light_samples } => direct_lanes(scene, rays, &hits, light_samples, samplers, counters, out),
            Integrator::Whitted { light_samples, max_depth } => {
                // Direct lighting in lanes where the surface is not a mirror or glass; the
                // recursion of the lanes where it is, their rays found depth by depth.
                let specular = lane_mask(&std::array::from_fn(|k| hits[k].as_ref().is_some_and(|h| scene.material(h).is_delta())));
                // PERF: the hits copied without the specular lanes only when there are some.
                if specular == 0 {
                    direct_lanes(scene, rays, &hits, light_samples, samplers, counters, out);
                } else {
                    let diffuse: [Option<Hit>; LANES] = std::array::from_fn(|k| if specular & (1 << k) != 0 { None } else { hits[k] });
                    direct_lanes(scene, rays, &diffuse, light_samples, samplers, counters, out);
                    let max_depth = max_depth.min(MAX_DEPTH_LIMIT);
                    whitted::li_at_hits(scene, rays, &hits, specular, light_samples, max_depth, samplers, counters, out);
                }
            }
            Integrator::Path { .. } => unreachable!("the path tracer returned above"),
            Integrator::RayCast => {
                for k in 0..n {
                    let ray = rays.ray(k);
                    out[k] = match &hits[k] {
                        None => scene.background,
                        Some(hit) => scene.material(hit).color_at(hit) * hit.normal.dot(-ray.direction).max(0.0),
                    };
                }
            }
        }
    }
}

/// At most this many live paths go on alone ([`Path::follow`]) unless the scene is one
/// mesh: 2, 3, 4, 6 and 8 measured alike (tp6-glass-quad, path, Lambert: 0.943, 0.939,
/// 0.936, 0.933, 0.939 of the CPU time).
const ALONE_LANES: u32 = 4;

/// The path tracer's sixteen paths stepped side by side: each lane's vertex is
/// [`Path::step`] (the lane's own sampler, the same operations as one path at a time),
/// run phase by phase over the lanes, and every bounce's next hits come from one
/// [`Scene::intersect_lanes`] over the paths still going (the others are zero rays,
/// which meet nothing), until, unless the scene is one mesh, at most [`ALONE_LANES`]
/// paths are left: those are followed alone ([`Path::follow`]). `hits` holds the camera
/// rays' hits, then each bounce's, and `rows` their points and normals as rows
/// ([`HitRows`]), read by the SIMD phases (the light samples, the BSDF's cosine lobe and
/// the next rays).
/// PERF: one path at a time, a vertex is one long chain of dependent operations (square
/// roots, divisions, a sine and cosine); phase by phase the CPU overlaps the lanes'
/// chains, and the arithmetic phases are SIMD loops over the lanes (`LightLanes`,
/// `cosine_hemisphere_lanes`, `spawn_lanes`, `LightSampler::intersect_lanes`). Path,
/// Lambert, tp6-matte 16 spp 1.67 -> 1.04 s over the tenth session (ARCHITECTURE.md).
/// Out of line: inlined into `li_lanes`, tp6-glass-quad took 1.04 of the time and
/// tp6-matte 1.02 (minima of 9).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn path_lanes(
    scene: &Scene,
    rays: &RayLanes,
    hits: &mut [Option<Hit>; LANES],
    rows: &mut HitRows,
    light_samples: u32,
    max_depth: u32,
    samplers: &mut [Sampler],
    counters: &mut RayCounters,
    out: &mut [Color],
) {
    let n = samplers.len();
    let mut paths = [Path::new(); LANES];
    // The rays followed (the camera's, then each bounce's) and the next ones, taking turns.
    // PERF: the per-bounce arrays live across the bounces, each lane written before it is
    // read: made afresh each bounce, their zeroing and copies (`memset`, `memcpy`) were
    // 7% of tp6-matte's samples (`perf`); kept, tp6-matte took 0.95 of the time and
    // tp6-glass-quad 0.97 (path, Lambert, minima of 9).
    let mut ray_pair = [*rays, RayLanes::EMPTY];
    let mut turn = 0;
    let mut wo = [Vec3::ZERO; LANES];
    let mut bs = [None; LANES];
    let (mut xi, mut wi) = ([Vec2::ZERO; LANES], [[0f32; LANES]; 3]);
    // The light samples' batch, filled in place at each vertex (`defer`, `quad_nee_lanes`),
    // and the Lambert lanes' albedos (each vertex writes the lanes it reads). PERF: made
    // afresh per vertex, their 1.5 kB were zeroed (`memset`).
    let mut batch = LightLanes::EMPTY;
    let mut albedo = [[0f32; BATCH]; 3];
    let mut active: u32 = if n == 0 { 0 } else { u32::MAX >> (32 - n) };
    // A scene lit by one point light: the sixteen paths' samples and shadow rays set up
    // together (`LightLanes`), the rays left for one `occluded_lanes` (`Path::defer_point`).
    // PERF: only there: the bookkeeping made the quad-light scenes 2% slower.
    let defer = defers_shadow(scene);
    let mut deferred = [DeferredShadow::NONE; LANES];
    let lights = light_samplers(scene);
    let uniform = MaterialMasks::uniform(scene);
    // A scene lit by one quad light sampled fewer than `BATCH_FROM` times per vertex:
    // each sample of the sixteen paths set up and traced together (`quad_nee_lanes`).
    let surface_lights = scene.lights.iter().any(Light::is_surface);
    let alone_from_few = scene.only_mesh().is_none();
    let quad_in_lanes = lights.len() == 1 && matches!(lights[0], LightSampler::Quad { .. }) && light_samples.max(1) < BATCH_FROM;
    loop {
        let (cur, next) = match &mut ray_pair {
            [a, b] if turn == 0 => (&*a, b),
            [a, b] => (&*b, a),
        };
        let mut ended = 0u32;
        // Each vertex as `Path::step`'s phases, each a pass over the lanes (each lane's
        // random numbers drawn in the same order): the light met on the way, next-event
        // estimation, the BSDF samples, the throughput and the next rays.
        // `Path::arrive`: the quad lights met by all the lanes at once, light by light.
        if surface_lights {
            let t_hit: [f32; LANES] = std::array::from_fn(|k| hits[k].as_ref().map_or(cur.t_max[k], |h| h.t));
            for light in &lights {
                let met = light.intersect_lanes(cur, &t_hit, active);
                for k in lanes_of(met.met) {
                    let Some(lh) = met.hit(k, light.emitted()) else { unreachable!("a lane that met the light has its hit") };
                    paths[k].meet_light(&lh, light_samples);
                }
            }
        }
        let back = cur.outgoing();
        for k in lanes_of(active) {
            if paths[k].goes_on(scene, hits[k].as_ref(), max_depth) {
                wo[k] = Vec3::new(back[0][k], back[1][k], back[2][k]);
            } else {
                ended |= 1 << k;
            }
        }
        let going = active & !ended;
        let kinds = MaterialMasks::of(scene, hits, going, uniform);
        // The lanes taking next-event estimation (`Path::light_direct`: not a delta).
        let nee = going & !kinds.delta;
        if defer {
            // The point light's samples and shadow rays of every lane at once; each
            // lane's two numbers skipped as `next_event` draws them (a point needs none).
            for k in lanes_of(nee) {
                samplers[k].skip::<2>();
            }
            batch.fill_rows(&lights[0], rows, &[Vec2::ZERO; BATCH]);
            // The lanes whose shadow rays the deferred samples trace. Lambert lanes decide
            // and value theirs in SIMD loops (`LightLanes::lambert_point_values`: the
            // operations of `defer_point`, the same floats), the others lane by lane.
            // PERF: lane by lane, each lane's sample, BRDF and value were one chain of
            // dependent operations.
            let lambert = nee & kinds.lambert;
            let mut traced = 0u32;
            if lambert != 0 {
                gather_albedos(scene, hits, lambert, &mut albedo);
                let lobe = LambertLanes { normal: &rows.normal, wo: &back, albedo: &albedo };
                let (lobe_traced, value) = batch.lambert_point_values(&lobe);
                traced = lane_mask(&lobe_traced) & lambert;
                for k in lanes_of(lambert & !traced) {
                    paths[k].add_unlit();
                }
                for k in lanes_of(traced) {
                    deferred[k] = paths[k].deferred(Vec3::new(value[0][k], value[1][k], value[2][k]));
                }
                counters.shadow += u64::from(traced.count_ones());
            }
            for k in lanes_of(nee & !lambert) {
                let Some(hit) = &hits[k] else { unreachable!("an arrived lane has a hit") };
                if let Some(d) = paths[k].defer_point(scene, hit, wo[k], &batch.sample(k), batch.has_ray[k], counters) {
                    deferred[k] = d;
                    traced |= 1 << k;
                }
            }
            // Each path's radiance gains the answer where `next_event` adds it: nothing
            // else is added to it before the next vertex.
            if traced != 0 {
                let blocked = scene.occluded_lanes(&batch.rays, traced);
                for k in lanes_of(traced) {
                    paths[k].finish_shadow(&deferred[k], blocked & (1 << k) != 0);
                }
            }
        } else if quad_in_lanes {
            let scratch = (&mut batch, &mut albedo);
            let wo = (&wo, &back);
            let masks = (nee, kinds.lambert);
            quad_nee_lanes(scene, &lights[0], hits, rows, wo, masks, light_samples.max(1), &mut paths, samplers, counters, scratch);
        } else {
            for k in lanes_of(going) {
                let Some(hit) = &hits[k] else { unreachable!("an arrived lane has a hit") };
                paths[k].light_direct(scene, &lights, hit, wo[k], light_samples, &mut samplers[k], counters);
            }
        }
        // The BSDF samples: the cosine lobe's directions of all the lanes at once, the
        // other materials' lane by lane (each lane's numbers drawn as `sample_bsdf` draws
        // them).
        let lobe = kinds.lobe;
        if lobe != 0 {
            // `u_lobe`, then `u` (the first number unused by the cosine lobe).
            let mut u = [[0f32; LANES]; 3];
            Sampler::draw_lanes(samplers, lobe, &mut u);
            xi = std::array::from_fn(|k| Vec2::new(u[1][k], u[2][k]));
        }
        for k in lanes_of(going & !lobe) {
            let Some(hit) = &hits[k] else { unreachable!("a gathered lane has a hit") };
            bs[k] = Path::sample_bsdf(scene, hit, wo[k], &mut samplers[k]);
        }
        if lobe != 0 {
            let (wi, pdf) = cosine_hemisphere_lanes(&rows.normal, &xi);
            for k in lanes_of(lobe) {
                let Some(hit) = &hits[k] else { unreachable!("a gathered lane has a hit") };
                let w = Vec3::new(wi[0][k], wi[1][k], wi[2][k]);
                bs[k] = scene.material(hit).cosine_lobe_sample_from(hit, wo[k], w, pdf[k]);
            }
        }
        // The paths that go on, and their next rays, all spawned together.
        let mut spawned = 0u32;
        for k in lanes_of(going) {
            let Some(w) = paths[k].advance(bs[k], &mut samplers[k], counters) else {
                ended |= 1 << k;
                continue;
            };
            for axis in 0..3 {
                wi[axis][k] = w[axis];
            }
            spawned |= 1 << k;
        }
        spawn_lanes(&rows.surface, &wi, spawned, next);
        for k in lanes_of(ended) {
            active &= !(1 << k);
            out[k] = paths[k].l;
        }
        if active == 0 {
            break;
        }
        // The last few paths followed alone ([`Path::follow`], the same operations, so
        // the same floats), unless the scene is one mesh: a pass of the lanes' phases over
        // one to four live paths costs more than those paths one at a time.
        // PERF: path, 16 spp, paired medians of the CPU time: tp6-glass-quad (Lambert)
        // 0.936, tp6-mirror-quad 0.949, tp6-matte 0.971, tp4-sphere 0.957, tp4-bunny 0.970;
        // in the conference room (one mesh, whose lanes share a stream down its tree)
        // 1.009 with its 8 light samples, 0.992 with one, so not there.
        if alone_from_few && active.count_ones() <= ALONE_LANES {
            for k in lanes_of(active) {
                let range = (next.t_min[k], next.t_max[k]);
                paths[k].follow(scene, &lights, &next.ray(k), range, light_samples, max_depth, &mut samplers[k], counters);
                out[k] = paths[k].l;
            }
            break;
        }
        let closest = scene.intersect_lanes(next, LANES);
        scene.lane_hit_rows_into(next, &closest, LANES, hits, rows);
        turn ^= 1;
    }
}

/// [`super::direct::direct_lighting`] for every lane with a hit, light by light: a point light's shadow
/// rays from all the lanes in one [`Scene::occluded_lanes`]; a quad light's one to three
/// samples likewise, sample by sample ([`quad_few_lanes`]); four to eight samples four lanes
/// to a stream, and nine to sixteen in a scene of one mesh two lanes to a stream
/// ([`quad_groups`]); otherwise lane by lane (each lane's samples traced together).
fn direct_lanes(
    scene: &Scene,
    rays: &RayLanes,
    hits: &[Option<Hit>; LANES],
    light_samples: u32,
    samplers: &mut [Sampler],
    counters: &mut RayCounters,
    out: &mut [Color],
) {
    let n = samplers.len();
    let mut li = [Color::ZERO; LANES];
    for (index, light) in scene.lights.iter().enumerate() {
        let light_sampler = light.sampler();
        if let LightSampler::Quad { .. } = light_sampler {
            let m = light_samples.max(1);
            if (BATCH_FROM..=(BATCH / 2) as u32).contains(&m) {
                quad_groups::<2>(scene, rays, hits, index, &light_sampler, m as usize, samplers, counters, &mut li);
                continue;
            }
            if m < BATCH_FROM {
                quad_few_lanes(scene, rays, hits, &light_sampler, m, samplers, counters, &mut li);
                continue;
            }
            // Where two batches go as one stream (a scene of one mesh); elsewhere the
            // pairs measured slower than lane by lane (tp3-quad-soft 0.37 -> 0.38 s).
            if m <= BATCH as u32 && scene.pair_mesh().is_some() {
                quad_groups::<1>(scene, rays, hits, index, &light_sampler, m as usize, samplers, counters, &mut li);
                continue;
            }
            // Each hit's shadow rays made where they are used. PERF: an array of the
            // sixteen hits' `ShadowRays` made first was 2% of tp6-matte-quad.
            // The planes that cannot block the shadow rays, proved for a box around the
            // lanes' hits (a pixel's samples), then per hit.
            let LightSampler::Quad { corner, u, v, .. } = light_sampler else { unreachable!("a quad light") };
            let planes = scene.quad_planes([corner, u, v]).map(|table| {
                let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
                for hit in hits[..n].iter().flatten() {
                    // A margin wider than the shadow rays' offsets (an origin outside the
                    // box gets no proof).
                    let margin = 1e-3 * (1.0 + hit.point.abs().max_element()) + 4.0 * hit.point_error;
                    (lo, hi) = (lo.min(hit.point - margin), hi.max(hit.point + margin));
                }
                (table, table.for_box(lo, hi))
            });
            let planes = planes.as_ref().map(|(t, p)| (*t, p));
            with_quad_scratch(|scratch| {
                for k in 0..n {
                    if let Some(hit) = &hits[k] {
                        let material = scene.material(hit);
                        let sampler = &mut samplers[k];
                        let mut sr = hit.shadow_rays();
                        li[k] +=
                            quad_light(scene, &rays.ray(k), hit, material, &light_sampler, &mut sr, m, sampler, counters, scratch, planes);
                    }
                }
            });
            continue;
        }
        // ---- A point light: one sample per lane, set up together, traced together ----
        for k in (0..n).filter(|&k| hits[k].is_some()) {
            // The sample's two numbers, skipped as one at a time draws them (a point
            // needs none).
            samplers[k].skip::<2>();
        }
        let mut batch = Kept::take(&LIGHT_LANES, || LightLanes::EMPTY);
        batch.fill(&light_sampler, hits, &[Vec2::ZERO; BATCH]);
        let live = live_mask(&batch.live, n);
        counters.shadow += u64::from(live.count_ones());
        let blocked = scene.occluded_lanes(&batch.rays, live);
        let mut sum = [Color::ZERO; LANES];
        for k in (0..n).filter(|&k| live & !blocked & (1 << k) != 0) {
            let Some(hit) = &hits[k] else { unreachable!("a live lane has a hit") };
            // PERF: the sample and the ray built only for the materials that use them.
            let material = scene.material(hit);
            let f = material.shade_any_direction(hit).unwrap_or_else(|| material.shade(&rays.ray(k), hit, &batch.sample(k)));
            sum[k] += f * batch.radiance(k) * batch.cos[k];
        }
        for k in 0..n {
            li[k] += sum[k] / 1.0;
        }
    }
    for k in 0..n {
        out[k] = match &hits[k] {
            None => scene.background,
            Some(_) => li[k],
        };
    }
}

thread_local! {
    /// This thread's batch of light samples in lanes for [`direct_lanes`]' point lights
    /// and [`quad_few_lanes`]: [`LightLanes::fill`] rewrites every lane it is read from
    /// (the rays' `t_min` are never written and stay the zeros of [`LightLanes::EMPTY`]).
    /// PERF: a zeroed batch per call, its `memset` was 2.3% of tp5-phong. Held as a
    /// [`Kept`] guard, not in a closure: `Material::shade` was then no longer inlined
    /// into `direct_lanes`, and tp5-phong took 1.04 of its time.
    static LIGHT_LANES: Slot<LightLanes> = const { std::cell::Cell::new(None) };
}

/// A quad light of fewer than [`BATCH_FROM`] samples (one to three) in every lane with a
/// hit, sample by sample: each lane's sample drawn from its own generator, the sixteen set
/// up together ([`LightLanes`]) and their shadow rays traced together, then each lane's
/// average added to `li` as [`super::direct::one_light`] makes it (the same random numbers
/// in the same order, the same floats).
/// PERF: one lane at a time these were single shadow rays, the conference room at one
/// light sample 1.5 times Mitsuba's time (see ARCHITECTURE.md, twenty-sixth session).
#[allow(clippy::too_many_arguments)]
fn quad_few_lanes(
    scene: &Scene,
    rays: &RayLanes,
    hits: &[Option<Hit>; LANES],
    light_sampler: &LightSampler,
    m: u32,
    samplers: &mut [Sampler],
    counters: &mut RayCounters,
    li: &mut [Color; LANES],
) {
    let n = samplers.len();
    let mut sum = [Color::ZERO; LANES];
    let mut batch = Kept::take(&LIGHT_LANES, || LightLanes::EMPTY);
    let with_hit = lane_mask(&std::array::from_fn(|k| hits[k].is_some()));
    for _ in 0..m {
        let mut u = [[0f32; LANES]; 2];
        Sampler::draw_lanes(samplers, with_hit, &mut u);
        let xi: [Vec2; BATCH] = std::array::from_fn(|k| Vec2::new(u[0][k], u[1][k]));
        batch.fill(light_sampler, hits, &xi);
        let live = live_mask(&batch.live, n);
        counters.shadow += u64::from(live.count_ones());
        let blocked = scene.occluded_lanes(&batch.rays, live);
        for k in lanes_of(live & !blocked) {
            let Some(hit) = &hits[k] else { unreachable!("a live lane has a hit") };
            let material = scene.material(hit);
            let f = material.shade_any_direction(hit).unwrap_or_else(|| material.shade(&rays.ray(k), hit, &batch.sample(k)));
            sum[k] += f * batch.radiance(k) * batch.cos[k];
        }
    }
    for k in (0..n).filter(|&k| hits[k].is_some()) {
        li[k] += sum[k] / m as f32;
    }
}

/// A quad light of `m` samples in every lane with a hit, `PER` lanes' samples to a batch
/// of sixteen and two batches traced together ([`Scene::occluded_lane_pair`]: one stream
/// of up to thirty-two in a scene of one mesh): at most eight samples four lanes to a
/// group (`PER` 2, the conference room's eight), nine to sixteen two lanes to a group
/// (`PER` 1, in a scene of one mesh). Each lane's samples are set up and shaded as
/// [`quad_light`] does ([`QuadBatch`]) and its sum added to `li` as [`quad_light`] makes
/// it (the same floats).
/// PERF: the lanes' hits are samples of one pixel: their rays share most nodes, and the
/// stream's per-node work is done once for all of them (eight samples: two lanes to a
/// stream instead of one 6% faster, four instead of two 4%; sixteen samples, two lanes
/// instead of one: the conference 0.97–0.98 of the time, twenty-sixth session). Elsewhere
/// than in a scene of one mesh the pairs go batch by batch, and sixteen samples measured
/// slower than lane by lane (tp3-quad-soft 0.37 -> 0.38 s).
#[allow(clippy::too_many_arguments)]
fn quad_groups<const PER: usize>(
    scene: &Scene,
    rays: &RayLanes,
    hits: &[Option<Hit>; LANES],
    light: usize,
    light_sampler: &LightSampler,
    m: usize,
    samplers: &mut [Sampler],
    counters: &mut RayCounters,
    li: &mut [Color; LANES],
) {
    // Each lane's share of a batch: eight lanes, or all sixteen.
    let span = BATCH / PER;
    debug_assert!((PER == 1 || PER == 2) && m <= span);
    let n = samplers.len();
    // The groups' memory, the thread's own from call to call (see `GroupScratch`).
    // PERF: zeroed per call (7 KB), `memset` was 2% of the conference room's profile;
    // kept, the conference took 0.950 and 0.960 of the CPU time (two runs of 11 pairs).
    GROUP_SCRATCH.with_borrow_mut(|g| {
        let GroupScratch { batches, f, both } = g;
        for first in (0..n).step_by(2 * PER) {
            // Lanes `first + i`: batch `i / PER`, its share `i % PER`.
            let mut live = [0u32; 2];
            let mut filled = [false; 4];
            let mut same = [None; 4];
            // The group's random numbers, then its batches, then the rest. PERF: 0.993 and
            // 0.983 of the conference's CPU time (two runs of nine pairs).
            let mut xi = [[Vec2::ZERO; BATCH]; 4];
            let group = first..(first + 2 * PER).min(n);
            for (i, k) in group.clone().enumerate() {
                if hits[k].is_some() {
                    samplers[k].fill_2d(&mut xi[i][..m]);
                }
            }
            for (i, k) in group.clone().enumerate() {
                if let Some(hit) = &hits[k] {
                    batches[i].fill(light_sampler, &hit.shadow_rays(), hit.normal, &xi[i], m);
                }
            }
            for (i, k) in group.enumerate() {
                let Some(hit) = &hits[k] else { continue };
                let batch = &mut batches[i];
                let lane_live = live_mask(&batch.live, m);
                counters.shadow += u64::from(lane_live.count_ones());
                live[i / PER] |= lane_live << ((i % PER) * span);
                // The whole share at once: lanes past `m` are not live, so never traced.
                both[i / PER].copy_lanes((i % PER) * span, &batch.rays, span);
                // A material of one value in every direction needs no lanes of values.
                let material = scene.material(hit);
                same[i] = material.shade_any_direction(hit);
                if same[i].is_none() {
                    batch.shade_into(material, &rays.ray(k), hit, &mut f[i]);
                }
                filled[i] = true;
            }
            let blocked = if live == [0, 0] { [0, 0] } else { scene.occluded_pair_to_light(light, [&both[0], &both[1]], live) };
            // Each batch's samples that reached the light (`% 2`: with one batch a hit, the
            // third and fourth are never filled, and read nothing past the pair).
            let seen: [u32; 4] = std::array::from_fn(|i| (live[i / PER % 2] & !blocked[i / PER % 2]) >> ((i % PER) * span));
            add_groups_seen::<PER>(&GroupSeen { batches, f, same, filled, seen, m }, &mut li[first..]);
        }
    });
}

/// The memory of [`quad_groups`]' groups: four batches, their shading values and the
/// pair of shadow-ray lanes they are traced as, kept per thread from call to call. Every
/// lane a group reads it wrote first (`fill` writes each batch's first eight or sixteen
/// lanes, `copy_lanes` as many of the pair's; only the live ones are traced, only the seen
/// ones summed), or it holds zeros or an earlier call's values, which are only carried
/// along under the masks, any of which will do; the rays' `t_min` are never written and
/// stay zero.
struct GroupScratch {
    batches: [QuadBatch; 4],
    f: [[[f32; BATCH]; 3]; 4],
    both: [RayLanes; 2],
}

thread_local! {
    static GROUP_SCRATCH: std::cell::RefCell<GroupScratch> = const {
        std::cell::RefCell::new(GroupScratch {
            batches: [QuadBatch::EMPTY, QuadBatch::EMPTY, QuadBatch::EMPTY, QuadBatch::EMPTY],
            f: [[[0f32; BATCH]; 3]; 4],
            both: [RayLanes::EMPTY, RayLanes::EMPTY],
        })
    };
}

/// What a group of [`quad_groups`] leaves to be summed once its rays are traced: its
/// batches, their values `f` (or the one value `same` of a material that has one), which
/// batches are filled, the samples each one's rays saw the light from, and the number
/// `m` of samples a hit.
struct GroupSeen<'a> {
    batches: &'a [QuadBatch; 4],
    f: &'a [[[f32; BATCH]; 3]; 4],
    same: [Option<Color>; 4],
    filled: [bool; 4],
    seen: [u32; 4],
    m: usize,
}

/// Adds to `li[i]` each filled batch `i`'s average of its seen samples
/// ([`QuadBatch::add_seen`] with the values `f[i]`, or [`QuadBatch::add_seen_same`] with
/// `same[i]` where it is given, then divided by `m`): the end of [`quad_groups`]' group,
/// its SIMD loops compiled for AVX2 where the CPU has it.
/// PERF: compiled for SSE2 with the rest of `direct_lanes`, the sixteen lanes' terms and
/// the sums were a third of that function's time (conference room).
fn add_groups_seen<const PER: usize>(g: &GroupSeen<'_>, li: &mut [Color]) {
    #[inline(always)]
    fn add<const PER: usize>(g: &GroupSeen<'_>, li: &mut [Color]) {
        for i in (0..2 * PER).filter(|&i| g.filled[i]) {
            let mut sum = Color::ZERO;
            match g.same[i] {
                Some(c) => g.batches[i].add_seen_same(c, g.seen[i], g.m, &mut sum),
                None => g.batches[i].add_seen(&g.f[i], g.seen[i], g.m, &mut sum),
            }
            li[i] += divided(sum, g.m);
        }
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        #[target_feature(enable = "avx2")]
        fn avx2<const PER: usize>(g: &GroupSeen<'_>, li: &mut [Color]) {
            add::<PER>(g, li);
        }
        // SAFETY: the CPU has AVX2, which is all `avx2` is compiled for.
        unsafe { avx2::<PER>(g, li) };
        return;
    }
    add::<PER>(g, li);
}

/// The kinds of the lanes' materials, as masks of lanes.
#[derive(Clone, Copy, PartialEq, Eq)]
struct MaterialMasks {
    /// Every lobe a delta ([`crate::materials::Material::is_delta`]).
    delta: u32,
    /// Sampled from the cosine lobe ([`crate::materials::Material::samples_cosine_lobe`]).
    lobe: u32,
    /// A Lambert lobe ([`crate::materials::Material::lambert_albedo`]).
    lambert: u32,
}

impl MaterialMasks {
    /// The kinds of one material, as masks of all the lanes or none.
    fn one(material: &Material) -> MaterialMasks {
        let all = |b: bool| if b { u32::MAX } else { 0 };
        MaterialMasks {
            delta: all(material.is_delta()),
            lobe: all(material.samples_cosine_lobe()),
            lambert: all(material.lambert_albedo().is_some()),
        }
    }

    /// The kinds every object's materials share, when they share them (`None` when two
    /// differ): then every hit's kinds are those.
    fn uniform(scene: &Scene) -> Option<MaterialMasks> {
        let mut ids = scene.objects.iter().flat_map(|o| o.materials.iter());
        let first = MaterialMasks::one(&scene.materials[*ids.next()? as usize]);
        ids.all(|&id| MaterialMasks::one(&scene.materials[id as usize]) == first).then_some(first)
    }

    /// The masks of the lanes `lanes`, which have hits, given the scene's `uniform` kinds.
    /// PERF: found once per vertex, without a branch on each lane's material: the phases'
    /// loops each branched on it, which mispredicted where glass and matte lanes mix
    /// (tp6-glass-quad's path tracer 0.96 of the time). Read from the scene once when its
    /// materials are all of one kind (tp6-matte's path tracer 1.02 of the time lane by
    /// lane).
    #[inline(always)]
    fn of(scene: &Scene, hits: &[Option<Hit>; LANES], lanes: u32, uniform: Option<MaterialMasks>) -> MaterialMasks {
        if let Some(u) = uniform {
            return MaterialMasks { delta: u.delta & lanes, lobe: u.lobe & lanes, lambert: u.lambert & lanes };
        }
        let mut m = MaterialMasks { delta: 0, lobe: 0, lambert: 0 };
        if lanes == 0 {
            // (Then the scene may have no material to read.)
            return m;
        }
        for (k, hit) in hits.iter().enumerate() {
            // A lane without a hit reads one of zeros (its bit is not in `lanes`).
            let material = scene.material(hit.as_ref().unwrap_or(&Hit::ZERO));
            m.delta |= u32::from(material.is_delta()) << k;
            m.lobe |= u32::from(material.samples_cosine_lobe()) << k;
            m.lambert |= u32::from(material.lambert_albedo().is_some()) << k;
        }
        MaterialMasks { delta: m.delta & lanes, lobe: m.lobe & lanes, lambert: m.lambert & lanes }
    }
}

/// The albedos of the Lambert lanes `lambert` into their lanes of `albedo`.
#[inline(always)]
fn gather_albedos(scene: &Scene, hits: &[Option<Hit>; LANES], lambert: u32, albedo: &mut [[f32; BATCH]; 3]) {
    for k in lanes_of(lambert) {
        let Some(hit) = &hits[k] else { unreachable!("a Lambert lane has a hit") };
        let Some(c) = scene.material(hit).lambert_albedo() else { unreachable!("a Lambert lane") };
        for (axis, row) in albedo.iter_mut().enumerate() {
            row[k] = c[axis];
        }
    }
}

/// Next-event estimation of the paths `going` ([`Path::light_direct`]) in a scene lit by
/// the one quad light `light`, sampled `n` times per vertex (fewer than [`BATCH_FROM`]):
/// sample by sample, every lane's sample and shadow ray set up together
/// ([`LightLanes`]), the rays traced in one [`Scene::occluded_lanes`], each lane's sum
/// made as `next_event` makes it (its random numbers drawn in the same order, the same
/// floats). The last argument is scratch: the batch and the Lambert lanes' albedos, kept by
/// the caller across its vertices.
#[allow(clippy::too_many_arguments)]
fn quad_nee_lanes(
    scene: &Scene,
    light: &LightSampler,
    hits: &[Option<Hit>; LANES],
    rows: &HitRows,
    (wo, back): (&[Vec3; LANES], &[[f32; LANES]; 3]),
    (nee, lambert): (u32, u32),
    n: u32,
    paths: &mut [Path; LANES],
    samplers: &mut [Sampler],
    counters: &mut RayCounters,
    (batch, albedo): (&mut LightLanes, &mut [[f32; BATCH]; 3]),
) {
    // The lanes whose material is a Lambert lobe (`lambert`): their samples' values as SIMD
    // loops (`LightLanes::lambert_values`, reading the hits' normals and the directions
    // back in rows: `wo[k]` is lane `k` of `back`), the others' lane by lane. (`albedo`'s
    // other lanes hold an earlier vertex's: their values are not read.)
    let lambert = lambert & nee;
    gather_albedos(scene, hits, lambert, albedo);
    let lobe = LambertLanes { normal: &rows.normal, wo: back, albedo };
    let mut acc = [Color::ZERO; LANES];
    for _ in 0..n {
        let mut u = [[0f32; LANES]; 2];
        Sampler::draw_lanes(samplers, nee, &mut u);
        let xi: [Vec2; BATCH] = std::array::from_fn(|k| Vec2::new(u[0][k], u[1][k]));
        batch.fill_rows(light, rows, &xi);
        let (lobe_traced, lobe_value) = if lambert != 0 { batch.lambert_values(&lobe, n) } else { ([false; BATCH], [[0.0; BATCH]; 3]) };
        let mut f = [Color::ZERO; LANES];
        let mut traced = lane_mask(&lobe_traced) & lambert;
        for k in lanes_of(nee & !lambert) {
            let Some(hit) = &hits[k] else { unreachable!("a lane with light has a hit") };
            if let Some(fk) = Path::light_sample_f(scene, hit, wo[k], &batch.sample(k)).filter(|_| batch.has_ray[k]) {
                f[k] = fk;
                traced |= 1 << k;
            }
        }
        counters.shadow += u64::from(traced.count_ones());
        let blocked = if traced == 0 { 0 } else { scene.occluded_lanes(&batch.rays, traced) };
        for k in lanes_of(traced & !blocked & lambert) {
            acc[k] += Vec3::new(lobe_value[0][k], lobe_value[1][k], lobe_value[2][k]);
        }
        for k in lanes_of(traced & !blocked & !lambert) {
            let Some(hit) = &hits[k] else { unreachable!("a traced lane has a hit") };
            acc[k] += Path::quad_sample_value(scene, hit, wo[k], &batch.sample(k), f[k], n);
        }
    }
    for k in lanes_of(nee) {
        paths[k].add_light_average(acc[k], n);
    }
}
