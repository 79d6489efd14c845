"""Adds a box of one material to the built-in Cornell box (assets/cornell-box.gltf) and
writes the result: shared by make_fog.py and make_smoke.py."""
import base64, json, struct


def write(out, name, lo, hi, extensions, generator):
    """Writes `out`: the Cornell box with a closed, outward-facing box `name` from `lo` to
    `hi` whose material is an index-matched boundary (transmission 1, ior 1) with the extra
    material `extensions`."""
    d = json.load(open("assets/cornell-box.gltf"))
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
    boundary = {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.0}}
    d["materials"].append({
        "name": name,
        "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {**boundary, **extensions},
    })
    d["meshes"].append({"name": name, "primitives": [{"attributes": {"POSITION": acc - 2}, "indices": acc - 1, "material": len(d["materials"]) - 1}]})
    d["nodes"].append({"name": name, "mesh": len(d["meshes"]) - 1})
    d["scenes"][d["scene"]]["nodes"].append(len(d["nodes"]) - 1)
    d["extensionsUsed"] = sorted(set(d["extensionsUsed"]) | set(boundary) | set(extensions))
    d["asset"]["generator"] = f"{generator} (Lucent) from assets/cornell-box.gltf"
    json.dump(d, open(out, "w"), indent=1)
