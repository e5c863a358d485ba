//! The coverage-guided fuzzers' corpus, replayed (issue 16): every input kept in
//! `fuzz/corpus/<target>/` and every minimal input of a finding in
//! `tests/fuzz/found/<target>/` goes through the same promise the fuzz target checks
//! ([`crate::promise`], which is fuzz/src/lib.rs), under the harness's watchdog and
//! allocation guard. No fuzzer is needed: this is plain `cargo test`.

use crate::harness::{check_bytes, Verdict};
use crate::promise;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The files of `dir`, sorted (none when it does not exist).
fn inputs(dir: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(entries) => entries.filter_map(|e| e.ok()).map(|e| e.path()).filter(|p| p.is_file()).collect(),
        Err(_) => Vec::new(),
    };
    out.sort();
    out
}

/// The memory budget the fuzzers ran under (fuzz/run.sh), so an input they kept is judged
/// by the same `available_memory`.
const FUZZ_MEMORY: &str = "1073741824";

/// Replays `folder/<target>/*` for every target; returns each target's number of inputs.
fn replay(folder: &str) -> Vec<(&'static str, usize)> {
    static BUDGET: std::sync::Once = std::sync::Once::new();
    // The other tests of this binary only load tiny scenes, well inside this budget.
    BUDGET.call_once(|| std::env::set_var("WAVETRACE_MEMORY", FUZZ_MEMORY));
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join(folder);
    let start = Instant::now();
    let mut broken = Vec::new();
    let mut per_target = Vec::new();
    for (target, check) in promise::TARGETS {
        let files = inputs(&root.join(target));
        let mut counts = [0usize; 3];
        for file in &files {
            let data = std::fs::read(file).unwrap();
            match check_bytes(check, data) {
                Ok(Verdict::Rejected) => counts[0] += 1,
                Ok(Verdict::Loaded) => counts[1] += 1,
                Ok(Verdict::Rendered) => counts[2] += 1,
                Ok(Verdict::Known(_)) => broken.push(format!("{}: a known failure", file.display())),
                Err(problem) => broken.push(format!("{}: {problem}", file.display())),
            }
        }
        println!(
            "{folder}/{target}: {} inputs: {} rejected, {} loaded or read, {} rendered",
            files.len(),
            counts[0],
            counts[1],
            counts[2]
        );
        per_target.push((target, files.len()));
    }
    let total: usize = per_target.iter().map(|t| t.1).sum();
    println!("{folder}: {total} inputs in {:.1} s", start.elapsed().as_secs_f64());
    assert!(broken.is_empty(), "{} inputs break the promise:\n{}", broken.len(), broken.join("\n"));
    per_target
}

/// The minimised corpus the fuzzers built (docs/robustness.md has the campaign).
#[test]
fn fuzz_corpus_keeps_the_promise() {
    for (target, n) in replay("fuzz/corpus") {
        assert!(n > 0, "the committed corpus of {target} is missing");
    }
}

/// The minimal input of every finding, one file each.
#[test]
fn fuzz_findings_stay_fixed() {
    replay("tests/fuzz/found");
}
