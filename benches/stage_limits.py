#!/usr/bin/env python3
"""Per stage, the time per item against what its instruction count and memory traffic allow.

usage: python3 benches/stage_limits.py NATIVE_BIN AVX2_BIN [--scenes penumbra,dof] [--res 320x240]
       [--spp 64] [--cg-res 160x120] [--cg-spp 16] [--reps 9] [--ghz 2.5] [--ipc 4] [--json OUT]

The harness scenes (../shared/peers/mitsuba/scenes/*.json, as benches/mitsuba_per_ray.py renders
them: uniform AA, one shadow ray per diffuse hit, 1 thread). Per stage:
  * ns/item of the native build (`-C target-cpu=native`: AVX-512 here) and of an AVX2 build
    (`RUSTFLAGS="-C target-cpu=x86-64-v3"`), medians of --reps `--stats-json` runs at --res
    and --spp (the per-ray comparison's setting), the two builds alternating;
  * instructions, L1 data misses and last-level misses per item of the AVX2 build (one render
    at --cg-res and --cg-spp) under
    callgrind with its cache model (valgrind has no AVX-512, hence the second build), counted
    in the stage's function and all it calls (`--toggle-collect`): camera `stages::camera::generate`, intersect
    `Tracer::closest`, shade `stages::shade::shade`, shadow `Tracer::occluded`, film
    `stages::film::accumulate`;
  * the floors they set: instructions / (--ipc x --ghz), and the bytes those misses move
    (64 a line) over the bandwidths measured here with numpy copies (L2-sized and DRAM-sized
    arrays, one thread);
  * the AVX2 build's achieved instructions per cycle, and its time over the larger floor.
Needs valgrind and numpy. Compare ratios; the machine is shared.
"""
import argparse, json, os, statistics, subprocess, sys, tempfile, time

HERE = os.path.dirname(os.path.abspath(__file__))
PEERS = os.path.normpath(os.path.join(HERE, "..", "..", "shared", "peers"))
STAGES = {
    "camera": "wavetrace::stages::camera::generate",
    "intersect": "wavetrace::accel::tracer::Tracer::closest",
    "shade": "wavetrace::stages::shade::shade",
    "shadow": "wavetrace::accel::tracer::Tracer::occluded",
    "film": "wavetrace::stages::film::accumulate",
}


def render_cmd(binary, toml, out_dir, res, spp):
    return [binary, "render", toml, "-o", os.path.join(out_dir, "w.exr"), "--threads", "1", "--quiet",
            "--stats-json", os.path.join(out_dir, "s.json"), "--res", res,
            "--set", "render.aa.mode=uniform", "--set", "render.aa.samples=%d" % spp,
            "--set", "render.shadows.mode=uniform", "--set", "render.shadows.samples=1"]


def items(stats):
    """Items per stage: rays generated (camera), rays in (the others)."""
    st = stats["stages"]
    return {k: (st[k]["rays_out"] if k == "camera" else st[k]["rays_in"]) for k in STAGES}


def timed(binaries, toml, tmp, a):
    """Median ns per item of each stage for each binary, the binaries alternating."""
    runs = [[] for _ in binaries]
    for _ in range(a.reps):
        for b, r in zip(binaries, runs):
            subprocess.run(render_cmd(b, toml, tmp, a.res, a.spp), check=True)
            s = json.load(open(os.path.join(tmp, "s.json")))
            r.append({k: s["stages"][k]["ns_per_ray"] for k in STAGES})
    return [{k: statistics.median(x[k] for x in r) for k in STAGES} for r in runs]


def callgrind(binary, toml, tmp, a):
    """Per stage, its function's events per item: callgrind collecting only inside it
    (`--toggle-collect`, everything it calls included), with the cache model on throughout."""
    per = {}
    for stage, fn in STAGES.items():
        out = os.path.join(tmp, "cg.out")
        cmd = ["valgrind", "--tool=callgrind", "--cache-sim=yes", "--toggle-collect=" + fn,
               "--callgrind-out-file=" + out] + render_cmd(binary, toml, tmp, a.cg_res, a.cg_spp)
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        k = items(json.load(open(os.path.join(tmp, "s.json"))))[stage]
        lines = dict(l.split(":", 1) for l in open(out) if l.startswith(("events:", "summary:")))
        c = dict(zip(lines["events"].split(), map(int, lines["summary"].split())))
        if k and c["Ir"]:
            miss = lambda *e: sum(c.get(x, 0) for x in e) / k
            per[stage] = dict(items=k, ir=c["Ir"] / k, d1=miss("D1mr", "D1mw"), ll=miss("DLmr", "DLmw"))
    return per


def bandwidth(nbytes, reps):
    """Bytes per second of a numpy copy (read + write) of an array of `nbytes`."""
    import numpy as np
    src = np.ones(nbytes // 4, dtype=np.float32)
    dst = np.empty_like(src)
    np.copyto(dst, src)
    best = float("inf")
    for _ in range(5):
        t = time.perf_counter()
        for _ in range(reps):
            np.copyto(dst, src)
        best = min(best, (time.perf_counter() - t) / reps)
    return 2 * nbytes / best


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("native")
    p.add_argument("avx2")
    p.add_argument("--scenes", default="penumbra,dof")
    p.add_argument("--res", default="320x240", help="timed renders' size")
    p.add_argument("--spp", type=int, default=64, help="timed renders' camera samples a pixel")
    p.add_argument("--cg-res", default="160x120", help="callgrind's render size (about 100x slower)")
    p.add_argument("--cg-spp", type=int, default=16)
    p.add_argument("--reps", type=int, default=9)
    p.add_argument("--ghz", type=float, default=2.5, help="clock for cycles (lscpu: 2.50 GHz here)")
    p.add_argument("--ipc", type=float, default=4.0, help="instructions a cycle taken as the core's limit")
    p.add_argument("--json")
    a = p.parse_args()
    l2_bw, dram_bw = bandwidth(512 << 10, 400), bandwidth(256 << 20, 2)
    print("bandwidth (numpy copy, read + write, 1 thread): L2-sized %.1f GB/s, DRAM-sized %.1f GB/s"
          % (l2_bw / 1e9, dram_bw / 1e9))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in a.scenes.split(","):
            toml = os.path.join(tmp, scene + ".toml")
            subprocess.run([sys.executable, os.path.join(PEERS, "wavetrace", "json2toml.py"),
                            os.path.join(PEERS, "mitsuba", "scenes", scene + ".json"), toml], check=True,
                           stdout=subprocess.DEVNULL)
            native, avx2 = timed([a.native, a.avx2], toml, tmp, a)
            cg = callgrind(a.avx2, toml, tmp, a)
            for stage, c in cg.items():
                ns_instr = c["ir"] / (a.ipc * a.ghz)
                ns_mem = c["d1"] * 64 / l2_bw * 1e9 + c["ll"] * 64 / dram_bw * 1e9
                floor = max(ns_instr, ns_mem)
                rows.append(dict(scene=scene, stage=stage, items=c["items"], ns_native=native[stage],
                                 ns_avx2=avx2[stage], instr=c["ir"], d1=c["d1"], ll=c["ll"],
                                 floor_instr=ns_instr, floor_mem=ns_mem,
                                 ipc=c["ir"] / (avx2[stage] * a.ghz), over=avx2[stage] / floor))
    print("| scene | stage | items | ns/item native | ns/item AVX2 | instructions/item | L1D misses/item "
          "| LL misses/item | floor: instructions ns | floor: memory ns | AVX2 IPC | AVX2 ÷ floor |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print("| %s | %s | %d | %.1f | %.1f | %.0f | %.2f | %.3f | %.1f | %.2f | %.2f | %.1f |" % (
            r["scene"], r["stage"], r["items"], r["ns_native"], r["ns_avx2"], r["instr"], r["d1"], r["ll"],
            r["floor_instr"], r["floor_mem"], r["ipc"], r["over"]))
    print("(timed: %s, %d spp, 1 thread, medians of %d runs; counted: %s, %d spp; floors at %.1f "
          "instructions a cycle and %.2f GHz)" % (a.res, a.spp, a.reps, a.cg_res, a.cg_spp, a.ipc, a.ghz))
    if a.json:
        json.dump(dict(rows=rows, l2_bw=l2_bw, dram_bw=dram_bw, args=vars(a)), open(a.json, "w"), indent=1)


if __name__ == "__main__":
    main()
