//! Camera and transform conversions against hand-computed values.

use glam::Vec3;
use wavetrace::accel::Shape;

use crate::{load_file, Files};

/// tan(fov_y / 2) of a W×H perspective sensor with the given fov parameters.
fn tan_half_fov(w: u32, h: u32, params: &str) -> f32 {
    let f = Files::temp();
    let text = format!(
        "<scene version=\"3.0.0\"><sensor type=\"perspective\">{params}\
         <film type=\"hdrfilm\"><integer name=\"width\" value=\"{w}\"/><integer name=\"height\" value=\"{h}\"/></film>\
         </sensor></scene>"
    );
    load_file(&f.write("cam.xml", text)).camera.tan_half_fov
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-5 * b.abs()
}

#[test]
fn fov_axis_conversions() {
    let fov =
        |v: f32, axis: &str| format!("<float name=\"fov\" value=\"{v}\"/><string name=\"fov_axis\" value=\"{axis}\"/>");
    // x: 90° across a 2:1 image, so the half-height is half the half-width.
    assert!(close(tan_half_fov(200, 100, &fov(90.0, "x")), 0.5));
    // The default axis is x.
    assert!(close(tan_half_fov(200, 100, "<float name=\"fov\" value=\"90\"/>"), 0.5));
    // y: the vertical field itself.
    assert!(close(tan_half_fov(200, 100, &fov(60.0, "y")), (30f32).to_radians().tan()));
    // diagonal: 90° over the diagonal of a 4:3 image, half-diagonal 1 = (0.8, 0.6).
    assert!(close(tan_half_fov(400, 300, &fov(90.0, "diagonal")), 0.6));
    // smaller / larger on a portrait 1:2 image: x is the smaller axis, y the larger.
    assert!(close(tan_half_fov(100, 200, &fov(90.0, "smaller")), 2.0));
    assert!(close(tan_half_fov(100, 200, &fov(60.0, "larger")), (30f32).to_radians().tan()));
    // ... and on a landscape 2:1 image the other way round.
    assert!(close(tan_half_fov(200, 100, &fov(60.0, "smaller")), (30f32).to_radians().tan()));
}

#[test]
fn focal_length_uses_the_36_by_24_mm_film() {
    // On a 3:2 image the film is exactly 36×24 mm: tan(fov_y / 2) = 12 mm / f.
    let fl = |f: &str| format!("<string name=\"focal_length\" value=\"{f}\"/>");
    assert!(close(tan_half_fov(300, 200, &fl("50mm")), 12.0 / 50.0));
    assert!(close(tan_half_fov(300, 200, &fl("24")), 12.0 / 24.0));
    // No fov and no focal length: Mitsuba's default 50 mm.
    assert!(close(tan_half_fov(300, 200, ""), 12.0 / 50.0));
    // On another aspect the diagonal (43.27 mm) is kept: a square image's half-side is
    // 43.27 / (2·√2) mm.
    let half = (36f32 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * 2f32.sqrt());
    assert!(close(tan_half_fov(100, 100, &fl("35mm")), half / 35.0));
}

#[test]
fn camera_frame_follows_mitsuba_lookat() {
    let f = Files::temp();
    let text = "<scene version=\"3.0.0\"><sensor type=\"perspective\"><float name=\"fov\" value=\"45\"/>\
        <transform name=\"to_world\"><lookat origin=\"1, 2, 3\" target=\"1, 2, 0\" up=\"0, 1, 0\"/></transform>\
        </sensor></scene>";
    let cam = load_file(&f.write("c.xml", text)).camera;
    assert_eq!(
        (cam.position, cam.forward, cam.up, cam.right),
        (Vec3::new(1.0, 2.0, 3.0), Vec3::NEG_Z, Vec3::Y, Vec3::X)
    );
    // Mitsuba's default film is 768×576.
    assert_eq!(cam.aspect, 768.0 / 576.0);
    // A mirrored camera (scale x = -1 on the frame) flips the image: right becomes -x.
    let text = text.replace("<lookat", "<scale x=\"-1\"/><lookat");
    let cam = load_file(&f.write("m.xml", text)).camera;
    assert_eq!((cam.forward, cam.right), (Vec3::NEG_Z, Vec3::NEG_X));
}

#[test]
fn transform_composition_matches_a_hand_computed_matrix() {
    // scale (2, 1, 1), then rotate 90° about z, then translate (1, 2, 3): the rectangle's
    // corner (-1, -1, 0) → (-2, -1, 0) → (1, -2, 0) → (2, 0, 3); its edges (2, 0, 0) →
    // (0, 4, 0) and (0, 2, 0) → (-2, 0, 0).
    let f = Files::temp();
    let body = "<shape type=\"rectangle\"><transform name=\"to_world\"><scale x=\"2\"/><rotate z=\"1\" angle=\"90\"/><translate x=\"1\" y=\"2\" z=\"3\"/></transform></shape>";
    let scene = load_file(&f.write("t.xml", crate::xml_scene(body)));
    let Shape::Quad { corner, u, v } = scene.accel.prim(0).shape else { panic!("not a quad") };
    let eq = |a: Vec3, b: Vec3| a.abs_diff_eq(b, 1e-6);
    assert!(
        eq(corner, Vec3::new(2.0, 0.0, 3.0)) && eq(u, Vec3::new(0.0, 4.0, 0.0)) && eq(v, Vec3::new(-2.0, 0.0, 0.0)),
        "{corner} {u} {v}"
    );
    // The same as one <matrix>, row by row.
    let m = "<matrix value=\"0 -1 0 1  2 0 0 2  0 0 1 3  0 0 0 1\"/>";
    let body = format!("<shape type=\"rectangle\"><transform name=\"to_world\">{m}</transform></shape>");
    let scene = load_file(&f.write("m.xml", crate::xml_scene(&body)));
    let Shape::Quad { corner: c2, u: u2, v: v2 } = scene.accel.prim(0).shape else { panic!("not a quad") };
    assert!(eq(c2, corner) && eq(u2, u) && eq(v2, v), "{c2} {u2} {v2}");
}
