//! The `wavetrace` command line: the clap definitions of every subcommand and the
//! `run` function of each, which turns parsed arguments into calls to the library.
//!
//! Choices are clap value enums (or parsers built on them), so a bad value is refused
//! while parsing, with the flag, the value and the accepted values in the message
//! (exit 2). Numbers that must be at least 1 share one clap range ([`at_least_one`]).
//!
//! One module per subcommand: [`render`] (also what runs with no subcommand),
//! [`compare`], [`sweep`], [`study`], [`bench`], [`merge`].

use clap::builder::{RangedU64ValueParser, TypedValueParser};
use clap::error::ErrorKind;
use clap::{Parser, Subcommand, ValueEnum};
use std::ffi::OsStr;
use std::path::PathBuf;

use wavetrace::scene::SceneSource;
use wavetrace::Result;

pub mod bench;
pub mod compare;
pub mod merge;
pub mod render;
pub mod study;
pub mod sweep;

/// A wavefront CPU ray tracer with adaptive sampling, soft shadows, refraction and depth of field.
#[derive(Parser, Debug)]
#[command(name = "wavetrace", version, args_conflicts_with_subcommands = true)]
pub struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// With no subcommand, `wavetrace` renders.
    #[command(flatten)]
    render: render::RenderArgs,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene to an image (the default command).
    Render(render::RenderArgs),
    /// Compare an image with a reference: RMSE, relative MSE, PSNR (linear) and mean LDR-FLIP.
    Compare(compare::CompareArgs),
    /// Render the cross product of parameter values and measure each against a reference:
    /// DIR/sweep.csv, DIR/sweep.json and error-vs-rays / error-vs-seconds plots.
    Sweep(sweep::SweepArgs),
    /// Where adaptive sampling pays: every method's cheapest setting per target FLIP, scene
    /// by scene, against the scene features: DIR/study.md, study.csv, study.json and plots.
    Study(study::StudyArgs),
    /// Trace fixed ray sets from a scene (primary, shadow, secondary) or a bare mesh with
    /// the packet, wide, interleaved, stream and hybrid kernels; print Mrays/s per set and kernel
    /// (median of --reps runs).
    Bench(bench::BenchArgs),
    /// Merge the tiles of one render (EXRs from render --crop/--tile) into the full
    /// image, after checking they come from one render and cover it exactly once.
    Merge(merge::MergeArgs),
}

/// Runs the parsed command; returns the exit status of a successful run (0, or 130 for a
/// render that Ctrl-C cut short).
pub fn run(cli: Cli) -> Result<i32> {
    match cli.command {
        Some(Command::Render(a)) => render::run(a),
        Some(Command::Compare(a)) => compare::run(a).map(|_| 0),
        Some(Command::Sweep(a)) => sweep::run(a).map(|_| 0),
        Some(Command::Study(a)) => study::run(a).map(|_| 0),
        Some(Command::Bench(a)) => bench::run(a).map(|_| 0),
        Some(Command::Merge(a)) => merge::run(a),
        None => render::run(cli.render),
    }
}

/// The value parser of counts that must be at least 1 (`--reps`, `--max-rays`,
/// `--reference-spp`; `--threads` has [`thread_count`]): one clap range, so every subcommand refuses 0 the
/// same way, while parsing.
pub fn at_least_one<T>() -> AtLeastOne<T> {
    AtLeastOne(std::marker::PhantomData)
}

/// See [`at_least_one`]: clap's `1..` range, with a message that says "must be at least
/// 1" (clap's own would print the integer type's whole range).
#[derive(Clone, Copy, Debug)]
pub struct AtLeastOne<T>(std::marker::PhantomData<T>);

impl<T> TypedValueParser for AtLeastOne<T>
where
    T: TryFrom<u64> + Clone + Send + Sync + 'static,
    <T as TryFrom<u64>>::Error: std::error::Error + Send + Sync + 'static,
{
    type Value = T;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &OsStr,
    ) -> std::result::Result<T, clap::Error> {
        RangedU64ValueParser::<T>::new().range(1..).parse_ref(cmd, arg, value).map_err(|e| {
            if e.kind() != ErrorKind::ValueValidation || value.to_str().and_then(|v| v.parse::<u64>().ok()) != Some(0) {
                return e;
            }
            let flag = arg.map_or_else(|| "the value".to_string(), |a| format!("'{a}'"));
            clap::Error::raw(ErrorKind::ValueValidation, format!("invalid value '0' for {flag}: must be at least 1\n"))
                .with_cmd(cmd)
        })
    }
}

/// The most worker threads a command accepts: 4 per CPU this process may use, at least
/// 64 (so a thread count that tests determinism runs on any machine), at most 1024.
/// Past a few per CPU more threads only add memory (each holds its own queues) and
/// switching; an unbounded count (`--threads 100000`) spawned threads until the process
/// was killed.
pub fn max_threads() -> usize {
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    cpus.saturating_mul(4).clamp(64, 1024)
}

/// Checks a worker-thread count (from a flag or an environment variable): at least 1
/// and at most [`max_threads`], else a message naming the limit.
pub fn check_threads(n: usize) -> std::result::Result<usize, String> {
    let max = max_threads();
    if n == 0 {
        return Err("must be at least 1".into());
    }
    if n > max {
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        return Err(format!(
            "{n} threads is more than the limit of {max} (4 per CPU, {cpus} CPUs here, at least 64, at most 1024)"
        ));
    }
    Ok(n)
}

/// The value parser of `--threads` (render, sweep, bench): a count in 1..=[`max_threads`],
/// refused while parsing (exit 2) otherwise.
pub fn thread_count(s: &str) -> std::result::Result<usize, String> {
    let n: usize = s.trim().parse().map_err(|_| format!("`{s}` is not a whole number of threads"))?;
    check_threads(n)
}

/// An on/off switch (`--split-mixed on`); `true` and `false` are accepted too.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Switch {
    /// On.
    #[value(alias = "true")]
    On,
    /// Off.
    #[value(alias = "false")]
    Off,
}

impl Switch {
    /// The switch of a boolean setting.
    pub fn of(on: bool) -> Switch {
        if on {
            Switch::On
        } else {
            Switch::Off
        }
    }

    /// True when on.
    pub fn is_on(self) -> bool {
        self == Switch::On
    }
}

/// Prints a line to stdout; a closed pipe (`| head`) is not an error worth a panic.
pub fn say(text: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stdout().lock(), "{text}");
}

/// The scene a subcommand reads: the file given, or the embedded default scene.
pub fn scene_source(path: Option<&PathBuf>) -> Result<SceneSource> {
    match path {
        Some(path) => SceneSource::from_file(path),
        None => Ok(SceneSource::default_scene()),
    }
}
