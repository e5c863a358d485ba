#!/usr/bin/env python3
"""A scene's stage table, for one or more wavetrace binaries run alternately: from each
binary's run with the median wall time, its wall seconds, and per stage the CPU seconds
summed over threads and the nanoseconds per item (`--stats-json`: `stages.*.seconds`,
`ns_per_ray`: per ray in, or per ray out for the camera). Prints one markdown table.

Usage: benches/stages.py SCENE BIN [BIN...] [--threads 2] [--runs 3] [--set KEY=VALUE]...
Example (docs/performance.md, Figure 8 before and after):
  benches/stages.py scenes/paper/fig08-combined.toml old/wavetrace target/release/wavetrace
"""

import argparse
import json
import os
import subprocess
import tempfile

STAGES = ["camera", "intersect", "shade", "shadow", "shadow_corner", "penumbra", "scatter", "film", "refine"]


def run(binary, scene, threads, sets, out):
    """One render: its stats JSON."""
    cmd = [binary, "render", scene, "--threads", str(threads), "--quiet", "-o", out + ".png", "--stats-json",
           out + ".json"]
    for kv in sets:
        cmd += ["--set", kv]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    with open(out + ".json") as f:
        return json.load(f)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("binaries", nargs="+")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--set", action="append", default=[])
    a = ap.parse_args()
    out = os.path.join(tempfile.mkdtemp(), "r")
    stats = {b: [] for b in a.binaries}
    for r in range(a.runs):
        # Alternate the order so that drift in the machine's load hits every binary.
        order = a.binaries if r % 2 == 0 else list(reversed(a.binaries))
        for b in order:
            stats[b].append(run(b, a.scene, a.threads, a.set, out))
    median = {}
    for b, runs in stats.items():
        runs.sort(key=lambda s: s["seconds"])
        median[b] = runs[len(runs) // 2]
    names = [os.path.relpath(b) for b in a.binaries]
    print(f"`{a.scene}`, {a.threads} threads, median of {a.runs} runs"
          + (f", --set {' '.join(a.set)}" if a.set else ""))
    print()
    print("| | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    row = lambda label, f: print(f"| {label} | " + " | ".join(f(median[b]) for b in a.binaries) + " |")
    row("wall s", lambda s: f"{s['seconds']:.2f}")
    row("rays (M)", lambda s: f"{s['total_rays'] / 1e6:.1f}")
    row("Mrays/s", lambda s: f"{s['total_rays'] / s['seconds'] / 1e6:.1f}")
    for st in STAGES:
        if any(median[b]["stages"].get(st, {}).get("rays_in", 0) or median[b]["stages"].get(st, {}).get("rays_out", 0)
               for b in a.binaries):
            row(f"{st}: CPU s, ns/item",
                lambda s: f"{s['stages'][st]['seconds']:.2f}, {s['stages'][st]['ns_per_ray']:.0f}"
                if st in s["stages"] else "")


if __name__ == "__main__":
    main()
