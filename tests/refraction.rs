//! Dielectrics through the real stages: Snell's law and Fresnel against f64 references,
//! ior = 1 bends and reflects nothing (also 1 + 1e-6), diamond, an air bubble (ior < 1),
//! total internal reflection at and beyond the critical angle, a slab shifts a ray
//! without turning it, nested media, the fixed reflect ratio C, and the paper's Figure 5
//! (inside/outside normal and eta). Every test states its tolerance next to the
//! assertion.

mod support;

use glam::{DVec3, Vec3};
use support::toml::{camera, material, quad, render_block, sphere};
use support::{one_ray, render_text, scene, step, FloorScene, Lcg, QuadLight, Sphere};
use wavetrace::queue::{RayQueue, MISS};
use wavetrace::stages::scatter::{fresnel, interface, reflect, refract};
use wavetrace::{RenderOutput, Scene};

/// Renders on two threads; every pixel finite and non-negative, and no non-finite
/// contribution dropped by the film (exact).
fn render_finite(text: &str) -> RenderOutput {
    let out = render_text(text, &[], 2);
    for (i, p) in out.image.pixels.iter().enumerate() {
        assert!(p.is_finite() && p.min_element() >= 0.0, "pixel {i} is {p}");
    }
    assert_eq!(out.stats.nonfinite, 0, "non-finite contributions were dropped");
    out
}

/// Unpolarised Fresnel reflectance in f64, the reference for the f32 stages.
fn fresnel64(cos_i: f64, eta: f64) -> f64 {
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// Direction at angle `deg` from -y towards +x: `(sin, -cos, 0)`, computed in f64.
fn down_at(deg: f64) -> Vec3 {
    let th = deg.to_radians();
    DVec3::new(th.sin(), -th.cos(), 0.0).as_vec3()
}

/// Sine of the angle between unit `d` and the line of unit `n`.
fn sin_to(d: Vec3, n: Vec3) -> f64 {
    d.as_dvec3().cross(n.as_dvec3()).length()
}

/// A glass slab between y = -1 and y = 0 (two quads, normals outward: +y on top, -y
/// below), or a glass sphere of radius 1 at the origin.
fn slab(ior: &str, ratio: &str) -> Scene {
    slab_of_width(ior, ratio, 1000.0)
}

/// [`slab`] spanning `[-half, half]` in x and z. A narrower slab places its surface
/// points, and so the ray offsets, more precisely.
fn slab_of_width(ior: &str, ratio: &str, half: f64) -> Scene {
    let w = 2.0 * half;
    let text = [
        camera([0.0, 5.0, 5.0], [0.0; 3], &[]),
        glass(ior, ratio),
        quad([-half, 0.0, -half], [0.0, 0.0, w], [w, 0.0, 0.0], "glass"),
        quad([-half, -1.0, -half], [w, 0.0, 0.0], [0.0, 0.0, w], "glass"),
    ]
    .concat();
    scene(&text, &[])
}

/// A glass sphere of radius 1 at the origin.
fn ball(ior: &str, ratio: &str) -> Scene {
    scene(&[camera([0.0, 5.0, 5.0], [0.0; 3], &[]), glass(ior, ratio), sphere([0.0; 3], 1.0, "glass")].concat(), &[])
}

/// `[materials.glass]`: a dielectric of index `ior` and reflect ratio `ratio`, both TOML
/// literals (`"fresnel"` or C).
fn glass(ior: &str, ratio: &str) -> String {
    material("glass", "dielectric", &[&format!("ior={ior}"), &format!("reflect_ratio={ratio}")])
}

/// A spawned ray's direction and weight.
type DirWeight = (Vec3, Vec3);

/// Splits the scatter output of a single ray with direction `d` at a surface of normal
/// `ng` into (reflected, refracted) rays (direction, weight).
fn split(next: &RayQueue, d: Vec3, ng: Vec3) -> (Vec<DirWeight>, Vec<DirWeight>) {
    let (mut refl, mut refr) = (Vec::new(), Vec::new());
    for i in 0..next.len() {
        let e = (next.dir(i), next.weight(i));
        if next.dir(i).dot(ng) * d.dot(ng) < 0.0 {
            refl.push(e);
        } else {
            refr.push(e);
        }
    }
    (refl, refr)
}

/// A ray into a slab of ior 1 (Fresnel) at `deg` from the normal: checks that it passes
/// unbent and unreflected.
fn ior_one_passes(scene: &Scene, deg: f64) {
    let d = down_at(deg);
    let (next, hits) = step(scene, &one_ray(Vec3::new(0.0, 1.0, 0.0), d));
    assert_ne!(hits.prim[0], MISS);
    let (refl, refr) = split(&next, d, Vec3::Y);
    // Tolerance: reflection weight at most 1e-6 (matched media reflect nothing); the
    // refracted ray keeps the direction within 1e-6 and weight 1 within 1e-6.
    for (_, w) in &refl {
        assert!(w.max_element() <= 1e-6, "{deg}°: ior 1 reflects with weight {w}");
    }
    assert_eq!(refr.len(), 1, "{deg}°: one refracted ray");
    let (t, w) = refr[0];
    assert!(t.abs_diff_eq(d, 1e-6), "{deg}°: bent from {d} to {t}");
    assert!((w - Vec3::ONE).abs().max_element() <= 1e-6, "{deg}°: refracted weight {w}");
}

#[test]
fn ior_one_neither_bends_nor_reflects() {
    let scene = slab("1.0", "\"fresnel\"");
    for deg in [0.0, 10.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0] {
        ior_one_passes(&scene, deg);
    }
    // Through a sphere of ior 1 with C = 0, in and out off-centre: one ray per interface,
    // the direction kept within 1e-5, and the exit point on the original line (1e-4).
    let scene = ball("1.0", "0.0");
    let start = Vec3::new(0.3, 3.0, 0.0);
    let d0 = Vec3::new(0.2, -1.0, 0.1).normalize();
    let mut rays = one_ray(start, d0);
    for _ in 0..2 {
        rays = step(&scene, &rays).0;
        assert_eq!(rays.len(), 1);
        assert!(rays.dir(0).abs_diff_eq(d0, 1e-5), "{} vs {d0}", rays.dir(0));
    }
    assert!((rays.origin(0) - start).cross(d0).length() < 1e-4);
}

#[test]
fn ior_one_at_grazing_incidence_neither_bends_nor_reflects() {
    // The same tolerances at 89.9° (cos θi = 1.7e-3).
    ior_one_passes(&slab("1.0", "\"fresnel\""), 89.9);
    // Tolerance: exact. With ior = 1 there is no critical angle, so even at 89.999° a
    // refracted ray must exist (refract() must not report TIR), and the Fresnel
    // reflectance must stay below 1e-3 (it is 0).
    for deg in [89.99, 89.995, 89.999] {
        let d = down_at(deg);
        let cos_i = -d.y;
        assert!(refract(d, Vec3::Y, 1.0).is_some(), "{deg}°: refract() reports TIR at ior 1");
        assert!(fresnel(cos_i, 1.0) < 1e-3, "{deg}°: fresnel = {}", fresnel(cos_i, 1.0));
    }
}

#[test]
fn ior_one_plus_1e_minus_6_follows_snell_and_fresnel() {
    let ior = 1.0f32 + 1e-6; // stored as 1 + 8 ulps = 1.00000095
    let scene = slab(&format!("{ior:e}"), "\"fresnel\"");
    let iord = ior as f64;
    for deg in [0.0, 30.0, 60.0, 85.0, 89.0] {
        let d = down_at(deg);
        let (inside, _) = step(&scene, &one_ray(Vec3::new(0.0, 1.0, 0.0), d));
        let (refl, refr) = split(&inside, d, Vec3::Y);
        assert_eq!(refr.len(), 1);
        // Tolerance: sin θ_t within 1e-6 of sin θ_i / ior (the bend is 1e-6·tan θ).
        let sin_t = sin_to(refr[0].0, Vec3::Y);
        let expect = sin_to(d, Vec3::Y) / iord;
        assert!((sin_t - expect).abs() < 1e-6, "{deg}°: sin θt {sin_t} vs {expect}");
        // Tolerance: reflection weight within 1e-6 of the f64 Fresnel (about 1e-13 here).
        let r = refl.first().map_or(0.0, |e| e.1.x as f64);
        let r64 = fresnel64(-d.y as f64, 1.0 / iord);
        assert!((r - r64).abs() < 1e-6, "{deg}°: reflected weight {r} vs {r64}");
        // Through the slab: the exit direction is the entry direction (within 1e-6).
        let (out, _) = step(&scene, &one_ray(inside.origin(inside.len() - 1), refr[0].0));
        let (_, exit) = split(&out, refr[0].0, Vec3::NEG_Y);
        assert!(exit[0].0.abs_diff_eq(d, 1e-6), "{deg}°: exits along {} not {d}", exit[0].0);
    }
    // From inside, the critical angle is asin(1/1.00000095) = 89.921°: beyond it, TIR.
    let crit = (1.0 / iord).asin().to_degrees();
    for (deg, tir) in [(crit - 0.01, false), (crit + 0.01, true), (89.99, true)] {
        let d = down_at(deg);
        let up = Vec3::new(d.x, -d.y, 0.0); // leaving the slab through its top face
        assert_eq!(refract(up, Vec3::NEG_Y, ior).is_none(), tir, "{deg}° from inside");
    }
}

#[test]
fn diamond_snell_fresnel_and_critical_angle() {
    let scene = slab("2.42", "\"fresnel\"");
    // Normal incidence: R = ((2.42 - 1) / 3.42)² = 0.17239.
    let (next, _) = step(&scene, &one_ray(Vec3::new(0.0, 1.0, 0.0), Vec3::NEG_Y));
    let (refl, refr) = split(&next, Vec3::NEG_Y, Vec3::Y);
    let r0 = ((2.42f64 - 1.0) / 3.42).powi(2);
    // Tolerance: 1e-6 on the weights (f32 Fresnel of a well-conditioned case).
    assert!((refl[0].1.x as f64 - r0).abs() < 1e-6, "{} vs {r0}", refl[0].1.x);
    assert!((refr[0].1.x as f64 - (1.0 - r0)).abs() < 1e-6);
    for deg in [10.0, 40.0, 70.0, 89.0] {
        let d = down_at(deg);
        let (inside, _) = step(&scene, &one_ray(Vec3::new(0.0, 1.0, 0.0), d));
        let (refl, refr) = split(&inside, d, Vec3::Y);
        // Tolerance: Snell within 1e-6 in sin θ; Fresnel within 1e-5 of f64 (the
        // reflectance changes fast near grazing, so allow 10× the normal case).
        let sin_t = sin_to(refr[0].0, Vec3::Y);
        assert!((sin_t - sin_to(d, Vec3::Y) / 2.42).abs() < 1e-6, "{deg}°: sin θt {sin_t}");
        let r64 = fresnel64(-d.y as f64, 1.0 / 2.42);
        assert!((refl[0].1.x as f64 - r64).abs() < 1e-5, "{deg}°: R {} vs {r64}", refl[0].1.x);
        // Entering, never TIR; the refracted angle stays below the critical 24.41°.
        assert!(sin_t < 1.0 / 2.42 + 1e-6);
    }
    // From inside: the critical angle is asin(1/2.42) = 24.41°.
    let crit = (1.0f64 / 2.42).asin().to_degrees();
    for (deg, tir) in [(crit - 1e-3, false), (crit + 1e-3, true), (60.0, true)] {
        let up = Vec3::new(down_at(deg).x, -down_at(deg).y, 0.0);
        assert_eq!(refract(up, Vec3::NEG_Y, 2.42).is_none(), tir, "{deg}° inside diamond");
    }
}

#[test]
fn air_bubble_with_ior_below_one() {
    // A bubble in glass: ior = 1/1.5 relative to the glass around it. Entering the
    // bubble the ray goes into the less dense medium (eta = 1.5), so it bends away from
    // the normal and totally reflects beyond asin(1/1.5) = 41.81°; leaving, it never does.
    let scene = ball("0.6666667", "0.0");
    for b in [0.0f32, 0.3, 0.6, 0.66, 0.67, 0.8, 0.99] {
        // A ray along -z at impact parameter b: incidence sin θ = b.
        let o = Vec3::new(b, 0.0, 3.0);
        let (next, hits) = step(&scene, &one_ray(o, Vec3::NEG_Z));
        assert_ne!(hits.prim[0], MISS, "b = {b}");
        let x = o + hits.t[0] * Vec3::NEG_Z;
        let n = x.normalize();
        assert_eq!(next.len(), 1, "C = 0: one ray, refracted or totally reflected");
        let (d1, w1) = (next.dir(0), next.weight(0));
        if 1.5 * b as f64 >= 1.0 + 1e-5 {
            // Tolerance: TIR sends the full weight (exactly 1) along the mirror direction (1e-6).
            assert_eq!(w1, Vec3::ONE, "b = {b}: TIR weight");
            assert!(d1.abs_diff_eq(reflect(Vec3::NEG_Z, n), 1e-6), "b = {b}: not the mirror direction");
            assert!(next.origin(0).length() > 1.0, "b = {b}: the reflection starts outside the bubble");
        } else if (1.5 * b as f64) < 1.0 - 1e-5 {
            // Snell with eta = 1.5 (tolerance 1e-5 in sin θ): bends away from the normal.
            let sin_t = sin_to(d1, n);
            assert!((sin_t - 1.5 * sin_to(Vec3::NEG_Z, n)).abs() < 1e-5, "b = {b}: sin θt {sin_t}");
            assert!(next.origin(0).length() < 1.0, "b = {b}: the refracted ray starts inside");
            // Leaving the bubble: symmetric, the exit angle equals the entry angle, within
            // 1e-5 / cos θt (the ray offset, up to 3e-5 here, moves the chord inside, and a
            // nearly tangent chord amplifies that and the f32 rounding).
            let (out, h2) = step(&scene, &one_ray(next.origin(0), d1));
            assert_ne!(h2.prim[0], MISS);
            assert_eq!(out.len(), 1, "leaving a bubble never totally reflects");
            let x2 = next.origin(0) + h2.t[0] * d1;
            let sin_out = sin_to(out.dir(0), x2.normalize());
            let tol = 1e-5 / (1.0 - sin_t * sin_t).sqrt();
            assert!((sin_out - b as f64).abs() < tol, "b = {b}: leaves at sin {sin_out} (tolerance {tol:e})");
            assert!(out.origin(0).length() > 1.0);
        }
    }
}

#[test]
fn beyond_critical_angle_inside_glass_everything_reflects() {
    let scene = ball("1.5", "0.0");
    // From (0.8, 0, 0) straight up: hits at (0.8, 0.6, 0), incidence 53.1° > 41.8°.
    let (next, hits) = step(&scene, &one_ray(Vec3::new(0.8, 0.0, 0.0), Vec3::Y));
    assert_ne!(hits.prim[0], MISS);
    assert_eq!(next.len(), 1, "total internal reflection: no refracted ray even with C = 0");
    assert_eq!(next.weight(0), Vec3::ONE, "all the weight goes to reflection");
    let n = Vec3::new(0.8, 0.6, 0.0);
    let expected = Vec3::Y - 2.0 * Vec3::Y.dot(n) * n;
    assert!(next.dir(0).abs_diff_eq(expected, 1e-5));
    assert!(next.origin(0).length() < 1.0, "the reflected ray starts inside the sphere");

    // Below the critical angle (from (0.5, 0, 0): 30°) the ray refracts out.
    let (next, _) = step(&scene, &one_ray(Vec3::new(0.5, 0.0, 0.0), Vec3::Y));
    assert_eq!(next.len(), 1);
    assert!(next.origin(0).length() > 1.0, "the refracted ray starts outside");
}

#[test]
fn total_internal_reflection_at_and_beyond_the_critical_angle() {
    for ior in [1.5f32, 2.42, 1.0 + 1e-3] {
        for ratio in ["\"fresnel\"", "0.5", "0.0"] {
            let scene = slab(&format!("{ior:e}"), ratio);
            let crit = (1.0 / ior as f64).asin();
            // Sweep ±2e-4 rad around the critical angle in 401 steps, from inside the slab
            // up through its top face (normal +y, leaving: eta = ior).
            for k in -200..=200 {
                let th = crit + k as f64 * 1e-6;
                let th = th.min(std::f64::consts::FRAC_PI_2 - 1e-6);
                let d = DVec3::new(th.sin(), th.cos(), 0.0).as_vec3();
                let (next, hits) = step(&scene, &one_ray(Vec3::new(0.0, -0.5, 0.0), d));
                assert_ne!(hits.prim[0], MISS);
                let (refl, refr) = split(&next, d, Vec3::Y);
                let s = sin_to(d, Vec3::Y) * ior as f64; // sin θt in f64
                let what = format!("ior {ior}, C {ratio}, θ − θc = {:e}", th - crit);
                for (dir, w) in refl.iter().chain(&refr) {
                    assert!(dir.is_finite() && w.is_finite(), "{what}");
                    assert!((dir.length() - 1.0).abs() < 1e-5, "{what}: direction {dir}");
                }
                // Tolerance: the reflected and refracted weights always sum to 1 within 1e-6
                // (white tint), across the transition.
                let sum: f32 = refl.iter().chain(&refr).map(|e| e.1.x).sum();
                assert!((sum - 1.0).abs() < 1e-6, "{what}: weights sum to {sum}");
                // Tolerance: exact classification outside a band of 2e-6 in sin θt around 1
                // (the f32 direction's own rounding); inside the band either is right.
                if s > 1.0 + 2e-6 {
                    assert!(refr.is_empty(), "{what}: beyond the critical angle a refracted ray exists");
                    assert_eq!(refl.len(), 1);
                    assert_eq!(refl[0].1, Vec3::ONE, "{what}: TIR must carry the full weight");
                } else if s < 1.0 - 2e-6 && ratio != "\"fresnel\"" {
                    // Fresnel may legitimately give the refraction a weight so small it
                    // rounds to 1 − R = 0 right at the critical angle; C < 1 never does.
                    assert_eq!(refr.len(), 1, "{what}: below the critical angle a refracted ray must exist");
                    let sin_t = sin_to(refr[0].0, Vec3::Y);
                    // Snell within 1e-3 in sin θt (near grazing the refracted direction is
                    // ill-conditioned: d sinθt/dθi = ior·cos θi).
                    assert!((sin_t - s).abs() < 1e-3, "{what}: sin θt {sin_t} vs {s}");
                }
            }
        }
    }
}

#[test]
fn slab_exit_direction_is_the_entry_direction_at_extreme_angles() {
    for ior in ["1.0", "1.000001", "1.5", "2.42", "0.6666667"] {
        let iord = ior.parse::<f32>().unwrap() as f64;
        // The wide slab at every angle; a slab 20 wide up to 70°, where the exit point is
        // checked too.
        for (scene, angles, narrow) in [
            (slab(ior, "0.0"), &[0.0, 20.0, 30.0, 45.0, 60.0, 70.0, 80.0, 85.0, 88.0, 89.0][..], false),
            (slab_of_width(ior, "0.0", 10.0), &[0.0, 20.0, 45.0, 70.0][..], true),
        ] {
            for &deg in angles {
                let d0 = down_at(deg);
                let (inside, _) = step(&scene, &one_ray(Vec3::new(0.0, 1.0, 0.0), d0));
                assert_eq!(inside.len(), 1, "C = 0: only the refracted ray");
                if inside.dir(0).y > 0.0 {
                    // ior < 1 entered beyond its critical angle: totally reflected upwards.
                    assert!(ior == "0.6666667" && sin_to(d0, Vec3::Y) > 0.6666667, "{ior} at {deg}°");
                    continue;
                }
                let (out, h) = step(&scene, &inside);
                assert_ne!(h.prim[0], MISS, "{ior} at {deg}°: the ray inside hits the bottom face");
                assert_eq!(out.len(), 1);
                // Tolerance: the exit origin lies just below y = -1, by the ray offset (at
                // most 1e-4; 256 ulps of 1 is 3e-5).
                let o = out.origin(0);
                assert!(o.y < -1.0 && o.y > -1.0 - 1e-4, "{ior} at {deg}°: {o}");
                let d1 = out.dir(0);
                // Tolerance: the exit direction equals the entry direction within 1e-5 up to
                // 85°, 1e-4 beyond: leaving the slab near grazing amplifies the f32 rounding
                // of the direction inside by ior·cos θi / cos θt (about 70 for diamond at 89°).
                let tol = if deg > 85.0 { 1e-4 } else { 1e-5 };
                assert!(d1.abs_diff_eq(d0, tol), "{ior} at {deg}°: leaves along {d1}, entered {d0}");
                assert_eq!(out.weight(0), Vec3::ONE, "C = 0 and white tint keep the full weight");
                // The narrow slab: the ray is shifted by Snell's offset, x = tan θi + tan θt
                // for a slab 1 thick entered 1 above it (tolerance 1e-4).
                if narrow {
                    let th = f64::to_radians(deg);
                    let exit_x = th.tan() + (th.sin() / iord).asin().tan();
                    assert!(
                        (o.x as f64 - exit_x).abs() < 1e-4 && (o.y + 1.0).abs() < 1e-4,
                        "{ior} at {deg}°: exits at {o}, expected x = {exit_x}"
                    );
                }
            }
        }
    }
}

/// A glass sphere of radius 1 (ior 1.5) around one of radius 0.5, both at the origin.
fn nested(inner_ior: &str, ratio: &str) -> Scene {
    let ratio = format!("reflect_ratio={ratio}");
    let text = [
        camera([0.0, 0.0, 5.0], [0.0; 3], &[]),
        material("outer", "dielectric", &["ior=1.5", &ratio]),
        material("inner", "dielectric", &[&format!("ior={inner_ior}"), &ratio]),
        sphere([0.0; 3], 1.0, "outer"),
        sphere([0.0; 3], 0.5, "inner"),
    ]
    .concat();
    scene(&text, &[])
}

#[test]
fn nested_spheres_a_ray_through_the_centre_passes_straight_through() {
    // C = 0: only refracted rays. Interfaces at z = 1, 0.5, -0.5, -1.
    let scene = nested("1.2", "0.0");
    let d = Vec3::NEG_Z;
    let mut rays = one_ray(Vec3::new(0.0, 0.0, 5.0), d);
    let expected_t = [4.0f32, 0.5, 1.0, 0.5];
    // After each interface the origin's distance from the centre lies in this range.
    let shells = [(0.5, 1.0), (0.0, 0.5), (0.5, 1.0), (1.0, 2.0)];
    for k in 0..4 {
        let (next, hits) = step(&scene, &rays);
        assert_ne!(hits.prim[0], MISS, "interface {k}");
        // Tolerance: t within 1e-4 of the exact distance (the origin offset is 1.5e-5 at
        // radius 1); above all not ≈ 0: the ray does not hit the surface it started on.
        assert!((hits.t[0] - expected_t[k]).abs() < 1e-4, "interface {k}: t = {}", hits.t[0]);
        assert_eq!(next.len(), 1, "interface {k}: C = 0 spawns only the refracted ray");
        // Tolerance: direction exactly -z within 1e-7 and the origin on the axis within 1e-6.
        assert!(next.dir(0).abs_diff_eq(d, 1e-7), "interface {k}: direction {}", next.dir(0));
        let o = next.origin(0);
        assert!(o.x.abs() < 1e-6 && o.y.abs() < 1e-6, "interface {k}: origin {o} off the axis");
        let r = o.length();
        assert!(r > shells[k].0 && r < shells[k].1, "interface {k}: origin at radius {r}");
        assert_eq!(next.weight(0), Vec3::ONE);
        rays = next;
    }
    let (last, hits) = step(&scene, &rays);
    assert_eq!(hits.prim[0], MISS, "after the fourth interface the ray leaves");
    assert!(last.is_empty());

    // Fresnel: the straight-through weight is the product of (1 − R) at normal incidence,
    // R = ((n − 1)/(n + 1))² with n = 1.5 (outer) and 1.2 (inner, relative to the glass).
    let scene = nested("1.2", "\"fresnel\"");
    let mut rays = one_ray(Vec3::new(0.0, 0.0, 5.0), d);
    let mut w = 1.0f64;
    for n in [1.5f64, 1.2, 1.2, 1.5] {
        let (next, _) = step(&scene, &rays);
        let r = ((n - 1.0) / (n + 1.0)).powi(2);
        w *= 1.0 - r;
        let through: Vec<usize> = (0..next.len()).filter(|&i| next.dir(i).z < 0.0).collect();
        assert_eq!(through.len(), 1);
        let i = through[0];
        // Tolerance: 1e-6 on the accumulated weight.
        assert!((next.weight(i).x as f64 - w).abs() < 1e-6, "weight {} vs {w}", next.weight(i).x);
        let mut q = RayQueue::default();
        q.push(next.origin(i), next.dir(i), 0, next.weight(i), 1, 9, 0, 0.0, None);
        rays = q;
    }

    // An off-centre ray with an inner ior of 1 (the same glass inside): the inner
    // interfaces do not bend it (within 1e-6).
    let scene = nested("1.0", "0.0");
    let mut rays = one_ray(Vec3::new(0.2, 0.1, 5.0), d);
    let (inside, _) = step(&scene, &rays);
    rays = inside;
    for k in 0..2 {
        let before = rays.dir(0);
        let (next, h) = step(&scene, &rays);
        let x = rays.origin(0) + h.t[0] * before;
        assert!((x.length() - 0.5).abs() < 1e-5, "inner interface {k} hit at radius {}", x.length());
        assert!(next.dir(0).abs_diff_eq(before, 1e-6), "inner interface {k} bent {before} to {}", next.dir(0));
        rays = next;
    }
}

#[test]
fn reflect_ratio_one_only_reflects_and_zero_only_refracts_unless_tir() {
    let mut rng = Lcg(3);
    for (ratio, c) in [("1.0", 1.0f32), ("0.0", 0.0)] {
        let scene = ball("1.5", ratio);
        for k in 0..400 {
            // Half the rays start outside (aimed at the sphere), half inside.
            let outside = k % 2 == 0;
            let (o, d) = if outside {
                let o = rng.unit() * 3.0;
                (o, ((rng.unit() * 0.9) - o).normalize())
            } else {
                (rng.unit() * rng.range(0.0, 0.9), rng.unit())
            };
            let (next, hits) = step(&scene, &one_ray(o, d));
            assert_ne!(hits.prim[0], MISS);
            let x = o + hits.t[0] * d;
            let ng = x.normalize();
            let side = interface(d, ng, 1.5);
            assert_eq!(side.entering, outside);
            let tir = refract(d, side.normal, side.eta).is_none();
            // Tolerance: exact counts; the weight is exactly 1 (white tint, C ∈ {0, 1}).
            assert_eq!(next.len(), 1, "C = {c}: one ray per hit");
            let (refl, _) = split(&next, d, ng);
            let reflected = refl.len() == 1;
            assert_eq!(reflected, c == 1.0 || tir, "C = {c}, outside {outside}, tir {tir}");
            assert_eq!(next.weight(0), Vec3::ONE);
            assert!(!tir || !outside, "entering glass never totally reflects");
        }
    }
}

#[test]
fn fixed_ratio_splits_weight_c_and_one_minus_c() {
    let scene = ball("1.5", "0.25");
    let (next, _) = step(&scene, &one_ray(Vec3::new(0.1, 3.0, 0.0), Vec3::NEG_Y));
    assert_eq!(next.len(), 2);
    let mut w: Vec<f32> = (0..2).map(|i| next.weight(i).x).collect();
    w.sort_by(f32::total_cmp);
    assert_eq!(w, vec![0.25, 0.75]);
}

#[test]
fn glass_with_c_one_renders_exactly_like_a_white_mirror() {
    let with = |material: &str| {
        let floor = FloorScene {
            look_at: [0.0, 0.5, 0.0],
            background: Some([0.1, 0.2, 0.3]),
            materials: vec![FloorScene::diffuse("white", [0.8; 3]), ("m", material.to_string())],
            light: QuadLight::square(3.0, 2.0, 4.0),
            spheres: vec![Sphere { center: [0.0, 0.6, 0.0], radius: 0.6, material: "m" }],
            ..FloorScene::default()
        };
        render_block(&["width=24", "height=24", "aa.samples=2", "shadows.samples=2"]) + &floor.toml()
    };
    let glass = render_finite(&with("type = \"dielectric\"\nior = 1.5\nreflect_ratio = 1.0"));
    let mirror = render_finite(&with("type = \"mirror\"\ncolor = [1, 1, 1]"));
    // Tolerance: bit-identical. Both reflect about the normal facing the ray, start the
    // reflection at the same offset origin with the same path key and full weight.
    assert_eq!(glass.image, mirror.image);
    assert_eq!(glass.stats.secondary_rays, mirror.stats.secondary_rays);
}

#[test]
fn figure_5_inside_outside_normal_and_eta_are_always_consistent() {
    // The paper's Figure 5 errors: using the outward normal from inside (wrong N), or
    // 1/ior instead of ior when leaving (wrong eta). interface() decides both from the
    // geometric normal; check every consequence on random directions and normals.
    let mut rng = Lcg(17);
    for ior in [0.6666667f32, 1.0, 1.000001, 1.5, 2.42] {
        for _ in 0..2000 {
            let ng = rng.unit();
            let d = rng.unit();
            if d.dot(ng).abs() < 1e-3 {
                continue; // extreme grazing is tested on its own
            }
            let side = interface(d, ng, ior);
            // Exact: entering ⇔ against the outward normal; eta = 1/ior in, ior out;
            // the normal used faces the incoming ray.
            assert_eq!(side.entering, d.dot(ng) < 0.0);
            if side.entering {
                assert_eq!((side.normal, side.eta), (ng, 1.0 / ior));
            } else {
                assert_eq!((side.normal, side.eta), (-ng, ior));
            }
            assert!(d.dot(side.normal) < 0.0, "the normal must face the incoming ray");
            let r = reflect(d, side.normal);
            // Tolerance 1e-5: the reflection stays on the incoming side, unit length.
            assert!(r.dot(side.normal) > 0.0 && (r.length() - 1.0).abs() < 1e-5);
            match refract(d, side.normal, side.eta) {
                None => {
                    // TIR only when going into the less dense side, beyond the critical angle.
                    let s = sin_to(d, ng) * side.eta as f64;
                    assert!(side.eta > 1.0 && s >= 1.0 - 1e-5, "ior {ior}: TIR with sin θt = {s}");
                    assert_eq!(fresnel(-d.dot(side.normal), side.eta), 1.0);
                }
                Some(t) => {
                    // The refracted ray crosses to the other side (strictly, unless grazing).
                    assert!(t.dot(side.normal) <= 0.0, "ior {ior}: refracted ray turned back");
                    // Snell within 1e-5·(1 + sin θt/cos θt): the refracted direction's
                    // sine error is amplified near grazing.
                    let (si, st) = (sin_to(d, ng), sin_to(t, ng));
                    let tol = 1e-5 * (1.0 + st / (1.0 - st * st).sqrt().max(1e-3));
                    assert!(
                        (st - side.eta as f64 * si).abs() < tol,
                        "ior {ior}: Snell {st} vs {}",
                        side.eta as f64 * si
                    );
                    // Reversibility: the reversed refracted ray, oriented by interface()
                    // from its own side, refracts back along -d (1e-4) with the same R (1e-4).
                    let back = interface(-t, ng, ior);
                    assert_eq!(back.entering, !side.entering);
                    assert!((back.eta * side.eta - 1.0).abs() < 1e-6, "eta {} then {}", side.eta, back.eta);
                    if let Some(rd) = refract(-t, back.normal, back.eta) {
                        // Away from grazing on either side (there both directions and R are
                        // ill-conditioned: R → 1 with an infinite slope).
                        if st < 0.99 && si < 0.99 {
                            assert!(rd.abs_diff_eq(-d, 1e-4), "ior {ior}: reverse {rd} vs {}", -d);
                            let (r1, r2) =
                                (fresnel(-d.dot(side.normal), side.eta), fresnel(-t.dot(side.normal), back.eta));
                            assert!((r1 - r2).abs() < 1e-4, "ior {ior}: Fresnel not reciprocal: {r1} vs {r2}");
                        }
                    }
                }
            }
        }
    }
    // Through the pipeline: a ray leaving a glass sphere bends away from the normal
    // (sin θt = 1.5 sin θi) and starts outside; entering, it bends towards the normal
    // (sin θt = sin θi / 1.5) and starts inside. Wrong eta swaps the two; wrong N puts
    // the origin on the wrong side. Tolerance 1e-5 in sin θ.
    let scene = ball("1.5", "0.0");
    let th = 30f32.to_radians();
    let (next, h) = step(&scene, &one_ray(Vec3::ZERO, Vec3::new(th.sin(), th.cos(), 0.0)));
    assert_ne!(h.prim[0], MISS);
    // From the centre every ray meets the surface head-on: no bend.
    assert!(next.dir(0).abs_diff_eq(Vec3::new(th.sin(), th.cos(), 0.0), 1e-6));
    let o = Vec3::new(0.4, 0.0, 0.0);
    let (next, h) = step(&scene, &one_ray(o, Vec3::Y));
    let n = (o + h.t[0] * Vec3::Y).normalize();
    let si = sin_to(Vec3::Y, n);
    assert!((sin_to(next.dir(0), n) - 1.5 * si).abs() < 1e-5, "leaving: eta must be ior");
    assert!(next.origin(0).length() > 1.0, "leaving: the refracted ray starts outside");
    let o = Vec3::new(0.4, -3.0, 0.0);
    let (next, h) = step(&scene, &one_ray(o, Vec3::Y));
    let n = (o + h.t[0] * Vec3::Y).normalize();
    let si = sin_to(Vec3::Y, n);
    assert!((sin_to(next.dir(0), n) - si / 1.5).abs() < 1e-5, "entering: eta must be 1/ior");
    assert!(next.origin(0).length() < 1.0, "entering: the refracted ray starts inside");
}

#[test]
fn a_thin_sheet_passes_light_straight_and_reflects_its_two_faces() {
    // One quad of thin glass in the plane y = 0 (Mitsuba's thindielectric).
    let text = [
        camera([0.0, 5.0, 5.0], [0.0; 3], &[]),
        material("sheet", "dielectric", &["ior=1.5", "thin=true", "color=[0.9, 0.8, 0.7]"]),
        quad([-10.0, 0.0, -10.0], [0.0, 0.0, 20.0], [20.0, 0.0, 0.0], "sheet"),
    ]
    .concat();
    let scene = scene(&text, &[]);
    for deg in [0.0f64, 30.0, 60.0, 85.0] {
        let th = deg.to_radians();
        let d = DVec3::new(th.sin(), -th.cos(), 0.0).as_vec3();
        // A unit step before the origin, where it hits the sheet.
        let (next, _) = step(&scene, &one_ray(-d, d));
        assert_eq!(next.len(), 2, "at {deg}°");
        // One face reflects R; the light bounced between the faces sums to 2R / (1 + R).
        let r = fresnel64(th.cos(), 1.0 / 1.5);
        let sheet = 2.0 * r / (1.0 + r);
        let (refl, through) = (0, 1);
        assert!((next.weight(refl).x as f64 - sheet).abs() < 1e-6, "at {deg}°: {} vs {sheet}", next.weight(refl));
        let t = next.weight(through);
        assert!((t.x as f64 - 0.9 * (1.0 - sheet)).abs() < 1e-6, "at {deg}°: {t}");
        assert!((t.z as f64 - 0.7 * (1.0 - sheet)).abs() < 1e-6, "at {deg}°: {t}");
        // Straight through, from below the sheet.
        assert_eq!(next.dir(through), d, "at {deg}°");
        assert!(next.origin(through).y < 0.0 && next.origin(refl).y > 0.0, "at {deg}°");
    }
}
