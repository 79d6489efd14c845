"""Lucent against Blender Cycles, object by object, on Khronos models under a uniform white sky.

Usage, in a Python 3.11 venv with the `bpy` wheel from PyPI (5.0.1 here) and numpy, from the
repository root after `cargo build --release`:
    /tmp/cycles-venv/bin/python docs/peers/agree.py [MODEL.glb ...] [--spp 256] [--size 256]
Without models it runs the standing list (MODELS below); MODEL@N looks through the file's
camera N. Each model is rendered by
`target/release/lucent render --background 1,1,1` and by Cycles (the glTF importer's
Principled BSDF, a world of radiance 1), both through the file's first camera or, for a file
without one, Lucent's framing camera (placed in Blender by cycles.py), at the same
size, samples and depth. Objects are told apart by ray casts from the camera through the
pixel centres (Blender's scene.ray_cast); a pixel counts for an object when it and its eight
neighbours all see that object, so edges, where the two renderers' pixel filters differ, are
left out. Printed per object: the mean luminance of its pixels in each renderer, their ratio
Lucent / Cycles with its standard error (from the pixel-to-pixel spread), and the known
difference between the two models that explains it, where there is one (NOTES).
"""
import argparse
import importlib.util
import math
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
# cycles.py is named like Blender's Cycles add-on: load it under another name, and keep this
# folder off the import path (see cycles.py).
sys.path[:] = [p for p in sys.path if os.path.abspath(p or ".") != HERE]
_spec = importlib.util.spec_from_file_location("lucent_cycles_peer", os.path.join(HERE, "cycles.py"))
peer = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(peer)

ASSETS = os.path.join(ROOT, "tests", "assets")
MODELS = [
    "MetalRoughSpheresNoTextures/glTF-Binary/MetalRoughSpheresNoTextures.glb",
    "SpecularTest/glTF-Binary/SpecularTest.glb",
    "TransmissionRoughnessTest/glTF-Binary/TransmissionRoughnessTest.glb",
    # Clearcoat (the body), sheen (the fabric seats) and transmission (the windows), through
    # the file's second camera, which sees the seats.
    "ToyCar/glTF/ToyCar.gltf@1",
    # KHR_materials_sheen alone under the open sky (written by docs/scenes/make_sheen_spheres.py).
    "../../docs/scenes/sheen-spheres.gltf",
]

# Differences the two material models explain (not bugs), by model and object-name prefix.
NOTES = {
    "MetalRoughSpheresNoTextures": [
        ("", "rough metals: Lucent's multiple-scattering compensation (Kulla-Conty) spreads the "
             "energy GGX loses differently from Cycles' multiple-scattering GGX (up to +1.7% at "
             "roughness 0.83)"),
    ],
    "SpecularTest": [
        ("Labels", "the label panel: a textured diffuse base under a rough specular layer"),
        ("", "smooth black dielectrics: head-on (the facing pixels) both give F0; towards the rim "
             "Lucent's Schlick Fresnel (glTF's: F90 = 1, untinted) stays below Cycles' Fresnel, so "
             "whole spheres read 0.5 to 0.9; a specular colour of 0 gives F0 = 0 in Lucent"),
    ],
    "TransmissionRoughnessTest": [
        ("IOR", "the base colour tints light at each crossing of the boundary in Lucent (twice "
                "through a cube), once per object in Cycles' Principled BSDF (a grey 0.5 glass cube "
                "transmits 0.25 and 0.50); and rough transmission loses the energy of "
                "single-scattering GGX in Lucent, which Cycles' multiple-scattering GGX keeps (the "
                "ratio falls with roughness, #1 to #9)"),
        ("", "opaque surfaces"),
    ],
    "sheen-spheres": [
        ("", "sheen: glTF's Charlie lobe with Ashikhmin's visibility, its albedo taken from the base "
             "beneath (Lucent), against Cycles' microfiber sheen layered over the Principled base"),
    ],
    "ToyCar": [
        ("Fabric", "sheen: glTF's Charlie lobe (Lucent) against Cycles' microfiber sheen"),
        ("Glass", "thin-walled glass (glTF without KHR_materials_volume) against the refracting "
                  "interface of the importer's Principled BSDF, and the base colour's tint"),
        ("", "clearcoat: Lucent's albedo-scaled layering against Cycles' coat layer"),
    ],
}


def render_lucent(binary, model, camera, out, a):
    cmd = [binary, "render", model, "--background", "1,1,1", "--spp", str(a.spp), "--width",
           str(a.size), "--height", str(a.size), "--max-depth", str(a.max_depth), "--seed", "1",
           "--out", out] + (["--camera", str(camera)] if camera else [])
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def render_cycles(bpy, model, camera, out, a):
    """Cycles' image of `model` under a uniform white world, and the scene it rendered."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=os.path.abspath(model))
    scene = bpy.context.scene
    doc = peer.read_gltf_json(model)
    peer.tidy_materials(bpy)
    args = argparse.Namespace(spp=a.spp, width=a.size, height=a.size, max_depth=a.max_depth,
                              rr_depth=a.max_depth + 1, seed=1, threads=2)
    peer.configure(bpy, scene, args)
    peer.place_camera(bpy, scene, doc, camera)
    world = bpy.data.worlds.new("white")
    if world.node_tree is None:
        world.use_nodes = True
    bg = world.node_tree.nodes.get("Background") or world.node_tree.nodes.new("ShaderNodeBackground")
    bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    scene.world = world
    scene.render.filepath = out
    bpy.ops.render.render(write_still=True)
    return scene


def pixels(bpy, path, size):
    """Linear RGB of an EXR, top row first, as a (size, size, 3) array."""
    import numpy as np
    img = bpy.data.images.load(path, check_existing=False)
    px = np.empty(len(img.pixels), dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(size, size, 4)[::-1, :, :3].astype(np.float64)


def object_ids(bpy, scene, size):
    """The name of the object each pixel centre sees (None for the sky) and the cosine between
    its normal there and the way back to the camera, top row first."""
    from mathutils import Vector
    cam = scene.camera
    depsgraph = bpy.context.evaluated_depsgraph_get()
    frame = [cam.matrix_world @ v for v in cam.data.view_frame(scene=scene)]
    # view_frame: top-right, bottom-right, bottom-left, top-left.
    tr, br, bl, tl = frame
    eye = cam.matrix_world.translation
    ids = []
    for y in range(size):
        row = []
        fy = (y + 0.5) / size
        for x in range(size):
            fx = (x + 0.5) / size
            top = tl.lerp(tr, fx)
            bottom = bl.lerp(br, fx)
            d = (top.lerp(bottom, fy) - eye).normalized()
            hit, _, normal, _, ob, _ = scene.ray_cast(depsgraph, eye, Vector(d))
            row.append((ob.name, abs(normal.dot(-d))) if hit else (None, 0.0))
        ids.append(row)
    return ids


def note(model, name):
    for prefix, text in NOTES.get(model, []):
        if name.startswith(prefix):
            return text
    return ""


def compare(bpy, model, camera, a, tmp):
    stem = os.path.splitext(os.path.basename(model))[0]
    lucent_out, cycles_out = os.path.join(tmp, stem + ".lucent.exr"), os.path.join(tmp, stem + ".cycles.exr")
    render_lucent(a.lucent, model, camera, lucent_out, a)
    scene = render_cycles(bpy, model, camera, cycles_out, a)
    ids = object_ids(bpy, scene, a.size)
    lum = [0.2126, 0.7152, 0.0722]
    lucent, cycles = pixels(bpy, lucent_out, a.size) @ lum, pixels(bpy, cycles_out, a.size) @ lum
    # Pixels that see one object, as do their eight neighbours, in connected parts (an object
    # made of several spheres is reported sphere by sphere, left to right).
    inner = {}
    for y in range(1, a.size - 1):
        for x in range(1, a.size - 1):
            name = ids[y][x][0]
            if name and all(ids[y + dy][x + dx][0] == name for dy in (-1, 0, 1) for dx in (-1, 0, 1)):
                inner[(x, y)] = name
    parts = {}
    seen = set()
    for start, name in sorted(inner.items(), key=lambda kv: kv[0]):
        if start in seen:
            continue
        part, stack = [], [start]
        seen.add(start)
        while stack:
            x, y = stack.pop()
            part.append((lucent[y, x], cycles[y, x], ids[y][x][1]))
            for q in ((x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)):
                if q not in seen and inner.get(q) == name:
                    seen.add(q)
                    stack.append(q)
        parts.setdefault(name, []).append(part)
    groups = {}
    for name, found in parts.items():
        found = [p for p in found if len(p) >= 16]
        for k, part in enumerate(found):
            groups[f"{name} #{k + 1}" if len(found) > 1 else name] = part
    print(f"\n{stem} ({a.size}x{a.size}, {a.spp} spp, max depth {a.max_depth}): ratio Lucent / Cycles "
          f"of the mean luminance over each object's pixels, and over those that face the camera "
          f"(cos > {FRONT}), each +- its standard error")
    print(f"{'object':28} {'pixels':>6} {'Lucent':>7} {'Cycles':>7} {'ratio':>13} {'facing':>6} "
          f"{'ratio':>13}  note")
    keys, ratios = {}, []
    for name, values in groups.items():
        front = [v for v in values if v[2] > FRONT]
        l, c, r, se = ratio(values)
        fr, fse = ratio(front)[2:] if len(front) >= 4 else (float("nan"), float("nan"))
        text = note(stem, name)
        key = keys.setdefault(text, chr(ord("a") + len(keys))) if text else ""
        ratios.append(r)
        print(f"{name[:28]:28} {len(values):6d} {l:7.4f} {c:7.4f} {r:6.3f} +-{se:.3f} {len(front):6d} "
              f"{fr:6.3f} +-{fse:.3f}  {key}")
    for text, key in keys.items():
        print(f"  {key}: {text}")
    ratios = sorted(r for r in ratios if r == r)
    if ratios:
        print(f"  {len(ratios)} objects: ratio {ratios[0]:.3f} to {ratios[-1]:.3f}, median {ratios[len(ratios) // 2]:.3f}")


# Pixels whose surface faces the camera more than this (cosine) count as "facing".
FRONT = 0.95


def ratio(values):
    """Mean luminance in each renderer, their ratio and its standard error (first order, from
    the pixel-to-pixel spread of both)."""
    n = len(values)
    l = sum(v[0] for v in values) / n
    c = sum(v[1] for v in values) / n
    var = lambda k, m: sum((v[k] - m) ** 2 for v in values) / max(n - 1, 1) / n
    if l <= 0 or c <= 0:
        return l, c, float("nan"), float("nan")
    r = l / c
    return l, c, r, r * math.sqrt(var(0, l) / l**2 + var(1, c) / c**2)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("models", nargs="*", help="glTF files, each optionally @N for the file's camera N "
                    "(0-based, in Lucent's order; default: the first, or the framing camera); "
                    "default: the standing list")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--size", type=int, default=256, help="image width and height")
    ap.add_argument("--max-depth", type=int, default=16)
    ap.add_argument("--lucent", default=os.path.join(ROOT, "target", "release", "lucent"))
    ap.add_argument("--keep", metavar="DIR", help="keep both renderers' images (EXR) in DIR")
    a = ap.parse_args()
    models = a.models or [os.path.join(ASSETS, m) for m in MODELS]
    import bpy
    with tempfile.TemporaryDirectory(prefix="lucent-agree-") as tmp:
        if a.keep:
            os.makedirs(a.keep, exist_ok=True)
        for entry in models:
            model, _, camera = entry.partition("@")
            if not os.path.exists(model):
                print(f"\n{model}: not found")
                continue
            compare(bpy, model, int(camera or 0), a, os.path.abspath(a.keep) if a.keep else tmp)


if __name__ == "__main__":
    main()
