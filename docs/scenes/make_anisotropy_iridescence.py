"""Writes anisotropy-iridescence.gltf: brushed metal (KHR_materials_anisotropy) beside thin
films (KHR_materials_iridescence) on a grey floor, lit by a sun (KHR_lights_punctual) and
the sky. Left to right: a disc brushed in circles (tangents around its centre: the sun's
highlight becomes a radial streak), a sphere brushed along its meridians and one brushed
around them (rotation 90 degrees), a coated dark metal with a 420 nm film, and a soap
bubble (a thin wall of index 1.33 under a 250-650 nm film whose thickness texture varies
from top to bottom). Run from the repository root: python3 docs/scenes/make_anisotropy_iridescence.py"""
import base64, json, math, struct, zlib

R = 0.62
buf, views, accessors, meshes = bytearray(), [], [], []

def add(data, fmt, kind, count, target, bounds=None):
    while len(buf) % 4:
        buf.append(0)
    views.append({"buffer": 0, "byteOffset": len(buf), "byteLength": struct.calcsize(fmt) * len(data), "target": target})
    buf.extend(b"".join(struct.pack(fmt, *d) if isinstance(d, tuple) else struct.pack(fmt, d) for d in data))
    acc = {"bufferView": len(views) - 1, "componentType": 5125 if fmt == "<I" else 5126, "count": count, "type": kind}
    if bounds:
        acc["min"], acc["max"] = bounds
    accessors.append(acc)
    return len(accessors) - 1

def mesh(pos, nrm, uv, tan, idx, material):
    lo = [min(p[i] for p in pos) for i in range(3)]
    hi = [max(p[i] for p in pos) for i in range(3)]
    attrs = {"POSITION": add(pos, "<3f", "VEC3", len(pos), 34962, (lo, hi)),
             "NORMAL": add(nrm, "<3f", "VEC3", len(nrm), 34962),
             "TEXCOORD_0": add(uv, "<2f", "VEC2", len(uv), 34962),
             "TANGENT": add(tan, "<4f", "VEC4", len(tan), 34962)}
    meshes.append({"primitives": [{"attributes": attrs, "indices": add(idx, "<I", "SCALAR", len(idx), 34963), "material": material}]})
    return len(meshes) - 1

def sphere(cx, cy, cz, material, stacks=40, slices=80):
    pos, nrm, uv, tan, idx = [], [], [], [], []
    for i in range(stacks + 1):
        th = math.pi * i / stacks
        for j in range(slices + 1):
            ph = 2 * math.pi * j / slices
            n = (math.sin(th) * math.cos(ph), math.cos(th), -math.sin(th) * math.sin(ph))
            pos.append((cx + R * n[0], cy + R * n[1], cz + R * n[2]))
            nrm.append(n)
            uv.append((j / slices, i / stacks))
            # Along increasing u: around the vertical axis (the brush runs along parallels).
            tan.append((-math.sin(ph), 0.0, -math.cos(ph), 1.0))
    row = slices + 1
    for i in range(stacks):
        for j in range(slices):
            a, b, c, d = i * row + j, i * row + j + 1, (i + 1) * row + j + 1, (i + 1) * row + j
            idx += ([a, d, c] if i < stacks - 1 else []) + ([a, c, b] if i > 0 else [])
    return mesh(pos, nrm, uv, tan, idx, material)

def disc(cx, cy, cz, material, rings=16, slices=96):
    """A disc facing +z, its tangents running around its centre."""
    pos, nrm, uv, tan, idx = [(cx, cy, cz)], [(0, 0, 1)], [(0.5, 0.5)], [(1, 0, 0, 1)], []
    for i in range(1, rings + 1):
        r = R * 1.15 * i / rings
        for j in range(slices):
            ph = 2 * math.pi * j / slices
            pos.append((cx + r * math.cos(ph), cy + r * math.sin(ph), cz))
            nrm.append((0, 0, 1))
            uv.append((0.5 + 0.5 * i / rings * math.cos(ph), 0.5 - 0.5 * i / rings * math.sin(ph)))
            tan.append((-math.sin(ph), math.cos(ph), 0, 1))
    at = lambda i, j: 1 + (i - 1) * slices + j % slices
    for j in range(slices):
        idx += [0, at(1, j), at(1, j + 1)]
    for i in range(1, rings):
        for j in range(slices):
            idx += [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1)]
    return mesh(pos, nrm, uv, tan, idx, material)

def floor(material, s=12.0):
    pos = [(-s, 0, -s), (s, 0, -s), (s, 0, s), (-s, 0, s)]
    return mesh(pos, [(0, 1, 0)] * 4, [(0, 0), (1, 0), (1, 1), (0, 1)], [(1, 0, 0, 1)] * 4, [0, 2, 1, 0, 3, 2], material)

def png_gradient(h=64):
    """A 1 x h greyscale PNG from black (top) to white (bottom): the bubble's film thickness."""
    raw = b"".join(b"\x00" + bytes([round(255 * y / (h - 1))] * 3) for y in range(h))
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 1, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))

def look_at(eye, target):
    """Quaternion (x, y, z, w) turning -z towards target - eye, +y kept up."""
    f = [target[i] - eye[i] for i in range(3)]
    n = math.sqrt(sum(v * v for v in f)); f = [v / n for v in f]
    yaw, pitch = math.atan2(-f[0], -f[2]), math.asin(f[1])
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    return [cy * sp, sy * cp, -sy * sp, cy * cp]

brushed = lambda name, rotation: {
    "name": name, "pbrMetallicRoughness": {"baseColorFactor": [0.95, 0.93, 0.88, 1], "metallicFactor": 1, "roughnessFactor": 0.3},
    "extensions": {"KHR_materials_anisotropy": {"anisotropyStrength": 0.85, "anisotropyRotation": rotation}}}
materials = [
    {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.35, 0.35, 0.37, 1], "metallicFactor": 0, "roughnessFactor": 0.8}},
    brushed("brushed in circles", 0.0),
    brushed("brushed along parallels", 0.0),
    brushed("brushed along meridians", math.pi / 2),
    {"name": "coated metal", "pbrMetallicRoughness": {"baseColorFactor": [0.12, 0.12, 0.14, 1], "metallicFactor": 1, "roughnessFactor": 0.15},
     "extensions": {"KHR_materials_iridescence": {"iridescenceFactor": 1, "iridescenceIor": 1.5,
                    "iridescenceThicknessMinimum": 420, "iridescenceThicknessMaximum": 420}}},
    {"name": "soap bubble", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0, "roughnessFactor": 0},
     "extensions": {"KHR_materials_ior": {"ior": 1.33}, "KHR_materials_transmission": {"transmissionFactor": 1},
                    "KHR_materials_iridescence": {"iridescenceFactor": 1, "iridescenceIor": 1.33,
                    "iridescenceThicknessMinimum": 250, "iridescenceThicknessMaximum": 650,
                    "iridescenceThicknessTexture": {"index": 0}}}},
]
xs = [-2.6, -1.3, 0.0, 1.3, 2.6]
nodes = [{"mesh": floor(0)}, {"mesh": disc(xs[0], R * 1.2, 0.0, 1)}]
# One sphere mesh per material, all four from the same vertex data placed by their nodes.
shape = sphere(0.0, 0.0, 0.0, 2)
for m in [3, 4, 5]:
    meshes.append({"primitives": [dict(meshes[shape]["primitives"][0], material=m)]})
nodes += [{"mesh": shape + i, "translation": [x, R, 0.0]} for i, x in enumerate(xs[1:])]
eye, target = [0.0, 1.6, 7.0], [0.0, 0.55, 0.0]
nodes.append({"camera": 0, "translation": eye, "rotation": look_at(eye, target)})
sun = [-0.45, -0.6, -0.66]
nodes.append({"extensions": {"KHR_lights_punctual": {"light": 0}}, "rotation": look_at([0, 0, 0], sun)})
doc = {
    "asset": {"version": "2.0", "generator": "docs/scenes/make_anisotropy_iridescence.py"},
    "extensionsUsed": ["KHR_materials_anisotropy", "KHR_materials_iridescence", "KHR_materials_ior",
                       "KHR_materials_transmission", "KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 3.0, "color": [1, 0.96, 0.9]}]}},
    "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}], "nodes": nodes, "meshes": meshes,
    "materials": [dict(m, doubleSided=True) for m in materials],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "aspectRatio": 16 / 9, "znear": 0.05}}],
    "images": [{"uri": "data:image/png;base64," + base64.b64encode(png_gradient()).decode()}],
    "samplers": [{"wrapS": 33071, "wrapT": 33071}], "textures": [{"source": 0, "sampler": 0}],
    "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(buf)).decode()}],
    "bufferViews": views, "accessors": accessors,
}
with open("docs/scenes/anisotropy-iridescence.gltf", "w") as f:
    json.dump(doc, f, separators=(",", ":"))
