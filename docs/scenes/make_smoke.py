"""Writes cornell-smoke.gltf: the built-in Cornell box (assets/cornell-box.gltf) with a box
(an index-matched boundary: transmission 1, ior 1) that cornell-smoke.media.toml fills
with the OpenVDB density grid smoke.vdb (tests/assets/grids/make_grids.py writes it).
Run from the repository root: python3 docs/scenes/make_smoke.py"""
import cornell_with_box

cornell_with_box.write(
    "docs/scenes/cornell-smoke.gltf", "smoke", (0.12, 0.01, 0.02), (0.5, 0.39, 0.4), {}, "docs/scenes/make_smoke.py"
)
