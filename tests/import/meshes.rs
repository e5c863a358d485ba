//! Meshes: PLY in every encoding, smooth normals (from the file, or computed as Mitsuba
//! computes them) and emissive meshes.

use glam::Vec3;
use std::f32::consts::PI;
use wavetrace::accel::Shape;
use wavetrace::scene::mesh::vertex_normals;
use wavetrace::scene::Light;

use crate::support::{only_pixel, probe_camera, scene_in};
use crate::Files;

/// A PLY of `verts` (with `normals` when given) and triangles, in `format`.
fn ply(format: &str, verts: &[Vec3], normals: Option<&[Vec3]>, tris: &[[u32; 3]]) -> Vec<u8> {
    let mut head = format!(
        "ply\nformat {format} 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        verts.len()
    );
    if normals.is_some() {
        head += "property float nx\nproperty float ny\nproperty float nz\n";
    }
    head += &format!("element face {}\nproperty list uchar uint vertex_indices\nend_header\n", tris.len());
    let mut out = head.into_bytes();
    let big = format == "binary_big_endian";
    let num = |out: &mut Vec<u8>, x: f32| match format {
        "ascii" => out.extend(format!("{x} ").bytes()),
        _ if big => out.extend(x.to_be_bytes()),
        _ => out.extend(x.to_le_bytes()),
    };
    for (i, v) in verts.iter().enumerate() {
        for x in v.to_array().into_iter().chain(normals.map(|n| n[i].to_array()).into_iter().flatten()) {
            num(&mut out, x);
        }
        if format == "ascii" {
            out.push(b'\n');
        }
    }
    for t in tris {
        if format == "ascii" {
            out.extend(format!("3 {} {} {}\n", t[0], t[1], t[2]).bytes());
        } else {
            out.push(3);
            for i in t {
                out.extend(if big { i.to_be_bytes() } else { i.to_le_bytes() });
            }
        }
    }
    out
}

const BASE: &str = "[render]\nwidth = 1\nheight = 1\n[render.aa]\nsamples = 1\n[materials.white]\ntype = \"diffuse\"\ncolor = [0.5, 0.5, 0.5]\n";

fn mesh_scene(file: &str, extra: &str) -> String {
    format!("{BASE}[camera]\nposition = [0, 3, 4]\nlook_at = [0, 0, 0]\n[[objects]]\ntype = \"mesh\"\nfile = \"{file}\"\nmaterial = \"white\"\n{extra}\n")
}

/// A tent: two triangles sharing the edge (0,0,0)–(0,0,1), one flat, one rising.
fn tent() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let v = vec![Vec3::ZERO, Vec3::Z, Vec3::new(1.0, 0.0, 0.0), Vec3::new(-1.0, 1.0, 0.0)];
    (v, vec![[0, 1, 2], [0, 3, 1]])
}

#[test]
fn ply_encodings_give_the_same_triangles() {
    let f = Files::temp();
    let (v, t) = tent();
    let mut prims = Vec::new();
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        f.write("m.ply", ply(format, &v, None, &t));
        let scene = scene_in(f.dir(), &mesh_scene("m.ply", ""), &[]);
        let mut shapes: Vec<String> = scene.accel.prims().map(|p| format!("{:?}", p.shape)).collect();
        shapes.sort();
        prims.push(shapes);
    }
    assert_eq!(prims[0].len(), 2);
    assert!(prims[1] == prims[0] && prims[2] == prims[0], "{prims:?}");
    // A broken PLY names the scene field, the mesh and the element.
    f.write("bad.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n3 0 1 2\n");
    let err = crate::support::try_scene_in(f.dir(), &mesh_scene("bad.ply", ""), &[]).err().unwrap().to_string();
    assert!(
        err.contains("objects.0.file")
            && err.contains("bad.ply")
            && err.contains("element `face` 0: vertex index 1 is out of range"),
        "{err}"
    );
}

#[test]
fn computed_vertex_normals_weight_faces_by_angle_as_mitsuba() {
    let (v, t) = tent();
    let n = vertex_normals(&v, &t);
    // Vertex 0: the flat face (normal -y... its winding: (0,0,1)×(1,0,0) = +y) meets it
    // at 90°, the rising face ((-1,1,0)×(0,0,1) = (1,1,0)/√2) at 90° too: equal weights.
    let flat = Vec3::Y;
    let rising = Vec3::new(1.0, 1.0, 0.0).normalize();
    assert!(n[0].abs_diff_eq((flat + rising).normalize(), 1e-6), "{}", n[0]);
    // Vertex 2 belongs to the flat face only; vertex 3 to the rising one only.
    assert!(n[2].abs_diff_eq(flat, 1e-6) && n[3].abs_diff_eq(rising, 1e-6));
    // Unequal angles: vertex 0 of a fan whose faces meet it at 90° and 45°.
    let v = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.0, 1.0, 1.0)];
    let n = vertex_normals(&v, &[[0, 1, 2], [0, 2, 3]]);
    let (a, b) = (Vec3::Z, Vec3::Y.cross(Vec3::new(0.0, 1.0, 1.0)).normalize());
    let want = (a * (PI / 2.0) + b * (PI / 4.0)).normalize();
    assert!(n[0].abs_diff_eq(want, 1e-6), "{} vs {want}", n[0]);
    // An isolated vertex gets Mitsuba's placeholder (1, 0, 0).
    assert_eq!(vertex_normals(&[Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE], &[[0, 1, 2]])[3], Vec3::X);
}

#[test]
fn smooth_shading_uses_the_interpolated_normal_and_flat_the_face() {
    // A big triangle in the plane y = 0 whose file normals all lean to +x: lit by a point
    // light straight above, a smooth point sees cos = n_s · up, a flat one cos = 1.
    let f = Files::temp();
    let v = [Vec3::new(-10.0, 0.0, 10.0), Vec3::new(10.0, 0.0, 10.0), Vec3::new(0.0, 0.0, -10.0)];
    let ns = Vec3::new(0.6, 0.8, 0.0);
    f.write("tilt.ply", ply("binary_little_endian", &v, Some(&[ns; 3]), &[[0, 1, 2]]));
    let p = Vec3::new(0.0, 0.0, 0.0);
    let light = "[[lights]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = [4, 4, 4]\n";
    let text = |smooth: bool| {
        let base = mesh_scene("tilt.ply", &format!("smooth = {smooth}\n"))
            .replace("[camera]\nposition = [0, 3, 4]\nlook_at = [0, 0, 0]\n", "");
        format!("{base}{}{light}", probe_camera(p + Vec3::new(0.0, 3.0, 4.0), p))
    };
    let render = |smooth| {
        let scene = scene_in(f.dir(), &text(smooth), &[]);
        assert_eq!(scene.normals.is_empty(), !smooth);
        only_pixel(&wavetrace::render(&scene, &Default::default()).unwrap()).x
    };
    let lambert = 0.5 / PI * 4.0 / 4.0; // albedo/π · I / r², r = 2
    let (flat, smooth) = (render(false), render(true));
    // Tolerance 1e-4: the probe pixel sees a patch a few 1e-5 wide around p, where r and
    // the offset origin differ from the closed form's by that much.
    assert!((flat - lambert).abs() < 1e-4 * lambert, "flat {flat} vs {lambert}");
    assert!((smooth - lambert * 0.8).abs() < 1e-4 * lambert, "smooth {smooth} vs {}", lambert * 0.8);
    // A non-uniform scale turns file normals by the inverse transpose: scaling x by 2
    // gives n ∝ (0.6 / 2, 0.8, 0).
    let scaled = text(true).replace("smooth = true", "smooth = true\ntransform = [{ scale = [2, 1, 1] }]");
    let scene = scene_in(f.dir(), &scaled, &[]);
    let want = Vec3::new(0.3, 0.8, 0.0).normalize();
    assert!(scene.normals.iter().all(|n| n.iter().all(|v| v.abs_diff_eq(want, 1e-6))), "{:?}", scene.normals);
}

#[test]
fn emissive_mesh_triangles_become_one_sided_lights() {
    let f = Files::temp();
    let (v, t) = tent();
    f.write("lamp.ply", ply("ascii", &v, None, &t));
    let text = mesh_scene("lamp.ply", "emission = [2, 3, 4]").replace("material = \"white\"\n", "");
    let scene = scene_in(f.dir(), &text, &[]);
    assert_eq!(scene.lights.len(), 2);
    for l in &scene.lights {
        let Light::Triangle { normal, area, radiance, .. } = *l else { panic!("{l:?}") };
        assert_eq!(radiance, Vec3::new(2.0, 3.0, 4.0));
        assert!(area > 0.49 && area < 0.71, "{area}");
        assert!(normal.y > 0.0, "counter-clockwise front: {normal}");
    }
    // Every emitting primitive names its light.
    let lit: Vec<u32> = scene.accel.prims().map(|p| p.light).collect();
    assert!(lit.contains(&0) && lit.contains(&1));
    assert!(scene.accel.prims().all(|p| matches!(p.shape, Shape::Triangle { .. })));
    // flip_normals turns the emitting side over.
    let flipped = scene_in(f.dir(), &format!("{text}flip_normals = true\n"), &[]);
    assert!(flipped.lights.iter().all(|l| matches!(l, Light::Triangle { normal, .. } if normal.y < 0.0)));
}
