#!/usr/bin/env python3
"""Time to equal error, wavetrace against Mitsuba 3, on a Mitsuba XML scene with the
transport both share (../shared/peers/mitsuba/render_xml.py: direct light at diffuse
surfaces, BSDF sampling at glossy ones, delta chains).

For each Mitsuba sample count (stratified sampler, llvm variant, render seconds after a
run that warms the JIT cache; every Mitsuba point and wavetrace setting timed once a round,
medians over --reps rounds), the fastest wavetrace setting (uniform samples per pixel, or
variance-driven AA in rounds of 8 up to a cap at threshold 0.1 or 0.03, × shadow setting,
the whole process timed: load, BVH, render, write) whose mean FLIP against the same
reference is at most Mitsuba's. FLIP is wavetrace's `compare` for both images.
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
# (samples per pixel, shadow rays ("4a": adaptive), variance threshold or None for uniform).
SETTINGS = [(spp, shadows, None) for spp in (4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048) for shadows in ("1", "4a")]
SETTINGS += [
    (spp, shadows, threshold)
    for spp in (16, 32, 64, 128, 256, 512, 1024, 2048)
    for shadows in ("1", "4a")
    for threshold in ("0.1", "0.03")
]


def flip(wavetrace, image, reference):
    out = subprocess.run([wavetrace, "compare", image, reference], capture_output=True, text=True, check=True).stdout
    return float(out.split("flip")[1].split()[0])


def mitsuba(scene, spp, out, seed):
    cmd = [sys.executable, RENDER_XML, scene, out, "--spp", str(spp), "--chunk", str(spp),
           "--seed", str(seed), "-D", "sampler=stratified"]
    text = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return float(text.split(":")[-1].split("s")[0])


def wavetrace_run(wavetrace, scene, spp, shadows, threshold, out):
    sets = ["--spp", str(spp), "--set", "render.shadows.samples=" + shadows.rstrip("a")]
    if shadows.endswith("a"):
        sets += ["--set", "render.shadows.mode=adaptive"]
    if threshold is not None:
        sets += ["--set", "render.aa.mode=variance", "--set", "render.aa.min_samples=8"]
        sets += ["--set", "render.aa.threshold=" + threshold]
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
    spps = [int(x) for x in a.spp.split(",")]
    m_out = {spp: os.path.join(tmp, f"m{spp}.exr") for spp in spps}
    w_out = [os.path.join(tmp, f"w{k}.exr") for k in range(len(SETTINGS))]
    for spp in spps:
        mitsuba(a.scene, spp, m_out[spp], 0)  # warms the JIT cache
    # Rounds of every Mitsuba point and every wavetrace setting, so the machine's drift
    # (this one's speed moves by a third from hour to hour) falls on both alike.
    m_secs = {spp: [] for spp in spps}
    w_secs = [[] for _ in SETTINGS]
    for r in range(a.reps):
        for spp in spps:
            m_secs[spp].append(mitsuba(a.scene, spp, m_out[spp], r + 1))
        for k, (spp, shadows, threshold) in enumerate(SETTINGS):
            w_secs[k].append(wavetrace_run(a.wavetrace, a.scene, spp, shadows, threshold, w_out[k]))
    points = [(spp, statistics.median(m_secs[spp]), flip(a.wavetrace, m_out[spp], a.reference)) for spp in spps]
    ours = []
    for k, (spp, shadows, threshold) in enumerate(SETTINGS):
        aa = "uniform" if threshold is None else "variance@" + threshold
        ours.append((statistics.median(w_secs[k]), spp, shadows, flip(a.wavetrace, w_out[k], a.reference), aa))
    ours.sort()
    print("mitsuba_spp mitsuba_s mitsuba_flip | equal_spp_flip flip_ratio | wavetrace_aa wavetrace_spp shadows wavetrace_s wavetrace_flip | time_ratio")
    for spp, secs, f in points:
        # The same samples per pixel and one shadow ray: Mitsuba's own sample budget.
        same = next((o[3] for o in ours if o[1] == spp and o[2] == "1" and o[4] == "uniform"), float("nan"))
        head = f"{spp} {secs:.3f} {f:.5f} | {same:.5f} {same / f:.2f}"
        best = next((o for o in ours if o[3] <= f), None)
        if best is None:
            print(f"{head} | none of the settings reaches it")
            continue
        s, wspp, shadows, wf, aa = best
        print(f"{head} | {aa} {wspp} {shadows} {s:.3f} {wf:.5f} | {s / secs:.2f}")


if __name__ == "__main__":
    main()
