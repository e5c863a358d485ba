//! Grazing rays: a ray at 89.9° to a plane and rays in a triangle's plane or along its
//! edges hit or miss correctly and never produce NaN.

use crate::support::toml::{camera, dielectric, diffuse, material, mesh, mirror, point_light, quad, quad_light};
use crate::support::{closest, one_ray, scene_in, step_all};
use glam::{DVec3, Vec3};
use std::path::Path;
use wavetrace::queue::MISS;

/// A plane y = 0, 20 units wide, of material `mat` (`white`, diffuse with a sharp Phong
/// highlight; `glass`; `mirror`), under a point light and a quad light.
fn plane_scene(mat: &str) -> String {
    [
        camera([0.0, 5.0, 5.0], [0.0; 3], &[]),
        material("white", "diffuse", &["color=[0.8, 0.8, 0.8]", "specular=[0.5, 0.5, 0.5]", "shininess=200"]),
        dielectric("glass", 1.5),
        mirror("mirror", [1.0; 3]),
        point_light([3.0, 2.0, 0.0], 5.0),
        quad_light([2.0, 3.0, -1.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0], 3.0),
        quad([-10.0, 0.0, -10.0], [20.0, 0.0, 0.0], [0.0, 0.0, 20.0], mat),
    ]
    .concat()
}

#[test]
fn ray_at_89_9_degrees_to_a_plane_hits_and_misses_correctly() {
    let a = 0.1f64.to_radians(); // 89.9° from the normal
    for mat in ["white", "glass", "mirror"] {
        let scene = scene_in(Path::new("."), &plane_scene(mat), &["render.shadows.samples=16"]);
        for (h, dir_y, expect_hit) in [
            (0.01, -1.0, true),  // lands at x = 5.73, inside the quad
            (0.019, -1.0, true), // lands at x = 10.89: outside (the quad ends at 10)
            (0.01, 1.0, false),  // rising: never reaches the plane
            (-0.01, 1.0, true),  // from below: two-sided
        ] {
            let expect_hit = expect_hit && h / a.tan() < 10.0;
            let o = Vec3::new(0.0, h as f32, 0.0);
            let d = DVec3::new(a.cos(), dir_y * a.sin(), 0.0).as_vec3();
            let (next, hits, shadow_q, film) = step_all(&scene, &one_ray(o, d));
            assert_eq!(hits.prim[0] != MISS, expect_hit, "{mat}, h = {h}, dir_y = {dir_y}");
            if !expect_hit {
                continue;
            }
            // Tolerance: t within 1e-4 relative of the exact h / sin(a) (f32 keeps ~1e-7;
            // the direction itself is rounded to f32 first).
            let exact = (h.abs() / (d.y.abs() as f64)).abs();
            let t = hits.t[0] as f64;
            assert!((t - exact).abs() < 1e-4 * exact, "{mat}, h = {h}: t = {t}, exact {exact}");
            // Shading at grazing incidence is finite and non-negative.
            for i in 0..shadow_q.len() {
                let l = shadow_q.radiance(i);
                assert!(l.is_finite() && l.min_element() >= 0.0, "{mat}: shadow ray {i} carries {l}");
                assert!(shadow_q.dir(i).is_finite() && shadow_q.tmax[i] > 0.0);
            }
            for i in 0..film.len() {
                assert!(film.r[i].is_finite() && film.g[i].is_finite() && film.b[i].is_finite());
            }
            for i in 0..next.len() {
                let (w, nd) = (next.weight(i), next.dir(i));
                // Tolerance: spawned directions unit length within 1e-5, weights in [0, 1].
                assert!(w.is_finite() && w.min_element() >= 0.0 && w.max_element() <= 1.0, "{mat}: weight {w}");
                assert!((nd.length() - 1.0).abs() < 1e-5, "{mat}: direction {nd}");
                // A reflected ray leaves the plane on the side it came from and does not
                // hit the plane again.
                if nd.y * d.y < 0.0 {
                    assert_eq!(next.origin(i).y > 0.0, o.y > 0.0, "{mat}: reflection starts on the wrong side");
                    assert!(closest(&scene, next.origin(i), nd).is_none(), "{mat}: the reflection hits the plane");
                }
            }
            if mat == "white" {
                assert!(!shadow_q.is_empty() || h < 0.0, "the lit side gets shadow rays");
            }
        }
    }
}

#[test]
fn rays_in_a_triangle_plane_and_along_its_edges_are_finite() {
    // One triangle (0,0,0), (1,0,0), (0,1,0), loaded as a mesh.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let text = [camera([0.0, 0.0, 5.0], [0.0; 3], &[]), diffuse("m", [1.0; 3]), mesh("tri.obj", "m", &[])].concat();
    let scene = scene_in(dir.path(), &text, &[]);
    let tri = scene.accel.prim(0).shape;
    let inf = f32::INFINITY;
    // In the plane, along each edge and through the interior: no hit (the ray is parallel
    // to the plane), and never NaN.
    let in_plane = [
        (Vec3::new(-1.0, 0.0, 0.0), Vec3::X),
        (Vec3::new(0.0, -1.0, 0.0), Vec3::Y),
        (Vec3::new(1.5, -0.5, 0.0), Vec3::new(-1.0, 1.0, 0.0).normalize()),
        (Vec3::new(-1.0, 0.2, 0.0), Vec3::X),
    ];
    for (o, d) in in_plane {
        let t = tri.intersect(o, d, 0.0, inf);
        assert!(!t.is_nan(), "in-plane ray {o} {d}: t = {t}");
        // Exact: a ray in the triangle's plane has no well-defined hit point; a test may
        // report one only on the triangle's closure, at the distance to it.
        if t.is_finite() {
            let p = o + t * d;
            assert!(p.x >= -1e-6 && p.y >= -1e-6 && p.x + p.y <= 1.0 + 1e-6, "in-plane ray {o} {d} hit {p}");
        }
    }
    // Tilted by 1e-7 rad to 1e-3 rad out of the plane, along the edges: whatever the
    // test says, t is never NaN, and a hit lies on the triangle (within 1e-4).
    for eps in [1e-7f32, 1e-5, 1e-3] {
        for (o, d) in in_plane {
            for sign in [-1.0f32, 1.0] {
                let o = o + Vec3::Z * (sign * 0.5 * eps);
                let d = (d - Vec3::Z * sign * eps).normalize();
                let t = tri.intersect(o, d, 0.0, inf);
                assert!(!t.is_nan(), "tilted {eps}: NaN");
                if t.is_finite() {
                    let p = o + t * d;
                    assert!(p.z.abs() < 1e-4 && p.x > -1e-4 && p.y > -1e-4 && p.x + p.y < 1.0 + 1e-4, "hit {p}");
                }
            }
        }
    }
    // From above, aimed exactly at points of the edges and at the vertices: never NaN,
    // and a hit is at the exact distance (1e-6).
    for k in 0..=8 {
        let f = k as f32 / 8.0;
        for target in [Vec3::new(f, 0.0, 0.0), Vec3::new(0.0, f, 0.0), Vec3::new(1.0 - f, f, 0.0)] {
            let o = Vec3::new(0.3, 0.2, 1.0);
            let d = (target - o).normalize();
            let t = tri.intersect(o, d, 0.0, inf);
            assert!(!t.is_nan());
            if t.is_finite() {
                assert!((t - (target - o).length()).abs() < 1e-6, "edge point {target}: t = {t}");
            }
        }
    }
    // At 89.9° to the normal over the triangle: hits inside, misses outside.
    let a = 0.1f32.to_radians();
    let d = Vec3::new(a.cos() * std::f32::consts::FRAC_1_SQRT_2, a.cos() * std::f32::consts::FRAC_1_SQRT_2, -a.sin());
    let over = |h: f32| tri.intersect(Vec3::new(0.05, 0.05, h), d, 0.0, inf);
    // Lands at 0.05 + h/tan(a)/√2 along each axis: h = 1e-4 → 0.0905 (inside), 1e-3 →
    // 0.455 (inside, x + y = 0.91), 1.5e-3 → 0.658 (outside, x + y = 1.3).
    assert!(over(1e-4).is_finite() && over(1e-3).is_finite());
    assert_eq!(over(1.5e-3), inf);
    // Tolerance: 1e-4 relative on t = h / sin(a).
    let t = over(1e-3);
    assert!((t - 1e-3 / a.sin()).abs() < 1e-4 * t, "grazing t = {t}");
}
