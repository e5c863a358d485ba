#!/usr/bin/env bash
# Prints one hash line per scene and mode: the EXR (linear float, exact bits), the three
# heatmaps and the stats JSON without its timings. Run it before and after a change that
# must not alter images and diff the two outputs:
#   scripts/image-hashes.sh > before.txt   (on the old commit)
#   scripts/image-hashes.sh > after.txt && diff before.txt after.txt
# WAVETRACE=path/to/binary skips the build; SIZE=WxH changes the 64x48 default.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -z "${WAVETRACE:-}" ]; then
  cargo build --release --quiet
  WAVETRACE=target/release/wavetrace
fi
size=${SIZE:-64x48}
w=${size%x*}
h=${size#*x}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

# name|--set overrides (space separated)
modes=(
  "default|"
  "aa-adaptive|render.aa.mode=adaptive"
  "shadows-adaptive|render.shadows.mode=adaptive"
  "both-adaptive|render.aa.mode=adaptive render.shadows.mode=adaptive"
  "dofaware-earlystop|render.aa.mode=adaptive render.aa.dof_aware=true render.shadows.mode=adaptive render.shadows.tolerance=0.05"
  "scalar-both|render.packets=false render.aa.mode=adaptive render.shadows.mode=adaptive"
)
# Timings, the per-thread split (which thread took which tile) and the queues' allocated
# bytes (capacities grow with the tiles a worker happened to take) vary run to run.
strip='del(.seconds, .mrays_per_s, .per_thread, .queue_bytes, .scene.bvh_seconds, .scene.load_seconds)
       | .stages |= map_values(del(.seconds, .ns_per_ray))'

for scene in scenes/*.toml scenes/paper/*.toml; do
  for mode in "${modes[@]}"; do
    name=${mode%%|*}
    args=(--set "render.width=$w" --set "render.height=$h")
    for kv in ${mode#*|}; do args+=(--set "$kv"); done
    "$WAVETRACE" render "$scene" "${args[@]}" --threads 2 --quiet -o "$out/img.exr" \
      --heatmap "aa=$out/aa.png" --heatmap "penumbra=$out/pen.png" --heatmap "rays=$out/rays.png" \
      --stats-json "$out/stats.json"
    jq -S "$strip" "$out/stats.json" > "$out/stats.txt"
    img=$(sha256sum "$out/img.exr" | cut -c1-16)
    heat=$(cat "$out/aa.png" "$out/pen.png" "$out/rays.png" | sha256sum | cut -c1-16)
    stats=$(sha256sum "$out/stats.txt" | cut -c1-16)
    printf '%-40s %-20s image %s heat %s stats %s\n' "$scene" "$name" "$img" "$heat" "$stats"
  done
done
