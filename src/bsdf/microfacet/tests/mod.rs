//! Tests of the microfacet module: χ² goodness of fit of every sampler against its
//! density (Mitsuba's `chi2.py` procedure), weights against eval / pdf, reciprocity,
//! energy bounds, and values read off Mitsuba 3.9.1's Python module.

use super::*;

/// PCG32 (O'Neill's `pcg32_random_r`, as Mitsuba's `PCG32`), seeded per test so every run
/// draws the same numbers.
pub(crate) struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    pub(crate) fn new(seed: u64, seq: u64) -> Self {
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
    pub(crate) fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    pub(crate) fn next_vec2(&mut self) -> Vec2 {
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

pub(crate) mod chi2;

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
