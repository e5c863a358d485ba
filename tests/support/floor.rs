//! The scene most render tests start from: a diffuse floor quad under a square quad
//! light, with spheres standing on it. [`FloorScene::default`] is the canonical one;
//! a test changes the parts it needs (struct update syntax) and calls
//! [`FloorScene::toml`].

use super::toml::{self, V3};

/// A one-sided quad light emitting towards `edge_u × edge_v`, with grey radiance.
#[derive(Clone, Copy, Debug)]
pub struct QuadLight {
    pub corner: [f32; 3],
    pub edge_u: [f32; 3],
    pub edge_v: [f32; 3],
    pub radiance: f32,
}

impl QuadLight {
    /// A square of side `side` centred over the origin at height `y`, facing down.
    pub fn square(y: f32, side: f32, radiance: f32) -> QuadLight {
        QuadLight {
            corner: [-side / 2.0, y, -side / 2.0],
            edge_u: [side, 0.0, 0.0],
            edge_v: [0.0, 0.0, side],
            radiance,
        }
    }
}

/// A quad object.
#[derive(Clone, Copy, Debug)]
pub struct Quad {
    pub corner: [f32; 3],
    pub edge_u: [f32; 3],
    pub edge_v: [f32; 3],
    pub material: &'static str,
}

impl Quad {
    /// The floor: the square `[-half, half]²` of the plane y = 0, normal +y.
    pub fn floor(half: f32, material: &'static str) -> Quad {
        Quad { corner: [-half, 0.0, -half], edge_u: [0.0, 0.0, 2.0 * half], edge_v: [2.0 * half, 0.0, 0.0], material }
    }
}

/// A sphere object.
#[derive(Clone, Copy, Debug)]
pub struct Sphere {
    pub center: [f32; 3],
    pub radius: f32,
    pub material: &'static str,
}

impl Sphere {
    /// A sphere of the default `white` material: an occluder.
    pub fn white(center: [f32; 3], radius: f32) -> Sphere {
        Sphere { center, radius, material: "white" }
    }
}

/// A floor under a quad light with spheres on it; see the module documentation.
#[derive(Clone, Debug)]
pub struct FloorScene {
    /// `[render]` and its sub-tables, verbatim, at the top of the text (empty: defaults).
    pub render: &'static str,
    pub position: [f32; 3],
    pub look_at: [f32; 3],
    /// `None`: the loader's default field of view.
    pub fov_y: Option<f32>,
    /// `None`: no `[background]` table (black).
    pub background: Option<[f32; 3]>,
    /// `[materials.NAME]` tables in order: the name and the table's lines.
    pub materials: Vec<(&'static str, String)>,
    pub light: QuadLight,
    /// The first object.
    pub floor: Quad,
    /// Objects after the floor.
    pub spheres: Vec<Sphere>,
}

impl Default for FloorScene {
    /// A 2×2 light of radiance 3 at height 3 over a 10×10 white floor with a white
    /// sphere of radius 0.5 at the origin, seen from 4 units away.
    fn default() -> FloorScene {
        FloorScene {
            render: "",
            position: [0.0, 1.0, 4.0],
            look_at: [0.0, 0.4, 0.0],
            fov_y: None,
            background: None,
            materials: vec![FloorScene::diffuse("white", [0.8; 3])],
            light: QuadLight::square(3.0, 2.0, 3.0),
            floor: Quad::floor(5.0, "white"),
            spheres: vec![Sphere { center: [0.0, 0.5, 0.0], radius: 0.5, material: "white" }],
        }
    }
}

/// The f64 of the decimal an f32 prints as, so the text shows `0.4`, not the f32's exact
/// binary value `0.4000000059604645`, and still loads as the same f32.
fn wide1(x: f32) -> f64 {
    x.to_string().parse().expect("an f32 prints as a decimal")
}

fn wide(v: [f32; 3]) -> V3 {
    v.map(wide1)
}

impl FloorScene {
    /// A diffuse material table.
    pub fn diffuse(name: &'static str, color: [f32; 3]) -> (&'static str, String) {
        (name, format!("type = \"diffuse\"\ncolor = {}", toml::vec3(wide(color))))
    }

    /// The shadow test bench of scenes/penumbra.toml: a 1×1 light of radiance 6 at height
    /// 3 over an 8×8 white floor, seen from above and in front; no spheres yet.
    pub fn overhead() -> FloorScene {
        FloorScene {
            position: [0.0, 3.2, 4.2],
            look_at: [0.0, 0.3, 0.0],
            fov_y: Some(45.0),
            light: QuadLight::square(3.0, 1.0, 6.0),
            floor: Quad::floor(4.0, "white"),
            spheres: Vec::new(),
            ..FloorScene::default()
        }
    }

    /// A grey 6×6 floor under a 1×1 quad light at height 2, with a sphere of radius 0.35
    /// on it: edges and a soft shadow, for the sweep and study tests; `render` is the
    /// `[render]` block.
    pub fn tiny(render: &'static str) -> FloorScene {
        FloorScene {
            render,
            position: [0.0, 2.0, 4.0],
            look_at: [0.0, 0.3, 0.0],
            fov_y: Some(45.0),
            materials: vec![FloorScene::diffuse("grey", [0.7; 3])],
            light: QuadLight::square(2.0, 1.0, 5.0),
            floor: Quad::floor(3.0, "grey"),
            spheres: vec![Sphere { center: [0.0, 0.6, 0.0], radius: 0.35, material: "grey" }],
            ..FloorScene::default()
        }
    }

    /// The scene text.
    pub fn toml(&self) -> String {
        let fov = self.fov_y.map(|f| format!("fov_y={f}"));
        let mut s = String::from(self.render);
        s += &toml::camera(wide(self.position), wide(self.look_at), fov.as_deref().as_slice());
        if let Some(c) = self.background {
            s += &toml::background(wide(c));
        }
        for (name, body) in &self.materials {
            s += &format!("[materials.{name}]\n{body}\n");
        }
        let (l, f) = (&self.light, &self.floor);
        s += &toml::quad_light(wide(l.corner), wide(l.edge_u), wide(l.edge_v), wide1(l.radiance));
        s += &toml::quad(wide(f.corner), wide(f.edge_u), wide(f.edge_v), f.material);
        for sp in &self.spheres {
            s += &toml::sphere(wide(sp.center), wide1(sp.radius), sp.material);
        }
        s
    }
}
