//! Watertight closed meshes: no ray from inside escapes through an edge or a vertex,
//! near the origin or far from it, tested against the triangles and through the BVH.

use super::mesh_dir;
use crate::support::toml::{camera, diffuse, placed_mesh};
use crate::support::{closest, scene_in, Lcg};
use glam::{DVec3, Vec3};

/// Rays from inside a closed mesh towards its vertices, along its edges (every triangle
/// edge, the cube's face diagonals included) and at its face centres: returns (escaped
/// through the BVH, escaped when every triangle is tested directly, total). A watertight
/// triangle test lets none escape the direct test; a conservative BVH none escape at all.
fn leaks(mesh: &str, translate: [f64; 3], scale: f64) -> (usize, usize, usize) {
    let dir = mesh_dir();
    let object = placed_mesh(mesh, "m", scale, 30.0, translate);
    let text = [camera([0.0, 0.0, 1e6], [0.0; 3], &[]), diffuse("m", [1.0; 3]), object].concat();
    let scene = scene_in(dir.path(), &text, &[]);
    let centre = DVec3::from_array(translate).as_vec3();
    // The triangles' vertices, transformed exactly as the loader does.
    let rot = glam::Quat::from_rotation_y(30f32.to_radians());
    let (sc, tr) = (scale as f32, centre);
    let xf = |p: Vec3| rot * (p * sc) + tr;
    let tris = wavetrace::scene::mesh::load_obj(&dir.path().join(mesh)).unwrap();
    assert_eq!(scene.info.triangles, tris.len());
    let mut targets = Vec::new();
    for tri in &tris {
        let v = tri.map(xf);
        targets.push((v[0] + v[1] + v[2]) / 3.0);
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            for j in 0..=16 {
                targets.push(a + (b - a) * (j as f32 / 16.0));
            }
        }
    }
    let mut rng = Lcg(5);
    let mut origins = vec![centre];
    for _ in 0..40 {
        // Inside the octahedron |x|+|y|+|z| < 1 (so inside the cube too), times 0.8.
        let mut p = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        p *= 0.8 * rng.next() / (p.x.abs() + p.y.abs() + p.z.abs()).max(1e-3);
        origins.push(centre + p * scale as f32);
    }
    let (mut escaped, mut brute, mut total) = (0, 0, 0);
    for &o in &origins {
        for &target in &targets {
            let d = (target - o).normalize();
            total += 1;
            let direct =
                scene.accel.prims().map(|p| p.shape.intersect(o, d, 0.0, f32::INFINITY)).fold(f32::INFINITY, f32::min);
            brute += direct.is_infinite() as usize;
            match closest(&scene, o, d) {
                None => escaped += 1,
                Some((t, _)) => {
                    // Tolerance: the hit is where the ray meets the surface, 1e-3 relative plus
                    // 8 float spacings of the position (targets and origins are rounded).
                    let expect = (target - o).length();
                    let tol = 1e-3 * expect + 8.0 * f32::EPSILON * centre.abs().max_element();
                    assert!((t - expect).abs() < tol, "{mesh}: hit at t = {t}, target at {expect}");
                }
            }
        }
    }
    (escaped, brute, total)
}

#[test]
fn closed_mesh_winding_is_outward() {
    // The fixture itself: every triangle's e1 × e2 points away from the centre.
    for mesh in ["cube.obj", "octa.obj"] {
        let dir = mesh_dir();
        let text = format!(
            "[camera]\nposition = [0, 0, 9]\nlook_at = [0, 0, 0]\n[materials.m]\ntype = \"diffuse\"\ncolor = [1, 1, 1]\n\
             [[objects]]\ntype = \"mesh\"\nfile = \"{mesh}\"\nmaterial = \"m\"\n"
        );
        let scene = scene_in(dir.path(), &text, &[]);
        assert_eq!(scene.info.triangles, if mesh == "cube.obj" { 12 } else { 8 });
        for prim in scene.accel.prims() {
            let (lo, hi) = prim.shape.bounds();
            let inside_face = (lo + hi) * 0.5; // on the face's outer side of the centre
            assert!(prim.shape.normal(inside_face).dot(inside_face) > 0.0, "{mesh}: inward triangle");
        }
    }
}

/// Leak counts of `mesh` near the origin (unit and skewed placement) and far from it:
/// (report lines, total BVH escapes, total direct escapes).
fn leak_report(mesh: &str) -> (Vec<String>, usize, usize) {
    let (mut report, mut bvh, mut direct) = (Vec::new(), 0, 0);
    for (t, s) in [([0.0; 3], 1.0), ([0.3, -0.2, 0.1], 1.7), ([1e5; 3], 1.7), ([1e4, -3e4, 2e4], 3.3)] {
        let (escaped, brute, total) = leaks(mesh, t, s);
        report.push(format!("{mesh} at {t:?} ×{s}: {escaped} of {total} escaped the BVH, {brute} the triangles"));
        bvh += escaped;
        direct += brute;
    }
    eprintln!("{report:#?}");
    (report, bvh, direct)
}

#[test]
fn no_ray_escapes_a_closed_mesh_through_its_edges_and_vertices() {
    // Tolerance: zero escaped rays, near the origin and 1e4..1e5 away. The cube's faces
    // are split along diagonals, so this also covers edges shared inside a face. Tested
    // against every triangle directly (the triangle test must be watertight: Möller–
    // Trumbore lets about 4% of these rays through), and through the BVH for the cube.
    let (report, bvh, direct) = leak_report("cube.obj");
    assert_eq!((bvh, direct), (0, 0), "{report:#?}");
    let (report, _, direct) = leak_report("octa.obj");
    assert_eq!(direct, 0, "{report:#?}");
}

#[test]
fn no_ray_escapes_the_bvh_of_a_closed_octahedron() {
    // Tolerance: zero escaped rays. Each octahedron face's bounding box has the shared
    // vertices on its faces and corners, where the slab distances tie exactly and
    // rounding can make the ray miss the box of the triangle it must hit.
    let (report, bvh, _) = leak_report("octa.obj");
    assert_eq!(bvh, 0, "{report:#?}");
}
