#!/usr/bin/env python3
"""The point-light caustic (docs/scenes/caustic.gltf) against Mitsuba 3's light tracer.

  $PEERS_VENV/bin/python docs/peers/caustic.py LUCENT.exr [--spp 256] [--passes 16]

LUCENT.exr: a 128x128 render of docs/scenes/caustic.gltf by BDPT, e.g.
`lucent render docs/scenes/caustic.gltf --integrator bdpt --width 128 --height 128
--max-depth 10 --time 240 --out LUCENT.exr`. Mitsuba's `ptracer` renders docs/peers/caustic.xml
(max depth 11: its count includes the camera ray) with a Lambertian grey, and the mean
luminance of a few windows is compared: the caustic (the brightest 6x6 pixels of the floor
in Lucent's image, and 16x10 around them), the directly lit floor on both sides, the wall.
Equal ratios in the caustic and outside it say the caustic carries the energy the light
tracer gives it. Mitsuba is installed by ../shared/peers/setup.sh; no test depends on it.
"""
import argparse
import os

import numpy as np
import mitsuba as mi


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("lucent")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--passes", type=int, default=16)
    args = ap.parse_args()
    mi.set_variant("llvm_ad_rgb")
    xml = os.path.join(os.path.dirname(os.path.abspath(__file__)), "caustic.xml")
    scene = mi.load_file(xml, floor="grey", res=128, spp=args.spp)
    ptracer = sum(np.array(mi.render(scene, seed=k)) for k in range(args.passes)) / args.passes
    lum = lambda a: np.asarray(a)[..., :3].mean(axis=2)
    m, r = lum(ptracer), lum(mi.Bitmap(args.lucent))
    _, y, x = max((r[y:y + 6, x:x + 6].mean(), y, x) for y in range(64, 122) for x in range(0, 122))
    windows = {
        "caustic, 6x6": (y, y + 6, x, x + 6),
        "caustic, 16x10": (y - 2, y + 8, x - 5, x + 11),
        "floor, left": (100, 120, 5, 30),
        "floor, right": (100, 120, 100, 123),
        "wall": (10, 30, 10, 40),
    }
    print(f"Mitsuba ptracer, {args.spp * args.passes} spp")
    for name, (y0, y1, x0, x1) in windows.items():
        a, b = r[y0:y1, x0:x1].mean(), m[y0:y1, x0:x1].mean()
        print(f"{name:16} rows {y0}-{y1 - 1}, columns {x0}-{x1 - 1}: Lucent {a:.4f}, Mitsuba {b:.4f}, ratio {a / b:.3f}")


if __name__ == "__main__":
    main()
