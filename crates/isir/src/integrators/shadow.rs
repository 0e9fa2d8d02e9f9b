//! A quad light's samples seen from one hit, sixteen at a time, as arrays: the light
//! points, directions, pdfs and radiances of [`LightSampler::sample`] and the shadow rays
//! of [`ShadowRays::to`], bit for bit, in straight-line loops the compiler turns into SIMD
//! (square roots and divisions eight at a time with AVX2, four with SSE2; no branches).
//! Sixteen lanes, so that 16 light samples make one packet of shadow rays; compiled for
//! AVX2 (two vectors), as the same loops compiled for AVX-512 measured slower (conference
//! room, 8 light samples: 5.8 s with AVX2 lanes, 6.4 s with AVX-512 ones).
//!
//! PERF: one sample at a time, setting up a sample and its shadow ray cost about as much
//! as tracing the ray (~360 instructions, measured with callgrind on the conference room).

use crate::geometry::{Hit, HitRows};
use crate::lights::{LightSample, LightSampler};
use crate::materials::{cook_torrance_lanes, ggx_alpha, oren_nayar_lanes, phong_pdf_lanes, plastic_lanes, visible_pdf, Material};
use crate::math::color::Color;
use crate::math::ray::{lane_mask, round_away, Ray, RayLanes, ShadowRays};
use glam::{Vec2, Vec3};

/// Samples per batch.
pub(super) const BATCH: usize = 16;

/// The fewest samples of a quad light set up as a batch; fewer go one at a time.
/// PERF: a batch computes all sixteen lanes whatever the count: with one light sample (the
/// path tracer as Mitsuba runs it) `QuadBatch::new` and the zeroing of its arrays were
/// 19% of the time (tp6-matte-quad, path, Lambert).
pub(super) const BATCH_FROM: u32 = 4;

/// A material's BRDF and pdf as [`QuadBatch::brdf_values`] computes them in lanes:
/// Oren–Nayar's (the course's `MatteMaterial`) and Lambert's of the given albedo (Lambert,
/// the course's colours), whose [`Material::pdf`] is the cosine lobe's; Cook–Torrance's,
/// whose pdf mixes in GGX's visible normals, and plastic's, whose pdf mixes in the Phong
/// lobe.
#[derive(Clone, Copy, Debug)]
pub(super) enum LaneBrdf {
    /// [`oren_nayar`](crate::materials::oren_nayar) of colour `kd` and roughness `sigma`.
    OrenNayar { kd: Color, sigma: f32 },
    /// `albedo / π`.
    Lambert(Color),
    /// [`Material::CookTorrance`]'s fields.
    CookTorrance { kd: Color, f0: Color, roughness: f32, metalness: f32 },
    /// [`Material::Plastic`]'s fields.
    Plastic { kd: Color, ks: Color, shininess: f32, blinn: bool },
}

impl LaneBrdf {
    /// The BRDF of `material`, `None` for the delta kinds and textures (whose
    /// `Material::eval` lights a NaN direction where Lambert's does not): left to the
    /// samples one at a time.
    pub(super) fn of(material: &Material) -> Option<LaneBrdf> {
        match *material {
            Material::Matte { kd, sigma } => Some(LaneBrdf::OrenNayar { kd, sigma }),
            Material::Color(c) | Material::Lambert(c) => Some(LaneBrdf::Lambert(c)),
            Material::CookTorrance { kd, f0, roughness, metalness } => Some(LaneBrdf::CookTorrance { kd, f0, roughness, metalness }),
            Material::Plastic { kd, ks, shininess, blinn } => Some(LaneBrdf::Plastic { kd, ks, shininess, blinn }),
            _ => None,
        }
    }
}

/// What [`QuadBatch::brdf_values`] needs of a path's vertex: its material's BRDF, its
/// shading normal, the direction the path leaves towards (`wo`), the samples of the light
/// per vertex (`n`) and how many of the batch's lanes are samples (`count`).
#[derive(Clone, Copy, Debug)]
pub(super) struct VertexSamples {
    pub(super) lobe: LaneBrdf,
    pub(super) normal: Vec3,
    pub(super) wo: Vec3,
    pub(super) n: u32,
    pub(super) count: usize,
}

/// Up to [`BATCH`] samples of a quad light from one hit, and their shadow rays.
pub(super) struct QuadBatch {
    point: [[f32; BATCH]; 3],
    wi: [[f32; BATCH]; 3],
    distance: [f32; BATCH],
    pdf: [f32; BATCH],
    radiance: [[f32; BATCH]; 3],
    /// `max(wi · n, 0)` with the hit's shading normal.
    pub(super) cos: [f32; BATCH],
    /// The shadow rays, in lanes (intervals from 0).
    pub(super) rays: RayLanes,
    /// The sample lights the hit (`cos > 0`, some radiance) and its shadow ray exists.
    pub(super) live: [bool; BATCH],
    /// The shadow ray exists (its target is finite and not its origin).
    pub(super) has_ray: [bool; BATCH],
    /// The shadow ray leaves from behind the surface (`origins[1]`).
    pub(super) back: [bool; BATCH],
    /// The rays' two origins, in front of the surface and behind it
    /// ([`ShadowRays::both_origins`]).
    pub(super) origins: [Vec3; 2],
}

/// The memory of [`quad_light`](super::direct::quad_light)'s batches: a batch and its
/// samples' shading values, reused from batch to batch and from hit to hit.
pub(super) struct QuadScratch {
    pub(super) batch: QuadBatch,
    pub(super) f: [[f32; BATCH]; 3],
}

impl QuadScratch {
    /// No sample yet.
    pub(super) const EMPTY: QuadScratch = QuadScratch { batch: QuadBatch::EMPTY, f: [[0.0; BATCH]; 3] };
}

impl QuadBatch {
    /// A new batch [`QuadBatch::fill`]ed (the tests' form: the renderer fills its
    /// threads' batches in place).
    #[cfg(test)]
    pub(super) fn new(light: &LightSampler, rays: &ShadowRays, normal: Vec3, xi: &[Vec2; BATCH], count: usize) -> Self {
        let mut b = QuadBatch::EMPTY;
        b.fill(light, rays, normal, xi, count);
        b
    }

    /// No sample: every array zero, no lane live.
    pub(super) const EMPTY: QuadBatch = QuadBatch {
        point: [[0.0; BATCH]; 3],
        wi: [[0.0; BATCH]; 3],
        distance: [0.0; BATCH],
        pdf: [0.0; BATCH],
        radiance: [[0.0; BATCH]; 3],
        cos: [0.0; BATCH],
        rays: RayLanes::EMPTY,
        live: [false; BATCH],
        has_ray: [false; BATCH],
        back: [false; BATCH],
        origins: [Vec3::ZERO; 2],
    };

    /// Samples `xi[..count]` of the quad light `light` seen from the hit whose shading
    /// normal is `normal` and whose shadow rays leave as `rays` says, in place: the lanes
    /// it computes (eight when `count` is at most 8, else sixteen) are overwritten, the
    /// others left as they are. Only the first `count` lanes are meaningful (the others
    /// are computed from whatever `xi` holds there).
    /// PERF: eight lanes computed when `count` is at most 8 (the conference room's eight
    /// light samples): 5% of that render was this function computing all sixteen.
    pub(super) fn fill(&mut self, light: &LightSampler, rays: &ShadowRays, normal: Vec3, xi: &[Vec2; BATCH], count: usize) {
        // PERF: a grey light (the course's are white) divides its radiance once per lane,
        // not once per channel: 4 of the 24 divisions and square roots of sixteen lanes.
        // In code of its own: decided inside the loops, the eight-lane form took the
        // conference room to 1.034 of its time, and LLVM made the sixteen-lane coloured
        // one 48 scalar divisions (branches around them, not selects).
        match (count <= BATCH / 2, grey(light)) {
            (true, true) => self.fill_for::<{ BATCH / 2 }, true>(light, rays, normal, xi),
            (true, false) => self.fill_for::<{ BATCH / 2 }, false>(light, rays, normal, xi),
            (false, true) => self.fill_for::<BATCH, true>(light, rays, normal, xi),
            (false, false) => self.fill_for::<BATCH, false>(light, rays, normal, xi),
        }
    }

    /// [`Self::fill`] of `W` lanes (`BATCH / 2` or `BATCH`), `GREY` when the light is.
    #[inline(always)]
    fn fill_for<const W: usize, const GREY: bool>(&mut self, light: &LightSampler, rays: &ShadowRays, normal: Vec3, xi: &[Vec2; BATCH]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, which is all `fill_avx2` is compiled for.
            unsafe { self.fill_avx2::<W, GREY>(light, rays, normal, xi) };
            return;
        }
        self.fill_portable::<W, GREY>(light, rays, rays.both_origins(), normal, &light_points::<W>(light, xi));
    }

    /// [`Self::fill`] compiled for AVX2: the same operations eight lanes wide (no FMA
    /// contraction, so the same floats).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn fill_avx2<const W: usize, const GREY: bool>(&mut self, light: &LightSampler, rays: &ShadowRays, normal: Vec3, xi: &[Vec2; BATCH]) {
        // Eight lanes' points from AVX2's shuffles; sixteen from the compiler's loops, which
        // measured as fast (tp3-quad-soft).
        let point = if W == BATCH / 2 { light_points_avx2(light, xi) } else { light_points::<W>(light, xi) };
        self.fill_portable::<W, GREY>(light, rays, rays.both_origins_avx2(), normal, &point);
    }

    /// The first `W` lanes (`W` at most [`BATCH`]; the others are left as they are), from
    /// the samples' points on the light, `point` (`[axis][lane]`, [`light_points`]);
    /// `origins` are `rays.both_origins()`.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loops vectorise
    fn fill_portable<const W: usize, const GREY: bool>(
        &mut self,
        light: &LightSampler,
        rays: &ShadowRays,
        origins: [Vec3; 2],
        normal: Vec3,
        point: &[[f32; BATCH]; 3],
    ) {
        let LightSampler::Quad { normal: ln, area, emitted, .. } = *light else {
            unreachable!("quad lights only");
        };
        let (x, ng) = rays.surface();
        let [front, back] = origins;
        let b = self;
        b.origins = origins;
        // The operations of `LightSampler::sample`, `Vec3::dot`, `Vec3::length` and
        // `ShadowRays::to`, in their order, so every float is the same. Stage by stage
        // over the lanes, without branches, so that each loop vectorises.
        let (xx, n, sn, g) = (x.to_array(), ln.to_array(), normal.to_array(), ng.to_array());
        let mut to = [[0f32; BATCH]; 3];
        for k in 0..3 {
            for j in 0..W {
                b.point[k][j] = point[k][j];
                to[k][j] = point[k][j] - xx[k];
            }
        }
        let mut lit = [false; BATCH];
        for j in 0..W {
            let d = (to[0][j] * to[0][j] + to[1][j] * to[1][j] + to[2][j] * to[2][j]).sqrt();
            b.distance[j] = d;
            let wi = [to[0][j] / d, to[1][j] / d, to[2][j] / d];
            let cl = n[0] * wi[0] + n[1] * wi[1] + n[2] * wi[2];
            // The back of the light (or NaN): nothing.
            lit[j] = cl > 0.0;
            let pdf = d * d / (area * cl);
            b.pdf[j] = if lit[j] { pdf } else { 0.0 };
            b.cos[j] = (wi[0] * sn[0] + wi[1] * sn[1] + wi[2] * sn[2]).max(0.0);
            b.back[j] = to[0][j] * g[0] + to[1][j] * g[1] + to[2][j] * g[2] < 0.0;
            for k in 0..3 {
                b.wi[k][j] = wi[k];
            }
        }
        let e = emitted.to_array();
        if GREY {
            // The three channels' quotients are one (`grey`).
            for j in 0..W {
                let r = if lit[j] { e[0] / b.pdf[j] } else { 0.0 };
                (b.radiance[0][j], b.radiance[1][j], b.radiance[2][j]) = (r, r, r);
            }
        }
        for k in 0..3 {
            for j in 0..W {
                if !GREY {
                    b.radiance[k][j] = if lit[j] { e[k] / b.pdf[j] } else { 0.0 };
                }
                b.rays.o[k][j] = if b.back[j] { back[k] } else { front[k] };
                to[k][j] = point[k][j] - b.rays.o[k][j];
            }
        }
        for j in 0..W {
            let dist = (to[0][j] * to[0][j] + to[1][j] * to[1][j] + to[2][j] * to[2][j]).sqrt();
            for k in 0..3 {
                b.rays.d[k][j] = to[k][j] / dist;
            }
            b.rays.t_max[j] = dist * (1.0 - 1e-4);
            b.has_ray[j] = dist > 0.0 && dist.is_finite();
            let some_radiance = b.radiance[0][j] != 0.0 || b.radiance[1][j] != 0.0 || b.radiance[2][j] != 0.0;
            b.live[j] = b.cos[j] != 0.0 && some_radiance && b.has_ray[j];
        }
    }

    /// Sample `j` as [`LightSampler::sample`] returns it.
    pub(super) fn sample(&self, j: usize) -> LightSample {
        lane_sample(j, &self.wi, &self.distance, &self.point, &self.radiance, &self.pdf)
    }

    /// The samples `0..v.count` of a quad light sampled `v.n` times per vertex, seen from a
    /// hit whose material's BRDF is `v.lobe` and whose shading normal is `v.normal`, the
    /// path leaving towards `v.wo`, into `value`: the lanes whose sample is worth its shadow ray
    /// (`has_ray` and [`super::path::Path::light_sample_f`] together), and what each brings
    /// when unoccluded ([`super::path::Path::quad_sample_value`]): the operations of
    /// `Material::eval` ([`oren_nayar_lanes`], [`cook_torrance_lanes`], [`plastic_lanes`]:
    /// the same floats as the scalar formulas), `Material::pdf`, the power heuristic and the
    /// sample's value in their order, so the same floats, as SIMD loops (AVX2 where the CPU
    /// has it).
    /// PERF: one sample at a time, `oren_nayar` and `Material::pdf` were 53% of the path
    /// tracer on the TP6 rooms with their own materials.
    pub(super) fn brdf_values(&self, v: VertexSamples, value: &mut [[f32; BATCH]; 3]) -> u32 {
        if let LaneBrdf::CookTorrance { .. } | LaneBrdf::Plastic { .. } = v.lobe {
            return self.glossy_values(v, value);
        }
        self.brdf_values_dispatch::<false>(v, value)
    }

    /// [`Self::brdf_values`] for Cook–Torrance and plastic. PERF: a function of its own:
    /// compiled into the same function as the diffuse lobes', Cook–Torrance's made the path
    /// tracer on tp6-glass-quad (Oren–Nayar) 1.053 of its time.
    #[inline(never)]
    fn glossy_values(&self, v: VertexSamples, value: &mut [[f32; BATCH]; 3]) -> u32 {
        self.brdf_values_dispatch::<true>(v, value)
    }

    /// [`Self::brdf_values_portable`] compiled for AVX2 where the CPU has it.
    #[inline(always)]
    fn brdf_values_dispatch<const GLOSSY: bool>(&self, v: VertexSamples, value: &mut [[f32; BATCH]; 3]) -> u32 {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            #[target_feature(enable = "avx2")]
            fn avx2<const GLOSSY: bool>(b: &QuadBatch, v: VertexSamples, value: &mut [[f32; BATCH]; 3]) -> u32 {
                b.brdf_values_portable::<GLOSSY>(v, value)
            }
            // SAFETY: the CPU has AVX2, which is all `avx2` is compiled for.
            return unsafe { avx2::<GLOSSY>(self, v, value) };
        }
        self.brdf_values_portable::<GLOSSY>(v, value)
    }

    /// [`Self::brdf_values`]' loops: `GLOSSY` for Cook–Torrance and plastic (whose pdf is
    /// computed first, in lanes), else the lobes whose pdf is the cosine lobe's.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // the loops vectorise
    fn brdf_values_portable<const GLOSSY: bool>(&self, v: VertexSamples, value: &mut [[f32; BATCH]; 3]) -> u32 {
        let VertexSamples { lobe, normal, wo, n, count } = v;
        let (wi, rad) = (&self.wi, &self.radiance);
        let nm = normal.to_array();
        let nf = n as f32;
        // `Vec3::dot`, left to right.
        let nwo = nm[0] * wo.x + nm[1] * wo.y + nm[2] * wo.z;
        let nwi = |j: usize| nm[0] * wi[0][j] + nm[1] * wi[1][j] + nm[2] * wi[2][j];
        // `Material::eval` into `value`: black unless both directions are above the
        // surface; for Cook–Torrance and plastic, `Material::pdf` into `m_pdf`.
        let mut m_pdf = [0f32; BATCH];
        match lobe {
            // What `oren_nayar` itself tests (the same dot products): `oren_nayar` alone.
            LaneBrdf::OrenNayar { kd, sigma } if !GLOSSY => oren_nayar_lanes(kd, sigma, normal, wo, &self.wi, value),
            LaneBrdf::Lambert(albedo) if !GLOSSY => {
                let c = albedo.to_array();
                for j in 0..BATCH {
                    let above = (nwo > 0.0) & (nwi(j) > 0.0);
                    for k in 0..3 {
                        value[k][j] = if above { c[k] * std::f32::consts::FRAC_1_PI } else { 0.0 };
                    }
                }
            }
            LaneBrdf::CookTorrance { kd, f0, roughness, metalness } if GLOSSY => {
                let (mut d, mut c) = ([0f32; BATCH], [0f32; BATCH]);
                cook_torrance_lanes(kd, f0, roughness, metalness, normal, wo, &self.wi, value, &mut d, &mut c);
                // `glossy_probability`, and `glossy_pdf` of GGX's visible normals.
                let (p, alpha) = (metalness.clamp(0.0, 1.0), ggx_alpha(roughness));
                for j in 0..BATCH {
                    let nwi = nwi(j);
                    let below = (nwo <= 0.0) | (nwi <= 0.0);
                    for k in 0..3 {
                        value[k][j] = if below { 0.0 } else { value[k][j] };
                    }
                    let visible = if c[j] <= 0.0 { 0.0 } else { visible_pdf(alpha, nwo, c[j], d[j]) / (4.0 * c[j]) };
                    let glossy = if p > 0.0 { visible } else { 0.0 };
                    m_pdf[j] = mixture_pdf(nwo, nwi, p, glossy);
                }
            }
            LaneBrdf::Plastic { kd, ks, shininess, blinn } if GLOSSY => {
                // `plastic` is `eval` (both test the same dot products), then
                // `glossy_probability` (one half) and `glossy_pdf` of the Phong lobe.
                plastic_lanes(kd, ks, shininess, blinn, normal, wo, &self.wi, value);
                let mut glossy = [0f32; BATCH];
                phong_pdf_lanes(shininess, blinn, normal, wo, &self.wi, &mut glossy);
                for j in 0..BATCH {
                    m_pdf[j] = mixture_pdf(nwo, nwi(j), 0.5, glossy[j]);
                }
            }
            _ => unreachable!("brdf_values sends Cook–Torrance and plastic to glossy_values"),
        }
        let mut traced = [false; BATCH];
        for j in 0..BATCH {
            let nwi = nwi(j);
            // `traced_f`: some radiance, a valid pdf, `eval` not zero.
            let some_radiance = !((rad[0][j] == 0.0) & (rad[1][j] == 0.0) & (rad[2][j] == 0.0));
            let pdf = self.pdf[j];
            let valid_pdf = !(pdf.is_nan() | (pdf <= 0.0));
            let some_f = !((value[0][j] == 0.0) & (value[1][j] == 0.0) & (value[2][j] == 0.0));
            traced[j] = some_radiance & valid_pdf & some_f & self.has_ray[j];
            // The diffuse lobes' `Material::pdf`: the cosine lobe's.
            let w = mis_weight(nf, pdf, if GLOSSY { m_pdf[j] } else { cosine_lobe_pdf(nwo, nwi) });
            let cos = nwi.abs();
            for k in 0..3 {
                value[k][j] = value[k][j] * rad[k][j] * cos * w;
            }
        }
        live_mask(&traced, count)
    }

    /// `material.shade(ray, hit, &self.sample(j))` for every sample `j` (`[axis][j]`), the
    /// same floats, computed together ([`Material::shade_lanes`], for AVX2 where the CPU
    /// has it).
    #[cfg(test)]
    pub(super) fn shade(&self, material: &Material, ray: &Ray, hit: &Hit) -> [[f32; BATCH]; 3] {
        let mut out = [[0.0; BATCH]; 3];
        self.shade_into(material, ray, hit, &mut out);
        out
    }

    /// `Self::shade` (the tests' form) into `out` (every lane written).
    pub(super) fn shade_into(&self, material: &Material, ray: &Ray, hit: &Hit, out: &mut [[f32; BATCH]; 3]) {
        if let Material::CookTorrance { .. } | Material::Plastic { .. } = material {
            self.glossy_into(material, ray, hit, out);
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            #[target_feature(enable = "avx2")]
            fn shade_avx2(b: &QuadBatch, material: &Material, ray: &Ray, hit: &Hit, out: &mut [[f32; BATCH]; 3]) {
                material.shade_lanes(ray, hit, &b.wi, out);
            }
            // SAFETY: the CPU has AVX2, which is all `shade_avx2` is compiled for.
            unsafe { shade_avx2(self, material, ray, hit, out) };
            return;
        }
        material.shade_lanes(ray, hit, &self.wi, out);
    }

    /// [`Self::shade_into`] for [`Material::CookTorrance`] ([`cook_torrance_lanes`]) and
    /// [`Material::Plastic`] ([`plastic_lanes`]), with the `wo` `Material::shade` computes.
    /// PERF: a function of its own: inlined into the other materials' `shade_lanes`,
    /// Cook–Torrance's lanes made tp6-glass-quad (Oren–Nayar) 1.018 of its time. Plastic
    /// one sample at a time: `plastic` took 40% of the TP6 room's Whitted render with
    /// plastic walls, libm's `powf` 22%.
    #[inline(never)]
    fn glossy_into(&self, material: &Material, ray: &Ray, hit: &Hit, out: &mut [[f32; BATCH]; 3]) {
        let wo = -ray.direction.normalize_or_zero();
        #[inline(always)]
        fn portable(b: &QuadBatch, material: &Material, n: Vec3, wo: Vec3, out: &mut [[f32; BATCH]; 3]) {
            match *material {
                Material::CookTorrance { kd, f0, roughness, metalness } => {
                    let (mut d, mut c) = ([0f32; BATCH], [0f32; BATCH]);
                    cook_torrance_lanes(kd, f0, roughness, metalness, n, wo, &b.wi, out, &mut d, &mut c);
                }
                Material::Plastic { kd, ks, shininess, blinn } => plastic_lanes(kd, ks, shininess, blinn, n, wo, &b.wi, out),
                _ => unreachable!("a Cook–Torrance or plastic material"),
            }
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            #[target_feature(enable = "avx2")]
            fn avx2(b: &QuadBatch, material: &Material, n: Vec3, wo: Vec3, out: &mut [[f32; BATCH]; 3]) {
                portable(b, material, n, wo, out);
            }
            // SAFETY: the CPU has AVX2, which is all `avx2` is compiled for.
            unsafe { avx2(self, material, hit.normal, wo, out) };
            return;
        }
        portable(self, material, hit.normal, wo, out);
    }

    /// Adds to `sum`, in sample order, `shade · radiance · cos` of the samples among the
    /// first `count` whose bits are set in `seen` (those whose shadow ray reached the
    /// light), `f` being [`QuadBatch::shade_into`]'s values.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // `j` indexes five arrays and the mask
    pub(super) fn add_seen(&self, f: &[[f32; BATCH]; 3], seen: u32, count: usize, sum: &mut Color) {
        // The terms first, as SIMD loops (`(f · radiance) · cos`, the products of `Color`'s
        // operators), those of blocked samples zero, then their sum in sample order: a
        // select instead of a branch per sample (whether a penumbra's rays reach the light
        // is not predictable). `s + 0` is `s` bit for bit, as `s` is never `-0` (it starts
        // at `+0`, and a sum that cancels rounds to `+0`).
        // PERF: tp6-glass-quad Whitted 0.942 -> 0.864 s with the select, conference
        // 1.316 -> 1.232; the terms as SIMD loops then took the conference to 1.46 from
        // 1.55 (7 runs; tp6-glass-quad within noise).
        self.add_seen_by(|c, j| f[c][j], seen, count, sum);
    }

    /// [`Self::add_seen`] where the material's value is `f` in every direction
    /// ([`Material::shade_any_direction`]): the same sum, without the sixteen lanes of
    /// `f` that [`QuadBatch::shade_into`] would write.
    #[inline(always)]
    pub(super) fn add_seen_same(&self, f: Color, seen: u32, count: usize, sum: &mut Color) {
        let f = f.to_array();
        self.add_seen_by(|c, _| f[c], seen, count, sum);
    }

    /// [`Self::add_seen`] with the material's value of channel `c` and sample `j` given by
    /// `f(c, j)`.
    #[inline(always)]
    fn add_seen_by(&self, f: impl Fn(usize, usize) -> f32, seen: u32, count: usize, sum: &mut Color) {
        // PERF: eight lanes' terms when `count` is at most 8 (the conference room's eight
        // light samples), as `fill` computes them.
        if count <= BATCH / 2 {
            self.add_seen_lanes::<{ BATCH / 2 }>(f, seen, count, sum);
        } else {
            self.add_seen_lanes::<BATCH>(f, seen, count, sum);
        }
    }

    /// [`Self::add_seen_by`] from the terms of the first `W` lanes (`count` at most `W`).
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // `j` indexes five arrays and the mask
    fn add_seen_lanes<const W: usize>(&self, f: impl Fn(usize, usize) -> f32, seen: u32, count: usize, sum: &mut Color) {
        debug_assert!(count <= W);
        let mut term = [[0f32; W]; 3];
        for c in 0..3 {
            for j in 0..W {
                let t = f(c, j) * self.radiance[c][j] * self.cos[j];
                term[c][j] = if (seen >> j) & 1 != 0 { t } else { 0.0 };
            }
        }
        let mut s = *sum;
        for j in 0..count.min(W) {
            s += Color::new(term[0][j], term[1][j], term[2][j]);
        }
        *sum = s;
    }

    /// The shadow ray of sample `j` and its `t_max`, as [`ShadowRays::to`] returns them.
    #[cfg(test)]
    fn shadow_ray(&self, j: usize) -> (Ray, f32) {
        (self.rays.ray(j), self.rays.t_max[j])
    }
}

/// A quad light's corner and edges `u` and `v`, as arrays.
#[inline(always)]
fn corner_and_edges(light: &LightSampler) -> [[f32; 3]; 3] {
    let LightSampler::Quad { corner, u, v, .. } = *light else {
        unreachable!("quad lights only");
    };
    [corner.to_array(), u.to_array(), v.to_array()]
}

/// The points of the quad light `light` of the samples `xi[..W]`, `corner + x·u + y·v`
/// axis by axis (`[axis][lane]`; the other lanes zero): the operations of
/// `LightSampler::sample`, in its order.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // one index into three arrays: the loops vectorise
fn light_points<const W: usize>(light: &LightSampler, xi: &[Vec2; BATCH]) -> [[f32; BATCH]; 3] {
    let [c, uu, vv] = corner_and_edges(light);
    let mut point = [[0f32; BATCH]; 3];
    for k in 0..3 {
        for j in 0..W {
            point[k][j] = c[k] + xi[j].x * uu[k] + xi[j].y * vv[k];
        }
    }
    point
}

/// [`light_points`] of eight samples with AVX2: the samples' numbers split into two rows
/// by two shuffles, then the same operations eight lanes at a time (no FMA), so the same
/// floats.
/// PERF: left to the compiler, the numbers were reloaded at odd offsets for each axis
/// (loads their stores could not forward) and the points computed four lanes at a time.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn light_points_avx2(light: &LightSampler, xi: &[Vec2; BATCH]) -> [[f32; BATCH]; 3] {
    use std::arch::x86_64::{
        _mm256_add_ps, _mm256_castpd_ps, _mm256_castps_pd, _mm256_loadu_ps, _mm256_mul_ps, _mm256_permute4x64_pd, _mm256_set1_ps,
        _mm256_shuffle_ps, _mm256_storeu_ps,
    };
    let [c, uu, vv] = corner_and_edges(light);
    let mut point = [[0f32; BATCH]; 3];
    // SAFETY: sixteen floats (eight `Vec2`s, x then y) read from `xi[..8]`, eight written
    // to each row of `point`.
    unsafe {
        let p = xi.as_ptr().cast::<f32>();
        let (a, b) = (_mm256_loadu_ps(p), _mm256_loadu_ps(p.add(8)));
        // [x0 x1 x4 x5 | x2 x3 x6 x7] -> x0..x7 (and the same for y).
        let x = _mm256_castpd_ps(_mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_castps_pd(_mm256_shuffle_ps::<0b10_00_10_00>(a, b))));
        let y = _mm256_castpd_ps(_mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_castps_pd(_mm256_shuffle_ps::<0b11_01_11_01>(a, b))));
        for k in 0..3 {
            let at = _mm256_add_ps(
                _mm256_add_ps(_mm256_set1_ps(c[k]), _mm256_mul_ps(x, _mm256_set1_ps(uu[k]))),
                _mm256_mul_ps(y, _mm256_set1_ps(vv[k])),
            );
            _mm256_storeu_ps(point[k].as_mut_ptr(), at);
        }
    }
    point
}

/// Whether the quad light's radiance is the same in its three channels, bit for bit (a
/// grey light, as the course's white ones are), so that [`QuadBatch::fill`] divides it
/// once per lane.
fn grey(light: &LightSampler) -> bool {
    let LightSampler::Quad { emitted, .. } = *light else { return false };
    let e = emitted.to_array().map(f32::to_bits);
    e == [e[0]; 3]
}

/// Lane `j` of a batch's samples (directions, distances, points, radiances, pdfs in
/// lanes) as a [`LightSample`].
#[inline(always)]
fn lane_sample(
    j: usize,
    wi: &[[f32; BATCH]; 3],
    distance: &[f32; BATCH],
    point: &[[f32; BATCH]; 3],
    radiance: &[[f32; BATCH]; 3],
    pdf: &[f32; BATCH],
) -> LightSample {
    let at = |a: &[[f32; BATCH]; 3]| Vec3::new(a[0][j], a[1][j], a[2][j]);
    LightSample { direction: at(wi), distance: distance[j], point: at(point), radiance: at(radiance), pdf: pdf[j] }
}

/// `Material::pdf` given `n · wo`, `n · wi`, the probability `p` of the glossy lobe and
/// that lobe's density `glossy`: zero below the surface, else `(1 - p)·cos/π + p·glossy`;
/// its operations in their order, so the same floats, for the SIMD loops.
#[inline(always)]
fn mixture_pdf(nwo: f32, nwi: f32, p: f32, glossy: f32) -> f32 {
    let cos_pdf = nwi.max(0.0) * std::f32::consts::FRAC_1_PI;
    let below = (nwo <= 0.0) | (nwi <= 0.0);
    if below {
        0.0
    } else {
        (1.0 - p) * cos_pdf + p * glossy
    }
}

/// [`mixture_pdf`] of a material without a glossy lobe (Lambert's, Oren–Nayar's: `p` 0).
#[inline(always)]
fn cosine_lobe_pdf(nwo: f32, nwi: f32) -> f32 {
    mixture_pdf(nwo, nwi, 0.0, 0.0)
}

/// The MIS weight (`quad_weight`: `power_heuristic(nf, pdf, 1, m_pdf)`) of a light sample
/// of pdf `pdf`, one of `nf` per vertex, against the material's pdf `m_pdf`: its
/// operations in their order, so the same floats, for the SIMD loops.
#[inline(always)]
fn mis_weight(nf: f32, pdf: f32, m_pdf: f32) -> f32 {
    let (a, b) = (nf * pdf, 1.0 * m_pdf);
    let (a2, b2) = (a * a, b * b);
    if a.is_infinite() {
        1.0
    } else if a2 + b2 > 0.0 {
        a2 / (a2 + b2)
    } else {
        0.0
    }
}

/// `sum / m`, the same floats: by a power of two as the product with its inverse, which
/// is exact, so that both round the same real number (subnormals, zeros, infinities and
/// NaNs included), without the division's latency at the end of each hit's sum.
#[inline(always)]
pub(super) fn divided(sum: Color, m: usize) -> Color {
    if m.is_power_of_two() {
        sum * (1.0 / m as f32)
    } else {
        sum / m as f32
    }
}

/// Hits with a Lambert lobe, in lanes, for [`LightLanes::lambert_values`]: shading
/// normals, `wo` and albedos (`[axis][lane]`).
pub(super) struct LambertLanes<'a> {
    pub(super) normal: &'a [[f32; BATCH]; 3],
    pub(super) wo: &'a [[f32; BATCH]; 3],
    pub(super) albedo: &'a [[f32; BATCH]; 3],
}

/// The lanes among the first `count` whose flag in `live` is set, as a mask (a batch's
/// live samples).
/// PERF: [`lane_mask`]'s multiplications, not a loop of selects and shifts per lane (3% of
/// `quad_light` on tp6-matte-quad).
pub(super) fn live_mask(live: &[bool; BATCH], count: usize) -> u32 {
    const { assert!(BATCH == crate::math::ray::LANES) };
    lane_mask(live) & ((1u32 << count.min(BATCH)) - 1)
}

/// One sample of a light from each of up to [`BATCH`] hits (one camera sample or one
/// path each, in lanes): the samples of [`LightSampler::sample`] and the shadow rays of
/// [`ShadowRays::to`] of every hit, bit for bit, in straight-line loops the compiler turns
/// into SIMD (AVX2 where the CPU has it, as [`QuadBatch`]). A point light needs no random
/// numbers; a quad light takes lane `j`'s sample from `xi[j]`.
pub(super) struct LightLanes {
    wi: [[f32; BATCH]; 3],
    distance: [f32; BATCH],
    point: [[f32; BATCH]; 3],
    radiance: [[f32; BATCH]; 3],
    pdf: [f32; BATCH],
    /// `max(wi · n, 0)` with the hit's shading normal.
    pub(super) cos: [f32; BATCH],
    /// The shadow rays, in lanes (intervals from 0).
    pub(super) rays: RayLanes,
    /// The lane has a hit, the light lights it (`cos > 0`, some radiance) and its shadow
    /// ray exists.
    pub(super) live: [bool; BATCH],
    /// The lane's shadow ray exists (its target is finite and not its origin), as
    /// [`ShadowRays::to`] says.
    pub(super) has_ray: [bool; BATCH],
}

impl LightLanes {
    /// This batch made the light `light` seen from the hits `hits`, lane `j`'s sample
    /// drawn with `xi[j]` (a point light ignores `xi`): every lane rewritten (the rays'
    /// `t_min` stay the zeros of [`Self::EMPTY`]).
    /// PERF: filled in place: a batch returned by value and built by a function filling
    /// it was zeroed, then copied (`memset`, `memcpy` of 1.3 kB).
    pub(super) fn fill(&mut self, light: &LightSampler, hits: &[Option<Hit>; BATCH], xi: &[Vec2; BATCH]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, which is all `fill_avx2` is compiled for.
            unsafe { self.fill_avx2(light, hits, xi) };
            return;
        }
        self.fill_portable(light, hits, xi);
    }

    /// [`Self::fill`] compiled for AVX2 (no FMA contraction: the same floats).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn fill_avx2(&mut self, light: &LightSampler, hits: &[Option<Hit>; BATCH], xi: &[Vec2; BATCH]) {
        self.fill_portable(light, hits, xi);
    }

    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loop vectorises
    fn fill_portable(&mut self, light: &LightSampler, hits: &[Option<Hit>; BATCH], xi: &[Vec2; BATCH]) {
        // The hits as arrays (lanes without one: zeros, and not live). PERF: gathered here,
        // with the offsets, in one loop: through `HitRows::of` and `fill_rows`, direct
        // lighting took 1.03 of the time (tp4-sphere, tp5-phong, tp4-bunny, minima of 9).
        let (mut p, mut ng, mut sn, mut off) = ([[0f32; BATCH]; 3], [[0f32; BATCH]; 3], [[0f32; BATCH]; 3], [0f32; BATCH]);
        let mut has = [false; BATCH];
        for j in 0..BATCH {
            // A lane without a hit reads one of zeros (the zeros it had). PERF: a pointer
            // chosen instead of a branch on each lane's hit, which mispredicted where paths
            // had ended.
            has[j] = hits[j].is_some();
            let h = hits[j].as_ref().unwrap_or(&Hit::ZERO);
            for k in 0..3 {
                (p[k][j], ng[k][j], sn[k][j]) = (h.point[k], h.geometric_normal[k], h.normal[k]);
            }
            // `ShadowRays::new`'s offset: |ng| · point_error.
            let e = h.point_error;
            off[j] = h.geometric_normal.x.abs() * e.x + h.geometric_normal.y.abs() * e.y + h.geometric_normal.z.abs() * e.z;
        }
        self.fill_arrays(light, &p, &ng, &sn, &off, &has, xi);
    }

    /// No lanes yet: a batch for [`Self::fill`] or [`Self::fill_rows`] to fill.
    pub(super) const EMPTY: LightLanes = LightLanes {
        wi: [[0.0; BATCH]; 3],
        distance: [0.0; BATCH],
        point: [[0.0; BATCH]; 3],
        radiance: [[0.0; BATCH]; 3],
        pdf: [0.0; BATCH],
        cos: [0.0; BATCH],
        rays: RayLanes::EMPTY,
        live: [false; BATCH],
        has_ray: [false; BATCH],
    };

    /// [`Self::fill`] from the hits' rows ([`HitRows`]), which the path tracer keeps.
    pub(super) fn fill_rows(&mut self, light: &LightSampler, rows: &HitRows, xi: &[Vec2; BATCH]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            #[target_feature(enable = "avx2")]
            fn avx2(b: &mut LightLanes, light: &LightSampler, rows: &HitRows, xi: &[Vec2; BATCH]) {
                b.fill_rows_portable(light, rows, xi);
            }
            // SAFETY: the CPU has AVX2, which is all `avx2` is compiled for.
            unsafe { avx2(self, light, rows, xi) };
            return;
        }
        self.fill_rows_portable(light, rows, xi);
    }

    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loops vectorise
    fn fill_rows_portable(&mut self, light: &LightSampler, rows: &HitRows, xi: &[Vec2; BATCH]) {
        let (ng, e) = (&rows.surface.ng, &rows.surface.p_error);
        let mut off = [0f32; BATCH];
        let mut has = [false; BATCH];
        for j in 0..BATCH {
            has[j] = rows.mask & (1 << j) != 0;
            // `ShadowRays::new`'s offset: |ng| · point_error.
            off[j] = ng[0][j].abs() * e[0][j] + ng[1][j].abs() * e[1][j] + ng[2][j].abs() * e[2][j];
        }
        self.fill_arrays(light, &rows.surface.p, ng, &rows.normal, &off, &has, xi);
    }

    /// The batch of the hits given as arrays: points `p`, geometric and shading normals
    /// `ng` and `sn`, the offsets of their shadow rays' origins `off` (`|ng| · error`), and
    /// whether each lane has a hit (a lane without one holds zeros).
    #[inline(always)]
    #[allow(clippy::needless_range_loop, clippy::too_many_arguments)] // one index into many arrays: the loops vectorise
    fn fill_arrays(
        &mut self,
        light: &LightSampler,
        p: &[[f32; BATCH]; 3],
        ng: &[[f32; BATCH]; 3],
        sn: &[[f32; BATCH]; 3],
        off: &[f32; BATCH],
        has: &[bool; BATCH],
        xi: &[Vec2; BATCH],
    ) {
        let b = self;
        // The operations of `LightSampler::sample`, in its order, so every float is the
        // same.
        let mut to = [[0f32; BATCH]; 3];
        match *light {
            LightSampler::Point { position, emitted } => {
                let (y, em) = (position.to_array(), emitted.to_array());
                for j in 0..BATCH {
                    let t = [y[0] - p[0][j], y[1] - p[1][j], y[2] - p[2][j]];
                    let d = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
                    let d2 = d * d;
                    for k in 0..3 {
                        to[k][j] = t[k];
                        b.point[k][j] = y[k];
                        b.wi[k][j] = t[k] / d;
                        b.radiance[k][j] = em[k] / d2;
                    }
                    b.distance[j] = d;
                    b.pdf[j] = 1.0;
                }
            }
            LightSampler::Quad { corner, u, v, normal, area, emitted, .. } => {
                let (c, uu, vv, n, em) = (corner.to_array(), u.to_array(), v.to_array(), normal.to_array(), emitted.to_array());
                let (mut cl_of, mut pdf_of) = ([0f32; BATCH], [0f32; BATCH]);
                for j in 0..BATCH {
                    // PERF: no `array::map` in these loops: left out of line, it kept
                    // them from vectorising (this function went 5% -> 23% of a render).
                    let y = [
                        c[0] + xi[j].x * uu[0] + xi[j].y * vv[0],
                        c[1] + xi[j].x * uu[1] + xi[j].y * vv[1],
                        c[2] + xi[j].x * uu[2] + xi[j].y * vv[2],
                    ];
                    let t = [y[0] - p[0][j], y[1] - p[1][j], y[2] - p[2][j]];
                    let d = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
                    let wi = [t[0] / d, t[1] / d, t[2] / d];
                    let cl = n[0] * wi[0] + n[1] * wi[1] + n[2] * wi[2];
                    for k in 0..3 {
                        to[k][j] = t[k];
                        b.point[k][j] = y[k];
                        b.wi[k][j] = wi[k];
                    }
                    b.distance[j] = d;
                    cl_of[j] = cl;
                    pdf_of[j] = d * d / (area * cl);
                }
                // PERF: what depends on the light's side in a loop of its own: in the loop
                // above, LLVM split the lanes by it and made every store an AVX masked
                // store once the crate was one codegen unit (this function 6.6% -> 13.9%
                // of tp6-matte-quad's path tracer; apart, 7.5%). And one loop per channel:
                // with the three channels in the lanes' loop, the select of each quotient
                // still became masked stores (the path tracer on tp6-glass-quad 0.982).
                // The back of the light (or NaN): nothing.
                for k in 0..3 {
                    for j in 0..BATCH {
                        let q = em[k] / pdf_of[j];
                        b.radiance[k][j] = if cl_of[j] > 0.0 { q } else { 0.0 };
                    }
                }
                for j in 0..BATCH {
                    b.pdf[j] = if cl_of[j] > 0.0 { pdf_of[j] } else { 0.0 };
                }
            }
        }
        // `Vec3::dot`, `f32::max` and `ShadowRays::to`, in their order.
        for j in 0..BATCH {
            let (t, wi) = ([to[0][j], to[1][j], to[2][j]], [b.wi[0][j], b.wi[1][j], b.wi[2][j]]);
            let cos = (wi[0] * sn[0][j] + wi[1] * sn[1][j] + wi[2] * sn[2][j]).max(0.0);
            // The shadow ray: the origin offset to the side of the target.
            let back = t[0] * ng[0][j] + t[1] * ng[1][j] + t[2] * ng[2][j] < 0.0;
            let mut o = [0f32; 3];
            for k in 0..3 {
                let side = if back { -ng[k][j] } else { ng[k][j] };
                o[k] = round_away(p[k][j] + off[j] * side, side);
            }
            let r = [b.point[0][j] - o[0], b.point[1][j] - o[1], b.point[2][j] - o[2]];
            let dist = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
            let has_ray = dist > 0.0 && dist.is_finite();
            let some_radiance = (b.radiance[0][j] != 0.0) | (b.radiance[1][j] != 0.0) | (b.radiance[2][j] != 0.0);
            for k in 0..3 {
                b.rays.o[k][j] = o[k];
                b.rays.d[k][j] = r[k] / dist;
            }
            b.cos[j] = cos;
            b.rays.t_max[j] = dist * (1.0 - 1e-4);
            b.has_ray[j] = has_ray;
            b.live[j] = has[j] & (cos != 0.0) & some_radiance & has_ray;
        }
    }

    /// The radiance of sample `j` (that of [`Self::sample`]).
    #[inline]
    pub(super) fn radiance(&self, j: usize) -> Color {
        Color::new(self.radiance[0][j], self.radiance[1][j], self.radiance[2][j])
    }

    /// The sample of lane `j`, as [`LightSampler::sample`] returns it.
    pub(super) fn sample(&self, j: usize) -> LightSample {
        lane_sample(j, &self.wi, &self.distance, &self.point, &self.radiance, &self.pdf)
    }

    /// A quad light's sample (one of `n` per vertex) in every lane at once, for hits whose
    /// material is a Lambert lobe ([`crate::materials::Material::lambert_albedo`]): lane
    /// `j`'s shading normal, `wo` and albedo in `lobe.normal`, `lobe.wo`, `lobe.albedo`.
    /// Per lane, whether the sample is worth its shadow ray (what
    /// [`super::path::Path::light_sample_f`] and `has_ray` say together) and what it brings
    /// when unoccluded ([`super::path::Path::quad_sample_value`]): the operations of
    /// `Material::eval`, `Material::pdf`, the power heuristic and the sample's value in
    /// their order, so the same floats, as SIMD loops (AVX2 where the CPU has it).
    /// PERF: lane by lane, each lane's chain of dot products, comparisons and the
    /// heuristic's division ran one after another.
    pub(super) fn lambert_values(&self, lobe: &LambertLanes<'_>, n: u32) -> ([bool; BATCH], [[f32; BATCH]; 3]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            #[target_feature(enable = "avx2")]
            fn avx2(b: &LightLanes, lobe: &LambertLanes<'_>, n: u32) -> ([bool; BATCH], [[f32; BATCH]; 3]) {
                b.lambert_values_portable::<true>(lobe, n)
            }
            // SAFETY: the CPU has AVX2, which is all `avx2` is compiled for.
            return unsafe { avx2(self, lobe, n) };
        }
        self.lambert_values_portable::<true>(lobe, n)
    }

    /// [`Self::lambert_values`] for a point light's samples (one per vertex, no MIS
    /// weight: `next_event`'s weight 1): what [`super::path::Path::defer_point`] decides
    /// and defers, in SIMD loops.
    pub(super) fn lambert_point_values(&self, lobe: &LambertLanes<'_>) -> ([bool; BATCH], [[f32; BATCH]; 3]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            #[target_feature(enable = "avx2")]
            fn avx2(b: &LightLanes, lobe: &LambertLanes<'_>) -> ([bool; BATCH], [[f32; BATCH]; 3]) {
                b.lambert_values_portable::<false>(lobe, 1)
            }
            // SAFETY: the CPU has AVX2, which is all `avx2` is compiled for.
            return unsafe { avx2(self, lobe) };
        }
        self.lambert_values_portable::<false>(lobe, 1)
    }

    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into many arrays: the loops vectorise
    fn lambert_values_portable<const WEIGHTED: bool>(&self, lobe: &LambertLanes<'_>, n: u32) -> ([bool; BATCH], [[f32; BATCH]; 3]) {
        let (nm, wo, c) = (lobe.normal, lobe.wo, lobe.albedo);
        let (wi, rad) = (&self.wi, &self.radiance);
        let mut traced = [false; BATCH];
        let mut value = [[0f32; BATCH]; 3];
        let nf = n as f32;
        for j in 0..BATCH {
            // `Vec3::dot`, left to right.
            let nwo = nm[0][j] * wo[0][j] + nm[1][j] * wo[1][j] + nm[2][j] * wo[2][j];
            let nwi = nm[0][j] * wi[0][j] + nm[1][j] * wi[1][j] + nm[2][j] * wi[2][j];
            // `traced_f`: some radiance, a valid pdf, `eval` (Lambert: albedo / π where
            // both directions are above the surface) not zero.
            let some_radiance = !((rad[0][j] == 0.0) & (rad[1][j] == 0.0) & (rad[2][j] == 0.0));
            let pdf = self.pdf[j];
            let valid_pdf = !(pdf.is_nan() | (pdf <= 0.0));
            let above = (nwo > 0.0) & (nwi > 0.0);
            let mut f = [0f32; 3];
            for k in 0..3 {
                f[k] = if above { c[k][j] * std::f32::consts::FRAC_1_PI } else { 0.0 };
            }
            let some_f = !((f[0] == 0.0) & (f[1] == 0.0) & (f[2] == 0.0));
            traced[j] = some_radiance & valid_pdf & some_f & self.has_ray[j];
            let w = if WEIGHTED { mis_weight(nf, pdf, cosine_lobe_pdf(nwo, nwi)) } else { 1.0 };
            // `unoccluded`: f · L · |wi · n| · w (`wi · n` is `nwi`, bit for bit: the same
            // products, commuted, summed in the same order).
            let cos = nwi.abs();
            for k in 0..3 {
                value[k][j] = f[k] * rad[k][j] * cos * w;
            }
        }
        (traced, value)
    }

    /// The shadow ray of lane `j` with its interval, as [`ShadowRays::to`] gives it.
    #[cfg(test)]
    fn shadow_ray(&self, j: usize) -> crate::math::ray::RaySegment {
        self.rays.segment(j)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Geometry, Plane};
    use crate::lights::Light;
    use crate::math::ray::RaySegment;
    use crate::math::sampling::Sampler;
    use crate::scene::Scene;

    /// [`divided`] is the quotient bit for bit, for every count of light samples and
    /// floats of every kind: normal, subnormal, huge, signed zeros, infinities, NaN.
    #[test]
    fn divided_is_the_quotient() {
        let mut rng = Sampler::from_seed(3);
        let special = [0.0, -0.0, 1e-45, -1e-45, 1.2e-38, 3.4e38, -3.4e38, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 1.0, 0.1];
        let mut checked = 0;
        for m in 1..=32usize {
            for round in 0..3000 {
                // Random bit patterns (every exponent, subnormals too), then the specials.
                let x = special.get(round).copied().unwrap_or_else(|| f32::from_bits((rng.next_f32() * 4.294_967e9) as u32));
                let sum = Color::new(x, -x, x * 0.5);
                let (a, b) = (divided(sum, m).to_array(), (sum / m as f32).to_array());
                for (a, b) in a.into_iter().zip(b) {
                    assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()), "{x:e} / {m}: {a:e} against {b:e}");
                }
                checked += 1;
            }
        }
        assert_eq!(checked, 32 * 3000);
    }

    /// The rays of `batch` from its origin `side` (0 front, 1 back) that plane object
    /// `i` of `scene` blocks, as `Scene::occluded_lanes` tests them.
    fn plane_blocks(scene: &Scene, i: usize, batch: &QuadBatch, side: usize) -> u32 {
        let Geometry::Plane(plane) = &scene.objects[i].geometry else { unreachable!("a plane") };
        let back = lane_mask(&batch.back);
        let lanes = lane_mask(&batch.has_ray) & if side == 0 { !back } else { back };
        plane.hit_lanes(&batch.rays) & lanes
    }

    /// The planes `QuadPlanes::clear` names for the origins of `batch` (proved for the box
    /// `lo..=hi`) block none of the batch's rays; returns the planes proved from the
    /// front and their number.
    fn check_clear(scene: &Scene, light: [Vec3; 3], batch: &QuadBatch, (lo, hi): (Vec3, Vec3), what: &str) -> (u32, u32) {
        let table = scene.quad_planes(light).expect("a table for the scene's light");
        let proof = table.for_box(lo, hi);
        let mut front = (0, 0);
        for side in 0..2 {
            let clear = table.clear(&proof, batch.origins[side]);
            for i in (0..scene.objects.len()).filter(|&i| matches!(scene.objects[i].geometry, Geometry::Plane(_))) {
                if side == 0 {
                    front.1 += 1;
                    front.0 += (clear >> i & 1) as u32;
                }
                if clear >> i & 1 != 0 {
                    assert_eq!(plane_blocks(scene, i, batch, side), 0, "{what}: object {i}, from {}", batch.origins[side]);
                }
            }
        }
        front
    }

    /// `QuadPlanes::clear` names only planes that none of a batch's rays meets
    /// (`Plane::hit_lanes`), and it names nearly every wall for the points the camera sees
    /// in the TP3 and TP6 rooms (the proof is not empty), with boxes around a hit or
    /// sixteen; an origin outside the box gets no proof.
    #[test]
    fn quad_planes_clear_the_walls_of_the_course_rooms() {
        for name in ["tp6-glass-quad", "tp3-quad-soft"] {
            let desc = crate::scenes::builtin(name).unwrap();
            let scene = desc.build(crate::Accel::BvhSah).unwrap();
            let light = scene.lights.iter().find(|l| l.is_surface()).unwrap().clone();
            let Light::Quad { corner, u, v, .. } = light else { unreachable!("a quad light") };
            let (ls, camera) = (light.sampler(), desc.camera.build(1.5));
            let mut rng = Sampler::from_seed(3);
            let (mut proved, mut planes) = (0, 0);
            let mut batch = QuadBatch::EMPTY;
            for round in 0..2000 {
                let ray = camera.generate_ray(rng.next_f32(), rng.next_f32());
                let Some(hit) = scene.intersect(&ray, 0.0, f32::INFINITY) else { continue };
                let xi = std::array::from_fn(|_| Vec2::new(rng.next_f32(), rng.next_f32()));
                batch.fill(&ls, &hit.shadow_rays(), hit.normal, &xi, BATCH);
                // A box around the hit, or a room-sized one.
                let margin = if round % 2 == 0 { Vec3::splat(1e-3) } else { Vec3::splat(4.0) };
                let (p, n) = check_clear(&scene, [corner, u, v], &batch, (hit.point - margin, hit.point + margin), name);
                proved += p;
                planes += n;
                // Outside the box: nothing.
                let table = scene.quad_planes([corner, u, v]).unwrap();
                let aside = table.for_box(hit.point + 1.0, hit.point + 2.0);
                assert_eq!(table.clear(&aside, batch.origins[0]), 0);
            }
            assert!(proved * 100 >= planes * 95, "{name}: {proved} of {planes} planes proved clear");
        }
    }

    /// `QuadPlanes::clear` names only planes that none of a batch's rays meets, for planes
    /// and quad lights at random: lights crossing a plane, lying in it, across it by a
    /// hair, far away; points on a plane, near the light, anywhere; boxes tight and wide.
    /// And it names some.
    #[test]
    fn quad_planes_clear_only_planes_no_ray_meets() {
        let mut rng = Sampler::from_seed(11);
        let (mut proved, mut blocked) = (0, 0);
        let mut batch = QuadBatch::EMPTY;
        for round in 0..4000 {
            let mut r = |scale: f32| (rng.next_f32() * 2.0 - 1.0) * scale;
            let scale = [1.0, 10.0, 1000.0][round % 3];
            let normals = [Vec3::Y, -Vec3::X, Vec3::new(r(1.0), r(1.0), r(1.0)), Vec3::new(0.3, -1.0, 0.0)];
            let planes: Vec<Plane> = (0..4).map(|k| Plane::new(Vec3::new(r(scale), r(scale), r(scale)), normals[k])).collect();
            let mut corner = Vec3::new(r(scale), r(scale), r(scale));
            let (u, mut v) = (Vec3::new(r(scale), r(scale * 0.1), r(scale)), Vec3::new(r(scale), r(scale), r(scale * 0.1)));
            let p0 = planes[0];
            if round % 4 == 1 {
                // The light in the first plane.
                corner -= (corner - p0.point).dot(p0.normal) * p0.normal;
                v -= v.dot(p0.normal) * p0.normal;
            }
            if round % 4 == 2 {
                // The light across the first plane by a hair (its lowest corner 10⁻⁴ of the
                // scale below it), seen from points on that plane.
                let low = (corner - p0.point).dot(p0.normal) + u.dot(p0.normal).min(0.0) + v.dot(p0.normal).min(0.0);
                corner -= (low + 1e-4 * scale) * p0.normal;
            }
            let light = Light::Quad { corner, u, v, color: Vec3::ONE, power: 1.0 };
            let objects = planes
                .iter()
                .enumerate()
                .map(|(k, &p)| crate::scene::Object { name: format!("plane {k}"), geometry: Geometry::Plane(p), materials: vec![0] })
                .collect();
            let scene = Scene::new(objects, vec![Material::Color(Color::ONE)], vec![light.clone()], Color::ZERO);
            let ls = light.sampler();
            for _ in 0..8 {
                let mut r = |s: f32| (rng.next_f32() * 2.0 - 1.0) * s;
                let k = if round % 4 == 2 { 0 } else { (r(1.0).abs() * 4.0) as usize % 4 };
                let mut p = Vec3::new(r(scale), r(scale), r(scale));
                let mut ng = Vec3::new(r(1.0), r(1.0), r(1.0)).normalize();
                match if round % 4 == 2 { 0 } else { round % 3 } {
                    // On plane `k`, its normal the surface's.
                    0 => {
                        p -= (p - planes[k].point).dot(planes[k].normal) * planes[k].normal;
                        ng = if r(1.0) < 0.0 { planes[k].normal } else { -planes[k].normal };
                    }
                    // Near the light.
                    1 => p = corner + 0.5 * (u + v) + Vec3::new(r(0.01), r(0.01), r(0.01)) * scale,
                    _ => {}
                }
                let err = Vec3::splat(r(1.0).abs() * 1e-6 * scale);
                let xi = std::array::from_fn(|_| Vec2::new(rng.next_f32(), rng.next_f32()));
                batch.fill(&ls, &ShadowRays::new(p, err, ng), ng, &xi, BATCH);
                let margin = Vec3::splat([1e-3, 0.1, 1.0][round % 3] * scale);
                let (front, _) = check_clear(&scene, [corner, u, v], &batch, (p - margin, p + margin), &format!("round {round}"));
                proved += front;
                blocked += (0..planes.len()).filter(|&i| plane_blocks(&scene, i, &batch, 0) != 0).count();
            }
        }
        assert!(proved > 10_000 && blocked > 1000, "{proved} planes proved clear, {blocked} blocking");
    }

    /// Every field equals the one-at-a-time computation, bit for bit, including samples
    /// behind the light, on the light's plane, and hits on either side of the surface.
    #[test]
    fn batches_are_the_samples_and_shadow_rays_of_one_at_a_time() {
        let mut rng = Sampler::from_seed(5);
        // A coloured light, and a grey one (whose channels `fill` divides once).
        let light = |color| Light::Quad {
            corner: Vec3::new(-1.0, 3.0, -1.0),
            u: Vec3::new(2.0, 0.0, 0.0),
            v: Vec3::new(0.0, 0.5, 2.0),
            color,
            power: 12.0,
        };
        let lights = [light(Vec3::new(1.0, 0.8, 0.6)).sampler(), light(Vec3::splat(0.7)).sampler()];
        let (mut live, mut dead) = (0, 0);
        for round in 0..6000 {
            let ls = &lights[round / 2 % 2];
            let mut r = || rng.next_f32() * 8.0 - 4.0;
            let mut p = Vec3::new(r(), r(), r());
            let mut ng = Vec3::new(r(), r(), r()).normalize();
            let mut normal = (ng + 0.2 * Vec3::new(r(), r(), r())).normalize();
            let err = Vec3::splat(r().abs() * 1e-6);
            // Axis-aligned normals, and points on the light's corner row (zeros and signed
            // zeros in the dot products).
            if round % 5 == 0 {
                (ng, normal) = ([Vec3::Y, -Vec3::X, Vec3::Z][round % 3], [-Vec3::Y, Vec3::X, -Vec3::Z][round % 3]);
                p.y = [3.0, 0.0, -1.0][round % 3];
            }
            let mut xi = [Vec2::ZERO; BATCH];
            for x in &mut xi {
                *x = Vec2::new(rng.next_f32(), rng.next_f32());
            }
            // A hit on the light's corner, and a sample there (a zero direction: NaN).
            if round % 7 == 0 {
                (p, xi[3]) = (Vec3::new(-1.0, 3.0, -1.0), Vec2::ZERO);
            }
            let mut rays = ShadowRays::new(p, err, ng);
            let batch = QuadBatch::new(ls, &rays, normal, &xi, BATCH);
            // Both code paths where this CPU has both.
            let mut portable = QuadBatch::EMPTY;
            if grey(ls) {
                portable.fill_portable::<BATCH, true>(ls, &rays, rays.both_origins(), normal, &light_points::<BATCH>(ls, &xi));
            } else {
                portable.fill_portable::<BATCH, false>(ls, &rays, rays.both_origins(), normal, &light_points::<BATCH>(ls, &xi));
            }
            // Eight lanes (eight samples or fewer): the first eight of sixteen, no more.
            let half = QuadBatch::new(ls, &rays, normal, &xi, BATCH / 2);
            // Every array, bit for bit (the AVX2 build, its offset origins in intrinsics,
            // against the portable loops).
            let bits = |b: &QuadBatch| {
                let rows = [b.point, b.wi, b.radiance, b.rays.o, b.rays.d];
                let mut v: Vec<u32> = rows.iter().flatten().flatten().map(|x| x.to_bits()).collect();
                v.extend([b.distance, b.pdf, b.cos, b.rays.t_max].iter().flatten().map(|x| x.to_bits()));
                v.extend(b.live.iter().chain(&b.has_ray).map(|&x| u32::from(x)));
                v
            };
            assert!(bits(&portable) == bits(&batch), "{p} {ng} {normal}");
            // Equal as printed: NaNs (a sample on the hit point itself) equal, signed zeros not.
            let same = |a: &dyn std::fmt::Debug, b: &dyn std::fmt::Debug| assert_eq!(format!("{a:?}"), format!("{b:?}"));
            #[allow(clippy::needless_range_loop)] // one index into several arrays
            for j in 0..BATCH {
                same(
                    &(portable.sample(j), portable.shadow_ray(j), portable.live[j]),
                    &(batch.sample(j), batch.shadow_ray(j), batch.live[j]),
                );
                if j < BATCH / 2 {
                    same(
                        &(half.sample(j), half.shadow_ray(j), half.live[j], half.has_ray[j]),
                        &(batch.sample(j), batch.shadow_ray(j), batch.live[j], batch.has_ray[j]),
                    );
                    assert_eq!(half.cos[j].to_bits(), batch.cos[j].to_bits());
                } else {
                    assert!(!half.live[j] && !half.has_ray[j]);
                }
                let s = ls.sample(p, xi[j]);
                same(&batch.sample(j), &s);
                let cos = s.direction.dot(normal).max(0.0);
                assert_eq!(batch.cos[j].to_bits(), cos.to_bits());
                let ray = rays.to(s.point);
                assert_eq!(batch.has_ray[j], ray.is_some());
                let expected = cos != 0.0 && s.radiance != Color::ZERO && ray.is_some();
                assert_eq!(batch.live[j], expected);
                if let Some(ray) = ray {
                    same(&batch.shadow_ray(j), &ray);
                }
                if expected {
                    live += 1;
                } else {
                    dead += 1;
                }
            }
        }
        assert!(live > 1000 && dead > 1000, "{live} {dead}");
    }

    /// The live mask has the bit of every live lane below `count`, and no other, for
    /// every count from 0 to 16.
    #[test]
    fn live_mask_is_the_live_lanes_below_count() {
        let mut rng = Sampler::from_seed(21);
        for round in 0..2000 {
            let live: [bool; BATCH] = std::array::from_fn(|_| rng.next_f32() < [0.1, 0.5, 0.9][round % 3]);
            for count in 0..=BATCH {
                let expected = (0..count).filter(|&j| live[j]).fold(0, |m, j| m | 1 << j);
                assert_eq!(live_mask(&live, count), expected, "{live:?} {count}");
            }
        }
    }

    /// A hit at a random point below the test lights, with a random geometric normal and
    /// a shading normal straight up, straight down or near the geometric one (by `round`):
    /// the hit, its point, shading normal and geometric normal.
    fn random_hit(round: usize, r: &mut impl FnMut() -> f32) -> (Hit, Vec3, Vec3, Vec3) {
        let ng = Vec3::new(r(), r(), r()).normalize();
        let normal = match round % 5 {
            0 => Vec3::Y,
            1 => -Vec3::Y,
            _ => (ng + 0.2 * Vec3::new(r(), r(), r())).normalize(),
        };
        let p = Vec3::new(r(), r() * 0.5, r());
        (test_hit(p, Vec3::ZERO, normal, ng), p, normal, ng)
    }

    /// A hit at `point` (error bound `point_error`) with shading normal `normal` and
    /// geometric normal `ng`.
    fn test_hit(point: Vec3, point_error: Vec3, normal: Vec3, ng: Vec3) -> Hit {
        Hit { t: 1.0, point, point_error, normal, geometric_normal: ng, front_face: true, ..Hit::ZERO }
    }

    /// A batch's shading is `Material::shade` of each sample, bit for bit, for every kind
    /// of material, on the AVX2 path (where this CPU has it) and the portable one, and so
    /// is `Material::shade_any_direction` where it gives a value: samples
    /// in front of and behind the surface, at grazing angles, straight above it, towards
    /// the back of the light, and rays of any length.
    #[test]
    fn batch_shading_is_shade_of_each_sample() {
        let materials = [
            Material::Color(Vec3::new(0.2, 0.4, 0.8)),
            Material::Lambert(Vec3::new(0.9, 0.5, 0.1)),
            Material::Matte { kd: Vec3::new(0.5, 0.6, 0.7), sigma: 0.6 },
            Material::Matte { kd: Vec3::ONE, sigma: 0.0 },
            Material::Matte { kd: Vec3::ONE, sigma: 1.5 },
            Material::Plastic { kd: Vec3::splat(0.5), ks: Vec3::ONE, shininess: 64.0, blinn: false },
            Material::Plastic { kd: Vec3::new(0.9, 0.2, 0.1), ks: Vec3::new(1.0, 0.5, 0.25), shininess: 3.0, blinn: true },
            Material::CookTorrance { kd: Vec3::splat(0.5), f0: Vec3::new(1.0, 0.85, 0.57), roughness: 0.3, metalness: 0.5 },
            Material::Mirror,
            // Colours whose products with zero are not `+0` (`-0`, NaN).
            Material::Matte { kd: Vec3::new(-0.5, -0.0, 0.7), sigma: 0.3 },
            Material::Matte { kd: Vec3::new(0.5, f32::INFINITY, 0.7), sigma: 0.3 },
        ];
        let light = Light::Quad {
            corner: Vec3::new(-1.0, 3.0, -1.0),
            u: Vec3::new(2.0, 0.0, 0.0),
            v: Vec3::new(0.0, 0.5, 2.0),
            color: Vec3::ONE,
            power: 1.0,
        }
        .sampler();
        let mut rng = Sampler::from_seed(11);
        let (mut lit, mut unlit) = (0, 0);
        for round in 0..3000 {
            let mut r = || rng.next_f32() * 8.0 - 4.0;
            let (hit, p, normal, ng) = random_hit(round, &mut r);
            // The ray arrives from above, below, along the normal, or is long.
            let d = match round % 4 {
                0 => -normal * 3.0,
                1 => Vec3::new(r(), r(), r()) * 100.0,
                _ => Vec3::new(r(), r(), r()),
            };
            let ray = Ray::new(p - d, d);
            let mut xi = [Vec2::ZERO; BATCH];
            for x in &mut xi {
                *x = Vec2::new(rng.next_f32(), rng.next_f32());
            }
            let batch = QuadBatch::new(&light, &ShadowRays::new(p, Vec3::ZERO, ng), normal, &xi, BATCH);
            let material = &materials[round % materials.len()];
            let fast = batch.shade(material, &ray, &hit);
            let mut portable = [[0.0; BATCH]; 3];
            material.shade_lanes(&ray, &hit, &batch.wi, &mut portable);
            // The materials whose value needs no direction, and only those, give it alone.
            let any = material.shade_any_direction(&hit);
            assert_eq!(any.is_some(), round % materials.len() < 2 || *material == Material::Mirror, "{material:?}");
            for j in 0..BATCH {
                let expected = material.shade(&ray, &hit, &batch.sample(j));
                for (k, e) in expected.to_array().into_iter().enumerate() {
                    assert_eq!(fast[k][j].to_bits(), e.to_bits(), "{material:?} {j}");
                    assert_eq!(portable[k][j].to_bits(), e.to_bits(), "{material:?} {j}");
                }
                if let Some(c) = any {
                    assert_eq!(c.to_array().map(f32::to_bits), expected.to_array().map(f32::to_bits), "{material:?} {j}");
                }
                if expected == Vec3::ZERO {
                    unlit += 1;
                } else {
                    lit += 1;
                }
            }
            // The sums of the seen samples, in sample order, for counts on both sides of
            // eight (the two widths of `add_seen`): from the lanes of values, and from the
            // one value where the material has it, the same bits.
            let (count, seen) = (1 + round % BATCH, (rng.next_f32() * 65536.0) as u32);
            let mut expected = Color::ZERO;
            for j in (0..count).filter(|&j| seen >> j & 1 != 0) {
                expected += Color::new(fast[0][j], fast[1][j], fast[2][j]) * batch.sample(j).radiance * batch.cos[j];
            }
            let mut by_lanes = Color::ZERO;
            batch.add_seen(&fast, seen, count, &mut by_lanes);
            assert_eq!(by_lanes.to_array().map(f32::to_bits), expected.to_array().map(f32::to_bits), "{material:?} {count}");
            if let Some(c) = any {
                let mut by_value = Color::ZERO;
                batch.add_seen_same(c, seen, count, &mut by_value);
                assert_eq!(by_value.to_array().map(f32::to_bits), expected.to_array().map(f32::to_bits), "{material:?} {count}");
            }
        }
        assert!(lit > 10_000 && unlit > 5_000, "{lit} {unlit}");
    }

    /// A batch's values for the path tracer at an Oren–Nayar, Lambert, colour,
    /// Cook–Torrance or plastic vertex are `next_event`'s, sample by sample, bit for bit, on the AVX2
    /// path (where this CPU has it) and the portable one: whether each sample is worth its
    /// shadow ray (`has_ray` and `Path::light_sample_f`) and what it brings unoccluded
    /// (`Path::quad_sample_value`), for counts of one to sixteen, path directions above
    /// and below the surface, colours whose products with zero are not `+0`, and the
    /// lanes past the count left out, Cook–Torrance of every metalness (0, between, 1,
    /// past both ends) and roughness down to 0, Phong's and Blinn–Phong's plastic. The delta
    /// kinds and textures stay one sample at a time.
    #[test]
    fn brdf_values_are_next_events_one_sample_at_a_time() {
        use crate::integrators::path::Path;
        let materials = [
            Material::Matte { kd: Vec3::new(0.5, 0.6, 0.7), sigma: 0.6 },
            Material::Lambert(Vec3::new(0.9, 0.5, 0.1)),
            Material::Matte { kd: Vec3::ONE, sigma: 0.0 },
            Material::Color(Vec3::new(0.2, 0.4, 0.8)),
            Material::Matte { kd: Vec3::ONE, sigma: 1.5 },
            Material::Matte { kd: Vec3::new(-0.5, -0.0, 0.7), sigma: 0.3 },
            Material::Lambert(Vec3::new(-0.5, -0.0, 0.7)),
            Material::Matte { kd: Vec3::new(0.5, f32::INFINITY, 0.7), sigma: 0.3 },
            Material::Color(Vec3::new(0.5, f32::INFINITY, 0.7)),
            Material::CookTorrance { kd: Vec3::new(0.5, 0.6, 0.7), f0: Vec3::new(1.0, 0.85, 0.57), roughness: 0.3, metalness: 0.5 },
            Material::CookTorrance { kd: Vec3::ONE, f0: Vec3::new(1.0, 0.85, 0.57), roughness: 0.3, metalness: 1.0 },
            Material::CookTorrance { kd: Vec3::ONE, f0: Vec3::splat(0.04), roughness: 0.0, metalness: 0.0 },
            Material::CookTorrance { kd: Vec3::ONE, f0: Vec3::splat(0.9), roughness: 1.0, metalness: 1.5 },
            Material::CookTorrance { kd: Vec3::ONE, f0: Vec3::splat(0.9), roughness: 0.05, metalness: -0.5 },
            Material::Plastic { kd: Vec3::ONE, ks: Vec3::ONE, shininess: 64.0, blinn: false },
            Material::Plastic { kd: Vec3::new(0.9, 0.2, 0.1), ks: Vec3::new(1.0, 0.5, 0.25), shininess: 3.0, blinn: true },
            Material::Plastic { kd: Vec3::new(0.5, 0.6, 0.7), ks: Vec3::ONE, shininess: 0.0, blinn: false },
        ];
        for m in [Material::Mirror, Material::Transparent { ior: 1.3 }] {
            assert!(LaneBrdf::of(&m).is_none(), "{m:?}");
        }
        let light = Light::Quad {
            corner: Vec3::new(-1.0, 3.0, -1.0),
            // `u × v` downwards: the light faces the hits below it.
            u: Vec3::new(0.0, 0.5, 2.0),
            v: Vec3::new(2.0, 0.0, 0.0),
            color: Vec3::new(1.0, 0.5, 0.25),
            power: 3.0,
        };
        let sampler = light.sampler();
        let mut rng = Sampler::from_seed(17);
        let (mut traced_lanes, mut untraced_lanes) = (0, 0);
        for round in 0..3000 {
            let material = materials[round % materials.len()].clone();
            let scene = Scene::new(Vec::new(), vec![material.clone()], vec![light.clone()], Color::ZERO);
            let mut r = || rng.next_f32() * 8.0 - 4.0;
            let (hit, p, normal, ng) = random_hit(round, &mut r);
            // The path leaves along the normal, above the surface, or below it.
            let wo = match round % 3 {
                0 => normal,
                _ => Vec3::new(r(), r(), r()).normalize(),
            };
            let mut xi = [Vec2::ZERO; BATCH];
            for x in &mut xi {
                *x = Vec2::new(rng.next_f32(), rng.next_f32());
            }
            let count = 1 + round % BATCH;
            let n = [4, 16, 23][round % 3];
            let batch = QuadBatch::new(&sampler, &ShadowRays::new(p, Vec3::ZERO, ng), normal, &xi, count);
            let (mut fast, mut portable) = ([[f32::NAN; BATCH]; 3], [[f32::NAN; BATCH]; 3]);
            let lobe = LaneBrdf::of(&material).expect("a material of the lanes");
            let v = VertexSamples { lobe, normal, wo, n, count };
            let fast_traced = batch.brdf_values(v, &mut fast);
            let portable_traced = if matches!(lobe, LaneBrdf::CookTorrance { .. } | LaneBrdf::Plastic { .. }) {
                batch.brdf_values_portable::<true>(v, &mut portable)
            } else {
                batch.brdf_values_portable::<false>(v, &mut portable)
            };
            assert_eq!(fast_traced, portable_traced);
            for j in 0..BATCH {
                let ls = batch.sample(j);
                let f = Path::light_sample_f(&scene, &hit, wo, &ls).filter(|_| batch.has_ray[j] && j < count);
                assert_eq!(fast_traced >> j & 1 != 0, f.is_some(), "{material:?} lane {j} of {count}");
                let Some(f) = f else {
                    untraced_lanes += 1;
                    continue;
                };
                traced_lanes += 1;
                let expected = Path::quad_sample_value(&scene, &hit, wo, &ls, f, n).to_array().map(f32::to_bits);
                for k in 0..3 {
                    assert_eq!(fast[k][j].to_bits(), expected[k], "{material:?} lane {j}");
                    assert_eq!(portable[k][j].to_bits(), expected[k], "{material:?} lane {j}");
                }
            }
        }
        assert!(traced_lanes > 5_000 && untraced_lanes > 5_000, "{traced_lanes} {untraced_lanes}");
    }

    /// The bits of a light sample's floats.
    fn sample_bits(s: &LightSample) -> Vec<u32> {
        [s.direction.to_array(), [s.distance, s.pdf, 0.0], s.point.to_array(), s.radiance.to_array()]
            .iter()
            .flatten()
            .map(|f| f.to_bits())
            .collect()
    }

    /// A light's lanes (point and quad lights) are the samples and shadow rays of one hit
    /// at a time, bit for bit, on both code paths: hits on either side of their surface,
    /// on the light, beside it, far from it, behind a quad, lanes without a hit.
    #[test]
    fn light_lanes_are_the_samples_and_shadow_rays_of_one_at_a_time() {
        let mut rng = Sampler::from_seed(7);
        let (mut live, mut dead) = (0, 0);
        for round in 0..6000 {
            let mut r = || rng.next_f32() * 8.0 - 4.0;
            let position = Vec3::new(r(), r(), r());
            // Coloured lights and grey ones (whose channels are divided once).
            let color = if round / 2 % 2 == 0 { Vec3::new(1.0, 0.5, 0.0) } else { Vec3::splat(0.8) };
            let light = if round % 2 == 0 {
                Light::Point { position, color, power: 10.0 }
            } else {
                Light::Quad { corner: position, u: Vec3::new(r(), 0.0, r()), v: Vec3::new(0.0, r(), r()), color, power: 10.0 }
            }
            .sampler();
            let xi: [Vec2; BATCH] = std::array::from_fn(|_| Vec2::new(r() / 8.0 + 0.5, r() / 8.0 + 0.5));
            let hits: [Option<Hit>; BATCH] = std::array::from_fn(|j| {
                let ng = Vec3::new(r(), r(), r()).normalize();
                let point = match (round + j) % 9 {
                    0 => return None,
                    1 => position,
                    2 => position * 1e5,
                    _ => Vec3::new(r(), r(), r()),
                };
                let point_error = Vec3::new(r().abs(), r().abs(), r().abs()) * 1e-6;
                Some(test_hit(point, point_error, (ng + 0.3 * Vec3::new(r(), r(), r())).normalize(), ng))
            });
            let mut batch = LightLanes::EMPTY;
            batch.fill(&light, &hits, &xi);
            let mut portable = LightLanes::EMPTY;
            portable.fill_portable(&light, &hits, &xi);
            for (j, hit) in hits.iter().enumerate() {
                assert_eq!(batch.live[j], portable.live[j]);
                let Some(hit) = hit else {
                    assert!(!batch.live[j]);
                    continue;
                };
                let s = light.sample(hit.point, xi[j]);
                let cos = s.direction.dot(hit.normal).max(0.0);
                let ray = hit.shadow_rays().to(s.point);
                let expected = cos != 0.0 && s.radiance != Color::ZERO && ray.is_some();
                assert_eq!(batch.live[j], expected, "{hit:?}");
                // Every lane with a hit, live or not (the path tracer's lanes use them all).
                for b in [&batch, &portable] {
                    // Bit for bit (a hit on the light itself has NaN directions).
                    assert_eq!(sample_bits(&b.sample(j)), sample_bits(&s));
                    assert_eq!(b.cos[j].to_bits(), cos.to_bits());
                    assert_eq!(b.has_ray[j], ray.is_some());
                    if let Some((ray, t_max)) = ray {
                        assert_eq!(b.shadow_ray(j), RaySegment { origin: ray.origin, t_min: 0.0, direction: ray.direction, t_max });
                    }
                }
                if expected {
                    live += 1;
                } else {
                    dead += 1;
                }
            }
        }
        assert!(live > 1000 && dead > 1000, "{live} {dead}");
    }
}
