"""Writes the scenes that check the cross-check's environment map against `gi render`'s.

`python environment_test.py DIR` (with the cross-check's venv, for Mitsuba's EXR writer) writes
into DIR an asymmetric environment `env.exr` (red growing with u, green toward the top, a warm
"sun" at u = 0.3, v = 0.3 and a blue spot at u = 0.8, v = 0.2) and two scenes:
* `lit.gltf`: a floor and two walls lit only by it, whose shadows show where both spots are;
* `sky.gltf`: a camera looking at the sky (toward +X and +Z, 35 degrees up, the blue spot in
  view) past one tiny far triangle.
Then `bash scripts/crosscheck/run.sh DIR/lit.gltf+DIR/env.exr DIR/sky.gltf+DIR/env.exr` must
agree pixel by pixel (relMSE at the noise level): a wrong turn of Mitsuba's `envmap` moves the
spots, the shadows and the sky's gradients.
"""

from __future__ import annotations

import base64
import json
import sys
from pathlib import Path

import numpy as np


def main() -> int:
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    w, h = 256, 128
    u, v = np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h)
    image = np.zeros((h, w, 3), np.float32)
    image[..., 0] = 0.5 * u
    image[..., 1] = 0.5 * (1 - v)
    image[..., 2] = 0.1
    image[(np.abs(u - 0.3) < 0.02) & (np.abs(v - 0.3) < 0.03)] = [200, 150, 100]
    image[(np.abs(u - 0.8) < 0.03) & (np.abs(v - 0.2) < 0.03)] = [20, 40, 200]
    mi.Bitmap(image).write(str(out / "env.exr"))

    floor_and_walls = (
        [[-5, 0, -5], [5, 0, -5], [5, 0, 5], [-5, 0, 5], [0, 0, -1], [0, 0, 1], [0, 2, 1], [0, 2, -1]]
        + [[-2, 0, 2], [-1, 0, 2], [-1, 1, 2], [-2, 1, 2]],
        [0, 3, 2, 0, 2, 1, 4, 5, 6, 4, 6, 7, 8, 9, 10, 8, 10, 11],
    )
    # Camera above the floor, looking down toward the walls (a unit quaternion, x y z w).
    write_gltf(out / "lit.gltf", *floor_and_walls, [3, 4, 6], [-0.2599, 0.2007, 0.0502, 0.9432])
    tiny_far_triangle = ([[0, -100, 0], [0.01, -100, 0], [0, -100, 0.01]], [0, 1, 2])
    # Camera at the origin looking toward +X and +Z, 35 degrees up: the blue spot in view.
    write_gltf(out / "sky.gltf", *tiny_far_triangle, [0, 0, 0], [0.1151, -0.8811, 0.2778, 0.365])
    print(f"wrote {out}/env.exr, lit.gltf, sky.gltf")
    return 0


def write_gltf(path: Path, positions, indices, camera_position, camera_rotation) -> None:
    p = np.array(positions, np.float32)
    i = np.array(indices, np.uint32)
    blob = p.tobytes() + i.tobytes()
    document = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"mesh": 0},
            {"camera": 0, "translation": camera_position, "rotation": camera_rotation},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.01}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.6, 0.5, 1]}, "doubleSided": True}],
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5126,
                "count": len(p),
                "type": "VEC3",
                "min": p.min(axis=0).tolist(),
                "max": p.max(axis=0).tolist(),
            },
            {"bufferView": 1, "componentType": 5125, "count": len(i), "type": "SCALAR"},
        ],
        "bufferViews": [
            {"buffer": 0, "byteLength": p.nbytes},
            {"buffer": 0, "byteOffset": p.nbytes, "byteLength": i.nbytes},
        ],
        "buffers": [
            {
                "byteLength": len(blob),
                "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
            }
        ],
    }
    path.write_text(json.dumps(document))


if __name__ == "__main__":
    sys.exit(main())
