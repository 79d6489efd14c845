"""Render a glTF scene with Blender Cycles (bpy, CPU) and print one JSON line with samples/s."""
# Usage, in a Python 3.11 venv with the `bpy` wheel from PyPI (5.0.1 here):
#   /tmp/cycles-venv/bin/python docs/peers/cycles.py --scene ../shared/scenes/cornell-box.gltf \
#       --spp 256 --warmup --out /tmp/cycles-box.exr
# The settings mirror `lucent render --max-depth 7 --rr-depth 5` (and Mitsuba max_depth 8):
# --max-depth and --rr-depth count scattering events as Lucent does; the mapping to Cycles'
# counters is in configure(). Time covers bpy.ops.render.render(write_still=True) only: Cycles'
# scene sync and BVH build, the render and the EXR write, not start-up or the glTF import.
# --warmup renders 1 spp first (not timed); --split also times a 1 spp render after it, to
# split the time into a fixed part and one per pass. The last line printed is one JSON object.
# The Khronos models of `lucent bench throughput` (256x256, 16 spp, --max-depth 7, Lucent's
# default roulette depth 3), from the repository root:
#   .../python docs/peers/cycles.py --scene tests/assets/MetalRoughSpheresNoTextures/glTF-Binary/\
#       MetalRoughSpheresNoTextures.glb --spp 16 --rr-depth 3 --warmup --out /tmp/mrs.exr
#   .../python docs/peers/cycles.py --scene tests/assets/ToyCar/glTF/ToyCar.gltf --camera 1 \
#       --env built-in --spp 16 --rr-depth 3 --warmup --out /tmp/toycar.exr
#   .../python docs/peers/cycles.py --scene tests/assets/WaterBottle/glTF/WaterBottle.gltf \
#       --env built-in --spp 16 --rr-depth 3 --warmup --out /tmp/bottle.exr
# The camera and the sky are placed as Lucent places them (see lucent_cameras, framing and
# add_environment); a scene without light of its own gets the built-in sky, as in Lucent.
# Materials are the importer's Principled BSDF: KHR_materials_sheen (Cycles' microfiber sheen,
# not glTF's Charlie lobe), clearcoat and transmission (a refracting interface, where glTF
# without KHR_materials_volume means a thin wall) differ from Lucent's; ToyCar shows all three.
import argparse
import json
import math
import os
import struct
import sys
import time

# This file is named like Blender's Cycles add-on (module `cycles`): keep its folder off the
# import path, or bpy would register this script instead of the add-on.
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:] = [p for p in sys.path if os.path.abspath(p or ".") != HERE]
# Lucent's built-in sky (`--env built-in`): this map, embedded in its binary.
BUILT_IN_SKY = os.path.join(HERE, "..", "..", "assets", "venice_sunset_1k.hdr")


def read_gltf_json(path):
    """The JSON part of a .gltf or .glb file."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] == b"glTF":
        length, kind = struct.unpack_from("<II", data, 12)
        assert kind == 0x4E4F534A, "first GLB chunk is not JSON"
        return json.loads(data[20:20 + length])
    return json.loads(data)


def node_matrix(Matrix, Quaternion, node):
    if "matrix" in node:
        m = node["matrix"]  # column-major
        return Matrix([[m[c * 4 + r] for c in range(4)] for r in range(4)])
    t = node.get("translation", [0, 0, 0])
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    s = node.get("scale", [1, 1, 1])
    scale = Matrix.Diagonal((s[0], s[1], s[2], 1.0))
    return Matrix.Translation(t) @ Quaternion((w, x, y, z)).to_matrix().to_4x4() @ scale


def lucent_cameras(doc):
    """The file's perspective cameras in Lucent's order (src/loader/gltf.rs): a depth-first
    walk of the default scene with a stack, so the last root node and the last child come
    first. Each as (name, world rotation+translation in glTF space without scale, yfov)."""
    from mathutils import Matrix, Quaternion
    scenes = doc.get("scenes", [])
    if not scenes:
        return []
    nodes = doc.get("nodes", [])
    stack = [(n, Matrix.Identity(4)) for n in scenes[doc.get("scene", 0)].get("nodes", [])]
    out = []
    while stack:
        i, parent = stack.pop()
        node = nodes[i]
        world = parent @ node_matrix(Matrix, Quaternion, node)
        if "camera" in node:
            cam = doc["cameras"][node["camera"]]
            if cam.get("type") == "perspective":
                t, r, _ = world.decompose()
                m = Matrix.Translation(t) @ r.normalized().to_matrix().to_4x4()
                out.append((cam.get("name", "camera"), m, cam["perspective"]["yfov"]))
        stack.extend((c, world) for c in node.get("children", []))
    return out


def has_own_light(doc):
    """Lucent's Scene::has_own_light: a punctual light, or a used material with untextured
    emission (emissive textures alone decorate a model: Lucent then adds its built-in sky)."""
    if any("KHR_lights_punctual" in n.get("extensions", {}) for n in doc.get("nodes", [])):
        return True
    used = {p.get("material") for m in doc.get("meshes", []) for p in m.get("primitives", [])}
    for i, m in enumerate(doc.get("materials", [])):
        ext = m.get("extensions", {})
        strength = ext.get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
        lamp = max(m.get("emissiveFactor", [0, 0, 0])) * strength > 0 and "emissiveTexture" not in m
        if i in used and lamp and "KHR_materials_unlit" not in ext:
            return True
    return False


# glTF (x, y, z) is Blender (x, -z, y) (the importer's conversion; y up becomes z up).
def gltf_to_blender(Matrix):
    return Matrix(((1, 0, 0, 0), (0, 0, -1, 0), (0, 1, 0, 0), (0, 0, 0, 1)))


def framing(bpy, scene):
    """Lucent's camera for a file without one (Camera::framing): yfov 0.8, looking at the
    centre of the triangles' bounds from its +z side (glTF), 20 degrees above the horizon,
    far enough that the bounds' sphere fits in the field of view (vertical, or horizontal
    if the image is taller than wide). Returns (glTF-space matrix, yfov)."""
    import numpy as np
    from mathutils import Matrix, Vector
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for ob in scene.objects:
        if ob.type != "MESH" or not ob.data.polygons:
            continue
        co = np.empty(len(ob.data.vertices) * 3)
        ob.data.vertices.foreach_get("co", co)
        m = np.array(ob.matrix_world)
        w = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
        lo, hi = np.minimum(lo, w.min(0)), np.maximum(hi, w.max(0))
    # Back to glTF space: x = X, y = Z, z = -Y.
    lo, hi = np.array([lo[0], lo[2], -hi[1]]), np.array([hi[0], hi[2], -lo[1]])
    yfov, aspect = 0.8, scene.render.resolution_x / scene.render.resolution_y
    center = Vector(0.5 * (lo + hi))
    radius = max(0.5 * float(np.linalg.norm(hi - lo)), 1e-38)
    half = 0.5 * min(yfov, 2.0 * math.atan(math.tan(0.5 * yfov) * aspect))
    distance = radius / math.sin(half)
    eye = center + Vector((0.0, math.sin(math.radians(20)), math.cos(math.radians(20)))) * distance
    forward = (center - eye).normalized()
    up = Vector((0, 1, 0)) if forward.cross(Vector((0, 1, 0))).length_squared >= 1e-8 else Vector((0, 0, 1))
    right = forward.cross(up).normalized()
    up = right.cross(forward)
    rot = Matrix((right, up, -forward)).transposed()  # columns right, up, -forward
    return Matrix.Translation(eye) @ rot.to_4x4(), yfov


def place_camera(bpy, scene, doc, index):
    """A camera where Lucent's is: the file's camera number `index` in Lucent's order, or
    Lucent's framing camera if the file has none. Lucent keeps the glTF yfov as the vertical
    field of view at any image aspect and ignores the camera's aspectRatio, as Blender's
    importer does (sensor fit vertical)."""
    from mathutils import Matrix
    cams = lucent_cameras(doc)
    if cams:
        if index >= len(cams):
            sys.exit(f"camera {index}: the file has {len(cams)} cameras")
        name, m, yfov = cams[index]
    else:
        if index:
            sys.exit(f"camera {index}: the file has no cameras")
        name, (m, yfov) = "framing", framing(bpy, scene)
    data = bpy.data.cameras.new("lucent-camera")
    data.type, data.sensor_fit, data.angle_y = "PERSP", "VERTICAL", yfov
    data.shift_x = data.shift_y = 0.0
    ob = bpy.data.objects.new("lucent-camera", data)
    scene.collection.objects.link(ob)
    ob.matrix_world = gltf_to_blender(Matrix) @ m  # both cameras look along local -z, +y up
    # Lucent has no clipping planes; these models are centimetres to metres across.
    data.clip_start, data.clip_end = 1e-6, 1e6
    scene.camera = ob
    return name


def add_environment(bpy, scene, path, strength=1.0):
    """A world of the equirectangular map at `path`, seen as Lucent sees it. Lucent (glTF
    space, y up): u = 0.5 + atan2(x, -z) / 2pi, v = acos(y) / pi, so the map's centre column
    lies along -z and u grows towards +x. In Blender space that is: centre along +Y, u
    growing towards +X. Cycles' equirectangular lookup puts u = 0.5 at +X and u grows
    towards -Y, so the direction is turned -90 degrees about Z first (+Y to +X, +X to -Y)."""
    world = bpy.data.worlds.new("lucent-sky")
    if world.node_tree is None:  # Blender before 5.0 (5.0 gives every world nodes)
        world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    nodes.clear()
    coord = nodes.new("ShaderNodeTexCoord")
    mapping = nodes.new("ShaderNodeMapping")
    mapping.vector_type = "VECTOR"
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, -math.pi / 2)
    tex = nodes.new("ShaderNodeTexEnvironment")
    tex.image = bpy.data.images.load(os.path.abspath(path), check_existing=True)
    tex.image.colorspace_settings.name = "Linear Rec.709"
    tex.projection, tex.interpolation = "EQUIRECTANGULAR", "Linear"  # Lucent: bilinear
    bg = nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = strength
    out = nodes.new("ShaderNodeOutputWorld")
    links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
    links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    links.new(tex.outputs["Color"], bg.inputs["Color"])
    links.new(bg.outputs["Background"], out.inputs["Surface"])
    # Importance sampling by a map of the texels' resolution, as Lucent's (1024x512 for the
    # built-in sky). "AUTOMATIC" would build a 4096x2048 one (the same image as MANUAL 4096),
    # which costs 0.85 s of every render call on 2 threads.
    world.cycles.sampling_method = "MANUAL"
    world.cycles.sample_map_resolution = max(tex.image.size[0], 4)
    scene.world = world


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
    # min_light_bounces = rr_depth - 2 starts both after the same event. (Both survive with
    # sqrt(max throughput); Lucent's includes eta^2 and is capped at 0.995.)
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
    ap.add_argument("--camera", type=int, default=0,
                    help="the file's camera number N, 0-based, in Lucent's order (its --camera)")
    ap.add_argument("--env", help="equirectangular map lighting the scene (.hdr/.exr), `built-in` "
                    "for Lucent's sky, or `none`; default: the built-in sky if the scene has no "
                    "light of its own, as in Lucent")
    ap.add_argument("--env-intensity", type=float, default=1.0)
    ap.add_argument("--warmup", action="store_true")
    ap.add_argument("--split", action="store_true",
                    help="after the timed render, time a 1 spp render too, to split the time into "
                    "a fixed part (sync, BVH build, EXR write) and one per pass of samples")
    ap.add_argument("--out", required=True, help="output .exr (linear float32 RGB)")
    a = ap.parse_args()

    stages = {}
    t = time.perf_counter()
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    stages["import_bpy"], t = time.perf_counter() - t, time.perf_counter()
    bpy.ops.import_scene.gltf(filepath=os.path.abspath(a.scene))
    scene = bpy.context.scene
    doc = read_gltf_json(a.scene)
    tidy_materials(bpy)
    configure(bpy, scene, a)  # sets the resolution, which the framing camera needs
    camera = place_camera(bpy, scene, doc, a.camera)
    env = a.env or ("none" if has_own_light(doc) else "built-in")
    if env != "none":
        add_environment(bpy, scene, BUILT_IN_SKY if env == "built-in" else env, a.env_intensity)

    stages["import_gltf_and_setup"], t = time.perf_counter() - t, time.perf_counter()
    if a.warmup:
        scene.cycles.samples = 1
        bpy.ops.render.render(write_still=False)
        scene.cycles.samples = a.spp
        stages["warmup_1spp"] = time.perf_counter() - t
    out = os.path.abspath(a.out)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    scene.render.filepath = out
    t0, c0 = time.perf_counter(), time.process_time()
    bpy.ops.render.render(write_still=True)
    secs, cpu = time.perf_counter() - t0, time.process_time() - c0
    stages["render"] = secs
    split = {}
    if a.split and a.spp > 1:
        # The same render at 1 spp (to a scratch file): T(1) = fixed + pass, T(spp) = fixed +
        # spp * pass. Cycles re-syncs the scene and rebuilds the BVH for every render call.
        scene.cycles.samples, scene.render.filepath = 1, out + ".1spp.exr"
        t = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        one = time.perf_counter() - t
        os.remove(out + ".1spp.exr")
        per_pass = (secs - one) / (a.spp - 1)
        split = {"one_spp_seconds": round(one, 4), "fixed_seconds": round(one - per_pass, 4),
                 "pass_seconds": round(per_pass, 5),
                 "pass_samples_per_sec": round(a.width * a.height / per_pass) if per_pass > 0 else None}
        scene.cycles.samples, scene.render.filepath = a.spp, out

    c = scene.cycles
    res = {
        "renderer": "cycles", "version": bpy.app.version_string, "scene": os.path.basename(a.scene),
        "camera": camera, "env": env,
        "width": a.width, "height": a.height, "spp": a.spp, "threads": scene.render.threads,
        "max_depth": a.max_depth, "max_bounces": c.max_bounces,
        "min_light_bounces": c.min_light_bounces,
        "light_tree": c.use_light_tree, "sampling_pattern": c.sampling_pattern, "seed": a.seed,
        "filter": [c.pixel_filter_type, c.filter_width], "seconds": round(secs, 4),
        "cpu_seconds": round(cpu, 4), "samples_per_sec": round(a.width * a.height * a.spp / secs),
        **split, "stages": {k: round(v, 4) for k, v in stages.items()},
        "mean_rgb": mean_rgb(bpy, out), "out": out,
    }
    print(json.dumps(res))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
