//! (e) PLY meshes: generated headers (formats, elements, property types, counts up to
//! 2^64 − 1) over ascii or random binary bodies, named by a mesh object of the default
//! scene. Counts the file cannot hold must be refused before anything is allocated.

use crate::harness::{cases, check_scene, run_property, TINY};
use proptest::prelude::*;
use wavetrace::DEFAULT_SCENE;

fn count() -> BoxedStrategy<String> {
    prop_oneof![
        8 => (0u64..6).prop_map(|n| n.to_string()),
        2 => prop::sample::select(vec!["2147483648", "4294967296", "9223372036854775807", "18446744073709551615", "18446744073709551616", "-1", "x", ""]).prop_map(String::from),
    ]
    .boxed()
}

fn ty() -> BoxedStrategy<&'static str> {
    prop::sample::select(vec![
        "float", "float32", "double", "uchar", "uint8", "char", "int", "int32", "uint", "short", "ushort", "float16",
        "list",
    ])
    .boxed()
}

fn header_line() -> BoxedStrategy<String> {
    prop_oneof![
        4 => count().prop_map(|n| format!("element vertex {n}")),
        3 => count().prop_map(|n| format!("element face {n}")),
        1 => count().prop_map(|n| format!("element edge {n}")),
        6 => (ty(), prop::sample::select(vec!["x", "y", "z", "nx", "ny", "nz", "red", "s"])).prop_map(|(t, n)| format!("property {t} {n}")),
        3 => (ty(), ty(), prop::sample::select(vec!["vertex_indices", "vertex_index", "other"])).prop_map(|(c, t, n)| format!("property list {c} {t} {n}")),
        1 => prop::sample::select(vec!["comment hi", "obj_info x", "format ascii 1.0", "format binary_big_endian 1.0", "bogus", "property", "element"]).prop_map(String::from),
    ]
    .boxed()
}

/// Whole PLY files: generated headers and bodies mostly, valid meshes now and then.
fn ply() -> BoxedStrategy<Vec<u8>> {
    let format = prop::sample::select(vec!["ascii", "binary_little_endian", "binary_big_endian", "binary"]);
    let header = prop_oneof![2 => Just(vec![VALID.to_string()]), 5 => prop::collection::vec(header_line(), 0..10)];
    let number = prop_oneof![
        6 => (-3i32..4).prop_map(|i| i.to_string()),
        2 => (-2.0f32..2.0).prop_map(|f| f.to_string()),
        1 => Just("nan".to_string()),
        1 => Just("1e39".to_string()),
        1 => Just("255".to_string()),
    ];
    let ascii_body = prop::collection::vec(number, 0..40).prop_map(|v| v.join(" ").into_bytes());
    let body = prop_oneof![ascii_body, prop::collection::vec(any::<u8>(), 0..400)];
    let generated = (format, header, body, any::<bool>()).prop_map(|(f, h, body, end)| {
        let mut out = format!("ply\nformat {f} 1.0\n{}\n", h.join("\n")).into_bytes();
        if end {
            out.extend(b"end_header\n");
        }
        out.extend(body);
        out
    });
    // A valid triangle (ascii or binary of either byte order), to reach the build.
    let valid =
        (prop::collection::vec(-3.0f32..3.0, 9..=9), any::<bool>(), any::<bool>()).prop_map(|(c, big, ascii)| {
            let f = if ascii {
                "ascii"
            } else if big {
                "binary_big_endian"
            } else {
                "binary_little_endian"
            };
            let mut out = format!("ply\nformat {f} 1.0\n{VALID}\nend_header\n").into_bytes();
            for x in &c {
                match (ascii, big) {
                    (true, _) => out.extend(format!("{x} ").bytes()),
                    (false, true) => out.extend(x.to_be_bytes()),
                    (false, false) => out.extend(x.to_le_bytes()),
                }
            }
            if ascii {
                out.extend(b"\n3 0 1 2\n");
            } else {
                out.push(3);
                for i in [0i32, 1, 2] {
                    out.extend(if big { i.to_be_bytes() } else { i.to_le_bytes() });
                }
            }
            out
        });
    prop_oneof![4 => generated, 1 => valid].boxed()
}

/// The header of one triangle.
const VALID: &str = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices";

#[test]
fn ply_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mesh.ply");
    let c = run_property("ply_mesh", (ply(), any::<bool>(), any::<bool>()), |(bytes, smooth, emit)| {
        std::fs::write(&path, bytes).map_err(|e| format!("cannot write the PLY: {e}"))?;
        let extra = if *emit { "emission = [1, 1, 1]\n" } else { "" };
        let text = format!(
            "{DEFAULT_SCENE}\n[[objects]]\ntype = \"mesh\"\nfile = \"mesh.ply\"\nmaterial = \"white\"\nsmooth = {smooth}\n{extra}"
        );
        check_scene(&text, dir.path(), &TINY.map(String::from))
    });
    if cases() >= 100 {
        assert!(c.loaded + c.rendered > 0, "no generated PLY loaded: the generator no longer reaches the build");
    }
}
