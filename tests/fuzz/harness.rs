//! The guards every fuzz case runs under: allocation accounting per case thread, a
//! watchdog for hangs, the rules a loaded scene must keep ([`check_scene`]), and the
//! property runner that counts verdicts ([`run_property`]).

use crate::promise;
use proptest::prelude::*;
use proptest::test_runner::{TestCaseError, TestRunner};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::{Cell, RefCell};
use std::path::Path;
use std::sync::{mpsc, Mutex, Once};
use std::time::{Duration, Instant};
use wavetrace::scene::SceneSource;

/// A case that takes longer than this is a hang.
pub(crate) const HANG_LIMIT: Duration = Duration::from_secs(30);
/// Most bytes a case thread may hold at once; past it the allocation fails, which aborts
/// the test binary with "memory allocation of N bytes failed" (an unbounded allocation).
const THREAD_CAP: isize = 1 << 30;
/// Most bytes one load of these small inputs may hold at once without failing the case.
pub(crate) const LOAD_MEMORY: isize = 256 << 20;
/// Largest generated scene text.
pub(crate) const MAX_SCENE_BYTES: usize = 8 << 10;
/// Most OBJ lines, and most OBJ bytes.
pub(crate) const MAX_OBJ_LINES: usize = 2000;
pub(crate) const MAX_OBJ_BYTES: usize = 64 << 10;
/// Overrides that keep a render tiny.
pub(crate) const TINY: [&str; 4] =
    ["render.width=4", "render.height=4", "render.aa.samples=1", "render.shadows.samples=1"];

/// Counts bytes held per thread; a guarded thread is refused past [`THREAD_CAP`].
struct Guard;

thread_local! {
    static GUARDED: Cell<bool> = const { Cell::new(false) };
    static LIVE: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
}

/// Records `delta` bytes for this thread; false when a guarded thread would pass its cap.
fn account(delta: isize) -> bool {
    LIVE.try_with(|live| {
        let now = live.get() + delta;
        if delta > 0 && now > THREAD_CAP && GUARDED.try_with(Cell::get).unwrap_or(false) {
            return false;
        }
        live.set(now);
        let _ = PEAK.try_with(|p| p.set(p.get().max(now)));
        true
    })
    .unwrap_or(true)
}

// SAFETY: every call is forwarded to `System` unchanged, or refused with null before it.
unsafe impl GlobalAlloc for Guard {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !account(layout.size() as isize) {
            return std::ptr::null_mut();
        }
        let p = System.alloc(layout);
        if p.is_null() {
            account(-(layout.size() as isize));
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !account(layout.size() as isize) {
            return std::ptr::null_mut();
        }
        let p = System.alloc_zeroed(layout);
        if p.is_null() {
            account(-(layout.size() as isize));
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout);
        account(-(layout.size() as isize));
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let delta = new_size as isize - layout.size() as isize;
        if !account(delta) {
            return std::ptr::null_mut();
        }
        let p = System.realloc(ptr, layout, new_size);
        if p.is_null() {
            account(-delta);
        }
        p
    }
}

#[global_allocator]
static GUARD: Guard = Guard;

/// How one case ended when it broke no rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// `load` returned `Error::Input`.
    Rejected,
    /// `load` returned a scene too big to render here.
    Loaded,
    /// `load` returned a scene; a 4×4 render of it has finite pixels.
    Rendered,
    /// The case hit a known, reported failure (see [`KNOWN`]); not counted as broken
    /// unless `WAVETRACE_FUZZ_STRICT` is set.
    Known(usize),
}

/// Known failures, found by this fuzzing and not yet fixed in src/: a problem whose text
/// contains both strings is one of them. Each has a test in `regressions` with a minimal input,
/// ignored where it fails. Remove an entry, and the test's `ignore`, once its fix lands.
pub(crate) const KNOWN: &[(&str, &str, &str)] = &[];

/// Which [`KNOWN`] failure `problem` is, unless `WAVETRACE_FUZZ_STRICT` is set.
fn known(problem: &str) -> Option<usize> {
    if std::env::var_os("WAVETRACE_FUZZ_STRICT").is_some() {
        return None;
    }
    KNOWN.iter().position(|(a, b, _)| problem.contains(a) && problem.contains(b))
}

thread_local! {
    /// Where the last panic on this thread happened.
    static PANIC_AT: RefCell<String> = const { RefCell::new(String::new()) };
}

/// Where the last panic on any thread happened: a render's panic is raised on a rayon
/// worker and resumed on the case thread without passing the hook again.
static LAST_PANIC_AT: Mutex<String> = Mutex::new(String::new());

/// Records each panic's location for [`guarded`]; prints a panic (with its backtrace) only
/// when it is not a known failure.
fn install_panic_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let at = info.location().map(|l| format!("{}:{}:{}", l.file(), l.line(), l.column())).unwrap_or_default();
            let msg = info
                .payload()
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| info.payload().downcast_ref::<String>().cloned())
                .unwrap_or_default();
            if known(&format!("panicked at {at}: {msg}")).is_none() {
                default(info);
            }
            *LAST_PANIC_AT.lock().unwrap_or_else(|e| e.into_inner()) = at.clone();
            PANIC_AT.with(|p| *p.borrow_mut() = at);
        }));
    });
}

/// Runs `f` on a fresh, allocation-guarded thread with the CLI's main-thread stack:
/// `Err` on a panic (location and message) or when it does not finish within [`HANG_LIMIT`].
fn guarded<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> Result<T, String> {
    install_panic_hook();
    let (tx, rx) = mpsc::channel();
    std::thread::Builder::new()
        .name("fuzz-case".into())
        .stack_size(8 << 20)
        .spawn(move || {
            GUARDED.with(|g| g.set(true));
            let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|e| {
                let msg = e
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| e.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "non-string panic payload".into());
                let mut at = PANIC_AT.with(|p| p.borrow().clone());
                if at.is_empty() {
                    at = LAST_PANIC_AT.lock().unwrap_or_else(|e| e.into_inner()).clone();
                }
                format!("panicked at {at}: {msg}")
            });
            let _ = tx.send(out);
        })
        .map_err(|e| format!("cannot spawn the case thread: {e}"))?;
    match rx.recv_timeout(HANG_LIMIT) {
        Ok(out) => out,
        // The thread is left running: the whole test fails anyway.
        Err(_) => Err(format!("hang: no result within {} s", HANG_LIMIT.as_secs())),
    }
}

/// Loads `text` (meshes relative to `dir`) with `sets`; renders it at 4×4 when it loads
/// and is small. `Err` names the broken rule.
pub(crate) fn check_scene(text: &str, dir: &Path, sets: &[String]) -> Result<Verdict, String> {
    assert!(text.len() <= MAX_SCENE_BYTES + 1024, "generator produced {} bytes", text.len());
    check_source(SceneSource::from_text("<fuzz>", text, dir), sets)
}

/// [`check_scene`] for any scene source (a Mitsuba XML file): the promise's rules
/// ([`promise::check_source`]; a refusal must name the scene or a file in its folder),
/// under the guards, holding at most [`LOAD_MEMORY`] at once (load and 4×4 render).
pub(crate) fn check_source(src: SceneSource, sets: &[String]) -> Result<Verdict, String> {
    let sets = sets.to_vec();
    let out = guarded(move || -> Result<Verdict, String> {
        let before = LIVE.with(Cell::get);
        PEAK.with(|p| p.set(before));
        let dir = src.dir.display().to_string();
        let files = [src.name.as_str(), dir.as_str()];
        let verdict = promise::check_source(&src, &sets, &files);
        let peak = PEAK.with(Cell::get) - before;
        if peak > LOAD_MEMORY {
            return Err(format!("load and render held {peak} bytes at once (limit {LOAD_MEMORY})"));
        }
        Ok(match verdict? {
            promise::Verdict::Rejected => Verdict::Rejected,
            promise::Verdict::Loaded | promise::Verdict::Read => Verdict::Loaded,
            promise::Verdict::Rendered => Verdict::Rendered,
        })
    });
    match out {
        Err(problem) => known(&problem).map(Verdict::Known).ok_or(problem),
        Ok(Err(problem)) => known(&problem).map(Verdict::Known).ok_or(problem),
        Ok(Ok(verdict)) => Ok(verdict),
    }
}

/// One input of a coverage-guided fuzz target (`fuzz/`) through the same promise, under
/// the guards: what the corpus replay runs.
pub(crate) fn check_bytes(target: promise::Target, data: Vec<u8>) -> Result<Verdict, String> {
    let out = guarded(move || target(&data));
    match out {
        Err(problem) | Ok(Err(problem)) => known(&problem).map(Verdict::Known).ok_or(problem),
        Ok(Ok(promise::Verdict::Rejected)) => Ok(Verdict::Rejected),
        Ok(Ok(promise::Verdict::Loaded | promise::Verdict::Read)) => Ok(Verdict::Loaded),
        Ok(Ok(promise::Verdict::Rendered)) => Ok(Verdict::Rendered),
    }
}

/// Cases per generator: `WAVETRACE_FUZZ_CASES`, default 200.
pub(crate) fn cases() -> u32 {
    std::env::var("WAVETRACE_FUZZ_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(200)
}

/// Verdict counts of one property run.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Counts {
    pub(crate) rejected: u32,
    pub(crate) loaded: u32,
    pub(crate) rendered: u32,
    pub(crate) known: [u32; KNOWN.len()],
}

/// Runs `strategy` through `check`, prints a summary, and panics with the shrunk input on
/// the first broken rule.
pub(crate) fn run_property<S: Strategy>(
    name: &str,
    strategy: S,
    check: impl Fn(&S::Value) -> Result<Verdict, String>,
) -> Counts
where
    S::Value: std::fmt::Debug,
{
    let config = ProptestConfig {
        cases: cases(),
        failure_persistence: None,
        max_shrink_iters: 2000,
        max_shrink_time: 120_000,
        ..ProptestConfig::default()
    };
    let counts = Cell::new(Counts::default());
    let slowest = Cell::new(Duration::ZERO);
    let start = Instant::now();
    let mut runner = TestRunner::new(config);
    let result = runner.run(&strategy, |input| {
        let t = Instant::now();
        let verdict = check(&input).map_err(TestCaseError::fail)?;
        slowest.set(slowest.get().max(t.elapsed()));
        let mut c = counts.get();
        match verdict {
            Verdict::Rejected => c.rejected += 1,
            Verdict::Loaded => c.loaded += 1,
            Verdict::Rendered => c.rendered += 1,
            Verdict::Known(i) => c.known[i] += 1,
        }
        counts.set(c);
        Ok(())
    });
    let c = counts.get();
    let known: u32 = c.known.iter().sum();
    println!(
        "{name}: {} inputs in {:.2} s (slowest {:.1} ms): {} rejected, {} loaded, {} rendered, {known} known failures",
        c.rejected + c.loaded + c.rendered + known,
        start.elapsed().as_secs_f64(),
        slowest.get().as_secs_f64() * 1e3,
        c.rejected,
        c.loaded,
        c.rendered,
    );
    for (n, (_, _, what)) in c.known.iter().zip(KNOWN) {
        if *n > 0 {
            println!("  {n} × known failure: {what}");
        }
    }
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
    c
}
