#!/usr/bin/env python3
"""Side-by-side speed comparison: ltcguide (pt, NEE on) vs Mitsuba 3 llvm_ad_rgb (path).

Both render the same pack scene at the same resolution, spp and max_depth on the
same machine and report paths/s (pixels x spp / render seconds).

Fairness:
- Mitsuba's scene is loaded and rendered once untimed per scene, so its LLVM JIT
  compilation is excluded; the timed renders use other seeds, which reuse the
  compiled kernels (the seed is an opaque JIT value). ltcguide's stats exclude
  scene loading (BVH build) likewise.
- Both use the scene's max_depth (checked from Mitsuba's integrator and
  ltcguide's stats), Russian roulette from depth 5 with Mitsuba's rule, and NEE
  with MIS (Mitsuba's `path` always samples emitters).
- On a shared machine load drifts, so each round times ltcguide and Mitsuba back
  to back and the ratio is taken per round; the summary is the median ratio.

Needs: pip install mitsuba; Debian's libllvm19 (apt-get install libllvm19).
Usage: scripts/mitsuba_speed.py [--spp 64] [--threads 2] [--repeat 3] [--baseline BIN] SCENE_DIR...
(--baseline: also time another ltcguide build in every round, e.g. before a change.)
"""
import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time


class Mitsuba:
    def __init__(self, threads):
        import mitsuba as mi
        mi.set_variant("llvm_ad_rgb")
        import drjit as dr
        dr.set_thread_count(threads)
        self.mi, self.dr = mi, dr

    def load(self, scene_xml, spp):
        self.scene = self.mi.load_file(scene_xml)
        m = re.search(r"max_depth = (-?\d+)", str(self.scene.integrator()))
        self.max_depth = int(m.group(1)) if m else None
        # Warm-up: compiles the kernels for this scene, spp and film.
        self.render(spp, seed=1000)

    def render(self, spp, seed):
        mi, dr = self.mi, self.dr
        size = self.scene.sensors()[0].film().crop_size()
        t0 = time.perf_counter()
        img = mi.render(self.scene, spp=spp, seed=seed)
        dr.eval(img)
        dr.sync_thread()
        seconds = time.perf_counter() - t0
        return size[0] * size[1] * spp / seconds, seconds


def ltcguide_render(binary, scene_xml, spp, threads, seed):
    with tempfile.TemporaryDirectory() as d:
        stats = os.path.join(d, "stats.json")
        subprocess.run([binary, "render", scene_xml, "--spp", str(spp), "--threads", str(threads),
                        "--nee", "--seed", str(seed), "--out", os.path.join(d, "x.exr"),
                        "--stats-json", stats],
                       check=True, stderr=subprocess.DEVNULL)
        s = json.load(open(stats))
        return s["paths_per_second"], s["seconds"], s["max_depth"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3, help="interleaved rounds per scene")
    ap.add_argument("--binary", default="target/release/ltcguide")
    ap.add_argument("--baseline", help="another ltcguide binary timed in every round")
    args = ap.parse_args()
    mitsuba = Mitsuba(args.threads)
    base_cols = " baseline paths/s | baseline / mitsuba |" if args.baseline else ""
    print("| scene | spp | round | ltcguide paths/s | mitsuba llvm_ad_rgb paths/s | "
          "ratio (ours / mitsuba) |" + base_cols)
    print("|---|---|---|---|---|---|" + ("---|---|" if args.baseline else ""))
    summary = []
    for d in args.scenes:
        name = os.path.basename(d.rstrip("/"))
        xml = os.path.join(d, "scene.xml")
        mitsuba.load(xml, args.spp)
        ratios = []
        for r in range(args.repeat):
            ours, ts, depth = ltcguide_render(args.binary, xml, args.spp, args.threads, seed=r)
            if mitsuba.max_depth is not None and depth != mitsuba.max_depth:
                sys.exit(f"{name}: max_depth differs (ours {depth}, mitsuba {mitsuba.max_depth})")
            theirs, tm = mitsuba.render(args.spp, seed=r)
            ratios.append(ours / theirs)
            extra = ""
            if args.baseline:
                base, tb, _ = ltcguide_render(args.baseline, xml, args.spp, args.threads, seed=r)
                extra = f" {base:,.0f} ({tb:.2f} s) | {base / theirs:.2f} |"
            print(f"| {name} | {args.spp} | {r + 1} | {ours:,.0f} ({ts:.2f} s) | "
                  f"{theirs:,.0f} ({tm:.2f} s) | {ours / theirs:.2f} |{extra}", flush=True)
        summary.append((name, statistics.median(ratios), min(ratios), max(ratios)))
    print()
    print("| scene | median ratio | min | max |")
    print("|---|---|---|---|")
    for name, med, lo, hi in summary:
        print(f"| {name} | {med:.2f} | {lo:.2f} | {hi:.2f} |")


if __name__ == "__main__":
    sys.exit(main())
