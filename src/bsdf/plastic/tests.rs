//! Plastic against Mitsuba 3.9.1's `plastic` and `roughplastic` (values read off its
//! Python module, `scalar_rgb`), its sampler against its density (χ²), and its energy.

use super::*;
use crate::bsdf::microfacet::tests::{chi2::chi2, Pcg32};
use crate::bsdf::microfacet::Distribution;

/// A plastic's parameters as the scene loader derives them.
struct Params {
    diffuse: Vec3,
    specular: Vec3,
    eta: f32,
    roughness: Option<Microfacet>,
    nonlinear: bool,
    table: Transmittance,
    internal: f32,
}

impl Params {
    fn new(diffuse: [f32; 3], specular: [f32; 3], eta: f32, roughness: Option<Microfacet>, nonlinear: bool) -> Params {
        let (table, internal) = match &roughness {
            None => ([0.0; TABLE_RES], smooth_internal(eta)),
            Some(mf) => (rough_transmittance(mf, eta), rough_internal(mf, eta)),
        };
        Params { diffuse: diffuse.into(), specular: specular.into(), eta, roughness, nonlinear, table, internal }
    }

    fn bsdf(&self) -> Plastic<'_> {
        Plastic {
            diffuse: self.diffuse,
            specular: self.specular,
            eta: self.eta,
            roughness: self.roughness.as_ref(),
            table: &self.table,
            internal: self.internal,
            nonlinear: self.nonlinear,
            specular_weight: specular_weight(self.specular.element_sum() / 3.0, self.diffuse.element_sum() / 3.0),
        }
    }
}

fn dir(theta: f32, phi: f32) -> Vec3 {
    let (t, p) = (theta.to_radians(), phi.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

fn mf(distribution: Distribution, alpha: f32) -> Option<Microfacet> {
    Some(Microfacet { distribution, alpha_u: alpha, alpha_v: alpha })
}

/// Mitsuba's four test plastics: smooth, smooth nonlinear with a tinted coating, GGX 0.3,
/// Beckmann 0.1 nonlinear (its defaults: polypropylene in air).
fn cases() -> [Params; 4] {
    let default_eta = 1.49 / 1.00028;
    [
        Params::new([0.2, 0.5, 0.8], [1.0; 3], 1.5, None, false),
        Params::new([0.9, 0.5, 0.1], [0.5, 0.6, 0.7], default_eta, None, true),
        Params::new([0.2, 0.5, 0.8], [1.0; 3], 1.5, mf(Distribution::Ggx, 0.3), false),
        Params::new([0.9, 0.5, 0.1], [1.0; 3], default_eta, mf(Distribution::Beckmann, 0.1), true),
    ]
}

fn close(a: Vec3, b: [f32; 3], tol: f32, what: &str) {
    let b = Vec3::from(b);
    assert!((a - b).abs().max_element() <= tol * b.abs().max_element().max(1e-3), "{what}: {a} vs Mitsuba {b}");
}

#[test]
fn eval_and_pdf_match_mitsuba() {
    // (θi, φi, θo, φo) → f·cos and pdf, per case, from Mitsuba 3.9.1.
    let angles = [(30.0, 10.0, 50.0, 200.0), (70.0, 0.0, 20.0, 90.0), (5.0, 40.0, 80.0, 300.0)];
    let expected: [[([f32; 3], f32); 3]; 4] = [
        [
            ([0.0407422, 0.1018555, 0.1629689], 0.1882915),
            ([0.0524636, 0.1311589, 0.2098543], 0.2117364),
            ([0.0071629, 0.0179073, 0.0286518], 0.051022),
        ],
        [
            ([0.1604557, 0.0592672, 0.0088781], 0.1948207),
            ([0.2067701, 0.0763743, 0.0114407], 0.2404114),
            ([0.0282459, 0.0104331, 0.0015629], 0.0527284),
        ],
        [
            ([0.0514484, 0.0918928, 0.1323373], 0.2407935),
            ([0.0402254, 0.0942989, 0.1483725], 0.2417171),
            ([0.0071026, 0.016194, 0.0252854], 0.0533315),
        ],
        [
            ([0.167183, 0.070206, 0.0205304], 0.2092333),
            ([0.2005494, 0.07548, 0.0114144], 0.212408),
            ([0.028712, 0.0108062, 0.0016342], 0.0511567),
        ],
    ];
    for (c, (p, exp)) in cases().iter().zip(expected).enumerate() {
        for (&(ti, pi, to, po), (f, pdf)) in angles.iter().zip(exp) {
            let (got_f, got_pdf) = p.bsdf().eval_pdf(dir(ti, pi), dir(to, po));
            let what = format!("case {c} at {:?}", (ti, pi, to, po));
            close(got_f, f, 2e-3, &what);
            assert!((got_pdf - pdf).abs() <= 2e-3 * pdf, "{what}: pdf {got_pdf} vs Mitsuba {pdf}");
        }
    }
}

#[test]
fn samples_match_mitsuba() {
    // (θi, φi, u1, u2) → wo, pdf (the lobe's probability for the smooth mirror, which
    // wavetrace reports as 0, a delta) and weight, per case, from Mitsuba 3.9.1.
    type Expected = ([f32; 3], f32, [f32; 3]);
    let draws = [(30.0, 10.0, 0.01, (0.3, 0.7)), (30.0, 10.0, 0.9, (0.3, 0.7)), (70.0, 0.0, 0.2, (0.8, 0.1))];
    let expected: [[Expected; 3]; 4] = [
        [
            ([-0.4924039, -0.0868241, 0.8660254], 0.0797345, [0.5207613; 3]),
            ([-0.2828427, 0.2828427, 0.9165152], 0.2684744, [0.2203115, 0.5507787, 0.881246]),
            ([-0.9396926, -0.0, 0.3420202], 0.2921201, [0.5855212; 3]),
        ],
        [
            ([-0.4924039, -0.0868241, 0.8660254], 0.0478233, [0.4200144, 0.5040173, 0.5880201]),
            ([-0.2828427, 0.2828427, 0.9165152], 0.277784, [0.8383901, 0.3096746, 0.0463884]),
            ([0.4444563, -0.6651756, 0.6], 0.1535043, [0.8385801, 0.3097448, 0.0463989]),
        ],
        [
            ([-0.5847407, 0.0487757, 0.8097523], 0.3185474, [0.2198044, 0.3836782, 0.5475519]),
            ([-0.2828427, 0.2828427, 0.9165152], 0.3055912, [0.186263, 0.3813957, 0.5765284]),
            ([0.1509054, -0.5675972, 0.8093582], 0.20023, [0.1649161, 0.3950314, 0.6251466]),
        ],
        [
            ([-0.411544, -0.1390889, 0.900714], 0.798188, [0.6200822, 0.4466519, 0.3578138]),
            ([-0.2828427, 0.2828427, 0.9165152], 0.2717791, [0.8363452, 0.3179145, 0.0523533]),
            ([-0.966265, 0.0538175, 0.2518643], 2.53546, [0.7154939, 0.7052189, 0.6999556]),
        ],
    ];
    for (c, (p, exp)) in cases().iter().zip(expected).enumerate() {
        for (&(ti, pi, u1, u2), (wo, pdf, weight)) in draws.iter().zip(exp) {
            let what = format!("case {c} draw {:?}", (ti, pi, u1, u2));
            let s = p.bsdf().sample(dir(ti, pi), u1, Vec2::new(u2.0, u2.1)).unwrap();
            close(s.wo, wo, 1e-4, &what);
            close(s.weight, weight, 2e-3, &what);
            let mirror = p.roughness.is_none() && s.wo.z == dir(ti, pi).z;
            let expected_pdf = if mirror { 0.0 } else { pdf };
            assert!((s.pdf - expected_pdf).abs() <= 2e-3 * pdf, "{what}: pdf {} vs {expected_pdf}", s.pdf);
        }
    }
}

#[test]
fn sampler_matches_density() {
    // The smooth coating's mirror is a delta: its samples are left out (weight 0, as
    // Mitsuba's χ² counts them), and the density covers the base alone.
    let mut results = Vec::new();
    for (c, p) in cases().iter().enumerate() {
        for (k, wi) in [dir(0.0, 0.0), dir(45.0, 30.0), dir(85.0, 120.0)].into_iter().enumerate() {
            let bsdf = p.bsdf();
            results.push(chi2(
                &format!("plastic case {c} wi {wi}"),
                500 + (3 * c + k) as u64,
                8,
                |rng: &mut Pcg32| {
                    let u1 = rng.next_f32();
                    bsdf.sample(wi, u1, rng.next_vec2()).filter(|s| s.pdf > 0.0).map(|s| s.wo)
                },
                |wo| bsdf.eval_pdf(wi, wo).1,
            ));
        }
    }
    let errors: Vec<String> = results.into_iter().filter_map(Result::err).collect();
    assert!(errors.is_empty(), "{}", errors.join("\n"));
}

/// The albedo at incidence `theta`: the mean sample weight (largest channel) over `n`
/// draws, and its standard error.
fn albedo(bsdf: &Plastic, theta: f32, rng: &mut Pcg32, n: usize) -> (f64, f64) {
    let wi = dir(theta, 15.0);
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let u1 = rng.next_f32();
        let w = bsdf.sample(wi, u1, rng.next_vec2()).map_or(0.0, |s| s.weight.max_element() as f64);
        sum += w;
        sum2 += w * w;
    }
    let mean = sum / n as f64;
    (mean, ((sum2 / n as f64 - mean * mean) / n as f64).sqrt())
}

#[test]
fn white_furnace_never_gains_energy() {
    // A white base under a white coating reflects at most what arrives, at every angle.
    // The smooth coating's exact albedo there is 1 (its transmittances in and out cancel
    // 1 / (1 − r) and 1/η²), but Mitsuba's fit of r is accurate to 0.1 % (Egan and
    // Hilgeman), which 1 / (1 − r) turns into up to 0.2 % above 1: Mitsuba's own albedo
    // is 1.0011 at normal incidence. Rough coatings lose what single-scattering
    // microfacets lose.
    let white = [1.0; 3];
    let plastics = [
        Params::new(white, white, 1.5, None, false),
        Params::new(white, white, 1.5, None, true),
        Params::new(white, white, 1.5, mf(Distribution::Ggx, 0.05), true),
        Params::new(white, white, 1.5, mf(Distribution::Ggx, 0.5), true),
        Params::new(white, white, 1.9, mf(Distribution::Beckmann, 0.3), true),
        Params::new(white, white, 1.33, mf(Distribution::Beckmann, 1.0), false),
    ];
    let mut rng = Pcg32::new(7, 3);
    for (c, p) in plastics.iter().enumerate() {
        let fit = if p.roughness.is_none() { 0.002 } else { 0.0 };
        for theta in [0.0, 30.0, 60.0, 80.0, 89.0] {
            let (mean, se) = albedo(&p.bsdf(), theta, &mut rng, 200_000);
            assert!(mean <= 1.0 + fit + 4.0 * se, "plastic {c} at {theta}°: albedo {mean} ± {se} > 1");
            assert!(mean > 0.35, "plastic {c} at {theta}°: albedo {mean}: energy lost");
        }
    }
}

#[test]
fn albedo_matches_mitsuba() {
    // Mitsuba 3.9.1 (llvm_ad_rgb, 2^20 samples) at 0°, 60° and 89°: white smooth plastic
    // (η 1.5), GGX 0.5 nonlinear (η 1.5), Beckmann 1.0 (η 1.33).
    let white = [1.0; 3];
    let cases = [
        (Params::new(white, white, 1.5, None, false), [1.00109, 1.00104, 1.00008]),
        (Params::new(white, white, 1.5, mf(Distribution::Ggx, 0.5), true), [0.540224, 0.500319, 0.388821]),
        (Params::new(white, white, 1.33, mf(Distribution::Beckmann, 1.0), false), [0.591095, 0.550468, 0.397103]),
    ];
    let mut rng = Pcg32::new(11, 5);
    for (c, (p, expected)) in cases.iter().enumerate() {
        for (theta, want) in [0.0, 60.0, 89.0].into_iter().zip(expected) {
            let (mean, se) = albedo(&p.bsdf(), theta, &mut rng, 400_000);
            // Mitsuba's own estimate has a standard error near ours.
            assert!((mean - want).abs() <= 5.0 * se + 1e-4, "case {c} at {theta}°: {mean} ± {se} vs Mitsuba {want}");
        }
    }
}

#[test]
fn gauss_legendre_integrates_polynomials_exactly() {
    // An n-point rule is exact up to degree 2n − 1: ∫₀¹ x^k dx = 1 / (k + 1), and the
    // same in y (up to the points' and the integrand's single precision).
    let q = Quadrature::new(16);
    for k in 0..32 {
        for axis in 0..2 {
            let got = q.integrate(|u| (0..k).fold(wide::f32x16::splat(1.0), |p, _| p * u[axis]));
            assert!((got - 1.0 / (k + 1) as f64).abs() < 1e-6, "x^{k} along axis {axis}: {got}");
        }
    }
}

#[test]
fn internal_reflectance_on_fewer_points_stays_mitsubas() {
    // Mitsuba integrates on 128² points; wavetrace on 64².
    let cases = [
        (Distribution::Beckmann, 0.08, 1.49),
        (Distribution::Ggx, 0.5, 1.5),
        (Distribution::Beckmann, 0.01, 1.5),
        (Distribution::Ggx, 1.0, 1.33),
        (Distribution::Beckmann, 0.3, 2.5),
    ];
    for (d, a, eta) in cases {
        let mf = Microfacet { distribution: d, alpha_u: a, alpha_v: a };
        let (ours, mitsuba) = (rough_internal(&mf, eta), internal_reflectance(&mf, eta, 128));
        assert!((ours - mitsuba).abs() < 1e-4, "{d:?} {a} {eta}: {ours} vs {mitsuba}");
    }
}

/// 16 random directions of the sphere (some below the surface) as lanes and as vectors.
fn random_lanes(rng: &mut Pcg32) -> (V3<f32x16>, [Vec3; LANES]) {
    let v: [Vec3; LANES] = std::array::from_fn(|_| {
        let u = rng.next_vec2();
        let z = 1.0 - 2.0 * u.y;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * std::f32::consts::PI * u.x;
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    });
    (V3::from_fn(|k| v[k]), v)
}

fn lane(v: &V3<f32x16>, k: usize) -> Vec3 {
    Vec3::new(v.x.to_array()[k], v.y.to_array()[k], v.z.to_array()[k])
}

#[test]
fn lanes_agree_with_the_scalar_code() {
    let mut rng = Pcg32::new(9, 4);
    for p in cases() {
        let bsdf = p.bsdf();
        for _ in 0..64 {
            // A base reflectance per lane, as a texture gives.
            let diffuse: [Vec3; LANES] = std::array::from_fn(|_| Vec3::new(rng.next_f32(), rng.next_f32(), 0.5));
            let (wi, wis) = random_lanes(&mut rng);
            let (wo, wos) = random_lanes(&mut rng);
            let lanes_diffuse = V3::from_fn(|k| diffuse[k]);
            let (f, pdf) = bsdf.eval_pdf_lanes(lanes_diffuse, wi, wo);
            let u1: [f32; LANES] = std::array::from_fn(|_| rng.next_f32());
            let u2: [Vec2; LANES] = std::array::from_fn(|_| rng.next_vec2());
            let s = bsdf.sample_lanes(
                lanes_diffuse,
                wi,
                f32x16::from(u1),
                [f32x16::from(u2.map(|u| u.x)), f32x16::from(u2.map(|u| u.y))],
            );
            for k in 0..LANES {
                let one = Plastic { diffuse: diffuse[k], ..bsdf };
                let (fs, pdfs) = one.eval_pdf(wis[k], wos[k]);
                let what = format!("{:?} wi {} wo {}", p.roughness, wis[k], wos[k]);
                assert!((fs - lane(&f, k)).abs().max_element() <= 2e-5 * fs.max_element().max(1.0), "{what}: f");
                assert!((pdfs - pdf.to_array()[k]).abs() <= 2e-5 * pdfs.max(1.0), "{what}: pdf {pdfs}");
                let scalar = one.sample(wis[k], u1[k], u2[k]);
                assert_eq!(scalar.is_some(), s.valid & (1 << k) != 0, "{what}: sampled");
                if let Some(t) = scalar {
                    let (wo, weight, pdf) = (lane(&s.wo, k), lane(&s.weight, k), s.pdf.to_array()[k]);
                    assert!((t.wo - wo).abs().max_element() < 1e-4, "{what}: wo {} vs {wo}", t.wo);
                    let tol = 1e-3 * t.weight.max_element().max(1.0);
                    assert!((t.weight - weight).abs().max_element() <= tol, "{what}: weight {} vs {weight}", t.weight);
                    assert!((t.pdf - pdf).abs() <= 1e-3 * t.pdf.max(1.0), "{what}: pdf {} vs {pdf}", t.pdf);
                }
            }
        }
    }
}
