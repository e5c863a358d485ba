//! Fixed hostile inputs, no generators: minimal inputs of failures the fuzzing found and
//! src/ now refuses, two the generators never produce (a mesh `file` that is a device or a
//! pipe), and one minimal input per entry of [`crate::harness::KNOWN`].

use crate::harness::{check_scene, Verdict, TINY};
use crate::values::quote;
use std::path::{Path, PathBuf};
use wavetrace::DEFAULT_SCENE;

// ---------------------------------------------------------------------------------------
// Regressions: minimal inputs of failures this fuzzing found and src/ now refuses, and two
// the generators never produce.

/// The default scene plus a mesh object that names `file`.
fn scene_with_mesh(file: &Path) -> String {
    format!(
        "{DEFAULT_SCENE}\n[[objects]]\ntype = \"mesh\"\nfile = {}\nmaterial = \"white\"\n",
        quote(&file.display().to_string())
    )
}

/// A mesh `file` that is a device with no end: tobj would read it as one endless line (a
/// regression aborts this binary at the 1 GiB allocation guard).
#[test]
fn mesh_file_that_never_ends() {
    let verdict = check_scene(&scene_with_mesh(Path::new("/dev/zero")), Path::new("."), &TINY.map(String::from));
    assert_eq!(verdict, Ok(Verdict::Rejected));
}

/// A mesh `file` that is a named pipe with no writer: opening it would block for ever.
#[test]
fn mesh_file_that_is_a_pipe() {
    let dir = tempfile::tempdir().unwrap();
    let fifo: PathBuf = dir.path().join("mesh.obj");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("mkfifo unavailable: skipped");
        return;
    }
    let verdict = check_scene(&scene_with_mesh(&fifo), dir.path(), &TINY.map(String::from));
    assert_eq!(verdict, Ok(Verdict::Rejected));
}

/// One finite triangle and four that `scale = 1e38` pushes past f32::MAX: their edges were
/// inf - inf = NaN, the zero-area test let NaN through, and obvhs's PLOC build indexed out
/// of bounds on the NaN bounds (ploc/mod.rs:467; a debug assertion at :441).
#[test]
fn mesh_vertices_that_overflow_after_the_transform() {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = String::from("v 0 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n");
    for (i, x) in [4, 5, 6, 7].into_iter().enumerate() {
        let k = 3 * i + 4;
        obj += &format!("v {x} 0 0\nv {x} 1 0\nv {x} 0 1\nf {k} {} {}\n", k + 1, k + 2);
    }
    std::fs::write(dir.path().join("mesh.obj"), obj).unwrap();
    let text = scene_with_mesh(Path::new("mesh.obj")) + "scale = 1e38\n";
    assert_eq!(check_scene(&text, dir.path(), &TINY.map(String::from)), Ok(Verdict::Rejected));
}

/// `look_at - position` overflowed to infinity: `forward` was NaN, yet the scene loaded.
#[test]
fn camera_view_vector_that_overflows() {
    let text = DEFAULT_SCENE
        .replace("position = [0, 1, 3.9]", "position = [3e38, 1, 3.9]")
        .replace("look_at = [0, 1, 0]", "look_at = [-3e38, 1, 0]");
    assert_eq!(check_scene(&text, Path::new("."), &TINY.map(String::from)), Ok(Verdict::Rejected));
}

// ---------------------------------------------------------------------------------------
// Debug-only failures (overflow checks and debug assertions), fixed; release builds
// passed them before too.

/// tobj 4.0.5 computes `vt * 2 + 1` and `vn * 3 + 2` on indices that a relative (negative)
/// index below the start, or a huge one, makes close to `usize::MAX`: with overflow checks
/// on that was a panic inside tobj (found again by the `obj` fuzz target); in release the
/// wrapped bounds check could pass. src/scene/mesh.rs now refuses such an index, with its
/// line, before tobj sees it.
#[test]
fn obj_attribute_index_overflow_in_debug() {
    let dir = tempfile::tempdir().unwrap();
    for obj in [
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/-5 2/-5 3/-5\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//-5 2//-5 3//-5\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//9223372036854775807 2//1 3//1\n",
    ] {
        std::fs::write(dir.path().join("mesh.obj"), obj).unwrap();
        let verdict = check_scene(&scene_with_mesh(Path::new("mesh.obj")), dir.path(), &TINY.map(String::from));
        assert_eq!(verdict, Ok(Verdict::Rejected), "{obj}");
    }
}

/// Geometry that was within the old MAX_COORD (1e18) but too big for f32 products (now
/// refused at 4e9): a unit triangle scaled by
/// 2^32, a floor of 1e17 × 1e17. `|e1 × e2|²` overflows to infinity, normals and hit
/// points turn to zero or NaN, and obvhs's `Ray::new` asserts against the NaN directions in
/// debug builds (release renders finite pixels).
#[test]
fn huge_geometry_in_debug() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("mesh.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    for text in [
        scene_with_mesh(Path::new("mesh.obj")) + "scale = 4294967296\n",
        DEFAULT_SCENE.replacen(
            "edge_u = [2, 0, 0]\nedge_v = [0, 0, 2]",
            "edge_u = [1e17, 0, 0]\nedge_v = [0, 0, 1e17]",
            1,
        ),
    ] {
        let verdict = check_scene(&text, dir.path(), &TINY.map(String::from));
        assert!(matches!(verdict, Ok(Verdict::Rejected | Verdict::Rendered)), "{verdict:?} for\n{text}");
    }
}

/// An emissive mesh triangle inside MAX_COORD (4e9) whose edge cross product squares past
/// f32::MAX: its light's area and normal came out infinite and zero, and the loader hit an
/// `unreachable!` (found by the `scene_values` target). The length is now taken in f64
/// there; the scene loads and renders finite pixels.
#[test]
fn emissive_triangle_with_huge_area() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("mesh.obj"), "v -1 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\n").unwrap();
    let text = scene_with_mesh(Path::new("mesh.obj")) + "scale = 3.9e9\nemission = [1, 1, 1]\n";
    assert_eq!(check_scene(&text, dir.path(), &TINY.map(String::from)), Ok(Verdict::Rendered), "{text}");
}

/// width × height × BYTES_PER_PIXEL computed in u64 before the 2^32-pixel check: with
/// overflow checks on, a multiplication overflow panic in `settings()`.
#[test]
fn pixel_budget_overflow_in_debug() {
    let text =
        DEFAULT_SCENE.replace("width = 320", "width = 4294967295").replace("height = 240", "height = 4294967295");
    assert_eq!(check_scene(&text, Path::new("."), &[]), Ok(Verdict::Rejected));
}
