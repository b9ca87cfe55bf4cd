"""Compares how `gi` and Mitsuba decode each texture of a glTF scene, through their renderers.

`~/.cache/gi/crosscheck-venv/bin/python scripts/crosscheck/texture_means.py GI SCENE OUT` puts each
image of SCENE on a square that fills the view (written as OUT/tex<i>.gltf), renders it with
`GI gbuffer` (the albedo image: linear albedo in 8 bits, sRGB-encoded in the PNG) and with
Mitsuba's `albedo` AOV through crosscheck.py's conversion, both 512 pixels square, and prints
ours / Mitsuba per channel of the image's mean albedo. The 8-bit G-buffer limits it to about 0.1%
(more in dark channels).
"""

from __future__ import annotations

import base64
import json
import math
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

import crosscheck
import gltf_scene

SIZE = 512
"""Image width and height of both renders."""


def main() -> int:
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    gi, scene_path, out = Path(sys.argv[1]).resolve(), Path(sys.argv[2]), Path(sys.argv[3])
    out.mkdir(parents=True, exist_ok=True)
    document = gltf_scene.Document(scene_path)
    for i, image in enumerate(document.json.get("images", [])):
        name = image.get("name", f"image {i}")
        data = document.image_bytes(i)
        suffix = ".jpg" if data[:2] == b"\xff\xd8" else ".png"
        image_file = out / f"tex{i}{suffix}"
        image_file.write_bytes(data)
        path = out / f"tex{i}.gltf"
        path.write_text(json.dumps(square_scene(image_file.name)))
        gbuffer = out / f"gbuffer{i}"
        subprocess.run(
            ["nice", "-n", "10", str(gi), "gbuffer", str(path), "--width", str(SIZE), "--height", str(SIZE),
             "--out", str(gbuffer)],
            check=True,
            capture_output=True,
        )  # fmt: skip
        encoded = np.array(mi.Bitmap(str(gbuffer / "albedo.png")), dtype=np.float64)[..., :3] / 255.0
        ours = np.where(encoded <= 0.04045, encoded / 12.92, ((encoded + 0.055) / 1.055) ** 2.4)
        scene = gltf_scene.load(path)
        settings = SimpleNamespace(max_bounces=1, mitsuba_bsdf="diffuse", alpha="opaque")
        d, _ = crosscheck.mitsuba_dict(mi, scene, scene.camera(), None, SIZE, SIZE, settings)
        d["integrator"] = {"type": "aov", "aovs": "albedo:albedo"}
        theirs = np.array(mi.render(mi.load_dict(d), spp=4), dtype=np.float64)[..., -3:]
        ratio = ours.mean(axis=(0, 1)) / theirs.mean(axis=(0, 1))
        print(f"{name:32s} ours / Mitsuba (R, G, B): {np.round(ratio, 4)}", flush=True)
    return 0


def square_scene(image_uri: str) -> dict:
    """A 2 x 2 square at z = 0 with the image (row 0 at the top), seen from z = 10 so that it
    fills a square view."""
    positions = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
    uvs = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
    indices = np.array([0, 1, 2, 0, 2, 3], np.uint32)
    blob = positions.tobytes() + uvs.tobytes() + indices.tobytes()
    return {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 10]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 2 * math.atan(0.1), "znear": 0.01}}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}
        ],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}, "doubleSided": True}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"wrapS": 10497, "wrapT": 10497}],
        "images": [{"uri": image_uri}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0],
             "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5125, "count": 6, "type": "SCALAR"},
        ],  # fmt: skip
        "bufferViews": [
            {"buffer": 0, "byteLength": positions.nbytes},
            {"buffer": 0, "byteOffset": positions.nbytes, "byteLength": uvs.nbytes},
            {"buffer": 0, "byteOffset": positions.nbytes + uvs.nbytes, "byteLength": indices.nbytes},
        ],
        "buffers": [
            {
                "byteLength": len(blob),
                "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
            }
        ],
    }


if __name__ == "__main__":
    sys.exit(main())
