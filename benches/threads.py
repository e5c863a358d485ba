#!/usr/bin/env python3
"""Thread scaling of `wavetrace bench` on bare meshes: one thread against two.

For each mesh, runs `wavetrace bench --mesh M --threads T --reps 3 --json` with T = 1 and
2 alternating, ROUNDS times, and prints per kernel and set the median Mrays/s at each
thread count and their ratio (the wall clock: CPU time would hide the scaling).

Usage: benches/threads.py [--wavetrace BIN] [--rounds 2] MESH.obj...
"""

import argparse
import json
import os
import statistics
import subprocess

SETS = ["camera", "shadow", "bounce", "random", "bounce-shadow"]
KERNELS = ["wide", "hybrid", "packet", "interleaved", "stream"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--wavetrace", default="target/release/wavetrace")
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args()
    res = {}
    for mesh in args.meshes:
        for _ in range(args.rounds):
            for t in (1, 2):
                cmd = [args.wavetrace, "bench", "--mesh", mesh, "--threads", str(t), "--reps", "3", "--json"]
                out = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
                for s in out["sets"]:
                    res.setdefault((mesh, s["set"], s["kernel"], t), []).append(s["mrays_per_s"])
    for k in KERNELS:
        print(k)
        for mesh in args.meshes:
            cells = []
            for s in SETS:
                one, two = (statistics.median(res[(mesh, s, k, t)]) for t in (1, 2))
                cells.append(f"{s} {one:.2f}→{two:.2f} ({two / one:.2f}×)")
            print(f"  {os.path.basename(mesh)}: " + " | ".join(cells))


if __name__ == "__main__":
    main()
