#!/usr/bin/env python3
"""Per-ray cost, 1 thread, same work: wavetrace vs Mitsuba 3 (llvm_ad_rgb) on the harness scenes.

usage: python3 benches/mitsuba_per_ray.py WAVETRACE_BIN [--scenes penumbra,dof] [--spp 64] [--reps 5] [--json OUT]

Both sides render the scene spec (../shared/peers/mitsuba/scenes/SCENE.json) at its resolution with SPP
camera samples per pixel, one shadow ray per diffuse hit, max depth 6 segments (wavetrace max_depth 5),
on one thread. wavetrace: uniform AA and uniform shadows (json2toml.py + --set), `--threads 1`, time = the
`seconds` of --stats-json (render only; the whole-process wall time is shown too). Mitsuba: mitsuba_time.py
(custom Whitted integrator, stratified sampler, `dr.set_thread_count(1)`, render time only, after a JIT
warm-up render in the same process, which is not counted). Runs alternate wavetrace, Mitsuba, wavetrace, ...;
every figure is the median over --reps. Needs ../shared/peers/mitsuba/setup.sh. Compare ratios, not seconds.
"""
import argparse, json, os, statistics, subprocess, sys, tempfile, time

HERE = os.path.dirname(os.path.abspath(__file__))
PEERS = os.path.normpath(os.path.join(HERE, "..", "..", "shared", "peers"))
STAGES = ("camera", "intersect", "shade", "shadow", "film")


def wavetrace_once(binary, toml, spp, tmp):
    stats = os.path.join(tmp, "stats.json")
    cmd = [binary, "render", toml, "-o", os.path.join(tmp, "w.exr"), "--threads", "1", "--quiet",
           "--stats-json", stats, "--set", "render.aa.mode=uniform", "--set", "render.aa.samples=%d" % spp,
           "--set", "render.shadows.mode=uniform", "--set", "render.shadows.samples=1"]
    t = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    wall = time.perf_counter() - t
    s = json.load(open(stats))
    return dict(wall=wall, seconds=s["seconds"], mrays=s["mrays_per_s"], rays=s["rays"], threads=s["threads"],
                total_rays=s["total_rays"], ns={k: s["stages"][k]["ns_per_ray"] for k in STAGES},
                width=s["width"], height=s["height"])


def mitsuba_once(scene, spp):
    out = subprocess.run([sys.executable, os.path.join(PEERS, "wavetrace", "mitsuba_time.py"), scene, str(spp),
                          "1", "1"], check=True, capture_output=True, text=True).stdout
    return float(out.split()[-1])


def check_work(w, spp):
    r = w["rays"]
    want = w["width"] * w["height"] * spp
    assert w["threads"] == 1, w["threads"]
    assert r["camera"] == want, "camera rays %d != %d (W*H*spp)" % (r["camera"], want)
    assert 0 < r["shadow"] <= r["camera"], "expected at most one shadow ray per camera ray: %s" % r
    extra = {k: v for k, v in r.items() if k not in ("camera", "shadow") and v}
    assert not extra, "unexpected ray kinds (adaptive or multi-sample work?): %s" % extra


def med(xs):
    return statistics.median(xs)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("binary")
    ap.add_argument("--scenes", default="penumbra,dof")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--json", default=None, help="write every timing here")
    a = ap.parse_args()
    binary = os.path.abspath(a.binary)
    rows, raw = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for scene in a.scenes.split(","):
            toml = os.path.join(tmp, scene + ".toml")
            subprocess.run([sys.executable, os.path.join(PEERS, "wavetrace", "json2toml.py"),
                            os.path.join(PEERS, "mitsuba", "scenes", scene + ".json"), toml,
                            "--aa-mode", "uniform", "--aa-samples", str(a.spp),
                            "--shadow-mode", "uniform", "--shadow-samples", "1", "--dof-samples", "1"], check=True)
            ws, ms = [], []
            for rep in range(a.reps):
                ws.append(wavetrace_once(binary, toml, a.spp, tmp))
                check_work(ws[-1], a.spp)
                ms.append(mitsuba_once(scene, a.spp))
                print("%s rep %d: wavetrace %.3f s (process %.3f s), mitsuba %.3f s" % (
                    scene, rep + 1, ws[-1]["seconds"], ws[-1]["wall"], ms[-1]), file=sys.stderr)
            w = dict(seconds=med([x["seconds"] for x in ws]), wall=med([x["wall"] for x in ws]),
                     mrays=med([x["mrays"] for x in ws]), ns={k: med([x["ns"][k] for x in ws]) for k in STAGES})
            m = med(ms)
            rays = ws[0]["rays"]
            rows.append((scene, w, m, rays))
            raw[scene] = dict(wavetrace=ws, mitsuba=ms, rays=rays)
    print("%d spp, 1 shadow ray per diffuse hit, uniform sampling, 1 thread; median of %d alternating runs\n"
          % (a.spp, a.reps))
    print("| scene | camera rays | shadow rays | wavetrace s | (process s) | Mitsuba s | wavetrace/Mitsuba | "
          "wavetrace Mrays/s | " + " | ".join("%s ns/ray" % k for k in STAGES) + " |")
    print("|---|" + "---:|" * (7 + len(STAGES)))
    for scene, w, m, rays in rows:
        print("| %s | %d | %d | %.3f | %.3f | %.3f | %.2f | %.2f | %s |" % (
            scene, rays["camera"], rays["shadow"], w["seconds"], w["wall"], m, w["seconds"] / m, w["mrays"],
            " | ".join("%.1f" % w["ns"][k] for k in STAGES)))
    if a.json:
        json.dump(raw, open(a.json, "w"), indent=1)


if __name__ == "__main__":
    main()
