"""Writes cornell-fog.gltf: the built-in Cornell box (assets/cornell-box.gltf) filled with a
box of fog just inside its walls, below the lamp: an index-matched boundary (transmission 1,
ior 1) around KHR_materials_volume + KHR_materials_volume_scatter.
Run from the repository root: python3 docs/scenes/make_fog.py"""
import cornell_with_box

cornell_with_box.write(
    "docs/scenes/cornell-fog.gltf", "fog", (0.002, 0.002, 0.002), (0.554, 0.540, 0.557),
    {
        "KHR_materials_volume": {"thicknessFactor": 1.0, "attenuationDistance": 0.4, "attenuationColor": [0.5, 0.5, 0.5]},
        "KHR_materials_volume_scatter": {"multiscatterColor": [0.9, 0.9, 0.9], "scatterAnisotropy": 0.5},
    },
    "docs/scenes/make_fog.py",
)
