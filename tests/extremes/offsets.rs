//! Ray offsets: shadow rays from a plane never hit the plane itself (no acne), and
//! secondary rays leave the surface they start on, near the origin and far from it.

use crate::support::toml::{camera, diffuse, material, mirror, place, point_light, quad, sphere, V3};
use crate::support::{closest, one_ray, scene_in, step, step_all, Lcg};
use glam::{DVec3, Vec3};
use std::path::Path;
use wavetrace::accel::tracer::{Kernel, Tracer};
use wavetrace::queue::{FilmQueue, RayQueue, MISS};
use wavetrace::stages::shadow;
use wavetrace::Scene;

/// Shadow rays from a diffuse plane never hit the plane itself: rays at grazing angles
/// onto a plane y = t.y, lit by a point light straight above, at several scales and
/// offsets. Counts self-shadowed shading points.
fn self_shadowed(s: f64, t: [f64; 3]) -> (usize, usize) {
    let p = |v: V3| place(v, s, t);
    let text = [
        camera(p([0.0, 1.0, 4.0]), p([0.0; 3]), &[]),
        diffuse("white", [1.0; 3]),
        point_light(p([0.0, 100.0, 0.0]), 1.0),
        quad(p([-1e3, 0.0, -1e3]), [2e3 * s, 0.0, 0.0], [0.0, 0.0, 2e3 * s], "white"),
    ]
    .concat();
    let scene = scene_in(Path::new("."), &text, &[]);
    let mut rays = RayQueue::default();
    let mut rng = Lcg(11);
    let base = DVec3::from_array(t);
    for _ in 0..2000 {
        // From a height of 0.01 to 5 (times s), down at 0.5° to 60° below the horizon.
        let h = 10f64.powf(rng.range(-2.0, 0.7) as f64);
        let below = (rng.range(0.5, 60.0) as f64).to_radians();
        let az = rng.range(0.0, std::f32::consts::TAU) as f64;
        let o = base + DVec3::new(rng.range(-3.0, 3.0) as f64 * s, h * s, rng.range(-3.0, 3.0) as f64 * s);
        let d = DVec3::new(below.cos() * az.cos(), -below.sin(), below.cos() * az.sin());
        rays.push(o.as_vec3(), d.as_vec3().normalize(), 0, Vec3::ONE, 0, rng.0 as u32, 0, 0.0, None);
    }
    let (_, hits, shadow_q, _) = step_all(&scene, &rays);
    assert!(hits.prim.iter().all(|&p| p != MISS), "every ray hits the plane");
    let mut film = FilmQueue::default();
    let lit = shadow::occlusion(
        &mut Tracer::new(&scene.accel, Kernel::render(scene.settings.packets), false),
        &shadow_q,
        &mut film,
    );
    (shadow_q.len() - lit, shadow_q.len())
}

#[test]
fn no_shadow_acne_on_a_plane_through_the_origin_or_far_from_it() {
    // Tolerance: zero. Nothing lies between the plane and the light, so every shadow
    // ray must reach it; a blocked one is the plane shadowing itself.
    for (s, t) in [(1.0, [0.0; 3]), (1.0, [1e5; 3]), (1e-4, [0.0; 3])] {
        let (blocked, total) = self_shadowed(s, t);
        assert_eq!(total, 2000, "each hit casts one shadow ray");
        assert_eq!(blocked, 0, "scale {s:e}, offset {t:?}: {blocked} of {total} shading points shadow themselves");
    }
}

#[test]
fn no_shadow_acne_on_a_plane_through_the_origin_seen_from_far_away() {
    // Tolerance: zero, as above. The camera is s units away, so the hit point's
    // coordinate across the plane (exactly 0) is computed with an error of about
    // ulp(s), far more than the fixed 1/65536 the near-origin branch pushes it by.
    for s in [1e4, 1e6] {
        let (blocked, total) = self_shadowed(s, [0.0; 3]);
        assert_eq!(blocked, 0, "scale {s:e}: {blocked} of {total} shading points shadow themselves");
    }
}

/// A mirror sphere, a glass sphere and a mirror quad at `c`, in a scene with nothing
/// else: secondary rays must leave the surface they start on.
fn far_specular(c: [f64; 3], r: f64) -> Scene {
    let p = |v: V3| place(v, r, c);
    let text = [
        camera(p([0.0, 0.0, 10.0]), p([0.0; 3]), &[]),
        mirror("mirror", [1.0; 3]),
        material("glass", "dielectric", &["ior=1.5", "reflect_ratio=0.5"]),
        sphere(p([0.0; 3]), r, "mirror"),
        sphere(p([5.0, 0.0, 0.0]), r, "glass"),
        quad(p([-20.0, -3.0, -20.0]), [40.0 * r, 0.0, 0.0], [0.0, 0.0, 40.0 * r], "mirror"),
    ]
    .concat();
    scene_in(Path::new("."), &text, &[])
}

/// Checks spawned rays at the mirror sphere, glass sphere and mirror plane of
/// `far_specular(c, r)`; returns a description of the first failure.
fn check_secondary_rays(c: [f64; 3], r: f64) -> Result<(), String> {
    let scene = far_specular(c, r);
    let centre = DVec3::from_array(c);
    let (mirror_c, glass_c) = (centre, centre + DVec3::new(5.0 * r, 0.0, 0.0));
    let plane_y = c[1] - 3.0 * r;
    let rf = r as f32;
    // Tolerance on how far a spawned origin may sit off the surface: 1e-3·r plus 4 float
    // spacings at the surface's coordinates (a point on the surface can only be placed to
    // within about one spacing, 2^-7 ≈ 0.008 at 1e5; a robust offset needs a few).
    let spacing = {
        let m = (c[0].abs().max(c[1].abs()).max(c[2].abs()) + 10.0 * r) as f32;
        (m.next_up() - m) as f64
    };
    let max_off = 1e-3 * r + 4.0 * spacing;
    for k in 0..40 {
        // Impact parameters from 0 to 0.975 r, coming in along -z (and a little -y).
        let b = k as f64 / 40.0;
        for (target, is_glass) in [(mirror_c, false), (glass_c, true)] {
            let o = target + DVec3::new(b * r, 0.0, 3.0 * r);
            let d = Vec3::new(0.0, -1e-3, -1.0).normalize();
            let (next, hits) = step(&scene, &one_ray(o.as_vec3(), d));
            if hits.prim[0] == MISS {
                return Err(format!("b = {b}: the camera ray missed the sphere"));
            }
            let x = o + hits.t[0] as f64 * d.as_dvec3();
            let n_out = (x - target).normalize();
            for i in 0..next.len() {
                let no = next.origin(i).as_dvec3();
                let nd = next.dir(i);
                let dist = (no - target).length() - r;
                let reflected = nd.as_dvec3().dot(n_out) > 0.0;
                let what = format!(
                    "{} sphere at {c:?}, r = {r}, b = {b}, {}",
                    if is_glass { "glass" } else { "mirror" },
                    if reflected { "reflected" } else { "refracted" }
                );
                if dist.abs() > max_off {
                    return Err(format!("{what}: spawned origin {dist:e} off the surface (max {max_off:e})"));
                }
                let again = closest(&scene, next.origin(i), nd);
                if reflected {
                    // It leaves a convex surface: it starts outside and never hits it again
                    // (only the mirror plane, far away, may be hit).
                    if dist <= 0.0 {
                        return Err(format!("{what}: starts inside the sphere ({dist:e})"));
                    }
                    if let Some((t2, _)) = again {
                        if t2 < 0.5 * rf {
                            return Err(format!("{what}: hits again at t = {t2:e}"));
                        }
                    }
                } else {
                    // Refracted into the glass: it starts inside and next hits the far side,
                    // at the chord length 2 r cos θ_t (within 2e-3·r + 2 × the offset bound).
                    if dist >= 0.0 {
                        return Err(format!("{what}: starts outside the glass ({dist:e})"));
                    }
                    let cos_t = nd.as_dvec3().dot(-n_out);
                    let chord = 2.0 * r * cos_t;
                    match again {
                        Some((t2, _)) if (t2 as f64 - chord).abs() <= 2e-3 * r + 2.0 * max_off => {}
                        other => return Err(format!("{what}: next hit {other:?}, expected the chord {chord:e}")),
                    }
                }
            }
        }
        // The mirror plane, hit at grazing to steep angles: the reflection leaves upwards
        // and never hits the plane again.
        let elev = (0.2 + 89.0 * k as f64 / 40.0).to_radians();
        // From a height that lands 5 r away, so every angle hits the plane near the sphere.
        let o = DVec3::new(c[0], plane_y + 5.0 * r * elev.tan(), c[2] + 10.0 * r);
        let d = DVec3::new(0.3 * elev.cos(), -elev.sin(), -elev.cos()).normalize().as_vec3();
        let (next, hits) = step(&scene, &one_ray(o.as_vec3(), d));
        if hits.prim[0] == MISS || next.len() != 1 {
            return Err(format!("plane at {:.2}°: no reflection", elev.to_degrees()));
        }
        let above = next.origin(0).y as f64 - plane_y;
        if !(0.0 < above && above < max_off) {
            return Err(format!("plane at {:.2}°: reflected origin {above:e} above the plane", elev.to_degrees()));
        }
        let again = closest(&scene, next.origin(0), next.dir(0));
        if let Some((t, _)) = again {
            if t < 0.5 * rf {
                return Err(format!("plane at {:.2}°: reflection hits again at t = {t:e}", elev.to_degrees()));
            }
        }
    }
    Ok(())
}

#[test]
fn secondary_rays_leave_the_surface_near_the_origin() {
    check_secondary_rays([0.0; 3], 1.0).unwrap();
    check_secondary_rays([3.0, -2.0, 1.0], 10.0).unwrap();
}

#[test]
fn secondary_rays_leave_the_surface_far_from_the_origin() {
    check_secondary_rays([1e5; 3], 1.0).unwrap();
    check_secondary_rays([1e5; 3], 10.0).unwrap();
}
