//! The command line: success paths, and every bad-input case exits 2 with a message
//! naming the file, line and field, leaving no output file behind.

mod support;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use support::{FloorScene, Quad, QuadLight, Sphere};

const BIN: &str = env!("CARGO_BIN_EXE_wavetrace");

/// A small valid scene (a glass sphere on a floor under a quad light); each bad case
/// replaces one piece of it.
fn good() -> String {
    FloorScene {
        render: "[render]\nwidth = 8\nheight = 6\n[render.aa]\nsamples = 2\n[render.shadows]\nsamples = 2\n",
        position: [0.0, 1.0, 5.0],
        look_at: [0.0, 1.0, 0.0],
        materials: vec![FloorScene::diffuse("white", [0.8; 3]), ("glass", "type = \"dielectric\"\nior = 1.5".into())],
        light: QuadLight::square(1.99, 1.0, 10.0),
        floor: Quad::floor(2.0, "white"),
        spheres: vec![Sphere { center: [0.0, 1.0, 0.0], radius: 1.0, material: "glass" }],
        ..FloorScene::default()
    }
    .toml()
}

/// `scene.toml:LINE:COLUMN` of the value of the first `key = ...` line of [`good`]: where
/// an error in that value must be reported.
fn at(key: &str) -> String {
    let prefix = format!("{key} = ");
    let line = good().lines().position(|l| l.starts_with(&prefix)).unwrap_or_else(|| panic!("no {key} in the fixture"));
    format!("scene.toml:{}:{}", line + 1, prefix.len() + 1)
}

struct Case {
    dir: tempfile::TempDir,
}

impl Case {
    fn new() -> Case {
        Case { dir: tempfile::tempdir().expect("tempdir") }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    fn write(&self, name: &str, text: &str) -> PathBuf {
        let p = self.path(name);
        std::fs::write(&p, text).expect("write");
        p
    }

    fn run(&self, args: &[&str]) -> Output {
        Command::new(BIN).args(args).current_dir(self.dir.path()).output().expect("run wavetrace")
    }

    /// Files in the case folder other than the inputs.
    fn outputs(&self, inputs: &[&str]) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(self.dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| !inputs.contains(&n.as_str()))
            .collect();
        v.sort();
        v
    }
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Renders `scene` (after replacing `from` by `to`) and expects exit 2, a message with
/// every one of `needles`, and no file written.
fn bad_scene(from: &str, to: &str, needles: &[&str]) {
    let good = good();
    assert!(good.contains(from), "fixture lacks {from:?}");
    let case = Case::new();
    case.write("scene.toml", &good.replacen(from, to, 1));
    let out = case.run(&["scene.toml", "-o", "out.png"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "expected exit 2 for {to:?}; stderr: {err}");
    for n in needles {
        assert!(err.contains(n), "message for {to:?} lacks {n:?}: {err}");
    }
    assert!(case.outputs(&["scene.toml"]).is_empty(), "files left behind: {:?}", case.outputs(&["scene.toml"]));
}

#[test]
fn good_scene_renders_and_writes_stats_json() {
    let case = Case::new();
    case.write("scene.toml", &good());
    let out =
        case.run(&["render", "scene.toml", "-o", "out.png", "--stats", "--stats-json", "s.json", "--threads", "2"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("Mrays/s") && stdout.contains("intersect"), "{stdout}");
    let img = image_dims(&case.path("out.png"));
    assert_eq!(img, (8, 6));
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(case.path("s.json")).unwrap()).unwrap();
    for key in ["width", "height", "seconds", "total_rays", "mrays_per_s", "rays", "stages"] {
        assert!(json.get(key).is_some(), "stats JSON lacks {key}");
    }
    // A TOML scene keeps the paper's transport, and says so.
    let depth = json["max_depth"].as_u64().expect("max_depth");
    assert_eq!(json["transport"].as_str(), Some("whitted"));
    assert!(stdout.contains(&format!("8x6 whitted (max_depth {depth}): ")), "{stdout}");
    let rays = &json["rays"];
    let sum = rays["camera"].as_u64().unwrap() + rays["shadow"].as_u64().unwrap() + rays["secondary"].as_u64().unwrap();
    assert_eq!(sum, json["total_rays"].as_u64().unwrap(), "ray kinds must sum to the total");
    assert_eq!(rays["camera"].as_u64().unwrap(), 8 * 6 * 2);
    assert_eq!(json["stages"]["camera"]["rays_out"], rays["camera"]);
    assert_eq!(json["stages"]["shadow"]["rays_in"], rays["shadow"]);
    assert_eq!(json["stages"]["scatter"]["rays_out"], rays["secondary"]);
    // ns per ray: seconds (summed over threads) over the rays read, or written for camera.
    for (stage, items) in
        [("camera", "rays_out"), ("intersect", "rays_in"), ("shade", "rays_in"), ("shadow", "rays_in")]
    {
        let st = &json["stages"][stage];
        let expected = st["seconds"].as_f64().unwrap() * 1e9 / st[items].as_f64().unwrap();
        let got = st["ns_per_ray"].as_f64().unwrap();
        assert!((got - expected).abs() <= 1e-9 * expected.max(1.0), "{stage}: ns_per_ray {got}, expected {expected}");
    }
    assert_eq!(json["stages"]["penumbra"]["ns_per_ray"], 0.0, "a stage that ran on nothing costs 0");
    // Per thread the same definition (a thread that got no tile has nothing to divide).
    for t in json["per_thread"].as_array().unwrap() {
        let st = &t["stages"]["intersect"];
        let (secs, n) = (st["seconds"].as_f64().unwrap(), st["rays_in"].as_f64().unwrap());
        let expected = if n > 0.0 { secs * 1e9 / n } else { 0.0 };
        let got = st["ns_per_ray"].as_f64().unwrap();
        assert!((got - expected).abs() <= 1e-9 * expected.max(1.0), "per thread: {got} vs {expected}");
    }
    assert!(stdout.contains("ns/ray"), "{stdout}");
    assert_eq!(case.outputs(&["scene.toml"]), vec!["out.png".to_string(), "s.json".to_string()]);
}

fn image_dims(p: &Path) -> (u32, u32) {
    let img = image::open(p).expect("readable PNG");
    (img.width(), img.height())
}

#[test]
fn no_arguments_renders_the_default_scene_to_render_png() {
    let case = Case::new();
    let out = case.run(&[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert_eq!(image_dims(&case.path("render.png")), (320, 240));
    assert!(String::from_utf8_lossy(&out.stdout).contains("Mrays/s"));
    // Not a terminal: no progress bar, nothing on stderr.
    assert!(out.stderr.is_empty(), "stderr: {}", stderr(&out));
}

#[test]
#[cfg(feature = "exr")]
fn exr_output_is_linear_float() {
    let case = Case::new();
    case.write("scene.toml", &good());
    let out = case.run(&["scene.toml", "-o", "out.exr", "--quiet"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(out.stdout.is_empty(), "--quiet prints nothing");
    let img = exr::prelude::read_first_rgba_layer_from_file(
        case.path("out.exr"),
        |res, _| vec![[0f32; 3]; res.width() * res.height()],
        |px: &mut Vec<[f32; 3]>, pos, (r, g, b, _a): (f32, f32, f32, f32)| px[pos.y() * 8 + pos.x()] = [r, g, b],
    )
    .expect("readable EXR");
    let px = &img.layer_data.channel_data.pixels;
    assert_eq!(px.len(), 48);
    assert!(px.iter().flatten().any(|&v| v > 0.0), "some light");
}

#[test]
fn toml_syntax_error_names_line_and_column() {
    bad_scene("radius = 1", "radius = = 1", &[&at("radius")]);
}

#[test]
fn unknown_field() {
    bad_scene("radius = 1", "radius = 1\nradus = 2.0", &["scene.toml:", "radus"]);
}

#[test]
fn missing_field() {
    bad_scene("radius = 1\n", "", &["scene.toml:", "radius"]);
}

#[test]
fn missing_camera() {
    bad_scene("[camera]\nposition = [0, 1, 5]\nlook_at = [0, 1, 0]\n", "", &["scene.toml", "camera"]);
}

#[test]
fn unknown_material() {
    bad_scene("material = \"glass\"", "material = \"gold\"", &["scene.toml:", "objects.1.material", "gold"]);
}

#[test]
fn zero_and_negative_radius() {
    bad_scene("radius = 1", "radius = 0.0", &[&at("radius"), "objects.1.radius"]);
    bad_scene("radius = 1", "radius = -2", &[&at("radius"), "objects.1.radius"]);
}

#[test]
fn ior_must_be_positive() {
    bad_scene("ior = 1.5", "ior = 0", &[&at("ior"), "materials.glass.ior"]);
    bad_scene("ior = 1.5", "ior = -1.5", &["materials.glass.ior"]);
}

#[test]
fn non_finite_numbers_anywhere() {
    bad_scene("radius = 1", "radius = nan", &[&at("radius"), "objects.1.radius", "finite"]);
    bad_scene("position = [0, 1, 5]", "position = [0, inf, 5]", &["scene.toml:", "camera.position.1", "finite"]);
    bad_scene("radiance = [10, 10, 10]", "radiance = [10, -inf, 10]", &["lights.0.radiance.1", "finite"]);
    bad_scene("radius = 1", "radius = 1e300", &["objects.1.radius", "finite"]);
}

#[test]
fn width_height_zero_or_absurd() {
    bad_scene("width = 8", "width = 0", &["scene.toml:2:", "render.width"]);
    bad_scene("height = 6", "height = 0", &["scene.toml:3:", "render.height"]);
    bad_scene("width = 8\nheight = 6", "width = 60000\nheight = 60000", &["render.width", "GiB"]);
    bad_scene("width = 8", "width = -8", &["scene.toml:2:"]);
    // A dithered 2×2 block's pixels index one sequence: four times a pixel's samples.
    let (from, to) = (
        "height = 6\n[render.aa]\nsamples = 2\n",
        "height = 6\nblue_noise = true\n[render.aa]\nsamples = 2000000000\n",
    );
    bad_scene(from, to, &["render.blue_noise", "2^32"]);
}

#[test]
fn zero_length_and_parallel_edges() {
    bad_scene("edge_u = [0, 0, 4]", "edge_u = [0, 0, 0]", &["scene.toml:", "objects.0.edge_u", "zero-length"]);
    bad_scene("edge_u = [1, 0, 0]", "edge_u = [0, 0, 0]", &["lights.0.edge_u", "zero-length"]);
    bad_scene("edge_u = [0, 0, 4]", "edge_u = [3, 0, 0]", &["objects.0.edge_v", "parallel"]);
}

#[test]
fn up_parallel_to_view_direction() {
    bad_scene("look_at = [0, 1, 0]", "look_at = [0, 1, 0]\nup = [0, 0, -2]", &["camera.up", "parallel"]);
    bad_scene("look_at = [0, 1, 0]", "look_at = [0, 1, 5]", &["camera.look_at"]);
}

#[test]
fn unknown_mode_and_zero_samples() {
    bad_scene("samples = 2\n[render.shadows]", "samples = 0\n[render.shadows]", &["render.aa.samples"]);
    bad_scene("[render.aa]", "[render.aa]\nmode = \"fancy\"", &["render.aa.mode", "fancy"]);
    bad_scene("[render.aa]", "bvh = \"fastest\"\n[render.aa]", &["render.bvh", "fastest"]);
}

#[test]
fn dof_aware_and_early_stopping_fields_are_checked() {
    let aa = "[render.aa]\nmode = \"adaptive\"\ndof_aware = true\n";
    bad_scene("[render.aa]\n", &format!("{aa}dof_radius = 0\n"), &["scene.toml:7:", "render.aa.dof_radius", "> 0"]);
    bad_scene("[render.aa]\n", &format!("{aa}dof_radius = -2\n"), &["scene.toml:7:", "render.aa.dof_radius"]);
    bad_scene("[render.aa]\n", &format!("{aa}dof_awre = true\n"), &["scene.toml:", "dof_awre"]);
    bad_scene("[render.aa]\n", "[render.aa]\ndof_aware = \"yes\"\n", &["scene.toml:5:", "invalid type"]);
    for bad in ["tolerance = 1.5", "tolerance = -0.1"] {
        bad_scene(
            "[render.shadows]\n",
            &format!("[render.shadows]\n{bad}\n"),
            &["scene.toml:7:", "render.shadows.tolerance"],
        );
    }
    bad_scene("[render.shadows]\n", "[render.shadows]\nbatch = 0\n", &["scene.toml:7:", "render.shadows.batch"]);
    bad_scene("[render.shadows]\n", "[render.shadows]\nbatch = -4\n", &["scene.toml:7:"]);
    // The same through --set, which the message names.
    let case = Case::new();
    case.write("scene.toml", &good());
    for (set, needle) in [
        ("render.shadows.tolerance=2", "(--set render.shadows.tolerance=2): field `render.shadows.tolerance`"),
        ("render.shadows.batch=0", "field `render.shadows.batch`"),
        ("render.aa.dof_radius=0", "field `render.aa.dof_radius`"),
    ] {
        let extra = if set.starts_with("render.aa") { "render.aa.mode=adaptive" } else { "render.seed=1" };
        let o = case.run(&["scene.toml", "-o", "b.png", "--set", extra, "--set", set]);
        assert_eq!(o.status.code(), Some(2), "{set}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{set}: {}", stderr(&o));
    }
    assert!(!case.path("b.png").exists());
    // Valid values render.
    let o = case.run(&[
        "scene.toml",
        "-o",
        "ok.png",
        "--set",
        "render.aa.mode=adaptive",
        "--set",
        "render.aa.dof_aware=true",
        "--set",
        "render.shadows.mode=adaptive",
        "--set",
        "render.shadows.tolerance=0.05",
        "--set",
        "render.shadows.batch=4",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn variance_fields_are_checked() {
    let aa = "[render.aa]\nmode = \"variance\"\n";
    bad_scene("[render.aa]\n", &format!("{aa}threshold = -0.1\n"), &["scene.toml:6:", "render.aa.threshold", ">= 0"]);
    bad_scene("[render.aa]\n", &format!("{aa}min_samples = 1\n"), &["scene.toml:6:", "render.aa.min_samples", "2..="]);
    bad_scene("[render.aa]\n", &format!("{aa}min_samples = 64\n"), &["render.aa.min_samples", "samples (2)"]);
    let auto = "[render.aa]\nmode = \"auto\"\n";
    bad_scene(
        "[render.aa]\n",
        &format!("{auto}min_samples = 1\n"),
        &["scene.toml:6:", "render.aa.min_samples", "in 2.."],
    );
    bad_scene(
        "[render.shadows]\n",
        "[render.shadows]\nmode = \"variance\"\n",
        &["scene.toml:7:", "render.shadows.mode", "anti-aliasing mode"],
    );
    // Through --set, the message names the key the --set changed.
    let case = Case::new();
    case.write("scene.toml", &good());
    let o =
        case.run(&["scene.toml", "-o", "b.png", "--set", "render.aa.mode=variance", "--set", "render.aa.samples=8"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("field `render.aa.samples`"), "{}", stderr(&o));
    assert!(!case.path("b.png").exists());
    let sets = ["render.aa.mode=variance", "render.aa.samples=8", "render.aa.min_samples=4"];
    let args: Vec<&str> =
        ["scene.toml", "-o", "ok.png"].into_iter().chain(sets.iter().flat_map(|s| ["--set", s])).collect();
    let o = case.run(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn missing_and_malformed_obj() {
    let mesh = "[[objects]]\ntype = \"mesh\"\nfile = \"m.obj\"\nmaterial = \"white\"\n";
    // Missing file.
    bad_scene(
        "[[objects]]\ntype = \"sphere\"",
        &format!("{mesh}[[objects]]\ntype = \"sphere\""),
        &["objects.1.file", "m.obj"],
    );
    // Malformed files.
    for (obj, needle) in [
        ("v 0 0 0\nv 1 0 0\nv x 1 0\nf 1 2 3\n", "vertex position"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "vertex"),
        ("v 0 0 0\nv 1 0 0\n", "no triangles"),
        ("v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n", "non-finite"),
    ] {
        let case = Case::new();
        case.write("m.obj", obj);
        case.write("scene.toml", &format!("{}{mesh}", good()));
        let out = case.run(&["scene.toml", "-o", "out.png"]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{obj:?}: {err}");
        assert!(err.contains("objects.2.file") && err.contains(needle), "{obj:?}: {err}");
        assert_eq!(case.outputs(&["scene.toml", "m.obj"]), Vec::<String>::new());
    }
}

#[test]
fn mesh_loads_relative_to_the_scene_file() {
    let case = Case::new();
    std::fs::create_dir(case.path("sub")).unwrap();
    std::fs::create_dir(case.path("sub/meshes")).unwrap();
    std::fs::write(case.path("sub/meshes/t.obj"), "v -1 0 0\nv 1 0 0\nv 0 2 0\nv 0 2 0\nf 1 2 3\nf 2 3 4\n").unwrap();
    let mesh = "[[objects]]\ntype = \"mesh\"\nfile = \"meshes/t.obj\"\nmaterial = \"white\"\n";
    std::fs::write(case.path("sub/scene.toml"), format!("{}{mesh}", good())).unwrap();
    let out = case.run(&["sub/scene.toml", "-o", "out.png", "--stats-json", "s.json"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(case.path("s.json")).unwrap()).unwrap();
    assert_eq!(json["scene"]["triangles"], 1);
    assert_eq!(json["scene"]["degenerate_triangles"], 1, "the zero-area triangle is skipped and counted");
}

#[test]
fn bad_output_paths() {
    let case = Case::new();
    case.write("scene.toml", &good());
    for (out, needle) in [("missing/out.png", "does not exist"), ("out.jpg", ".jpg"), ("out", "extension")] {
        let o = case.run(&["scene.toml", "-o", out]);
        assert_eq!(o.status.code(), Some(2), "{out}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{out}: {}", stderr(&o));
    }
    let o = case.run(&["scene.toml", "-o", "out.png", "--stats-json", "missing/s.json"]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(case.outputs(&["scene.toml"]), Vec::<String>::new());
}

#[test]
fn set_overrides_work_and_bad_ones_fail() {
    let case = Case::new();
    case.write("scene.toml", &good());
    let o = case.run(&["scene.toml", "-o", "a.png", "--set", "render.width=5", "--set", "objects.1.radius=0.5"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(image_dims(&case.path("a.png")), (5, 6));
    for (set, needle) in [
        ("render.widht=5", "widht"),
        ("render.width=abc", "invalid type"),
        ("objects.1.radius=-1", "objects.1.radius"),
        ("objects.9.radius=1", "out of range"),
        ("render.width", "KEY=VALUE"),
        ("camera.position=[0, nan, 1]", "finite"),
    ] {
        let o = case.run(&["scene.toml", "-o", "b.png", "--set", set]);
        assert_eq!(o.status.code(), Some(2), "{set}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{set}: {}", stderr(&o));
    }
    assert!(!case.path("b.png").exists());
}

#[test]
fn usage_errors_exit_2() {
    let case = Case::new();
    for args in [&["--bogus"][..], &["render", "--threads", "x"], &["--threads", "0"], &["missing.toml"]] {
        let o = case.run(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    }
    assert!(case.outputs(&[]).is_empty());
}

#[test]
fn failed_write_keeps_the_earlier_file() {
    let case = Case::new();
    case.write("scene.toml", &good());
    // A folder where the temporary file would be renamed to cannot be replaced.
    std::fs::create_dir(case.path("out.png")).unwrap();
    let o = case.run(&["scene.toml", "-o", "out.png"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(case.path("out.png").is_dir());
    assert_eq!(case.outputs(&["scene.toml"]), vec!["out.png".to_string()]);
}

/// Sends SIGINT to a child process (through kill(1): no libc dependency).
fn interrupt(child: &std::process::Child) {
    let ok = Command::new("kill").args(["-INT", &child.id().to_string()]).status().expect("kill");
    assert!(ok.success());
}

/// A render long enough to interrupt: seconds to minutes on any machine.
fn long_render(case: &Case) -> std::process::Child {
    case.write("scene.toml", &good());
    let args = ["scene.toml", "-o", "out.png", "--stats-json", "s.json", "--set", "render.width=2000"];
    let more = ["--set", "render.height=2000", "--set", "render.aa.samples=64", "--threads", "2"];
    Command::new(BIN)
        .args(args)
        .args(more)
        .current_dir(case.dir.path())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn")
}

#[test]
fn ctrl_c_writes_what_is_finished_and_exits_130() {
    let case = Case::new();
    let mut child = long_render(&case);
    // Give it time to load the scene and install the handler.
    std::thread::sleep(std::time::Duration::from_millis(1500));
    interrupt(&child);
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    assert_eq!(image_dims(&case.path("out.png")), (2000, 2000), "the finished part is written");
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(case.path("s.json")).unwrap()).unwrap();
    assert_eq!(json["partial"], true);
    assert_eq!(case.outputs(&["scene.toml"]), vec!["out.png".to_string(), "s.json".to_string()], "no temporary files");
}

#[test]
fn a_second_ctrl_c_exits_at_once() {
    let case = Case::new();
    let mut child = long_render(&case);
    std::thread::sleep(std::time::Duration::from_millis(1500));
    interrupt(&child);
    interrupt(&child);
    assert_eq!(child.wait().unwrap().code(), Some(130));
}

#[test]
#[cfg(all(feature = "exr", feature = "flip"))]
fn compare_prints_metrics_and_rejects_bad_pairs() {
    let case = Case::new();
    case.write("scene.toml", &good());
    assert_eq!(case.run(&["scene.toml", "-o", "a.png", "-q"]).status.code(), Some(0));
    assert_eq!(case.run(&["scene.toml", "-o", "a.exr", "-q"]).status.code(), Some(0));
    assert_eq!(case.run(&["scene.toml", "-o", "b.png", "-q", "--set", "render.width=9"]).status.code(), Some(0));
    // Identical images: zero error, in text and JSON.
    let o = case.run(&["compare", "a.png", "a.png"]);
    assert_eq!(o.status.code(), Some(0));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("rmse 0.000000") && text.contains("flip 0.000000"), "{text}");
    let o = case.run(&["compare", "a.exr", "a.exr", "--json"]);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["rmse"], 0.0);
    // PNG against EXR of the same render: only 8-bit quantisation and clamping remain.
    let o = case.run(&["compare", "a.png", "a.exr", "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(json["rmse"].as_f64().unwrap() > 0.0);
    // Size mismatch and unreadable files are bad input.
    for args in
        [&["compare", "a.png", "b.png"][..], &["compare", "a.png", "missing.png"], &["compare", "scene.toml", "a.png"]]
    {
        let o = case.run(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    }
    assert!(stderr(&case.run(&["compare", "a.png", "b.png"])).contains("differ in size"));
}

#[test]
fn meshes_outside_the_scene_folder_are_allowed_and_reported() {
    let case = Case::new();
    std::fs::create_dir(case.path("scenes")).unwrap();
    std::fs::write(case.path("m.obj"), "v -1 0 0\nv 1 0 0\nv 0 2 0\nf 1 2 3\n").unwrap();
    let mesh = "[[objects]]\ntype = \"mesh\"\nfile = \"../m.obj\"\nmaterial = \"white\"\n";
    std::fs::write(case.path("scenes/scene.toml"), format!("{}{mesh}", good())).unwrap();
    let o = case.run(&["scenes/scene.toml", "-o", "out.png", "--stats-json", "s.json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(case.path("s.json")).unwrap()).unwrap();
    let outside = json["scene"]["outside_paths"].as_array().unwrap();
    assert_eq!(outside.len(), 1, "{outside:?}");
    assert!(outside[0].as_str().unwrap().ends_with("m.obj"));
    // Inside the folder: nothing reported.
    std::fs::write(case.path("scenes/m.obj"), "v -1 0 0\nv 1 0 0\nv 0 2 0\nf 1 2 3\n").unwrap();
    std::fs::write(case.path("scenes/in.toml"), format!("{}{}", good(), mesh.replace("../m.obj", "m.obj"))).unwrap();
    let o = case.run(&["scenes/in.toml", "-o", "in.png", "--stats-json", "t.json"]);
    assert_eq!(o.status.code(), Some(0));
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(case.path("t.json")).unwrap()).unwrap();
    assert!(json["scene"]["outside_paths"].as_array().unwrap().is_empty());
}

#[test]
fn resource_limits_are_checked_before_work() {
    // More bounces than any queue budget allows.
    bad_scene("width = 8", "width = 8\nmax_depth = 100000", &["render.max_depth", "64"]);
    // A mesh file too large for the machine is refused before it is read: a sparse
    // file costs no disk.
    let case = Case::new();
    let f = std::fs::File::create(case.path("huge.obj")).unwrap();
    f.set_len(1 << 40).unwrap();
    let mesh = "[[objects]]\ntype = \"mesh\"\nfile = \"huge.obj\"\nmaterial = \"white\"\n";
    case.write("scene.toml", &format!("{}{mesh}", good()));
    let o = case.run(&["scene.toml", "-o", "out.png"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("GiB") && stderr(&o).contains("objects.2.file"), "{}", stderr(&o));
    assert!(!case.path("out.png").exists());
}
