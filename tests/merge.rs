//! `wavetrace merge`: tiles from `render --tile/--crop` merge into files byte-identical
//! to the single render's; gaps, overlaps, foreign tiles (seed, scene, settings) and
//! corrupt files are exit 2 naming the tiles, with nothing written; `--missing` lists
//! the tasks to resubmit; `--allow-missing` writes black and says so in the stats.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_wavetrace");
const SIZE: [&str; 4] = ["--set", "render.width=41", "--set", "render.height=35"];

struct Dir(tempfile::TempDir);

impl Dir {
    fn new() -> Dir {
        Dir(tempfile::tempdir().unwrap())
    }

    fn p(&self, name: &str) -> PathBuf {
        self.0.path().join(name)
    }

    fn run(&self, args: &[&str]) -> Output {
        Command::new(BIN).current_dir(self.0.path()).args(args).env_remove("SLURM_CPUS_PER_TASK").output().unwrap()
    }

    /// Renders the default scene at 41×35 (adaptive AA and shadows) with `extra` args.
    fn render(&self, out: &str, extra: &[&str]) {
        let mut args = vec!["render", "--quiet", "-o", out, "--set", "render.aa.mode=adaptive"];
        args.extend(["--set", "render.shadows.mode=adaptive"]);
        args.extend(SIZE);
        args.extend(extra);
        let o = self.run(&args);
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    }

    /// `--tile k/n` for every k in `ks`, to t{k}.exr.
    fn tiles(&self, n: u32, ks: impl IntoIterator<Item = u32>) -> Vec<String> {
        ks.into_iter()
            .map(|k| {
                let name = format!("t{k}.exr");
                self.render(&name, &["--tile", &format!("{k}/{n}"), "--threads", &(1 + k % 2).to_string()]);
                name
            })
            .collect()
    }

    /// `merge` with `args`; asserts exit 2 with `want` in the message and no `out.*`.
    fn refused(&self, args: &[&str], want: &[&str]) {
        let o = self.run(&[&["merge"], args].concat());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        for w in want {
            assert!(err.contains(w), "{args:?}: expected `{w}` in: {err}");
        }
        assert!(!self.p("out.exr").exists() && !self.p("out.png").exists(), "{args:?} wrote an output");
    }
}

fn read(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn tiles_merge_into_the_single_render_byte_for_byte() {
    let d = Dir::new();
    d.render("full.exr", &["--threads", "2"]);
    d.render("full.png", &["--threads", "2"]);
    let tiles = d.tiles(5, 0..5);
    let mut args = vec!["merge", "--quiet", "-o", "out.exr", "--stats-json", "stats.json"];
    args.extend(tiles.iter().rev().map(String::as_str));
    assert!(d.run(&args).status.success());
    assert!(read(&d.p("out.exr")) == read(&d.p("full.exr")), "merged EXR differs from the single render");
    let o = d.run(
        &[&["merge", "--quiet", "-o", "out.png"], &tiles.iter().map(String::as_str).collect::<Vec<_>>()[..]].concat(),
    );
    assert!(o.status.success());
    assert!(read(&d.p("out.png")) == read(&d.p("full.png")), "merged PNG differs from the single render");

    let stats: serde_json::Value = serde_json::from_slice(&read(&d.p("stats.json"))).unwrap();
    let rows = stats["tiles"].as_array().unwrap();
    assert_eq!(rows.len(), 5);
    let sum: u64 = rows.iter().map(|r| r["rays"].as_u64().unwrap()).sum();
    assert!(sum > 0);
    assert_eq!(stats["rays"].as_u64(), Some(sum));
    assert_eq!(stats["partial"], false);
    assert_eq!(stats["width"], 41);
}

#[test]
fn unaligned_crops_merge_exactly_too() {
    let d = Dir::new();
    d.render("full.exr", &[]);
    // Three crops off the tile grid that tile the frame.
    for (name, c) in [("a.exr", "0,7,0,35"), ("b.exr", "7,41,0,20"), ("c.exr", "7,41,20,35")] {
        d.render(name, &["--crop", c]);
    }
    assert!(d.run(&["merge", "-q", "a.exr", "b.exr", "c.exr", "-o", "all.exr"]).status.success());
    assert!(read(&d.p("all.exr")) == read(&d.p("full.exr")));
    // Crops are not tasks: no indices to list.
    d.refused(&["a.exr", "b.exr", "--missing"], &["not all `--tile K/N` tasks"]);
    d.render("w.exr", &["--crop-window", "0,0.5,0,1"]);
    d.refused(&["a.exr", "w.exr", "-o", "out.exr"], &["`a.exr` (0,7,0,35) and `w.exr` (0,21,0,35) overlap"]);
}

#[test]
fn a_gap_is_refused_listed_and_allowed_only_on_request() {
    let d = Dir::new();
    let tiles = d.tiles(4, [0, 1, 3]);
    let t: Vec<&str> = tiles.iter().map(String::as_str).collect();
    d.refused(&[&t[..], &["-o", "out.exr"]].concat(), &["pixels are in no tile", "missing tasks: 2"]);
    let o = d.run(&[&["merge", "--missing"], &t[..]].concat());
    assert!(o.status.success());
    assert_eq!(String::from_utf8_lossy(&o.stdout), "2\n");
    let o = d.run(&[&["merge", "-q", "--allow-missing", "-o", "out.exr", "--stats-json", "s.json"], &t[..]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("written black"));
    let s: serde_json::Value = serde_json::from_slice(&read(&d.p("s.json"))).unwrap();
    assert_eq!(s["partial"], true);
    assert_eq!(s["coverage"]["missing_tasks"], serde_json::json!([2]));
    // After the resubmitted task, the merge succeeds.
    d.tiles(4, [2]);
    let o = d.run(&["merge", "--missing", "t0.exr", "t1.exr", "t2.exr", "t3.exr"]);
    assert_eq!(String::from_utf8_lossy(&o.stdout), "");
    assert!(d.run(&["merge", "-q", "-o", "all.exr", "t0.exr", "t1.exr", "t2.exr", "t3.exr"]).status.success());
}

#[test]
fn overlaps_and_foreign_tiles_are_refused_naming_the_tiles() {
    let d = Dir::new();
    d.tiles(2, 0..2);
    d.render("q.exr", &["--tile", "1/4"]);
    d.refused(&["t0.exr", "t1.exr", "q.exr", "-o", "out.exr"], &["overlap", "q.exr"]);
    d.refused(&["t0.exr", "t0.exr", "-o", "out.exr"], &["overlap"]);

    d.render("seed.exr", &["--tile", "1/2", "--seed", "7"]);
    d.refused(
        &["t0.exr", "seed.exr", "-o", "out.exr"],
        &["`seed.exr` is not from the same render as `t0.exr`", "seed 7 vs 1"],
    );
    d.render("scene.exr", &["--tile", "1/2", "--set", "camera.fov_y=31"]);
    d.refused(&["t0.exr", "scene.exr", "-o", "out.exr"], &["`scene.exr`", "scene hash"]);
    d.render("set.exr", &["--tile", "1/2", "--set", "render.shadows.samples=9"]);
    d.refused(&["t0.exr", "set.exr", "-o", "out.exr"], &["`set.exr`", "settings hash"]);
    d.render("size.exr", &["--tile", "1/2", "--set", "render.width=40"]);
    d.refused(&["t0.exr", "size.exr", "-o", "out.exr"], &["`size.exr`", "frame 40×35 vs 41×35"]);
}

#[test]
fn corrupt_truncated_and_foreign_files_are_refused_naming_the_file() {
    let d = Dir::new();
    d.tiles(2, 0..2);
    let bytes = read(&d.p("t1.exr"));
    for cut in [0, 4, 100, bytes.len() / 2, bytes.len() - 1] {
        std::fs::write(d.p("cut.exr"), &bytes[..cut]).unwrap();
        d.refused(&["t0.exr", "cut.exr", "-o", "out.exr"], &["tile `cut.exr`: not a readable EXR"]);
    }
    std::fs::write(d.p("junk.exr"), b"not an exr at all").unwrap();
    d.refused(&["t0.exr", "junk.exr", "-o", "out.exr"], &["tile `junk.exr`"]);
    // A whole-frame render has no tile header.
    d.render("full.exr", &[]);
    d.refused(&["full.exr", "-o", "out.exr"], &["tile `full.exr`: no `wavetrace.scene_hash` header attribute"]);
    d.refused(&["t0.exr", "missing.exr", "-o", "out.exr"], &["missing.exr"]);
}
