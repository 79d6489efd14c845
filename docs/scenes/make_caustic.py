"""Writes caustic.gltf: a smooth glass ball over a grey floor lit by a point light
(KHR_lights_punctual) above it, in front of a grey wall. The path tracer cannot render the
light the ball focuses onto the floor (its shadow rays stop at the glass, and its BSDF
sampling never hits a point): under the ball it sees a shadow. Bidirectional path tracing's
light subpaths refract through the ball and are seen where they land. Its second camera
looks down through the ball at that light, which only vertex merging finds. Run from the
repository root: python3 docs/scenes/make_caustic.py"""
import base64, json, math, struct

buf, views, accessors, meshes = bytearray(), [], [], []


def add(data, fmt, kind, target, bounds=None):
    while len(buf) % 4:
        buf.append(0)
    views.append({"buffer": 0, "byteOffset": len(buf), "byteLength": struct.calcsize(fmt) * len(data), "target": target})
    buf.extend(b"".join(struct.pack(fmt, *d) if isinstance(d, tuple) else struct.pack(fmt, d) for d in data))
    acc = {"bufferView": len(views) - 1, "componentType": 5125 if fmt == "<I" else 5126, "count": len(data), "type": kind}
    if bounds:
        acc["min"], acc["max"] = bounds
    accessors.append(acc)
    return len(accessors) - 1


def mesh(pos, nrm, idx, material):
    lo = [min(p[i] for p in pos) for i in range(3)]
    hi = [max(p[i] for p in pos) for i in range(3)]
    attrs = {"POSITION": add(pos, "<3f", "VEC3", 34962, (lo, hi)), "NORMAL": add(nrm, "<3f", "VEC3", 34962)}
    meshes.append({"primitives": [{"attributes": attrs, "indices": add(idx, "<I", "SCALAR", 34963), "material": material}]})
    return len(meshes) - 1


def quad(corners, normal, material):
    return mesh(corners, [normal] * 4, [0, 1, 2, 0, 2, 3], material)


def sphere(r, material, stacks=64, slices=128):
    pos, nrm, idx = [], [], []
    for i in range(stacks + 1):
        th = math.pi * i / stacks
        for j in range(slices + 1):
            ph = 2 * math.pi * j / slices
            n = (math.sin(th) * math.cos(ph), math.cos(th), -math.sin(th) * math.sin(ph))
            pos.append((r * n[0], r * n[1], r * n[2]))
            nrm.append(n)
    row = slices + 1
    for i in range(stacks):
        for j in range(slices):
            a, b, c, d = i * row + j, i * row + j + 1, (i + 1) * row + j + 1, (i + 1) * row + j
            idx += ([a, d, c] if i < stacks - 1 else []) + ([a, c, b] if i > 0 else [])
    return mesh(pos, nrm, idx, material)


floor = quad([(-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3)], (0, 1, 0), 0)
wall = quad([(-3, 0, -2), (3, 0, -2), (3, 3, -2), (-3, 3, -2)], (0, 0, 1), 0)
ball = sphere(0.5, 1)
doc = {
    "asset": {"version": "2.0", "generator": "docs/scenes/make_caustic.py"},
    "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume", "KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [{"name": "bulb", "type": "point", "intensity": 12.0}]}},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2, 3, 4, 5]}],
    "nodes": [
        {"name": "floor", "mesh": floor},
        {"name": "wall", "mesh": wall},
        {"name": "ball", "mesh": ball, "translation": [0.0, 0.9, 0.0]},
        {"name": "bulb", "translation": [0.3, 2.6, 0.2], "extensions": {"KHR_lights_punctual": {"light": 0}}},
        # Looking down through the ball at the caustic under it (--camera 1): only vertex
        # merging (--integrator vcm) finds that light. Lucent lists a scene's cameras from its
        # last node, so the view from the front (the last node) is camera 0.
        {"name": "through the ball", "camera": 1, "translation": [0.0, 2.2, 0.4], "rotation": [-0.6618026, 0.0, 0.0, 0.7496782]},
        {"name": "camera", "camera": 0, "translation": [0.0, 2.2, 3.4], "rotation": [-0.2588190, 0.0, 0.0, 0.9659258]},
    ],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.75, "znear": 0.01}},
                {"type": "perspective", "perspective": {"yfov": 0.35, "znear": 0.01}}],
    "meshes": meshes,
    "materials": [
        {"name": "grey", "pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1], "metallicFactor": 0, "roughnessFactor": 1}},
        {"name": "glass", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0, "roughnessFactor": 0},
         "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5},
                        "KHR_materials_volume": {"thicknessFactor": 1.0}}},
    ],
    "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(buf)).decode()}],
    "bufferViews": views,
    "accessors": accessors,
}
with open("docs/scenes/caustic.gltf", "w") as f:
    json.dump(doc, f)
