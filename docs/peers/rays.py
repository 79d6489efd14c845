#!/usr/bin/env python3
"""Ray queries alone, Lucent's BVH against Embree's (through Mitsuba 3's llvm_ad_rgb), on the
same rays in the Cornell box: how much of Mitsuba's lead is traversal.

  $PEERS_VENV/bin/python docs/peers/rays.py gen OUT_DIR   # camera.bin, bounce.bin, shadow.bin
  cargo run --release --example rays -- OUT_DIR [--runs 5] [--threads 2]
  $PEERS_VENV/bin/python docs/peers/rays.py mitsuba OUT_DIR [--runs 5] [--threads 2]
  $PEERS_VENV/bin/python docs/peers/rays.py compare OUT_DIR

$PEERS_VENV is the Python that ../shared/peers/setup.sh sets up (numpy, Mitsuba 3); the
Mitsuba scene is read from $PEERS, by default the shared/peers folder beside the repository.

Each .bin (and .centred.bin, the same rays in Lucent's centred frame) holds little-endian
float32 records (ox, oy, oz, dx, dy, dz, tmax), one per ray, from a fixed seed:
- camera: 2^20 rays of the box's camera through uniformly jittered points of a 256x256
  film (coherent, as the first segment of every path);
- bounce: 2^20 rays from points uniform in the box's inside, directions uniform on the
  sphere (incoherent, as later segments; a point inside a block sees its inside);
- shadow: 2^20 occlusion queries from the same points to uniform points on the light,
  stopping 1e-3 of the distance short of it.
Both programs print the median over runs of the machine time per ray (wall time x threads
/ rays) and write their answers (hit distances, occlusion flags) beside the rays, and
`compare` counts the rays on which they disagree, to show that both traced the same scene.
"""
import argparse
import json
import os
import statistics
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
COUNT = 1 << 20
# The box's inside, its camera and its light (shared/scenes/cornell-box.gltf).
INSIDE = (np.array([0.0, 0.0, 0.0]), np.array([0.5496, 0.5483, 0.5592]))
CAMERA = np.array([0.278, 0.273, -0.8])
FOV_Y = np.radians(39.307648116)
# Lucent keeps a glTF scene relative to the centre of its meshes' bounds (src/loader/gltf.rs),
# so its rays are written again with their origins moved by that centre (in float64, then
# rounded once, as the absolute rays are).
CENTRE = 0.5 * np.array([0.556, 0.5488, 0.5592], dtype=np.float32).astype(np.float64)
LIGHT = (np.array([0.213, 0.5483, 0.227]), np.array([0.343, 0.5483, 0.332]))


def unit(v):
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def generate(out):
    rng = np.random.default_rng(15)
    # Camera: looking down +z, +x to the image's left (the glTF camera turned by the Mitsuba
    # scene's diag(-1, 1, -1)); film coordinates in [-1, 1]^2, y up.
    film = rng.uniform(-1.0, 1.0, (COUNT, 2))
    half = np.tan(FOV_Y / 2)
    d = unit(np.stack([-film[:, 0] * half, -film[:, 1] * half, np.ones(COUNT)], axis=1))
    camera = np.hstack([np.tile(CAMERA, (COUNT, 1)), d, np.full((COUNT, 1), np.inf)])
    lo, hi = INSIDE
    o = lo + rng.uniform(0.001, 0.999, (COUNT, 3)) * (hi - lo)
    bounce = np.hstack([o, unit(rng.normal(size=(COUNT, 3))), np.full((COUNT, 1), np.inf)])
    target = LIGHT[0] + rng.uniform(0.0, 1.0, (COUNT, 3)) * (LIGHT[1] - LIGHT[0])
    to = target - o
    dist = np.linalg.norm(to, axis=1, keepdims=True)
    shadow = np.hstack([o, to / dist, dist * (1 - 1e-3)])
    os.makedirs(out, exist_ok=True)
    for name, rays in (("camera", camera), ("bounce", bounce), ("shadow", shadow)):
        rays.astype("<f4").tofile(os.path.join(out, f"{name}.bin"))
        centred = rays.copy()
        centred[:, :3] -= CENTRE
        centred.astype("<f4").tofile(os.path.join(out, f"{name}.centred.bin"))
    print(f"wrote {COUNT} rays each to {out}/camera.bin, bounce.bin, shadow.bin (and .centred.bin)")


def load(out, name):
    return np.fromfile(os.path.join(out, f"{name}.bin"), dtype="<f4").reshape(-1, 7)


def mitsuba(out, runs, threads):
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    dr.set_thread_count(threads)
    scene = mi.load_file(os.path.join(os.environ.get("PEERS", os.path.join(HERE, "..", "..", "..", "shared", "peers")),
                                      "cbox_mitsuba.xml"))
    results = {}
    for name in ("camera", "bounce", "shadow"):
        r = load(out, name)
        tmax = np.where(np.isinf(r[:, 6]), np.float32(np.finfo(np.float32).max), r[:, 6])
        ray = mi.Ray3f(mi.Point3f(*(mi.Float(np.ascontiguousarray(r[:, i])) for i in range(3))),
                       mi.Vector3f(*(mi.Float(np.ascontiguousarray(r[:, i])) for i in range(3, 6))),
                       mi.Float(np.ascontiguousarray(tmax)), 0.0, [])
        dr.eval(ray)

        def query(coherent=False):
            if name == "shadow":
                hit = scene.ray_test(ray)
                dr.eval(hit)
                return hit
            pi = scene.ray_intersect_preliminary(ray, coherent=coherent)
            dr.eval(pi.t)
            return pi.t

        def median(coherent=False):
            query(coherent)  # JIT compilation, not timed
            times = []
            for _ in range(runs):
                dr.sync_thread()
                start = time.perf_counter()
                query(coherent)
                dr.sync_thread()
                times.append(time.perf_counter() - start)
            return statistics.median(times) * threads / len(r) * 1e9

        if name == "camera":
            # Embree's coherent mode (what `coherent=True` asks for) took twice the time of
            # its single-ray mode on these rays; Mitsuba's own renders cost less per
            # sample at max depth 1 than the coherent query alone, so the faster is timed.
            results["camera-coherent"] = median(coherent=True)
        results[name] = median()
        answer = query()
        answer = np.array(answer, dtype=np.float32 if name != "shadow" else np.uint8)
        if name != "shadow":
            answer = np.where(np.isfinite(answer) & (answer < 1e30), answer, np.inf).astype(np.float32)
        path = os.path.join(out, f"{name}.mitsuba")
        answer.tofile(path + ".tmp")
        os.replace(path + ".tmp", path)
        print(f"{name}: {results[name]:.1f} ns machine time per ray (Embree via Mitsuba "
              f"{mi.__version__} llvm_ad_rgb, {threads} threads, median of {runs})")
    print(json.dumps({"renderer": "mitsuba", "ns_per_ray": results}))


def compare(out):
    for name in ("camera", "bounce", "shadow"):
        a = np.fromfile(os.path.join(out, f"{name}.lucent"), dtype=np.float32 if name != "shadow" else np.uint8)
        b = np.fromfile(os.path.join(out, f"{name}.mitsuba"), dtype=np.float32 if name != "shadow" else np.uint8)
        if name == "shadow":
            differ = int(np.count_nonzero(a != b))
        else:
            both = np.isfinite(a) & np.isfinite(b)
            differ = int(np.count_nonzero(np.isfinite(a) != np.isfinite(b)))
            differ += int(np.count_nonzero(np.abs(a[both] - b[both]) > 1e-4 * np.maximum(1.0, b[both])))
        print(f"{name}: {differ} of {len(a)} rays answered differently")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["gen", "mitsuba", "compare"])
    ap.add_argument("out")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    if args.what == "gen":
        generate(args.out)
    elif args.what == "mitsuba":
        mitsuba(args.out, args.runs, args.threads)
    else:
        compare(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
