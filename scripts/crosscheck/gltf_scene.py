"""A small glTF 2.0 reader for the cross-check: the scene as `gi render` sees it, in world space.

It reads `.gltf` (external or `data:` URI buffers) and `.glb` files and follows the same rules as
the project's loader (host/src/scene/loader.rs):

* the default scene's root nodes (else the first scene's, else every node that is no child);
  node transforms are a `matrix` or translation x rotation x scale, composed down the hierarchy;
* triangle lists, strips and fans (same winding as the loader); points and lines are skipped;
* a mirrored node (negative determinant) keeps its object-space front face, so its world-space
  winding is reversed here;
* punctual lights (`KHR_lights_punctual`) with their photometric intensity divided by 683 lm/W
  (W/sr for point and spot lights, W/m^2 for directional ones); `range` is ignored;
* the camera of `gbuffer::scene_camera`: the first perspective camera in node order, else one
  looking at the centre of the scene's bounds from slightly above +Z at a 45 degree vertical FOV.

`write_glb_with_png_images` rewrites a .glb file with some images replaced by PNGs.
`write_flat_copy` writes the scene, baked to world space, as a new glTF without NORMAL attributes
and without shared vertices, so that the project's loader (which computes area-weighted smooth
normals for primitives without normals) ends up with flat normals.
"""

from __future__ import annotations

import base64
import json
import math
import struct
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote

import numpy as np

LUMENS_PER_WATT = 683.0
"""The project's conversion of glTF's photometric light units (host/src/scene/mod.rs)."""

DEFAULT_FOV_Y = math.pi / 4
"""Vertical FOV of the camera of a scene without cameras (host/src/gbuffer.rs)."""

_COMPONENT_TYPES = {
    5120: np.int8,
    5121: np.uint8,
    5122: np.int16,
    5123: np.uint16,
    5125: np.uint32,
    5126: np.float32,
}
_COMPONENT_COUNTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
_MODE_TRIANGLES, _MODE_STRIP, _MODE_FAN = 4, 5, 6


@dataclass
class Primitive:
    """One glTF primitive of one node, in world space."""

    name: str
    positions: np.ndarray  # (N, 3) float64
    normals: np.ndarray | None  # (N, 3) unit, or None when the file has none
    uvs: np.ndarray | None  # (N, 2) TEXCOORD_0, or None
    triangles: np.ndarray  # (T, 3) int64, counter-clockwise seen from the front
    material: int | None  # index into the file's materials; None: glTF's default material


@dataclass
class Light:
    """A punctual light in world space, in the project's radiometric units."""

    kind: str  # "point", "spot" or "directional"
    intensity: np.ndarray  # RGB: W/sr (point, spot) or W/m^2 (directional)
    position: np.ndarray
    direction: np.ndarray  # unit; the way the light shines (node's -Z)
    inner_cone_angle: float = 0.0
    outer_cone_angle: float = math.pi / 4
    node_matrix: np.ndarray = field(default_factory=lambda: np.eye(4))
    index: int = 0  # index into the file's KHR_lights_punctual lights


@dataclass
class Camera:
    """A pinhole camera the way `gi render` builds it: eye, unit forward and up, vertical FOV."""

    position: np.ndarray
    forward: np.ndarray
    up: np.ndarray
    yfov: float
    aspect_ratio: float | None  # the file's, if any (the render uses the image's aspect)
    node_matrix: np.ndarray | None = None  # None for the default camera
    index: int | None = None  # index into the file's cameras


@dataclass
class Scene:
    """What the cross-check needs of a glTF file."""

    document: Document
    primitives: list[Primitive]
    lights: list[Light]
    cameras: list[Camera]  # perspective cameras in node order

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corner of every triangle's vertices."""
        points = np.concatenate([p.positions[np.unique(p.triangles)] for p in self.primitives])
        return points.min(axis=0), points.max(axis=0)

    def camera(self) -> Camera:
        """The camera of `gbuffer::scene_camera`: the first one, else a view of the bounds."""
        if self.cameras:
            return self.cameras[0]
        low, high = self.bounds()
        center = 0.5 * (low + high)
        radius = max(0.5 * float(np.linalg.norm(high - low)), 1e-3)
        distance = radius / math.sin(0.5 * DEFAULT_FOV_Y)
        back = _normalize(np.array([0.0, 0.25, 1.0]))
        return Camera(center + back * distance, -back, np.array([0.0, 1.0, 0.0]), DEFAULT_FOV_Y, None)


class Document:
    """A parsed glTF file: its JSON and its buffers."""

    def __init__(self, path: Path):
        self.path = path
        data = path.read_bytes()
        binary_chunk = None
        if data[:4] == b"glTF":
            offset, chunks = 12, {}
            while offset + 8 <= len(data):
                length, kind = struct.unpack_from("<I4s", data, offset)
                chunks[kind] = data[offset + 8 : offset + 8 + length]
                offset += 8 + ((length + 3) & ~3)
            self.json = json.loads(chunks[b"JSON"])
            binary_chunk = chunks.get(b"BIN\x00")
        else:
            self.json = json.loads(data)
        self.buffers = [
            self.read_uri(b["uri"]) if "uri" in b else binary_chunk for b in self.json.get("buffers", [])
        ]

    def read_uri(self, uri: str) -> bytes:
        """The bytes of a `data:` URI or of a file relative to the glTF file."""
        if uri.startswith("data:"):
            return base64.b64decode(uri.split(",", 1)[1])
        return (self.path.parent / unquote(uri)).read_bytes()

    def buffer_view(self, index: int) -> bytes:
        view = self.json["bufferViews"][index]
        start = view.get("byteOffset", 0)
        return self.buffers[view["buffer"]][start : start + view["byteLength"]]

    def accessor(self, index: int) -> np.ndarray:
        """Accessor `index` as a (count, components) array; normalised integers become floats."""
        a = self.json["accessors"][index]
        if "sparse" in a:
            raise NotImplementedError(f"accessors[{index}]: sparse accessors are not supported")
        dtype = np.dtype(_COMPONENT_TYPES[a["componentType"]]).newbyteorder("<")
        n = _COMPONENT_COUNTS[a["type"]]
        if "bufferView" not in a:
            return np.zeros((a["count"], n))
        view = self.json["bufferViews"][a["bufferView"]]
        stride = view.get("byteStride") or dtype.itemsize * n
        values = np.ndarray(
            (a["count"], n),
            dtype=dtype,
            buffer=self.buffer_view(a["bufferView"]),
            offset=a.get("byteOffset", 0),
            strides=(stride, dtype.itemsize),
        )
        if a.get("normalized") and dtype.kind in "iu":
            return np.maximum(values / np.iinfo(dtype).max, -1.0)
        return values.astype(np.float64 if dtype.kind == "f" else np.int64)

    def image_bytes(self, index: int) -> bytes:
        image = self.json["images"][index]
        if "uri" in image:
            return self.read_uri(image["uri"])
        return self.buffer_view(image["bufferView"])


def load(path: Path) -> Scene:
    """Reads `path` and bakes its primitives, lights and cameras to world space."""
    doc = Document(path)
    j = doc.json
    scene = Scene(doc, [], [], [])
    if "scene" in j or j.get("scenes"):
        roots = j["scenes"][j.get("scene", 0)].get("nodes", [])
    else:
        children = {c for n in j.get("nodes", []) for c in n.get("children", [])}
        roots = [i for i in range(len(j.get("nodes", []))) if i not in children]
    for root in roots:
        _visit(doc, scene, root, np.eye(4))
    return scene


def _visit(doc: Document, scene: Scene, index: int, parent: np.ndarray) -> None:
    node = doc.json["nodes"][index]
    world = parent @ _local_matrix(node)
    if "mesh" in node:
        for p, prim in enumerate(doc.json["meshes"][node["mesh"]]["primitives"]):
            baked = _primitive(doc, prim, world, f"node {index} ({node.get('name', '')}) primitive {p}")
            if baked is not None:
                scene.primitives.append(baked)
    if "camera" in node:
        cam = doc.json["cameras"][node["camera"]]
        if cam["type"] == "perspective":
            scene.cameras.append(
                Camera(
                    world[:3, 3].copy(),
                    -_normalize(world[:3, 2]),
                    _normalize(world[:3, 1]),
                    cam["perspective"]["yfov"],
                    cam["perspective"].get("aspectRatio"),
                    world,
                    node["camera"],
                )
            )
    light_ref = node.get("extensions", {}).get("KHR_lights_punctual")
    if light_ref is not None:
        light = doc.json["extensions"]["KHR_lights_punctual"]["lights"][light_ref["light"]]
        spot = light.get("spot", {})
        scene.lights.append(
            Light(
                light["type"],
                np.array(light.get("color", [1.0, 1.0, 1.0])) * light.get("intensity", 1.0) / LUMENS_PER_WATT,
                world[:3, 3].copy(),
                _normalize(world[:3, :3] @ np.array([0.0, 0.0, -1.0])),
                spot.get("innerConeAngle", 0.0),
                spot.get("outerConeAngle", math.pi / 4),
                world,
                light_ref["light"],
            )
        )
    for child in node.get("children", []):
        _visit(doc, scene, child, world)


def _primitive(doc: Document, prim: dict, world: np.ndarray, name: str) -> Primitive | None:
    mode = prim.get("mode", _MODE_TRIANGLES)
    if mode not in (_MODE_TRIANGLES, _MODE_STRIP, _MODE_FAN):
        return None
    attributes = prim["attributes"]
    positions = doc.accessor(attributes["POSITION"])
    if "indices" in prim:
        indices = doc.accessor(prim["indices"])[:, 0]
    else:
        indices = np.arange(len(positions))
    triangles = _triangulate(mode, indices)
    if len(triangles) == 0:
        return None
    linear = world[:3, :3]
    positions = positions @ linear.T + world[:3, 3]
    normals = None
    if "NORMAL" in attributes:
        normals = doc.accessor(attributes["NORMAL"]) @ np.linalg.inv(linear)
        lengths = np.linalg.norm(normals, axis=1, keepdims=True)
        if not np.all(np.isfinite(normals)) or np.any(lengths == 0):
            raise ValueError(f"{name}: zero or non-finite normals are not supported")
        normals = normals / lengths
    if np.linalg.det(linear) < 0:
        triangles = triangles[:, ::-1]
    uvs = doc.accessor(attributes["TEXCOORD_0"]) if "TEXCOORD_0" in attributes else None
    return Primitive(name, positions, normals, uvs, np.ascontiguousarray(triangles), prim.get("material"))


def _triangulate(mode: int, indices: np.ndarray) -> np.ndarray:
    """Triangles of a list, strip or fan, with the winding of glTF (and of the project's loader)."""
    if mode == _MODE_TRIANGLES:
        return indices[: len(indices) // 3 * 3].reshape(-1, 3)
    count = max(len(indices) - 2, 0)
    i = np.arange(count)
    if mode == _MODE_STRIP:
        odd = i % 2 == 1
        first = np.where(odd, indices[i + 1], indices[i])
        second = np.where(odd, indices[i], indices[i + 1])
        return np.stack([first, second, indices[i + 2]], axis=1)
    return np.stack([indices[i + 1], indices[i + 2], np.full(count, indices[0])], axis=1)


def _local_matrix(node: dict) -> np.ndarray:
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T
    x, y, z, w = _normalize(np.array(node.get("rotation", [0.0, 0.0, 0.0, 1.0]), dtype=np.float64))
    rotation = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    m = np.eye(4)
    m[:3, :3] = rotation * np.array(node.get("scale", [1.0, 1.0, 1.0]))
    m[:3, 3] = node.get("translation", [0.0, 0.0, 0.0])
    return m


def _normalize(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def write_glb_with_png_images(document: Document, pngs: dict[int, bytes], path: Path) -> None:
    """Writes `document` (a .glb file with one buffer) to `path` with the images named in `pngs`
    replaced by those PNG bytes (appended to its binary chunk, the old bytes left unused)."""
    j = json.loads(json.dumps(document.json))
    if document.path.suffix.lower() != ".glb" or len(document.buffers) != 1:
        raise NotImplementedError(f"{document.path}: only .glb files with one buffer are rewritten")
    blob = bytearray(document.buffers[0])
    for index, png in pngs.items():
        blob.extend(b"\0" * (-len(blob) % 4))
        j["bufferViews"].append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(png)})
        blob.extend(png)
        image = j["images"][index]
        image.pop("uri", None)
        image.update({"bufferView": len(j["bufferViews"]) - 1, "mimeType": "image/png"})
    blob.extend(b"\0" * (-len(blob) % 4))
    j["buffers"][0]["byteLength"] = len(blob)
    text = json.dumps(j).encode()
    text += b" " * (-len(text) % 4)
    size = 12 + 8 + len(text) + 8 + len(blob)
    path.write_bytes(
        struct.pack("<4sII", b"glTF", 2, size)
        + struct.pack("<I4s", len(text), b"JSON")
        + text
        + struct.pack("<I4s", len(blob), b"BIN\x00")
        + bytes(blob)
    )


def write_flat_copy(scene: Scene, directory: Path) -> Path:
    """Writes `scene` baked to world space as `directory/scene.gltf`: one node per primitive,
    every triangle with its own three vertices and no NORMAL attribute (so flat normals in the
    project's loader), the same materials, textures (images copied beside it), cameras and
    lights (as nodes with their world matrices, cameras first in their original order)."""
    j = scene.document.json
    blob = bytearray()
    views, accessors, meshes, nodes = [], [], [], []

    def add_accessor(values: np.ndarray, kind: str, with_bounds: bool = False) -> int:
        data = np.ascontiguousarray(values, dtype="<f4")
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": data.nbytes})
        blob.extend(data.tobytes())
        accessor = {
            "bufferView": len(views) - 1,
            "componentType": 5126,
            "count": len(data),
            "type": kind,
        }
        if with_bounds:
            accessor["min"] = data.min(axis=0).tolist()
            accessor["max"] = data.max(axis=0).tolist()
        accessors.append(accessor)
        return len(accessors) - 1

    for prim in scene.primitives:
        corners = prim.triangles.reshape(-1)
        attributes = {"POSITION": add_accessor(prim.positions[corners], "VEC3", with_bounds=True)}
        if prim.uvs is not None:
            attributes["TEXCOORD_0"] = add_accessor(prim.uvs[corners], "VEC2")
        primitive = {"attributes": attributes, "mode": _MODE_TRIANGLES}
        if prim.material is not None:
            primitive["material"] = prim.material
        meshes.append({"name": prim.name, "primitives": [primitive]})
        nodes.append({"name": prim.name, "mesh": len(meshes) - 1})
    for camera in scene.cameras:
        nodes.append({"camera": camera.index, "matrix": camera.node_matrix.T.reshape(-1).tolist()})
    for light in scene.lights:
        nodes.append(
            {
                "matrix": light.node_matrix.T.reshape(-1).tolist(),
                "extensions": {"KHR_lights_punctual": {"light": light.index}},
            }
        )
    images = []
    for i, image in enumerate(j.get("images", [])):
        suffix = ".jpg" if image.get("mimeType") == "image/jpeg" else ".png"
        (directory / f"image{i}{suffix}").write_bytes(scene.document.image_bytes(i))
        images.append({"uri": f"image{i}{suffix}"})
    (directory / "scene.bin").write_bytes(bytes(blob))
    copy = {
        key: j[key]
        for key in (
            "asset",
            "extensionsUsed",
            "extensionsRequired",
            "extensions",
            "materials",
            "textures",
            "samplers",
            "cameras",
        )
        if key in j
    }
    copy.update(
        {
            "buffers": [{"uri": "scene.bin", "byteLength": len(blob)}],
            "bufferViews": views,
            "accessors": accessors,
            "meshes": meshes,
            "nodes": nodes,
            "scenes": [{"nodes": list(range(len(nodes)))}],
            "scene": 0,
        }
    )
    if images:
        copy["images"] = images
    path = directory / "scene.gltf"
    path.write_text(json.dumps(copy))
    return path
