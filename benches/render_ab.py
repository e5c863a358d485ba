#!/usr/bin/env python3
"""Whole renders with two wavetrace binaries, interleaved, timed by the CPU time of each
render process (user + system), so that on a shared machine the time other processes held
the cores is not counted. Prints the median CPU seconds per scene and binary and the
old/new speed-up. (scripts/ab-timing.py times the wall clock instead.)

Usage: benches/render_ab.py OLD NEW [--runs 5] [--threads 1] [--set KEY=VALUE]... SCENE...
A SCENE of `default` is the embedded default scene.
"""

import argparse
import os
import resource
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
    a = ap.parse_args()
    out = os.path.join(tempfile.mkdtemp(), "t.exr")
    sets = [x for kv in a.set for x in ("--set", kv)]
    times = {(s, b): [] for s in a.scenes for b in ("old", "new")}
    for run in range(a.runs):
        # Alternate which binary goes first, so drift in the machine's load hits both.
        order = [("old", a.old), ("new", a.new)] if run % 2 == 0 else [("new", a.new), ("old", a.old)]
        for s in a.scenes:
            for label, binary in order:
                scene = [] if s == "default" else [s]
                cmd = [binary, "render", *scene, *sets, "--threads", a.threads, "--quiet", "-o", out]
                times[(s, label)].append(cpu_of(cmd))
    print(f"| scene | old CPU s | new CPU s | old ÷ new |  ({a.runs} interleaved runs, median, {a.threads} thread(s))")
    print("|---|---|---|---|")
    for s in a.scenes:
        old, new = statistics.median(times[(s, "old")]), statistics.median(times[(s, "new")])
        print(f"| {s} | {old:.2f} | {new:.2f} | {old / new:.2f} |")


if __name__ == "__main__":
    main()
