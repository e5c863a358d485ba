#!/usr/bin/env python3
"""What motion blur costs: a scene rendered moving (its shutter) and still
(`camera.shutter=[0,0]`), interleaved round by round, by the render's seconds in the
stats JSON (no load, no outputs). Prints per binary the median seconds of each, the
still ÷ moving ratio of the medians (the moving scene's share of the still scene's rays
per second: both cast the same rays to within 0.2%) and every round's ratio, whose
spread is the machine's noise. With two binaries both run in the same rotation.

Usage: benches/motion_cost.py BIN [BIN2] [--runs 9] [--threads 1] [--scene scenes/motion/bunnies.toml]
"""

import argparse
import json
import os
import statistics
import subprocess
import tempfile


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bins", nargs="+")
    ap.add_argument("--runs", type=int, default=9)
    ap.add_argument("--threads", default="1")
    ap.add_argument("--scene", default="scenes/motion/bunnies.toml")
    a = ap.parse_args()
    out = tempfile.mkdtemp()
    shutters = {"moving": None, "still": "camera.shutter=[0,0]"}
    secs = {(b, s): [] for b in range(len(a.bins)) for s in shutters}
    for _ in range(a.runs):
        for b, s in secs:
            stats = os.path.join(out, "stats.json")
            cmd = [a.bins[b], a.scene, "--threads", a.threads, "-o", os.path.join(out, "o.png"), "--stats-json", stats]
            if shutters[s]:
                cmd += ["--set", shutters[s]]
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            with open(stats) as f:
                secs[(b, s)].append(json.load(f)["seconds"])
    for b, name in enumerate(a.bins):
        moving, still = statistics.median(secs[(b, "moving")]), statistics.median(secs[(b, "still")])
        rounds = sorted(x / y for x, y in zip(secs[(b, "still")], secs[(b, "moving")]))
        print(f"{name}: moving {moving:.3f} s, still {still:.3f} s, still/moving {still / moving:.3f}")
        print("  rounds: " + " ".join(f"{r:.2f}" for r in rounds))


if __name__ == "__main__":
    main()
