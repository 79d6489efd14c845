"""Writes glTF scenes of flat-shaded triangle meshes (positions only, embedded in one
base64 buffer): shared by make_prism.py and make_rainbow.py."""
import base64, json, struct


def sub(a, b): return [a[i] - b[i] for i in range(3)]
def cross(a, b): return [a[1]*b[2]-a[2]*b[1], a[2]*b[0]-a[0]*b[2], a[0]*b[1]-a[1]*b[0]]
def dot(a, b): return sum(a[i]*b[i] for i in range(3))


def outward(tris, centre):
    """Winds each triangle so that its normal points away from `centre`."""
    out = []
    for a, b, c in tris:
        mid = [(a[i] + b[i] + c[i]) / 3 for i in range(3)]
        out.append((a, b, c) if dot(cross(sub(b, a), sub(c, a)), sub(mid, centre)) > 0 else (a, c, b))
    return out


def write(gltf, meshes, nodes, path):
    """Adds `meshes` ((name, triangles, material) each, a node apiece) and then `nodes` to
    `gltf`, puts them all in its scene 0 and writes it to `path`."""
    blob = b""
    for name, tris, material in meshes:
        points = [p for t in tris for p in t]
        data = b"".join(struct.pack("<3f", *p) for p in points)
        gltf["bufferViews"].append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": 34962})
        blob += data
        gltf["accessors"].append({"bufferView": len(gltf["bufferViews"]) - 1, "componentType": 5126, "count": len(points), "type": "VEC3",
                                  "min": [min(p[i] for p in points) for i in range(3)], "max": [max(p[i] for p in points) for i in range(3)]})
        gltf["meshes"].append({"name": name, "primitives": [{"attributes": {"POSITION": len(gltf["accessors"]) - 1}, "material": material}]})
        gltf["nodes"].append({"name": name, "mesh": len(gltf["meshes"]) - 1})
    gltf["nodes"] += nodes
    gltf["scenes"][0]["nodes"] = list(range(len(gltf["nodes"])))
    gltf["buffers"].append({"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()})
    json.dump(gltf, open(path, "w"), indent=1)
