#!/usr/bin/env python3
"""Writes the small glTF files of host/tests/scene_loading.rs and tests/tests/tracing.rs (Python 3
standard library only).

    python3 tests/data/generate.py

Each file is a one- or few-triangle document, mostly with its buffer embedded as a base64 data:
URI so that it stands alone; the files under bad/ each break one thing (their names say which).
Running it again gives the same bytes.
"""

import base64
import json
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
FLOAT, USHORT = 5126, 5123


def data_uri(data):
    return "data:application/octet-stream;base64," + base64.b64encode(data).decode("ascii")


def document(positions, indices=None, mode=None, uri=None, extra_buffer=b"", uvs=None):
    """A document with one mesh "tri" of one primitive, placed by one node in one scene.

    positions: list of (x, y, z); indices: list of ints (u16) or None; uri: buffer URI (default:
    embedded). Bounds are computed over the finite positions (JSON has no NaN).
    """
    data = struct.pack("<%df" % (3 * len(positions)), *[c for p in positions for c in p])
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": len(data)}]
    finite = [p for p in positions if all(math.isfinite(c) for c in p)] or [(0, 0, 0)]
    accessors = [{"bufferView": 0, "componentType": FLOAT, "count": len(positions), "type": "VEC3",
                  "min": [min(p[i] for p in finite) for i in range(3)],
                  "max": [max(p[i] for p in finite) for i in range(3)]}]
    primitive = {"attributes": {"POSITION": 0}}
    if uvs is not None:
        uv_data = struct.pack("<%df" % (2 * len(uvs)), *[c for uv in uvs for c in uv])
        views.append({"buffer": 0, "byteOffset": len(data), "byteLength": len(uv_data)})
        accessors.append({"bufferView": len(views) - 1, "componentType": FLOAT,
                          "count": len(uvs), "type": "VEC2"})
        primitive["attributes"]["TEXCOORD_0"] = len(accessors) - 1
        data += uv_data
    if indices is not None:
        index_data = struct.pack("<%dH" % len(indices), *indices)
        index_data += b"\0" * (-len(index_data) % 4)
        views.append({"buffer": 0, "byteOffset": len(data), "byteLength": 2 * len(indices)})
        accessors.append({"bufferView": len(views) - 1, "componentType": USHORT,
                          "count": len(indices), "type": "SCALAR"})
        primitive["indices"] = len(accessors) - 1
        data += index_data
    if mode is not None:
        primitive["mode"] = mode
    data += extra_buffer
    buffer = {"byteLength": len(data), "uri": uri or data_uri(data)}
    return {
        "asset": {"version": "2.0", "generator": "gi tests/data/generate.py"},
        "scene": 0,
        "scenes": [{"name": "scene", "nodes": [0]}],
        "nodes": [{"name": "node", "mesh": 0}],
        "meshes": [{"name": "tri", "primitives": [primitive]}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [buffer],
    }


TRIANGLE = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]


def write(name, doc):
    path = os.path.join(HERE, name)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        if isinstance(doc, str):
            f.write(doc)
        else:
            json.dump(doc, f, indent=1)
            f.write("\n")


def mirrored_scene():
    """Instances whose transforms mirror (negative determinant) beside ones that do not: a closed
    cube and an open, asymmetric fan, for the tracing agreement test (front faces of mirrored
    instances) in tests/tests/tracing.rs."""
    cube = [(x, y, z) for z in (-1.0, 1.0) for y in (-1.0, 1.0) for x in (-1.0, 1.0)]
    quads = [(0, 4, 6, 2), (1, 3, 7, 5), (0, 1, 5, 4), (2, 6, 7, 3), (0, 2, 3, 1), (4, 5, 7, 6)]
    cube_indices = [i for a, b, c, d in quads for i in (a, b, c, a, c, d)]
    fan = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.2), (0.8, 0.9, -0.3), (-0.2, 1.2, 0.4), (-1.1, 0.3, 0.1)]
    fan_indices = [0, 1, 2, 0, 2, 3, 0, 3, 4]
    data = b""
    views, accessors = [], []
    for positions, indices in ((cube, cube_indices), (fan, fan_indices)):
        p = struct.pack("<%df" % (3 * len(positions)), *[c for v in positions for c in v])
        i = struct.pack("<%dH" % len(indices), *indices)
        i += b"\0" * (-len(i) % 4)
        views.append({"buffer": 0, "byteOffset": len(data), "byteLength": len(p)})
        accessors.append({"bufferView": len(views) - 1, "componentType": FLOAT,
                          "count": len(positions), "type": "VEC3",
                          "min": [min(v[k] for v in positions) for k in range(3)],
                          "max": [max(v[k] for v in positions) for k in range(3)]})
        data += p
        views.append({"buffer": 0, "byteOffset": len(data), "byteLength": 2 * len(indices)})
        accessors.append({"bufferView": len(views) - 1, "componentType": USHORT,
                          "count": len(indices), "type": "SCALAR"})
        data += i
    s = math.sqrt(0.5)
    nodes = [
        {"name": "cube", "mesh": 0, "translation": [-3, 0, 0]},
        {"name": "cube mirrored in x", "mesh": 0, "translation": [0, 0, 0], "scale": [-1, 1, 1]},
        {"name": "cube mirrored in y, turned", "mesh": 0, "translation": [3, 0, 0],
         "rotation": [0, 0, s, s], "scale": [1, -1.5, 1]},
        {"name": "cube mirrored in all three", "mesh": 0, "translation": [0, 3, 0],
         "scale": [-1, -1, -1]},
        {"name": "cube mirrored twice", "mesh": 0, "translation": [0, -3, 0],
         "scale": [-1, -1, 1]},
        {"name": "fan", "mesh": 1, "translation": [-2, 2, 2], "scale": [2, 2, 2]},
        {"name": "fan mirrored in z", "mesh": 1, "translation": [2, -2, 2], "scale": [2, 2, -2]},
        {"name": "fan under a mirrored parent", "scale": [1, 1, -1], "translation": [0, 0, -2],
         "children": [8]},
        {"name": "fan child", "mesh": 1, "rotation": [s, 0, 0, s], "scale": [3, 3, 3]},
    ]
    return {
        "asset": {"version": "2.0", "generator": "gi tests/data/generate.py"},
        "scene": 0,
        "scenes": [{"name": "scene", "nodes": [0, 1, 2, 3, 4, 5, 6, 7]}],
        "nodes": nodes,
        "meshes": [{"name": "cube", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]},
                   {"name": "fan", "primitives": [{"attributes": {"POSITION": 2}, "indices": 3}]}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(data), "uri": data_uri(data)}],
    }


def main():
    write("mirrored.gltf", mirrored_scene())

    # Positive: a hierarchy whose vertex (1, 0, 0) lands at known world positions.
    doc = document(TRIANGLE, [0, 1, 2])
    s = math.sqrt(0.5)
    doc["nodes"] = [
        {"name": "parent", "translation": [10, 0, 0], "scale": [2, 2, 2], "children": [1]},
        {"name": "child", "rotation": [0, 0, s, s], "mesh": 0, "children": [2]},
        {"name": "grandchild", "mesh": 0,
         "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 5, 1]},
    ]
    write("transforms.gltf", doc)

    # Bad input, one fault each.
    write("bad/malformed-json.gltf",
          '{"asset": {"version": "2.0"}, "meshes": [{"primitives": [{"attributes": {"POSITION"\n')

    write("bad/missing-bin.gltf", document(TRIANGLE, [0, 1, 2], uri="missing.bin"))

    doc = document(TRIANGLE, [0, 1, 2])
    doc["accessors"][0]["count"] = 4  # 48 bytes from a 36-byte view
    write("bad/accessor-out-of-range.gltf", doc)

    doc = document(TRIANGLE, [0, 1, 2])
    doc["meshes"][0]["primitives"][0]["indices"] = 7  # there are 2 accessors
    write("bad/accessor-reference-out-of-range.gltf", doc)

    write("bad/index-out-of-range.gltf", document(TRIANGLE, [0, 1, 5]))

    nan, inf = float("nan"), float("inf")
    write("bad/nan-positions.gltf", document(TRIANGLE + [
        (0.0, 0.0, 1.0), (nan, 0.0, 1.0), (0.0, 1.0, 1.0),
        (0.0, 0.0, 2.0), (1.0, 0.0, 2.0), (0.0, -inf, 2.0),
    ]))

    write("bad/degenerate-triangles.gltf", document(
        TRIANGLE + [(2.0, 0.0, 0.0), (0.0, 0.0, 1.0)],
        # good, repeated vertex, collinear (0, 1, 3 on the x axis), good
        [0, 1, 2, 0, 0, 2, 0, 1, 3, 0, 4, 1]))

    write("bad/no-triangles.gltf", document(TRIANGLE, mode=0))  # POINTS

    doc = document(TRIANGLE, [0, 1, 2], uvs=[(0, 0), (1, 0), (0, 1)])
    doc["images"] = [{"uri": "missing.png"}]
    doc["textures"] = [{"source": 0}]
    doc["materials"] = [{"name": "checker", "pbrMetallicRoughness": {
        "baseColorFactor": [0.5, 0.25, 1.0, 1.0], "baseColorTexture": {"index": 0}}}]
    doc["meshes"][0]["primitives"][0]["material"] = 0
    write("bad/missing-texture.gltf", doc)

    doc = document(TRIANGLE, [0, 1, 2])
    doc["extensionsUsed"] = ["KHR_draco_mesh_compression"]
    doc["extensionsRequired"] = ["KHR_draco_mesh_compression"]
    write("bad/unsupported-required-extension.gltf", doc)

    # A GLB whose header claims more bytes than the file holds.
    with open(os.path.join(HERE, "bad", "truncated.glb"), "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, 4096) + struct.pack("<I4s", 2, b"JSON") + b"{}")


if __name__ == "__main__":
    main()
