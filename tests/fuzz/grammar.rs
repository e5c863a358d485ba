//! (b) Scenes from the schema's grammar: tables, keys and tagged types, plus unknown keys,
//! values of the wrong type and random `--set` overrides.

use crate::harness::{cases, check_scene, run_property, MAX_SCENE_BYTES};
use crate::values::{cap, key, odd_value, plain_number, quote, standard_sets, toml_float};
use proptest::prelude::*;

/// What a field of the schema holds.
#[derive(Clone, Copy, Debug)]
enum Kind {
    /// A u32 that must be at least 1 (samples, sizes).
    Count,
    /// Any u32 (max_depth, seed).
    Int,
    /// An adaptive refinement level, 2..=16.
    Level,
    /// Any f32.
    Real,
    /// An f32 that must be > 0 (radius, ior, fov_y, scale...).
    Positive,
    /// An f32 that must be >= 0 (aperture, shininess).
    NonNegative,
    Vec3,
    Color,
    Bool,
    Word(&'static [&'static str]),
    Ratio,
    MaterialRef,
    MeshFile,
    /// `camera.shutter`: two times, valid when 0 ≤ open ≤ close ≤ 1.
    Shutter,
    /// `transform_end`: a short transform list.
    Motion,
}

/// A field: name, kind, and how often it is present.
type Field = (&'static str, Kind, f64);

/// Material names: the first three usually, the rest are odd keys.
const MATERIAL_NAMES: &[&str] = &["white", "red", "glass"];
const ODD_MATERIAL_NAMES: &[&str] = &["m", "", "a.b", "é", " ", "white "];

/// A value for a field of `kind`: valid usually, invalid now and then, and now and then
/// extreme, of the wrong type, or not TOML at all.
fn field_value(kind: Kind) -> BoxedStrategy<String> {
    let real = |lo: f64, hi: f64| {
        prop_oneof![
            2 => ((lo.ceil() as i64)..=(hi.floor() as i64)).prop_map(|i| i.to_string()),
            3 => (lo..hi).prop_map(toml_float),
        ]
    };
    let vec3 = || [real(-3.0, 3.0), real(-3.0, 3.0), real(-3.0, 3.0)].prop_map(|v| format!("[{}]", v.join(", ")));
    let (valid, invalid): (BoxedStrategy<String>, BoxedStrategy<String>) = match kind {
        Kind::Count => (
            (1u32..=4).prop_map(|n| n.to_string()).boxed(),
            prop_oneof![Just(0u32), any::<u32>()].prop_map(|n| n.to_string()).boxed(),
        ),
        Kind::Int => ((0u32..=8).prop_map(|n| n.to_string()).boxed(), any::<u32>().prop_map(|n| n.to_string()).boxed()),
        Kind::Level => {
            ((2u32..=6).prop_map(|n| n.to_string()).boxed(), (0u32..=20).prop_map(|n| n.to_string()).boxed())
        }
        Kind::Real => (real(-3.0, 3.0).boxed(), real(-1e3, 1e3).boxed()),
        Kind::Positive => (real(0.05, 3.0).boxed(), real(-3.0, 0.0).boxed()),
        Kind::NonNegative => (real(0.0, 1.0).boxed(), real(-3.0, 0.0).boxed()),
        Kind::Vec3 => (vec3().boxed(), Just("[0, 0, 0]".to_string()).boxed()),
        Kind::Color => (
            [0.0f64..20.0, 0.0f64..20.0, 0.0f64..20.0]
                .prop_map(|v| format!("[{}]", v.map(toml_float).join(", ")))
                .boxed(),
            vec3().boxed(),
        ),
        Kind::Bool => (any::<bool>().prop_map(|b| b.to_string()).boxed(), Just("\"true\"".to_string()).boxed()),
        Kind::Word(words) => (
            prop::sample::select(words).prop_map(quote).boxed(),
            prop::sample::select(&["", "Uniform", "none", "3X3", " uniform"][..]).prop_map(quote).boxed(),
        ),
        Kind::Ratio => (
            prop_oneof![real(0.0, 1.0), Just("\"fresnel\"".to_string())].boxed(),
            prop_oneof![real(-1.0, 3.0), Just("\"Fresnel\"".to_string()), Just("\"\"".to_string())].boxed(),
        ),
        Kind::MaterialRef => (
            prop::sample::select(MATERIAL_NAMES).prop_map(quote).boxed(),
            prop::sample::select(ODD_MATERIAL_NAMES).prop_map(quote).boxed(),
        ),
        // Never a device or a pipe here: see `mesh_file_that_never_ends`.
        Kind::MeshFile => (
            Just(quote("mesh.obj")).boxed(),
            prop::sample::select(
                &["missing.obj", "", ".", "..", "sub/../mesh.obj", "mesh.obj/", "\u{0}", "/nonexistent/x.obj"][..],
            )
            .prop_map(quote)
            .boxed(),
        ),
        Kind::Shutter => (
            (0.0f64..=1.0, 0.0f64..=1.0)
                .prop_map(|(a, b)| format!("[{}, {}]", toml_float(a.min(b)), toml_float(a.max(b))))
                .boxed(),
            (real(-1.0, 2.0), real(-1.0, 2.0)).prop_map(|(a, b)| format!("[{a}, {b}]")).boxed(),
        ),
        Kind::Motion => {
            let step = |scale: BoxedStrategy<String>, axis: BoxedStrategy<String>| {
                prop_oneof![
                    vec3().prop_map(|v| format!("{{ translate = {v} }}")),
                    (axis, real(-400.0, 400.0))
                        .prop_map(|(a, d)| format!("{{ rotate = {{ axis = {a}, angle = {d} }} }}")),
                    scale.prop_map(|s| format!("{{ scale = [{s}, {s}, {s}] }}")),
                ]
            };
            let list = |scale: BoxedStrategy<String>, axis: BoxedStrategy<String>| {
                prop::collection::vec(step(scale, axis), 0..4).prop_map(|steps| format!("[{}]", steps.join(", ")))
            };
            (
                list(real(0.2, 3.0).boxed(), vec3().boxed()).boxed(),
                // A mirror (singular somewhere in between), a zero scale, a zero axis.
                list(real(-3.0, 0.0).boxed(), Just("[0, 0, 0]".to_string()).boxed()).boxed(),
            )
        }
    };
    prop_oneof![90 => valid, 4 => invalid, 1 => odd_value(), 1 => plain_number()].boxed()
}

/// `key = value` lines for a table, each field present as often as its spec says, and
/// now and then an unknown key.
fn fields(spec: &'static [Field]) -> BoxedStrategy<Vec<String>> {
    let each: Vec<BoxedStrategy<Option<String>>> = spec
        .iter()
        .map(|&(name, kind, p)| {
            prop::option::weighted(p, field_value(kind)).prop_map(move |v| v.map(|v| format!("{name} = {v}"))).boxed()
        })
        .collect();
    let unknown = prop::option::weighted(
        0.02,
        (prop::sample::select(&["bogus", "Width", "colour", "type", "extra.key", "\"\""][..]), plain_number())
            .prop_map(|(k, v)| format!("{k} = {v}")),
    );
    (each, unknown).prop_map(|(each, unknown)| each.into_iter().flatten().chain(unknown).collect()).boxed()
}

/// A table header and its lines.
fn section(header: &'static str, spec: &'static [Field]) -> BoxedStrategy<String> {
    fields(spec).prop_map(move |lines| format!("{header}\n{}\n", lines.join("\n"))).boxed()
}

/// The body of a tagged table: `type = "..."` (one of `types`, rarely not) and that
/// type's fields.
fn tagged(types: &'static [(&'static str, &'static [Field])]) -> BoxedStrategy<String> {
    let variants: Vec<BoxedStrategy<String>> = types
        .iter()
        .map(|&(ty, spec)| {
            let ty = prop_oneof![30 => Just(quote(ty)), 1 => field_value(Kind::Word(&["", "Sphere", "cube"]))];
            (ty, fields(spec)).prop_map(move |(ty, lines)| format!("type = {ty}\n{}\n", lines.join("\n"))).boxed()
        })
        .collect();
    prop::strategy::Union::new(variants).boxed()
}

const RENDER: &[Field] = &[
    ("width", Kind::Count, 0.8),
    ("height", Kind::Count, 0.8),
    ("max_depth", Kind::Int, 0.6),
    ("seed", Kind::Int, 0.5),
];
const AA: &[Field] = &[
    ("mode", Kind::Word(&["uniform", "adaptive"]), 0.9),
    ("samples", Kind::Count, 0.6),
    ("eps", Kind::NonNegative, 0.5),
    ("min_level", Kind::Level, 0.5),
    ("max_level", Kind::Level, 0.5),
    ("share_corners", Kind::Bool, 0.5),
];
const SHADOWS: &[Field] = &[
    ("mode", Kind::Word(&["uniform", "adaptive"]), 0.9),
    ("samples", Kind::Count, 0.6),
    ("probe", Kind::Word(&["corners", "corners+center", "jittered", "3x3"]), 0.6),
];
const DOF: &[Field] = &[("samples", Kind::Count, 0.9)];
const CAMERA: &[Field] = &[
    ("position", Kind::Vec3, 0.97),
    ("look_at", Kind::Vec3, 0.97),
    ("up", Kind::Vec3, 0.5),
    ("fov_y", Kind::Positive, 0.7),
    ("aperture", Kind::NonNegative, 0.3),
    ("focus_distance", Kind::Positive, 0.3),
    ("shutter", Kind::Shutter, 0.3),
    ("transform_end", Kind::Motion, 0.1),
];
const BACKGROUND: &[Field] = &[("color", Kind::Color, 0.9)];
const DIFFUSE: &[Field] =
    &[("color", Kind::Color, 0.97), ("specular", Kind::Color, 0.5), ("shininess", Kind::NonNegative, 0.5)];
const MIRROR: &[Field] = &[("color", Kind::Color, 0.97)];
const DIELECTRIC: &[Field] =
    &[("ior", Kind::Positive, 0.97), ("reflect_ratio", Kind::Ratio, 0.5), ("color", Kind::Color, 0.5)];
const QUAD_LIGHT: &[Field] = &[
    ("corner", Kind::Vec3, 0.97),
    ("edge_u", Kind::Vec3, 0.97),
    ("edge_v", Kind::Vec3, 0.97),
    ("radiance", Kind::Color, 0.97),
    ("transform_end", Kind::Motion, 0.02),
];
const POINT_LIGHT: &[Field] = &[("position", Kind::Vec3, 0.97), ("intensity", Kind::Color, 0.97)];
const SPHERE: &[Field] = &[
    ("center", Kind::Vec3, 0.97),
    ("radius", Kind::Positive, 0.97),
    ("material", Kind::MaterialRef, 0.97),
    ("transform_end", Kind::Motion, 0.2),
];
const QUAD: &[Field] = &[
    ("corner", Kind::Vec3, 0.97),
    ("edge_u", Kind::Vec3, 0.97),
    ("edge_v", Kind::Vec3, 0.97),
    ("material", Kind::MaterialRef, 0.97),
    ("transform_end", Kind::Motion, 0.2),
];
const MESH: &[Field] = &[
    ("file", Kind::MeshFile, 0.97),
    ("material", Kind::MaterialRef, 0.97),
    ("scale", Kind::Positive, 0.5),
    ("rotate_y", Kind::Real, 0.5),
    ("translate", Kind::Vec3, 0.5),
    ("transform_end", Kind::Motion, 0.2),
];
const MATERIAL_TYPES: &[(&str, &[Field])] = &[("diffuse", DIFFUSE), ("mirror", MIRROR), ("dielectric", DIELECTRIC)];
const LIGHT_TYPES: &[(&str, &[Field])] = &[("quad", QUAD_LIGHT), ("point", POINT_LIGHT)];
const OBJECT_TYPES: &[(&str, &[Field])] = &[("sphere", SPHERE), ("quad", QUAD), ("mesh", MESH)];

/// `[materials.NAME]` tables with distinct names (a repeated name is a TOML error the
/// mutations already cover).
fn material_sections() -> BoxedStrategy<Vec<String>> {
    let names = (
        prop_oneof![9 => prop::sample::subsequence(MATERIAL_NAMES, 2..=3), 1 => prop::sample::subsequence(MATERIAL_NAMES, 0..=3)],
        prop::option::weighted(0.1, prop::sample::select(ODD_MATERIAL_NAMES)),
    );
    names
        .prop_flat_map(|(names, odd)| {
            names
                .into_iter()
                .chain(odd)
                .map(|name| tagged(MATERIAL_TYPES).prop_map(move |body| format!("[materials.{}]\n{body}", key(name))))
                .collect::<Vec<_>>()
        })
        .boxed()
}

/// `[render]` with `aa` either as its own `[render.aa]` table or inline.
fn render_sections() -> BoxedStrategy<String> {
    let aa = prop::option::weighted(0.5, (any::<bool>(), fields(AA)));
    (prop::option::weighted(0.7, fields(RENDER)), aa)
        .prop_map(|(render, aa)| match aa {
            Some((true, aa)) => {
                let mut lines = render.unwrap_or_default();
                lines.push(format!("aa = {{ {} }}", aa.join(", ")));
                format!("[render]\n{}\n", lines.join("\n"))
            }
            Some((false, aa)) => {
                let render = render.map(|l| format!("[render]\n{}\n", l.join("\n"))).unwrap_or_default();
                format!("{render}[render.aa]\n{}\n", aa.join("\n"))
            }
            None => render.map(|l| format!("[render]\n{}\n", l.join("\n"))).unwrap_or_default(),
        })
        .boxed()
}

/// `--set` overrides beyond the tiny-render ones: known and unknown keys, array indices,
/// malformed forms.
fn extra_set() -> BoxedStrategy<String> {
    let keys = prop::sample::select(vec![
        "render.width",
        "render.height",
        "render.max_depth",
        "render.aa.mode",
        "render.aa.max_level",
        "render.shadows.probe",
        "render.dof.samples",
        "camera.fov_y",
        "camera.position",
        "camera.position.0",
        "camera.position.9",
        "objects.0.radius",
        "objects.0.type",
        "objects.99.radius",
        "objects.x.radius",
        "lights.0.radiance",
        "materials.white.color",
        "materials.white.color.1",
        "render",
        "camera",
        "bogus",
        "",
        "a..b",
        ".",
        " render.width ",
    ]);
    prop_oneof![
        6 => (keys, prop_oneof![plain_number(), odd_value(), "[ -~]{0,12}"]).prop_map(|(k, v)| format!("{k}={v}")),
        1 => "[ -~]{0,20}",
    ]
    .boxed()
}

#[test]
fn grammar_scene() {
    let dir = tempfile::tempdir().unwrap();
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    std::fs::write(dir.path().join("mesh.obj"), obj).unwrap();
    let unknown_table =
        prop::sample::select(&["[bogus]\nx = 1\n", "[render.bogus]\n", "[[render]]\n", "[camera.lens]\n"][..]);
    let parts = (
        render_sections(),
        prop::option::weighted(0.4, section("[render.shadows]", SHADOWS)),
        prop::option::weighted(0.3, section("[render.dof]", DOF)),
        prop::option::weighted(0.97, section("[camera]", CAMERA)),
        prop::option::weighted(0.4, section("[background]", BACKGROUND)),
        material_sections(),
        prop::collection::vec(tagged(LIGHT_TYPES).prop_map(|b| format!("[[lights]]\n{b}")), 0..3),
        prop::collection::vec(tagged(OBJECT_TYPES).prop_map(|b| format!("[[objects]]\n{b}")), 0..6),
        prop::option::weighted(0.03, unknown_table),
        prop::option::weighted(0.1, any::<(prop::sample::Index, prop::sample::Index)>()),
    );
    let scene = parts.prop_map(|(render, shadows, dof, camera, background, mats, lights, objs, unknown, swap)| {
        // Sections in the usual order, sometimes two swapped: TOML allows that, except
        // where it splits a table (`[render.aa]` before an inline `aa`), which it refuses.
        let mut blocks: Vec<String> = [Some(render), shadows, dof, camera, background].into_iter().flatten().collect();
        blocks.extend(mats);
        blocks.extend(lights);
        blocks.extend(objs);
        blocks.extend(unknown.map(String::from));
        if let (Some((a, b)), false) = (swap, blocks.is_empty()) {
            let n = blocks.len();
            blocks.swap(a.index(n), b.index(n));
        }
        cap(blocks.concat(), MAX_SCENE_BYTES)
    });
    let sets = (standard_sets(), prop::collection::vec(extra_set(), 0..3), 0..5usize).prop_map(|(mut s, extra, n)| {
        // Extra overrides in one case out of five.
        if n == 0 {
            s.extend(extra);
        }
        s
    });
    let c = run_property("grammar_scene", (scene, sets), |(text, sets)| check_scene(text, dir.path(), sets));
    if cases() >= 100 {
        assert!(c.loaded + c.rendered > 0, "no generated scene loaded: the grammar no longer reaches the build");
    }
}
