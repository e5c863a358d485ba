//! Outputs that never destroy, inputs that never fool (issues 26 and 42): where each
//! kind of output path leads (regular file, symlink, character device, FIFO, `-`),
//! outputs that name one file or a file the scene reads, read-only outputs and folders,
//! all-or-nothing writes, SIGINT/SIGTERM/SIGHUP at any moment, fixed-length arrays, the
//! translation bound of `transform_end`, the thread limit, the command-line shorthands
//! and the messages that name what the user typed, the warning for a scene that shows
//! nothing, Ctrl-C in adaptive mode, and the cgroup memory reader on fake cgroup trees.
//! Every node (device, FIFO, symlink, read-only file or folder) is made inside the
//! test's own temporary folder.

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
/// lands in the corner-grid pass, or in the writing of the finished image, must leave no
/// image at all.
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
        if err.contains("interrupted: written: nothing") && !case.path("part.exr").exists() {
            // Stopped while the finished render was being written: nothing half-written
            // is left behind (the signals test checks this case on its own).
            assert!(err.contains("not written: `part.exr`"), "{err}");
            assert!(temporaries(case.dir.path()).is_empty(), "a temporary file is left: {err}");
            continue;
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

/// [`SCENE`] reading files beside it: its material's colour is a texture (`tex.png`) and
/// its first sphere a mesh (`tri.obj`).
fn scene_with_files() -> String {
    let textured = SCENE.replacen("color = [0.8, 0.5, 0.3]", r#"color = { type = "bitmap", file = "tex.png" }"#, 1);
    let sphere = "type = \"sphere\"\ncenter = [-0.6, 0.2, 0]\nradius = 1.1\n";
    assert!(textured.contains(sphere) && textured != SCENE, "SCENE changed: update scene_with_files");
    textured.replacen(sphere, "type = \"mesh\"\nfile = \"tri.obj\"\n", 1)
}

/// A Mitsuba scene whose BSDF is in an included file.
const MAIN_XML: &str = r#"<scene version="3.0.0">
    <default name="spp" value="1"/>
    <include filename="inc.xml"/>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
    </sensor>
    <shape type="sphere"><ref id="grey"/></shape>
    <emitter type="point"><point name="position" value="0, 0, -5"/><rgb name="intensity" value="10"/></emitter>
</scene>
"#;

const INC_XML: &str = r#"<scene version="3.0.0">
    <bsdf type="diffuse" id="grey"/>
</scene>
"#;

/// Writes the files [`scene_with_files`] and [`MAIN_XML`] read.
fn with_files(case: &Case) {
    std::fs::write(case.path("files.toml"), scene_with_files()).unwrap();
    std::fs::write(case.path("tri.obj"), "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n")
        .unwrap();
    image::RgbImage::from_pixel(2, 2, image::Rgb([200, 120, 40])).save(case.path("tex.png")).unwrap();
    std::fs::write(case.path("main.xml"), MAIN_XML).unwrap();
    std::fs::write(case.path("inc.xml"), INC_XML).unwrap();
}

/// Every file a scene reads (meshes, textures, includes) is an input no output may
/// overwrite, refused before the render with both uses named (issue 42).
#[test]
fn outputs_never_overwrite_the_files_the_scene_reads() {
    let case = Case::new();
    with_files(&case);
    let before: Vec<(String, Vec<u8>)> =
        case.names().into_iter().map(|n| (n.clone(), std::fs::read(case.path(&n)).unwrap())).collect();
    let cases: [(&[&str], &str); 5] = [
        (&["files.toml", "-o", "tex.png"], "the texture of `materials.orange.color`"),
        (&["files.toml", "-o", "out.png", "--stats-json", "tri.obj"], "the mesh of `objects.0`"),
        (&["files.toml", "-o", "out.png", "--heatmap", "rays=./tex.png"], "the texture"),
        (&["main.xml", "-o", "out.png", "--trace", "inc.xml"], "a file the scene includes"),
        (&["main.xml", "-o", "out.png", "--stats-json", "main.xml"], "the scene"),
    ];
    for (args, use_) in cases {
        let o = case.run(args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        let output = args[args.len() - 1].rsplit('=').next().unwrap();
        assert!(err.contains(use_) && err.contains(output.trim_start_matches("./")), "{args:?}: {err}");
        assert!(err.contains("-o") || err.contains("--"), "the output's flag is named: {err}");
    }
    let after: Vec<(String, Vec<u8>)> =
        case.names().into_iter().map(|n| (n.clone(), std::fs::read(case.path(&n)).unwrap())).collect();
    assert_eq!(before, after, "nothing written, nothing changed");
    // The same scenes render when the outputs go elsewhere.
    for scene in ["files.toml", "main.xml"] {
        let o = case.run(&[scene, "-o", "out.png"]);
        assert_eq!(o.status.code(), Some(0), "{scene}: {}", stderr(&o));
    }
}

/// The mode bits of a path, as `ls` shows them.
fn mode(p: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt;
    std::fs::symlink_metadata(p).unwrap().permissions().mode() & 0o7777
}

fn set_mode(p: &Path, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(p, std::fs::Permissions::from_mode(mode)).unwrap();
}

/// A read-only output, and an output in a folder that does not let it be replaced, are
/// refused by their mode bits, so root (which may write anything) is refused too; a
/// writable output that is replaced keeps its mode.
#[test]
fn read_only_outputs_and_folders_are_refused() {
    let case = Case::new();
    std::fs::write(case.path("ro.png"), "earlier").unwrap();
    set_mode(&case.path("ro.png"), 0o444);
    std::os::unix::fs::symlink("ro.png", case.path("link.png")).unwrap();
    std::fs::create_dir(case.path("locked")).unwrap();
    std::fs::write(case.path("locked/old.png"), "earlier").unwrap();
    set_mode(&case.path("locked"), 0o555);
    let cases: [(&[&str], &[&str]); 5] = [
        (&["-o", "ro.png"], &["ro.png", "read-only", "444"]),
        (&["-o", "out.png", "--stats-json", "ro.png"], &["ro.png", "444"]),
        (&["-o", "link.png"], &["link.png", "444", "symlink"]),
        (&["-o", "locked/old.png"], &["locked", "555"]),
        (&["-o", "locked/new.png"], &["locked", "555"]),
    ];
    for (args, words) in cases {
        let o = case.command(&["scene.toml"]).args(args).output().unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(words.iter().all(|w| err.contains(w)), "{args:?} names {words:?}: {err}");
    }
    assert_eq!(std::fs::read_to_string(case.path("ro.png")).unwrap(), "earlier");
    assert_eq!(mode(&case.path("ro.png")), 0o444, "the file keeps its mode");
    assert_eq!(std::fs::read_to_string(case.path("locked/old.png")).unwrap(), "earlier");
    assert!(!case.path("locked/new.png").exists());
    assert_eq!(case.names(), ["link.png", "locked", "ro.png", "scene.toml"], "nothing written");
    set_mode(&case.path("locked"), 0o755);

    // A writable file is replaced, and keeps its mode (a private file stays private).
    std::fs::write(case.path("private.png"), "earlier").unwrap();
    set_mode(&case.path("private.png"), 0o600);
    let o = case.run(&["scene.toml", "-o", "private.png"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(png_dims(&case.path("private.png")), (8, 6));
    assert_eq!(mode(&case.path("private.png")), 0o600);
}

/// Runs wavetrace with a file size limit of `bytes` (RLIMIT_FSIZE, SIGXFSZ ignored, so
/// a write past it fails with EFBIG as on a full disk).
fn run_with_file_limit(case: &Case, args: &[&str], bytes: u64) -> Output {
    use std::os::unix::process::CommandExt;
    let mut c = case.command(args);
    // SAFETY: setrlimit and signal are async-signal-safe; nothing else runs in the child.
    unsafe {
        c.pre_exec(move || {
            let limit = libc::rlimit { rlim_cur: bytes, rlim_max: bytes };
            libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
            if libc::setrlimit(libc::RLIMIT_FSIZE, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    c.output().unwrap()
}

/// All or nothing: an output that cannot be written (a file past the disk's room, here
/// a file size limit) leaves every output as it was, the earlier ones too; a device,
/// written in place after every file is in place, says what was written before it.
#[test]
fn a_failing_output_leaves_every_earlier_file_as_it_was() {
    let case = Case::new();
    for name in ["out.png", "trace.json", "stats.json"] {
        std::fs::write(case.path(name), format!("earlier {name}")).unwrap();
    }
    // The image (about 200 bytes) and the trace (about 500) fit in 4 KiB; the stats
    // (about 9 KiB) do not, and they are written last.
    let args = ["scene.toml", "-o", "out.png", "--trace", "trace.json", "--stats-json", "stats.json"];
    let o = run_with_file_limit(&case, &args, 4096);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("stats.json") && err.contains("cannot write"), "{err}");
    for name in ["out.png", "trace.json", "stats.json"] {
        assert_eq!(std::fs::read_to_string(case.path(name)).unwrap(), format!("earlier {name}"), "{name}: {err}");
    }
    assert_eq!(case.names(), ["out.png", "scene.toml", "stats.json", "trace.json"], "no temporary file left");
    // Without the limit all three are written.
    let o = case.run(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(png_dims(&case.path("out.png")), (8, 6));

    // A device that refuses the bytes comes after every file: the message says which
    // were written before it.
    if case.mknod("full.json", 1, 7) {
        let o = case.run(&["scene.toml", "-o", "new.png", "--stats-json", "full.json"]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains("full.json") && err.contains("already written: `new.png`"), "{err}");
        assert_eq!(png_dims(&case.path("new.png")), (8, 6));
    }
}

/// Temporary files in a folder: hidden names ending in `.tmp`.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.') && n.ends_with(".tmp"))
        .collect()
}

/// The outputs an interrupted command's message lists after `label` (`written: ` or
/// `not written: `), up to the next `;`.
fn listed(err: &str, label: &str) -> Vec<String> {
    let line = err.lines().find(|l| l.starts_with("interrupted: written: ")).unwrap_or("");
    let Some(rest) = line.split(&format!("; {label}")).nth(1).or_else(|| line.split(label).nth(1)) else {
        return Vec::new();
    };
    rest.split(';').next().unwrap_or("").split(", ").map(|s| s.trim().trim_matches('`').to_string()).collect()
}

/// SIGINT, SIGTERM and SIGHUP at several moments: while a temporary file is being
/// written (the final write, where a SLURM time limit's SIGTERM lands), twice (the
/// second during the write of what the first left finished), and once during the
/// render. Each time no temporary file is left, every output is either its earlier
/// file or whole, and the message says which were written and which not.
#[test]
fn signals_remove_the_temporary_files_and_say_what_was_written() {
    use std::process::Stdio;
    use std::time::{Duration, Instant};
    let case = Case::new();
    let args = ["scene.toml", "--res", "1000x1000", "--threads", "2", "-o", "out.png"];
    let more = ["--heatmap", "rays=rays.png", "--stats-json", "stats.json"];
    let start = Instant::now();
    let o = case.command(&args).args(more).output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let full_seconds = start.elapsed().as_secs_f64();
    let outputs = ["out.png", "rays.png", "stats.json"];
    let whole = |name: &str| match name {
        "out.png" => image::open(case.path(name)).is_ok_and(|i| (i.width(), i.height()) == (1000, 1000)),
        "rays.png" => image::open(case.path(name)).is_ok(),
        _ => serde_json::from_slice::<serde_json::Value>(&std::fs::read(case.path(name)).unwrap()).is_ok(),
    };
    let send = |pid: u32, sig: libc::c_int| {
        // SAFETY: kill with the child's own pid, which it holds until it is waited for.
        unsafe { libc::kill(pid as libc::pid_t, sig) };
    };
    let wait_for_temporary = |child: &mut std::process::Child| {
        let deadline = Instant::now() + Duration::from_secs_f64(10.0 + 4.0 * full_seconds);
        while temporaries(case.dir.path()).is_empty() && Instant::now() < deadline {
            if child.try_wait().unwrap().is_some() {
                return false;
            }
            std::thread::sleep(Duration::from_micros(200));
        }
        true
    };
    let mut hit_the_write = 0;
    for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
        for moment in ["write", "twice", "render"] {
            for name in outputs {
                std::fs::write(case.path(name), "earlier").unwrap();
            }
            let mut child =
                case.command(&args).args(more).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
            let mut during_write = false;
            match moment {
                "write" => during_write = wait_for_temporary(&mut child),
                "twice" => {
                    std::thread::sleep(Duration::from_secs_f64(full_seconds * 0.5));
                    send(child.id(), sig);
                    during_write = wait_for_temporary(&mut child);
                }
                _ => std::thread::sleep(Duration::from_secs_f64(full_seconds * 0.6)),
            }
            send(child.id(), sig);
            let out = child.wait_with_output().unwrap();
            let err = stderr(&out);
            let what = format!("signal {sig} at {moment}: {err}");
            assert!(temporaries(case.dir.path()).is_empty(), "{what}: {:?}", case.names());
            for name in outputs {
                let earlier = std::fs::read(case.path(name)).unwrap() == b"earlier";
                assert!(earlier || whole(name), "{name} is neither the earlier file nor whole: {what}");
                if listed(&err, "not written: ").contains(&name.to_string()) {
                    assert!(earlier, "{name} is listed as not written: {what}");
                }
                if listed(&err, "written: ").contains(&name.to_string()) {
                    assert!(whole(name), "{name} is listed as written: {what}");
                }
            }
            match out.status.code() {
                Some(130) => assert!(err.contains("interrupted"), "{what}"),
                // The signal came as the process ended, after the last output was in place.
                Some(0) => assert!(outputs.iter().all(|n| whole(n)), "exit 0 with an output unwritten: {what}"),
                other => panic!("exit {other:?}: {what}"),
            }
            if during_write && out.status.code() == Some(130) {
                assert_eq!(out.status.code(), Some(130), "{what}");
                assert!(err.contains("not written: ") && err.contains("temporary file"), "{what}");
                hit_the_write += 1;
            }
        }
    }
    // Six tries aim at the write; the process may finish first on a busy machine.
    assert!(hit_the_write >= 2, "a signal landed during the write only {hit_the_write} times of 6");
    eprintln!("signals landed during the write {hit_the_write} times of 6");
}

fn expect_refusal(case: &Case, args: &[&str], words: &[&str]) -> String {
    let o = case.run(args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(words.iter().all(|w| err.contains(w)), "{args:?} should name {words:?}: {err}");
    err
}

/// Every fixed-length array of the scene format refuses another length, naming the
/// field, in a file and through `--set` alike (a file's extra numbers used to be
/// dropped: `shutter = [0, 1, 0.5]` rendered as `[0, 1]`).
#[test]
fn fixed_length_arrays_refuse_other_lengths_in_files_and_sets() {
    let case = Case::new();
    let edits: [(&str, &str, &[&str]); 11] = [
        ("fov_y = 40.0", "fov_y = 40.0\nshutter = [0, 1, 0.5]", &["camera.shutter", "2 numbers, not 3"]),
        ("fov_y = 40.0", "fov_y = 40.0\nshutter = [0, 1, 0.5, 7, -3]", &["camera.shutter", "not 5"]),
        ("position = [0, 0, 6]\nlook_at", "position = [0, 0, 6, 1]\nlook_at", &["camera.position", "not 4"]),
        ("look_at = [0, 0, 0]", "look_at = [0, 0, 0, 0, 0]", &["camera.look_at", "not 5"]),
        ("fov_y = 40.0", "fov_y = 40.0\nup = [0, 1]", &["camera.up", "not 2"]),
        ("color = [0.3, 0.4, 0.6]", "color = [0.3, 0.4, 0.6, 1]", &["background.color", "not 4"]),
        ("color = [0.8, 0.5, 0.3]", "color = [0.8, 0.5]", &["materials.orange", "`color` takes 3 numbers", "not 2"]),
        ("intensity = [40, 40, 40]", "intensity = [40, 40]", &["`intensity` takes 3 numbers, not 2"]),
        ("center = [-0.6, 0.2, 0]", "center = [-0.6, 0.2, 0, 9]", &["`center` takes 3 numbers, not 4"]),
        ("radius = 0.6", "radius = 0.6\ntransform = [{ translate = [1, 2, 3, 4] }]", &["translate", "not 4"]),
        ("fov_y = 40.0", "fov_y = 40.0\ntransform_end = [{ matrix = [1, 0, 0, 0] }]", &["camera.transform_end", "16"]),
    ];
    for (from, to, words) in edits {
        assert!(SCENE.contains(from), "{from}");
        std::fs::write(case.path("bad.toml"), SCENE.replacen(from, to, 1)).unwrap();
        expect_refusal(&case, &["bad.toml", "-o", "out.png"], &[&["bad.toml"][..], words].concat());
    }
    let sets: [(&str, &[&str]); 4] = [
        ("camera.shutter=[0, 1, 0.5]", &["camera.shutter", "2 numbers, not 3"]),
        ("camera.look_at=[0, 0, 0, 1]", &["camera.look_at", "not 4"]),
        ("objects.0.center=[0, 0, 0, 1]", &["objects.0.center", "not 4"]),
        ("background.color=[1]", &["background.color", "not 1"]),
    ];
    for (set, words) in sets {
        expect_refusal(&case, &["scene.toml", "-o", "out.png", "--set", set], words);
    }
    assert_eq!(case.names(), ["bad.toml", "scene.toml"], "nothing written");
    // The right lengths are read whole.
    std::fs::write(case.path("ok.toml"), SCENE.replacen("fov_y = 40.0", "fov_y = 40.0\nshutter = [0, 0.5]", 1))
        .unwrap();
    let o = case.run(&["ok.toml", "-o", "out.png", "--set", "objects.0.center=[0, 0, 0]"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// `transform_end` is held to the bound `transform` is (a translation of 1e30 used to
/// pass at time 1), for objects and the camera.
#[test]
fn one_bound_for_translations_in_transform_and_transform_end() {
    let case = Case::new();
    let sphere = "radius = 0.6";
    let cases: [(&str, &str, &str); 3] = [
        (sphere, "radius = 0.6\ntransform = [{ translate = [1e30, 0, 0] }]", "objects.1.transform"),
        (sphere, "radius = 0.6\ntransform_end = [{ translate = [1e30, 0, 0] }]", "objects.1.transform_end"),
        ("fov_y = 40.0", "fov_y = 40.0\ntransform_end = [{ translate = [0, 0, 1e30] }]", "camera.transform_end"),
    ];
    for (from, to, field) in cases {
        std::fs::write(case.path("far.toml"), SCENE.replacen(from, to, 1)).unwrap();
        expect_refusal(&case, &["far.toml", "-o", "out.png"], &[field, "4e9"]);
        let shutter = SCENE.replacen(from, to, 1).replacen("fov_y = 40.0", "fov_y = 40.0\nshutter = [0, 1]", 1);
        std::fs::write(case.path("far.toml"), shutter).unwrap();
        expect_refusal(&case, &["far.toml", "-o", "out.png"], &[field, "4e9"]);
    }
    let near = SCENE.replacen(sphere, "radius = 0.6\ntransform_end = [{ translate = [0.2, 0, 0] }]", 1);
    std::fs::write(case.path("near.toml"), near.replacen("fov_y = 40.0", "fov_y = 40.0\nshutter = [0, 1]", 1)).unwrap();
    let o = case.run(&["near.toml", "-o", "out.png"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// `--heatmap aa` with uniform anti-aliasing refines no pixel: a warning says the map
/// will show nothing (it used to equal the render without a word).
#[test]
fn a_heatmap_that_can_show_nothing_warns() {
    let case = Case::new();
    let o = case.run(&["scene.toml", "-o", "out.png", "--heatmap", "aa=aa.png", "--heatmap", "penumbra=pen.png"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("warning: --heatmap aa") && err.contains("anti-aliasing is uniform"), "{err}");
    assert!(err.contains("warning: --heatmap penumbra") && err.contains("shadows are uniform"), "{err}");
    let o = case.run(&["scene.toml", "-o", "out.png", "--heatmap", "aa=aa.png", "--set", "render.aa.mode=adaptive"]);
    assert!(!stderr(&o).contains("warning"), "adaptive: {}", stderr(&o));
}

/// `--seed -1` is refused as a seed, without clap's advice to write `-- -1` (which
/// would make `-1` the scene's name).
#[test]
fn a_negative_seed_is_refused_as_a_seed() {
    let case = Case::new();
    let err = expect_refusal(&case, &["scene.toml", "-o", "bad.png", "--seed", "-1"], &["--seed", "not a seed"]);
    assert!(!err.contains("-- -1"), "{err}");
    let err = expect_refusal(&case, &["scene.toml", "-o", "bad.png", "--threads", "-2"], &["--threads", "-2"]);
    assert!(!err.contains("-- -2"), "{err}");
    assert!(!case.path("bad.png").exists());
}

/// A size too big for memory given by `--res` names `--res`, not a `--set` the user
/// never typed.
#[test]
fn res_too_big_names_res() {
    let case = Case::new();
    let o = case
        .command(&["scene.toml", "-o", "bad.png", "--res", "100000x100000"])
        .env("WAVETRACE_MEMORY", "1073741824")
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("(--res 100000x100000)") && !err.contains("--set"), "{err}");
    // An explicit --set of the same key still names the --set.
    let o = case
        .command(&["scene.toml", "-o", "bad.png", "--res", "4x4", "--set", "render.height=100000000"])
        .env("WAVETRACE_MEMORY", "1073741824")
        .output()
        .unwrap();
    assert!(stderr(&o).contains("(--set render.height=100000000)"), "{}", stderr(&o));
}

/// A NaN vertex in an OBJ names its line.
#[test]
fn a_non_finite_obj_vertex_names_its_line() {
    let case = Case::new();
    std::fs::write(case.path("nan.obj"), "v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n").unwrap();
    let mesh = SCENE.replacen(
        "type = \"sphere\"\ncenter = [1.2, -0.5, 0.5]\nradius = 0.6",
        "type = \"mesh\"\nfile = \"nan.obj\"",
        1,
    );
    std::fs::write(case.path("nan.toml"), mesh).unwrap();
    expect_refusal(&case, &["nan.toml", "-o", "bad.png"], &["nan.obj", "line 3:", "non-finite"]);
    assert!(!case.path("bad.png").exists());
}

/// A missing bitmap of a scene in the working folder says it looked in `.` (it used to
/// say "looked in ``, ``").
#[test]
fn a_missing_bitmap_says_where_it_looked() {
    let case = Case::new();
    with_files(&case);
    let bitmap = MAIN_XML.replace(
        "<shape type=\"sphere\"><ref id=\"grey\"/></shape>",
        "<shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">\
         <string name=\"filename\" value=\"nope.png\"/></texture></bsdf></shape>",
    );
    std::fs::write(case.path("bitmap.xml"), bitmap).unwrap();
    let err = expect_refusal(&case, &["bitmap.xml", "-o", "out.png"], &["nope.png", "looked in `.`"]);
    assert!(!err.contains("``"), "{err}");
}

/// An error in an anonymous Mitsuba BSDF prints its place once (the BSDF used to be
/// named by its place: `x.xml:4:1: field `materials.x.xml:4:1.alpha``).
#[test]
fn an_anonymous_bsdf_error_prints_its_place_once() {
    let case = Case::new();
    with_files(&case);
    let rough = MAIN_XML.replace(
        "<shape type=\"sphere\"><ref id=\"grey\"/></shape>",
        "<shape type=\"sphere\">\n<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"-1\"/></bsdf></shape>",
    );
    std::fs::write(case.path("rough.xml"), rough).unwrap();
    let err = expect_refusal(&case, &["rough.xml", "-o", "out.png"], &["rough.xml:", "alpha", "-1"]);
    assert_eq!(err.matches("rough.xml").count(), 1, "the place is printed once: {err}");
}

/// An unset `$name` in a file made to be included says which files include it; in an
/// include, it names the file that includes it.
#[test]
fn an_unset_parameter_in_an_include_says_who_includes_it() {
    let case = Case::new();
    with_files(&case);
    // The sensor moved into an include that uses the main file's `$spp`.
    let sensor_start = MAIN_XML.find("    <sensor").unwrap();
    let sensor_end = MAIN_XML.find("</sensor>").unwrap() + "</sensor>\n".len();
    let sensor = &MAIN_XML[sensor_start..sensor_end];
    std::fs::write(case.path("camera.xml"), format!("<scene version=\"3.0.0\">\n{sensor}</scene>\n")).unwrap();
    let main = MAIN_XML.replace(sensor, "    <include filename=\"camera.xml\"/>\n");
    std::fs::write(case.path("shot.xml"), &main).unwrap();
    let o = case.run(&["shot.xml", "-o", "out.png"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    expect_refusal(&case, &["camera.xml", "-o", "out.png"], &["$spp", "meant to be included", "`shot.xml`"]);
    std::fs::write(case.path("unset.xml"), main.replace("<default name=\"spp\" value=\"1\"/>", "")).unwrap();
    expect_refusal(&case, &["unset.xml", "-o", "out.png"], &["camera.xml", "$spp", "included by `unset.xml`"]);
}
