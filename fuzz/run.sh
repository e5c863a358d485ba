#!/usr/bin/env bash
# Runs one fuzz target (docs/robustness.md, "Coverage-guided fuzzing"):
#
#   fuzz/run.sh TARGET SECONDS          # e.g. fuzz/run.sh obj 1800
#
# Needs `cargo install cargo-fuzz` once. Builds on the stable toolchain without a
# sanitizer (`-s none`; AddressSanitizer needs nightly, see the docs) but with debug
# assertions and overflow checks (`-a`). Starts from the committed corpus
# (fuzz/corpus/TARGET, where new inputs are added) and the seeds (fuzz/seeds/TARGET, from
# fuzz/seeds.py). The promise's time and memory bounds are the libFuzzer options below:
# an input slower than 10 s is a hang, one that grows the process past 2 GiB is an
# out-of-memory finding (-malloc_limit_mb, one allocation over 1 GiB, is enforced only with
# a sanitizer's malloc hooks: docs/robustness.md); inputs slower than 1 s are reported.
# The same budget is set by the corpus replay (tests/fuzz/corpus.rs). The log goes to
# fuzz/logs/TARGET-DATE-TIME.log (fuzz/summary.py sums them); a finding to fuzz/artifacts/TARGET/.
set -euo pipefail
cd "$(dirname "$0")"
target=${1:?target: scene_toml obj ply mitsuba_xml image scene_values}
seconds=${2:?seconds}
# The memory an accepted input may claim (src/scene/load.rs, `available_memory`): half of
# it, 512 MiB, well inside the 2 GiB rss limit, so a frame the renderer would accept on a
# big machine is refused here rather than reported as out-of-memory.
export WAVETRACE_MEMORY=$((1 << 30))
mkdir -p "corpus/$target" "seeds/$target" logs
# A token dictionary (fuzz/dict/TARGET.dict) where the format has keywords.
dict=()
[ -f "dict/$target.dict" ] && dict=(-dict="dict/$target.dict")
exec cargo fuzz run -s none -a "$target" "corpus/$target" "seeds/$target" -- \
    -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=1024 \
    -max_len=65536 -report_slow_units=1 -print_final_stats=1 "${dict[@]}" \
    >"logs/$target-$(date +%Y%m%d-%H%M%S).log" 2>&1
