#!/usr/bin/env python3
"""Where a whole `wavetrace render` process spends its time outside the render: for each
binary, interleaved runs of a small render and of `--version`, medians of the whole
process's wall time, the stats JSON's `seconds` (the render), `scene.load_seconds` and
`scene.bvh_seconds`, and what is left (start, thread pools, encode, write, exit).

usage: python3 benches/overhead.py BIN [BIN2] [--scene S] [--runs 21] [--threads 2]
       [--output png|exr] [--fresh] [--set KEY=VALUE]...

The default scene is the Mitsuba harness penumbra scene (converted with json2toml.py) at
320x240, 4 camera samples and 4 shadow rays: a 4-spp render, where the process's fixed
costs weigh most against the render. Compare binaries in one run; the machine is shared.
"""
import argparse, json, os, statistics, subprocess, sys, tempfile, time

HERE = os.path.dirname(os.path.abspath(__file__))
PEERS = os.path.normpath(os.path.join(HERE, "..", "..", "shared", "peers"))


def once(binary, scene, tmp, a):
    stats = os.path.join(tmp, "s.json")
    out = os.path.join(tmp, "o." + a.output)
    if a.fresh:
        for f in (stats, out):
            if os.path.exists(f):
                os.remove(f)
    cmd = [binary, "render", scene, "-o", out, "--threads", str(a.threads), "--quiet", "--stats-json", stats]
    for s in a.set:
        cmd += ["--set", s]
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t
    s = json.load(open(stats))
    t = time.perf_counter()
    subprocess.run([binary, "--version"], check=True, stdout=subprocess.DEVNULL)
    version = time.perf_counter() - t
    load, bvh = s["scene"]["load_seconds"], s["scene"]["bvh_seconds"]
    return dict(wall=wall, render=s["seconds"], load=load, bvh=bvh, rest=wall - s["seconds"] - load,
                outside=wall - s["seconds"], version=version)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("binaries", nargs="+")
    p.add_argument("--scene", help="scene file (default: the harness penumbra scene)")
    p.add_argument("--runs", type=int, default=21)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--output", choices=("png", "exr"), default="png")
    p.add_argument("--set", action="append", default=[])
    p.add_argument("--fresh", action="store_true",
                   help="remove the outputs before each run (else each run replaces the last one's files)")
    a = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        scene = a.scene
        if scene is None:
            scene = os.path.join(tmp, "penumbra.toml")
            subprocess.run([sys.executable, os.path.join(PEERS, "wavetrace", "json2toml.py"),
                            os.path.join(PEERS, "mitsuba", "scenes", "penumbra.json"), scene], check=True,
                           stdout=subprocess.DEVNULL)
            a.set = ["render.aa.mode=uniform", "render.aa.samples=4", "render.shadows.mode=uniform",
                     "render.shadows.samples=4"] + a.set
        rows = {b: [] for b in a.binaries}
        for _ in range(a.runs):
            for b in a.binaries:
                rows[b].append(once(b, scene, tmp, a))
    keys = ("wall", "render", "load", "bvh", "outside", "rest", "version")
    print("| binary | " + " | ".join(k + " ms" for k in keys) + " |")
    print("|---" * (len(keys) + 1) + "|")
    for b, rs in rows.items():
        med = [statistics.median(r[k] for r in rs) * 1e3 for k in keys]
        print("| %s | " % b + " | ".join("%.2f" % m for m in med) + " |")
    print("(%d interleaved runs, medians; outside = wall - render; rest = outside - load)" % a.runs)


if __name__ == "__main__":
    main()
