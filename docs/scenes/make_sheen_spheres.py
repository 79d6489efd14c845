"""Writes sheen-spheres.gltf: KHR_materials_sheen on its own, for the agreement check with
Blender Cycles under an open white sky (docs/agreement.md). A row of spheres over dark and
light bases: a dark grey base under a white sheen of roughness 0.3 and 0.8, a mid grey base
under the same, and a dark base under a red sheen; and the two bases without sheen. No
textures, no other extension. Run from the repository root:
python3 docs/scenes/make_sheen_spheres.py"""
import base64, json, math, struct

R = 0.45
buf, views, accessors, meshes, nodes = bytearray(), [], [], [], []


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


def sphere(material, stacks=32, slices=64):
    """A unit-radius R sphere at the origin (each node places it) with smooth normals."""
    pos, nrm, idx = [], [], []
    for i in range(stacks + 1):
        th = math.pi * i / stacks
        for j in range(slices + 1):
            ph = 2 * math.pi * j / slices
            n = (math.sin(th) * math.cos(ph), math.cos(th), -math.sin(th) * math.sin(ph))
            pos.append((R * n[0], R * n[1], R * n[2]))
            nrm.append(n)
    row = slices + 1
    for i in range(stacks):
        for j in range(slices):
            a, b, c, d = i * row + j, i * row + j + 1, (i + 1) * row + j + 1, (i + 1) * row + j
            idx += ([a, d, c] if i < stacks - 1 else []) + ([a, c, b] if i > 0 else [])
    attrs = {"POSITION": add(pos, "<3f", "VEC3", 34962, ([-R] * 3, [R] * 3)), "NORMAL": add(nrm, "<3f", "VEC3", 34962)}
    meshes.append({"primitives": [{"attributes": attrs, "indices": add(idx, "<I", "SCALAR", 34963), "material": material}]})
    return len(meshes) - 1


def material(name, base, sheen=None):
    m = {"name": name, "pbrMetallicRoughness": {"baseColorFactor": [base, base, base, 1.0], "metallicFactor": 0.0,
                                                 "roughnessFactor": 0.6}}
    if sheen:
        colour, roughness = sheen
        m["extensions"] = {"KHR_materials_sheen": {"sheenColorFactor": colour, "sheenRoughnessFactor": roughness}}
    return m


materials = [
    material("dark, white sheen 0.3", 0.05, ([1.0, 1.0, 1.0], 0.3)),
    material("dark, white sheen 0.8", 0.05, ([1.0, 1.0, 1.0], 0.8)),
    material("grey, white sheen 0.3", 0.4, ([1.0, 1.0, 1.0], 0.3)),
    material("grey, white sheen 0.8", 0.4, ([1.0, 1.0, 1.0], 0.8)),
    material("dark, red sheen 0.5", 0.05, ([1.0, 0.2, 0.1], 0.5)),
    material("dark, no sheen", 0.05),
    material("grey, no sheen", 0.4),
]
for k, m in enumerate(materials):
    nodes.append({"name": m["name"], "mesh": sphere(k), "translation": [(k - 3) * 1.1, 0.0, 0.0]})

doc = {
    "asset": {"version": "2.0", "generator": "docs/scenes/make_sheen_spheres.py"},
    "extensionsUsed": ["KHR_materials_sheen"],
    "scene": 0,
    "scenes": [{"nodes": list(range(len(nodes)))}],
    "nodes": nodes,
    "meshes": meshes,
    "materials": materials,
    "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(buf)).decode()}],
    "bufferViews": views,
    "accessors": accessors,
}
with open("docs/scenes/sheen-spheres.gltf", "w") as f:
    json.dump(doc, f)
