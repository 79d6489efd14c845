"""Writes prism.gltf: a flint-glass prism (KHR_materials_dispersion, V_d = 20) in front of a
thin white emissive line on a faintly glowing grey wall; the camera sees the line through the prism,
split into its spectrum. Run from the repository root: python3 docs/scenes/make_prism.py"""
import math, sys
from flat_meshes import outward as closed
import flat_meshes

LINE_X = float(sys.argv[1]) if len(sys.argv) > 1 else 3.23
# The prism: apex angle 30 degrees, edges along y, turned so the view crosses it near
# minimum deviation.
apex, side, cz = math.radians(30), 0.6, -2.0
half = side * math.sin(apex / 2)
tri = [(0.0, side * math.cos(apex / 2) / 2), (-half, -side * math.cos(apex / 2) / 2), (half, -side * math.cos(apex / 2) / 2)]
turn = math.radians(90 + 11)
rot = lambda p: (p[0] * math.cos(turn) - p[1] * math.sin(turn), p[0] * math.sin(turn) + p[1] * math.cos(turn))
tri = [rot(p) for p in tri]
top = [[x, 0.4, cz + z] for x, z in tri]
bot = [[x, -0.4, cz + z] for x, z in tri]
prism = [(top[0], top[1], top[2]), (bot[0], bot[1], bot[2])]
for i in range(3):
    j = (i + 1) % 3
    prism += [(top[i], top[j], bot[j]), (top[i], bot[j], bot[i])]
prism = closed(prism, [sum(p[0] for p in tri) / 3, 0.0, cz + sum(p[1] for p in tri) / 3])

def quad(x0, x1, y0, y1, z, facing):
    a, b, c, d = [x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]
    return closed([(a, b, c), (a, c, d)], [0.0, 0.0, z - facing])

line = quad(LINE_X - 0.01, LINE_X + 0.01, -1.5, 1.5, -9.99, 1.0)
wall = quad(-8.0, 8.0, -5.0, 5.0, -10.0, 1.0)

gltf = {"asset": {"version": "2.0", "generator": "docs/scenes/make_prism.py (Lucent)"}, "scene": 0,
        "scenes": [{"nodes": []}], "nodes": [], "meshes": [], "accessors": [], "bufferViews": [], "buffers": [],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.3, "aspectRatio": 1.5, "znear": 0.01}}],
        "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume",
                           "KHR_materials_dispersion", "KHR_materials_emissive_strength"],
        "materials": [
            {"name": "flint", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
             "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.7},
                            "KHR_materials_volume": {"thicknessFactor": 0.3}, "KHR_materials_dispersion": {"dispersion": 1.0}}},
            {"name": "line", "emissiveFactor": [1, 1, 1], "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 20.0}}},
            {"name": "wall", "emissiveFactor": [0.04, 0.04, 0.04], "pbrMetallicRoughness": {"baseColorFactor": [0.3, 0.3, 0.3, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}},
        ]}
flat_meshes.write(gltf, [("prism", prism, 0), ("line", line, 1), ("wall", wall, 2)],
                  [{"name": "camera", "camera": 0}], "docs/scenes/prism.gltf")
