"""Render a glTF scene with Blender Cycles (bpy, CPU) and print one JSON line with samples/s."""
# Usage, in a Python 3.11 venv with the `bpy` wheel from PyPI (5.0.1 here):
#   /tmp/cycles-venv/bin/python docs/peers/cycles.py --scene ../shared/scenes/cornell-box.gltf \
#       --spp 256 --warmup --out /tmp/cycles-box.exr
# The settings mirror `lucent render --max-depth 7 --rr-depth 5` (and Mitsuba max_depth 8):
# --max-depth and --rr-depth count scattering events as Lucent does; the mapping to Cycles'
# counters is in configure(). Time covers bpy.ops.render.render(write_still=True) only: Cycles'
# scene sync and BVH build, the render and the EXR write, not start-up or the glTF import.
# --warmup renders 1 spp first (not timed). The last line printed is one JSON object.
import argparse
import json
import os
import sys
import time

# This file is named like Blender's Cycles add-on (module `cycles`): keep its folder off the
# import path, or bpy would register this script instead of the add-on.
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:] = [p for p in sys.path if os.path.abspath(p or ".") != HERE]


def tidy_materials(bpy):
    """Keep the imported materials, minus two things Cycles would handle differently."""
    for mat in bpy.data.materials:
        if not mat.node_tree:
            continue
        for node in list(mat.node_tree.nodes):
            # glTF KHR_materials_volume without attenuationDistance absorbs nothing, but the
            # importer still wires a zero-density Volume Absorption, which would make Cycles
            # track the glass as a volume (same image, ~5% more CPU time). Drop it.
            if node.type == "OUTPUT_MATERIAL" and node.inputs["Volume"].is_linked:
                src = node.inputs["Volume"].links[0].from_node
                if src.type == "VOLUME_ABSORPTION" and src.inputs["Density"].default_value == 0:
                    mat.node_tree.links.remove(node.inputs["Volume"].links[0])
            # glTF (and Lucent) emit from the front side only; Cycles' emission is two-sided
            # (the Cornell light's back would light the 0.5 mm gap to the ceiling, and light
            # leaks out of it). Scale the strength by 1 - Backfacing; sample the front only.
            strength = node.inputs["Emission Strength"] if node.type == "BSDF_PRINCIPLED" else None
            if strength and not strength.is_linked and strength.default_value > 0:
                nodes, links = mat.node_tree.nodes, mat.node_tree.links
                geo = nodes.new("ShaderNodeNewGeometry")
                front, scale = nodes.new("ShaderNodeMath"), nodes.new("ShaderNodeMath")
                front.operation, front.inputs[0].default_value = "SUBTRACT", 1.0
                scale.operation, scale.inputs[1].default_value = "MULTIPLY", strength.default_value
                links.new(geo.outputs["Backfacing"], front.inputs[1])
                links.new(front.outputs[0], scale.inputs[0])
                links.new(scale.outputs[0], strength)
                mat.cycles.emission_sampling = "FRONT"


def configure(bpy, scene, a):
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = a.spp
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.use_guiding = False
    # One quad light: pick it by power as Lucent does (the light tree gives the same image here
    # for ~40% more CPU time).
    c.use_light_tree = False
    c.light_sampling_threshold = 0.0  # always trace the shadow ray (no light-sample roulette)
    # Cycles counts bounces after the first hit: max_bounces 0 is direct light only, i.e. one
    # scattering event. So Lucent's --max-depth N (N scattering events) is max_bounces N - 1.
    bounces = max(a.max_depth - 1, 0)
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = bounces
    c.volume_bounces = 0
    c.transparent_max_bounces = 8  # no alpha/transparent BSDFs in these scenes
    # Russian roulette: Cycles rolls at each hit once `bounce` (scattering events so far) exceeds
    # min_light_bounces + 1; Lucent rolls before tracing on once `depth` >= rr_depth. So
    # min_light_bounces = rr_depth - 2 starts both after the same event. (The survival
    # probability differs: Cycles sqrt(max throughput), Lucent max(throughput * eta^2).)
    c.min_light_bounces = max(a.rr_depth - 2, 0)
    c.min_transparent_bounces = 0
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.caustics_reflective = c.caustics_refractive = True
    c.blur_glossy = 0.0
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.seed = a.seed
    c.use_animated_seed = False
    c.film_exposure = 1.0
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = a.width, a.height, 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.film_transparent = False
    r.threads_mode = "FIXED"
    r.threads = a.threads
    r.use_compositing = r.use_sequencer = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    im = r.image_settings
    im.file_format = "OPEN_EXR"
    im.color_mode = "RGB"
    im.color_depth = "32"
    im.exr_codec = "ZIP"
    r.use_file_extension = False


def mean_rgb(bpy, path):
    import numpy as np
    img = bpy.data.images.load(path, check_existing=False)
    px = np.empty(len(img.pixels), dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return [round(float(x), 6) for x in px.reshape(-1, 4)[:, :3].astype(np.float64).mean(0)]


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scene", required=True, help="path to a .gltf/.glb with a camera")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--width", type=int, default=256)
    ap.add_argument("--height", type=int, default=256)
    ap.add_argument("--max-depth", type=int, default=7, help="scattering events, as in Lucent")
    ap.add_argument("--rr-depth", type=int, default=5, help="roulette from this bounce (Lucent)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--warmup", action="store_true")
    ap.add_argument("--out", required=True, help="output .exr (linear float32 RGB)")
    a = ap.parse_args()

    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=os.path.abspath(a.scene))
    scene = bpy.context.scene
    cams = [o for o in scene.objects if o.type == "CAMERA"]
    if not cams:
        sys.exit("no camera in " + a.scene)
    scene.camera = cams[0]  # as imported: vertical sensor fit, angle_y = glTF yfov
    tidy_materials(bpy)
    configure(bpy, scene, a)

    if a.warmup:
        scene.cycles.samples = 1
        bpy.ops.render.render(write_still=False)
        scene.cycles.samples = a.spp
    out = os.path.abspath(a.out)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    scene.render.filepath = out
    t0, c0 = time.perf_counter(), time.process_time()
    bpy.ops.render.render(write_still=True)
    secs, cpu = time.perf_counter() - t0, time.process_time() - c0

    c = scene.cycles
    res = {
        "renderer": "cycles", "version": bpy.app.version_string, "scene": os.path.basename(a.scene),
        "width": a.width, "height": a.height, "spp": a.spp, "threads": scene.render.threads,
        "max_depth": a.max_depth, "max_bounces": c.max_bounces,
        "min_light_bounces": c.min_light_bounces,
        "light_tree": c.use_light_tree, "sampling_pattern": c.sampling_pattern, "seed": a.seed,
        "filter": [c.pixel_filter_type, c.filter_width], "seconds": round(secs, 4),
        "cpu_seconds": round(cpu, 4), "samples_per_sec": round(a.width * a.height * a.spp / secs),
        "mean_rgb": mean_rgb(bpy, out), "out": out,
    }
    print(json.dumps(res))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
