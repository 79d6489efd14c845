"""Writes cornell-subsurface.gltf: the built-in Cornell box (assets/cornell-box.gltf) with a
sphere of a dense, warm scattering medium (wax-like) behind a diffuse-transmission boundary
under a glossy specular layer, the boundary KHR_materials_volume_scatter recommends for dense
media: KHR_materials_diffuse_transmission + _ior + _volume + _volume_scatter.
Run from the repository root: python3 docs/scenes/make_subsurface.py"""
import base64, json, math, struct

d = json.load(open("assets/cornell-box.gltf"))
centre, radius, stacks, slices = (0.43, 0.1, 0.12), 0.1, 32, 64
positions, normals = [], []
for i in range(stacks + 1):
    theta = math.pi * i / stacks
    for j in range(slices + 1):
        phi = 2 * math.pi * j / slices
        n = (math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi))
        positions.append(tuple(c + radius * k for c, k in zip(centre, n)))
        normals.append(n)
row = slices + 1
indices = []
for i in range(stacks):
    for j in range(slices):
        a, b, c, e = i * row + j, i * row + j + 1, (i + 1) * row + j + 1, (i + 1) * row + j
        if i > 0:  # the first row's (a, b) is the pole: that triangle has no area
            indices += [a, b, c]
        if i < stacks - 1:  # the last row's (c, e) is the other pole
            indices += [a, c, e]
pos = b"".join(struct.pack("<3f", *p) for p in positions)
nor = b"".join(struct.pack("<3f", *n) for n in normals)
idx = struct.pack(f"<{len(indices)}H", *indices)
data = pos + nor + idx
d["buffers"].append({"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()})
buf = len(d["buffers"]) - 1
d["bufferViews"] += [
    {"buffer": buf, "byteOffset": 0, "byteLength": len(pos), "target": 34962},
    {"buffer": buf, "byteOffset": len(pos), "byteLength": len(nor), "target": 34962},
    {"buffer": buf, "byteOffset": len(pos) + len(nor), "byteLength": len(idx), "target": 34963},
]
v = len(d["bufferViews"])
lo = [min(p[k] for p in positions) for k in range(3)]
hi = [max(p[k] for p in positions) for k in range(3)]
d["accessors"] += [
    {"bufferView": v - 3, "componentType": 5126, "count": len(positions), "type": "VEC3", "min": lo, "max": hi},
    {"bufferView": v - 2, "componentType": 5126, "count": len(normals), "type": "VEC3"},
    {"bufferView": v - 1, "componentType": 5123, "count": len(indices), "type": "SCALAR"},
]
a = len(d["accessors"])
d["materials"].append({
    "name": "wax",
    "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.3},
    "extensions": {
        "KHR_materials_diffuse_transmission": {"diffuseTransmissionFactor": 1.0},
        "KHR_materials_ior": {"ior": 1.4},
        "KHR_materials_volume": {"thicknessFactor": 1.0, "attenuationDistance": 0.02, "attenuationColor": [0.35, 0.2, 0.12]},
        "KHR_materials_volume_scatter": {"multiscatterColor": [0.95, 0.75, 0.5], "scatterAnisotropy": 0.0},
    },
})
d["meshes"].append({"name": "wax sphere", "primitives": [{"attributes": {"POSITION": a - 3, "NORMAL": a - 2}, "indices": a - 1, "material": len(d["materials"]) - 1}]})
d["nodes"].append({"name": "wax sphere", "mesh": len(d["meshes"]) - 1})
d["scenes"][d["scene"]]["nodes"].append(len(d["nodes"]) - 1)
d["extensionsUsed"] = sorted(set(d["extensionsUsed"]) | {"KHR_materials_diffuse_transmission", "KHR_materials_ior", "KHR_materials_volume", "KHR_materials_volume_scatter"})
d["asset"]["generator"] = "docs/scenes/make_subsurface.py (Lucent) from assets/cornell-box.gltf"
json.dump(d, open("docs/scenes/cornell-subsurface.gltf", "w"), indent=1)
