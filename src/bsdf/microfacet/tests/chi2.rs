//! χ² goodness-of-fit tests of every sampler, after Mitsuba's `python/chi2.py`.

use super::*;

// ---------------------------------------------------------------------------------------
// χ² goodness of fit, after Mitsuba's `python/chi2.py` (`ChiSquareTest`, `SphericalDomain`)
// and `math::chi2`.

/// The number of χ² tests in this file, in plastic's (`bsdf/plastic/tests.rs`, 12) and in
/// the environment's (`emitter/environment/tests.rs`, 3): the Šidák correction spreads
/// the 1 % significance level over all of them, so the whole set rejects a correct
/// sampler 1 % of the time.
const CHI2_TESTS: u32 = 12 + 12 + 16 + 12 + 3;

/// Histogram resolution over (φ, −cos θ), Mitsuba's aspect 2 for the sphere.
const RES_PHI: usize = 100;
const RES_COS: usize = 50;
/// Trapezoid points per cell side when integrating a BSDF's density (Mitsuba's default
/// is 4). The visible-normal density drops to 0 across the great circle wi·m = 0, inside
/// cells, and needs finer integration not to reject a correct sampler at grazing
/// incidence: Mitsuba's own VNDF test (`test_microfacet.py`) uses 32; here [`IRES_VNDF`].
const IRES: usize = 8;
/// Trapezoid points per cell side for the visible-normal density.
const IRES_VNDF: usize = 24;
const SAMPLES: usize = 400_000;

/// Sphere ↔ (φ, y = −cos θ) as Mitsuba's `SphericalDomain` (Jacobian 1).
fn domain_forward(phi: f64, y: f64) -> Vec3 {
    let cos_t = -y;
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    Vec3::new((phi.cos() * sin_t) as f32, (phi.sin() * sin_t) as f32, cos_t as f32)
}

fn domain_cell(v: Vec3) -> usize {
    let phi = (v.y as f64).atan2(v.x as f64);
    let y = -(v.z as f64);
    let fx = (phi + std::f64::consts::PI) / (2.0 * std::f64::consts::PI) * RES_PHI as f64;
    let fy = (y + 1.0) / 2.0 * RES_COS as f64;
    let ix = (fx as isize).clamp(0, RES_PHI as isize - 1) as usize;
    let iy = (fy as isize).clamp(0, RES_COS as isize - 1) as usize;
    iy * RES_PHI + ix
}

/// ln Γ(x) by Lanczos (the coefficients of Dr.Jit's `lgamma`), x > 0.
fn lgamma(x: f64) -> f64 {
    const C: [f64; 7] = [
        1.000000000190015,
        76.18009172947146,
        -86.50532032941677,
        24.01409824083091,
        -1.231739572450155,
        0.1208650973866179e-2,
        -0.5395239384953e-5,
    ];
    let x = x - 1.0;
    let b = x + 5.5;
    let sum = C[0] + (1..7).map(|i| C[i] / (x + i as f64)).sum::<f64>();
    (0.918_938_533_204_672_8 + sum.ln()) - b + b.ln() * (x + 0.5)
}

/// The regularized lower incomplete gamma P(a, x), CEPHES' series and continued fraction
/// as Mitsuba's `math_py.rlgamma`.
fn rlgamma(a: f64, x: f64) -> f64 {
    const EPS: f64 = 1e-15;
    const BIG: f64 = 4.503599627370496e15;
    const BIGINV: f64 = 2.220_446_049_250_313e-16;
    if x <= 0.0 {
        return 0.0;
    }
    let ax = a * x.ln() - x - lgamma(a);
    if ax < -709.782_712_893_384 {
        return if a < x { 1.0 } else { 0.0 };
    }
    if x <= 1.0 || x <= a {
        let (mut r2, mut c2, mut ans2) = (a, 1.0, 1.0);
        loop {
            r2 += 1.0;
            c2 *= x / r2;
            ans2 += c2;
            if c2 / ans2 <= EPS {
                break;
            }
        }
        return ax.exp() * ans2 / a;
    }
    let (mut c, mut y, mut z) = (0.0, 1.0 - a, x + 2.0 - a);
    let (mut p3, mut q3, mut p2, mut q2) = (1.0, x, x + 1.0, z * x);
    let mut ans = p2 / q2;
    loop {
        c += 1.0;
        y += 1.0;
        z += 2.0;
        let yc = y * c;
        let p = p2 * z - p3 * yc;
        let q = q2 * z - q3 * yc;
        let error = if q != 0.0 {
            let next = p / q;
            let e = ((ans - next) / next).abs();
            ans = next;
            e
        } else {
            1.0
        };
        (p3, p2, q3, q2) = (p2, p, q2, q);
        if p.abs() > BIG {
            p3 *= BIGINV;
            p2 *= BIGINV;
            q3 *= BIGINV;
            q2 *= BIGINV;
        }
        if error <= EPS {
            break;
        }
    }
    1.0 - ax.exp() * ans
}

/// Runs the χ² test of `sample` (one direction per pair of random numbers, None for an
/// invalid sample, which Mitsuba counts with weight 0) against `pdf` (a density over the
/// sphere) and returns Err with the reason when it rejects.
pub(crate) fn chi2(
    name: &str,
    seed: u64,
    ires: usize,
    mut sample: impl FnMut(&mut Pcg32) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f32,
) -> Result<(), String> {
    let mut rng = Pcg32::new(seed, 54);
    let mut hist = vec![0.0f64; RES_PHI * RES_COS];
    for _ in 0..SAMPLES {
        if let Some(v) = sample(&mut rng) {
            if !v.is_finite() || (v.length() - 1.0).abs() > 1e-3 {
                return Err(format!("{name}: sample {v} is not a unit vector"));
            }
            hist[domain_cell(v)] += 1.0;
        }
    }
    // The trapezoid rule over IRES × IRES points per cell, Mitsuba's `tabulate_pdf`.
    let (two_pi, pi) = (2.0 * std::f64::consts::PI, std::f64::consts::PI);
    let cell = (two_pi / RES_PHI as f64, 2.0 / RES_COS as f64);
    let spacing = (cell.0 / (ires - 1) as f64, cell.1 / (ires - 1) as f64);
    let mut expected = vec![0.0f64; RES_PHI * RES_COS];
    for (i, e) in expected.iter_mut().enumerate() {
        let (cx, cy) = (i % RES_PHI, i / RES_PHI);
        let mut sum = 0.0;
        for sy in 0..ires {
            for sx in 0..ires {
                let phi = -pi + cx as f64 * cell.0 + (sx as f64 + 1e-4) * (1.0 - 2e-4) * spacing.0;
                let y = -1.0 + cy as f64 * cell.1 + (sy as f64 + 1e-4) * (1.0 - 2e-4) * spacing.1;
                let w = if sx == 0 || sx == ires - 1 { 0.5 } else { 1.0 }
                    * if sy == 0 || sy == ires - 1 { 0.5 } else { 1.0 };
                sum += w * pdf(domain_forward(phi, y)) as f64;
            }
        }
        *e = sum * spacing.0 * spacing.1 * SAMPLES as f64;
    }
    let pdf_sum = expected.iter().sum::<f64>() / SAMPLES as f64;
    if pdf_sum > 1.1 || expected.iter().any(|&e| e.is_nan() || e < 0.0) {
        return Err(format!("{name}: the density integrates to {pdf_sum} or is negative"));
    }
    // Pool the cells of low expected count, sorted by it, as Mitsuba's `math::chi2`.
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut chsq, mut pooled_obs, mut pooled_exp, mut dof) = (0.0, 0.0, 0.0, 0usize);
    for &i in &order {
        let (obs, exp) = (hist[i], expected[i]);
        if exp == 0.0 && obs > 0.0 {
            return Err(format!("{name}: {obs} samples in a cell of density 0"));
        }
        if exp == 0.0 && obs == 0.0 {
            continue;
        }
        if exp < 5.0 {
            pooled_obs += obs;
            pooled_exp += exp;
            if pooled_exp > 5.0 {
                chsq += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
                (pooled_obs, pooled_exp) = (0.0, 0.0);
                dof += 1;
            }
        } else {
            chsq += (obs - exp) * (obs - exp) / exp;
            dof += 1;
        }
    }
    if dof < 2 {
        return Err(format!("{name}: too few degrees of freedom"));
    }
    let dof = dof - 1;
    let p_value = 1.0 - rlgamma(dof as f64 / 2.0, chsq / 2.0);
    let level = 1.0 - (1.0f64 - 0.01).powf(1.0 / CHI2_TESTS as f64);
    if p_value.is_nan() || p_value < level {
        return Err(format!("{name}: rejected, χ² = {chsq:.1} with {dof} dof, p = {p_value:.3e} < {level:.3e}"));
    }
    Ok(())
}

/// Runs every case and fails listing all rejections (not just the first).
fn all_pass(results: Vec<Result<(), String>>) {
    let errors: Vec<String> = results.into_iter().filter_map(Result::err).collect();
    assert!(errors.is_empty(), "{}", errors.join("\n"));
}

/// The distributions and incident directions the χ² tests cover: GGX and Beckmann,
/// isotropic and anisotropic, normal, oblique and near-grazing (85°) incidence.
fn chi2_cases() -> Vec<(Microfacet, Vec3)> {
    let mut cases = Vec::new();
    for mf in [ggx(0.5, 0.5), ggx(0.2, 0.6), beckmann(0.5, 0.5), beckmann(0.6, 0.2)] {
        for wi in [dir(0.0, 0.0), dir(45.0, 30.0), dir(85.0, 120.0)] {
            cases.push((mf, wi));
        }
    }
    cases
}

#[test]
fn chi2_vndf_sample_matches_pdf() {
    let results = chi2_cases()
        .into_iter()
        .enumerate()
        .map(|(i, (mf, wi))| {
            chi2(
                &format!("vndf {mf:?} wi {wi}"),
                i as u64,
                IRES_VNDF,
                |rng| Some(mf.sample(wi, rng.next_vec2())),
                |m| if m.z > 0.0 { mf.pdf(wi, m) } else { 0.0 },
            )
        })
        .collect();
    all_pass(results);
}

#[test]
fn chi2_rough_conductor_sample_matches_pdf() {
    let (eta, k) = named_conductor("Au").unwrap();
    let results = chi2_cases()
        .into_iter()
        .enumerate()
        .map(|(i, (mf, wi))| {
            chi2(
                &format!("conductor {mf:?} wi {wi}"),
                100 + i as u64,
                IRES,
                |rng| rough_conductor_sample(&mf, eta, k, wi, rng.next_vec2()).map(|s| s.0),
                |wo| rough_conductor_pdf(&mf, wi, wo),
            )
        })
        .collect();
    all_pass(results);
}

/// Mitsuba's stochastic rough dielectric sample built from the split: reflection with
/// probability F (the Fresnel term at the same m), else refraction; None when the chosen
/// branch is.
fn dielectric_choice(mf: &Microfacet, eta: f32, wi: Vec3, rng: &mut Pcg32) -> Option<Vec3> {
    let u = rng.next_vec2();
    let u1 = rng.next_f32();
    let split = rough_dielectric_split(mf, eta, wi, u);
    let f = dielectric_micro(mf, eta, wi, u)?.f;
    let branch = if u1 < f { split.reflect } else { split.refract };
    branch.map(|b| b.0)
}

#[test]
fn chi2_rough_dielectric_sample_matches_pdf() {
    let mut results = Vec::new();
    let mut seed = 200;
    for mf in [ggx(0.3, 0.3), ggx(0.2, 0.5), beckmann(0.3, 0.3), beckmann(0.5, 0.2)] {
        // Outside at 45° and 85°, inside at 30° and at 60°, past the critical angle of
        // η = 1.5 (41.8°), where most samples are totally reflected.
        let wis = [dir(45.0, 30.0), dir(85.0, 200.0), -dir(30.0, 80.0), -dir(60.0, 10.0)];
        for wi in wis {
            let eta = 1.5;
            seed += 1;
            results.push(chi2(
                &format!("dielectric {mf:?} wi {wi}"),
                seed,
                IRES,
                |rng| dielectric_choice(&mf, eta, wi, rng),
                |wo| rough_dielectric_pdf(&mf, eta, wi, wo),
            ));
        }
    }
    all_pass(results);
}

/// The χ² test can fail: GGX samples are rejected against the Beckmann density, and
/// against a GGX density whose α is off by 5 %.
#[test]
fn chi2_rejects_a_wrong_density() {
    let wi = dir(45.0, 30.0);
    let g = ggx(0.5, 0.5);
    for (seed, wrong) in [(1, beckmann(0.5, 0.5)), (2, ggx(0.525, 0.525))] {
        let result = chi2(
            "wrong",
            seed,
            IRES_VNDF,
            |rng| Some(g.sample(wi, rng.next_vec2())),
            |m| if m.z > 0.0 { wrong.pdf(wi, m) } else { 0.0 },
        );
        assert!(result.is_err(), "{wrong:?} accepted");
    }
}

#[test]
fn rlgamma_matches_known_values() {
    // P(1, x) = 1 − e^−x; P(0.5, x) = erf(√x); P(10, 10) = 0.5420702855281478 (scipy).
    // (The Lanczos ln Γ is good to about 1e-10.)
    assert!((rlgamma(1.0, 2.0) - (1.0 - (-2.0f64).exp())).abs() < 1e-9);
    assert!((rlgamma(0.5, 0.25) - 0.520_499_877_813_046_5).abs() < 1e-9);
    assert!((rlgamma(10.0, 10.0) - 0.542_070_285_528_147_8).abs() < 1e-9);
    assert!((rlgamma(100.0, 150.0) - 1.0).abs() < 1e-4);
}
