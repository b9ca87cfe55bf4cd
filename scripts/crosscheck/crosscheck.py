"""Cross-check of the reference path tracer (`gi render`) against Mitsuba 3.

Run it by hand from the repository root (not in CI): `bash scripts/crosscheck/run.sh [options]`
(that sets up the Python environment, then runs this file; `--help` lists the options).

For each scene it converts the glTF file into a Mitsuba scene built in Python (gltf_scene.py reads
the file the way the project's loader does), renders the same view with Mitsuba's `path`
integrator and with `gi render`, and compares the two: the ratio of the mean radiance
(ours / Mitsuba, per channel and for the luminance) with its standard error, and the relative MSE
of host/src/metrics.rs (Mitsuba as the reference), next to the relMSE that the noise of both
images alone would give. It prints a Markdown table and writes it to `<out>/table.md`; the images
go to `<out>/<scene>-gi.exr` and `<out>/<scene>-mitsuba.exr`.

The Mitsuba scene follows what our renderer does:
* every surface two-sided Lambert (`twosided` + `diffuse`); reflectance = baseColorFactor x the
  sRGB-decoded base colour texture (bilinear, no mipmaps, the sampler's wrap mode), handed over as
  linear floats; metallic and roughness ignored. Where shading normals tilt from the geometric
  ones, renderers differ by design (Mitsuba's lobe loses energy, ours is folded to keep it, see
  shared/src/path_tracer.rs): `--mitsuba-bsdf folded` gives Mitsuba our folded lobe as a Python
  BSDF, so that its integrator checks ours with the same material model;
* emission (`area`) = emissiveFactor x KHR_materials_emissive_strength (x the emissive texture),
  from the counter-clockwise face only, unless the material is doubleSided (then a second,
  reversed copy of its triangles emits from the other face). Mitsuba's area emitter emits toward
  the interpolated vertex normal; ours toward the geometric (winding) normal. So emissive
  primitives get no vertex normals in Mitsuba, and the script says so if that drops tilted ones;
* punctual lights with the loader's units (candela and lux / 683); glTF's spot falloff (square of
  the linear ramp in the cosine) through a projected texture on a hard-edged Mitsuba `spot`,
  since Mitsuba's own falloff is linear in the angle; `range` ignored;
* the camera of `gi render` (`gbuffer::scene_camera`), with a box pixel filter as our renderer's
  uniform jitter; max_depth = max-bounces + 1 (Mitsuba counts segments);
* an environment map only where the scene is given as `scene.glb+environment.exr` (the form of
  `gi bench` and `gi sweep`; `gi render` gets `--environment`): Mitsuba's `envmap` looks up
  u = atan2(x, -z) / 2pi, ours 1/2 + atan2(x, -z) / 2pi (gi_shared::environment), so its
  `to_world` is a 180 degree turn about +Y; both take the image at scale 1. Ours reads the nearest
  texel, Mitsuba's interpolates bilinearly, so Mitsuba gets the image resampled (nearest)
  ENVIRONMENT_REPEAT times finer in both directions: it then blends neighbours only within a
  quarter texel of their edge (its rows are centred at v = i / (h - 1), not (i + 1/2) / h, so each row
  gets our texel at its own v);
* alpha (`--alpha`): `mask` (the default) gives glTF `alphaMode: MASK` materials a Mitsuba `mask`
  BSDF whose opacity is 1 where alpha = baseColorFactor.a x the base colour texture's alpha
  (linear), sampled bilinearly with the sampler's wrap mode, is >= alphaCutoff (0.5 by default),
  else 0: bilinear then threshold, as a filtered lookup followed by glTF's test does. Mitsuba gets
  that test precomputed on a grid ALPHA_SUPERSAMPLE times finer than the texture, read with its
  nearest filter, so the cut-out's edge is placed within a quarter texel. `opaque` ignores alpha
  (what `gi render` did before it honoured MASK). `BLEND` is taken as `MASK` at 0.5, as our loader
  takes it.

Our renderer is built once through `scripts/run.sh` and its binary copied to `<out>`, so that every
scene is rendered by the same build even while others edit and rebuild the tree (`--gi` names a
built binary instead). Its samples are
split into four runs with different seeds and Mitsuba's into passes of 256, which gives the
standard errors.

`--reuse-gi` keeps our renders when `<out>/<scene>-gi-seed<k>.json` records the very command
that would render them again (binary, scene, settings), so that a slow scene's Mitsuba side can
be rerun in other modes (`--alpha`, `--mitsuba-bsdf`) without rendering ours again.

`--png-textures` gives both renderers every JPEG texture as a lossless PNG of Mitsuba's decoding
(ours reads a copy of the .glb file written to `<out>`), so that the two JPEG decoders
(libjpeg in Mitsuba, zune-jpeg in ours), which differ by up to 0.5% in a channel's mean on some
images, do not take part.

`--flat-normals` drops the vertex normals in both renderers' inputs (for ours, a copy of the scene
without NORMAL attributes and without shared vertices is written to a temporary directory).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import gltf_scene

REPO = Path(__file__).resolve().parents[2]
SCENES = [
    "scenes/cornell-box.gltf",
    "scenes/indirect-room.gltf",
    "scenes/many-lights.gltf",
    "scenes/textured.gltf",
    "../shared/scenes/third-party/cornell-box-vinc3r/cornellBox-2.80-Eevee-gltf.gltf",
]
OUR_RUNS = 4
"""`gi render` runs per scene, with seeds 0..3: their spread gives our standard error."""
MITSUBA_PASS_SPP = 256
"""Samples per pixel of one Mitsuba pass (memory of the LLVM wavefront); passes use new seeds."""
RELATIVE_MSE_EPSILON = 1e-2
"""As in host/src/metrics.rs."""
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
"""Rec. 709 luminance of linear sRGB primaries."""
SPOT_TEXTURE_SIZE = 1024
ENVIRONMENT_REPEAT = 2
"""Each environment texel is repeated this many times per axis for Mitsuba (see the docstring)."""
ALPHA_SUPERSAMPLE = 4
"""The alpha test is evaluated on a grid this many times finer than the texture (see above)."""
WRAP_MODES = {33071: "clamp", 33648: "mirror", 10497: "repeat"}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "scenes",
        nargs="*",
        default=SCENES,
        help="glTF scenes, or scene+environment.exr (default: the five of issue 8)",
    )
    parser.add_argument("--spp", type=int, default=1024, help="gi render's samples per pixel (default 1024)")
    parser.add_argument(
        "--mitsuba-spp", type=int, default=4096, help="Mitsuba's samples per pixel (default 4096)"
    )
    parser.add_argument(
        "--width", type=int, default=160, help="image width; the height follows the camera's aspect ratio"
    )
    parser.add_argument(
        "--max-bounces", type=int, default=30, help="reflections per path in both (default 30)"
    )
    parser.add_argument(
        "--flat-normals", action="store_true", help="drop the vertex normals in both renderers' inputs"
    )
    parser.add_argument(
        "--out", type=Path, default=REPO / "out/crosscheck", help="images and table.md go here"
    )
    parser.add_argument(
        "--mitsuba-bsdf",
        choices=["diffuse", "folded"],
        default="diffuse",
        help="Mitsuba's `twosided` `diffuse` (default), or our folded cosine lobe as a Python BSDF",
    )
    parser.add_argument(
        "--gi", type=Path, help="a built gi binary to use instead of building one with scripts/run.sh"
    )
    parser.add_argument(
        "--variant", default="llvm_ad_rgb", help="Mitsuba variant; scalar_rgb if it fails to load"
    )
    parser.add_argument(
        "--alpha",
        choices=["mask", "opaque"],
        default="mask",
        help="alphaMode MASK cut out in Mitsuba (default), or every surface opaque",
    )
    parser.add_argument(
        "--png-textures",
        action="store_true",
        help="both read each JPEG texture as a PNG of Mitsuba's decoding (.glb scenes only)",
    )
    parser.add_argument(
        "--reuse-gi",
        action="store_true",
        help="reuse <out>/<scene>-gi-seed<k>.exr where its .json records the same gi command",
    )
    args = parser.parse_args()
    if args.spp % OUR_RUNS or args.mitsuba_spp % MITSUBA_PASS_SPP or args.mitsuba_spp < 2 * MITSUBA_PASS_SPP:
        parser.error(
            f"--spp must be a multiple of {OUR_RUNS}, --mitsuba-spp of {MITSUBA_PASS_SPP} (at least two)"
        )
    if args.flat_normals and args.png_textures:
        parser.error("--flat-normals and --png-textures do not go together")

    os.nice(10)  # others compile on the same machine; `gi render` runs under `nice -n 10` too
    mi = load_mitsuba(args.variant)
    register_folded_lambert(mi)
    args.out.mkdir(parents=True, exist_ok=True)
    gi = args.gi.resolve() if args.gi else snapshot_gi(args.out)
    rows, notes = [], []
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="gi-crosscheck-") as tmp:
        for name in args.scenes:
            scene_name, _, environment_name = name.partition("+")
            path = (REPO / scene_name).resolve()
            environment = (REPO / environment_name).resolve() if environment_name else None
            absent = [p for p in (path, environment) if p is not None and not p.exists()]
            if absent:
                message = f"{name}: skipped, {absent[0]} is absent (../shared is not on this machine)"
                print(message)
                notes.append(message)
                continue
            row, scene_notes = crosscheck(mi, gi, name, path, environment, args, Path(tmp))
            rows.append(row)
            notes.extend(scene_notes)
    table = markdown(rows, notes, args, mi, time.monotonic() - started)
    print("\n" + table)
    (args.out / "table.md").write_text(table)
    print(f"wrote {args.out / 'table.md'}")
    return 0


def load_mitsuba(variant: str):
    import mitsuba as mi

    try:
        mi.set_variant(variant)
        mi.load_dict({"type": "scene"})  # makes the JIT back end load (libLLVM) now
    except (ImportError, RuntimeError) as error:
        print(f"Mitsuba variant {variant} unavailable ({error}); using scalar_rgb")
        mi.set_variant("scalar_rgb")
    return mi


def snapshot_gi(out: Path) -> Path:
    """Builds `gi` through scripts/run.sh and copies the binary to `out`."""
    subprocess.run(["bash", "scripts/run.sh", "--version"], cwd=REPO, check=True, stdout=subprocess.DEVNULL)
    target = subprocess.run(
        ["bash", "-c", ". scripts/env.sh && echo $CARGO_TARGET_DIR"],
        cwd=REPO,
        check=True,
        capture_output=True,
        text=True,
    ).stdout.strip()
    copy = out / "gi"
    shutil.copy2(Path(target) / "debug/gi", copy)
    return copy


@dataclass
class Row:
    name: str
    size: tuple[int, int]
    ours_mean: np.ndarray  # mean RGB
    ours_error: np.ndarray  # standard error of the mean RGB, and of the luminance, last
    mitsuba_mean: np.ndarray
    mitsuba_error: np.ndarray
    relative_mse: float
    noise_relative_mse: float
    seconds: tuple[float, float]  # ours, Mitsuba


def crosscheck(
    mi, gi: Path, name: str, path: Path, environment: Path | None, args, tmp: Path
) -> tuple[Row, list[str]]:
    scene = gltf_scene.load(path)
    gi_stem = path.stem + ("-flat" if args.flat_normals else "") + ("-png" if args.png_textures else "")
    stem = (
        gi_stem
        + ("-folded" if args.mitsuba_bsdf == "folded" else "")
        + ("-opaque" if args.alpha == "opaque" and has_alpha_mask(scene) else "")
    )
    if args.flat_normals:
        for prim in scene.primitives:
            prim.normals = None
        flat_dir = tmp / stem
        flat_dir.mkdir()
        path = gltf_scene.write_flat_copy(scene, flat_dir)
    if args.png_textures:
        path = (args.out / f"{gi_stem}.glb").resolve()  # kept: --reuse-gi finds the same command
        gltf_scene.write_glb_with_png_images(scene.document, jpegs_as_pngs(mi, scene.document), path)
        scene = gltf_scene.load(path)
    camera = scene.camera()
    width = args.width
    height = max(1, round(width / camera.aspect_ratio)) if camera.aspect_ratio else width
    print(f"{name}: {width}x{height}, gi {args.spp} spp, Mitsuba {args.mitsuba_spp} spp")

    ours, ours_seconds = render_ours(gi, path, environment, args, width, height, gi_stem)
    mi.Bitmap(ours.mean(axis=0).astype(np.float32)).write(str(args.out / f"{gi_stem}-gi.exr"))
    start = time.monotonic()
    mitsuba_scene, notes = mitsuba_dict(mi, scene, camera, environment, width, height, args)
    theirs = render_mitsuba(mi, mi.load_dict(mitsuba_scene), args.mitsuba_spp)
    mitsuba_seconds = time.monotonic() - start
    mi.Bitmap(theirs.mean(axis=0).astype(np.float32)).write(str(args.out / f"{stem}-mitsuba.exr"))

    reference, test = theirs.mean(axis=0), ours.mean(axis=0)
    relative_mse = float(np.mean((test - reference) ** 2 / (reference**2 + RELATIVE_MSE_EPSILON)))
    # Variance of each pixel's mean, from the spread of the runs (passes).
    variance = ours.var(axis=0, ddof=1) / len(ours) + theirs.var(axis=0, ddof=1) / len(theirs)
    noise_relative_mse = float(np.mean(variance / (reference**2 + RELATIVE_MSE_EPSILON)))
    row = Row(
        stem,
        (width, height),
        *mean_and_error(ours),
        *mean_and_error(theirs),
        relative_mse,
        noise_relative_mse,
        (ours_seconds, mitsuba_seconds),
    )
    ratio = row.ours_mean / row.mitsuba_mean
    print(f"  ours / Mitsuba (R, G, B, luminance): {np.round(ratio, 4)}")
    print(f"  relMSE {relative_mse:.3e}, from the noise alone {noise_relative_mse:.3e}")
    return row, [f"{stem}: {n}" for n in notes]


def jpegs_as_pngs(mi, document: gltf_scene.Document) -> dict[int, bytes]:
    """PNGs of Mitsuba's (libjpeg's) decoding of the document's JPEG images, by image index."""
    pngs = {}
    with tempfile.TemporaryDirectory() as tmp:
        for i, image in enumerate(document.json.get("images", [])):
            jpeg, png = Path(tmp) / f"{i}.jpg", Path(tmp) / f"{i}.png"
            jpeg.write_bytes(document.image_bytes(i))
            if jpeg.read_bytes()[:3] != b"\xff\xd8\xff":
                continue
            mi.Bitmap(str(jpeg)).write(str(png))
            pngs[i] = png.read_bytes()
    return pngs


def mean_and_error(runs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean RGB then luminance over the image, and the standard errors, from (runs, H, W, 3)."""
    per_run = runs.mean(axis=(1, 2))
    per_run = np.concatenate([per_run, per_run @ LUMINANCE[:, None]], axis=1)
    return per_run.mean(axis=0), per_run.std(axis=0, ddof=1) / math.sqrt(len(per_run))


def render_ours(
    gi: Path, path: Path, environment: Path | None, args, width: int, height: int, stem: str
) -> tuple[np.ndarray, float]:
    """`gi render` in OUR_RUNS runs of spp / OUR_RUNS with seeds 0..: (runs, H, W, 3), and the
    seconds they took (as recorded when reused). Each run's image and command stay in `args.out`."""
    import mitsuba as mi

    runs, seconds = [], 0.0
    for seed in range(OUR_RUNS):
        out = args.out / f"{stem}-gi-seed{seed}.exr"
        record = out.with_suffix(".json")
        command = [
            str(gi), "render", str(path), "--spp", str(args.spp // OUR_RUNS),
            "--width", str(width), "--height", str(height), "--max-bounces", str(args.max_bounces),
            "--seed", str(seed),
        ]  # fmt: skip
        if environment is not None:
            command += ["--environment", str(environment)]
        previous = json.loads(record.read_text()) if args.reuse_gi and record.exists() else {}
        if previous.get("command") == command and out.exists():
            print(f"  reusing {out} ({previous['seconds']:.0f} s)")
            seconds += previous["seconds"]
        else:
            start = time.monotonic()
            subprocess.run(
                ["nice", "-n", "10", *command, "--out", str(out)],
                cwd=REPO,
                check=True,
                stdout=subprocess.DEVNULL,
            )
            record.write_text(json.dumps({"command": command, "seconds": time.monotonic() - start}))
            seconds += time.monotonic() - start
        runs.append(np.array(mi.Bitmap(str(out)), dtype=np.float64)[..., :3])
    return np.array(runs), seconds


def render_mitsuba(mi, scene, spp: int) -> np.ndarray:
    """Passes of MITSUBA_PASS_SPP with seeds 0..: (passes, H, W, 3)."""
    passes = [
        np.array(mi.render(scene, spp=MITSUBA_PASS_SPP, seed=seed), dtype=np.float64)[..., :3]
        for seed in range(spp // MITSUBA_PASS_SPP)
    ]
    return np.array(passes)


def mitsuba_dict(
    mi,
    scene: gltf_scene.Scene,
    camera: gltf_scene.Camera,
    environment: Path | None,
    width: int,
    height: int,
    args,
):
    """The Mitsuba scene dictionary of `scene`, and notes on what the conversion changed."""
    bounces = args.max_bounces
    materials = scene.document.json.get("materials", [])
    textures = TextureCache(mi, scene.document)
    notes = []
    low, high = scene.bounds()
    offset = 1e-5 * float(np.linalg.norm(high - low))
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": bounces + 1},
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": math.degrees(camera.yfov),
            "near_clip": 1e-4,
            "to_world": mi.ScalarTransform4f().look_at(
                origin=camera.position.tolist(),
                target=(camera.position + camera.forward).tolist(),
                up=camera.up.tolist(),
            ),
            "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"}},
            "sampler": {"type": "independent"},
        },
    }
    bsdfs, emitters = {}, {}
    for i, prim in enumerate(scene.primitives):
        material = materials[prim.material] if prim.material is not None else {}
        if prim.material not in bsdfs:
            bsdfs[prim.material] = mi.load_dict(bsdf(material, textures, args.mitsuba_bsdf, args.alpha))
            emitters[prim.material] = emission(material, textures)
        emitter = emitters[prim.material]
        normals = prim.normals
        if emitter is not None and normals is not None:
            tilt = max_tilt_degrees(prim)
            if tilt > 1.0:
                notes.append(
                    f"{prim.name}: emissive, so Mitsuba shades it with flat normals "
                    f"(the file's are up to {tilt:.1f} deg from the face)"
                )
            normals = None
        d[f"shape{i}"] = mesh(
            mi, f"shape{i}", prim.positions, prim.triangles, normals, prim.uvs, bsdfs[prim.material], emitter
        )
        if emitter is not None and material.get("doubleSided"):
            # The back face's emission: the triangles reversed, moved a hair behind the front ones.
            corners = prim.triangles[:, ::-1]
            p = prim.positions[corners]
            n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
            p = p + offset * (n / np.linalg.norm(n, axis=1, keepdims=True))[:, None, :]
            uvs = prim.uvs[corners].reshape(-1, 2) if prim.uvs is not None else None
            faces = np.arange(3 * len(corners)).reshape(-1, 3)
            d[f"shape{i}-back"] = mesh(
                mi, f"shape{i}-back", p.reshape(-1, 3), faces, None, uvs, bsdfs[prim.material], emitter
            )
    for i, light in enumerate(scene.lights):
        d[f"light{i}"] = punctual(mi, light)
    if environment is not None:
        d["environment"] = environment_map(mi, environment)
    return d, notes


def environment_map(mi, path: Path) -> dict:
    """Mitsuba's `envmap` of the image at `path`, lighting the scene as `gi render --environment`
    does (see the docstring: the turn about +Y, the repeated texels)."""
    image = np.array(mi.Bitmap(str(path)), dtype=np.float32)[..., :3]
    h, w = image.shape[:2]
    # Mitsuba centres column j of a w'-wide image at u = (j + 1/2) / w', as ours does, but row i of
    # an h'-high one at v = i / (h' - 1): each row gets our texel at its own v.
    rows = h * ENVIRONMENT_REPEAT
    ours = np.minimum((np.arange(rows) / (rows - 1) * h).astype(np.int64), h - 1)
    image = np.repeat(image[ours], ENVIRONMENT_REPEAT, axis=1)
    return {
        "type": "envmap",
        "bitmap": mi.Bitmap(np.ascontiguousarray(image)),
        "to_world": mi.ScalarTransform4f().rotate([0.0, 1.0, 0.0], 180.0),
    }


# glTF alpha modes cut out by the alpha test (BLEND as MASK at 0.5, like our loader).
MASKED = ("MASK", "BLEND")


def has_alpha_mask(scene: gltf_scene.Scene) -> bool:
    return any(m.get("alphaMode") in MASKED for m in scene.document.json.get("materials", []))


def bsdf(material: dict, textures: TextureCache, kind: str, alpha: str) -> dict:
    pbr = material.get("pbrMetallicRoughness", {})
    factor = pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0])
    reflectance = textures.scaled(pbr.get("baseColorTexture"), factor[:3])
    if kind == "folded":
        surface = {"type": "folded_lambert", "reflectance": reflectance}
    else:
        surface = {"type": "twosided", "material": {"type": "diffuse", "reflectance": reflectance}}
    mode = material.get("alphaMode")
    if alpha == "mask" and mode in MASKED:
        # BLEND has no cutoff of its own: our loader cuts it at 0.5.
        cutoff = material.get("alphaCutoff", 0.5) if mode == "MASK" else 0.5
        opacity = textures.alpha_test(pbr.get("baseColorTexture"), factor[3], cutoff)
        return {"type": "mask", "opacity": opacity, "bsdf": surface}
    return surface


def emission(material: dict, textures: TextureCache) -> dict | None:
    """The `area` emitter of a material (a dictionary: each shape needs its own), or None."""
    strength = (
        material.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
    )
    factor = [c * strength for c in material.get("emissiveFactor", [0.0, 0.0, 0.0])]
    if max(factor) <= 0:
        return None
    return {"type": "area", "radiance": textures.scaled(material.get("emissiveTexture"), factor)}


class TextureCache:
    """glTF textures as linear float RGB arrays, decoded once."""

    def __init__(self, mi, document: gltf_scene.Document):
        self.mi = mi
        self.document = document
        self.linear = {}

    def scaled(self, info: dict | None, factor) -> dict:
        """A Mitsuba texture: `factor` alone, or x the texture of glTF texture `info`."""
        if info is None:
            return {"type": "rgb", "value": list(factor)}
        source, wrap = self.source_and_wrap(info)
        if source not in self.linear:
            self.linear[source] = self.decode(source)
        return {
            "type": "bitmap",
            "data": self.mi.TensorXf((self.linear[source][..., :3] * np.array(factor)).astype(np.float32)),
            "raw": True,
            "filter_type": "bilinear",
            "wrap_mode": wrap,
        }

    def alpha_test(self, info: dict | None, factor: float, cutoff: float) -> dict:
        """The opacity (0 or 1) of glTF's alpha test: factor x the texture's alpha, sampled
        bilinearly, >= cutoff; as a texture evaluated ALPHA_SUPERSAMPLE times finer, nearest."""
        if info is None:
            return {"type": "rgb", "value": [float(factor >= cutoff)] * 3}
        source, wrap = self.source_and_wrap(info)
        if source not in self.linear:
            self.linear[source] = self.decode(source)
        alpha = self.linear[source][..., 3] * factor
        h, w = alpha.shape
        # Fine texel centres in the coarse image's continuous texel coordinates.
        ys = (np.arange(h * ALPHA_SUPERSAMPLE) + 0.5) / ALPHA_SUPERSAMPLE - 0.5
        xs = (np.arange(w * ALPHA_SUPERSAMPLE) + 0.5) / ALPHA_SUPERSAMPLE - 0.5
        y0, x0 = np.floor(ys).astype(np.int64), np.floor(xs).astype(np.int64)
        fy, fx = (ys - y0)[:, None], (xs - x0)[None, :]
        rows = [wrap_index(y0, h, wrap), wrap_index(y0 + 1, h, wrap)]
        cols = [wrap_index(x0, w, wrap), wrap_index(x0 + 1, w, wrap)]
        filtered = (
            alpha[np.ix_(rows[0], cols[0])] * (1 - fy) * (1 - fx)
            + alpha[np.ix_(rows[0], cols[1])] * (1 - fy) * fx
            + alpha[np.ix_(rows[1], cols[0])] * fy * (1 - fx)
            + alpha[np.ix_(rows[1], cols[1])] * fy * fx
        )
        opacity = (filtered >= cutoff).astype(np.float32)[..., None]
        return {
            "type": "bitmap",
            "data": self.mi.TensorXf(np.ascontiguousarray(opacity)),
            "raw": True,
            "filter_type": "nearest",
            "wrap_mode": wrap,
        }

    def source_and_wrap(self, info: dict) -> tuple[int, str]:
        """The image index and Mitsuba wrap mode of glTF texture `info`."""
        if info.get("texCoord", 0) != 0:
            raise NotImplementedError("textures on TEXCOORD_1 and later (the project drops them)")
        j = self.document.json
        texture = j["textures"][info["index"]]
        sampler = j.get("samplers", [])[texture["sampler"]] if "sampler" in texture else {}
        wrap = WRAP_MODES[sampler.get("wrapS", 10497)]
        if WRAP_MODES[sampler.get("wrapT", 10497)] != wrap:
            raise NotImplementedError("different wrap modes in u and v (Mitsuba's bitmap has one)")
        return texture["source"], wrap

    def decode(self, image: int) -> np.ndarray:
        """Image `image` as linear RGB (the project's sRGB decoding) and linear alpha (1 where
        the image has none), row 0 at the top: (H, W, 4)."""
        mi = self.mi
        with tempfile.NamedTemporaryFile() as f:
            f.write(self.document.image_bytes(image))
            f.flush()
            bitmap = mi.Bitmap(f.name)
            has_alpha = bitmap.has_alpha()
            bitmap = bitmap.convert(mi.Bitmap.PixelFormat.RGBA, mi.Struct.Type.UInt8, srgb_gamma=True)
        c = np.array(bitmap, dtype=np.float64) / 255.0
        rgb = c[..., :3]
        rgb = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
        alpha = c[..., 3:] if has_alpha else np.ones_like(c[..., 3:])
        return np.concatenate([rgb, alpha], axis=2)


def wrap_index(i: np.ndarray, n: int, wrap: str) -> np.ndarray:
    """Texel indices `i` of an axis of `n` texels wrapped like the sampler: repeat, mirror, clamp."""
    if wrap == "repeat":
        return np.mod(i, n)
    if wrap == "mirror":
        period = np.mod(i, 2 * n)
        return np.where(period < n, period, 2 * n - 1 - period)
    return np.clip(i, 0, n - 1)


def register_folded_lambert(mi) -> None:
    """Registers `folded_lambert`: the BSDF of shared/src/path_tracer.rs ("Shading normals"), the
    cosine lobe around the shading normal folded about the geometric surface, whose
    cosine-weighted value is albedo/pi x (<ns.w> + <ns.R(w)>) for w above the geometric surface
    (R: the mirror about it) and which is sampled exactly (a cosine sample, mirrored when below).
    Both sides shade alike: the normals are flipped toward the incoming ray, as ours does."""
    import drjit as dr

    class FoldedLambert(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.reflectance = props.get_texture("reflectance")
            flags = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
            self.m_components = [flags]
            self.m_flags = flags

        @staticmethod
        def normals(si):
            """Shading and geometric normal in the local (shading) frame, on the side of si.wi."""
            ng = si.to_local(si.n)
            sign = dr.select(dr.dot(ng, si.wi) < 0, -1.0, 1.0)
            ng = ng * sign
            ns = mi.Vector3f(0, 0, sign)
            return dr.select(dr.dot(ns, ng) <= 0, ng, ns), ng

        @staticmethod
        def folded_cosine(ns, ng, w):
            d = dr.dot(ng, w)
            value = dr.maximum(dr.dot(ns, w), 0) + dr.maximum(dr.dot(ns, w - ng * (2 * d)), 0)
            return dr.select(d > 0, value, 0.0)

        def sample(self, ctx, si, sample1, sample2, active):
            ns, ng = self.normals(si)
            w = mi.Frame3f(ns).to_world(mi.warp.square_to_cosine_hemisphere(sample2))
            d = dr.dot(ng, w)
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = dr.select(d < 0, dr.normalize(w - ng * (2 * d)), w)
            bs.pdf = self.folded_cosine(ns, ng, bs.wo) / math.pi
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DiffuseReflection)
            bs.sampled_component = mi.UInt32(0)
            active = active & (bs.pdf > 0)
            return bs, dr.select(active, self.reflectance.eval(si, active), 0.0)

        def eval(self, ctx, si, wo, active):
            return self.eval_pdf(ctx, si, wo, active)[0]

        def pdf(self, ctx, si, wo, active):
            return self.eval_pdf(ctx, si, wo, active)[1]

        def eval_pdf(self, ctx, si, wo, active):
            ns, ng = self.normals(si)
            pdf = self.folded_cosine(ns, ng, wo) / math.pi
            return self.reflectance.eval(si, active) * pdf, pdf

        def traverse(self, callback):
            callback.put("reflectance", self.reflectance, mi.ParamFlags.NonDifferentiable)

        def to_string(self):
            return "FoldedLambert[]"

    mi.register_bsdf("folded_lambert", FoldedLambert)


def mesh(mi, name, positions, faces, normals, uvs, bsdf_object, emitter):
    props = mi.Properties()
    props["bsdf"] = bsdf_object
    if emitter is not None:
        props["emitter"] = mi.load_dict(emitter)
    m = mi.Mesh(
        name,
        len(positions),
        len(faces),
        props=props,
        has_vertex_normals=normals is not None,
        has_vertex_texcoords=uvs is not None,
    )
    params = mi.traverse(m)
    params["vertex_positions"] = mi.Float(np.asarray(positions, dtype=np.float32).ravel())
    params["faces"] = mi.UInt32(np.asarray(faces, dtype=np.uint32).ravel())
    if uvs is not None:
        params["vertex_texcoords"] = mi.Float(np.asarray(uvs, dtype=np.float32).ravel())
    params.update()
    if normals is not None:
        # Set alone, after the positions: an update that names the positions recomputes normals.
        params["vertex_normals"] = mi.Float(np.asarray(normals, dtype=np.float32).ravel())
        params.update()
    return m


def max_tilt_degrees(prim: gltf_scene.Primitive) -> float:
    """Largest angle between a vertex normal and its triangle's face normal."""
    p = prim.positions[prim.triangles]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    cos = np.einsum("tk,tvk->tv", n, prim.normals[prim.triangles])
    return math.degrees(math.acos(max(-1.0, min(1.0, float(cos.min())))))


def punctual(mi, light: gltf_scene.Light) -> dict:
    rgb = {"type": "rgb", "value": light.intensity.tolist()}
    if light.kind == "directional":
        return {"type": "directional", "direction": light.direction.tolist(), "irradiance": rgb}
    if light.kind == "point":
        return {"type": "point", "position": light.position.tolist(), "intensity": rgb}
    # glTF's falloff as a texture on a hard-edged cone: the texture spans tan(outer) on each side.
    outer, inner = light.outer_cone_angle, light.inner_cone_angle
    centres = (np.arange(SPOT_TEXTURE_SIZE) + 0.5) / SPOT_TEXTURE_SIZE * 2 - 1
    x, y = np.meshgrid(centres * math.tan(outer), centres * math.tan(outer))
    cos_angle = 1 / np.sqrt(1 + x * x + y * y)
    t = np.clip((cos_angle - math.cos(outer)) / max(math.cos(inner) - math.cos(outer), 1e-3), 0, 1)
    falloff = np.repeat((t * t)[..., None], 3, axis=2).astype(np.float32)
    up = [0.0, 1.0, 0.0] if abs(light.direction[1]) < 0.9 else [1.0, 0.0, 0.0]
    return {
        "type": "spot",
        "intensity": rgb,
        "cutoff_angle": math.degrees(outer),
        "beam_width": math.degrees(outer),
        "texture": {"type": "bitmap", "data": mi.TensorXf(falloff), "raw": True, "wrap_mode": "clamp"},
        "to_world": mi.ScalarTransform4f().look_at(
            origin=light.position.tolist(), target=(light.position + light.direction).tolist(), up=up
        ),
    }


def markdown(rows: list[Row], notes: list[str], args, mi, seconds: float) -> str:
    """The table, headed by what was compared: versions, settings, how to read it."""

    def git(*command: str) -> str:
        return subprocess.run(["git", *command], cwd=REPO, capture_output=True, text=True, check=True).stdout

    head = git("rev-parse", "--short", "HEAD").strip()
    edited = git("status", "--porcelain", "--", "shared", "kernels", "host").count("\n")
    bsdf_name = {"diffuse": "`twosided` `diffuse`", "folded": "our folded cosine lobe (Python BSDF)"}
    built = f"`{args.gi}` (tree" if args.gi else "`gi render` (built"
    settings = [
        f"{built} at {head} + {edited} edited files in shared/ kernels/ host/), {args.spp} spp "
        f"({OUR_RUNS} seeds)",
        f"Mitsuba {mi.__version__} `{mi.variant()}` `path` with {bsdf_name[args.mitsuba_bsdf]}, "
        f"{args.mitsuba_spp} spp",
        f"{args.max_bounces} bounces",
    ]
    if args.alpha == "opaque":
        settings.append("alpha ignored (MASK opaque) in Mitsuba")
    if args.flat_normals:
        settings.append("**vertex normals dropped in both**")
    if args.png_textures:
        settings.append("JPEG textures as PNGs of Mitsuba's decoding in both")
    lines = [
        "; ".join(settings) + f"; {seconds / 60:.1f} min in all.",
        "",
        "Ratio: mean radiance of ours / Mitsuba's, ± one standard error (from the spread of the runs "
        "and passes). relMSE: host/src/metrics.rs's, Mitsuba's image as the reference; noise relMSE: "
        "what the noise of the two images alone gives (equal: the images agree pixel by pixel).",
        "",
        "| scene | size | ratio R | ratio G | ratio B | ratio luminance | relMSE | noise relMSE "
        "| gi s | Mitsuba s |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        ratio = r.ours_mean / r.mitsuba_mean
        error = ratio * np.hypot(r.ours_error / r.ours_mean, r.mitsuba_error / r.mitsuba_mean)
        cells = [f"{q:.4f} ± {e:.4f}" for q, e in zip(ratio, error, strict=True)]
        lines.append(
            f"| {r.name} | {r.size[0]}x{r.size[1]} | {' | '.join(cells)} | {r.relative_mse:.2e} | "
            f"{r.noise_relative_mse:.2e} | {r.seconds[0]:.0f} | {r.seconds[1]:.0f} |"
        )
    if notes:
        lines.append("")
        lines.extend(f"- {n}" for n in notes)
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
