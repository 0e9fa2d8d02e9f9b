//! Materials and samplers checked as Mitsuba and Nori check them: formulas against values
//! computed by hand, white-furnace albedos, reciprocity, and every sampling routine against
//! its pdf by a chi-square test (Nori's `warptest`, pbrt-v4's `chi2` tests). The p-values
//! are printed (`cargo test --test materials -- --nocapture`).

use isir::geometry::Hit;
use isir::materials::{ggx_visible_pdf, sample_ggx_visible, Material};
use isir::math::sampling::{
    square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf, square_to_uniform_sphere, square_to_uniform_sphere_pdf, Sampler,
};
use isir::{Color, Light, Ray, Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// A hit with shading normal +z at the origin.
fn hit() -> Hit {
    Hit {
        t: 1.0,
        point: Vec3::ZERO,
        point_error: Vec3::ZERO,
        normal: Vec3::Z,
        geometric_normal: Vec3::Z,
        front_face: true,
        object: 0,
        prim: 0,
        u: 0.0,
        v: 0.0,
        uv: Vec2::ZERO,
        material: 0,
    }
}

fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol * b.abs().max(1e-6)
}

// ---- Formulas by hand ----

#[test]
fn formulas_against_values_computed_by_hand() {
    let h = hit();
    let white = Color::ONE;
    // Oren–Nayar, σ = 0.5, θi = θo = 45° in one plane (φ difference 0):
    // A = 1 - 0.125/0.58 = 0.7844828, B = 0.1125/0.34 = 0.3308824, sin α tan β = 0.7071068.
    let on = Material::Matte { kd: white, sigma: 0.5 }.eval(&h, dir(45.0, 180.0), dir(45.0, 180.0));
    assert!(close(on.x, (0.7844828 + 0.3308824 * std::f32::consts::FRAC_1_SQRT_2) * FRAC_1_PI, 1e-5), "{on}");
    // Opposite azimuths: cos(φi - φo) < 0, only A remains.
    let on = Material::Matte { kd: white, sigma: 0.5 }.eval(&h, dir(45.0, 0.0), dir(45.0, 180.0));
    assert!(close(on.x, 0.7844828 * FRAC_1_PI, 1e-5), "{on}");
    // Phong, s = 2: light at 30°, viewer on its mirror direction (cos α = 1), then at the
    // normal (cos α = cos 30° = 0.8660254, squared 0.75).
    let phong = Material::Plastic { kd: white, ks: white, shininess: 2.0, blinn: false };
    let (wi, mirror) = (dir(30.0, 0.0), dir(30.0, 180.0));
    assert!(close(phong.eval(&h, mirror, wi).x, 0.7 * FRAC_1_PI + 0.3 / 0.8660254, 1e-5));
    assert!(close(phong.eval(&h, Vec3::Z, wi).x, 0.7 * FRAC_1_PI + 0.3 * 0.75 / 0.8660254, 1e-5));
    // Blinn–Phong: at the mirror direction the half vector is n (cos = 1).
    let blinn = Material::Plastic { kd: white, ks: white, shininess: 2.0, blinn: true };
    assert!(close(blinn.eval(&h, mirror, wi).x, 0.7 * FRAC_1_PI + 0.3 / 0.8660254, 1e-5));
    // Cook–Torrance at normal incidence, roughness 0.5 (α = 0.25): D = 1/(π α²) = 5.092958,
    // G = 1, F = F0: spec = D·F0/4.
    let ct = Material::CookTorrance { kd: white, f0: Color::new(1.0, 0.85, 0.57), roughness: 0.5, metalness: 1.0 };
    let v = ct.eval(&h, Vec3::Z, Vec3::Z);
    assert!(close(v.x, 5.092958 / 4.0, 1e-4) && close(v.z, 5.092958 / 4.0 * 0.57, 1e-4), "{v}");
    // The course's shade() is the same BRDF, seen from the ray and the light sample.
    let ray = Ray::new(-mirror * 3.0, mirror * -1.0);
    let ls = isir::lights::LightSample { direction: wi, distance: 1.0, point: wi, radiance: Color::ONE, pdf: 1.0 };
    assert!(close(phong.shade(&ray, &h, &ls).x, 0.7 * FRAC_1_PI + 0.3 / 0.8660254, 1e-5));
}

#[test]
fn cook_torrance_with_metalness_zero_is_oren_nayar_and_reciprocity_holds() {
    let h = hit();
    let kd = Color::new(0.8, 0.5, 0.2);
    let mut rng = Sampler::from_seed(3);
    for _ in 0..2000 {
        let wo = square_to_cosine_hemisphere(Vec3::Z, rng.next_2d());
        let wi = square_to_cosine_hemisphere(Vec3::Z, rng.next_2d());
        for r in [0.1f32, 0.4, 0.9] {
            let ct = Material::CookTorrance { kd, f0: Color::splat(0.04), roughness: r, metalness: 0.0 }.eval(&h, wo, wi);
            let on = Material::Matte { kd, sigma: r }.eval(&h, wo, wi);
            assert_eq!(ct, on);
        }
        for m in [
            Material::Lambert(kd),
            Material::Matte { kd, sigma: 0.6 },
            Material::CookTorrance { kd, f0: Color::splat(0.9), roughness: 0.3, metalness: 0.5 },
        ] {
            let (a, b) = (m.eval(&h, wo, wi), m.eval(&h, wi, wo));
            assert!((a - b).abs().max_element() <= 1e-4 * a.max_element().max(1.0), "{m:?}: {a} vs {b}");
        }
    }
    // Plastic with the course's 1/cos θi is not reciprocal (documented): show it.
    for blinn in [false, true] {
        let plastic = Material::Plastic { kd, ks: Color::ONE, shininess: 16.0, blinn };
        let (a, b) = (plastic.eval(&h, dir(10.0, 0.0), dir(60.0, 180.0)), plastic.eval(&h, dir(60.0, 180.0), dir(10.0, 0.0)));
        assert!((a - b).abs().max_element() > 1e-4, "{a} {b}");
    }
}

#[test]
fn no_material_returns_nan_even_at_grazing_angles() {
    let h = hit();
    let mut rng = Sampler::from_seed(9);
    let kinds = [
        Material::Matte { kd: Color::ONE, sigma: 1.0 },
        Material::Plastic { kd: Color::ONE, ks: Color::ONE, shininess: 1000.0, blinn: false },
        Material::Plastic { kd: Color::ONE, ks: Color::ONE, shininess: 1000.0, blinn: true },
        Material::CookTorrance { kd: Color::ONE, f0: Color::ONE, roughness: 0.0, metalness: 1.0 },
        Material::CookTorrance { kd: Color::ONE, f0: Color::ONE, roughness: 1.0, metalness: 0.5 },
    ];
    let grazing = [dir(90.0, 0.0), dir(89.999, 40.0), Vec3::Z, dir(0.001, 0.0)];
    for m in &kinds {
        for _ in 0..2000 {
            let wo = square_to_uniform_sphere(rng.next_2d());
            let wi = square_to_uniform_sphere(rng.next_2d());
            for (a, b) in [(wo, wi), (grazing[0], wi), (wo, grazing[1]), (grazing[2], grazing[3])] {
                assert!(m.eval(&h, a, b).is_finite() && m.pdf(&h, a, b).is_finite(), "{m:?} {a} {b}");
                if let Some(s) = m.sample(&h, a, rng.next_f32(), rng.next_2d()) {
                    assert!(s.weight.is_finite() && s.pdf.is_finite() && s.weight.min_element() >= 0.0, "{m:?} {s:?}");
                }
            }
        }
    }
}

/// The path tracer's lanes draw the cosine lobe's directions for many hits at once and
/// finish each sample with `cosine_lobe_sample_from`: that must be `sample`'s answer bit
/// for bit for every material that `samples_cosine_lobe`, with `wo` above, below and
/// along the surface, normals of every direction, and grazing draws. Oren–Nayar (whose
/// weight is not its albedo) and the glossy kinds must not claim the cosine lobe.
#[test]
fn cosine_lobe_samples_are_sample_bit_for_bit() {
    let kinds = [
        Material::Color(Color::new(0.2, 0.4, 0.8)),
        Material::Lambert(Color::new(0.9, 0.5, 0.1)),
        Material::Color(Color::new(0.5, f32::INFINITY, 0.7)),
        Material::Lambert(Color::new(-0.5, -0.0, 0.7)),
    ];
    let bits = |s: Option<isir::materials::BsdfSample>| {
        s.map(|s| (s.wi.to_array().map(f32::to_bits), s.weight.to_array().map(f32::to_bits), s.pdf.to_bits(), s.delta))
    };
    let mut rng = Sampler::from_seed(23);
    let (mut some, mut none) = (0, 0);
    for m in &kinds {
        assert!(m.samples_cosine_lobe(), "{m:?}");
        for round in 0..20_000 {
            let mut h = hit();
            h.normal = if round % 4 == 0 { Vec3::Z } else { square_to_uniform_sphere(rng.next_2d()) };
            let wo = match round % 3 {
                0 => h.normal,
                _ => square_to_uniform_sphere(rng.next_2d()),
            };
            let (u_lobe, mut u) = (rng.next_f32(), rng.next_2d());
            if round % 7 == 0 {
                u.x = 1.0 - f32::EPSILON / 2.0;
            }
            let expected = m.sample(&h, wo, u_lobe, u);
            let wi = square_to_cosine_hemisphere(h.normal, u);
            let got = m.cosine_lobe_sample_from(&h, wo, wi, square_to_cosine_hemisphere_pdf(h.normal, wi));
            assert_eq!(bits(got), bits(expected), "{m:?} n {} wo {wo} u {u}", h.normal);
            if expected.is_some() {
                some += 1;
            } else {
                none += 1;
            }
        }
    }
    assert!(some > 30_000 && none > 20_000, "{some} {none}");
    for m in [
        Material::Matte { kd: Color::ONE, sigma: 0.6 },
        Material::Plastic { kd: Color::ONE, ks: Color::ONE, shininess: 64.0, blinn: false },
        Material::CookTorrance { kd: Color::ONE, f0: Color::ONE, roughness: 0.3, metalness: 0.5 },
        Material::Mirror,
        Material::Transparent { ior: 1.3 },
    ] {
        assert!(!m.samples_cosine_lobe(), "{m:?}");
    }
}

// ---- White furnace ----

/// The albedo `∫ f cos dωi` for `wo`, estimated twice: by the material's own sampling
/// (mean of the weights) and by uniform hemisphere sampling of `eval`.
/// Also the standard error of the uniform estimate (large for sharp lobes).
fn albedo(m: &Material, wo: Vec3, n: usize) -> (f32, f32, f32) {
    let h = hit();
    let mut rng = Sampler::from_seed(11);
    let mut by_sampling = 0.0f64;
    let (mut by_uniform, mut squares) = (0.0f64, 0.0f64);
    for _ in 0..n {
        if let Some(s) = m.sample(&h, wo, rng.next_f32(), rng.next_2d()) {
            by_sampling += f64::from(s.weight.x);
        }
        let mut w = square_to_uniform_sphere(rng.next_2d());
        w.z = w.z.abs();
        let x = f64::from(m.eval(&h, wo, w).x * w.z * 2.0 * PI);
        by_uniform += x;
        squares += x * x;
    }
    let mean = by_uniform / n as f64;
    let se = ((squares / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
    ((by_sampling / n as f64) as f32, mean as f32, se as f32)
}

#[test]
fn white_furnace_albedos_are_at_most_one_and_exactly_kd_for_lambert() {
    let n = 200_000;
    for theta in [0.0f32, 30.0, 60.0, 80.0] {
        let wo = dir(theta, 20.0);
        let (s, u, _) = albedo(&Material::Lambert(Color::splat(0.7)), wo, n);
        assert!(close(s, 0.7, 1e-6), "Lambert by its sampling: {s}");
        assert!(close(u, 0.7, 0.01), "Lambert by uniform sampling: {u}");
        let mut cases = vec![];
        for sigma in [0.0f32, 0.3, 0.6, 1.0] {
            cases.push((format!("Oren–Nayar σ {sigma}"), Material::Matte { kd: Color::ONE, sigma }));
        }
        for r in [0.2f32, 0.5, 0.9] {
            cases.push((
                format!("Cook–Torrance r {r}"),
                Material::CookTorrance { kd: Color::ONE, f0: Color::ONE, roughness: r, metalness: 1.0 },
            ));
            cases.push((
                format!("Cook–Torrance r {r} m 0.5"),
                Material::CookTorrance { kd: Color::ONE, f0: Color::ONE, roughness: r, metalness: 0.5 },
            ));
        }
        for (name, m) in cases {
            let (s, u, se) = albedo(&m, wo, n);
            println!("white furnace θo {theta}°: {name}: {s:.4} (own sampling), {u:.4} ± {se:.4} (uniform)");
            assert!(s <= 1.02 && u <= 1.02, "{name} at {theta}°: reflects {s} / {u} > 1");
            // Both estimators agree (within the uniform one's noise, which is large for
            // sharp lobes): eval, pdf and sample are consistent.
            assert!((s - u).abs() <= 0.01 * u.max(0.05) + 4.0 * se, "{name} at {theta}°: {s} by sampling vs {u} ± {se} uniform");
        }
    }
}

// ---- Chi-square tests ----

/// The upper regularized incomplete gamma function Q(a, x) (Numerical Recipes, §6.2).
fn gamma_q(a: f64, x: f64) -> f64 {
    fn ln_gamma(z: f64) -> f64 {
        // Lanczos, g = 7.
        const C: [f64; 9] = [
            0.999_999_999_999_809_9,
            676.520_368_121_885_1,
            -1_259.139_216_722_402_8,
            771.323_428_777_653_1,
            -176.615_029_162_140_6,
            12.507_343_278_686_905,
            -0.138_571_095_265_720_12,
            9.984_369_578_019_572e-6,
            1.505_632_735_149_311_6e-7,
        ];
        let z = z - 1.0;
        let t = z + 7.5;
        let s: f64 = C[0] + (1..9).map(|i| C[i] / (z + i as f64)).sum::<f64>();
        0.5 * (2.0 * std::f64::consts::PI).ln() + (z + 0.5) * t.ln() - t + s.ln()
    }
    if x < a + 1.0 {
        // Series for P, then Q = 1 - P.
        let (mut sum, mut del, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..1000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - ln_gamma(a)).exp()
    } else {
        // Continued fraction (Lentz).
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (-x + a * x.ln() - ln_gamma(a)).exp() * h
    }
}

const COS_BINS: usize = 10;
const PHI_BINS: usize = 20;

fn cell(w: Vec3) -> usize {
    let c = ((w.z.clamp(-1.0, 1.0) + 1.0) * 0.5 * COS_BINS as f32).min(COS_BINS as f32 - 1.0) as usize;
    let phi = w.y.atan2(w.x).rem_euclid(2.0 * PI);
    let p = (phi / (2.0 * PI) * PHI_BINS as f32).min(PHI_BINS as f32 - 1.0) as usize;
    c * PHI_BINS + p
}

/// Pearson's chi-square test of `samples` draws of `sample` (None: no direction) against
/// the density `pdf` on the sphere, in (cos θ, φ) cells (equal solid angle), cells
/// expecting fewer than 5 pooled. Returns the p-value.
fn chi2(name: &str, samples: usize, mut sample: impl FnMut(&mut Sampler) -> Option<Vec3>, pdf: impl Fn(Vec3) -> f32) -> f64 {
    let mut rng = Sampler::from_seed(1234);
    let mut observed = vec![0f64; COS_BINS * PHI_BINS];
    for _ in 0..samples {
        if let Some(w) = sample(&mut rng) {
            observed[cell(w)] += 1.0;
        }
    }
    // Expected counts: the pdf integrated over each cell by 48×48 midpoints (sharp lobes
    // and the quad's edges need them).
    const SUB: usize = 48;
    let cell_area = (2.0 / COS_BINS as f64) * (2.0 * std::f64::consts::PI / PHI_BINS as f64);
    let mut expected = vec![0f64; COS_BINS * PHI_BINS];
    for c in 0..COS_BINS {
        for p in 0..PHI_BINS {
            let mut sum = 0.0f64;
            for i in 0..SUB {
                for j in 0..SUB {
                    let z = -1.0 + (c as f64 + (i as f64 + 0.5) / SUB as f64) * 2.0 / COS_BINS as f64;
                    let phi = (p as f64 + (j as f64 + 0.5) / SUB as f64) * 2.0 * std::f64::consts::PI / PHI_BINS as f64;
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    sum += f64::from(pdf(Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)));
                }
            }
            expected[c * PHI_BINS + p] = sum / (SUB * SUB) as f64 * cell_area * samples as f64;
        }
    }
    let (mut stat, mut dof, mut pool_o, mut pool_e) = (0.0, 0usize, 0.0, 0.0);
    for (o, e) in observed.iter().zip(&expected) {
        if *e < 5.0 {
            pool_o += o;
            pool_e += e;
        } else {
            stat += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pool_e >= 5.0 {
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        dof += 1;
    } else {
        assert!(pool_o <= 5.0 + 5.0 * pool_e, "{name}: {pool_o} samples where the pdf expects {pool_e}");
    }
    let p = gamma_q((dof - 1) as f64 / 2.0, stat / 2.0);
    println!("chi-square {name}: statistic {stat:.1}, {} degrees of freedom, p = {p:.4}", dof - 1);
    p
}

#[test]
fn the_gamma_function_is_right() {
    // Q(1, x) = e^-x; Q(k/2, x/2) for k = 2, x = 2: e^-1.
    assert!((gamma_q(1.0, 0.7) - (-0.7f64).exp()).abs() < 1e-10);
    assert!((gamma_q(1.0, 20.0) - (-20.0f64).exp()).abs() < 1e-15);
    // Chi-square with 10 dof at 18.307 has p = 0.05.
    assert!((gamma_q(5.0, 18.307 / 2.0) - 0.05).abs() < 1e-4);
}

#[test]
fn warps_match_their_pdfs() {
    let n = Vec3::Z;
    let p = chi2(
        "cosine hemisphere",
        200_000,
        |r| Some(square_to_cosine_hemisphere(n, r.next_2d())),
        |w| square_to_cosine_hemisphere_pdf(n, w),
    );
    assert!(p > 0.01);
    let p = chi2("uniform sphere", 200_000, |r| Some(square_to_uniform_sphere(r.next_2d())), |_| square_to_uniform_sphere_pdf());
    assert!(p > 0.01);
    for (alpha, theta) in [(0.2f32, 30.0f32), (0.6, 70.0)] {
        let wo = dir(theta, 0.0);
        let p = chi2(
            &format!("GGX visible normals α {alpha} θo {theta}°"),
            200_000,
            |r| Some(sample_ggx_visible(alpha, n, wo, r.next_2d())),
            |h| ggx_visible_pdf(alpha, n, wo, h),
        );
        assert!(p > 0.01);
    }
}

#[test]
fn material_sampling_matches_material_pdfs() {
    let h = hit();
    let wo = dir(40.0, 10.0);
    let kinds = [
        ("Oren–Nayar", Material::Matte { kd: Color::ONE, sigma: 0.6 }),
        ("Phong s 16", Material::Plastic { kd: Color::ONE, ks: Color::ONE, shininess: 16.0, blinn: false }),
        ("Blinn–Phong s 16", Material::Plastic { kd: Color::ONE, ks: Color::ONE, shininess: 16.0, blinn: true }),
        ("Cook–Torrance r 0.4 m 0.5", Material::CookTorrance { kd: Color::ONE, f0: Color::ONE, roughness: 0.4, metalness: 0.5 }),
        ("Cook–Torrance r 0.7 m 1", Material::CookTorrance { kd: Color::ONE, f0: Color::ONE, roughness: 0.7, metalness: 1.0 }),
    ];
    for (name, m) in kinds {
        let p = chi2(name, 200_000, |r| m.sample(&h, wo, r.next_f32(), r.next_2d()).map(|s| s.wi), |wi| m.pdf(&h, wo, wi));
        assert!(p > 0.01, "{name}");
    }
}

#[test]
fn quad_light_samples_match_their_pdf() {
    // Seen from the origin, TP3's quad light: directions and the pdf each sample carries,
    // against the pdf of the direction found by intersecting the light.
    let light = Light::Quad {
        corner: Vec3::new(-1.0, -1.0, 2.0),
        u: Vec3::new(2.0, 0.0, 0.0),
        v: Vec3::new(0.0, 3.0, 1.0),
        color: Color::ONE,
        power: 1.0,
    };
    let x = Vec3::ZERO;
    let mut carried_ok = true;
    let p = chi2(
        "quad light",
        200_000,
        |r| {
            let s = light.sample(x, r.next_2d());
            let by_ray = light.intersect(&Ray::new(x, s.direction), 0.0, f32::INFINITY).map_or(0.0, |h| h.pdf);
            carried_ok &= (s.pdf - by_ray).abs() <= 1e-3 * by_ray;
            Some(s.direction)
        },
        |w| light.intersect(&Ray::new(x, w), 0.0, f32::INFINITY).map_or(0.0, |h| h.pdf),
    );
    assert!(carried_ok, "a sample's pdf differs from the pdf of its direction");
    assert!(p > 0.01);
}

#[test]
fn the_test_rejects_a_wrong_pdf() {
    // The cosine warp against the uniform hemisphere's pdf: must fail.
    let n = Vec3::Z;
    let p = chi2(
        "cosine vs uniform (must fail)",
        50_000,
        |r| Some(square_to_cosine_hemisphere(n, r.next_2d())),
        |w| {
            if w.z > 0.0 {
                0.5 * FRAC_1_PI
            } else {
                0.0
            }
        },
    );
    assert!(p < 1e-6, "{p}");
    let _ = Vec2::ZERO;
}
