#!/usr/bin/env python3
"""Time to equal error, wavetrace against Mitsuba 3, on a Mitsuba XML scene with the
transport both share (../shared/peers/mitsuba/render_xml.py: direct light at diffuse
surfaces, BSDF sampling at glossy ones, delta chains).

For each Mitsuba sample count (stratified sampler, llvm variant, render seconds of a second
run so the JIT cache is warm), the fastest wavetrace setting (uniform samples per pixel ×
shadow setting, the whole process timed: load, BVH, render, write) whose mean FLIP against
the same reference is at most Mitsuba's. FLIP is wavetrace's `compare` for both images.
Prints one line per Mitsuba point: spp, Mitsuba seconds and FLIP; wavetrace's FLIP at the
same spp with one shadow ray and its ratio to Mitsuba's; the fastest wavetrace setting,
its seconds and FLIP, and the time ratio wavetrace / Mitsuba (below 1: wavetrace faster).

Usage: benches/gloss_vs_mitsuba.py WAVETRACE SCENE.xml REFERENCE.exr [--reps 3] [--spp 16,64,256]
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

RENDER_XML = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "peers", "mitsuba", "render_xml.py")
SETTINGS = [(spp, shadows) for spp in (8, 16, 32, 64, 128, 256, 512, 1024, 2048) for shadows in ("1", "4a")]


def flip(wavetrace, image, reference):
    out = subprocess.run([wavetrace, "compare", image, reference], capture_output=True, text=True, check=True).stdout
    return float(out.split("flip")[1].split()[0])


def mitsuba(scene, spp, out, seed):
    cmd = [sys.executable, RENDER_XML, scene, out, "--spp", str(spp), "--chunk", str(spp),
           "--seed", str(seed), "-D", "sampler=stratified"]
    text = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return float(text.split(":")[-1].split("s")[0])


def wavetrace_run(wavetrace, scene, spp, shadows, out):
    sets = ["--spp", str(spp), "--set", "render.shadows.samples=" + shadows.rstrip("a")]
    if shadows.endswith("a"):
        sets += ["--set", "render.shadows.mode=adaptive"]
    start = time.perf_counter()
    subprocess.run([wavetrace, scene, "-q", "-o", out] + sets, check=True)
    return time.perf_counter() - start


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("wavetrace")
    ap.add_argument("scene")
    ap.add_argument("reference")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--spp", default="16,64,256")
    a = ap.parse_args()
    tmp = tempfile.mkdtemp()
    points = []
    for spp in map(int, a.spp.split(",")):
        out = os.path.join(tmp, "m.exr")
        mitsuba(a.scene, spp, out, 0)  # warms the JIT cache
        secs = statistics.median(mitsuba(a.scene, spp, out, r + 1) for r in range(a.reps))
        points.append((spp, secs, flip(a.wavetrace, out, a.reference)))
    ours = []
    for spp, shadows in SETTINGS:
        out = os.path.join(tmp, "w.exr")
        secs = statistics.median(wavetrace_run(a.wavetrace, a.scene, spp, shadows, out) for _ in range(a.reps))
        ours.append((secs, spp, shadows, flip(a.wavetrace, out, a.reference)))
    ours.sort()
    print("mitsuba_spp mitsuba_s mitsuba_flip | equal_spp_flip flip_ratio | wavetrace_spp shadows wavetrace_s wavetrace_flip | time_ratio")
    for spp, secs, f in points:
        # The same samples per pixel and one shadow ray: Mitsuba's own sample budget.
        same = next((o[3] for o in ours if o[1] == spp and o[2] == "1"), float("nan"))
        head = f"{spp} {secs:.3f} {f:.5f} | {same:.5f} {same / f:.2f}"
        best = next((o for o in ours if o[3] <= f), None)
        if best is None:
            print(f"{head} | none of the settings reaches it")
            continue
        s, wspp, shadows, wf = best
        print(f"{head} | {wspp} {shadows} {s:.3f} {wf:.5f} | {s / secs:.2f}")


if __name__ == "__main__":
    main()
