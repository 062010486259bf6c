#!/usr/bin/env python3
"""Side-by-side speed comparison: ltcguide (pt, NEE on) vs Mitsuba 3 llvm_ad_rgb (path).

Both render the same pack scene at the same resolution, spp and max_depth on the
same machine, one after the other, and report paths/s (pixels x spp / render
seconds). Mitsuba's render is timed after a warm-up render, so its LLVM JIT
compilation and scene loading are excluded; ltcguide's stats exclude loading too.

Needs: pip install mitsuba; Debian's libllvm19 (apt-get install libllvm19).
Usage: scripts/mitsuba_speed.py [--spp 64] [--threads 2] SCENE_DIR...
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time


def mitsuba_paths_per_second(scene_xml, spp, threads):
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    import drjit as dr
    dr.set_thread_count(threads)
    scene = mi.load_file(scene_xml)
    sensor = scene.sensors()[0]
    size = sensor.film().crop_size()
    # Warm-up: compiles the kernels for this scene.
    img = mi.render(scene, spp=spp, seed=1000)
    dr.eval(img)
    dr.sync_thread()
    t0 = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=0)
    dr.eval(img)
    dr.sync_thread()
    seconds = time.perf_counter() - t0
    return size[0] * size[1] * spp / seconds, seconds


def ltcguide_paths_per_second(binary, scene_xml, spp, threads):
    with tempfile.TemporaryDirectory() as d:
        stats = os.path.join(d, "stats.json")
        subprocess.run([binary, "render", scene_xml, "--spp", str(spp), "--threads", str(threads),
                        "--nee", "--out", os.path.join(d, "x.exr"), "--stats-json", stats],
                       check=True, stderr=subprocess.DEVNULL)
        s = json.load(open(stats))
        return s["paths_per_second"], s["seconds"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--binary", default="target/release/ltcguide")
    args = ap.parse_args()
    print("| scene | spp | ltcguide paths/s | mitsuba llvm_ad_rgb paths/s | ratio (ours / mitsuba) |")
    print("|---|---|---|---|---|")
    for d in args.scenes:
        xml = os.path.join(d, "scene.xml")
        ours, ts = ltcguide_paths_per_second(args.binary, xml, args.spp, args.threads)
        theirs, tm = mitsuba_paths_per_second(xml, args.spp, args.threads)
        print(f"| {os.path.basename(d.rstrip('/'))} | {args.spp} | {ours:,.0f} ({ts:.2f} s) | "
              f"{theirs:,.0f} ({tm:.2f} s) | {ours / theirs:.2f} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
