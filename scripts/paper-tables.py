#!/usr/bin/env python3
"""Renders the measured tables of docs/paper.md, docs/tradeoffs.md, docs/import.md and docs/adaptive.md
with the current binary and prints them as markdown, command line first. Run from the repository root.
Renders use --threads 2 (the bunny timing: 1 thread, 9 runs); rays, RMSE, FLIP are exact, seconds not.
  --wavetrace  the binary (default: $WAVETRACE, else target/release/wavetrace)
  --work       images, stats JSON, sweeps and cached sweep references (default /tmp/paper-tables)
  --runs       renders of each paper/import/adaptive table row, interleaved; seconds: the median (default 1)
  --res WxH    every scene at WxH instead of its own size: a quick check of the script only
"""
import argparse, functools, itertools, json, os, shlex, statistics, struct, subprocess, sys, time
KINDS = [("camera", "cam"), ("aa_corner", "cor"), ("aa_refine", "ref"), ("dof_probe", "dp"),
         ("shadow", "sh"), ("shadow_corner", "sc"), ("penumbra", "pen"), ("secondary", "sec")]
A = None  # the parsed arguments (main)
S = lambda *kv: [x for v in kv for x in ("--set", v)]  # --set flags
sec = lambda x: f"{x:.2f}" if x < 10 else f"{x:.1f}"  # seconds
mr = lambda x: f"{x / 1e6:.2f}" if x < 1e7 else f"{x / 1e6:.1f}" if x < 1e9 else f"{x / 1e6:,.0f}"  # M rays
g3 = lambda x: f"{x:#.3g}"  # an error metric
SHADOW = lambda r: r["shadow"] + r["shadow_corner"] + r["penumbra"]
CAMERA = lambda r: r["camera"] + r["aa_corner"] + r["aa_refine"]

def wt(*args, out=False):  # runs wavetrace; out: returns its stdout
    return subprocess.run([A.wavetrace, *map(str, args)], check=True, text=True, capture_output=out).stdout

def size_args(sweep=False):  # --res WxH: render flags, or a sweep's --set flags
    w, h = (A.res or "x").split("x")
    return [] if not A.res else S(f"render.width={w}", f"render.height={h}") if sweep else ["--res", A.res]

def render_all(jobs, runs, threads=2):
    """jobs: (name, scene, args). Renders each `runs` times, interleaved; returns name -> stats
    (rays of the first run, checked equal in all; seconds: the median)."""
    res = {}
    for i in range(runs):
        for name, scene, args in jobs:
            js = f"{A.work}/{name}.{i + 1}.json"
            wt(scene, *size_args(), *args, "--threads", threads, "-q", "--stats-json", js,
               *([] if "-o" in args else ["-o", f"{A.work}/images/{name}.png"]))
            res.setdefault(name, []).append(json.load(open(js)))
    for name, rs in res.items():
        assert all(r["rays"] == rs[0]["rays"] for r in rs), name
        t = statistics.median(r["seconds"] for r in rs)
        res[name] = dict(rs[0], seconds=t, mrays_per_s=rs[0]["total_rays"] / t / 1e6, all=rs)
    return res

def sweep(name, scene, params, ref):
    """wavetrace sweep into WORK/name; ref: --reference-spp N, or a reference image's path."""
    d, args = f"{A.work}/{name}", [x for p in params for x in ("--param", p)]
    ref = ["--reference-spp", ref] if isinstance(ref, int) else ["--reference", ref]
    wt("sweep", scene, *args, *size_args(True), *ref, "-o", d, "--threads", 2, "-q")
    return json.load(open(f"{d}/sweep.json"))

def groups(d, label):
    """A sweep's points by label(point); points that share a label must be the same render."""
    g = {}
    for p in d["points"]:
        g.setdefault(label(p), []).append(p)
        assert p["rays"] == g[label(p)][0]["rays"] and p["rmse"] == g[label(p)][0]["rmse"], label(p)
    return g

def table(title, d, header, rows, ref=None):
    """Prints a title line, the sweep's reference (d: a sweep.json, or None; ref: a line instead),
    then the table."""
    print(title + ":\n" + (f"\n{ref}\n" if ref else ""))
    if d:
        r = d["reference"]
        t = f", {sec(r['seconds'])} s" if r["rendered"] else " (cached)"
        print(f"Reference: {', '.join(r['overrides'])}: {mr(r['total_rays'])} M rays{t}.\n" if r["total_rays"]
              else f"Reference: {os.path.basename(r['path'])}.\n")
    print("| " + " | ".join(h.lstrip(">") for h in header) + " |")  # ">": right-aligned
    print("|" + "|".join("---:" if h[:1] == ">" else "---" for h in header) + "|")
    print("\n".join("| " + " | ".join(map(str, r)) + " |" for r in rows) + "\n")

# ---- docs/paper.md ---------------------------------------------------------------------
P = "scenes/paper/"
UAA = lambda n: S("render.aa.mode=uniform", f"render.aa.samples={n}")
USH = S("render.shadows.mode=uniform")
H = lambda kind, name: ["--heatmap", f"{kind}={A.work}/images/{name}_heat_{kind}.png"]
DOF = S("render.aa.dof_aware=true")
# Fig., paper: setting, paper: time, scene, rows (name, ours, args, ÷ uniform?), uniform (name, args, label)
FIGS = lambda: [
    ("2", "adaptive AA, corners, eps 0.01, ≤ 64 samples", "67.6 s", "fig02-aa",
     [("fig02", "adaptive (paper-literal: min_level 2, 5 rays per pixel)", H("aa", "fig02"), 1),
      ("fig02_shared", "adaptive, shared corners (same image)", S("render.aa.share_corners=true"), 1)],
     ("fig02_uniform64", UAA(64), "uniform 64")),
    ("3", "adaptive shadows, 128 samples", "129.38 s (unoptimised 309.68 s; no shadow samples 36.1 s)",
     "fig03-penumbra",
     [("fig03", "adaptive 128, corner probe", H("penumbra", "fig03"), 1),
      ("fig03_3x3", "adaptive 128, 3×3 probe (our default)", S("render.shadows.probe=3x3"), 1),
      ("fig03_uniform1", 'uniform, 1 shadow ray ("no shadow samples")', USH + S("render.shadows.samples=1"), 0)],
     ("fig03_uniform128", USH, "uniform 128")),
    ("4", "refractive sphere, several η", "—", "fig04-refraction",
     [("fig04", "ior 1.5, adaptive AA", [], 1)] +
     [(f"fig04_ior{v}", f"ior {v} (one render)", S(f"materials.glass.ior={v}"), 0) for v in ("1.0", "2.0")],
     ("fig04_uniform64", UAA(64), "uniform 64")),
    ("6", "C = 0.1 / 0.5, depth 3", "—", "fig06-semireflective",
     [("fig06", "C = 0.1, adaptive AA and shadows", [], 1),
      ("fig06_C0.5", "C = 0.5 (one render)", S("materials.glass.reflect_ratio=0.5"), 0)],
     ("fig06_uniform", UAA(64) + USH, "uniform 64 AA, 16 shadow")),
    ("7", "blur radius 2 / 5", "—", "fig07-dof",
     [("fig07", "b = 2, 4 AA × 32 lens, 4 shadow (all uniform)", [], 0),
      ("fig07_b5", "b = 5 (one render)", S("camera.aperture=5"), 0)], None),
    ("8", "4 shadow + 4 AA, depth 3, 70 DOF, b = 5, η = 1.000293/1.5", "6 hours", "fig08-combined",
     [("fig08", "adaptive AA and shadows", H("aa", "fig08"), 1),
      ("fig08_dofaware", "DOF-aware adaptive", DOF + H("aa", "fig08_dofaware"), 1)],
     ("fig08_uniform", UAA(4) + USH, "uniform 4 AA × 70, 4 shadow")),
    ("10", "64 AA, 1 shadow, depth 3, 5 DOF, b = 2, η = 1.000293/1.5", "—", "fig10-debug",
     [("fig10", "adaptive AA and shadows", H("aa", "fig10"), 1),
      ("fig10_dofaware", "DOF-aware adaptive", DOF + H("aa", "fig10_dofaware"), 1)],
     ("fig10_uniform", UAA(64) + USH, "uniform 64 AA × 5, 1 shadow")),
]

def ours(text, s):  # says where adaptive shadows sampled a light as uniform mode does
    sh = s.get("adaptive_shadows") or {}
    fb, ent = sh.get("uniform_fallback", 0), sh.get("entered", 0)
    return text + ("" if not fb else " (shadows: uniform fallback)" if not ent else
                   f" ({fb / (fb + ent):.0%} of light pairs: uniform fallback)")

def paper():
    figs = FIGS()
    jobs = [(r[0], P + f[3] + ".toml", r[2]) for f in figs for r in f[4]]
    jobs += [(f[5][0], P + f[3] + ".toml", f[5][1]) for f in figs if f[5]]
    jobs += [(f"fig04_ior{v}", P + "fig04-refraction.toml", S(f"materials.glass.ior={v}")) for v in ("1.1", "1.33")]
    st = render_all(jobs, A.runs)  # (fig04 ior 1.1 and 1.33: images only)
    rows = []
    for fig, setting, ptime, _, frows, uni in figs:
        for k, (name, text, _, ratio) in enumerate(frows):
            s, u = st[name], uni and st[uni[0]]
            rat = "—" if not ratio else (
                f"{s['total_rays'] / u['total_rays']:.3f}, {s['seconds'] / u['seconds']:.3f} (uniform: "
                f"{u['total_rays'] / 1e6:.1f} M rays, {sec(u['seconds'])} s; {uni[2]})")
            kinds = " · ".join(f"{ab} {s['rays'][kd] / 1e6:.2f}" for kd, ab in KINDS if s["rays"][kd])
            rows.append(((fig, setting, ptime) if k == 0 else ("", "", "")) + (
                ours(text, s), kinds, mr(s["total_rays"]), sec(s["seconds"]), f"{s['mrays_per_s']:.2f}", rat))
    table(f"Per figure ({A.runs} run(s) per row, median seconds)", None,
          ["Fig.", "paper: setting", "paper: time", "ours", "rays (M) by kind", ">total rays (M)", ">seconds",
           ">Mrays/s", "÷ uniform: rays, seconds"], rows)
    aa = {r[0]: st[r[0]]["adaptive_aa"] for f in figs for r in f[4] if "adaptive_aa" in st[r[0]]}
    print("\n".join(f"- {n}: {a['refined'] / a['entered']:.1%} of the pixels refined"
                    for n, a in aa.items()), end="\n\n")
    paper_sweeps()

def paper_sweeps():
    d = sweep("sweep_fig03", P + "fig03-penumbra.toml", ["render.shadows.mode=uniform,adaptive",
              "render.shadows.samples=16,32,64,128", "render.shadows.tolerance=0,0.03,0.05,0.1,0.2"], 1024)
    rows = []  # one row per distinct render: a tolerance too small to stop anything is tolerance 0
    for (mode, n, *_), ps in groups(d, lambda p: (p["params"]["render.shadows.mode"],
                                    p["params"]["render.shadows.samples"], p["total_rays"], p["rmse"])).items():
        tols = [q["params"]["render.shadows.tolerance"] for q in ps]
        tol = "" if mode == "uniform" else "0 (any)" if len(tols) == 5 else ", ".join(tols)
        rows.append((f"uniform {n}" if mode == "uniform" else n, tol, mr(ps[0]["total_rays"]) + " M",
                     "" if mode == "uniform" else mr(ps[0]["rays"]["penumbra"]) + " M",
                     sec(statistics.median(q["seconds"] for q in ps)), g3(ps[0]["rmse"]), g3(ps[0]["flip"])))
    table("Early stopping, fig03", d, [">" + h for h in ("samples", "tolerance", "rays", "penumbra rays",
                                                          "seconds", "RMSE", "FLIP")], rows)
    d = sweep("sweep_fig08", P + "fig08-combined.toml", ["render.aa.dof_aware=false,true",
              "render.dof.samples=8,16,35,70"], 16)
    pts = {tuple(p["params"].values()): p for p in d["points"]}
    cell = lambda p: (mr(p["total_rays"]) + " M", sec(p["seconds"]), g3(p["rmse"]), g3(p["flip"]))
    table("DOF-aware, fig08", d, [">lens samples", ">adaptive: rays", ">seconds", ">RMSE", ">FLIP",
                                  ">DOF-aware: rays", ">seconds", ">RMSE", ">FLIP"],
          [(n,) + cell(pts[("false", n)]) + cell(pts[("true", n)]) for n in ("8", "16", "35", "70")])
    d = sweep("sweep_fig10", P + "fig10-debug.toml", ["render.aa.dof_aware=false,true",
              "render.aa.eps=0.01,0.03,0.1", "render.aa.dof_radius=1,2,4"], 256)
    pts = {tuple(p["params"].values()): p for p in d["points"]}
    cell = lambda p: (mr(p["total_rays"]) + " M", g3(p["rmse"]), g3(p["flip"]))
    head = [">eps"] + [x for c in ("adaptive", "DOF-aware, dof_radius 1", "radius 2", "radius 4")
                       for x in (f">{c}: rays", ">RMSE", ">FLIP")]
    table("DOF-aware, fig10", d, head, [(e,) + cell(pts[("false", e, "1")]) + sum(
        (cell(pts[("true", e, r)]) for r in "124"), ()) for e in ("0.01", "0.03", "0.1")])

# ---- docs/tradeoffs.md -----------------------------------------------------------------
def sweep_table(title, d, head, label, extra):
    """One row per distinct render (points whose label differs only in a setting their mode
    ignores); seconds: the median of those points, with their count in brackets."""
    rows = []
    for lab, ps in groups(d, lambda p: label(p["params"])).items():
        p = ps[0]
        t = f"{statistics.median(q['seconds'] for q in ps):.3f}" + (f" ({len(ps)})" if len(ps) > 1 else "")
        rows.append((lab, f"{p['total_rays']:,}", f"{extra(p['rays']):,}", t, f"{p['rmse']:.6f}",
                     f"{p['flip']:.5f}", "yes" if p["pareto_rays"] else ""))
    table(title, d, head + [">total rays", ">" + ("shadow rays" if extra is SHADOW else "camera-level rays"),
                            ">seconds", ">RMSE", ">FLIP", "front"], rows)

def tradeoffs():
    pa = lambda key: lambda params: params[f"render.{key}"]
    mode, n, probe, eps = pa("shadows.mode"), pa("shadows.samples"), pa("shadows.probe"), pa("aa.eps")
    d = sweep("sweep_penumbra", "scenes/penumbra.toml", ["render.shadows.mode=uniform,adaptive",
              "render.shadows.samples=4,16,64,128"], 1024)
    sweep_table("penumbra.toml", d, ["setting"], lambda q: f"{mode(q)}, samples {n(q)}", SHADOW)
    d = sweep("sweep_penumbra_probe", "scenes/penumbra.toml", ["render.shadows.mode=adaptive",
              "render.shadows.probe=corners,3x3", "render.shadows.samples=16,64,128"], d["reference"]["path"])
    sweep_table("penumbra.toml, probes", d, ["setting"], lambda q: f"{probe(q)}, samples {n(q)}", SHADOW)
    d = sweep("sweep_fooled", "scenes/fooled.toml", ["render.shadows.mode=uniform,adaptive",
              "render.shadows.probe=corners,3x3", "render.shadows.samples=16,64"], 1024)
    sweep_table("fooled.toml", d, ["setting"], lambda q: f"uniform, samples {n(q)} (probe ignored)"
                if mode(q) == "uniform" else f"adaptive, {probe(q)}, samples {n(q)}", SHADOW)
    d = sweep("sweep_edges", "scenes/edges.toml", ["render.aa.mode=uniform,adaptive",
              "render.aa.samples=4,16,64", "render.aa.eps=0.003,0.01,0.03"], 1024)
    sweep_table("edges.toml", d, ["setting"], lambda q: f"uniform, samples {q['render.aa.samples']}"
                if q["render.aa.mode"] == "uniform" else
                f"adaptive, eps {eps(q)}" + (" (default)" if eps(q) == "0.01" else ""), CAMERA)
    d = sweep("sweep_edges_adaptive", "scenes/edges.toml", ["render.aa.mode=adaptive", "render.aa.max_level=6,7,8",
              "render.aa.min_level=4,6", "render.aa.eps=0.001,0.003,0.01"], d["reference"]["path"])
    sweep_table("edges.toml, adaptive knobs", d, [">max_level", ">min_level", ">eps"],
                lambda q: " | ".join(q[f"render.aa.{x}"] for x in ("max_level", "min_level", "eps")), CAMERA)

# ---- docs/import.md --------------------------------------------------------------------
def import_():
    sc, ref = "scenes/import/penumbra-triangle.toml", f"{A.work}/ref_tri.exr"
    render_all([("ref_tri", sc, S("render.shadows.samples=1024") + ["-o", ref])], 1)
    ad = lambda n, pr: S("render.shadows.mode=adaptive", f"render.shadows.samples={n}", f"render.shadows.probe={pr}")
    rows = [(f"uniform {n}", S(f"render.shadows.samples={n}")) for n in (16, 64, 128)] + [
        (f"adaptive {n}, probe `{pr}`{c}", ad(n, pr)) for n, pr, c in ((128, "corners", " (3 rays)"),
        (128, "corners+center", " (4)"), (128, "jittered", " (4)"), (128, "3x3", " (7, default)"), (64, "3x3", ""))]
    st = render_all([(f"tri{i}", sc, a + ["-o", f"{A.work}/tri{i}.exr"]) for i, (_, a) in enumerate(rows)], A.runs)
    out = []
    for i, (lab, _) in enumerate(rows):
        s, sh = st[f"tri{i}"], st[f"tri{i}"].get("adaptive_shadows")
        c = json.loads(wt("compare", f"{A.work}/tri{i}.exr", ref, "--json", out=True))
        out.append((lab, f"{SHADOW(s['rays']):,}", f"{s['seconds']:.2f}", f"{c['rmse']:.6f}",
                    f"{sh['refined']:,} of {sh['entered']:,}" if sh else ""))
    table(f"penumbra-triangle.toml ({A.runs} run(s) per row, median seconds)", None,
          ["setting", ">shadow rays", ">seconds", ">RMSE", ">penumbra points"], out)
    st = render_all([(f"bunny_{m}", "scenes/bunny.toml", S(f"objects.0.smooth={m}") + ["-o", f"{A.work}/b.exr"])
                     for m in ("false", "true")], 9, threads=1)
    rows = []
    for lab, key in (("whole render (s)", "seconds"), ("load, normals included (s)", "scene.load_seconds"),
                     ("shade stage (s)", "stages.shade.seconds"), ("scatter stage (s)", "stages.scatter.seconds")):
        f = lambda r: functools.reduce(dict.get, key.split("."), r)
        a, b = (statistics.median(f(r) for r in st[f"bunny_{m}"]["all"]) for m in ("false", "true"))
        rows.append((lab, f"{a:.3f}", f"{b:.3f}", f"{b / a:.2f}"))
    table("bunny.toml, flat against smooth (9 interleaved runs on 1 thread, medians)", None,
          ["", ">flat", ">smooth", ">ratio"], rows)

# ---- docs/adaptive.md ------------------------------------------------------------------
def read_exr(path):
    """wavetrace's EXR output (tiled, one level, FLOAT or HALF channels, no or RLE compression):
    returns width, height and {channel: values, row-major}."""
    b, i, hd = open(path, "rb").read(), 8, {}
    while b[i]:  # the header: name, type, size, value
        j = b.index(0, i); k = b.index(0, j + 1); n, = struct.unpack_from("<i", b, k + 1)
        hd[b[i:j].decode()], i = b[k + 5:k + 5 + n], k + 5 + n
    chans, c, p = [], hd["channels"], 0
    while c[p]:
        q = c.index(0, p); chans.append((c[p:q].decode(), struct.unpack_from("<i", c, q + 1)[0])); p = q + 17
    x0, y0, x1, y1 = struct.unpack("<4i", hd["dataWindow"])
    w, h, (tw, th, _), comp = x1 - x0 + 1, y1 - y0 + 1, struct.unpack("<IIB", hd["tiles"]), hd["compression"][0]
    assert comp in (0, 1), f"{path}: compression {comp}"
    n, = struct.unpack("<i", hd["chunkCount"])
    px = {name: [0.0] * (w * h) for name, _ in chans}
    for off in struct.unpack_from(f"<{n}Q", b, i + 1):
        tx, ty, _, _, size = struct.unpack_from("<5i", b, off)
        d, cw, ch = b[off + 20:off + 20 + size], min(tw, w - tx * tw), min(th, h - ty * th)
        if comp == 1 and size < ch * sum(cw * (2 if t == 1 else 4) for _, t in chans):  # RLE, predictor, halves
            o, k = bytearray(), 0
            while k < len(d):
                r = d[k] - 256 if d[k] > 127 else d[k]
                o += d[k + 1:k + 1 - r] if r < 0 else d[k + 1:k + 2] * (r + 1); k += 1 - r if r < 0 else 2
            o = bytes(itertools.accumulate(o, lambda a, x: (a + x - 128) & 255))
            d = bytearray(len(o)); d[0::2], d[1::2] = o[:(len(o) + 1) // 2], o[(len(o) + 1) // 2:]
        k = 0
        for y in range(ch):
            for name, t in chans:
                row = (ty * th + y) * w + tx * tw
                px[name][row:row + cw] = struct.unpack_from(f"<{cw}{'e' if t == 1 else 'f'}", d, k)
                k += cw * (2 if t == 1 else 4)
    return w, h, px

def differing(a, b, rel=1e-4):
    """The fraction of pixels where images a and b (EXR paths) differ by more than rel (relative)
    in some channel: points the probes misjudged, since everything else is the same sum."""
    (w, h, pa), (_, _, pb) = read_exr(a), read_exr(b)
    return sum(any(abs(pa[c][i] - pb[c][i]) > rel * max(abs(pa[c][i]), abs(pb[c][i]), 1e-6) for c in pa)
               for i in range(w * h)) / (w * h)

TINY_PHONG = lambda *mats: S(*(f"materials.{m}.specular=[1e-4,1e-4,1e-4]" for m in mats))  # lit: sampled
ADS = lambda n, pr: S("render.shadows.mode=adaptive", f"render.shadows.samples={n}", f"render.shadows.probe={pr}")
B = lambda text, bold: f"**{text}**" if bold else text
PROBES = ("corners", "corners+center", "jittered", "3x3")

def adaptive_table(tag, scene, rows, ref_args, head, cells, ref_text):
    """rows: (name, label, args, bold). Renders the reference once and every row A.runs times
    (EXR), compares each with the reference; prints the table. Returns name -> stats."""
    ref = f"{A.work}/{tag}_ref.exr"
    r = render_all([(f"{tag}_ref", scene, ref_args + ["-o", ref])], 1)[f"{tag}_ref"]
    st = render_all([(n, scene, a + ["-o", f"{A.work}/{n}.exr"]) for n, _, a, _ in rows], A.runs)
    for n, *_ in rows:
        c = json.loads(wt("compare", f"{A.work}/{n}.exr", ref, "--json", out=True))
        st[n]["name"], st[n]["rmse"] = n, c["rmse"]
    table(f"{scene} ({A.runs} run(s) per row, median seconds)", None, head,
          [(ours(B(lab, bold), st[n]),) + cells(st[n], bold) for n, lab, _, bold in rows],
          f"Reference: {ref_text}: {mr(r['total_rays'])} M rays, {sec(r['seconds'])} s.")
    return st

def fooled_pixels(tag, scene, uniform, probes, mats):
    """Fooled pixels per probe: adaptive against uniform with the same samples, with a tiny Phong
    term on mats so that lit points sum the same samples instead of the analytic irradiance."""
    ph = TINY_PHONG(*mats)
    jobs = [(f"{tag}_phong_{x}", scene, ph + a + ["-o", f"{A.work}/{tag}_phong_{x}.exr"])
            for x, a in [("uniform", uniform)] + [(pr, a) for pr, a in probes]]
    render_all(jobs, 1)
    u = f"{A.work}/{tag}_phong_uniform.exr"
    return {pr: differing(f"{A.work}/{tag}_phong_{pr}.exr", u) for pr, _ in probes}

def adaptive():
    img = lambda kind, name: ["--heatmap", f"{kind}={A.work}/images/{name}.png"]
    # edges.toml: adaptive anti-aliasing
    AD, sc = S("render.aa.mode=adaptive"), "scenes/edges.toml"
    rows = [(f"edges_u{n}", f"uniform {n} spp", UAA(n), 0) for n in (4, 16, 64)] + [
        ("edges_ml2", "adaptive, eps 0.01, max_level 6, **min_level 2 (the paper's rule)**",
         AD + S("render.aa.min_level=2"), 0),
        ("edges_ml2_own", "same, corners not shared (the paper's 5 rays per pixel)",
         AD + S("render.aa.min_level=2", "render.aa.share_corners=false"), 0),
        ("edges_eps0.003", "adaptive, eps 0.003 (min_level 4, default)", AD + S("render.aa.eps=0.003"), 0),
        ("edges_eps0.01", "adaptive, eps 0.01 (defaults: min_level 4, max_level 6)",
         AD + img("aa", "edges_heat_aa") + img("rays", "edges_heat_rays"), 1),
        ("edges_eps0.03", "adaptive, eps 0.03", AD + S("render.aa.eps=0.03"), 0),
        ("edges_own", "adaptive, eps 0.01, corners not shared", AD + S("render.aa.share_corners=false"), 0)]
    st = adaptive_table("edges", sc, rows, UAA(1024), ["setting", ">total rays", ">camera-level rays",
                        ">seconds", ">RMSE"], lambda s, b: (B(f"{s['total_rays']:,}", b),
                        B(f"{CAMERA(s['rays']):,}", b), f"{s['seconds']:.3f}", B(f"{s['rmse']:.6f}", b)),
                        "uniform, 1024 samples per pixel")
    print("\n".join(f"- {n}: {s['adaptive_aa']['refined']:,} pixels refined "
                    f"({s['adaptive_aa']['refined'] / s['adaptive_aa']['entered']:.1%})"
                    for n, s in st.items() if "adaptive_aa" in s))
    # min_level 2: where refined pixels stop, from the same render cut at max_level 2..5
    lv = render_all([(f"edges_ml2_max{m}", sc, AD + S("render.aa.min_level=2", f"render.aa.max_level={m}"))
                     for m in range(2, 6)], 1)
    rf = [lv[f"edges_ml2_max{m}"]["rays"]["aa_refine"] for m in range(2, 6)] + [st["edges_ml2"]["rays"]["aa_refine"]]
    cast = [st["edges_ml2"]["adaptive_aa"]["refined"]] + [(b - a) >> m  # pixels that cast level m
                                                          for m, (a, b) in enumerate(zip(rf, rf[1:]), 3)]
    assert rf[0] == 4 * cast[0], "levels 2..5 must make the same decisions"
    print("- min_level 2, refined pixels that stopped after level 2 (4 samples), 3 (12), 4 (28), 5 (60), "
          "ran to 6 (124): " + ", ".join(f"{(a - b) / cast[0]:.1%}" for a, b in zip(cast, cast[1:] + [0])) + "\n")
    # penumbra.toml: adaptive soft shadows
    sc, US = "scenes/penumbra.toml", lambda n: S(f"render.shadows.samples={n}")
    rows = [(f"pen_u{n}", f"uniform {n}", US(n), 0) for n in (16, 64, 128)] + [
        (f"pen_{pr}", f"adaptive 128, probe `{pr}`" + (" (the paper's)" if pr == "corners" else " (default)"
         if pr == "3x3" else ""), ADS(128, pr) + (img("penumbra", "pen_heat") if pr == "3x3" else []), pr == "3x3")
        for pr in PROBES] + [("pen_3x3_64", "adaptive 64, probe `3x3`", ADS(64, "3x3"), 0)]
    pts = lambda s: f"{s['adaptive_shadows']['refined']:,} of {s['adaptive_shadows']['entered']:,}" \
        if s.get("adaptive_shadows") else ""
    adaptive_table("pen", sc, rows, US(1024), ["setting", ">shadow rays", ">seconds", ">RMSE", ">penumbra points"],
                   lambda s, b: (B(f"{SHADOW(s['rays']):,}", b), f"{s['seconds']:.3f}", B(f"{s['rmse']:.6f}", b),
                                 pts(s)), "uniform shadows, 1024 samples, the same camera samples")
    fp = fooled_pixels("pen", sc, US(128), [(pr, ADS(128, pr)) for pr in PROBES], ("floor", "block"))
    print("- fooled pixels, adaptive 128 against uniform 128: " +
          ", ".join(f"{pr} {f:.2%}" for pr, f in fp.items()) + "\n")
    # fooled.toml: the paper's failure
    sc, probe = "scenes/fooled.toml", lambda p: S(f"render.shadows.probe={p}")
    UF = S("render.shadows.mode=uniform")
    fp = fooled_pixels("fooled", sc, UF, [(p, probe(p)) for p in PROBES], ("white",))
    rows = [("fooled_u64", "uniform 64", UF, 0)] + [(f"fooled_{p}", f"adaptive, `{p}`", probe(p), 0) for p in PROBES]
    adaptive_table("fooled", sc, rows, UF + S("render.shadows.samples=1024"), ["setting", ">shadow rays",
                   ">seconds", ">RMSE", ">penumbra points", ">fooled pixels"],
                   lambda s, b: (f"{SHADOW(s['rays']):,}", f"{s['seconds']:.3f}", f"{s['rmse']:.6f}", pts(s),
                                 "" if not s.get("adaptive_shadows") else
                                 f"{fp[s['name'].removeprefix('fooled_')]:.1%}"), "uniform shadows, 1024 samples")
    render_all([("fooled_uniform", sc, UF), ("fooled_corners", sc, probe("corners") +
                img("penumbra", "fooled_heat_corners"))], 1)  # the page's images, in WORK/images

def main():
    global A
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["paper", "tradeoffs", "import", "adaptive", "all"])
    ap.add_argument("--wavetrace", default=os.environ.get("WAVETRACE", "target/release/wavetrace"))
    ap.add_argument("--work", default="/tmp/paper-tables")
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--res")
    A, t0 = ap.parse_args(), time.time()
    os.makedirs(f"{A.work}/images", exist_ok=True)
    print("```sh\n" + shlex.join(["scripts/paper-tables.py"] + sys.argv[1:]) + "\n```\n")
    for f in [paper, tradeoffs, import_, adaptive]:
        if A.what in ("all", f.__name__.rstrip("_")):
            f()
    print(f"({A.what}: {time.time() - t0:.0f} s)", file=sys.stderr)

if __name__ == "__main__":
    main()
