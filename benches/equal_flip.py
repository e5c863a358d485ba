#!/usr/bin/env python3
"""Time to equal error, wavetrace against Mitsuba 3, searching every sampler wavetrace has.

Two kinds of scene, each rendered by both with the transport they share:
- a Mitsuba XML scene (`scenes/gloss/*.xml`; Mitsuba: ../shared/peers/mitsuba/render_xml.py,
  direct light at diffuse surfaces, BSDF sampling at glossy ones, delta chains; wavetrace
  reads the XML), against `--reference`;
- a harness scene by name (`penumbra`, `glass`, `dof`: ../shared/peers/mitsuba/scenes/NAME.json;
  Mitsuba: render.py's Whitted integrator; wavetrace: json2toml.py's TOML, with `--scale`
  and `--translate` for a held-out variant: the same image, other coordinates), against
  the harness's converged reference (refs/NAME.exr) unless `--reference` says otherwise.

For each Mitsuba sample count (stratified sampler, llvm variant, render seconds after a
run that warms the JIT cache), the fastest wavetrace setting whose FLIP against the
reference is at most Mitsuba's: uniform samples per pixel (plain, or blue-noise dithered:
`render.blue_noise`), or variance-driven AA in rounds of 8 up to a cap at threshold 0.1
or 0.03, each with one uniform shadow ray, four, or four or sixteen adaptive ones; the whole process timed (load, BVH, render, write; the
last run's image removed first, untimed).
FLIP is wavetrace's `compare` for both renderers' images.

Timing: a first round renders every setting once (its FLIP is the setting's; seeds are
fixed, so the image is too); the finalists, each target's settings that reach it within
2× of that round's fastest, and every Mitsuba point are then timed once a round for
--reps rounds (so the machine's drift falls on both alike), and medians compared.

Prints one line per Mitsuba point: spp, Mitsuba seconds and FLIP; wavetrace's FLIP at the
same spp with one shadow ray and its ratio to Mitsuba's; the fastest wavetrace setting,
its seconds and FLIP, and the time ratio wavetrace / Mitsuba (below 1: wavetrace faster).

`--json PATH` also writes every setting's seconds (each round's), FLIP and whether it was
a finalist, and every Mitsuba point's.

Usage: benches/equal_flip.py WAVETRACE SCENE [--reference REF.exr] [--reps 3] [--spp 16,64,256]
       [--scale S] [--translate=X,Y,Z] [--json PATH]
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

PEERS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "peers")
MITSUBA = os.path.join(PEERS, "mitsuba")
# (samples per pixel, shadow rays ("4a": adaptive), AA: "uniform", "blue" (uniform,
# blue-noise dithered) or a variance threshold).
SHADOWS = ("1", "4", "4a", "16a")
SETTINGS = [
    (spp, shadows, aa)
    for spp in (1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048)
    for shadows in SHADOWS
    for aa in ("uniform", "blue")
]
SETTINGS += [
    (spp, shadows, threshold)
    for spp in (16, 32, 64, 128, 256, 512, 1024, 2048)
    for shadows in SHADOWS
    for threshold in ("0.1", "0.03")
]
# A setting past this many times the slowest Mitsuba point's seconds in the first round
# stops its sample counts' climb (more samples only cost more).
CLIMB = 3.0
# Finalists: within this factor of a target's fastest in the first round (one run each:
# a run the machine slowed by half must not cost its setting a place in the final).
FINAL = 2.0


def flip(wavetrace, image, reference):
    out = subprocess.run([wavetrace, "compare", image, reference], capture_output=True, text=True, check=True).stdout
    return float(out.split("flip")[1].split()[0])


class Scene:
    """How both renderers render one scene, and its reference."""

    def __init__(self, scene, reference, scale, translate, tmp):
        if scene.endswith(".xml"):
            if reference is None:
                sys.exit("an XML scene needs --reference")
            if scale != 1.0 or translate != "0,0,0":
                sys.exit("--scale and --translate apply to harness scenes only")
            self.mitsuba = lambda spp, out, seed: [os.path.join(MITSUBA, "render_xml.py"), scene, out, "--spp",
                                                   str(spp), "--chunk", str(spp), "--seed", str(seed), "-D",
                                                   "sampler=stratified"]
            self.wavetrace, self.reference = scene, reference
            return
        name = os.path.splitext(os.path.basename(scene))[0]
        self.mitsuba = lambda spp, out, seed: [os.path.join(MITSUBA, "render.py"), name, str(spp), out, "--sampler",
                                               "stratified", "--seed", str(seed)]
        self.wavetrace = os.path.join(tmp, name + ".toml")
        subprocess.run([sys.executable, os.path.join(PEERS, "wavetrace", "json2toml.py"),
                        os.path.join(MITSUBA, "scenes", name + ".json"), self.wavetrace, "--scale", str(scale),
                        "--translate=" + translate], check=True, capture_output=True)
        self.reference = reference or os.path.join(MITSUBA, "refs", name + ".exr")

    def render_mitsuba(self, spp, out, seed):
        text = subprocess.run([sys.executable] + self.mitsuba(spp, out, seed), capture_output=True, text=True,
                              check=True).stdout
        return float(text.split(":")[-1].split("s")[0])


def wavetrace_run(wavetrace, scene, spp, shadows, aa, out):
    sets = ["--spp", str(spp), "--set", "render.shadows.samples=" + shadows.rstrip("a")]
    sets += ["--set", "render.shadows.mode=" + ("adaptive" if shadows.endswith("a") else "uniform")]
    if aa in ("uniform", "blue"):
        sets += ["--set", "render.aa.mode=uniform", "--set", "render.blue_noise=" + str(aa == "blue").lower()]
    else:
        sets += ["--set", "render.aa.mode=variance", "--set", "render.aa.min_samples=8"]
        sets += ["--set", "render.aa.threshold=" + aa]
    # The last run's image is removed untimed: replacing a file costs its unlink (1-2 ms
    # on this machine's ext4), which a new render's output does not pay.
    if os.path.exists(out):
        os.remove(out)
    start = time.perf_counter()
    subprocess.run([wavetrace, scene, "-q", "-o", out] + sets, check=True)
    return time.perf_counter() - start


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("wavetrace")
    ap.add_argument("scene")
    ap.add_argument("--reference")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--spp", default="16,64,256")
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--translate", default="0,0,0")
    ap.add_argument("--json")
    a = ap.parse_args()
    tmp = tempfile.mkdtemp()
    scene = Scene(a.scene, a.reference, a.scale, a.translate, tmp)
    spps = [int(x) for x in a.spp.split(",")]
    m_out = {spp: os.path.join(tmp, f"m{spp}.exr") for spp in spps}
    m_secs = {spp: [] for spp in spps}
    for spp in spps:
        scene.render_mitsuba(spp, m_out[spp], 0)  # warms the JIT cache
        m_secs[spp].append(scene.render_mitsuba(spp, m_out[spp], 1))
    points = {spp: flip(a.wavetrace, m_out[spp], scene.reference) for spp in spps}
    slowest = max(s[0] for s in m_secs.values())

    # The first round: every setting once, each sampler and shadow setting's climb in
    # samples stopped once it is far past Mitsuba's slowest point.
    w_out = [os.path.join(tmp, f"w{k}.exr") for k in range(len(SETTINGS))]
    w_secs, w_flip, stopped = {}, {}, set()
    for k, (spp, shadows, aa) in enumerate(SETTINGS):
        if (shadows, aa) in stopped:
            continue
        w_secs[k] = [wavetrace_run(a.wavetrace, scene.wavetrace, spp, shadows, aa, w_out[k])]
        w_flip[k] = flip(a.wavetrace, w_out[k], scene.reference)
        if w_secs[k][0] > CLIMB * slowest:
            stopped.add((shadows, aa))
    finalists = set()
    for f in points.values():
        reach = [k for k in w_secs if w_flip[k] <= f]
        if reach:
            fastest = min(w_secs[k][0] for k in reach)
            finalists |= {k for k in reach if w_secs[k][0] <= FINAL * fastest}

    # Rounds of every Mitsuba point and every finalist, so the machine's drift (this
    # one's speed moves by a third from hour to hour) falls on both alike.
    for r in range(1, a.reps):
        for spp in spps:
            m_secs[spp].append(scene.render_mitsuba(spp, m_out[spp], r + 1))
        for k in sorted(finalists):
            spp, shadows, aa = SETTINGS[k]
            w_secs[k].append(wavetrace_run(a.wavetrace, scene.wavetrace, spp, shadows, aa, w_out[k]))
    ours = []
    for k in w_secs:
        spp, shadows, aa = SETTINGS[k]
        aa = aa if aa in ("uniform", "blue") else "variance@" + aa
        ours.append((statistics.median(w_secs[k]), spp, shadows, w_flip[k], aa, k in finalists))
    ours.sort()
    if a.json:
        with open(a.json, "w") as f:
            json.dump({
                "mitsuba": [{"spp": spp, "seconds": m_secs[spp], "flip": points[spp]} for spp in spps],
                "wavetrace": [{"spp": SETTINGS[k][0], "shadows": SETTINGS[k][1], "aa": SETTINGS[k][2],
                               "seconds": w_secs[k], "flip": w_flip[k], "finalist": k in finalists} for k in w_secs],
            }, f, indent=1)
    print("mitsuba_spp mitsuba_s mitsuba_flip | equal_spp_flip flip_ratio | wavetrace_aa wavetrace_spp shadows wavetrace_s wavetrace_flip | time_ratio")
    for spp in spps:
        secs, f = statistics.median(m_secs[spp]), points[spp]
        # The same samples per pixel and one shadow ray: Mitsuba's own sample budget.
        same = next((o[3] for o in ours if o[1] == spp and o[2] == "1" and o[4] == "uniform"), float("nan"))
        head = f"{spp} {secs:.3f} {f:.5f} | {same:.5f} {same / f:.2f}"
        best = next((o for o in ours if o[3] <= f and o[5]), None)
        if best is None:
            print(f"{head} | none of the settings reaches it")
            continue
        s, wspp, shadows, wf, aa, _ = best
        print(f"{head} | {aa} {wspp} {shadows} {s:.3f} {wf:.5f} | {s / secs:.2f}")


if __name__ == "__main__":
    main()
