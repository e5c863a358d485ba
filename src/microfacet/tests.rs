//! Tests of the microfacet module: χ² goodness of fit of every sampler against its
//! density (Mitsuba's `chi2.py` procedure), weights against eval / pdf, reciprocity,
//! energy bounds, and values read off Mitsuba 3.9.1's Python module.

use super::*;

/// PCG32 (O'Neill's `pcg32_random_r`, as Mitsuba's `PCG32`), seeded per test so every run
/// draws the same numbers.
struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    fn new(seed: u64, seq: u64) -> Self {
        let mut rng = Pcg32 { state: 0, inc: (seq << 1) | 1 };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// A float in [0, 1) with 24 random bits.
    fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    fn next_vec2(&mut self) -> Vec2 {
        Vec2::new(self.next_f32(), self.next_f32())
    }

    /// A uniform direction on the unit sphere.
    fn sphere(&mut self) -> Vec3 {
        let z = 1.0 - 2.0 * self.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * self.next_f32();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

/// A unit direction from polar angle θ and azimuth φ in degrees.
fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

fn ggx(au: f32, av: f32) -> Microfacet {
    Microfacet { distribution: Distribution::Ggx, alpha_u: au, alpha_v: av }
}

fn beckmann(au: f32, av: f32) -> Microfacet {
    Microfacet { distribution: Distribution::Beckmann, alpha_u: au, alpha_v: av }
}

// ---------------------------------------------------------------------------------------
// χ² goodness of fit, after Mitsuba's `python/chi2.py` (`ChiSquareTest`, `SphericalDomain`)
// and `math::chi2`.

/// The number of χ² tests in this file: the Šidák correction spreads the 1 % significance
/// level over all of them, so the whole set rejects a correct sampler 1 % of the time.
const CHI2_TESTS: u32 = 12 + 12 + 16;

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
fn chi2(
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

// ---------------------------------------------------------------------------------------
// Weights, reciprocity, energy.

fn close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-6
}

#[test]
fn conductor_weight_is_eval_over_pdf() {
    let (eta, k) = named_conductor("Cu").unwrap();
    let mut rng = Pcg32::new(7, 1);
    let mut checked = 0;
    for mf in [ggx(0.1, 0.1), ggx(0.3, 0.7), beckmann(0.4, 0.4), beckmann(0.05, 0.3)] {
        for _ in 0..2000 {
            let mut wi = rng.sphere();
            wi.z = wi.z.abs();
            let Some((wo, weight)) = rough_conductor_sample(&mf, eta, k, wi, rng.next_vec2()) else {
                continue;
            };
            let pdf = rough_conductor_pdf(&mf, wi, wo);
            if pdf < 1e-3 || wi.z < 1e-2 || wo.z < 1e-2 {
                continue;
            }
            let ratio = rough_conductor_eval(&mf, eta, k, wi, wo) / pdf;
            for c in 0..3 {
                assert!(close(weight[c], ratio[c], 2e-3), "{mf:?} {wi} {wo}: {weight} vs {ratio}");
            }
            checked += 1;
        }
    }
    assert!(checked > 5000, "{checked}");
}

#[test]
fn dielectric_weights_are_eval_over_pdf_times_branch_probability() {
    let mut rng = Pcg32::new(8, 1);
    let mut checked = [0; 2];
    for mf in [ggx(0.1, 0.1), ggx(0.3, 0.7), beckmann(0.4, 0.4), beckmann(0.05, 0.3)] {
        for eta in [1.5, 1.0 / 1.33] {
            for _ in 0..2000 {
                let wi = rng.sphere();
                let u = rng.next_vec2();
                let split = rough_dielectric_split(&mf, eta, wi, u);
                let Some(micro) = dielectric_micro(&mf, eta, wi, u) else {
                    continue;
                };
                for (branch, prob, i) in [(split.reflect, micro.f, 0), (split.refract, 1.0 - micro.f, 1)] {
                    let Some((wo, weight)) = branch else { continue };
                    let pdf = rough_dielectric_pdf(&mf, eta, wi, wo);
                    if pdf < 1e-3 || wi.z.abs() < 1e-2 || wo.z.abs() < 1e-2 || prob < 1e-3 {
                        continue;
                    }
                    let expect = rough_dielectric_eval(&mf, eta, wi, wo) / pdf * prob;
                    assert!(close(weight, expect, 3e-3), "{mf:?} η {eta} {wi} {wo}: {weight} vs {expect}");
                    checked[i] += 1;
                }
            }
        }
    }
    assert!(checked[0] > 3000 && checked[1] > 3000, "{checked:?}");
}

#[test]
fn total_internal_reflection_leaves_no_refraction() {
    // Inside glass at 60° from the normal: past the critical angle for every m near +z.
    let mf = ggx(0.01, 0.01);
    let wi = -dir(60.0, 0.0);
    let mut rng = Pcg32::new(9, 1);
    for _ in 0..100 {
        let s = rough_dielectric_split(&mf, 1.5, wi, rng.next_vec2());
        assert!(s.refract.is_none());
        let (wo, w) = s.reflect.unwrap();
        assert!(wo.z < 0.0 && w > 0.9, "{wo} {w}");
    }
}

#[test]
fn index_matched_dielectric_passes_straight_through() {
    // η = 1: F = 0, so no reflection, and the refracted direction is −wi for every m.
    let mf = beckmann(0.4, 0.2);
    let mut rng = Pcg32::new(13, 1);
    for _ in 0..100 {
        let wi = rng.sphere();
        let s = rough_dielectric_split(&mf, 1.0, wi, rng.next_vec2());
        assert!(s.reflect.is_none());
        if let Some((wo, w)) = s.refract {
            // Mitsuba's rational Beckmann G1 overshoots 1 by up to ~5e-5 near a = 1.6.
            assert!(wo.abs_diff_eq(-wi, 1e-5) && w > 0.0 && w <= 1.0001, "{wi} {wo} {w}");
        }
    }
    // The density of that delta is not a function: eval and pdf are 0 rather than NaN.
    let wi = dir(30.0, 0.0);
    assert_eq!(rough_dielectric_eval(&mf, 1.0, wi, -wi), 0.0);
    assert_eq!(rough_dielectric_pdf(&mf, 1.0, wi, -wi), 0.0);
}

#[test]
fn conductor_eval_is_reciprocal() {
    let (eta, k) = named_conductor("Au").unwrap();
    let mut rng = Pcg32::new(10, 1);
    for mf in [ggx(0.2, 0.2), ggx(0.3, 0.8), beckmann(0.5, 0.5), beckmann(0.2, 0.6)] {
        for _ in 0..1000 {
            let (mut a, mut b) = (rng.sphere(), rng.sphere());
            a.z = a.z.abs().max(1e-3);
            b.z = b.z.abs().max(1e-3);
            let (a, b) = (a.normalize(), b.normalize());
            let fab = rough_conductor_eval(&mf, eta, k, a, b) / b.z;
            let fba = rough_conductor_eval(&mf, eta, k, b, a) / a.z;
            for c in 0..3 {
                assert!(close(fab[c], fba[c], 1e-3), "{mf:?} {a} {b}: {fab} vs {fba}");
            }
        }
    }
}

#[test]
fn dielectric_eval_obeys_generalised_reciprocity() {
    // Without the 1/η² radiance scale, f(wi, wo) / η_o² = f(wo, wi) / η_i², with η = 1
    // outside (+z) and η = `eta` inside.
    let mut rng = Pcg32::new(11, 1);
    let mut nonzero = [0; 2];
    for mf in [ggx(0.2, 0.2), ggx(0.3, 0.8), beckmann(0.5, 0.5), beckmann(0.2, 0.6)] {
        for eta in [1.5f32, 0.8] {
            let side = |v: Vec3| if v.z > 0.0 { 1.0 } else { eta };
            for _ in 0..2000 {
                let (a, b) = (rng.sphere(), rng.sphere());
                if a.z.abs() < 1e-2 || b.z.abs() < 1e-2 {
                    continue;
                }
                let fab = rough_dielectric_eval(&mf, eta, a, b) / b.z.abs() / (side(b) * side(b));
                let fba = rough_dielectric_eval(&mf, eta, b, a) / a.z.abs() / (side(a) * side(a));
                assert!(close(fab, fba, 2e-3), "{mf:?} η {eta} {a} {b}: {fab} vs {fba}");
                if fab > 0.0 {
                    nonzero[usize::from(a.z * b.z < 0.0)] += 1;
                }
            }
        }
    }
    // Both reflection and transmission pairs were compared with nonzero values.
    assert!(nonzero[0] > 1000 && nonzero[1] > 1000, "{nonzero:?}");
}

/// The Monte Carlo albedo of a sampler: the mean of its weights (sum of both branches
/// for the split).
fn albedo(n: usize, seed: u64, mut weight: impl FnMut(Vec2) -> f32) -> f32 {
    let mut rng = Pcg32::new(seed, 3);
    (0..n).map(|_| weight(rng.next_vec2()) as f64).sum::<f64>() as f32 / n as f32
}

#[test]
fn energy_is_bounded_and_conserved_when_lossless() {
    // A perfect conductor: η = 0 makes Mitsuba's fresnel_conductor exactly 1.
    let (eta0, k1) = (Vec3::ZERO, Vec3::ONE);
    assert_eq!(fresnel_conductor(0.3, eta0, k1), Vec3::ONE);
    for alpha in [0.02, 0.3, 0.8] {
        for mf in [ggx(alpha, alpha), beckmann(alpha, alpha), ggx(alpha, alpha * 0.5)] {
            for theta in [0.0, 60.0, 85.0] {
                let wi = dir(theta, 40.0);
                let a = albedo(20_000, 1, |u| rough_conductor_sample(&mf, eta0, k1, wi, u).map_or(0.0, |s| s.1.x));
                assert!(a <= 1.0 + 1e-3, "conductor {mf:?} θ {theta}: {a}");
                // Smith loses energy to masking, more at high roughness and grazing
                // angles; at low roughness short of grazing almost none.
                if alpha <= 0.02 && theta < 80.0 {
                    assert!(a > 0.99, "conductor {mf:?} θ {theta}: {a}");
                }
                for eta in [1.5, 1.0 / 1.5] {
                    for wi in [wi, -wi] {
                        let a = albedo(20_000, 2, |u| {
                            let s = rough_dielectric_split(&mf, eta, wi, u);
                            s.reflect.map_or(0.0, |b| b.1) + s.refract.map_or(0.0, |b| b.1)
                        });
                        assert!(a <= 1.0 + 1e-3, "dielectric {mf:?} η {eta} wi {wi}: {a}");
                        if alpha <= 0.02 && theta < 80.0 {
                            assert!(a > 0.99, "dielectric {mf:?} η {eta} wi {wi}: {a}");
                        }
                    }
                }
            }
        }
    }
}

/// The sampler and eval agree globally: the mean weight (importance sampled) equals the
/// integral of eval over the sphere estimated with uniform directions.
#[test]
fn albedo_by_sampling_equals_integral_of_eval() {
    let (eta, k) = named_conductor("Al").unwrap();
    let mut rng = Pcg32::new(12, 1);
    for mf in [ggx(0.4, 0.4), beckmann(0.3, 0.6)] {
        let wi = dir(50.0, 10.0);
        let sampled = albedo(100_000, 4, |u| rough_conductor_sample(&mf, eta, k, wi, u).map_or(0.0, |s| s.1.y));
        let n = 400_000;
        let uniform = (0..n).map(|_| rough_conductor_eval(&mf, eta, k, wi, rng.sphere()).y as f64).sum::<f64>()
            * 4.0
            * std::f64::consts::PI
            / n as f64;
        assert!((sampled as f64 - uniform).abs() < 0.02, "conductor {mf:?}: {sampled} vs {uniform}");
        for wi in [wi, -wi] {
            let sampled = albedo(100_000, 5, |u| {
                let s = rough_dielectric_split(&mf, 1.5, wi, u);
                s.reflect.map_or(0.0, |b| b.1) + s.refract.map_or(0.0, |b| b.1)
            });
            let uniform = (0..n).map(|_| rough_dielectric_eval(&mf, 1.5, wi, rng.sphere()) as f64).sum::<f64>()
                * 4.0
                * std::f64::consts::PI
                / n as f64;
            assert!((sampled as f64 - uniform).abs() < 0.02, "dielectric {mf:?} {wi}: {sampled} vs {uniform}");
        }
    }
}

// ---------------------------------------------------------------------------------------
// Fresnel and the conductor table.

/// Complex numbers in f64 for the hand-written Fresnel reference.
#[derive(Clone, Copy)]
struct C(f64, f64);

impl C {
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    fn sub(self, o: C) -> C {
        C(self.0 - o.0, self.1 - o.1)
    }
    fn norm2(self) -> f64 {
        self.0 * self.0 + self.1 * self.1
    }
    fn div(self, o: C) -> C {
        let d = o.norm2();
        C((self.0 * o.0 + self.1 * o.1) / d, (self.1 * o.0 - self.0 * o.1) / d)
    }
    /// The principal square root.
    fn sqrt(self) -> C {
        let r = self.norm2().sqrt();
        let re = ((r + self.0) / 2.0).sqrt();
        let im = ((r - self.0) / 2.0).sqrt().copysign(self.1);
        C(re, im)
    }
}

/// Fresnel reflectance of a conductor of index n = η + i k from the textbook amplitudes:
/// r_s = (cos θ − √(n² − sin²θ)) / (cos θ + √(n² − sin²θ)),
/// r_p = (n² cos θ − √(n² − sin²θ)) / (n² cos θ + √(n² − sin²θ)), F = (|r_s|² + |r_p|²) / 2.
fn fresnel_reference(cos_i: f64, eta: f64, k: f64) -> f64 {
    let n = C(eta, k);
    let n2 = n.mul(n);
    let sin2 = 1.0 - cos_i * cos_i;
    let root = n2.sub(C(sin2, 0.0)).sqrt();
    let cos = C(cos_i, 0.0);
    let rs = cos.sub(root).div(cos.add(root));
    let n2cos = n2.mul(cos);
    let rp = n2cos.sub(root).div(n2cos.add(root));
    0.5 * (rs.norm2() + rp.norm2())
}

#[test]
fn fresnel_conductor_matches_hand_computed_values() {
    let (eta, k) = named_conductor("Au").unwrap();
    // Normal incidence: ((η − 1)² + k²) / ((η + 1)² + k²) per channel.
    let f = fresnel_conductor(1.0, eta, k);
    for c in 0..3 {
        let (e, kk) = (eta[c] as f64, k[c] as f64);
        let expect = ((e - 1.0).powi(2) + kk * kk) / ((e + 1.0).powi(2) + kk * kk);
        assert!((f[c] as f64 - expect).abs() < 1e-5, "channel {c}: {} vs {expect}", f[c]);
    }
    // Oblique incidence, with the complex amplitudes written out.
    for cos_i in [0.8f32, 0.5, 0.1, 0.0] {
        let f = fresnel_conductor(cos_i, eta, k);
        for c in 0..3 {
            let expect = fresnel_reference(cos_i as f64, eta[c] as f64, k[c] as f64);
            assert!((f[c] as f64 - expect).abs() < 1e-4, "cos {cos_i} channel {c}: {} vs {expect}", f[c]);
        }
    }
}

#[test]
fn fresnel_conductor_matches_mitsuba() {
    // mi.fresnel_conductor(cos, dr.scalar.Complex2f(eta, k)) in Mitsuba 3.9.1 scalar_rgb,
    // with Au's (eta, k) from the table.
    let (eta, k) = named_conductor("Au").unwrap();
    let cases = [
        (1.0, [0.966_679_3, 0.802_010_24, 0.324_121_45]),
        (0.5, [0.962_210_4, 0.804_370_8, 0.371_175_17]),
        (0.1, [0.973_434_2, 0.919_499_16, 0.718_890_8]),
    ];
    for (cos_i, expect) in cases {
        let f = fresnel_conductor(cos_i, eta, k);
        for c in 0..3 {
            assert!(close(f[c], expect[c], 1e-5), "cos {cos_i}: {f} vs {expect:?}");
        }
    }
}

#[test]
fn named_conductors_are_physically_plausible() {
    let (eta, k) = named_conductor("Au").unwrap();
    // The table as scripts/conductor-rgb.py printed it.
    assert_eq!(eta, Vec3::new(0.143_035_98, 0.375_307_08, 1.442_045_3));
    assert_eq!(k, Vec3::new(3.982_997, 2.385_556_5, 1.603_359_2));
    // Gold is yellow: it reflects more red than green than blue at normal incidence.
    let f = fresnel_conductor(1.0, eta, k);
    assert!(f.x > f.y && f.y > f.z && f.x > 0.9, "{f}");
    // Silver and aluminium are bright and nearly neutral.
    for name in ["Ag", "Al"] {
        let (eta, k) = named_conductor(name).unwrap();
        let f = fresnel_conductor(1.0, eta, k);
        assert!(f.min_element() > 0.85 && f.max_element() - f.min_element() < 0.1, "{name} {f}");
    }
    // Copper is red.
    let (eta, k) = named_conductor("Cu").unwrap();
    let f = fresnel_conductor(1.0, eta, k);
    assert!(f.x > f.y && f.x > f.z, "Cu {f}");
    assert!(named_conductor("none").is_none() && named_conductor("gold").is_none());
    // The 66 names of Mitsuba's documentation less W_palik, which 3.9.1 refuses.
    assert_eq!(CONDUCTORS.len(), 65);
    assert!(CONDUCTORS.iter().all(|n| named_conductor(n).is_some()));
}

// ---------------------------------------------------------------------------------------
// Values against Mitsuba 3.9.1 (read off its Python module, scalar_rgb, with the same
// inputs: `mi.MicrofacetDistribution(type, 0.3, 0.6)`, the `roughconductor` and
// `roughdielectric` plugins with alpha_u = 0.3, alpha_v = 0.6, int_ior 1.5, and
// `mi.BSDFContext(mi.TransportMode.Importance)` for the dielectric).

fn vclose(a: Vec3, b: [f32; 3], tol: f32) -> bool {
    (a - Vec3::from(b)).abs().max_element() <= tol
}

#[test]
fn distribution_matches_mitsuba() {
    let wi = Vec3::new(0.3, -0.2, 0.5).normalize();
    let m = Vec3::new(-0.1, 0.2, 0.9).normalize();
    let wg = Vec3::new(0.99, 0.0, 0.02).normalize();
    // (D, G1, pdf, samples for u = (0.3, 0.7), (0.9, 0.1), (0.5, 0.5), grazing (0.2, 0.8)).
    let cases = [
        (
            ggx(0.3, 0.6),
            [1.227_518_4, 0.978_458_9, 0.984_316_95],
            [
                [0.065_966_7, 0.116_402, 0.991_009],
                [-0.015_612_8, -0.769_107, 0.638_93],
                [0.049_391_9, -0.131_712, 0.990_057],
            ],
            [0.232_852, 0.336_73, 0.912_356],
        ),
        (
            beckmann(0.3, 0.6),
            [1.515_152_7, 1.0, 1.241_711_6],
            [
                [0.002_833_94, -0.354_308, 0.935_124],
                [0.070_305_2, 0.560_363, 0.825_258],
                [0.026_532_9, -0.070_754_3, 0.997_141],
            ],
            [0.330_467, -0.317_383, 0.888_853],
        ),
    ];
    for (mf, [d, g1, pdf], samples, grazing) in cases {
        assert!(close(mf.eval(m), d, 1e-5), "{mf:?} D {}", mf.eval(m));
        assert!(close(mf.smith_g1(wi, m), g1, 1e-5), "{mf:?} G1 {}", mf.smith_g1(wi, m));
        assert!(close(mf.pdf(wi, m), pdf, 1e-5), "{mf:?} pdf {}", mf.pdf(wi, m));
        for (u, expect) in [Vec2::new(0.3, 0.7), Vec2::new(0.9, 0.1), Vec2::new(0.5, 0.5)].into_iter().zip(samples) {
            let s = mf.sample(wi, u);
            assert!(vclose(s, expect, 2e-5), "{mf:?} u {u}: {s} vs {expect:?}");
        }
        let s = mf.sample(wg, Vec2::new(0.2, 0.8));
        assert!(vclose(s, grazing, 2e-5), "{mf:?} grazing: {s} vs {grazing:?}");
    }
}

#[test]
fn rough_conductor_matches_mitsuba() {
    let (eta, k) = named_conductor("Au").unwrap();
    let wi = Vec3::new(0.3, -0.2, 0.5).normalize();
    let wo = Vec3::new(-0.4, 0.1, 0.6).normalize();
    // (eval, pdf, sample's wo and weight for u = (0.3, 0.7)).
    let cases = [
        (
            ggx(0.3, 0.6),
            [0.472_766, 0.392_127, 0.160_418],
            0.495_340_3,
            [-0.381_361, 0.510_256, 0.770_846],
            [0.926_153, 0.768_17, 0.315_551],
        ),
        (
            beckmann(0.3, 0.6),
            [0.514_242, 0.426_528, 0.174_492],
            0.532_225_25,
            [-0.481_706, -0.295_467, 0.825_02],
            [0.966_451, 0.801_673, 0.325_9],
        ),
    ];
    for (mf, e, p, swo, sw) in cases {
        let ev = rough_conductor_eval(&mf, eta, k, wi, wo);
        assert!(vclose(ev, e, 2e-5), "{mf:?} eval {ev}");
        assert!(close(rough_conductor_pdf(&mf, wi, wo), p, 1e-5), "{mf:?} pdf");
        let (wo_s, w) = rough_conductor_sample(&mf, eta, k, wi, Vec2::new(0.3, 0.7)).unwrap();
        assert!(vclose(wo_s, swo, 2e-5) && vclose(w, sw, 2e-5), "{mf:?} sample {wo_s} {w}");
    }
}

#[test]
fn rough_dielectric_matches_mitsuba() {
    let n = |x: f32, y: f32, z: f32| Vec3::new(x, y, z).normalize();
    let wi_out = n(0.3, -0.2, 0.5);
    let wi_in = n(0.3, -0.2, -0.5);
    let wi_tir = n(0.6, 0.1, -0.3);
    // (distribution, wi, wo, Mitsuba's eval and pdf).
    let evals = [
        (ggx(0.3, 0.6), wi_out, n(-0.4, 0.1, 0.6), 0.020_982_88, 0.021_241_967),
        (ggx(0.3, 0.6), wi_out, n(-0.3, 0.2, -0.9), 9.275_281, 9.339_252),
        (ggx(0.3, 0.6), wi_in, n(-0.4, 0.1, 0.6), 0.674_934_4, 0.683_268_1),
        (ggx(0.3, 0.6), wi_in, n(0.4, -0.1, -0.6), 0.001_432_237_8, 0.001_449_922_4),
        (ggx(0.3, 0.6), wi_tir, n(-0.6, 0.2, 0.4), 0.047_418_344, 0.050_663_702),
        (beckmann(0.3, 0.6), wi_out, n(-0.4, 0.1, 0.6), 0.022_823_723, 0.022_823_723),
        (beckmann(0.3, 0.6), wi_out, n(-0.3, 0.2, -0.9), 9.720_13, 9.720_13),
        (beckmann(0.3, 0.6), wi_in, n(-0.4, 0.1, 0.6), 0.227_109_64, 0.227_109_63),
        (beckmann(0.3, 0.6), wi_in, n(0.4, -0.1, -0.6), 0.000_443_015_9, 0.000_443_015_86),
        (beckmann(0.3, 0.6), wi_tir, n(-0.6, 0.2, 0.4), 0.0, 0.0),
    ];
    for (mf, wi, wo, e, p) in evals {
        let (ev, pd) = (rough_dielectric_eval(&mf, 1.5, wi, wo), rough_dielectric_pdf(&mf, 1.5, wi, wo));
        assert!(close(ev, e, 1e-4) && close(pd, p, 1e-4), "{mf:?} {wi} {wo}: {ev} {pd}");
    }
    // Mitsuba's sample(sample1, (0.3, 0.7)): its weight is G1(wo, m) for either branch (the
    // branch probability cancels), ours is that times F or 1 − F.
    let u = Vec2::new(0.3, 0.7);
    // (distribution, wi, Mitsuba's reflection and refraction as (wo, weight)).
    type Branch = Option<([f32; 3], f32)>;
    let samples: [(Microfacet, Vec3, Branch, Branch); 6] = [
        (
            ggx(0.3, 0.6),
            wi_out,
            Some(([-0.381_361, 0.510_256, 0.770_846], 0.958_694)),
            Some(([-0.349_754, 0.171_632, -0.920_986], 0.993_709)),
        ),
        (
            ggx(0.3, 0.6),
            wi_in,
            Some(([-0.381_361, 0.510_256, -0.770_846], 0.958_694)),
            Some(([-0.679_266, 0.576_18, 0.454_548], 0.856_916)),
        ),
        (ggx(0.3, 0.6), wi_tir, Some(([-0.854_785, 0.055_103_2, -0.516_049], 0.944_066)), None),
        (
            beckmann(0.3, 0.6),
            wi_out,
            Some(([-0.481_706, -0.295_467, 0.825_02], 1.0)),
            Some(([-0.325_472, 0.344_979, -0.880_373], 1.0)),
        ),
        (
            beckmann(0.3, 0.6),
            wi_in,
            Some(([-0.481_706, -0.295_467, -0.825_02], 1.0)),
            Some(([-0.728_224, 0.265_134, 0.631_976], 1.0)),
        ),
        (beckmann(0.3, 0.6), wi_tir, Some(([-0.628_257, -0.252_802, -0.735_788], 1.0)), None),
    ];
    for (mf, wi, r, t) in samples {
        let split = rough_dielectric_split(&mf, 1.5, wi, u);
        let f = dielectric_micro(&mf, 1.5, wi, u).unwrap().f;
        for (got, expect, prob) in [(split.reflect, r, f), (split.refract, t, 1.0 - f)] {
            match (got, expect) {
                (Some((wo, w)), Some((ewo, ew))) => {
                    assert!(vclose(wo, ewo, 2e-5), "{mf:?} {wi}: {wo} vs {ewo:?}");
                    assert!(close(w / prob, ew, 1e-4), "{mf:?} {wi}: {w} / {prob} vs {ew}");
                }
                (None, None) => {}
                _ => panic!("{mf:?} {wi}: {got:?} vs {expect:?}"),
            }
        }
    }
}

#[test]
fn tangents_match_mitsuba() {
    // mi.coordinate_system(n) in Mitsuba 3.9.1.
    let cases = [
        (Vec3::new(0.3, -0.2, 0.5), [0.869_228, 0.087_181_3, -0.486_664], [0.087_181_3, 0.941_879, 0.324_443]),
        (Vec3::new(0.3, 0.2, -0.5), [0.869_228, -0.087_181_3, 0.486_664], [0.087_181_3, -0.941_879, -0.324_443]),
        (Vec3::new(0.0, 0.0, -1.0), [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]),
    ];
    for (n, s, t) in cases {
        let n = n.normalize();
        let (a, b) = tangents(n);
        assert!(vclose(a, s, 2e-6) && vclose(b, t, 2e-6), "{n}: {a} {b}");
        assert!(a.cross(b).abs_diff_eq(n, 1e-6) && a.dot(n).abs() < 1e-6);
    }
}

#[test]
fn erf_and_erfinv_match_drjit() {
    // dr.erf / dr.erfinv in Dr.Jit 1.5 (double precision values).
    assert!((erf(0.5) - 0.520_499_9).abs() < 1e-6);
    assert!((erf(1.7) - 0.983_790_5).abs() < 1e-6);
    assert!((erf(-1.7) + 0.983_790_5).abs() < 1e-6);
    assert!((erfinv(0.3) - 0.272_462_74).abs() < 1e-5);
    assert!((erfinv(-0.999) + 2.326_753_8).abs() < 1e-4);
    for i in -99..100 {
        let x = i as f32 / 100.0;
        assert!((erf(erfinv(x)) - x).abs() < 2e-5, "{x}");
    }
}
