#!/usr/bin/env python3
"""Where the adaptive shadow test pays: for each scene, probe set and shadow sample count,
the penumbra fraction f (points the probes could not decide, of the points probed) and
the rays adaptive mode casts against uniform mode's for the same points
(`adaptive_shadows` in `--stats-json`). Ray counts only: deterministic, no timing.

A probed point costs P probe rays, plus N penumbra rays when it lands in the penumbra;
uniform mode casts N (those facing the light), so probing saves rays while
f < 1 - P/N. With P >= N it cannot, and such a light is sampled uniformly
(`uniform_fallback`).

Usage: benches/shadow_breakeven.py [BIN] [--size 160x120] [SCENE...]
"""

import argparse
import json
import os
import subprocess
import tempfile

SCENES = ["scenes/penumbra.toml", "scenes/cornell.toml", "scenes/default.toml", "scenes/paper/fig03-penumbra.toml",
          "scenes/paper/fig06-semireflective.toml", "scenes/paper/fig08-combined.toml"]
PROBES = [("corners", 4), ("3x3", 9)]
SAMPLES = [4, 8, 16, 32, 64]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("binary", nargs="?", default="target/release/wavetrace")
    ap.add_argument("scenes", nargs="*", default=SCENES)
    ap.add_argument("--size", default="160x120")
    a = ap.parse_args()
    w, h = a.size.split("x")
    out = os.path.join(tempfile.mkdtemp(), "r")
    print(f"`benches/shadow_breakeven.py` at {a.size}: penumbra fraction f, and adaptive rays ÷ uniform rays "
          "(below 1: probing saved rays; `fallback`: the light was sampled uniformly)")
    print()
    print("| scene | probe (P) | " + " | ".join(f"N = {n}: f, ratio" for n in SAMPLES) + " |")
    print("|---|---|" + "---|" * len(SAMPLES))
    for scene in a.scenes:
        for probe, p in PROBES:
            cells = []
            for n in SAMPLES:
                cmd = [a.binary, "render", scene, "--quiet", "--threads", "2", "-o", out + ".png", "--stats-json",
                       out + ".json", "--set", f"render.width={w}", "--set", f"render.height={h}", "--set",
                       "render.shadows.mode=adaptive", "--set", f"render.shadows.samples={n}", "--set",
                       f'render.shadows.probe="{probe}"']
                subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
                with open(out + ".json") as f:
                    q = json.load(f)["adaptive_shadows"]
                if q["entered"] == 0:
                    cells.append("fallback" if q.get("uniform_fallback") else "—")
                else:
                    cells.append(f"{q['refined'] / q['entered']:.2f}, {q['rays'] / max(q['uniform_rays'], 1):.2f}")
            print(f"| `{os.path.basename(scene)}` | {probe} ({p}) | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
