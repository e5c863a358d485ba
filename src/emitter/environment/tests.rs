//! The environment against Mitsuba 3.9.1's `envmap` lookups, its density against its
//! samples (χ²) and against 1 (its integral over the sphere).

use super::*;
use crate::bsdf::microfacet::tests::{chi2::chi2, Pcg32};

/// An 8 × 4 map whose texels differ in every channel, scaled by 2 and turned 30° about
/// +y: Mitsuba's test map.
fn test_map() -> Environment {
    let (w, h) = (8, 4);
    let texels = (0..h)
        .flat_map(|j| {
            (0..w).map(move |i| {
                Vec3::new(0.1 + i as f32 * 0.3, 0.2 + j as f32 * 0.5, 1.0 + ((i * 7 + j * 3) % 5) as f32 * 0.2)
            })
        })
        .collect();
    let to_world = Mat3::from_rotation_y(30f32.to_radians());
    Environment {
        radiance: Vec3::splat(2.0),
        map: LatLong::new(w, h, texels),
        to_local: to_world.transpose(),
        to_world,
    }
}

/// A map with a bright small sun and a dark half: a hard case for the sampler.
fn sun_map() -> Environment {
    let (w, h) = (64, 32);
    let texels = (0..h)
        .flat_map(|j| {
            (0..w).map(move |i| {
                let sun = (i as i32 - 40).abs() <= 1 && (j as i32 - 9).abs() <= 1;
                let sky = if j < h / 2 { Vec3::new(0.3, 0.5, 0.9) } else { Vec3::ZERO };
                if sun {
                    Vec3::new(500.0, 450.0, 400.0)
                } else {
                    sky
                }
            })
        })
        .collect();
    let to_world = Mat3::from_rotation_x(0.4) * Mat3::from_rotation_y(1.1);
    Environment { radiance: Vec3::ONE, map: LatLong::new(w, h, texels), to_local: to_world.transpose(), to_world }
}

#[test]
fn lookups_match_mitsuba() {
    // Mitsuba 3.9.1 scalar_rgb: envmap of the test map, scale 2, to_world rotate y 30°,
    // eval for a ray arriving along d (si.wi = −d).
    let cases = [
        ([1.0, 0.0, 0.0], [1.5, 1.9, 2.533334]),
        ([0.3, 0.5, -0.8], [0.574081, 1.394393, 2.452102]),
        ([-0.6, -0.2, 0.7], [3.241351, 2.103993, 2.65114]),
        ([0.01, 0.2, -0.98], [0.307795, 1.707766, 2.848783]),
    ];
    let env = test_map();
    for (d, want) in cases {
        let got = env.eval(Vec3::from(d).normalize());
        let want = Vec3::from(want);
        assert!((got - want).abs().max_element() < 2e-4 * want.max_element(), "{d:?}: {got} vs Mitsuba {want}");
    }
}

#[test]
fn density_integrates_to_one() {
    for (name, env) in [("test", test_map()), ("sun", sun_map()), ("constant", Environment::constant(Vec3::ONE))] {
        // Midpoint rule over (φ, cos θ), 2000 × 1000 cells of equal solid angle.
        let (n_phi, n_cos) = (2000, 1000);
        let cell = 4.0 * std::f64::consts::PI / (n_phi * n_cos) as f64;
        let mut sum = 0.0f64;
        for a in 0..n_phi {
            let phi = (a as f64 + 0.5) / n_phi as f64 * 2.0 * std::f64::consts::PI;
            for b in 0..n_cos {
                let z = -1.0 + (b as f64 + 0.5) / n_cos as f64 * 2.0;
                let r = (1.0 - z * z).sqrt();
                let d = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                sum += env.pdf(d) as f64 * cell;
            }
        }
        assert!((sum - 1.0).abs() < 2e-3, "{name}: the density integrates to {sum}");
    }
}

#[test]
fn samples_carry_their_radiance_and_density() {
    let mut rng = Pcg32::new(3, 9);
    for env in [test_map(), sun_map()] {
        for _ in 0..10_000 {
            let s = env.sample(rng.next_vec2()).unwrap();
            assert!((s.wi.length() - 1.0).abs() < 1e-5);
            let (l, p) = (env.eval(s.wi), env.pdf(s.wi));
            assert_eq!(env.eval_pdf(s.wi), (l, p), "one lookup gives both");
            // The sample's radiance is the map at its own (u, v), the lookup's at wi's:
            // the round trip moves (u, v) by ~1e-6, which the sun's steep texel-to-texel
            // gradients turn into up to ~7e-4 of the value.
            assert!((s.radiance - l).abs().max_element() <= 2e-3 * l.max_element(), "{s:?}: {l}");
            assert!((s.pdf - p).abs() <= 2e-3 * p, "{s:?}: pdf {} vs {p}", s.pdf);
        }
    }
}

/// `env` with the two texel rows at each pole black. The sampler's density has the
/// sphere's 1/sin θ at the poles, which the χ² test's trapezoid rule cannot integrate
/// (the other tests cover the poles).
fn polar_black(env: Environment) -> Environment {
    let map = env.map.unwrap();
    let (w, h) = (map.width, map.height);
    let texels =
        map.texels.iter().enumerate().map(|(k, &t)| if k / w < 2 || k / w >= h - 2 { Vec3::ZERO } else { t }).collect();
    Environment { map: LatLong::new(w, h, texels), ..env }
}

/// The test map stretched to 24 × 12 texels (each texel repeated three times each way).
fn bigger_test_map() -> Environment {
    let env = test_map();
    let map = env.map.as_ref().unwrap();
    let texels =
        (0..12).flat_map(|j| (0..24).map(move |i| (i / 3, j / 3))).map(|(i, j)| map.texels[j * 8 + i]).collect();
    Environment { map: LatLong::new(24, 12, texels), ..env }
}

#[test]
fn sampler_matches_density() {
    let mut errors = Vec::new();
    let envs = [
        ("test", polar_black(bigger_test_map())),
        ("sun", polar_black(sun_map())),
        ("constant", Environment::constant(Vec3::ONE)),
    ];
    for (k, (name, env)) in envs.into_iter().enumerate() {
        // The density jumps at cell edges: a finer trapezoid rule, as for visible normals.
        let r = chi2(
            &format!("environment {name}"),
            900 + k as u64,
            24,
            |rng| env.sample(rng.next_vec2()).map(|s| s.wi),
            |d| env.pdf(d),
        );
        errors.extend(r.err());
    }
    assert!(errors.is_empty(), "{}", errors.join("\n"));
}

#[test]
fn black_environment_is_not_sampled() {
    let black = LatLong::new(4, 2, vec![Vec3::ZERO; 8]);
    let env = Environment { radiance: Vec3::ONE, map: black, ..Environment::constant(Vec3::ONE) };
    assert!(env.is_black());
    assert!(env.sample(Vec2::new(0.3, 0.6)).is_none());
    assert_eq!(env.pdf(Vec3::Y), 0.0);
    assert!(Environment::constant(Vec3::ZERO).is_black());
    assert!(LatLong::new(0, 4, vec![]).is_none());
    assert!(LatLong::new(4, 4, vec![Vec3::ONE; 15]).is_none());
}

#[test]
fn guided_search_finds_the_bisections_index() {
    let mut rng = Pcg32::new(5, 17);
    for n in [1usize, 2, 3, 7, 64, 100] {
        for plateaus in [false, true] {
            // A cdf with runs of equal values (cells of weight 0), ending at 1.
            let mut acc = 0.0f32;
            let weights: Vec<f32> =
                (0..n).map(|_| if plateaus && rng.next_f32() < 0.5 { 0.0 } else { rng.next_f32() }).collect();
            let total: f32 = weights.iter().sum::<f32>().max(1e-30);
            let mut cdf: Vec<f32> = weights
                .iter()
                .map(|w| {
                    acc += w;
                    acc / total
                })
                .collect();
            cdf[n - 1] = 1.0;
            let g = super::guide(&cdf);
            // Random values, every entry and its neighbours, and the slice bounds k / n.
            let mut xs: Vec<f32> = (0..200).map(|_| rng.next_f32()).collect();
            for &c in &cdf {
                xs.extend([c, f32::from_bits(c.to_bits().saturating_sub(1)), f32::from_bits(c.to_bits() + 1)]);
            }
            xs.extend((0..=n).map(|k| k as f32 / n as f32));
            xs.extend([0.0, -0.0, 1.0, 0.999_999_94, -1.0, 2.0]);
            for x in xs {
                let expected = cdf.partition_point(|&c| c <= x);
                assert_eq!(super::find(&cdf, &g, x), expected, "n {n}, x {x}, cdf {cdf:?}");
            }
        }
    }
}
