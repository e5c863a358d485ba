//! Refraction through the real stages: a glass slab shifts a ray without turning it,
//! total internal reflection inside a sphere, and ior = 1 bends nothing.

mod support;

use glam::Vec3;
use support::scene;
use wavetrace::geometry::tracer::{Coherence, Kernel, Tracer};
use wavetrace::queue::{FilmQueue, HitQueue, IndexQueue, RayQueue, ShadowPointQueue, ShadowQueue, MISS};
use wavetrace::stages::{intersect, scatter, shade};
use wavetrace::Scene;

const CAMERA: &str = "[camera]\nposition = [0, 5, 5]\nlook_at = [0, 0, 0]\n";

/// Pushes one ray through intersect → shade → scatter and returns the next wave.
fn step(scene: &Scene, rays: &RayQueue) -> (RayQueue, HitQueue) {
    let mut hits = HitQueue::default();
    let (mut shadow, mut spec, mut film) = (ShadowQueue::default(), IndexQueue::default(), FilmQueue::default());
    intersect::intersect(
        &mut Tracer::new(&scene.accel, Kernel::render(scene.settings.packets), false),
        rays,
        Coherence::Camera,
        &mut hits,
    );
    shade::shade(scene, rays, &hits, &mut shadow, &mut ShadowPointQueue::default(), &mut spec, &mut film);
    let mut next = RayQueue::default();
    scatter::scatter(scene, rays, &hits, &spec, &mut next);
    (next, hits)
}

fn one_ray(o: Vec3, d: Vec3) -> RayQueue {
    let mut q = RayQueue::default();
    q.push(o, d.normalize(), 0, Vec3::ONE, 0, 7);
    q
}

#[test]
fn slab_shifts_ray_by_snell_offset_and_keeps_direction() {
    // Top face at y = 0 (normal +y), bottom at y = -1 (normal -y): a slab 1 thick.
    let text = format!(
        r#"{CAMERA}
[materials.glass]
type = "dielectric"
ior = 1.5
reflect_ratio = 0.0
[[objects]]
type = "quad"
corner = [-10, 0, -10]
edge_u = [0, 0, 20]
edge_v = [20, 0, 0]
material = "glass"
[[objects]]
type = "quad"
corner = [-10, -1, -10]
edge_u = [20, 0, 0]
edge_v = [0, 0, 20]
material = "glass"
"#
    );
    let scene = scene(&text, &[]);
    for deg in [0.0f32, 20.0, 45.0, 70.0] {
        let th = deg.to_radians();
        let d0 = Vec3::new(th.sin(), -th.cos(), 0.0);
        let (inside, _) = step(&scene, &one_ray(Vec3::new(0.0, 1.0, 0.0), d0));
        assert_eq!(inside.len(), 1, "C = 0: only the refracted ray");
        let (out, _) = step(&scene, &inside);
        assert_eq!(out.len(), 1);
        let d1 = out.dir(0);
        assert!(d1.abs_diff_eq(d0, 1e-5), "{deg}°: leaves along {d1}, entered along {d0}");
        let th_t = (th.sin() / 1.5).asin();
        let exit_x = th.tan() + th_t.tan();
        let o = out.origin(0);
        assert!((o.x - exit_x).abs() < 1e-4 && (o.y + 1.0).abs() < 1e-4, "{deg}°: exits at {o}, expected x = {exit_x}");
        assert_eq!(out.weight(0), Vec3::ONE, "C = 0 and white tint keep the full weight");
    }
}

const SPHERE: &str = r#"
[materials.glass]
type = "dielectric"
ior = IOR
reflect_ratio = 0.0
[[objects]]
type = "sphere"
center = [0, 0, 0]
radius = 1.0
material = "glass"
"#;

#[test]
fn beyond_critical_angle_inside_glass_everything_reflects() {
    let scene = scene(&format!("{CAMERA}{}", SPHERE.replace("IOR", "1.5")), &[]);
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
fn ior_one_leaves_rays_unbent() {
    let scene = scene(&format!("{CAMERA}{}", SPHERE.replace("IOR", "1.0")), &[]);
    let d0 = Vec3::new(0.2, -1.0, 0.1).normalize();
    let mut rays = one_ray(Vec3::new(0.3, 3.0, 0.0), d0);
    for _ in 0..2 {
        rays = step(&scene, &rays).0;
        assert_eq!(rays.len(), 1);
        assert!(rays.dir(0).abs_diff_eq(d0, 1e-5), "{} vs {d0}", rays.dir(0));
    }
    // The exit point lies on the original line.
    let o = rays.origin(0) - Vec3::new(0.3, 3.0, 0.0);
    assert!(o.cross(d0).length() < 1e-4);
}

#[test]
fn fixed_ratio_splits_weight_c_and_one_minus_c() {
    let text =
        format!("{CAMERA}{}", SPHERE.replace("IOR", "1.5").replace("reflect_ratio = 0.0", "reflect_ratio = 0.25"));
    let scene = scene(&text, &[]);
    let (next, _) = step(&scene, &one_ray(Vec3::new(0.1, 3.0, 0.0), Vec3::NEG_Y));
    assert_eq!(next.len(), 2);
    let mut w: Vec<f32> = (0..2).map(|i| next.weight(i).x).collect();
    w.sort_by(f32::total_cmp);
    assert_eq!(w, vec![0.25, 0.75]);
}
