#!/usr/bin/env bash
# Error of two wavetrace binaries, each scene at its own settings, against a reference
# rendered by the first at 1024 uniform samples per pixel (uniform shadows), for every
# scene of scenes/ and scenes/paper/ at 64x48. Prints RMSE and FLIP per scene and binary.
#   scripts/error-vs-reference.sh OLD NEW [OUT_DIR]
# A sampler change must not raise the error of any scene (use --seed runs where the
# difference is within one seed's noise).
set -euo pipefail
old=$1 new=$2 out=${3:-$(mktemp -d)}
root=$(cd "$(dirname "$0")/.." && pwd)
size=(--set render.width=64 --set render.height=48)
metric() { "$new" compare "$1" "$2" --json | python3 -c 'import json,sys; j=json.load(sys.stdin); print(f"{j[\"rmse\"]:.5f} {j[\"flip\"]:.5f}")'; }
printf '%-22s %-17s %-17s\n' scene "old rmse flip" "new rmse flip"
for scene in "$root"/scenes/*.toml "$root"/scenes/paper/*.toml; do
  n=$(basename "$scene" .toml)
  ref="$out/ref-$n.exr"
  [ -f "$ref" ] || "$old" render "$scene" "${size[@]}" --set render.aa.mode=uniform --set render.aa.samples=1024 \
    --set render.shadows.mode=uniform -q -o "$ref" --threads 2
  "$old" render "$scene" "${size[@]}" -q -o "$out/old-$n.exr" --threads 2
  "$new" render "$scene" "${size[@]}" -q -o "$out/new-$n.exr" --threads 2
  printf '%-22s %-17s %-17s\n' "$n" "$(metric "$out/old-$n.exr" "$ref")" "$(metric "$out/new-$n.exr" "$ref")"
done
