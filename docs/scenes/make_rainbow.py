"""Writes rainbow.gltf: a narrow spot light (KHR_lights_punctual) shines through a 60-degree
flint prism (KHR_materials_dispersion, n_d 1.7, V_d 20) set at minimum deviation; the beam
leaves it fanned into its spectrum and falls on a white wall. A dim ceiling lights the rest.
No camera path can find the spectrum (a point light seen only through delta refractions):
bidirectional path tracing's light tracing draws it. Run from the repository root:
python3 docs/scenes/make_rainbow.py"""
import math
import flat_meshes
from flat_meshes import dot, outward

N_D, APEX = 1.7, math.radians(60)
# Minimum deviation: the ray inside runs parallel to the base, at half the apex angle from
# each face's normal; outside it makes theta with the normal.
theta = math.asin(N_D * math.sin(APEX / 2))
tilt = theta - APEX / 2  # the outside ray's angle to the inside one
SIDE, HALF_HEIGHT, CENTRE_Z = 0.8, 0.3, -1.5
# Prism-local (u along the inside ray, v towards the apex), turned so the beam leaves
# straight towards the wall (-z).
phi = -math.pi / 2 + tilt
def world(u, v):
    return (u * math.cos(phi) - v * math.sin(phi), CENTRE_Z + u * math.sin(phi) + v * math.cos(phi))
h = SIDE * math.sqrt(3) / 2
corners = [world(-SIDE / 2, -h / 3), world(SIDE / 2, -h / 3), world(0.0, 2 * h / 3)]
entry = world(-SIDE / 4, h / 6)  # the middle of the entry face, at the inside ray's height
incoming = (math.cos(phi + tilt), math.sin(phi + tilt))  # the beam's direction (x, z)
LIGHT = [entry[0] - 3.0 * incoming[0], 0.0, entry[1] - 3.0 * incoming[1]]

top = [[x, HALF_HEIGHT, z] for x, z in corners]
bottom = [[x, -HALF_HEIGHT, z] for x, z in corners]
prism = [(top[0], top[1], top[2]), (bottom[0], bottom[1], bottom[2])]
for i in range(3):
    j = (i + 1) % 3
    prism += [(top[i], top[j], bottom[j]), (top[i], bottom[j], bottom[i])]
centroid = [sum(c[0] for c in corners) / 3, 0.0, sum(c[1] for c in corners) / 3]
prism = outward(prism, centroid)
wall = outward([([-4, -3, -4], [4, -3, -4], [4, 3, -4]), ([-4, -3, -4], [4, 3, -4], [-4, 3, -4])], [0, 0, -8])
ceiling = outward([([-4, 3, -4], [4, 3, -4], [4, 3, 4]), ([-4, 3, -4], [4, 3, 4], [-4, 3, 4])], [0, 4, 0])

def look_at(eye, target):
    """A node rotation (quaternion) turning the camera's -z towards `target`."""
    f = [target[i] - eye[i] for i in range(3)]
    n = math.sqrt(dot(f, f)); f = [x / n for x in f]
    yaw, pitch = math.atan2(-f[0], -f[2]), math.asin(f[1])
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    return [cy * sp, sy * cp, -sy * sp, cy * cp]

eye, target = [0.0, 1.2, 2.5], [0.0, -0.1, -4.0]
gltf = {"asset": {"version": "2.0", "generator": "docs/scenes/make_rainbow.py (Lucent)"}, "scene": 0,
        "scenes": [{"nodes": []}], "nodes": [], "meshes": [], "accessors": [], "bufferViews": [], "buffers": [],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.3, "aspectRatio": 1.5, "znear": 0.01}}],
        "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume",
                           "KHR_materials_dispersion", "KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "beam", "type": "spot", "color": [1, 1, 1], "intensity": 1500.0,
             "spot": {"innerConeAngle": math.radians(0.2), "outerConeAngle": math.radians(0.25)}}]}},
        "materials": [
            {"name": "flint", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
             "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": N_D},
                            "KHR_materials_volume": {"thicknessFactor": 0.5}, "KHR_materials_dispersion": {"dispersion": 1.0}}},
            {"name": "wall", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}},
            {"name": "ceiling", "emissiveFactor": [0.3, 0.3, 0.3], "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0}},
        ]}
# The spot shines down its node's -z: turn it along the beam.
flat_meshes.write(
    gltf,
    [("prism", prism, 0), ("wall", wall, 1), ("ceiling", ceiling, 2)],
    [{"name": "beam", "translation": LIGHT, "rotation": look_at(LIGHT, [entry[0], 0.0, entry[1]]),
      "extensions": {"KHR_lights_punctual": {"light": 0}}},
     {"name": "camera", "camera": 0, "translation": eye, "rotation": look_at(eye, target)}],
    "docs/scenes/rainbow.gltf",
)
