#!/usr/bin/env python3
"""Whole renders with two wavetrace binaries, interleaved, timed by the CPU time of each
render process (user + system), so that on a shared machine the time other processes held
the cores is not counted. Prints the median CPU seconds per scene and binary and the
old/new speed-up. (scripts/ab-timing.py times the wall clock instead.)

With --control, a copy of OLD runs as a third binary in the same rotation, and its column
(old ÷ old copy, which should be 1.00) shows how far the machine's noise alone moves a
ratio in that run: a difference smaller than that is not measured.

Usage: benches/render_ab.py OLD NEW [--runs 5] [--threads 1] [--control] [--set KEY=VALUE]... SCENE...
A SCENE of `default` is the embedded default scene.
"""

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import tempfile


def cpu_of(cmd):
    """CPU seconds (user + system) the finished child `cmd` used."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--threads", default="1")
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--control", action="store_true", help="also time a copy of OLD (the noise floor)")
    a = ap.parse_args()
    tmp = tempfile.mkdtemp()
    out = os.path.join(tmp, "t.exr")
    sets = [x for kv in a.set for x in ("--set", kv)]
    binaries = [("old", a.old), ("new", a.new)]
    if a.control:
        binaries.append(("control", shutil.copy2(a.old, os.path.join(tmp, "old-copy"))))
    times = {(s, b): [] for s in a.scenes for b, _ in binaries}
    for run in range(a.runs):
        # Rotate which binary goes first, so drift in the machine's load hits each.
        k = run % len(binaries)
        order = binaries[k:] + binaries[:k]
        for s in a.scenes:
            for label, binary in order:
                scene = [] if s == "default" else [s]
                cmd = [binary, "render", *scene, *sets, "--threads", a.threads, "--quiet", "-o", out]
                times[(s, label)].append(cpu_of(cmd))
    control = " old ÷ old copy |" if a.control else ""
    print(f"| scene | old CPU s | new CPU s | old ÷ new |{control}  ({a.runs} interleaved runs, median, {a.threads} thread(s))")
    print("|---|---|---|---|" + ("---|" if a.control else ""))
    for s in a.scenes:
        med = {b: statistics.median(times[(s, b)]) for b, _ in binaries}
        row = f"| {s} | {med['old']:.2f} | {med['new']:.2f} | {med['old'] / med['new']:.2f} |"
        print(row + (f" {med['old'] / med['control']:.2f} |" if a.control else ""))


if __name__ == "__main__":
    main()
