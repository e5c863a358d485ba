//! (c) OBJ meshes: generated OBJ text named by a mesh object of the default scene.

use crate::harness::{cases, check_scene, run_property, MAX_OBJ_BYTES, MAX_OBJ_LINES, TINY};
use crate::values::{cap, toml_float};
use proptest::prelude::*;
use wavetrace::DEFAULT_SCENE;

/// A coordinate: plain mostly, sometimes extreme or not a number at all.
fn coord() -> BoxedStrategy<String> {
    prop_oneof![
        12 => (-2.0f32..2.0).prop_map(|f| f.to_string()),
        3 => (-3i32..=3).prop_map(|i| i.to_string()),
        1 => prop::sample::select(&[
            "1e38", "-3.4e38", "3.5e38", "1e39", "nan", "NaN", "inf", "-inf", "infinity", "-0", "1e-45", "0x1", "1,5",
            "", "abc", "1e", "--1", "+1", ".", "1.5.5", "٣", "\u{0}",
        ][..])
        .prop_map(String::from),
        1 => any::<f32>().prop_map(|f| f.to_string()),
    ]
    .boxed()
}

/// A face index: in range mostly (meshes here have a handful of vertices), sometimes zero,
/// negative beyond the start, huge, or junk.
fn index() -> BoxedStrategy<String> {
    prop_oneof![
        12 => (1i64..=10).prop_map(|i| i.to_string()),
        4 => (-10i64..=-1).prop_map(|i| i.to_string()),
        1 => Just("0".to_string()),
        1 => prop::sample::select(&[
            i64::MAX, i64::MIN, i64::MIN + 1, 1 << 31, -(1 << 31), 1 << 32, u32::MAX as i64, 1 << 62,
        ][..])
        .prop_map(|i| i.to_string()),
        1 => prop::sample::select(&["", "x", "1.5", "1e3", "+1", "--1", "99999999999999999999999", "1 /2", "٣"][..])
            .prop_map(String::from),
    ]
    .boxed()
}

/// One vertex reference of a face: `v`, `v/t`, `v//n`, `v/t/n`, or too many slashes.
fn vertex_ref() -> BoxedStrategy<String> {
    prop_oneof![
        10 => index(),
        2 => (index(), index()).prop_map(|(v, t)| format!("{v}/{t}")),
        2 => (index(), index()).prop_map(|(v, n)| format!("{v}//{n}")),
        2 => (index(), index(), index()).prop_map(|(v, t, n)| format!("{v}/{t}/{n}")),
        1 => (index(), index()).prop_map(|(v, x)| format!("{v}/1/1/{x}")),
    ]
    .boxed()
}

fn obj_line() -> BoxedStrategy<String> {
    let v3 = || [coord(), coord(), coord()].prop_map(|c| c.join(" "));
    let name = || "[ -~]{0,12}";
    prop_oneof![
        30 => (v3(), prop_oneof![3 => Just(String::new()), 1 => coord(), 1 => v3()])
            .prop_map(|(c, extra)| format!("v {c} {extra}")),
        20 => (prop::sample::select(&["f", "f", "f", "l", "p", "F", "fo"][..]), prop::collection::vec(vertex_ref(), 0..8))
            .prop_map(|(k, refs)| format!("{k} {}", refs.join(" "))),
        4 => v3().prop_map(|c| format!("vn {c}")),
        4 => (coord(), coord(), prop_oneof![Just(String::new()), coord()]).prop_map(|(u, v, w)| format!("vt {u} {v} {w}")),
        1 => (coord(), coord()).prop_map(|(a, b)| format!("vp {a} {b}")),
        3 => (prop::sample::select(&["o", "g", "o", "g", "s", "usemtl", "mtllib"][..]), name())
            .prop_map(|(k, n)| format!("{k} {n}")),
        1 => Just("mtllib ../../../../etc/passwd".to_string()),
        1 => Just("mtllib mesh.obj".to_string()),
        2 => name().prop_map(|c| format!("# {c}")),
        2 => prop::sample::select(&["", " ", "\t", "\r", "\u{0}", "\u{feff}v 0 0 0", "  f 1 2 3", "v", "f", "#"][..])
            .prop_map(String::from),
        2 => "[ -~]{0,30}",
        1 => any::<String>().prop_map(|s| s.replace('\n', " ")),
        // Very long lines: a face with hundreds of references, a number with thousands of digits.
        1 => (100usize..1500).prop_map(|n| format!("f {}", (0..n).map(|i| (i % 7 + 1).to_string()).collect::<Vec<_>>().join(" "))),
        1 => (100usize..4000).prop_map(|n| format!("v 1{} 0 0", "0".repeat(n))),
        1 => (100usize..4000).prop_map(|n| format!("v 0.{} 0 0", "3".repeat(n))),
    ]
    .boxed()
}

/// Whole OBJ files: a few lines usually, now and then hundreds.
fn obj_text() -> BoxedStrategy<String> {
    let lines = prop_oneof![
        8 => prop::collection::vec(obj_line(), 0..40),
        1 => prop::collection::vec(obj_line(), 0..=MAX_OBJ_LINES),
    ];
    // Many copies of a valid triangle, to reach the BVH with a big mesh.
    let many = (1usize..=MAX_OBJ_LINES / 4).prop_map(|n| {
        let mut s = String::new();
        for i in 0..n {
            let x = i as f32 * 0.01;
            s.push_str(&format!("v {x} 0 0\nv {x} 1 0\nv {x} 0 1\nf -3 -2 -1\n"));
        }
        s
    });
    prop_oneof![
        10 => (lines, prop::sample::select(&["\n", "\r\n", "\r"][..]), any::<bool>()).prop_map(|(lines, nl, end)| {
            let mut s = lines.join(nl);
            if end {
                s.push_str(nl);
            }
            cap(s, MAX_OBJ_BYTES)
        }),
        1 => many,
    ]
    .boxed()
}

/// The mesh object's transform: plain usually, sometimes extreme.
fn transform() -> BoxedStrategy<(String, String, String)> {
    let scale = prop_oneof![
        8 => (0.05f64..3.0).prop_map(toml_float),
        1 => prop::sample::select(&["1e38", "3.4e38", "1e-30", "1e-45", "0", "-1", "-0.0"][..]).prop_map(String::from),
    ];
    let rotate = prop_oneof![4 => (-360.0f64..360.0).prop_map(toml_float), 1 => prop::sample::select(&["1e30", "3e38", "-3e38"][..]).prop_map(String::from)];
    let translate = prop_oneof![
        8 => Just("[0, 0.5, 0]".to_string()),
        1 => prop::sample::select(&["[3e38, 3e38, 3e38]", "[-3e38, 0, 3e38]", "[1e30, 0, 0]"][..]).prop_map(String::from),
    ];
    (scale, rotate, translate).boxed()
}

#[test]
fn obj_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mesh.obj");
    let c = run_property("obj_mesh", (obj_text(), transform()), |(obj, (scale, rotate, translate))| {
        assert!(obj.lines().count() <= MAX_OBJ_LINES + 1 && obj.len() <= MAX_OBJ_BYTES, "generator too big");
        std::fs::write(&path, obj).map_err(|e| format!("cannot write the OBJ: {e}"))?;
        let text = format!(
            "{DEFAULT_SCENE}\n[[objects]]\ntype = \"mesh\"\nfile = \"mesh.obj\"\nmaterial = \"white\"\n\
             scale = {scale}\nrotate_y = {rotate}\ntranslate = {translate}\n"
        );
        check_scene(&text, dir.path(), &TINY.map(String::from))
    });
    if cases() >= 100 {
        assert!(c.loaded + c.rendered > 0, "no generated mesh loaded: the generator no longer reaches the build");
    }
}
