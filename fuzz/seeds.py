#!/usr/bin/env python3
"""Writes the seed corpus of every fuzz target into fuzz/seeds/<target>/ (not committed:
the fuzzers start from it, and what they keep, minimised, is fuzz/corpus/<target>/).

Seeds: the project's scenes (scenes/, scenes/paper/, scenes/import/) with the small mesh
and include files they name, its small meshes, images the renderer writes (PNG, EXR, a
tile), and the hostile cases of tests/fuzz/ (a mesh that is a device, NaN and overflowing
values, include cycles, DTD entities).

    python3 fuzz/seeds.py [path/to/wavetrace]     # default target/release/wavetrace
"""
import pathlib
import re
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT = ROOT / "fuzz" / "seeds"
SMALL = 64 << 10
TINY = ["render.width=4", "render.height=4", "render.aa.samples=1", "render.shadows.samples=1"]


def bundle(main: bytes, files=(), args=()) -> bytes:
    """The fuzz crate's Bundle format (fuzz/src/lib.rs)."""
    out = main
    for name, body in files:
        out += b"\n=== file " + name.encode() + b"\n" + body
    if args:
        out += b"\n=== args\n" + "\n".join(args).encode()
    return out


def put(target: str, name: str, data: bytes):
    d = OUT / target
    d.mkdir(parents=True, exist_ok=True)
    (d / name).write_bytes(data)


def named_files(scene: pathlib.Path, text: str):
    """The small files a scene names (meshes, includes), relative to it, recursively."""
    found = {}
    for name in re.findall(r'(?:file|filename)\s*(?:=|value=)\s*"([^"]+)"', text):
        path = scene.parent / name
        if ".." in name or not path.is_file() or path.stat().st_size > SMALL:
            continue
        body = path.read_bytes()
        found[name] = body
        if name.endswith(".xml"):
            for sub, b in named_files(path, body.decode(errors="replace")).items():
                found[str(pathlib.PurePosixPath(name).parent / sub)] = b
    return found


def scenes():
    for path in sorted(ROOT.glob("scenes/**/*.toml")) + sorted(ROOT.glob("scenes/**/*.xml")):
        text = path.read_text()
        target = "mitsuba_xml" if path.suffix == ".xml" else "scene_toml"
        files = sorted(named_files(path, text).items())
        args = [] if target == "mitsuba_xml" else TINY
        put(target, path.stem + "-" + path.parent.name, bundle(text.encode(), files, args))


def hostile():
    default = (ROOT / "scenes" / "default.toml").read_bytes()
    mesh = b'\n[[objects]]\ntype = "mesh"\nfile = "%s"\nmaterial = "white"\n'
    tri = b"v 0 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n"
    cases = {
        "mesh-device": bundle(default + mesh % b"/dev/zero", (), TINY),
        "mesh-overflow": bundle(default + mesh % b"m.obj" + b"scale = 1e38\n", [("m.obj", tri * 3)], TINY),
        "nan-camera": bundle(default.replace(b"fov_y = 40.0", b"fov_y = nan"), (), TINY),
        "huge-look": bundle(default.replace(b"look_at = [0, 1, 0]", b"look_at = [3e38, -3e38, 0]"), (), TINY),
        "sets": bundle(default, (), TINY + ["objects.99.radius=1", "camera.position.9=1", "render.aa.mode=adaptive",
                                           "render.aa.max_level=40", "render=1", "a..b=2"]),
        "deep": bundle(b"a = " + b"[" * 200 + b"]" * 200 + b"\n"),
    }
    for name, data in cases.items():
        put("scene_toml", name, data)
    xml = {
        "cycle": bundle(b'<scene version="3.0.0"><include filename="a.xml"/></scene>',
                        [("a.xml", b'<scene version="3.0.0"><include filename="a.xml"/></scene>')]),
        "dtd": bundle(b'<?xml version="1.0"?><!DOCTYPE s [<!ENTITY a "aaaa">]><scene version="3.0.0">&a;</scene>'),
        "undefined-param": bundle(b'<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="$f"/></sensor></scene>',
                                  (), ["f=45"]),
    }
    for name, data in xml.items():
        put("mitsuba_xml", name, data)
    put("obj", "overflow-index", b"\x00" + b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/99999999999 2/1 3/1\n")
    put("ply", "huge-count", b"\x00ply\nformat ascii 1.0\nelement vertex 18446744073709551615\nproperty float x\nend_header\n")


def meshes():
    for path in sorted(ROOT.glob("scenes/import/meshes/*")):
        target = "ply" if path.suffix == ".ply" else "obj"
        for smooth in (0, 1):
            put(target, f"{path.stem}-{smooth}", bytes([smooth]) + path.read_bytes())
    cube = b"".join(b"v %d %d %d\n" % (x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1))
    cube += b"vn 0 0 1\nvt 0 0\nf 1/1/1 2/1/1 4/1/1 3/1/1\nf 5 6 8 7\nf 1 2 6 5\no second\ng grp\ns 1\nusemtl x\nf -1 -2 -3\n"
    put("obj", "cube", b"\x01" + cube)
    ascii_ply = (b"ply\nformat ascii 1.0\ncomment c\nelement vertex 3\nproperty float x\nproperty float y\n"
                 b"property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                 b"element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                 b"0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n")
    put("ply", "ascii-normals", b"\x01" + ascii_ply)


def images(binary: str):
    with tempfile.TemporaryDirectory() as d:
        d = pathlib.Path(d)
        base = [binary, "--quiet"] + [a for s in TINY for a in ("--set", s)]
        subprocess.run(base + ["-o", str(d / "a.png")], check=True)
        subprocess.run(base + ["-o", str(d / "a.exr")], check=True)
        subprocess.run(base + ["--crop", "0,2,0,4", "-o", str(d / "t.exr")], check=True)
        subprocess.run(base + ["--crop", "0,4,0,4", "-o", str(d / "full.exr")], check=True)
        put("image", "png", b"\x00" + (d / "a.png").read_bytes())
        put("image", "exr", b"\x01" + (d / "a.exr").read_bytes())
        put("image", "tile", b"\x02" + (d / "t.exr").read_bytes())
        put("image", "tile-as-exr", b"\x01" + (d / "t.exr").read_bytes())
        put("image", "tile-full", b"\x02" + (d / "full.exr").read_bytes())


if __name__ == "__main__":
    scenes()
    hostile()
    meshes()
    images(sys.argv[1] if len(sys.argv) > 1 else str(ROOT / "target" / "release" / "wavetrace"))
    for d in sorted(OUT.iterdir()):
        print(f"{d.name}: {len(list(d.iterdir()))} seeds")
