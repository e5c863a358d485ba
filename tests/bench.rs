//! `wavetrace bench`: its JSON schema, its ray sets, and bad flags (exit 2, nothing
//! printed to stdout).

use std::process::Command;
use wavetrace::tools::bench::{ray_sets, run_scene, BenchOptions, RaySet};

const BIN: &str = env!("CARGO_BIN_EXE_wavetrace");
const SMALL: [&str; 4] = ["--set", "render.width=24", "--set", "render.height=16"];

fn bench(args: &[&str]) -> std::process::Output {
    Command::new(BIN).arg("bench").args(args).output().expect("run wavetrace")
}

#[test]
fn json_has_every_set_and_kernel() {
    let mut args = SMALL.to_vec();
    args.extend(["--reps", "1", "--threads", "2", "--json"]);
    let out = bench(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let total = v["bvh_build_seconds"].as_f64().expect("build seconds");
    assert!(total >= 0.0);
    // The build's phases: each timed, together the total (the rest is what they leave).
    let phases = ["ploc", "reinsertion", "leaf_collapse", "reorder", "wide_plan", "wide_fill", "wide_blocks", "rest"];
    let secs: Vec<f64> = phases.iter().map(|p| v["bvh_build_phases"][p].as_f64().expect(p)).collect();
    assert!(secs.iter().all(|&s| s >= 0.0), "{secs:?}");
    assert!((secs.iter().sum::<f64>() - total).abs() <= 1e-6 + 1e-9 * total, "{secs:?} vs {total}");
    assert_eq!(v["threads"], 2);
    let sets = v["sets"].as_array().expect("sets");
    let mut seen = Vec::new();
    for s in sets {
        let (set, kernel) = (s["set"].as_str().unwrap(), s["kernel"].as_str().unwrap());
        assert!(["primary", "shadow", "secondary"].contains(&set));
        assert!(["packet", "wide", "interleaved", "stream", "hybrid"].contains(&kernel), "{kernel}");
        assert!(s["rays"].as_u64().unwrap() > 0, "{s}");
        assert!(s["mrays_per_s"].as_f64().unwrap() > 0.0, "{s}");
        seen.push((set.to_string(), kernel.to_string()));
    }
    assert_eq!(seen.len(), 15);
    assert_eq!(v["renderer_kernel"], "hybrid");
    // The default scene at 24×16 with 16 AA samples: every camera ray is in the set.
    assert_eq!(sets[0]["rays"], 24 * 16 * 16);
}

#[test]
fn text_table_lists_each_set() {
    let mut args = SMALL.to_vec();
    args.extend(["--reps", "1", "--lanes", "4", "--shadow-order", "morton"]);
    let out = bench(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    for word in ["BVH build", "primary", "shadow", "secondary", "interleaved"] {
        assert!(text.contains(word), "{text}");
    }
}

#[test]
fn kernels_flag_measures_only_the_kernels_named() {
    let mut args = SMALL.to_vec();
    args.extend(["--reps", "1", "--kernels", "hybrid,wide", "--json"]);
    let out = bench(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let kernels: Vec<&str> = v["sets"].as_array().unwrap().iter().map(|s| s["kernel"].as_str().unwrap()).collect();
    // The table's order, whatever the order asked in.
    assert_eq!(kernels, ["wide", "hybrid"].repeat(3));
    let mut args = SMALL.to_vec();
    args.extend(["--reps", "1", "--kernels", "packet"]);
    let text = String::from_utf8(bench(&args).stdout).unwrap();
    let header = text.lines().find(|l| l.starts_with("set")).expect("a header row");
    assert_eq!(header.split_whitespace().last(), Some("packet"), "{text}");
    assert!(!header.contains("hybrid") && !header.contains("wide"), "{text}");
}

#[test]
fn ray_sets_flag_measures_only_the_sets_named() {
    let mut args = SMALL.to_vec();
    args.extend(["--reps", "1", "--kernels", "wide", "--ray-sets", "shadow,primary", "--json"]);
    let out = bench(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let sets: Vec<&str> = v["sets"].as_array().unwrap().iter().map(|s| s["set"].as_str().unwrap()).collect();
    assert_eq!(sets, ["primary", "shadow"]);
    let mut args = SMALL.to_vec();
    args.extend(["--reps", "1", "--ray-sets", "camera"]);
    let out = bench(&args);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--ray-sets camera") && err.contains("primary, shadow, secondary"), "{err}");
}

#[test]
fn bad_flags_exit_2_with_a_message() {
    for (args, needle) in [
        (&["--lanes", "5"][..], "'5' for '--lanes"),
        (&["--reps", "0"], "--reps"),
        (&["--threads", "0"], "--threads"),
        (&["--max-rays", "0"], "--max-rays"),
        (&["--bounce-order", "zigzag"], "zigzag"),
        (&["--split-mixed", "maybe"], "maybe"),
        (&["no/such/scene.toml"], "no/such/scene.toml"),
        (&["--set", "render.width=0"], "render.width"),
        (&["--mesh", "no/such/mesh.obj"], "no/such/mesh.obj"),
        (&["--sphere", "11"], "--sphere"),
        (&["--leaf", "0"], "--leaf"),
        (&["--bvh", "fastest"], "'fastest' for '--bvh"),
        (&["--kernels", "wide,simd"], "'simd' for '--kernels"),
        (
            &["--export-rays", "target/no-such-export-dir", "--set", "render.width=8", "--set", "render.height=8"],
            "spheres or parallelograms",
        ),
        (&["--mesh", "a.obj", "scene.toml"], "--mesh"),
    ] {
        let out = bench(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(out.stdout.is_empty(), "{args:?}");
    }
    assert!(!std::path::Path::new("target/no-such-export-dir").exists(), "a refused export leaves nothing");
}

#[test]
fn ray_sets_are_the_renderers_rays_and_thin_uniformly() {
    let text = wavetrace::DEFAULT_SCENE;
    let load = |sets: &[&str]| {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        wavetrace::scene::load(&wavetrace::scene::SceneSource::from_text("<t>", text, std::path::Path::new(".")), &sets)
            .unwrap()
    };
    let scene = load(&["render.width=32", "render.height=16", "render.aa.samples=4"]);
    let sets = ray_sets(&scene, 1 << 20);
    let len = |name: &str| sets.iter().find(|s| s.0 == name).unwrap().1.len();
    assert_eq!(len("primary"), 32 * 16 * 4);
    assert!(len("shadow") > 0 && len("secondary") > 0 && len("secondary") <= len("primary"));
    assert!(matches!(sets[1].1, RaySet::AnyHit(_)));
    // A cap keeps at most twice itself, and the scene's settings are left as they were.
    let capped = ray_sets(&scene, 1000);
    assert!(capped.iter().all(|s| s.1.len() < 2000 && !s.1.is_empty()));
    assert!(scene.settings.packets);
    // Packet, wide, interleaved, stream and hybrid kernels agree on every set (run() checks the
    // hit checksums).
    let report = run_scene(&scene, &BenchOptions { reps: 1, ..BenchOptions::default() }).expect("bench");
    assert_eq!(report.sets.len(), 15);
}

/// `wavetrace bench --sphere LEVEL` on small sets, one thread, exporting its rays to a
/// fresh directory named after `name`, with `extra` flags: the JSON and the directory.
fn export_sphere(level: &str, name: &str, extra: &[&str]) -> (serde_json::Value, std::path::PathBuf) {
    let dir = std::env::temp_dir().join(format!("wavetrace-bench-{name}-{}", std::process::id()));
    let mut args = vec!["--sphere", level, "--max-rays", "4096", "--reps", "1", "--threads", "1", "--json"];
    args.extend(extra);
    args.extend(["--export-rays", dir.to_str().unwrap()]);
    let out = bench(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    (serde_json::from_slice(&out.stdout).expect("JSON"), dir)
}

#[test]
fn mesh_sets_export_npy_files_that_match_the_json() {
    let (v, dir) = export_sphere("2", "export", &["--cpu-time"]);
    assert_eq!(v["primitives"], 320);
    assert_eq!(v["clock"], "cpu");
    let list = std::fs::read_to_string(dir.join("sets.txt")).unwrap();
    let names: Vec<&str> = list.lines().map(|l| l.split(' ').next().unwrap()).collect();
    assert_eq!(names, ["camera", "shadow", "bounce", "random", "bounce-shadow"]);
    for s in v["sets"].as_array().unwrap() {
        let name = s["set"].as_str().unwrap();
        // n×3 f32 after a header padded to 64 bytes: the file size gives n.
        let bytes = std::fs::read(dir.join(format!("{name}.origins.npy"))).unwrap();
        let header = 10 + u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!(((bytes.len() - header) / 12) as u64, s["rays"].as_u64().unwrap(), "{name}");
    }
    // The camera looks at the sphere from outside: some rays hit (t finite), some miss.
    let t = std::fs::read(dir.join("camera.t.npy")).unwrap();
    let header = 10 + u16::from_le_bytes([t[8], t[9]]) as usize;
    let ts: Vec<f32> = t[header..].chunks(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    assert!(ts.iter().any(|t| t.is_finite()) && ts.iter().any(|t| t.is_infinite()));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bvh_flag_changes_the_tree_not_the_answers() {
    let export = |quality: &str| {
        let (v, dir) = export_sphere("3", &format!("bvh-{quality}"), &["--kernels", "wide", "--bvh", quality]);
        let read = |name: &str| std::fs::read(dir.join(name)).unwrap();
        let files = ["camera.t.npy", "bounce.origins.npy", "bounce.t.npy", "random.t.npy", "bounce-shadow.blocked.npy"]
            .map(read);
        std::fs::remove_dir_all(&dir).unwrap();
        (v["bytes_per_primitive"][1].as_f64().unwrap(), files)
    };
    let (medium_bytes, medium) = export("medium");
    let (high_bytes, high) = export("high");
    // Different wide trees (their sizes differ)...
    assert_ne!(medium_bytes, high_bytes);
    // ...the same distances, the same bounce rays built from them, the same blocked rays.
    assert!(medium == high, "the answers differ between --bvh medium and --bvh high");
}
