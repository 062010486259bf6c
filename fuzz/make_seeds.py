#!/usr/bin/env python3
"""Writes the seed corpus of the scene_loader target to the folder given
(default: fuzz/seeds/scene_loader). Each seed is `XML \\0 OBJ`: the pack and
test scenes with every mesh `filename` pointed at the harness's `mesh.obj`
and every image at its `tex.png` / `tex.exr`, crossed with small OBJ
snippets. Run it from anywhere; it needs ../shared/scenes next to the repo
or SCENES=path."""

import os
import re
import sys
from pathlib import Path

fuzz = Path(__file__).resolve().parent
repo = fuzz.parent
scenes = Path(os.environ.get("SCENES", repo.parent / "shared" / "scenes"))
out = Path(sys.argv[1]) if len(sys.argv) > 1 else fuzz / "seeds" / "scene_loader"
out.mkdir(parents=True, exist_ok=True)


def retarget(xml: str) -> str:
    def sub(m):
        value = m.group(2)
        if value.lower().endswith(".obj"):
            value = "mesh.obj"
        elif value.lower().endswith(".exr"):
            value = "tex.exr"
        else:
            value = "tex.png"
        return m.group(1) + value + '"'

    return re.sub(r'(name="filename"\s+value=")([^"]*)"', sub, xml)


xmls = []
for p in sorted(scenes.glob("*/scene.xml")):
    xmls.append((p.parent.name, p.read_text()))
for p in sorted((repo / "scenes").glob("*/scene.xml")):
    xmls.append((p.parent.name, p.read_text()))
for kind in ("ok", "bad", "analytic"):
    for p in sorted((repo / "tests" / "data" / kind).glob("*.xml")):
        xmls.append((f"{kind}-{p.stem}", p.read_text()))

objs = {
    "none": "",
    "quad": (repo / "tests/data/ok/quad.obj").read_text(),
    "tri": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    "full": "o a\ng b\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
    "vt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\n"
    "f 1/1/1 2/2/2 3/3/3\nf -3/-3/-3 -1/-1/-1 -2/-2/-2\n",
    "vn-only": "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n",
    "mtllib": "mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    "degenerate": (repo / "tests/data/bad/degenerate.obj").read_text(),
    "nan": (repo / "tests/data/bad/nan.obj").read_text(),
    "out-of-range": (repo / "tests/data/bad/out_of_range.obj").read_text(),
}
painting = scenes / "living-room/meshes/Painting.obj"
if painting.exists():
    objs["painting"] = painting.read_text()

n = 0
for name, xml in xmls:
    xml = retarget(xml)
    uses_mesh = "mesh.obj" in xml
    for oname, obj in objs.items():
        # Scenes without a mesh get one seed; the OBJ part is unreachable.
        if not uses_mesh and oname != "none":
            continue
        (out / f"{name}--{oname}").write_bytes(xml.encode() + b"\0" + obj.encode())
        n += 1
print(f"{n} seeds in {out}")
