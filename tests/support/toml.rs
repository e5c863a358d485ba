//! Scene text in pieces: each function writes one TOML table, so that a test names the
//! values that matter and the syntax is written once. A scene is the pieces in order,
//! `[render_block(..), camera(..), diffuse(..), point_light(..), sphere(..)].concat()`.
//!
//! Optional keys are given as `--set` gives them, `key=value`: the value a TOML literal
//! (`4`, `0.5`, `[1, 0, 0]`, `"fresnel"`) or else a bare string (`adaptive`). A vector is
//! `[f64; 3]`, written so that TOML reads back the same number (whole numbers as
//! integers, which the loader reads as the same `f32`).

/// A coordinate or colour.
pub type V3 = [f64; 3];

/// A number as a TOML literal that reads back as `x`: whole numbers as integers, others
/// in Rust's shortest round-trip form. Past 1e15 a whole number is written as a float
/// (it need not fit a TOML integer), and so is -0 (an integer has no sign to keep).
pub fn num(x: f64) -> String {
    assert!(x.is_finite(), "{x} has no TOML literal here");
    if x == x.trunc() && x.abs() < 1e15 && !(x == 0.0 && x.is_sign_negative()) {
        format!("{x}")
    } else {
        format!("{x:?}")
    }
}

/// A vector as a TOML array.
pub fn vec3(v: V3) -> String {
    format!("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2]))
}

/// `key=value` lines (as `--set` takes them) as TOML lines; a value that is not a TOML
/// literal is a bare string, as the loader reads `--set render.aa.mode=adaptive`.
fn keys(sets: &[&str]) -> String {
    let mut s = String::new();
    for set in sets {
        let (key, value) = set.split_once('=').unwrap_or_else(|| panic!("`{set}` is not key=value"));
        let literal = ::toml::from_str::<::toml::Table>(&format!("v = {value}")).is_ok();
        s += &if literal { format!("{key} = {value}\n") } else { format!("{key} = {value:?}\n") };
    }
    s
}

/// The `[render]` table from `key=value` settings under it (`width=24`, `aa.samples=2`,
/// `shadows.mode=adaptive`).
pub fn render_block(sets: &[&str]) -> String {
    format!("[render]\n{}", keys(sets))
}

/// The `[camera]` at `position` looking at `look_at`, with further keys (`fov_y=30.0`,
/// `aperture=0.5`).
pub fn camera(position: V3, look_at: V3, sets: &[&str]) -> String {
    format!("[camera]\nposition = {}\nlook_at = {}\n{}", vec3(position), vec3(look_at), keys(sets))
}

/// A `[background]` of one colour.
pub fn background(color: V3) -> String {
    format!("[background]\ncolor = {}\n", vec3(color))
}

/// `[materials.NAME]` of type `ty` with its keys (`color=[1, 1, 1]`, `ior=1.5`).
pub fn material(name: &str, ty: &str, sets: &[&str]) -> String {
    format!("[materials.{name}]\ntype = {ty:?}\n{}", keys(sets))
}

/// A diffuse material.
pub fn diffuse(name: &str, color: V3) -> String {
    material(name, "diffuse", &[&format!("color={}", vec3(color))])
}

/// A mirror material.
pub fn mirror(name: &str, color: V3) -> String {
    material(name, "mirror", &[&format!("color={}", vec3(color))])
}

/// A dielectric material of index `ior` (the reflect ratio by Fresnel).
pub fn dielectric(name: &str, ior: f64) -> String {
    material(name, "dielectric", &[&format!("ior={}", num(ior))])
}

/// A point light of grey intensity.
pub fn point_light(position: V3, intensity: f64) -> String {
    format!("[[lights]]\ntype = \"point\"\nposition = {}\nintensity = {}\n", vec3(position), vec3([intensity; 3]))
}

/// A one-sided quad light of grey radiance, emitting towards `edge_u × edge_v`.
pub fn quad_light(corner: V3, edge_u: V3, edge_v: V3, radiance: f64) -> String {
    format!(
        "[[lights]]\ntype = \"quad\"\ncorner = {}\nedge_u = {}\nedge_v = {}\nradiance = {}\n",
        vec3(corner),
        vec3(edge_u),
        vec3(edge_v),
        vec3([radiance; 3])
    )
}

/// What the edge tests look at: a camera at (0, 0, 5) looking at the origin, with further
/// keys (`fov_y=30.0`), and a quad light of radiance 1 facing it in the plane z = 0, from
/// x = -5 to x = -5 + `width` and y = -5 to 5. Its right edge is the vertical edge under
/// test.
pub fn wall(width: f64, camera_sets: &[&str]) -> String {
    camera([0.0, 0.0, 5.0], [0.0; 3], camera_sets)
        + &quad_light([-5.0, -5.0, 0.0], [width, 0.0, 0.0], [0.0, 10.0, 0.0], 1.0)
}

/// A quad object.
pub fn quad(corner: V3, edge_u: V3, edge_v: V3, material: &str) -> String {
    format!(
        "[[objects]]\ntype = \"quad\"\ncorner = {}\nedge_u = {}\nedge_v = {}\nmaterial = {material:?}\n",
        vec3(corner),
        vec3(edge_u),
        vec3(edge_v)
    )
}

/// A sphere object.
pub fn sphere(center: V3, radius: f64, material: &str) -> String {
    format!(
        "[[objects]]\ntype = \"sphere\"\ncenter = {}\nradius = {}\nmaterial = {material:?}\n",
        vec3(center),
        num(radius)
    )
}

/// A mesh object from `file` (relative to the scene's folder), with further keys
/// (`scale=0.3`, `rotate_y=30`).
pub fn mesh(file: &str, material: &str, sets: &[&str]) -> String {
    format!("[[objects]]\ntype = \"mesh\"\nfile = {file:?}\nmaterial = {material:?}\n{}", keys(sets))
}

/// A mesh object scaled by `scale`, turned by `rotate_y` degrees about y, then moved by
/// `translate`.
pub fn placed_mesh(file: &str, material: &str, scale: f64, rotate_y: f64, translate: V3) -> String {
    let (scale, rotate_y, translate) = (num(scale), num(rotate_y), vec3(translate));
    mesh(
        file,
        material,
        &[&format!("scale={scale}"), &format!("rotate_y={rotate_y}"), &format!("translate={translate}")],
    )
}

/// `s·v + t`: a point of a test world drawn at scale `s` and moved by `t`.
pub fn place(v: V3, s: f64, t: V3) -> V3 {
    [v[0] * s + t[0], v[1] * s + t[1], v[2] * s + t[2]]
}
