//! Outputs that never destroy, inputs that never fool (issue 26): where each kind of
//! output path leads (regular file, symlink, character device, FIFO, `-`), outputs
//! that name one file, the thread limit, the command-line shorthands, the warning for a
//! scene that shows nothing, Ctrl-C in adaptive mode, and the cgroup memory reader on
//! fake cgroup trees. Every node (device, FIFO, symlink) is made inside the test's own
//! temporary folder.

use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_wavetrace");

/// A small lit scene: a diffuse sphere in front of a blue background, lit by a point
/// light at the camera, so every pixel the camera sees is lit (no pixel is black).
const SCENE: &str = r#"
[render]
width = 8
height = 6
max_depth = 0
[render.aa]
samples = 2

[camera]
position = [0, 0, 6]
look_at = [0, 0, 0]
fov_y = 40.0

[background]
color = [0.3, 0.4, 0.6]

[materials.orange]
type = "diffuse"
color = [0.8, 0.5, 0.3]

[[lights]]
type = "point"
position = [0, 0, 6]
intensity = [40, 40, 40]

[[objects]]
type = "sphere"
center = [-0.6, 0.2, 0]
radius = 1.1
material = "orange"

[[objects]]
type = "sphere"
center = [1.2, -0.5, 0.5]
radius = 0.6
material = "orange"
"#;

struct Case {
    dir: tempfile::TempDir,
}

impl Case {
    fn new() -> Case {
        let case = Case { dir: tempfile::tempdir().expect("tempdir") };
        std::fs::write(case.path("scene.toml"), SCENE).expect("write scene");
        case
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    fn command(&self, args: &[&str]) -> Command {
        let mut c = Command::new(BIN);
        c.args(args).current_dir(self.dir.path()).env_remove("SLURM_CPUS_PER_TASK");
        c
    }

    fn run(&self, args: &[&str]) -> Output {
        self.command(args).output().expect("run wavetrace")
    }

    /// Names in the folder, sorted.
    fn names(&self) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(self.dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    /// Makes a character device node `name` (`mknod NAME c MAJOR MINOR`); false, with a
    /// note, where that is not allowed (not root).
    fn mknod(&self, name: &str, major: u32, minor: u32) -> bool {
        let ok = Command::new("mknod")
            .arg(self.path(name))
            .args(["c", &major.to_string(), &minor.to_string()])
            .status()
            .is_ok_and(|s| s.success());
        if !ok {
            eprintln!("note: mknod {name} c {major} {minor} failed (not root?): that part is skipped");
        }
        ok
    }
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn is_char_device(p: &Path) -> bool {
    std::fs::symlink_metadata(p).is_ok_and(|m| m.file_type().is_char_device())
}

fn png_dims(p: &Path) -> (u32, u32) {
    let img = image::open(p).expect("readable PNG");
    (img.width(), img.height())
}

#[test]
fn device_nodes_are_written_in_place_not_replaced() {
    let case = Case::new();
    if !(case.mknod("null.png", 1, 3) && case.mknod("null.json", 1, 3) && case.mknod("full.json", 1, 7)) {
        return;
    }
    let o = case.run(&["scene.toml", "-o", "null.png", "--stats-json", "null.json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(is_char_device(&case.path("null.png")), "the image's device node was replaced");
    assert!(is_char_device(&case.path("null.json")), "the stats' device node was replaced");

    // A device that refuses the bytes (/dev/full: no space) is a write error, and the
    // node is still a device afterwards.
    let o = case.run(&["scene.toml", "-o", "out.png", "--trace", "full.json"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("full.json"), "{}", stderr(&o));
    assert!(is_char_device(&case.path("full.json")));
    assert!(!case.names().iter().any(|n| n.contains(".tmp")), "no temporary file left: {:?}", case.names());
}

#[test]
fn a_symlinked_output_writes_its_target_and_keeps_the_link() {
    let case = Case::new();
    std::fs::create_dir(case.path("real")).unwrap();
    std::os::unix::fs::symlink("real/target.png", case.path("link.png")).unwrap();
    std::os::unix::fs::symlink("real/stats.json", case.path("stats.json")).unwrap();
    std::fs::write(case.path("real/stats.json"), "old").unwrap();
    let o = case.run(&["scene.toml", "-o", "link.png", "--stats-json", "stats.json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for link in ["link.png", "stats.json"] {
        let meta = std::fs::symlink_metadata(case.path(link)).unwrap();
        assert!(meta.file_type().is_symlink(), "{link} is no longer a symlink");
    }
    assert_eq!(png_dims(&case.path("real/target.png")), (8, 6), "the dangling link's target was created");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(case.path("real/stats.json")).unwrap()).unwrap();
    assert_eq!(json["width"], 8);
    let mut real: Vec<String> =
        std::fs::read_dir(case.path("real")).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    real.sort();
    assert_eq!(real, ["stats.json", "target.png"], "no temporary file left beside the target");
}

#[test]
fn a_fifo_output_is_written_to_its_reader() {
    let case = Case::new();
    let fifo = case.path("stats.fifo");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo).expect("read the FIFO"))
    };
    let o = case.run(&["scene.toml", "-o", "out.png", "--stats-json", "stats.fifo"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = reader.join().unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).expect("the stats JSON came through the FIFO");
    assert_eq!(json["height"], 6);
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo(), "the FIFO was replaced");
}

#[test]
fn folders_and_sockets_are_refused_before_any_work() {
    let case = Case::new();
    std::fs::create_dir(case.path("dir.json")).unwrap();
    let sock = std::os::unix::net::UnixListener::bind(case.path("sock.json")).unwrap();
    for (name, what) in [("dir.json", "a folder"), ("sock.json", "a socket")] {
        let o = case.run(&["scene.toml", "-o", "out.png", "--stats-json", name]);
        assert_eq!(o.status.code(), Some(2), "{name}: {}", stderr(&o));
        assert!(stderr(&o).contains(name) && stderr(&o).contains(what), "{}", stderr(&o));
        assert!(!case.path("out.png").exists(), "{name}: nothing is rendered or written");
    }
    drop(sock);
}

#[test]
fn outputs_naming_one_file_are_refused_before_any_work() {
    let case = Case::new();
    std::fs::write(case.path("keep.png"), "earlier").unwrap();
    std::os::unix::fs::symlink("keep.png", case.path("alias.png")).unwrap();
    let cases: [&[&str]; 5] = [
        &["-o", "x.png", "--heatmap", "rays=x.png"],
        &["-o", "x.png", "--heatmap", "aa=./x.png"],
        &["-o", "keep.png", "--heatmap", "rays=alias.png"],
        &["-o", "out.png", "--stats-json", "s.json", "--trace", "s.json"],
        &["-o", "out.png", "--stats-json", "-", "--trace", "-"],
    ];
    for args in cases {
        let o = case.command(&["scene.toml"]).args(args).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("same file"), "{args:?}: {}", stderr(&o));
        assert!(o.stdout.is_empty(), "{args:?}: nothing on stdout");
    }
    // The scene itself is an input: no output may overwrite it.
    let o = case.run(&["scene.toml", "-o", "out.png", "--stats-json", "scene.toml"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("the scene"), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(case.path("scene.toml")).unwrap(), SCENE);
    assert_eq!(std::fs::read_to_string(case.path("keep.png")).unwrap(), "earlier");
    assert_eq!(case.names(), ["alias.png", "keep.png", "scene.toml"], "nothing written");
}

#[test]
fn merge_refuses_an_output_that_is_one_of_its_inputs() {
    let case = Case::new();
    std::fs::write(case.path("a.exr"), "tile a").unwrap();
    std::fs::write(case.path("b.png"), "tile b").unwrap();
    let o = case.run(&["merge", "a.exr", "b.png", "-o", "b.png"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("b.png") && stderr(&o).contains("input tile"), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(case.path("b.png")).unwrap(), "tile b", "the input is untouched");
    let o = case.run(&["merge", "a.exr", "b.png", "-o", "out.png", "--stats-json", "a.exr"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(case.path("a.exr")).unwrap(), "tile a");
    assert_eq!(case.names(), ["a.exr", "b.png", "scene.toml"]);
}

#[test]
fn thread_counts_over_the_limit_are_refused_at_once() {
    let case = Case::new();
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    let limit = (4 * cpus).clamp(64, 1024);
    let start = std::time::Instant::now();
    for args in [&["scene.toml", "--threads", "100000"][..], &["bench", "--threads", "5000"]] {
        let o = case.run(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(&format!("limit of {limit}")), "{args:?}: {}", stderr(&o));
    }
    let over = (limit + 1).to_string();
    let o = case.run(&["scene.toml", "-o", "out.png", "--threads", &over]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = case.command(&["scene.toml", "-o", "out.png"]).env("SLURM_CPUS_PER_TASK", &over).output().unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("SLURM_CPUS_PER_TASK") && stderr(&o).contains(&format!("limit of {limit}")));
    assert!(start.elapsed().as_secs() < 20, "refused before any work");
    assert_eq!(case.names(), ["scene.toml"]);
    // The limit itself is accepted.
    let o = case.run(&["scene.toml", "-o", "out.png", "--threads", &limit.to_string()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// The stats JSON of a render with `args`, read from stdout (`--stats-json -`).
fn stats_on_stdout(case: &Case, args: &[&str]) -> (serde_json::Value, String) {
    let o = case.command(&["scene.toml", "-o", "out.png", "--stats-json", "-"]).args(args).output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let json = serde_json::from_slice(&o.stdout)
        .unwrap_or_else(|e| panic!("stdout is not one JSON document ({e}):\n{}", String::from_utf8_lossy(&o.stdout)));
    (json, stderr(&o))
}

#[test]
fn stats_json_to_stdout_keeps_stdout_pure_json() {
    let case = Case::new();
    let (json, err) = stats_on_stdout(&case, &["--stats"]);
    assert_eq!(json["width"], 8);
    assert!(err.contains("-> out.png"), "the summary goes to stderr: {err}");
    assert!(!case.path("-").exists(), "no file named `-`");
    // The trace likewise.
    let o = case.run(&["scene.toml", "-o", "out.png", "--trace", "-"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let trace: serde_json::Value = serde_json::from_slice(&o.stdout).expect("the trace is the whole of stdout");
    assert!(trace.is_object() || trace.is_array());
    assert!(!case.path("-").exists());
    // An image is never written to stdout.
    let o = case.run(&["scene.toml", "-o", "-"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn spp_and_res_set_the_samples_and_the_size() {
    let case = Case::new();
    let (json, _) = stats_on_stdout(&case, &["--spp", "3", "--res", "5x4"]);
    assert_eq!((json["width"].as_u64(), json["height"].as_u64()), (Some(5), Some(4)));
    assert_eq!(json["rays"]["camera"], 5 * 4 * 3, "{json}");
    assert_eq!(png_dims(&case.path("out.png")), (5, 4));
    // An explicit --set wins over the shorthand.
    let (json, _) = stats_on_stdout(&case, &["--spp", "3", "--set", "render.aa.samples=1", "--res", "5x4"]);
    assert_eq!(json["rays"]["camera"], 5 * 4, "{json}");
    for bad in [&["--res", "5"][..], &["--res", "0x4"], &["--res", "5x-1"], &["--spp", "0"]] {
        let o = case.command(&["scene.toml", "-o", "bad.png"]).args(bad).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{bad:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(bad[0]), "{bad:?}: {}", stderr(&o));
    }
    assert!(!case.path("bad.png").exists());
}

#[test]
fn a_scene_that_can_show_nothing_renders_with_a_warning() {
    let case = Case::new();
    let dark =
        SCENE.replace("intensity = [40, 40, 40]", "intensity = [0, 0, 0]").replace("[0.3, 0.4, 0.6]", "[0, 0, 0]");
    std::fs::write(case.path("dark.toml"), dark).unwrap();
    let o = case.run(&["dark.toml", "-o", "dark.png"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("warning") && stderr(&o).contains("black"), "{}", stderr(&o));
    assert_eq!(png_dims(&case.path("dark.png")), (8, 6));
    let o = case.run(&["scene.toml", "-o", "lit.png"]);
    assert!(!stderr(&o).contains("warning"), "a lit scene has no warning: {}", stderr(&o));
}

/// Ctrl-C in adaptive mode: the pixels written are exactly the finished tiles', each
/// equal to the full render's, the rest black, and the message's pixel count is theirs.
/// The interrupt is sent at several delays until one lands in the pixel pass; one that
/// lands in the corner-grid pass must write no image at all.
#[test]
#[cfg(feature = "exr")]
fn ctrl_c_in_adaptive_mode_writes_exactly_the_finished_tiles() {
    use std::process::Stdio;
    use wavetrace::tools::compare::load_linear;
    let case = Case::new();
    let args = ["scene.toml", "--set", "render.aa.mode=adaptive", "--res", "800x800", "--threads", "2"];
    let start = std::time::Instant::now();
    let o = case.command(&args).args(["-o", "full.exr"]).output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let full_seconds = start.elapsed().as_secs_f64();
    let full = load_linear(&case.path("full.exr")).unwrap();
    assert!(full.pixels.iter().all(|p| p.max_element() > 0.0), "the fixture has no black pixel");
    let total = full.pixels.len() as u64;

    for fraction in [0.6, 0.8, 0.4, 0.9, 0.7, 0.5, 0.95, 0.3] {
        let _ = std::fs::remove_file(case.path("part.exr"));
        let child =
            case.command(&args).args(["-o", "part.exr"]).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
        std::thread::sleep(std::time::Duration::from_secs_f64(full_seconds * fraction));
        let _ = Command::new("kill").args(["-INT", &child.id().to_string()]).status();
        let out = child.wait_with_output().unwrap();
        let err = stderr(&out);
        match out.status.code() {
            Some(0) => continue, // finished before the interrupt
            Some(130) => {}
            other => {
                // The interrupt came before the handler was installed (killed by the signal).
                assert!(other.is_none(), "{other:?}: {err}");
                continue;
            }
        }
        if err.contains("0 of") && !case.path("part.exr").exists() {
            assert!(err.contains("not written"), "{err}");
            continue; // stopped in the corner-grid pass: nothing to show, nothing written
        }
        let claimed: u64 = err
            .split("finished tiles, ")
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("no pixel count in: {err}"));
        let part = load_linear(&case.path("part.exr")).unwrap();
        assert_eq!((part.width, part.height), (full.width, full.height));
        let mut equal = 0u64;
        for (i, (p, q)) in part.pixels.iter().zip(&full.pixels).enumerate() {
            if p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits) {
                equal += 1;
            } else {
                assert_eq!(p.max_element(), 0.0, "pixel {i}: neither the full render's ({q}) nor black ({p})");
            }
        }
        assert_eq!(equal, claimed, "the finished pixels are exactly the ones the message counts: {err}");
        assert!(err.contains(&format!("of {total} pixels")), "{err}");
        if claimed > 0 && claimed < total {
            eprintln!("interrupted at {fraction} of {full_seconds:.2} s: {claimed} of {total} pixels, all checked");
            return; // an interrupt inside the pixel pass, checked
        }
    }
    panic!("no interrupt landed inside the pixel pass (full render {full_seconds:.2} s)");
}

/// Writes `text` to `root/rel`, making its folders.
fn put(root: &Path, rel: &str, text: &str) {
    let p = root.join(rel);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(p, text).unwrap();
}

#[test]
fn cgroup_v2_limits_are_read_at_every_level_up_to_the_root() {
    use wavetrace::system::cgroup_memory;
    let t = tempfile::tempdir().unwrap();
    let root = t.path();
    assert_eq!(cgroup_memory(root), None, "no /proc/self/cgroup: nothing known");
    put(root, "proc/self/cgroup", "0::/job_7/step_0/task_0\n");
    assert_eq!(cgroup_memory(root), None, "no memory files: no limit");
    // The process's own cgroup is unlimited; the job two levels up holds the limit.
    put(root, "sys/fs/cgroup/job_7/step_0/task_0/memory.max", "max\n");
    put(root, "sys/fs/cgroup/job_7/step_0/task_0/memory.current", "1000\n");
    put(root, "sys/fs/cgroup/job_7/memory.max", "8000\n");
    put(root, "sys/fs/cgroup/job_7/memory.current", "3000\n");
    assert_eq!(cgroup_memory(root), Some(5000), "an ancestor's limit binds");
    // A tighter level in between wins; the smallest room over all levels.
    put(root, "sys/fs/cgroup/job_7/step_0/memory.max", "4500\n");
    put(root, "sys/fs/cgroup/job_7/step_0/memory.current", "1000\n");
    assert_eq!(cgroup_memory(root), Some(3500));
    // The hierarchy's root counts too.
    put(root, "sys/fs/cgroup/memory.max", "2000\n");
    assert_eq!(cgroup_memory(root), Some(2000));
    // Usage above the limit leaves no room, not an underflow.
    put(root, "sys/fs/cgroup/memory.current", "9000\n");
    assert_eq!(cgroup_memory(root), Some(0));
}

#[test]
fn cgroup_v1_limits_are_read_and_unlimited_does_not_bind() {
    use wavetrace::system::cgroup_memory;
    let t = tempfile::tempdir().unwrap();
    let root = t.path();
    put(root, "proc/self/cgroup", "12:cpu,cpuacct:/slurm/uid_0/job_9\n4:memory:/slurm/uid_0/job_9/step_batch\n");
    let v1 = "sys/fs/cgroup/memory";
    // v1's "unlimited" is a number near 2^63: it never binds.
    put(root, &format!("{v1}/slurm/uid_0/job_9/step_batch/memory.limit_in_bytes"), "9223372036854771712\n");
    put(root, &format!("{v1}/slurm/uid_0/job_9/step_batch/memory.usage_in_bytes"), "100\n");
    assert_eq!(cgroup_memory(root), Some(9223372036854771712 - 100));
    put(root, &format!("{v1}/slurm/uid_0/job_9/memory.limit_in_bytes"), "1000000\n");
    put(root, &format!("{v1}/slurm/uid_0/job_9/memory.usage_in_bytes"), "250000\n");
    assert_eq!(cgroup_memory(root), Some(750000), "the job's limit above the step's binds");
    // A v2 line beside it (hybrid): the smaller room of both hierarchies.
    put(root, "proc/self/cgroup", "4:memory:/slurm/uid_0/job_9/step_batch\n0::/user.slice\n");
    put(root, "sys/fs/cgroup/user.slice/memory.max", "600000\n");
    assert_eq!(cgroup_memory(root), Some(600000));
}
