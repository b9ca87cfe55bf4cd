#!/usr/bin/env python3
"""Writes the project's own glTF 2.0 test scenes into this folder (Python 3 standard library only).

    python3 scenes/generate.py

Outputs (deterministic: running it again gives the same bytes):
  cornell-box.gltf + cornell-box.bin, and the same scene as cornell-box.glb
  indirect-room.gltf (buffer embedded as a base64 data: URI)
  many-lights.gltf + many-lights.bin
  textured.gltf + textured.bin + checker.png
  light-leak.gltf (buffer embedded)
  moving-box.gltf (buffer embedded; a node animation)
See README.md beside this script for what each scene holds.
"""

import base64
import colorsys
import json
import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))

# glTF constants.
FLOAT, UBYTE, USHORT, UINT = 5126, 5121, 5123, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
TRIANGLES, TRIANGLE_STRIP = 4, 5
REPEAT = 10497
LINEAR, LINEAR_MIPMAP_LINEAR = 9729, 9987

# Photometric units of KHR_lights_punctual: the loader divides by this to get W/sr and W/m².
LUMENS_PER_WATT = 683.0


def r6(x):
    """Rounds for stable, compact JSON (and normalises -0.0)."""
    return round(x, 6) + 0.0


# --- vector helpers -------------------------------------------------------------------------

def add(a, b):
    return [a[i] + b[i] for i in range(3)]


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def mul(a, s):
    return [x * s for x in a]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def normalize(a):
    n = math.sqrt(sum(x * x for x in a))
    return [x / n for x in a]


def quat_from_axes(right, up, back):
    """Unit quaternion [x, y, z, w] of the rotation whose columns are right, up, back."""
    m00, m01, m02 = right[0], up[0], back[0]
    m10, m11, m12 = right[1], up[1], back[1]
    m20, m21, m22 = right[2], up[2], back[2]
    trace = m00 + m11 + m22
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = [(m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s]
    elif m00 > m11 and m00 > m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        q = [0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s]
    elif m11 > m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        q = [(m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
        q = [(m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s]
    return [r6(x) for x in q]


def look_at(eye, target, up=(0.0, 1.0, 0.0)):
    """Rotation of a glTF camera or light (which look down local -Z) at eye, facing target."""
    forward = normalize(sub(target, eye))
    right = normalize(cross(forward, list(up)))
    true_up = cross(right, forward)
    return quat_from_axes(right, true_up, mul(forward, -1.0))


def quat_axis_angle(axis, degrees):
    axis = normalize(axis)
    half = math.radians(degrees) / 2.0
    s = math.sin(half)
    return [r6(axis[0] * s), r6(axis[1] * s), r6(axis[2] * s), r6(math.cos(half))]


# --- geometry -------------------------------------------------------------------------------

class Geometry:
    """Vertices with normals (and optionally UVs) plus triangle indices."""

    def __init__(self):
        self.positions, self.normals, self.uvs, self.indices = [], [], [], []

    def quad(self, center, u, v, uv_scale=(1.0, 1.0)):
        """A rectangle center ± u ± v, facing u × v (counter-clockwise seen from the front)."""
        normal = normalize(cross(u, v))
        base = len(self.positions)
        corners = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
        for su, sv in corners:
            self.positions.append(add(center, add(mul(u, su), mul(v, sv))))
            self.normals.append(normal)
            self.uvs.append([(su + 1) / 2 * uv_scale[0], (1 - sv) / 2 * uv_scale[1]])
        self.indices += [base, base + 1, base + 2, base, base + 2, base + 3]
        return self

    def box(self, center, half):
        """An axis-aligned box, faces outward."""
        cx, cy, cz = center
        hx, hy, hz = half
        self.quad([cx + hx, cy, cz], [0, 0, -hz], [0, hy, 0])  # +X
        self.quad([cx - hx, cy, cz], [0, 0, hz], [0, hy, 0])  # -X
        self.quad([cx, cy + hy, cz], [hx, 0, 0], [0, 0, -hz])  # +Y
        self.quad([cx, cy - hy, cz], [hx, 0, 0], [0, 0, hz])  # -Y
        self.quad([cx, cy, cz + hz], [hx, 0, 0], [0, hy, 0])  # +Z
        self.quad([cx, cy, cz - hz], [-hx, 0, 0], [0, hy, 0])  # -Z
        return self


def unit_box():
    return Geometry().box([0, 0, 0], [0.5, 0.5, 0.5])


# --- document -------------------------------------------------------------------------------

class Document:
    def __init__(self, generator_note):
        self.bin = bytearray()
        self.gltf = {
            "asset": {"version": "2.0", "generator": "gi scenes/generate.py"},
            "extras": {"note": generator_note},
            "scene": 0,
            "scenes": [{"name": "Scene", "nodes": []}],
            "nodes": [],
            "meshes": [],
            "materials": [],
            "accessors": [],
            "bufferViews": [],
            "buffers": [],
        }
        self.used = set()

    def _view(self, data, target):
        while len(self.bin) % 4:
            self.bin.append(0)
        view = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            view["target"] = target
        self.bin += data
        self.gltf["bufferViews"].append(view)
        return len(self.gltf["bufferViews"]) - 1

    def _accessor(self, data, component, count, kind, target, bounds=None):
        accessor = {"bufferView": self._view(data, target), "componentType": component,
                    "count": count, "type": kind}
        if bounds:
            accessor["min"], accessor["max"] = bounds
        self.gltf["accessors"].append(accessor)
        return len(self.gltf["accessors"]) - 1

    def floats(self, rows, kind, with_bounds=False, target=ARRAY_BUFFER):
        flat = [float(x) for row in rows for x in row]
        bounds = None
        if with_bounds:
            n = len(rows[0])
            bounds = ([r6(min(r[i] for r in rows)) for i in range(n)],
                      [r6(max(r[i] for r in rows)) for i in range(n)])
        return self._accessor(struct.pack("<%df" % len(flat), *flat), FLOAT, len(rows), kind,
                              target, bounds)

    def index_accessor(self, indices, component):
        fmt = {UBYTE: "B", USHORT: "H", UINT: "I"}[component]
        data = struct.pack("<%d%s" % (len(indices), fmt), *indices)
        return self._accessor(data, component, len(indices), "SCALAR", ELEMENT_ARRAY_BUFFER)

    def material(self, name, color, emissive=None, strength=None, texture=None,
                 metallic=0.0, roughness=1.0):
        pbr = {"baseColorFactor": [r6(c) for c in color] + [1.0],
               "metallicFactor": metallic, "roughnessFactor": roughness}
        if texture is not None:
            pbr["baseColorTexture"] = {"index": texture}
        m = {"name": name, "pbrMetallicRoughness": pbr}
        if emissive:
            m["emissiveFactor"] = [r6(c) for c in emissive]
        if strength is not None:
            m["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": strength}}
            self.used.add("KHR_materials_emissive_strength")
        self.gltf["materials"].append(m)
        return len(self.gltf["materials"]) - 1

    def mesh(self, name, parts, index_type=USHORT, uvs=False, mode=TRIANGLES, indexed=True):
        """A mesh of one primitive per (Geometry, material) part."""
        primitives = []
        for geometry, material in parts:
            attributes = {
                "POSITION": self.floats(geometry.positions, "VEC3", with_bounds=True),
                "NORMAL": self.floats(geometry.normals, "VEC3"),
            }
            if uvs:
                attributes["TEXCOORD_0"] = self.floats(geometry.uvs, "VEC2")
            primitive = {"attributes": attributes, "material": material}
            if indexed:
                primitive["indices"] = self.index_accessor(geometry.indices, index_type)
            if mode != TRIANGLES:
                primitive["mode"] = mode
            primitives.append(primitive)
        self.gltf["meshes"].append({"name": name, "primitives": primitives})
        return len(self.gltf["meshes"]) - 1

    def node(self, name, parent=None, **fields):
        node = {"name": name}
        for key, value in fields.items():
            node[key] = [r6(x) for x in value] if key in ("translation", "scale", "matrix") else value
        self.gltf["nodes"].append(node)
        index = len(self.gltf["nodes"]) - 1
        if parent is None:
            self.gltf["scenes"][0]["nodes"].append(index)
        else:
            self.gltf["nodes"][parent].setdefault("children", []).append(index)
        return index

    def camera(self, name, eye, target, yfov_degrees, aspect=16.0 / 9.0):
        cameras = self.gltf.setdefault("cameras", [])
        cameras.append({"name": name, "type": "perspective", "perspective": {
            "yfov": r6(math.radians(yfov_degrees)), "aspectRatio": r6(aspect),
            "znear": 0.01, "zfar": 100.0}})
        return self.node(name, camera=len(cameras) - 1, translation=eye,
                         rotation=look_at(eye, target))

    def light(self, light, node_name, parent=None, **node_fields):
        self.used.add("KHR_lights_punctual")
        ext = self.gltf.setdefault("extensions", {}).setdefault("KHR_lights_punctual",
                                                                {"lights": []})
        ext["lights"].append(light)
        return self.node(node_name, parent,
                         extensions={"KHR_lights_punctual": {"light": len(ext["lights"]) - 1}},
                         **node_fields)

    def animation(self, name, channels):
        """One animation of (node, path, times, values) channels, all LINEAR. Keyframe data has no
        buffer view target, and the times accessor has bounds, as glTF requires."""
        samplers, targets = [], []
        for node, path, times, values in channels:
            kind = "VEC4" if path == "rotation" else "VEC3"
            samplers.append({"input": self.floats([[t] for t in times], "SCALAR",
                                                  with_bounds=True, target=None),
                             "output": self.floats(values, kind, target=None),
                             "interpolation": "LINEAR"})
            targets.append({"sampler": len(samplers) - 1,
                            "target": {"node": node, "path": path}})
        self.gltf.setdefault("animations", []).append(
            {"name": name, "channels": targets, "samplers": samplers})

    def _finish(self):
        while len(self.bin) % 4:
            self.bin.append(0)
        if self.used:
            self.gltf["extensionsUsed"] = sorted(self.used)
        for key in ("cameras", "materials"):
            if key in self.gltf and not self.gltf[key]:
                del self.gltf[key]

    def write_gltf(self, name, embed=False):
        self._finish()
        buffer = {"byteLength": len(self.bin)}
        if embed:
            buffer["uri"] = ("data:application/octet-stream;base64,"
                             + base64.b64encode(bytes(self.bin)).decode("ascii"))
        else:
            buffer["uri"] = name + ".bin"
            with open(os.path.join(HERE, name + ".bin"), "wb") as f:
                f.write(self.bin)
        self.gltf["buffers"] = [buffer]
        with open(os.path.join(HERE, name + ".gltf"), "w") as f:
            json.dump(self.gltf, f, indent=1)
            f.write("\n")

    def write_glb(self, name):
        """The same document as binary glTF: the buffer becomes the BIN chunk (no uri)."""
        self._finish()
        gltf = dict(self.gltf)
        gltf["buffers"] = [{"byteLength": len(self.bin)}]
        json_bytes = json.dumps(gltf, separators=(",", ":")).encode("utf-8")
        json_bytes += b" " * (-len(json_bytes) % 4)
        bin_bytes = bytes(self.bin)
        length = 12 + 8 + len(json_bytes) + 8 + len(bin_bytes)
        with open(os.path.join(HERE, name + ".glb"), "wb") as f:
            f.write(struct.pack("<4sII", b"glTF", 2, length))
            f.write(struct.pack("<I4s", len(json_bytes), b"JSON") + json_bytes)
            f.write(struct.pack("<I4s", len(bin_bytes), b"BIN\0") + bin_bytes)


# --- scenes ---------------------------------------------------------------------------------

WHITE, RED, GREEN = [0.73, 0.73, 0.73], [0.65, 0.05, 0.05], [0.12, 0.45, 0.15]


def cornell_box():
    doc = Document("Cornell box: red left wall, green right wall, emissive ceiling quad.")
    white = doc.material("white", WHITE)
    red = doc.material("red", RED)
    green = doc.material("green", GREEN)
    light = doc.material("light", WHITE, emissive=[1.0, 0.78, 0.47], strength=17.0)
    # The room is one mesh of five primitives, one per wall, all facing inward; x, z in [-1, 1],
    # y in [0, 2], open towards +Z where the camera stands.
    room = doc.mesh("room", [
        (Geometry().quad([0, 0, 0], [0, 0, 1], [1, 0, 0]), white),  # floor
        (Geometry().quad([0, 2, 0], [1, 0, 0], [0, 0, 1]), white),  # ceiling
        (Geometry().quad([0, 1, -1], [1, 0, 0], [0, 1, 0]), white),  # back
        (Geometry().quad([-1, 1, 0], [0, 1, 0], [0, 0, 1]), red),  # left
        (Geometry().quad([1, 1, 0], [0, 0, 1], [0, 1, 0]), green),  # right
    ])
    lamp = doc.mesh("ceiling light", [
        (Geometry().quad([0, 1.98, 0], [0.25, 0, 0], [0, 0, 0.2]), light)])
    box = doc.mesh("box", [(unit_box(), white)])
    doc.node("room", mesh=room)
    doc.node("ceiling light", mesh=lamp)
    # One box mesh, two instances under a parent given as a matrix (a pure translation).
    boxes = doc.node("boxes", matrix=[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, -0.05, 1])
    doc.node("tall box", boxes, mesh=box, translation=[-0.33, 0.6, -0.3],
             rotation=quat_axis_angle([0, 1, 0], 17.0), scale=[0.55, 1.2, 0.55])
    doc.node("short box", boxes, mesh=box, translation=[0.35, 0.3, 0.35],
             rotation=quat_axis_angle([0, 1, 0], -17.0), scale=[0.55, 0.6, 0.55])
    doc.camera("camera", [0.0, 1.0, 3.9], [0.0, 1.0, 0.0], 39.3, aspect=1.0)
    doc.write_gltf("cornell-box")
    doc.write_glb("cornell-box")


def indirect_room():
    doc = Document("Room lit by the sun through a window and a spot light hidden behind a "
                   "partition, aimed at the ceiling: the camera sees mostly indirect light.")
    plaster = doc.material("plaster", [0.8, 0.78, 0.74])
    floor_m = doc.material("wood floor", [0.45, 0.3, 0.18])
    blue = doc.material("blue", [0.15, 0.25, 0.6])
    # Room: x, z in [-3, 3], y in [0, 3]. The +X wall has a window: y in [1, 2.2], z in [-1, 1].
    walls = Geometry()
    walls.quad([-3, 1.5, 0], [0, 1.5, 0], [0, 0, 3])  # -X wall, facing +X
    walls.quad([0, 1.5, -3], [3, 0, 0], [0, 1.5, 0])  # back wall, facing +Z
    walls.quad([0, 1.5, 3], [-3, 0, 0], [0, 1.5, 0])  # front wall, facing -Z
    walls.quad([0, 3, 0], [3, 0, 0], [0, 0, 3])  # ceiling, facing -Y
    # The window wall (+X, facing -X) around its opening.
    walls.quad([3, 0.5, 0], [0, 0, 3], [0, 0.5, 0])  # below the window
    walls.quad([3, 2.6, 0], [0, 0, 3], [0, 0.4, 0])  # above
    walls.quad([3, 1.6, -2], [0, 0, 1], [0, 0.6, 0])  # left of it
    walls.quad([3, 1.6, 2], [0, 0, 1], [0, 0.6, 0])  # right of it
    floor = Geometry().quad([0, 0, 0], [0, 0, 3], [3, 0, 0])
    room = doc.mesh("room", [(walls, plaster), (floor, floor_m)])
    doc.node("room", mesh=room)
    # Furniture: a table-like block and a low partition that hides the spot light.
    furniture = Geometry().box([-1.2, 0.4, -1.0], [0.8, 0.4, 0.5])
    furniture.box([1.6, 0.6, 2.2], [0.05, 0.6, 0.7])
    # Non-indexed: the loader reads the vertices three at a time.
    flat = Geometry()
    for i in furniture.indices:
        flat.positions.append(furniture.positions[i])
        flat.normals.append(furniture.normals[i])
    doc.node("furniture", mesh=doc.mesh("furniture", [(flat, blue)], indexed=False))
    # Sun: 3 W/m² of warm light, coming in through the window and down onto the floor.
    sun_dir = normalize([-1.0, -0.55, 0.25])
    doc.light({"name": "sun", "type": "directional", "color": [1.0, 0.93, 0.8],
               "intensity": r6(3.0 * LUMENS_PER_WATT)}, "sun",
              translation=[6, 4, 0], rotation=look_at([6, 4, 0], add([6, 4, 0], sun_dir)))
    # Spot light behind the partition (x = 1.6), pointing at the ceiling.
    spot_pos = [2.2, 0.3, 2.2]
    doc.light({"name": "uplight", "type": "spot", "color": [1.0, 0.85, 0.6],
               "intensity": r6(4.0 * LUMENS_PER_WATT),
               "spot": {"innerConeAngle": r6(math.radians(20)),
                        "outerConeAngle": r6(math.radians(35))}},
              "uplight", translation=spot_pos,
              rotation=look_at(spot_pos, [2.2, 3.0, 2.2], up=(0.0, 0.0, -1.0)))
    doc.camera("camera", [-2.6, 1.6, 2.6], [1.0, 0.8, -1.0], 60.0)
    doc.write_gltf("indirect-room", embed=True)


def many_lights():
    doc = Document("A floor with pillars and 256 coloured point lights on a 16 x 16 grid.")
    grey = doc.material("floor", [0.6, 0.6, 0.6])
    stone = doc.material("pillar", [0.75, 0.72, 0.68])
    floor = Geometry().quad([0, 0, 0], [0, 0, 10], [10, 0, 0], uv_scale=(1, 1))
    # Four vertices: unsigned byte indices suffice.
    doc.node("floor", mesh=doc.mesh("floor", [(floor, grey)], index_type=UBYTE))
    pillar = doc.mesh("pillar", [(unit_box(), stone)])
    pillars = doc.node("pillars")
    for i in range(4):
        for j in range(4):
            x, z = -6.0 + 4.0 * i, -6.0 + 4.0 * j
            doc.node("pillar %d %d" % (i, j), pillars, mesh=pillar,
                     translation=[x, 1.0, z], scale=[0.5, 2.0, 0.5])
    lights = doc.node("lights", translation=[0.0, 0.4, 0.0])
    for i in range(16):
        for j in range(16):
            hue = ((i * 16 + j) * 0.618034) % 1.0
            color = [r6(c) for c in colorsys.hsv_to_rgb(hue, 0.8, 1.0)]
            x, z = -7.5 + i, -7.5 + j
            doc.light({"type": "point", "color": color, "range": 3.0,
                       "intensity": r6(0.25 * LUMENS_PER_WATT)},
                      "light %d %d" % (i, j), lights, translation=[x, 0.0, z])
    doc.camera("camera", [0.0, 9.0, 12.0], [0.0, 0.0, 0.0], 50.0)
    doc.write_gltf("many-lights")


def checker_png(path, size=64, checks=8):
    """A size x size RGB checkerboard of checks x checks squares, as a PNG."""
    cell = size // checks
    rows = bytearray()
    for y in range(size):
        rows.append(0)  # filter: none
        for x in range(size):
            light = ((x // cell) + (y // cell)) % 2 == 0
            rows += bytes((230, 230, 230) if light else (40, 40, 40))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    png = b"\x89PNG\r\n\x1a\n"
    png += chunk(b"IHDR", struct.pack(">IIBBBBB", size, size, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(bytes(rows), 9))
    png += chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def textured():
    doc = Document("A checkerboard-textured floor and box under a point and a directional light.")
    checker_png(os.path.join(HERE, "checker.png"))
    doc.gltf["images"] = [{"name": "checker", "uri": "checker.png", "mimeType": "image/png"}]
    doc.gltf["samplers"] = [{"wrapS": REPEAT, "wrapT": REPEAT, "magFilter": LINEAR,
                             "minFilter": LINEAR_MIPMAP_LINEAR}]
    doc.gltf["textures"] = [{"sampler": 0, "source": 0}]
    floor_m = doc.material("checker floor", [1.0, 1.0, 1.0], texture=0)
    box_m = doc.material("checker box", [0.9, 0.6, 0.3], texture=0)
    # The floor as a four-vertex triangle strip without indices, its UVs tiling 4 x 4 times.
    quad = Geometry().quad([0, 0, 0], [0, 0, 4], [4, 0, 0], uv_scale=(4, 4))
    strip = Geometry()
    for i in (0, 1, 3, 2):
        strip.positions.append(quad.positions[i])
        strip.normals.append(quad.normals[i])
        strip.uvs.append(quad.uvs[i])
    doc.node("floor", mesh=doc.mesh("floor", [(strip, floor_m)], uvs=True,
                                      mode=TRIANGLE_STRIP, indexed=False))
    box = doc.mesh("box", [(unit_box(), box_m)], index_type=UINT, uvs=True)
    doc.node("box", mesh=box, translation=[0, 0.5, 0], rotation=quat_axis_angle([0, 1, 0], 30))
    doc.light({"name": "lamp", "type": "point", "color": [1.0, 0.95, 0.9],
               "intensity": r6(5.0 * LUMENS_PER_WATT)}, "lamp", translation=[1.5, 2.5, 1.5])
    sun_from = [3.0, 5.0, 2.0]
    doc.light({"name": "sun", "type": "directional", "color": [0.9, 0.95, 1.0],
               "intensity": r6(1.0 * LUMENS_PER_WATT)}, "sun", translation=sun_from,
              rotation=look_at(sun_from, [0.0, 0.0, 0.0]))
    doc.camera("camera", [2.5, 2.0, 3.5], [0.0, 0.4, 0.0], 45.0)
    doc.write_gltf("textured")


def light_leak():
    doc = Document("Two rooms open at the front, sharing a 1 cm wall that no power-of-two cell "
                   "boundary of the hash grid meets: a bright lit room and a dark room lit only "
                   "by a dim lamp, seen together from outside. No light path crosses the wall: "
                   "light found in the dark room beyond the lamp's is a leak.")
    plaster = doc.material("plaster", [0.8, 0.8, 0.8])
    lamp_bright = doc.material("bright lamp", WHITE, emissive=[1.0, 0.9, 0.7], strength=20.0)
    lamp_dim = doc.material("dim lamp", WHITE, emissive=[0.7, 0.8, 1.0], strength=0.5)
    # The shared wall's centre, x = 0.3 m, lies inside a cell and a tile at every level of detail
    # from 64 mm cells up, so a cache cell straddles it, as cells straddle thin walls in general.
    wall = 0.3
    # Both rooms: z in [-1.5, 1.5], y in [0, 3], open at z = 1.5; the lit room x in [wall - 3,
    # wall - 0.005], the dark room x in [wall + 0.005, wall + 3]. Every face looks into its
    # room; the shared wall is two faces 1 cm apart. The openings are coplanar, so no light
    # leaving one can enter the other.
    walls = Geometry()
    for x0, x1 in ((wall - 3.0, wall - 0.005), (wall + 0.005, wall + 3.0)):
        cx, hx = (x0 + x1) / 2, (x1 - x0) / 2
        walls.quad([cx, 0, 0], [0, 0, 1.5], [hx, 0, 0])  # floor, facing +Y
        walls.quad([cx, 3, 0], [hx, 0, 0], [0, 0, 1.5])  # ceiling, facing -Y
        walls.quad([cx, 1.5, -1.5], [hx, 0, 0], [0, 1.5, 0])  # back, facing +Z
        walls.quad([x0, 1.5, 0], [0, 1.5, 0], [0, 0, 1.5])  # -X side, facing +X
        walls.quad([x1, 1.5, 0], [0, 0, 1.5], [0, 1.5, 0])  # +X side, facing -X
    doc.node("rooms", mesh=doc.mesh("rooms", [(walls, plaster)]))
    # The bright lamp hangs near the shared wall so that its light grazes it.
    bright = Geometry().quad([wall - 0.6, 2.98, 0], [0.4, 0, 0], [0, 0, 0.8])
    dim = Geometry().quad([wall + 1.5, 2.98, 0], [1.2, 0, 0], [0, 0, 1.2])
    doc.node("lamps", mesh=doc.mesh("lamps", [(bright, lamp_bright), (dim, lamp_dim)]))
    # Outside, in line with the shared wall: the lit room fills the left half of the image, the
    # dark room the right half.
    doc.camera("camera", [wall, 1.5, 3.6], [wall, 1.5, 0.0], 70.0, aspect=1.0)
    doc.write_gltf("light-leak", embed=True)


def moving_box():
    doc = Document("Cornell-like box with a 0.4 m cube that crosses the view: its carrier node "
                   "slides from x = -0.6 to x = 0.6 m in 2 s while the cube, its child, turns "
                   "180 degrees about +Y. For motion vectors and ghost trails.")
    white = doc.material("white", WHITE)
    red = doc.material("red", RED)
    green = doc.material("green", GREEN)
    orange = doc.material("orange", [0.8, 0.45, 0.1])
    light = doc.material("light", WHITE, emissive=[1.0, 0.78, 0.47], strength=17.0)
    room = doc.mesh("room", [
        (Geometry().quad([0, 0, 0], [0, 0, 1], [1, 0, 0]), white),  # floor
        (Geometry().quad([0, 2, 0], [1, 0, 0], [0, 0, 1]), white),  # ceiling
        (Geometry().quad([0, 1, -1], [1, 0, 0], [0, 1, 0]), white),  # back
        (Geometry().quad([-1, 1, 0], [0, 1, 0], [0, 0, 1]), red),  # left
        (Geometry().quad([1, 1, 0], [0, 0, 1], [0, 1, 0]), green),  # right
    ])
    lamp = doc.mesh("ceiling light", [
        (Geometry().quad([0, 1.98, 0], [0.25, 0, 0], [0, 0, 0.2]), light)])
    doc.node("room", mesh=room)
    doc.node("ceiling light", mesh=lamp)
    # The carrier translates; the cube under it rotates: the world transform at time t is
    # T(x(t), 0.2, 0) R_y(90 t degrees) S(0.4), with x(t) = -0.6 + 0.6 t.
    carrier = doc.node("carrier", translation=[-0.6, 0.2, 0.0])
    cube = doc.node("cube", carrier, mesh=doc.mesh("cube", [(unit_box(), orange)]),
                    scale=[0.4, 0.4, 0.4])
    doc.animation("move", [
        (carrier, "translation", [0.0, 2.0], [[-0.6, 0.2, 0.0], [0.6, 0.2, 0.0]]),
        (cube, "rotation", [0.0, 1.0, 2.0],
         [quat_axis_angle([0, 1, 0], a) for a in (0.0, 90.0, 180.0)]),
    ])
    doc.camera("camera", [0.0, 1.0, 3.9], [0.0, 1.0, 0.0], 39.3, aspect=1.0)
    doc.write_gltf("moving-box", embed=True)


if __name__ == "__main__":
    cornell_box()
    indirect_room()
    many_lights()
    textured()
    light_leak()
    moving_box()
