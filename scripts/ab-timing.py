#!/usr/bin/env python3
"""Times two wavetrace binaries side by side, interleaved, on the same machine and run:
whole renders (wall clock of the process) and `wavetrace bench` (Mrays/s per set and
kernel, itself a median of its --reps). Prints medians and new/old ratios.

Usage: scripts/ab-timing.py OLD NEW [--runs 5] [--scene S]... [--bench-scene S]... [--threads N] [--reps N]
A scene argument of `default` is the embedded default scene.
"""
import argparse
import json
import os
import statistics
import subprocess
import tempfile
import time


def scene_args(s):
    return [] if s == "default" else [s]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--scene", action="append", default=None)
    ap.add_argument("--bench-scene", action="append", default=None)
    ap.add_argument("--threads", default="2")
    ap.add_argument("--reps", default="5", help="wavetrace bench --reps")
    a = ap.parse_args()
    scenes = a.scene or ["default"]
    bench_scenes = a.bench_scene or ["default"]
    out = os.path.join(tempfile.mkdtemp(), "t.png")
    renders = {(s, b): [] for s in scenes for b in ("old", "new")}
    bench = {}
    for run in range(a.runs):
        # Alternate which binary goes first, so drift in the machine's load hits both.
        order = [("old", a.old), ("new", a.new)] if run % 2 == 0 else [("new", a.new), ("old", a.old)]
        for s in scenes:
            for label, exe in order:
                t = time.perf_counter()
                subprocess.run([exe, "render", *scene_args(s), "-q", "-o", out, "--threads", a.threads], check=True)
                renders[(s, label)].append(time.perf_counter() - t)
        for s in bench_scenes:
            for label, exe in order:
                r = subprocess.run([exe, "bench", *scene_args(s), "--json", "--threads", a.threads, "--reps", a.reps],
                                   check=True, capture_output=True, text=True)
                for row in json.loads(r.stdout)["sets"]:
                    bench.setdefault((s, row["set"], row["kernel"], label), []).append(row["mrays_per_s"])
    print(f"{a.runs} interleaved runs, --threads {a.threads}, bench --reps {a.reps}; medians")
    print(f"{'render':34} {'old s':>8} {'new s':>8} {'new/old':>8}")
    for s in scenes:
        o, n = statistics.median(renders[(s, 'old')]), statistics.median(renders[(s, 'new')])
        print(f"{s:34} {o:8.3f} {n:8.3f} {n / o:8.3f}")
    print(f"{'bench (Mrays/s)':34} {'old':>8} {'new':>8} {'new/old':>8}")
    for (s, st, k, label) in sorted(bench):
        if label != "old":
            continue
        o, n = statistics.median(bench[(s, st, k, 'old')]), statistics.median(bench[(s, st, k, 'new')])
        print(f"{s + ' ' + st + ' ' + k:34} {o:8.2f} {n:8.2f} {n / o:8.3f}")


if __name__ == "__main__":
    main()
