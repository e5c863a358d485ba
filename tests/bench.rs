//! `wavetrace bench`: its JSON schema, its ray sets, and bad flags (exit 2, nothing
//! printed to stdout).

use std::process::Command;
use wavetrace::tools::bench::{ray_sets, run, BenchOptions, RaySet};

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
    assert!(v["bvh_build_seconds"].as_f64().is_some_and(|s| s >= 0.0));
    assert_eq!(v["threads"], 2);
    let sets = v["sets"].as_array().expect("sets");
    let mut seen = Vec::new();
    for s in sets {
        let (set, kernel) = (s["set"].as_str().unwrap(), s["kernel"].as_str().unwrap());
        assert!(["primary", "shadow", "secondary"].contains(&set) && ["scalar", "packet"].contains(&kernel));
        assert!(s["rays"].as_u64().unwrap() > 0, "{s}");
        assert!(s["mrays_per_s"].as_f64().unwrap() > 0.0, "{s}");
        seen.push((set.to_string(), kernel.to_string()));
    }
    assert_eq!(seen.len(), 6);
    // The default scene at 24×16 with 16 AA samples: every camera ray is in the set.
    assert_eq!(sets[0]["rays"], 24 * 16 * 16);
}

#[test]
fn text_table_lists_each_set() {
    let mut args = SMALL.to_vec();
    args.extend(["--reps", "1", "--lanes", "4", "--min-active", "2", "--shadow-order", "morton"]);
    let out = bench(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    for word in ["BVH build", "primary", "shadow", "secondary", "ratio"] {
        assert!(text.contains(word), "{text}");
    }
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
    ] {
        let out = bench(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(out.stdout.is_empty(), "{args:?}");
    }
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
    // Scalar and packet kernels agree on every set (run() checks the hit checksums).
    let report = run(&scene, &BenchOptions { reps: 1, ..BenchOptions::default() }).expect("bench");
    assert_eq!(report.sets.len(), 6);
}
