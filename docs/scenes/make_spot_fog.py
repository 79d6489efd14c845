"""Writes spot-fog.gltf: the fog of cornell-fog.gltf filling the built-in Cornell box up to
its ceiling, lit by a spot light (KHR_lights_punctual) hanging inside the fog under the
ceiling and aimed past the tall block, whose shadow cuts the beam into shafts. The ceiling
lamp is dimmed to a glow. Run from the repository root: python3 docs/scenes/make_spot_fog.py"""
import json, math
import cornell_with_box

OUT = "docs/scenes/spot-fog.gltf"
cornell_with_box.write(
    OUT, "fog", (0.002, 0.002, 0.002), (0.554, 0.547, 0.557),
    {
        "KHR_materials_volume": {"thicknessFactor": 1.0, "attenuationDistance": 0.6, "attenuationColor": [0.5, 0.5, 0.5]},
        "KHR_materials_volume_scatter": {"multiscatterColor": [0.9, 0.9, 0.9], "scatterAnisotropy": 0.3},
    },
    "docs/scenes/make_spot_fog.py",
)
d = json.load(open(OUT))
for m in d["materials"]:
    if m.get("name") == "light":
        m["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] = 0.5
position, target = [0.42, 0.52, 0.45], [0.20, 0.0, 0.25]
f = [target[i] - position[i] for i in range(3)]
n = math.sqrt(sum(x * x for x in f))
f = [x / n for x in f]
# The rotation turning -z onto f: about the axis -z x f by the angle between them.
axis = [f[1], -f[0], 0.0]
s = math.sqrt(sum(x * x for x in axis))
angle = math.acos(-f[2])
q = [axis[0] / s * math.sin(angle / 2), axis[1] / s * math.sin(angle / 2), 0.0, math.cos(angle / 2)]
d.setdefault("extensions", {})["KHR_lights_punctual"] = {"lights": [
    {"name": "spot", "type": "spot", "color": [1.0, 0.95, 0.85], "intensity": 1.5,
     "spot": {"innerConeAngle": math.radians(10), "outerConeAngle": math.radians(14)}}]}
d["extensionsUsed"] = sorted(set(d["extensionsUsed"]) | {"KHR_lights_punctual"})
d["nodes"].append({"name": "spot", "translation": position, "rotation": q, "extensions": {"KHR_lights_punctual": {"light": 0}}})
d["scenes"][d["scene"]]["nodes"].append(len(d["nodes"]) - 1)
json.dump(d, open(OUT, "w"), indent=1)
