#!/usr/bin/env bash
# The SLURM end-to-end test (run by .ci/run): starts a one-node cluster
# (cluster-start.sh), renders a frame as an 8-task array job plus a merge job and
# compares the merged EXR with the single-process render byte for byte; one task's first
# attempt crashes on purpose (it must be requeued automatically by exit 75). Then a
# second array where one task is cancelled on purpose before it runs: the merge job must
# fail naming it, `wavetrace merge --missing` must list it, and the resubmitted task
# plus a new merge must give the same bytes again. Stops only the daemons it started.
#
# Where it cannot run (not root, no apt-get) it says so loudly and exits 0, unless
# WAVETRACE_REQUIRE_SLURM=1, which makes that a failure. Any failed check exits 1.
# WAVETRACE=path/to/binary skips the build (.ci/run passes the one `cargo test
# --release` built: a plain `cargo build --release` after it rebuilds, because the
# dev-dependencies unify features differently).
set -euo pipefail
cd "$(dirname "$0")/../.."
here=scripts/slurm
t0=$(date +%s%N)
ms() { echo $(( ($(date +%s%N) - t0) / 1000000 )); }
skip() {
  echo "##################################################################" >&2
  echo "## SLURM END-TO-END TEST NOT RUN: $1" >&2
  echo "##################################################################" >&2
  [ "${WAVETRACE_REQUIRE_SLURM:-0}" = 1 ] && exit 1
  exit 0
}
[ "$(id -u)" = 0 ] || skip "needs root (it installs and starts slurmctld, slurmd, munged)"
command -v apt-get >/dev/null || skip "needs apt-get (Debian packages slurmctld slurmd slurm-client munge)"
# One cluster per machine (ports 6817/6818): concurrent runs (several worktrees' CI on
# one machine) take turns, or the first one's stop would pull the cluster from under
# the second.
exec 9>/var/lock/wavetrace-slurm-e2e.lock
flock 9

if [ -z "${WAVETRACE:-}" ]; then
  cargo build --release --quiet
  WAVETRACE=target/release/wavetrace
fi
bin=$(realpath "$WAVETRACE")
t0=$(date +%s%N)
work=$(mktemp -d /tmp/wavetrace-slurm.XXXXXX)
STATE=${SLURM_LOCAL_STATE:-/var/spool/slurm-local}

# A cluster already running (started earlier, by someone else) is used and left running.
ours=1
for d in munged slurmctld slurmd; do
  f="$STATE/pids/$d"
  if [ -s "$f" ] && [ "$(cat "/proc/$(cat "$f")/comm" 2>/dev/null)" = "$d" ]; then ours=; fi
done
cleanup() {
  rc=$?
  [ -n "$ours" ] && bash "$here/cluster-stop.sh" >/dev/null
  if [ $rc != 0 ]; then
    echo "slurm e2e FAILED; logs:" >&2
    tail -n 20 "$work"/run*/logs/* >&2 2>/dev/null || true
  fi
  rm -rf "$work"
}
trap cleanup EXIT
if ! bash "$here/cluster-start.sh"; then
  skip_reason="cluster-start.sh failed (no package access?)"
  [ "${WAVETRACE_REQUIRE_SLURM:-0}" = 1 ] && { echo "$skip_reason" >&2; exit 1; }
  skip "$skip_reason"
fi
echo "slurm e2e: cluster up at $(ms) ms"

fail() { echo "slurm e2e FAILED: $*" >&2; exit 1; }
# wait_jobs ID...: until squeue shows none of them (3 minutes at most).
wait_jobs() {
  local ids; ids=$(IFS=,; echo "$*")
  for _ in $(seq 720); do
    [ -z "$(squeue -h -j "$ids" 2>/dev/null)" ] && return 0
    sleep 0.25
  done
  squeue -j "$ids" >&2
  fail "jobs $ids still queued after 3 minutes"
}
# state JOB: the JobState of a (non-array) job, or of every task of an array job.
state() { scontrol -o show job "$1" | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | sort | uniq -c | xargs; }

scene=scenes/paper/fig08-combined.toml
args=(--set render.width=96 --set render.height=64 --set render.dof.samples=4)
"$bin" render "$scene" "${args[@]}" --threads 2 --quiet -o "$work/single.exr"
export WAVETRACE=$bin

# 1. Eight tasks and the merge; task 3's first attempt crashes and is requeued.
read -r a m < <(WT_TEST_CRASH_ONCE=3 bash "$here/submit.sh" "$scene" 8 "$work/run1" "${args[@]}")
wait_jobs "$a" "$m"
[ "$(state "$m")" = "1 COMPLETED" ] || fail "merge job $m: $(state "$m")"
[ "$(state "$a")" = "8 COMPLETED" ] || fail "array $a: $(state "$a")"
scontrol -o show job "${a}_3" | grep -q 'Restarts=1' || fail "task 3 was not requeued once"
cmp "$work/single.exr" "$work/run1/frame.exr" || fail "merged frame differs from the single render"
echo "slurm e2e: 8-task array + merge identical to the single render (task 3 requeued) at $(ms) ms"

# 2. Task 5 is cancelled before it runs: the merge fails naming it; resubmit it.
read -r a m < <(WT_SBATCH=--hold bash "$here/submit.sh" "$scene" 8 "$work/run2" "${args[@]}")
scancel "${a}_5"
scontrol release "$a"
scontrol release "$m"
wait_jobs "$a" "$m"
[ "$(state "$m")" = "1 FAILED" ] || fail "merge job $m with a task missing: $(state "$m"), expected FAILED"
grep -q "MERGE FAILED: missing tasks: 5;" "$work"/run2/logs/merge_"$m".log || fail "merge log does not name task 5"
missing=$("$bin" merge --missing "$work"/run2/tiles/tile-*.exr)
[ "$missing" = 5 ] || fail "merge --missing printed '$missing', expected 5"
[ ! -e "$work/run2/frame.exr" ] || fail "the failed merge wrote an image"
read -r a m < <(WT_ARRAY=$missing bash "$here/submit.sh" "$scene" 8 "$work/run2" "${args[@]}")
wait_jobs "$a" "$m"
[ "$(state "$m")" = "1 COMPLETED" ] || fail "merge job $m after the resubmit: $(state "$m")"
cmp "$work/single.exr" "$work/run2/frame.exr" || fail "merged frame after the resubmit differs"
echo "slurm e2e: cancelled task 5 -> merge failed naming it -> merge --missing -> resubmit -> identical at $(ms) ms"
echo "slurm e2e: passed in $(ms) ms"
