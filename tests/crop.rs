//! Crops and `--tile K/N` tasks: every pixel of a crop has the full render's bits (and
//! heat) in every mode and at any thread count; the task rectangles cover the frame
//! exactly once; bad crop arguments are exit 2 with a clear message and no output.

use std::path::Path;
use std::process::Command;

use wavetrace::film::{split, Crop, Tile, TILE};
use wavetrace::scene::{load, SceneSource};
use wavetrace::{render, RenderOptions, RenderOutput};

const BIN: &str = env!("CARGO_BIN_EXE_wavetrace");
/// Odd, not a multiple of the 16-pixel tile: the last tile column and row are partial.
const W: u32 = 53;
const H: u32 = 39;

fn fig08() -> SceneSource {
    SceneSource::from_file(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/paper/fig08-combined.toml"))
        .expect("fig08 loads")
}

/// Figure 8 (glass, mirror, DOF, a quad light) at W×H with 6 lens samples, plus `mode`.
fn run(mode: &[&str], crop: Option<Tile>, threads: usize) -> RenderOutput {
    let mut sets = vec![format!("render.width={W}"), format!("render.height={H}"), "render.dof.samples=6".into()];
    sets.extend(mode.iter().map(|s| s.to_string()));
    let scene = load(&fig08(), &sets).expect("scene");
    render(&scene, &RenderOptions { threads: Some(threads), crop, ..Default::default() }).expect("render")
}

fn bits(v: &[glam::Vec3]) -> Vec<u32> {
    v.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect()
}

/// Crops touching each border and corner, single pixels (at a corner, on a tile
/// boundary, inside a tile), crops off the tile grid, and the whole frame.
fn crops() -> Vec<Tile> {
    let t = |x0, x1, y0, y1| Tile { x0, x1, y0, y1 };
    vec![
        t(0, 5, 0, 3),                             // top-left corner
        t(W - 7, W, 0, 9),                         // top-right corner
        t(0, 13, H - 2, H),                        // bottom-left corner
        t(W - 1, W, H - 1, H),                     // bottom-right pixel
        t(0, 3, 10, 30),                           // left border
        t(W - 4, W, 17, 33),                       // right border
        t(20, 40, 0, 1),                           // top border, one row
        t(15, 47, H - 5, H),                       // bottom border
        t(TILE - 1, TILE + 1, TILE - 1, TILE + 1), // across a tile corner
        t(TILE, TILE + 1, TILE, TILE + 1),         // one pixel at a tile's top-left
        t(17, 18, 23, 24),                         // one pixel inside a tile
        t(5, 50, 7, 36),                           // unaligned, spanning tiles
        t(0, W, 0, H),                             // everything
    ]
}

/// Every mode: uniform (plain and blue-noise dithered), adaptive AA with shared and with
/// per-pixel corners, adaptive shadows, DOF-aware AA with early stopping (both corner
/// kinds), one ray at a time, variance-driven AA, and the auto modes (their pilot covers
/// the whole image in every crop).
const MODES: &[(&str, &[&str])] = &[
    ("uniform", &["render.aa.mode=uniform", "render.aa.samples=2", "render.shadows.mode=uniform"]),
    // Dithered: a pixel's keys come from its 2×2 block, crops cut blocks in two; 2 and 3
    // samples (× 6 lens samples) take the lanes shared by pixels and a pixel's own lanes.
    ("blue-noise", &["render.aa.mode=uniform", "render.aa.samples=2", "render.blue_noise=true"]),
    ("blue-noise-own-lanes", &["render.aa.mode=uniform", "render.aa.samples=3", "render.blue_noise=true"]),
    ("adaptive-aa", &["render.shadows.mode=uniform"]),
    ("adaptive-aa-own-corners", &["render.aa.share_corners=false"]),
    ("adaptive-shadows", &["render.aa.mode=uniform", "render.shadows.mode=adaptive"]),
    ("dof-aware-early-stop", &["render.aa.dof_aware=true", "render.shadows.tolerance=0.05"]),
    (
        "dof-aware-own-corners",
        &["render.aa.dof_aware=true", "render.aa.share_corners=false", "render.shadows.tolerance=0.05"],
    ),
    ("single", &["render.packets=false", "render.aa.dof_aware=true"]),
    (
        "variance",
        &["render.aa.mode=variance", "render.aa.samples=12", "render.aa.min_samples=4", "render.aa.threshold=0.05"],
    ),
    ("auto", &["render.aa.mode=auto", "render.aa.samples=12", "render.aa.min_samples=4", "render.aa.threshold=0.05"]),
    ("auto-shadows", &["render.aa.mode=uniform", "render.shadows.mode=auto", "render.shadows.samples=64"]),
];

#[test]
fn every_crop_is_bit_identical_to_the_full_render_in_every_mode() {
    for (name, mode) in MODES {
        let full = run(mode, None, 2);
        for (i, c) in crops().iter().enumerate() {
            // Alternate 1 and 2 threads: the crop must not depend on the thread count.
            let out = run(mode, Some(*c), 1 + i % 2);
            let want = full.image.crop(c);
            assert_eq!((out.image.width, out.image.height), (c.x1 - c.x0, c.y1 - c.y0), "{name} {c}");
            assert!(bits(&out.image.pixels) == bits(&want.pixels), "{name}: crop {c} differs from the full render");
            assert_eq!(out.heat, full.heat.crop(W, c), "{name}: crop {c}'s heat differs");
            assert!(!out.partial);
        }
    }
}

#[test]
fn a_crop_renders_only_the_tiles_it_touches() {
    let mode = MODES[0].1;
    let full = run(mode, None, 2);
    let one = run(mode, Some(Tile { x0: 17, x1: 18, y0: 23, y1: 24 }), 2);
    assert_eq!(one.stats.tiles, 1);
    assert_eq!(full.stats.tiles, (W.div_ceil(TILE) * H.div_ceil(TILE)) as u64);
    assert!(one.stats.total_rays() < full.stats.total_rays());
}

#[test]
fn tile_tasks_cover_every_frame_exactly_once() {
    for (w, h) in [(137u32, 131u32), (200, 177), (129, 513), (1000, 17), (500, 500), (1920, 1080)] {
        let tiles = w.div_ceil(TILE) * h.div_ceil(TILE);
        for n in 1..=64u32.min(tiles) {
            let parts = split(w, h, n).expect("enough tiles");
            assert_eq!(parts.len(), n as usize);
            let mut hits = vec![0u8; (w * h) as usize];
            for p in &parts {
                assert!(p.x0 < p.x1 && p.y0 < p.y1 && p.x1 <= w && p.y1 <= h, "{w}×{h} N={n}: {p}");
                // On the tile grid: every edge is a multiple of TILE or the frame's edge.
                for (e, end) in [(p.x0, w), (p.x1, w), (p.y0, h), (p.y1, h)] {
                    assert!(e % TILE == 0 || e == end, "{w}×{h} N={n}: {p} is off the tile grid");
                }
                for y in p.y0..p.y1 {
                    for x in p.x0..p.x1 {
                        hits[(y * w + x) as usize] += 1;
                    }
                }
            }
            assert!(hits.iter().all(|&c| c == 1), "{w}×{h} N={n}: a pixel is covered {:?} times", hits.iter().max());
            // Near-equal where it matters, the array job's longest task: in grid tiles,
            // at most 1.5× the even share, ceil(tiles / N).
            let size = |p: &Tile| (p.x1.div_ceil(TILE) - p.x0 / TILE) * (p.y1.div_ceil(TILE) - p.y0 / TILE);
            let hi = parts.iter().map(size).max().unwrap();
            let share = tiles.div_ceil(n);
            assert!(2 * hi <= 3 * share, "{w}×{h} N={n}: a task of {hi} tiles, even share {share}");
        }
    }
    assert!(split(33, 17, 7).is_none(), "6 tiles cannot make 7 tasks");
    assert!(split(33, 17, 0).is_none());
}

#[test]
fn crop_window_is_pbrts_ceiling_rule() {
    let t = Crop::Window([0.25, 0.75, 0.0, 0.5]).resolve(10, 7).unwrap();
    assert_eq!(t, Tile { x0: 3, x1: 8, y0: 0, y1: 4 });
    assert_eq!(Crop::Window([0.0, 1.0, 0.0, 1.0]).resolve(10, 7).unwrap(), Tile { x0: 0, x1: 10, y0: 0, y1: 7 });
    assert!(Crop::Window([0.5, 0.5, 0.0, 1.0]).resolve(10, 7).is_err(), "empty");
    assert!(Crop::Window([0.0, 1.5, 0.0, 1.0]).resolve(10, 7).is_err(), "outside");
}

/// Runs the binary on a tiny scene with `args`; returns (exit code, stderr).
fn cli(dir: &Path, args: &[&str]) -> (i32, String) {
    let out = Command::new(BIN)
        .current_dir(dir)
        .args(["render", "--set", "render.width=40", "--set", "render.height=30", "--quiet", "-o", "out.exr"])
        .args(args)
        .env_remove("SLURM_CPUS_PER_TASK")
        .output()
        .expect("runs");
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn bad_crop_arguments_exit_2_with_a_message_and_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["--crop", "0,41,0,10"], "outside the 40×30 image"),
        (&["--crop", "0,10,25,31"], "outside the 40×30 image"),
        (&["--crop", "5,5,0,10"], "empty or reversed"),
        (&["--crop", "9,3,0,10"], "empty or reversed"),
        (&["--crop", "0,10,0"], "expected four numbers"),
        (&["--crop", "a,1,2,3"], "expected four numbers"),
        (&["--crop=-1,3,0,3"], "expected four numbers"),
        (&["--crop-window", "0,1.2,0,1"], "must be in [0, 1]"),
        (&["--crop-window", "0.5,0.2,0,1"], "empty or reversed"),
        (&["--tile", "3"], "expected K/N"),
        (&["--tile", "0/0"], "need N ≥ 1 and 0 ≤ K < N"),
        (&["--tile", "4/4"], "need N ≥ 1 and 0 ≤ K < N"),
        (&["--tile", "0/7"], "fewer than 7 tasks"),
        (&["--tile", "0/2", "--crop", "0,1,0,1"], "cannot be used with"),
    ];
    for (args, want) in cases {
        let (code, err) = cli(dir.path(), args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: expected `{want}` in: {err}");
        assert!(!dir.path().join("out.exr").exists(), "{args:?} left an output");
    }
    let out = Command::new(BIN)
        .current_dir(dir.path())
        .args(["render", "--set", "render.width=8", "--set", "render.height=8", "--quiet", "-o", "o.png"])
        .env("SLURM_CPUS_PER_TASK", "zero")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("SLURM_CPUS_PER_TASK=`zero`"));
}
