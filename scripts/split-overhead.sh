#!/usr/bin/env bash
# The cost of splitting a frame into --tile tasks: for each N, every task rendered one
# after the other on 1 thread (as `sbatch -c 1` tasks would be), against the single
# render on 1 thread, interleaved in one run (N order, then again) so that load on a
# shared machine hits both. Prints per N: the sum of the tasks' render seconds (their
# tile headers, via merge --stats-json), the sum of the task processes' wall seconds
# (scene load and BVH build included), and the single render's, and their ratios; the
# tasks' rays against the single render's (a task traces whole corner-grid tiles at its
# edges: see docs/scale-out.md); and checks that the merged frame is byte-identical to
# the single render.
#   scripts/split-overhead.sh [SCENE] [SIZE] [N...]   (default fig08, 500, 2 8 32)
# WAVETRACE=path/to/binary skips the build; REPS (default 2) rounds.
set -euo pipefail
cd "$(dirname "$0")/.."
scene=${1:-scenes/paper/fig08-combined.toml}
size=${2:-500}
shift $(( $# < 2 ? $# : 2 ))
ns=("${@:-2 8 32}")
read -r -a ns <<<"${ns[*]}"
if [ -z "${WAVETRACE:-}" ]; then cargo build --release --quiet; WAVETRACE=target/release/wavetrace; fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
args=(--set "render.width=$size" --set "render.height=$size" --threads 1 --quiet)
now() { date +%s%N; }
single() { # prints "render_seconds wall_seconds rays"
  local t=$(now)
  "$WAVETRACE" render "$scene" "${args[@]}" -o "$out/single.exr" --stats-json "$out/single.json"
  echo "$(jq .seconds "$out/single.json") $(( $(now) - t ))e-9 $(jq .total_rays "$out/single.json")"
}
split() { # N: prints "sum_render_seconds sum_wall_seconds sum_rays"
  local n=$1 k t wall=0
  rm -f "$out"/t-*.exr
  for ((k = 0; k < n; k++)); do
    t=$(now)
    "$WAVETRACE" render "$scene" "${args[@]}" --tile "$k/$n" -o "$out/t-$k.exr"
    wall=$(( wall + $(now) - t ))
  done
  "$WAVETRACE" merge "$out"/t-*.exr -q -o "$out/merged.exr" --stats-json "$out/merged.json"
  cmp -s "$out/merged.exr" "$out/single.exr" || { echo "N=$n: merged frame differs from the single render" >&2; exit 1; }
  echo "$(jq .seconds "$out/merged.json") ${wall}e-9 $(jq .rays "$out/merged.json")"
}
printf '%-6s %-4s %12s %12s %12s %12s %8s %8s %8s\n' round N task_render single_render task_wall single_wall render_x wall_x rays_x
for ((r = 1; r <= ${REPS:-2}; r++)); do
  for n in "${ns[@]}"; do
    read -r sr sw sx < <(single)
    read -r tr tw tx < <(split "$n")
    awk -v r="$r" -v n="$n" -v tr="$tr" -v sr="$sr" -v tw="$tw" -v sw="$sw" -v tx="$tx" -v sx="$sx" \
      'BEGIN { printf "%-6s %-4s %12.2f %12.2f %12.2f %12.2f %8.3f %8.3f %8.3f\n", r, n, tr, sr, tw, sw, tr / sr, tw / sw, tx / sx }'
  done
done
