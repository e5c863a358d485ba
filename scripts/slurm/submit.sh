#!/usr/bin/env bash
# Submits a frame as an N-task SLURM array job plus its merge job, and prints the two job
# ids ("ARRAY MERGE"). Usage:
#   scripts/slurm/submit.sh SCENE N OUT_DIR [render args...]
# Tiles go to OUT_DIR/tiles, logs to OUT_DIR/logs, the image to OUT_DIR/frame.exr.
# Resubmit missing tasks (after the merge job failed, or `wavetrace merge --missing`):
#   WT_ARRAY=3,5 scripts/slurm/submit.sh SCENE N OUT_DIR [render args...]
# Environment: WAVETRACE (binary, default wavetrace on PATH), WT_CPUS (cpus per task,
# default 1), WT_ARRAY (indices, default 0-(N-1)), WT_SBATCH (more sbatch options).
set -euo pipefail
[ $# -ge 3 ] || { sed -n '2,10p' "$0" >&2; exit 2; }
scene=$(realpath "$1"); n=$2; out=$(realpath -m "$3"); shift 3
here=$(dirname "$(realpath "$0")")
mkdir -p "$out/tiles" "$out/logs"
export WT_SCENE=$scene WT_OUT=$out/tiles WT_TASKS=$n WT_IMAGE=$out/frame.exr WT_ARGS="$*"
export WAVETRACE=${WAVETRACE:+$(realpath "$WAVETRACE")}
[ -n "$WAVETRACE" ] || unset WAVETRACE
# shellcheck disable=SC2086 # WT_SBATCH is a list of options
array=$(sbatch --parsable --array="${WT_ARRAY:-0-$((n - 1))}" -c "${WT_CPUS:-1}" --requeue \
  --open-mode=append -o "$out/logs/tile_%A_%a.log" --export=ALL ${WT_SBATCH:-} "$here/render-tile.sbatch")
# shellcheck disable=SC2086
merge=$(sbatch --parsable --dependency="afterany:$array" --kill-on-invalid-dep=yes \
  --open-mode=append -o "$out/logs/merge_%j.log" --export=ALL ${WT_SBATCH:-} "$here/merge.sbatch")
echo "$array $merge"
