"""Writes cornell-smoke.gltf: the built-in Cornell box (assets/cornell-box.gltf) with a box
(an index-matched boundary: transmission 1, ior 1) that cornell-smoke.media.toml fills
with the OpenVDB density grid smoke.vdb (tests/assets/grids/make_grids.py writes it).
Run from the repository root: python3 docs/scenes/make_smoke.py"""
import base64, json, struct

d = json.load(open("assets/cornell-box.gltf"))
lo, hi = (0.12, 0.01, 0.02), (0.5, 0.39, 0.4)
corners = [(hi[0] if i & 1 else lo[0], hi[1] if i & 2 else lo[1], hi[2] if i & 4 else lo[2]) for i in range(8)]
faces = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]]
indices = [i for a, b, c, e in faces for i in (a, b, c, a, c, e)]
data = b"".join(struct.pack("<3f", *c) for c in corners) + struct.pack(f"<{len(indices)}H", *indices)
d["buffers"].append({"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()})
buf = len(d["buffers"]) - 1
d["bufferViews"] += [
    {"buffer": buf, "byteOffset": 0, "byteLength": 96, "target": 34962},
    {"buffer": buf, "byteOffset": 96, "byteLength": 2 * len(indices), "target": 34963},
]
views = len(d["bufferViews"])
d["accessors"] += [
    {"bufferView": views - 2, "componentType": 5126, "count": 8, "type": "VEC3", "min": list(lo), "max": list(hi)},
    {"bufferView": views - 1, "componentType": 5123, "count": len(indices), "type": "SCALAR"},
]
acc = len(d["accessors"])
d["materials"].append({
    "name": "smoke",
    "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
    "extensions": {
        "KHR_materials_transmission": {"transmissionFactor": 1.0},
        "KHR_materials_ior": {"ior": 1.0},
    },
})
d["meshes"].append({"name": "smoke", "primitives": [{"attributes": {"POSITION": acc - 2}, "indices": acc - 1, "material": len(d["materials"]) - 1}]})
d["nodes"].append({"name": "smoke", "mesh": len(d["meshes"]) - 1})
d["scenes"][d["scene"]]["nodes"].append(len(d["nodes"]) - 1)
d["extensionsUsed"] = sorted(set(d["extensionsUsed"]) | {"KHR_materials_transmission", "KHR_materials_ior"})
d["asset"]["generator"] = "docs/scenes/make_smoke.py (Lucent) from assets/cornell-box.gltf"
json.dump(d, open("docs/scenes/cornell-smoke.gltf", "w"), indent=1)
