//! Direct light from a rectangle light and from a triangle light on a diffuse wall, at
//! scales 1/550, 1 and 20 of a Cornell box's (coordinates ~1, ~500, ~1e4), against
//! Lambert's closed form for the irradiance of a polygon, computed in f64 here (and
//! checked against a midpoint rule over the light).
//!
//! The wall is the plane x = 0, as a quad object and as a two-triangle OBJ mesh: the
//! mesh wall of mitsuba-data's cbox-rgb.xml rendered 20–30% dark on its lower triangle,
//! whose shadow rays found that triangle again at t ≈ 10⁻⁶ (its hit points' error bound
//! is 0 across a plane x = 0, so their origins moved one denormal step, while the
//! triangle test's distance carried the rounding of the triangle's size).

mod support;

use glam::{DVec3, Vec3};
use std::f64::consts::PI;
use std::path::Path;
use support::toml::{camera, diffuse, mesh, quad, quad_light, vec3, V3};
use support::{only_pixel, scene, scene_in};
use wavetrace::light::area_light_samples;
use wavetrace::surface::Surface;
use wavetrace::{render, RenderOptions};

/// Radiance of the lights, one grey channel (cbox-rgb's green channel).
const RADIANCE: f64 = 10.987;
/// The wall's albedo (cbox-rgb's green wall, green channel).
const ALBEDO: f64 = 0.378;
/// Scales of the box: coordinates within ±1, the Cornell box's 550 units, 1.1e4.
const SCALES: [f64; 3] = [1.0 / 550.0, 1.0, 20.0];
/// Points on the wall x = 0 (y, z at scale 1): the seven, four on the wall's
/// lower triangle (y/548.8 + z/559.2 < 1), where its shadow rays hit it.
const POINTS: [[f64; 2]; 7] =
    [[384.8, 227.2], [316.0, 227.2], [281.6, 227.2], [247.2, 227.2], [191.8, 81.7], [54.8, 271.3], [44.2, 81.7]];

/// The emitters: cbox-rgb's luminaire (a rectangle facing down, −y), and the triangle
/// that is its half below the diagonal from (343, z 227) to (213, z 332), also facing
/// down. Vertices in order around each, at scale 1.
fn lights() -> [(&'static str, Vec<V3>); 2] {
    let (y, x0, x1, z0, z1) = (548.3, 213.0, 343.0, 227.0, 332.0);
    [
        ("rectangle", vec![[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]]),
        ("triangle", vec![[x0, y, z0], [x1, y, z0], [x0, y, z1]]),
    ]
}

fn scaled(v: V3, s: f64) -> V3 {
    v.map(|c| c * s)
}

/// A vertex as the scene holds it (f32), for the reference.
fn held(v: V3) -> DVec3 {
    DVec3::from_array(v).as_vec3().as_dvec3()
}

/// The light's TOML at scale `s`: a `quad` light (corner, edges along its sides) or a
/// `triangle` light. Both emit towards (v1 − v0) × (v2 − v0), here −y.
fn light_toml(verts: &[V3], s: f64) -> String {
    let v: Vec<V3> = verts.iter().map(|&v| scaled(v, s)).collect();
    let edge = |a: V3, b: V3| [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    if v.len() == 4 {
        quad_light(v[0], edge(v[0], v[1]), edge(v[0], v[3]), RADIANCE)
    } else {
        let r = vec3([RADIANCE; 3]);
        format!(
            "[[lights]]\ntype = \"triangle\"\nv0 = {}\nv1 = {}\nv2 = {}\nradiance = {r}\n",
            vec3(v[0]),
            vec3(v[1]),
            vec3(v[2])
        )
    }
}

/// Irradiance at `p` (unit normal `n`) from a convex polygon of unit radiance above the
/// tangent plane, by Lambert's formula: E = ½ |Σ θᵢ (n · γᵢ)|, θᵢ the angle the edge
/// from vertex i to i + 1 subtends at `p` (atan2, precise for small angles), γᵢ the unit
/// normal of the plane through `p` and that edge.
fn lambert(p: DVec3, n: DVec3, verts: &[DVec3]) -> f64 {
    let mut sum = 0.0;
    for (i, &v) in verts.iter().enumerate() {
        let (a, b) = ((v - p).normalize(), (verts[(i + 1) % verts.len()] - p).normalize());
        let c = a.cross(b);
        sum += c.length().atan2(a.dot(b)) * n.dot(c.normalize());
    }
    0.5 * sum.abs()
}

/// The same irradiance by the midpoint rule over the parallelogram `c + a·u + b·v`
/// (a, b in [0, 1]; with `triangle`, the cells below its diagonal a + b < 1, halved on
/// it), `m` × `m` cells: Σ cos θ cos θ' / r² dA.
fn midpoint(p: DVec3, n: DVec3, c: DVec3, u: DVec3, v: DVec3, triangle: bool, m: usize) -> f64 {
    let normal = u.cross(v).normalize();
    let cell = u.cross(v).length() / (m * m) as f64;
    let mut sum = 0.0;
    for i in 0..m {
        for j in 0..m {
            // Cells on the diagonal (i + j = m − 1) are cut in half by it.
            let w = match (triangle, i + j + 1) {
                (false, _) => 1.0,
                (true, k) if k < m => 1.0,
                (true, k) if k == m => 0.5,
                _ => 0.0,
            };
            let q = c + u * ((i as f64 + 0.5) / m as f64) + v * ((j as f64 + 0.5) / m as f64);
            let d = q - p;
            let r2 = d.length_squared();
            let wi = d / r2.sqrt();
            sum += w * n.dot(wi).max(0.0) * (-normal.dot(wi)).max(0.0) / r2;
        }
    }
    sum * cell
}

/// The diffuse radiance the wall sends back at `p` (on x = 0, normal +x) under light
/// `verts` at scale `s`: albedo / π · L · E, with the light's vertices as the scene
/// holds them.
fn expected(verts: &[V3], s: f64, p: DVec3) -> f64 {
    let v: Vec<DVec3> = verts.iter().map(|&v| held(scaled(v, s))).collect();
    ALBEDO / PI * RADIANCE * lambert(p, DVec3::X, &v)
}

/// The relative error allowed to an estimate from `n` of a light's stratified samples
/// (Owen-scrambled Sobol points): 8 n^-3/2 for a rectangle (a smooth integrand over the
/// square), 8 / n for a triangle (folding the square along its diagonal leaves a kink, so
/// the error falls as 1/n). The measured errors are at least 6 times smaller (rectangle
/// 6e-7 at n = 4096 and 9e-6 at 1024, triangle 3.1e-4 and 5.0e-4); the self-shadowed
/// mesh wall was 20–30% dark.
fn tolerance(verts: &[V3], n: u32) -> f64 {
    let n = n as f64;
    if verts.len() == 3 {
        8.0 / n
    } else {
        8.0 / (n * n.sqrt())
    }
}

/// The wall x = 0 at scale `s`: a quad object, or a mesh of two triangles written to
/// `dir` (the quad face 1 2 3 4 cut along 1–3, from (y 0, z 559.2) to (548.8, 0)).
fn wall(s: f64, as_mesh: bool, dir: &Path) -> String {
    let (h, w) = (548.8 * s, 559.2 * s);
    if !as_mesh {
        return quad([0.0; 3], [0.0, h, 0.0], [0.0, 0.0, w], "green");
    }
    let obj = format!("v 0 0 {w}\nv 0 0 0\nv 0 {h} 0\nv 0 {h} {w}\nf 1 2 3 4\n");
    std::fs::write(dir.join("wall.obj"), obj).expect("write the wall mesh");
    mesh("wall.obj", "green", &[])
}

/// The radiance of one pixel looking at `p` on the wall from the direction of the
/// issue's camera at (278, 273, −800)·s, but 10·s away (its footprint, which the one
/// camera ray samples, then spans 2e-4·s: a relative change of the irradiance below
/// 1e-6): `samples` shadow rays per light in shadow `mode`.
fn measure(scene_text: &str, dir: &Path, s: f64, p: DVec3, samples: u32, mode: &str) -> f64 {
    let eye = p + (DVec3::from_array(scaled([278.0, 273.0, -800.0], s)) - p).normalize() * (10.0 * s);
    let text = camera(eye.to_array(), p.to_array(), &["up=[0, 1, 0]", "fov_y=0.001"]) + scene_text;
    let sets = [
        "render.width=1".to_string(),
        "render.height=1".to_string(),
        "render.aa.samples=1".to_string(),
        format!("render.shadows.samples={samples}"),
        format!("render.shadows.mode={mode}"),
    ];
    let sets: Vec<&str> = sets.iter().map(String::as_str).collect();
    let scene = scene_in(dir, &text, &sets);
    let out = render(&scene, &RenderOptions { threads: Some(1), ..Default::default() }).expect("render");
    let l = only_pixel(&out);
    assert!(l.x == l.y && l.y == l.z, "a grey light on a grey wall stays grey: {l}");
    l.y as f64
}

#[test]
fn lambert_reference_matches_a_midpoint_rule() {
    // The two references share nothing but the geometry: agreement to 1e-6 checks the
    // closed form's signs and factors. The midpoint rule's error falls as 1/m²: at
    // m = 600 it measured 5e-8 relative on the rectangle, 5e-7 on the triangle (whose
    // diagonal cells are halved).
    for (name, verts) in lights() {
        let v: Vec<DVec3> = verts.iter().map(|&v| DVec3::from_array(v)).collect();
        let far = if v.len() == 4 { v[3] } else { v[2] };
        let (c, u, w) = (v[0], v[1] - v[0], far - v[0]);
        for [y, z] in POINTS {
            let p = DVec3::new(0.0, y, z);
            let closed = lambert(p, DVec3::X, &v);
            let numeric = midpoint(p, DVec3::X, c, u, w, v.len() == 3, 600);
            let rel = (closed - numeric).abs() / closed;
            assert!(rel < 1e-6, "{name} at {p}: Lambert {closed} vs midpoint {numeric} (rel {rel:e})");
        }
    }
}

#[test]
fn light_samples_sum_to_the_irradiance_at_every_scale() {
    // The light sampling alone (no shadow rays): area_light_samples' contributions,
    // unoccluded, are the estimate.
    for (name, verts) in lights() {
        for s in SCALES {
            let text = camera([0.0, 0.0, -1.0], [0.0; 3], &[]) + &light_toml(&verts, s);
            let scene = scene(&text, &["render.shadows.samples=4096"]);
            for [y, z] in POINTS {
                let p = DVec3::new(0.0, y * s, z * s);
                let surf = Surface {
                    o: p.as_vec3(),
                    n: Vec3::X,
                    wo: Vec3::new(1.0, 0.0, -1.0).normalize(),
                    color: Vec3::splat(ALBEDO as f32),
                    specular: Vec3::ZERO,
                    shininess: 0.0,
                    w: Vec3::ONE,
                    slot: 0,
                    key: 0x5eed,
                    sample: 0,
                };
                let mut sum = 0.0f64;
                area_light_samples(&scene, &surf, 0, |_, _, _, l| sum += l.y as f64);
                let want = expected(&verts, s, p);
                let rel = (sum - want).abs() / want;
                assert!(
                    rel < tolerance(&verts, 4096),
                    "{name} light, scale {s}, at {p}: sampled {sum} vs {want} (rel {rel:e})"
                );
            }
        }
    }
}

#[test]
fn wall_radiance_matches_lambert_for_quad_and_mesh_walls_at_every_scale() {
    let dir = tempfile::tempdir().expect("temporary folder");
    for (name, verts) in lights() {
        for s in SCALES {
            for as_mesh in [false, true] {
                let text = diffuse("green", [ALBEDO; 3]) + &wall(s, as_mesh, dir.path()) + &light_toml(&verts, s);
                for [y, z] in POINTS {
                    let p = DVec3::new(0.0, y * s, z * s);
                    let want = expected(&verts, s, p);
                    let what = format!("{name} light, {} wall, scale {s}, at {p}", ["quad", "mesh"][as_mesh as usize]);
                    // Uniform: 1024 stratified shadow rays, every one unblocked (nothing
                    // lies between the wall and the light).
                    let got = measure(&text, dir.path(), s, p, 1024, "uniform");
                    let rel = (got - want).abs() / want;
                    assert!(rel < tolerance(&verts, 1024), "{what}: uniform {got} vs Lambert {want} (rel {rel:e})");
                    // Adaptive: every probe reaches the light, so the point is lit and
                    // gets the closed form itself, in f32 (measured below 3e-6): 1e-4, as
                    // tests/radiometry.rs.
                    let got = measure(&text, dir.path(), s, p, 16, "adaptive");
                    let rel = (got - want).abs() / want;
                    assert!(rel < 1e-4, "{what}: adaptive {got} vs Lambert {want} (rel {rel:e})");
                }
            }
        }
    }
}
