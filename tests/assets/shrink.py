#!/usr/bin/env python3
"""Downscales the textures of glTF models to at most 256 px on a side, in place.

Usage: python3 tests/assets/shrink.py MODEL.gltf|MODEL.glb[:I,J,...] ...

With :I,J,... only the images of those indices (in the model's "images") are shrunk;
without, all of them. Each image keeps its format (PNG or JPEG), its file name and, for
PNG, its colour type, so a .gltf file is unchanged. A .glb is rewritten with its embedded
images shrunk and its buffer views moved to fit; nothing else in it changes. Needs
ImageMagick's mogrify. This is how the reduced models in tests/assets/INDEX.md were made
from the upstream files.
"""

import json
import os
import struct
import subprocess
import sys
import tempfile

SIZE = "256x256>"


def shrink_image(path):
    """Resizes one PNG or JPEG file in place (only if it is larger than SIZE)."""
    with open(path, "rb") as f:
        head = f.read(26)
    if head.startswith(b"\x89PNG"):
        options = ["-define", f"png:color-type={head[25]}", "-define", "png:bit-depth=8"]
    else:
        options = ["-type", "TrueColor", "-quality", "90"]
    # -strip drops metadata, the creation dates included, so the output is reproducible.
    subprocess.run(["mogrify", "-strip", "-resize", SIZE, *options, path], check=True)


def shrink_gltf(path, chosen):
    with open(path) as f:
        doc = json.load(f)
    for i, image in enumerate(doc.get("images", [])):
        uri = image.get("uri", "")
        if chosen(i) and uri and not uri.startswith("data:"):
            shrink_image(os.path.join(os.path.dirname(path), uri))


def pad4(data, byte):
    return data + byte * (-len(data) % 4)


def shrink_glb(path, chosen):
    with open(path, "rb") as f:
        glb = f.read()
    json_len = struct.unpack_from("<I", glb, 12)[0]
    doc = json.loads(glb[20 : 20 + json_len])
    bin_start = 20 + json_len + 8
    bin_len = struct.unpack_from("<I", glb, 20 + json_len)[0]
    blob = glb[bin_start : bin_start + bin_len]
    views = [bytes(blob[v.get("byteOffset", 0) : v.get("byteOffset", 0) + v["byteLength"]]) for v in doc["bufferViews"]]
    with tempfile.TemporaryDirectory() as tmp:
        for i, image in enumerate(doc.get("images", [])):
            if not chosen(i) or "bufferView" not in image:
                continue
            name = os.path.join(tmp, f"{i}.{'png' if image['mimeType'] == 'image/png' else 'jpg'}")
            with open(name, "wb") as f:
                f.write(views[image["bufferView"]])
            shrink_image(name)
            with open(name, "rb") as f:
                views[image["bufferView"]] = f.read()
    out = b""
    for view, data in zip(doc["bufferViews"], views):
        view["byteOffset"] = len(out)
        view["byteLength"] = len(data)
        out = pad4(out + data, b"\0")
    doc["buffers"][0]["byteLength"] = len(out)
    text = pad4(json.dumps(doc, separators=(",", ":")).encode(), b" ")
    chunks = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(out), 0x004E4942) + out
    with open(path, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, 12 + len(chunks)) + chunks)


for arg in sys.argv[1:]:
    model, _, indices = arg.partition(":")
    picked = {int(i) for i in indices.split(",") if i}
    (shrink_glb if model.endswith(".glb") else shrink_gltf)(model, lambda i: not picked or i in picked)
