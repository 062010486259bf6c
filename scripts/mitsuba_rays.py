#!/usr/bin/env python3
"""Per-ray traversal speed on identical rays: ltcguide's BVH vs Mitsuba 3 llvm_ad_rgb (Embree).

`mitsuba_speed.py` compares whole renders; this isolates the ray queries. Mitsuba draws the
rays: camera rays through random film points, then one cosine-distributed bounce from each
hit (the camera ray itself where it misses), the incoherent secondary rays a path tracer
traces. Both renderers then answer the same rays on one thread:
- closest hit: Mitsuba's `ray_intersect_preliminary` (Embree's closest hit, no surface
  interaction), ltcguide's `Accel::closest_hit`;
- occlusion of the first OCCLUSION_FRACTION of the scene's bounding-box diagonal along each
  ray: `ray_test` and `Accel::occluded`.
Rounds alternate the two renderers and the summary is the median of the per-round ratios, as
in `mitsuba_speed.py`. Mitsuba's first pass compiles its kernels and is not timed. The
`agree` column is the share of rays whose closest-hit distance matches Mitsuba's (1e-3
relative), which checks that both renderers read the scene and the rays alike.

Needs: pip install mitsuba; Debian's libllvm19.
Usage: scripts/mitsuba_rays.py [--rays 1048576] [--repeat 3] SCENE_DIR...
"""
import argparse
import array
import os
import statistics
import struct
import subprocess
import sys
import tempfile
import time

OCCLUSION_FRACTION = 0.1


def mitsuba_rays(mi, dr, scene, n):
    rng = mi.PCG32(size=n)
    sensor = scene.sensors()[0]
    film_pos = mi.Point2f(rng.next_float32(), rng.next_float32())
    ray, _ = sensor.sample_ray(0.0, 0.5, film_pos, mi.Point2f(0.5, 0.5))
    si = scene.ray_intersect(ray)
    local = mi.warp.square_to_cosine_hemisphere(mi.Point2f(rng.next_float32(), rng.next_float32()))
    n_facing = dr.select(dr.dot(si.n, ray.d) < 0, si.n, -si.n)
    bounce = si.spawn_ray(mi.Frame3f(n_facing).to_world(local))
    o = dr.select(si.is_valid(), bounce.o, ray.o)
    d = dr.select(si.is_valid(), bounce.d, ray.d)
    dr.eval(o, d)
    return o, d


def best_seconds(dr, f, repeat):
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        r = f()
        dr.eval(r)
        dr.sync_thread()
        best = min(best, time.perf_counter() - t0)
    return best


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--rays", type=int, default=1 << 20)
    ap.add_argument("--repeat", type=int, default=3, help="alternating rounds per scene")
    ap.add_argument("--passes", type=int, default=5, help="timed passes per round (best kept)")
    args = ap.parse_args()
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    subprocess.run(["cargo", "build", "--release", "--quiet", "--example", "ray_file_timing"],
                   cwd=root, check=True)
    example = os.path.join(root, "target", "release", "examples", "ray_file_timing")

    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    import drjit as dr
    threads = dr.thread_count()

    print("| scene | round | ltcguide closest Mrays/s | Embree closest | ratio | "
          "ltcguide occluded | Embree occluded | ratio | agree |")
    print("|---|---|---|---|---|---|---|---|---|")
    summary = []
    for scene_dir in args.scenes:
        name = os.path.basename(os.path.normpath(scene_dir))
        xml = os.path.join(scene_dir, "scene.xml")
        # Loading runs nested parallel tasks, which deadlock on a pool of
        # one thread (living-room): load on the full pool, time on one.
        dr.set_thread_count(threads)
        scene = mi.load_file(xml)
        dr.set_thread_count(1)
        o, d = mitsuba_rays(mi, dr, scene, args.rays)
        bbox = scene.bbox()
        tmax = OCCLUSION_FRACTION * dr.norm(bbox.max - bbox.min)
        tmax = float(tmax[0] if hasattr(tmax, "__len__") else tmax)
        closest = mi.Ray3f(o, d)
        shadow = mi.Ray3f(o, d, tmax)
        their_t = scene.ray_intersect_preliminary(closest).t
        dr.eval(their_t)
        ratios = ([], [])
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "rays.bin")
            with open(path, "wb") as f:
                f.write(b"LTCRAYS1" + struct.pack("<If", args.rays, tmax))
                for plane in (o.x, o.y, o.z, d.x, d.y, d.z, their_t):
                    array.array("f", list(plane)).tofile(f)
            for rnd in range(1, args.repeat + 1):
                t_c = best_seconds(dr, lambda: scene.ray_intersect_preliminary(closest).t, args.passes)
                t_o = best_seconds(dr, lambda: scene.ray_test(shadow), args.passes)
                out = subprocess.run([example, xml, path, str(args.passes)], check=True,
                                     capture_output=True, text=True).stdout
                ours = dict(kv.split("=") for kv in out.split())
                mc, mo = args.rays / t_c / 1e6, args.rays / t_o / 1e6
                oc, oo = float(ours["closest_per_s"]) / 1e6, float(ours["occluded_per_s"]) / 1e6
                ratios[0].append(oc / mc)
                ratios[1].append(oo / mo)
                print(f"| {name} | {rnd} | {oc:.2f} | {mc:.2f} | {oc / mc:.2f} | {oo:.2f} | {mo:.2f} "
                      f"| {oo / mo:.2f} | {float(ours['agree']):.4f} |", flush=True)
        summary.append((name, statistics.median(ratios[0]), statistics.median(ratios[1])))
    print("\n| scene | closest hit: median ratio (ours / Embree) | occlusion: median ratio |")
    print("|---|---|---|")
    for name, c, o in summary:
        print(f"| {name} | {c:.2f} | {o:.2f} |")


if __name__ == "__main__":
    sys.exit(main())
