//! Malformed input, one fault per test, each with the exact answer it must get: the error variant
//! and the element it names, or the warning and what the loader kept. CPU only (no Vulkan device).
//!
//! Most documents are made here from one valid base (`base()`): a textured, lit triangle placed
//! twice, with a camera; each test breaks one thing. List them with
//! `cargo test -p gi-host --test malformed -- --list`.
//!
//! Errors or warnings: a fault that makes the file unusable or its meaning unknowable (a reference
//! to nothing, a cycle, a buffer shorter than declared, a non-finite transform) is an error naming
//! the element. Where glTF semantics let a reader skip the element (a texture that cannot be
//! decoded falls back to its factor; a light or camera with invalid parameters; a node whose
//! transform collapses its mesh to nothing) it is skipped with a warning naming it, and the rest
//! of the scene loads.

use base64::Engine;
use gi_host::Error;
use gi_host::gi::{GiSettings, ViewOptions};
use gi_host::image_io::{HdrImage, ToneMap};
use gi_host::scene::lights::Environment;
use gi_host::scene::{Scene, Warning};
use glam::Vec3;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

// --- the base document and its loading -------------------------------------------------------

/// The base triangle's vertices.
const POSITIONS: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// The base buffer: positions (36 bytes), normals (36), UVs (24), u16 indices (6, padded to 8).
fn base_buffer(positions: &[[f32; 3]; 3]) -> Vec<u8> {
    let mut data: Vec<u8> = bytemuck::cast_slice(positions).to_vec();
    data.extend(bytemuck::cast_slice(&[[0.0f32, 0.0, 1.0]; 3]));
    data.extend(bytemuck::cast_slice(&[
        [0.0f32, 0.0],
        [1.0, 0.0],
        [0.0, 1.0],
    ]));
    data.extend(bytemuck::cast_slice(&[0u16, 1, 2, 0]));
    data
}

fn data_uri(bytes: &[u8]) -> String {
    format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// A valid document: mesh "tri" placed by nodes "a" and "b", a camera on node "eye", a point
/// light on node "lamp", a material whose base colour texture is `tex.png` beside the file.
fn base() -> Value {
    let buffer = base_buffer(&POSITIONS);
    json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "scene": 0,
        "scenes": [{"name": "scene", "nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"name": "a", "mesh": 0},
            {"name": "b", "mesh": 0, "translation": [3.0, 0.0, 0.0]},
            {"name": "eye", "camera": 0, "translation": [0.0, 0.0, 5.0]},
            {"name": "lamp", "translation": [0.0, 2.0, 0.0],
             "extensions": {"KHR_lights_punctual": {"light": 0}}}
        ],
        "meshes": [{"name": "tri", "primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
            "indices": 3,
            "material": 0
        }]}],
        "materials": [{"name": "paint", "pbrMetallicRoughness": {
            "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "baseColorTexture": {"index": 0}}}],
        "textures": [{"source": 0}],
        "images": [{"uri": "tex.png"}],
        "cameras": [{"name": "cam", "type": "perspective",
                     "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "bulb", "type": "point", "intensity": 100.0}
        ]}},
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 3, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 36},
            {"buffer": 0, "byteOffset": 72, "byteLength": 24},
            {"buffer": 0, "byteOffset": 96, "byteLength": 6}
        ],
        "buffers": [{"byteLength": buffer.len(), "uri": data_uri(&buffer)}]
    })
}

/// The base with `edit` applied.
fn with(edit: impl FnOnce(&mut Value)) -> Value {
    let mut doc = base();
    edit(&mut doc);
    doc
}

/// The base with its triangle's positions replaced.
fn with_positions(positions: [[f32; 3]; 3]) -> Value {
    with(|d| {
        let buffer = base_buffer(&positions);
        d["buffers"][0]["uri"] = json!(data_uri(&buffer));
    })
}

/// A 2×2 RGBA PNG.
fn png() -> Vec<u8> {
    let mut bytes = Vec::new();
    image::write_buffer_with_format(
        &mut std::io::Cursor::new(&mut bytes),
        &[200u8; 16],
        2,
        2,
        image::ExtendedColorType::Rgba8,
        image::ImageFormat::Png,
    )
    .unwrap();
    bytes
}

/// A folder of the test's own with `files` in it.
fn folder(test: &str, files: &[(&str, &[u8])]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gi-malformed-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    dir
}

/// Writes `doc` as `scene.gltf` with `tex.png` (and `files`) beside it, and loads it.
fn load(
    test: &str,
    doc: &Value,
    files: &[(&str, &[u8])],
) -> (PathBuf, gi_host::Result<(Scene, Vec<Warning>)>) {
    let png = png();
    let mut all = vec![("tex.png", png.as_slice())];
    all.extend_from_slice(files);
    let dir = folder(test, &all);
    let path = dir.join("scene.gltf");
    std::fs::write(&path, serde_json::to_vec_pretty(doc).unwrap()).unwrap();
    (path.clone(), Scene::load(&path))
}

/// The scene error of `doc`: asserts it names the file and exactly `element`, and that its reason
/// contains `why`.
fn scene_error(test: &str, doc: &Value, files: &[(&str, &[u8])], element: &str, why: &str) {
    let (path, loaded) = load(test, doc, files);
    expect_scene_error(&path, loaded, element, why);
}

fn expect_scene_error(
    path: &Path,
    loaded: gi_host::Result<(Scene, Vec<Warning>)>,
    element: &str,
    why: &str,
) {
    match loaded {
        Ok((_, warnings)) => panic!("loads, but must fail at {element}: {warnings:#?}"),
        Err(e @ Error::Scene { .. }) => {
            let message = e.to_string();
            let Error::Scene {
                file,
                element: at,
                why: reason,
            } = e
            else {
                unreachable!()
            };
            assert_eq!(file, path, "{message}");
            assert_eq!(at, element, "{message}");
            assert!(reason.contains(why), "{message} lacks {why:?}");
            assert!(!message.contains('\n'), "not one line: {message}");
        }
        Err(e) => panic!("not a scene error: {e}"),
    }
}

/// Loads `doc`, which must load with a warning about exactly `element` whose message contains
/// `message`; returns the scene.
fn scene_warning(
    test: &str,
    doc: &Value,
    files: &[(&str, &[u8])],
    element: &str,
    message: &str,
) -> Scene {
    let (path, loaded) = load(test, doc, files);
    let (scene, warnings) = loaded.unwrap_or_else(|e| panic!("must load with a warning: {e}"));
    let found: Vec<&Warning> = warnings
        .iter()
        .filter(|w| w.message.contains(message))
        .collect();
    let [w] = found[..] else {
        panic!("one warning about {message:?} expected: {warnings:#?}")
    };
    assert_eq!(w.element, element, "{w}");
    assert_eq!(w.file, path);
    scene
}

/// The one-line `Error::InvalidArgument` of `result`: its name, and that its reason contains
/// `why`.
fn invalid_argument<T: std::fmt::Debug>(result: gi_host::Result<T>, name: &str, why: &str) {
    match result {
        Err(e @ Error::InvalidArgument { .. }) => {
            let message = e.to_string();
            let Error::InvalidArgument {
                name: at,
                why: reason,
            } = e
            else {
                unreachable!()
            };
            assert_eq!(at, name, "{message}");
            assert!(reason.contains(why), "{message} lacks {why:?}");
            assert!(!message.contains('\n'), "not one line: {message}");
        }
        other => panic!("{name}: expected an invalid argument, got {other:?}"),
    }
}

/// The `Error::Image` of `result`: names `path`, and its reason contains `why`.
fn image_error<T: std::fmt::Debug>(result: gi_host::Result<T>, path: &Path, why: &str) {
    match result {
        Err(e @ Error::Image { .. }) => {
            let message = e.to_string();
            let Error::Image {
                path: at,
                why: reason,
            } = e
            else {
                unreachable!()
            };
            assert_eq!(at, path, "{message}");
            assert!(reason.contains(why), "{message} lacks {why:?}");
            assert!(!message.contains('\n'), "not one line: {message}");
        }
        other => panic!(
            "expected an image error about {}, got {other:?}",
            path.display()
        ),
    }
}

/// The base itself loads cleanly: every test below differs from a working scene by its fault.
#[test]
fn the_base_document_loads_without_warnings() {
    let (_, loaded) = load("base", &base(), &[]);
    let (scene, warnings) = loaded.unwrap();
    assert!(warnings.is_empty(), "{warnings:#?}");
    assert_eq!(scene.instances.len(), 2);
    assert_eq!(scene.triangle_count(), 2);
    assert_eq!((scene.textures.len(), scene.lights.len()), (1, 1));
    assert_eq!(scene.cameras.len(), 1);
}

// --- JSON, GLB and the document --------------------------------------------------------------

#[test]
fn empty_file() {
    let dir = folder("empty-file", &[("scene.gltf", b"")]);
    let path = dir.join("scene.gltf");
    expect_scene_error(&path, Scene::load(&path), "JSON", "EOF");
}

#[test]
fn json_that_is_not_an_object() {
    let dir = folder("json-array", &[("scene.gltf", b"[1, 2, 3]")]);
    let path = dir.join("scene.gltf");
    expect_scene_error(&path, Scene::load(&path), "JSON", "malformed glTF JSON");
}

#[test]
fn missing_asset() {
    let doc = with(|d| {
        d.as_object_mut().unwrap().remove("asset");
    });
    scene_error("missing-asset", &doc, &[], "JSON", "missing field `asset`");
}

#[test]
fn unsupported_major_version() {
    let doc = with(|d| d["asset"]["version"] = json!("3.0"));
    scene_error("version-3", &doc, &[], "asset.version", "3.0");
}

/// A GLB file of `json` and an optional BIN chunk, with `version` in its header.
fn glb(version: u32, json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
    let pad = |b: &[u8], with: u8| {
        let mut v = b.to_vec();
        v.resize(b.len().next_multiple_of(4), with);
        v
    };
    let json = pad(json, b' ');
    let mut chunks = Vec::new();
    chunks.extend((json.len() as u32).to_le_bytes());
    chunks.extend(b"JSON");
    chunks.extend(&json);
    if let Some(bin) = bin {
        let bin = pad(bin, 0);
        chunks.extend((bin.len() as u32).to_le_bytes());
        chunks.extend(b"BIN\0");
        chunks.extend(&bin);
    }
    let mut out = b"glTF".to_vec();
    out.extend(version.to_le_bytes());
    out.extend((12 + chunks.len() as u32).to_le_bytes());
    out.extend(chunks);
    out
}

/// The base as a GLB whose buffer 0 is the BIN chunk `bin`, declared `byte_length` long.
fn base_glb(bin: &[u8], byte_length: usize) -> Vec<u8> {
    let doc = with(|d| d["buffers"][0] = json!({"byteLength": byte_length}));
    glb(2, &serde_json::to_vec(&doc).unwrap(), Some(bin))
}

fn load_glb(test: &str, bytes: &[u8]) -> (PathBuf, gi_host::Result<(Scene, Vec<Warning>)>) {
    let png = png();
    let dir = folder(test, &[("scene.glb", bytes), ("tex.png", &png)]);
    let path = dir.join("scene.glb");
    let loaded = Scene::load(&path);
    (path, loaded)
}

#[test]
fn glb_of_the_base_loads() {
    let buffer = base_buffer(&POSITIONS);
    let (_, loaded) = load_glb("glb-ok", &base_glb(&buffer, buffer.len()));
    assert_eq!(loaded.unwrap().0.triangle_count(), 2);
}

#[test]
fn glb_version_1() {
    let buffer = base_buffer(&POSITIONS);
    let mut bytes = base_glb(&buffer, buffer.len());
    bytes[4] = 1;
    let (path, loaded) = load_glb("glb-version", &bytes);
    expect_scene_error(&path, loaded, "GLB container", "GLB version 1, expected 2");
}

#[test]
fn glb_cut_inside_its_header() {
    let (path, loaded) = load_glb("glb-header", b"glTF\x02\x00");
    expect_scene_error(
        &path,
        loaded,
        "GLB container",
        "shorter than its 12-byte header",
    );
}

#[test]
fn glb_chunk_longer_than_the_file() {
    let buffer = base_buffer(&POSITIONS);
    let mut bytes = base_glb(&buffer, buffer.len());
    // The JSON chunk's length, past everything.
    bytes[12..16].copy_from_slice(&100_000u32.to_le_bytes());
    let (path, loaded) = load_glb("glb-chunk", &bytes);
    expect_scene_error(&path, loaded, "GLB container", "runs past the end");
}

#[test]
fn glb_without_a_json_chunk() {
    let mut bytes = b"glTF".to_vec();
    bytes.extend(2u32.to_le_bytes());
    bytes.extend(24u32.to_le_bytes());
    bytes.extend(4u32.to_le_bytes());
    bytes.extend(b"ABCD");
    bytes.extend(b"\0\0\0\0");
    let (path, loaded) = load_glb("glb-no-json", &bytes);
    expect_scene_error(&path, loaded, "GLB container", "no JSON chunk");
}

// --- truncated and oversized buffers ---------------------------------------------------------

#[test]
fn glb_bin_chunk_shorter_than_its_buffer() {
    let buffer = base_buffer(&POSITIONS);
    let (path, loaded) = load_glb("glb-short-bin", &base_glb(&buffer[..64], buffer.len()));
    expect_scene_error(
        &path,
        loaded,
        "buffers[0]",
        "holds 64 bytes, fewer than its byteLength 104",
    );
}

#[test]
fn data_uri_shorter_than_its_byte_length() {
    let doc = with(|d| d["buffers"][0]["byteLength"] = json!(4096));
    scene_error(
        "short-data-uri",
        &doc,
        &[],
        "buffers[0]",
        "holds 104 bytes, fewer than its byteLength 4096",
    );
}

#[test]
fn byte_length_of_a_terabyte() {
    let doc = with(|d| d["buffers"][0]["byteLength"] = json!(1u64 << 40));
    scene_error(
        "terabyte-buffer",
        &doc,
        &[],
        "buffers[0]",
        "fewer than its byteLength 1099511627776",
    );
}

#[test]
fn external_buffer_file_cut_short() {
    let buffer = base_buffer(&POSITIONS);
    let doc = with(|d| d["buffers"][0]["uri"] = json!("tri.bin"));
    scene_error(
        "short-bin-file",
        &doc,
        &[("tri.bin", &buffer[..50])],
        "buffers[0]",
        "holds 50 bytes, fewer than its byteLength 104",
    );
}

#[test]
fn missing_buffer_file() {
    let doc = with(|d| d["buffers"][0]["uri"] = json!("gone.bin"));
    scene_error(
        "missing-bin",
        &doc,
        &[],
        "buffers[0] (uri \"gone.bin\")",
        "cannot read",
    );
}

#[test]
fn data_uri_that_is_not_base64() {
    let doc = with(|d| {
        d["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,@@@@not base64@@@@")
    });
    // The element is not the whole URI: a data URI can be megabytes long.
    scene_error(
        "bad-base64",
        &doc,
        &[],
        "buffers[0] (data URI)",
        "not valid base64",
    );
}

#[test]
fn remote_buffer_uri() {
    let doc = with(|d| d["buffers"][0]["uri"] = json!("https://example.com/tri.bin"));
    scene_error(
        "remote-uri",
        &doc,
        &[],
        "buffers[0] (uri \"https://example.com/tri.bin\")",
        "only relative paths and data: URIs",
    );
}

#[test]
fn buffer_view_past_its_buffer() {
    let doc = with(|d| d["bufferViews"][0]["byteOffset"] = json!(100));
    scene_error(
        "view-past-buffer",
        &doc,
        &[],
        "bufferViews[0]",
        "bytes 100..136 lie outside buffers[0], which has 104 bytes",
    );
}

#[test]
fn accessor_offset_past_its_view() {
    let doc = with(|d| d["accessors"][0]["byteOffset"] = json!(4));
    scene_error(
        "accessor-offset",
        &doc,
        &[],
        "accessors[0] (POSITION of meshes[0] (\"tri\").primitives[0])",
        "3 elements of 12 bytes from byte 4 with stride 12 do not fit in bufferViews[0], which \
         has 36 bytes",
    );
}

#[test]
fn accessor_count_of_four_billion() {
    let doc = with(|d| d["accessors"][0]["count"] = json!(4_294_967_295u64));
    scene_error(
        "huge-count",
        &doc,
        &[],
        "accessors[0] (POSITION of meshes[0] (\"tri\").primitives[0])",
        "count 4294967295 is too large",
    );
}

#[test]
fn byte_stride_that_overlaps_elements() {
    let doc = with(|d| d["bufferViews"][0]["byteStride"] = json!(8));
    scene_error(
        "small-stride",
        &doc,
        &[],
        "accessors[0] (POSITION of meshes[0] (\"tri\").primitives[0])",
        "bufferViews[0] has byteStride 8, less than its 12-byte elements",
    );
}

// --- out-of-range indices --------------------------------------------------------------------

#[test]
fn vertex_index_past_the_last_vertex() {
    let doc = with(|d| {
        let mut buffer = base_buffer(&POSITIONS);
        buffer[98..100].copy_from_slice(&7u16.to_le_bytes());
        d["buffers"][0]["uri"] = json!(data_uri(&buffer));
    });
    scene_error(
        "index-7",
        &doc,
        &[],
        "accessors[3] (indices of meshes[0] (\"tri\").primitives[0])",
        "index 7 at position 1 is out of range: POSITION has 3 vertices",
    );
}

#[test]
fn index_accessor_of_floats() {
    let doc = with(|d| d["meshes"][0]["primitives"][0]["indices"] = json!(0));
    scene_error(
        "float-indices",
        &doc,
        &[],
        "accessors[0] (indices of meshes[0] (\"tri\").primitives[0])",
        "index accessors hold unsigned integers, not F32",
    );
}

#[test]
fn attribute_that_names_no_accessor() {
    let doc = with(|d| d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(9));
    scene_error(
        "position-9",
        &doc,
        &[],
        "meshes[0].primitives[0].attributes[\"POSITION\"]",
        "refers to an element that does not exist",
    );
}

#[test]
fn normals_fewer_than_positions() {
    let doc = with(|d| d["accessors"][1]["count"] = json!(2));
    scene_error(
        "normal-count",
        &doc,
        &[],
        "accessors[1] (NORMAL of meshes[0] (\"tri\").primitives[0])",
        "has 2 elements, POSITION has 3",
    );
}

#[test]
fn positions_stored_as_vec2() {
    let doc = with(|d| d["accessors"][0]["type"] = json!("VEC2"));
    scene_error(
        "position-vec2",
        &doc,
        &[],
        "accessors[0] (POSITION of meshes[0] (\"tri\").primitives[0])",
        "has type Vec2, expected Vec3",
    );
}

#[test]
fn material_that_does_not_exist() {
    let doc = with(|d| d["meshes"][0]["primitives"][0]["material"] = json!(5));
    scene_error(
        "material-5",
        &doc,
        &[],
        "meshes[0].primitives[0].material",
        "refers to an element that does not exist",
    );
}

#[test]
fn node_mesh_that_does_not_exist() {
    let doc = with(|d| d["nodes"][1]["mesh"] = json!(4));
    scene_error(
        "mesh-4",
        &doc,
        &[],
        "nodes[1].mesh",
        "refers to an element that does not exist",
    );
}

#[test]
fn scene_root_that_does_not_exist() {
    let doc = with(|d| d["scenes"][0]["nodes"] = json!([0, 12]));
    scene_error(
        "root-12",
        &doc,
        &[],
        "scenes[0].nodes[1]",
        "refers to an element that does not exist",
    );
}

#[test]
fn default_scene_that_does_not_exist() {
    let doc = with(|d| d["scene"] = json!(3));
    scene_error(
        "scene-3",
        &doc,
        &[],
        "scene",
        "refers to an element that does not exist",
    );
}

#[test]
fn child_that_does_not_exist() {
    let doc = with(|d| d["nodes"][0]["children"] = json!([40]));
    scene_error(
        "child-40",
        &doc,
        &[],
        "nodes[0].children[0]",
        "refers to an element that does not exist",
    );
}

#[test]
fn light_that_does_not_exist() {
    let doc = with(|d| d["nodes"][3]["extensions"]["KHR_lights_punctual"]["light"] = json!(2));
    scene_error(
        "light-2",
        &doc,
        &[],
        "nodes[3].extensions.KHR_lights_punctual.light",
        "refers to an element that does not exist",
    );
}

#[test]
fn sparse_index_past_the_accessor() {
    let doc = with(|d| {
        // One sparse substitution at vertex 9 of 3; its index and value in a buffer of their own.
        let mut extra: Vec<u8> = 9u16.to_le_bytes().to_vec();
        extra.extend([0, 0]);
        extra.extend(bytemuck::cast_slice(&[0.5f32, 0.5, 0.5]));
        d["buffers"]
            .as_array_mut()
            .unwrap()
            .push(json!({"byteLength": extra.len(), "uri": data_uri(&extra)}));
        let views = d["bufferViews"].as_array_mut().unwrap();
        views.push(json!({"buffer": 1, "byteOffset": 0, "byteLength": 2}));
        views.push(json!({"buffer": 1, "byteOffset": 4, "byteLength": 12}));
        d["accessors"][0]["sparse"] = json!({
            "count": 1,
            "indices": {"bufferView": 4, "componentType": 5123},
            "values": {"bufferView": 5}
        });
    });
    scene_error(
        "sparse-9",
        &doc,
        &[],
        "accessors[0] (POSITION of meshes[0] (\"tri\").primitives[0]).sparse",
        "index 9 is out of range: the accessor has 3 elements",
    );
}

// --- NaN and infinite positions --------------------------------------------------------------

/// A triangle with a NaN vertex is dropped (it cannot be traced) with a warning naming the
/// primitive; the other instances of the same mesh lose it too, so here nothing is left.
#[test]
fn nan_vertex_leaves_no_triangles() {
    let doc = with_positions([[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    scene_error(
        "nan-vertex",
        &doc,
        &[],
        "scenes[0] (\"scene\")",
        "has no triangles to trace (skipped: meshes[0] (\"tri\").primitives[0]: triangles with \
         a NaN or infinite vertex position are dropped)",
    );
}

#[test]
fn infinite_vertex_leaves_no_triangles() {
    let doc = with_positions([[0.0, 0.0, 0.0], [1.0, f32::INFINITY, 0.0], [0.0, 1.0, 0.0]]);
    scene_error(
        "inf-vertex",
        &doc,
        &[],
        "scenes[0] (\"scene\")",
        "triangles with a NaN or infinite vertex position are dropped",
    );
}

/// Within `MAX_WORLD_COORDINATE` in object space, beyond it once placed: that instance is
/// dropped with a warning (squared distances of its positions would overflow `f32`), the other
/// instance stays.
#[test]
fn vertex_placed_beyond_the_world_limit() {
    let doc = with(|d| {
        let buffer = base_buffer(&[[0.0, 0.0, 0.0], [1e17, 0.0, 0.0], [0.0, 1e17, 0.0]]);
        d["buffers"][0]["uri"] = json!(data_uri(&buffer));
        d["accessors"][0]["max"] = json!([1e17, 1e17, 0.0]);
        d["nodes"][1]["scale"] = json!([100.0, 100.0, 100.0]);
    });
    let scene = scene_warning(
        "overflow-placed",
        &doc,
        &[],
        "nodes[1] (\"b\")",
        "world-space positions",
    );
    assert_eq!(scene.instances.len(), 1);
    assert!(scene.bounds.min.is_finite() && scene.bounds.max.is_finite());
}

#[test]
fn nan_normals_are_recomputed() {
    let doc = with(|d| {
        let mut buffer = base_buffer(&POSITIONS);
        buffer[36..40].copy_from_slice(&f32::NAN.to_le_bytes());
        d["buffers"][0]["uri"] = json!(data_uri(&buffer));
    });
    let scene = scene_warning(
        "nan-normal",
        &doc,
        &[],
        "meshes[0] (\"tri\").primitives[0]",
        "normals that are zero or not finite are replaced by computed ones",
    );
    assert!(scene.meshes[0].normals.iter().all(|n| n.is_finite()));
}

#[test]
fn infinite_uvs_become_zero() {
    let doc = with(|d| {
        let mut buffer = base_buffer(&POSITIONS);
        buffer[72..76].copy_from_slice(&f32::INFINITY.to_le_bytes());
        d["buffers"][0]["uri"] = json!(data_uri(&buffer));
    });
    let scene = scene_warning(
        "inf-uv",
        &doc,
        &[],
        "meshes[0] (\"tri\").primitives[0]",
        "UVs that are not finite are replaced by zero",
    );
    assert!(
        scene.meshes[0]
            .uvs
            .as_ref()
            .unwrap()
            .iter()
            .all(|uv| uv.is_finite())
    );
}

// --- scales and node matrices ----------------------------------------------------------------

/// A zero scale collapses the mesh to nothing: that instance is skipped with a warning (glTF
/// allows it, e.g. to hide an object), the other stays.
#[test]
fn zero_scale_skips_the_instance() {
    let doc = with(|d| d["nodes"][1]["scale"] = json!([0.0, 0.0, 0.0]));
    let scene = scene_warning(
        "zero-scale",
        &doc,
        &[],
        "nodes[1] (\"b\")",
        "has a singular transform",
    );
    assert_eq!(scene.instances.len(), 1);
    assert_eq!(scene.instances[0].name, "a");
}

/// One zero axis is as singular as three.
#[test]
fn one_zero_axis_skips_the_instance() {
    let doc = with(|d| d["nodes"][1]["scale"] = json!([1.0, 0.0, 1.0]));
    let scene = scene_warning(
        "flat-scale",
        &doc,
        &[],
        "nodes[1] (\"b\")",
        "has a singular transform",
    );
    assert_eq!(scene.instances.len(), 1);
}

/// A scale beyond `f32` (1e39 parses as infinity) is an error naming the node.
#[test]
fn infinite_scale() {
    let doc = with(|d| d["nodes"][1]["scale"] = json!([1e39, 1.0, 1.0]));
    scene_error(
        "inf-scale",
        &doc,
        &[],
        "nodes[1] (\"b\")",
        "has a transform that is not finite",
    );
}

/// A finite but huge scale puts the triangle far beyond where `f32` arithmetic on positions
/// (squared distances) stays finite: skipped with a warning.
#[test]
fn huge_scale_skips_the_instance() {
    let doc = with(|d| d["nodes"][1]["scale"] = json!([1e30, 1e30, 1e30]));
    let scene = scene_warning(
        "huge-scale",
        &doc,
        &[],
        "nodes[1] (\"b\")",
        "world-space positions",
    );
    assert_eq!(scene.instances.len(), 1);
    assert!(scene.bounds.max.max_element() < 10.0);
}

#[test]
fn tiny_scale_is_singular() {
    let doc = with(|d| d["nodes"][1]["scale"] = json!([1e-20, 1e-20, 1e-20]));
    scene_warning(
        "tiny-scale",
        &doc,
        &[],
        "nodes[1] (\"b\")",
        "has a singular transform",
    );
}

/// Translation only: the linear part is all zeros.
#[test]
fn matrix_without_a_linear_part() {
    let mut m = [0.0; 16];
    m[12] = 3.0;
    m[15] = 1.0;
    let doc = with(|d| d["nodes"][1]["matrix"] = json!(m));
    let scene = scene_warning(
        "zero-matrix",
        &doc,
        &[],
        "nodes[1] (\"b\")",
        "has a singular transform",
    );
    assert_eq!(scene.instances.len(), 1);
}

/// Rank 2: the z column is x + y.
#[test]
fn non_invertible_matrix() {
    let m = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 3.0, 0.0, 0.0, 1.0,
    ];
    let doc = with(|d| d["nodes"][1]["matrix"] = json!(m));
    scene_warning(
        "rank-2-matrix",
        &doc,
        &[],
        "nodes[1] (\"b\")",
        "has a singular transform",
    );
}

/// A projective last row: glTF node matrices must be affine (decomposable into TRS).
#[test]
fn projective_matrix() {
    let m = [
        1.0, 0.0, 0.0, 0.5, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ];
    let doc = with(|d| d["nodes"][1]["matrix"] = json!(m));
    scene_error(
        "projective-matrix",
        &doc,
        &[],
        "nodes[1] (\"b\")",
        "not affine",
    );
}

#[test]
fn matrix_with_an_infinite_element() {
    let mut m = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ];
    m[12] = 1e39;
    let doc = with(|d| d["nodes"][1]["matrix"] = json!(m));
    scene_error(
        "inf-matrix",
        &doc,
        &[],
        "nodes[1] (\"b\")",
        "has a transform that is not finite",
    );
}

#[test]
fn zero_rotation_quaternion() {
    let doc = with(|d| d["nodes"][1]["rotation"] = json!([0.0, 0.0, 0.0, 0.0]));
    scene_error(
        "zero-quaternion",
        &doc,
        &[],
        "nodes[1] (\"b\")",
        "zero rotation quaternion",
    );
}

#[test]
fn camera_on_a_singular_node_is_skipped() {
    let doc = with(|d| d["nodes"][2]["scale"] = json!([0.0, 0.0, 0.0]));
    let scene = scene_warning(
        "singular-camera",
        &doc,
        &[],
        "nodes[2] (\"eye\")",
        "camera has no direction: skipped",
    );
    assert!(scene.cameras.is_empty());
}

// --- the node graph --------------------------------------------------------------------------

#[test]
fn node_that_is_its_own_child() {
    let doc = with(|d| d["nodes"][1]["children"] = json!([1]));
    scene_error(
        "self-child",
        &doc,
        &[],
        "nodes[1] (\"b\")",
        "the node hierarchy has a cycle",
    );
}

#[test]
fn two_node_cycle() {
    let doc = with(|d| {
        d["nodes"][0]["children"] = json!([1]);
        d["nodes"][1]["children"] = json!([0]);
        d["scenes"][0]["nodes"] = json!([0, 2, 3]);
    });
    scene_error(
        "two-cycle",
        &doc,
        &[],
        "nodes[0] (\"a\")",
        "the node hierarchy has a cycle",
    );
}

/// glTF node hierarchies are disjoint trees: a node with two parents would be placed twice.
#[test]
fn node_with_two_parents() {
    let doc = with(|d| {
        d["nodes"][2]["children"] = json!([1]);
        d["nodes"][3]["children"] = json!([1]);
        d["scenes"][0]["nodes"] = json!([0, 2, 3]);
    });
    scene_error(
        "two-parents",
        &doc,
        &[],
        "nodes[1] (\"b\")",
        "reached twice",
    );
}

#[test]
fn root_listed_twice() {
    let doc = with(|d| d["scenes"][0]["nodes"] = json!([0, 1, 2, 3, 1]));
    scene_error("root-twice", &doc, &[], "nodes[1] (\"b\")", "reached twice");
}

#[test]
fn hierarchy_two_thousand_deep() {
    let doc = with(|d| {
        let nodes = d["nodes"].as_array_mut().unwrap();
        let first = nodes.len();
        nodes[0]["children"] = json!([first]);
        for i in 0..2000 {
            let next = if i + 1 < 2000 {
                json!([first + i + 1])
            } else {
                json!([])
            };
            nodes.push(json!({"children": next}));
        }
        nodes
            .last_mut()
            .unwrap()
            .as_object_mut()
            .unwrap()
            .remove("children");
    });
    scene_error(
        "deep",
        &doc,
        &[],
        "nodes[1027]",
        "the node hierarchy is deeper than 1024 levels",
    );
}

// --- textures --------------------------------------------------------------------------------

/// Loads the base with its texture image replaced by `bytes` (as `name`): the texture is dropped
/// with a warning naming the image and why, and the material keeps its factor.
fn texture_fallback(test: &str, name: &str, bytes: &[u8], why: &str) {
    let doc = with(|d| d["images"][0]["uri"] = json!(name));
    let scene = scene_warning(
        test,
        &doc,
        &[(name, bytes)],
        &format!("images[0] (uri {name:?})"),
        why,
    );
    assert!(scene.textures.is_empty());
    assert_eq!(scene.materials[0].base_color_texture, None);
    assert_eq!(scene.materials[0].base_color.x, 0.5);
}

#[test]
fn missing_texture_file() {
    let doc = with(|d| d["images"][0]["uri"] = json!("gone.png"));
    let scene = scene_warning(
        "missing-png",
        &doc,
        &[],
        "images[0] (uri \"gone.png\")",
        "cannot read",
    );
    assert!(scene.textures.is_empty());
}

#[test]
fn png_of_garbage() {
    texture_fallback("garbage-png", "noise.png", &[0x5a; 300], "cannot decode it");
}

#[test]
fn png_cut_in_half() {
    let png = png();
    texture_fallback(
        "cut-png",
        "cut.png",
        &png[..png.len() / 2],
        "cannot decode it",
    );
}

#[test]
fn png_claiming_100000_by_100000_texels() {
    // Signature and an IHDR chunk only (CRC left wrong: the size is refused first or the CRC is).
    let mut bytes = b"\x89PNG\r\n\x1a\n".to_vec();
    bytes.extend(13u32.to_be_bytes());
    bytes.extend(b"IHDR");
    bytes.extend(100_000u32.to_be_bytes());
    bytes.extend(100_000u32.to_be_bytes());
    bytes.extend([8, 6, 0, 0, 0]);
    bytes.extend([0; 4]);
    texture_fallback("huge-png", "huge.png", &bytes, "cannot decode it");
}

#[test]
fn jpeg_of_garbage() {
    let mut bytes = vec![0xFF, 0xD8, 0xFF, 0xE0];
    bytes.extend([0x13; 200]);
    texture_fallback("garbage-jpeg", "noise.jpg", &bytes, "cannot decode it");
}

#[test]
fn ktx2_of_garbage() {
    let mut bytes = b"\xABKTX 20\xBB\r\n\x1A\n".to_vec();
    bytes.extend([0xEE; 100]);
    texture_fallback("garbage-ktx2", "noise.ktx2", &bytes, "KTX2: ");
}

#[test]
fn dds_of_garbage() {
    let mut bytes = b"DDS ".to_vec();
    bytes.extend([0x7C; 60]);
    texture_fallback("garbage-dds", "noise.dds", &bytes, "DDS: ");
}

#[test]
fn texture_image_of_bad_base64() {
    let doc = with(|d| d["images"][0] = json!({"uri": "data:image/png;base64,%%%%"}));
    let scene = scene_warning(
        "image-base64",
        &doc,
        &[],
        "images[0]",
        "data URI is not valid base64",
    );
    assert!(scene.textures.is_empty());
}

#[test]
fn texture_image_in_a_buffer_view_past_its_buffer() {
    let doc = with(|d| {
        d["bufferViews"]
            .as_array_mut()
            .unwrap()
            .push(json!({"buffer": 0, "byteOffset": 64, "byteLength": 4000}));
        d["images"][0] = json!({"bufferView": 4, "mimeType": "image/png"});
    });
    let scene = scene_warning(
        "image-view",
        &doc,
        &[],
        "images[0]",
        "bytes 64..4064 lie outside buffers[0], which has 104 bytes",
    );
    assert!(scene.textures.is_empty());
}

#[test]
fn texture_that_does_not_exist() {
    let doc =
        with(|d| d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"] = json!(6));
    scene_error(
        "texture-6",
        &doc,
        &[],
        "materials[0].pbrMetallicRoughness.baseColorTexture.index",
        "refers to an element that does not exist",
    );
}

#[test]
fn texture_source_that_does_not_exist() {
    let doc = with(|d| d["textures"][0]["source"] = json!(3));
    scene_error(
        "source-3",
        &doc,
        &[],
        "textures[0].source",
        "refers to an element that does not exist",
    );
}

// --- extensions ------------------------------------------------------------------------------

#[test]
fn required_mesh_compression() {
    let doc = with(|d| {
        d["extensionsUsed"] = json!(["KHR_lights_punctual", "EXT_meshopt_compression"]);
        d["extensionsRequired"] = json!(["EXT_meshopt_compression"]);
    });
    scene_error(
        "meshopt",
        &doc,
        &[],
        "extensionsRequired[0]",
        "required extension EXT_meshopt_compression is not supported",
    );
}

#[test]
fn required_extension_second_in_the_list() {
    let doc = with(|d| {
        d["extensionsUsed"] = json!(["KHR_lights_punctual", "KHR_draco_mesh_compression"]);
        d["extensionsRequired"] = json!(["KHR_lights_punctual", "KHR_draco_mesh_compression"]);
    });
    scene_error(
        "draco",
        &doc,
        &[],
        "extensionsRequired[1]",
        "required extension KHR_draco_mesh_compression is not supported",
    );
}

#[test]
fn unsupported_optional_extension_is_a_warning() {
    let doc = with(|d| {
        d["extensionsUsed"] = json!(["KHR_lights_punctual", "KHR_materials_clearcoat"]);
    });
    scene_warning(
        "clearcoat",
        &doc,
        &[],
        "extensionsUsed[1]",
        "extension KHR_materials_clearcoat is not supported",
    );
}

// --- absurd lights ---------------------------------------------------------------------------

/// Loads the base with light 0's `field` set to `value`: the light is skipped with a warning
/// naming it.
fn light_skipped(test: &str, field: &str, value: Value, why: &str) {
    let doc = with(|d| d["extensions"]["KHR_lights_punctual"]["lights"][0][field] = value);
    let scene = scene_warning(
        test,
        &doc,
        &[],
        "KHR_lights_punctual.lights[0] (\"bulb\")",
        why,
    );
    assert!(scene.lights.is_empty());
}

#[test]
fn negative_light_intensity() {
    light_skipped(
        "light-negative",
        "intensity",
        json!(-5.0),
        "colour or intensity is negative or not finite",
    );
}

#[test]
fn infinite_light_intensity() {
    light_skipped(
        "light-inf",
        "intensity",
        json!(1e39),
        "colour or intensity is negative or not finite",
    );
}

/// 1e30 candela: finite, but its light overflows `f32` once squared or summed (radiance, MIS
/// weights).
#[test]
fn light_intensity_of_1e30() {
    light_skipped("light-1e30", "intensity", json!(1e30), "larger than");
}

#[test]
fn negative_light_colour() {
    light_skipped(
        "light-colour",
        "color",
        json!([1.0, -1.0, 1.0]),
        "colour or intensity is negative or not finite",
    );
}

#[test]
fn light_of_an_unknown_type() {
    let doc =
        with(|d| d["extensions"]["KHR_lights_punctual"]["lights"][0]["type"] = json!("laser"));
    scene_error(
        "light-laser",
        &doc,
        &[],
        "extensions.KHR_lights_punctual.lights[0].type",
        "has an invalid value",
    );
}

#[test]
fn spot_light_with_inner_cone_wider_than_outer() {
    let doc = with(|d| {
        d["extensions"]["KHR_lights_punctual"]["lights"][0] = json!({
            "name": "bulb", "type": "spot", "intensity": 10.0,
            "spot": {"innerConeAngle": 0.7, "outerConeAngle": 0.3}
        })
    });
    scene_warning(
        "spot-cones",
        &doc,
        &[],
        "KHR_lights_punctual.lights[0] (\"bulb\")",
        "spot cone angles must satisfy 0 <= inner < outer <= π/2",
    );
}

#[test]
fn zero_light_range_is_ignored() {
    let doc = with(|d| d["extensions"]["KHR_lights_punctual"]["lights"][0]["range"] = json!(0.0));
    let scene = scene_warning(
        "light-range",
        &doc,
        &[],
        "KHR_lights_punctual.lights[0] (\"bulb\")",
        "a light range must be positive",
    );
    assert_eq!(scene.lights[0].range, None);
}

/// Emission of 1e30 (factor × strength): as absurd as the light above, replaced by zero.
#[test]
fn emissive_strength_of_1e30() {
    let doc = with(|d| {
        d["extensionsUsed"] = json!(["KHR_lights_punctual", "KHR_materials_emissive_strength"]);
        d["materials"][0]["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
        d["materials"][0]["extensions"] =
            json!({"KHR_materials_emissive_strength": {"emissiveStrength": 1e30}});
    });
    let scene = scene_warning(
        "emission-1e30",
        &doc,
        &[],
        "materials[0] (\"paint\").emissiveStrength",
        "replaced by zero",
    );
    assert_eq!(scene.materials[0].emissive, Vec3::ZERO);
    assert!(scene.emissive_triangles.is_empty());
}

/// glTF factors are at least 0: a negative one is replaced by zero, the material kept.
#[test]
fn negative_emissive_factor() {
    let doc = with(|d| d["materials"][0]["emissiveFactor"] = json!([1.0, -2.0, 1.0]));
    let scene = scene_warning(
        "emission-negative",
        &doc,
        &[],
        "materials[0] (\"paint\").emissiveFactor",
        "negative or non-finite material factors are replaced by zero",
    );
    assert_eq!(scene.materials[0].emissive, Vec3::new(1.0, 0.0, 1.0));
}

// --- cameras ---------------------------------------------------------------------------------

#[test]
fn camera_with_zero_field_of_view() {
    let doc = with(|d| d["cameras"][0]["perspective"]["yfov"] = json!(0.0));
    let scene = scene_warning(
        "camera-yfov",
        &doc,
        &[],
        "cameras[0] (\"cam\")",
        "a camera needs 0 < yfov < π",
    );
    assert!(scene.cameras.is_empty());
}

#[test]
fn camera_with_far_plane_before_near_plane() {
    let doc = with(|d| d["cameras"][0]["perspective"]["zfar"] = json!(0.01));
    scene_warning(
        "camera-zfar",
        &doc,
        &[],
        "cameras[0] (\"cam\")",
        "0 < znear < zfar",
    );
}

// --- environment maps ------------------------------------------------------------------------

#[test]
fn hdr_environment_of_garbage() {
    let dir = folder(
        "env-hdr",
        &[("sky.hdr", b"#?RADIANCE\nFORMAT=garbage\n\n-Y x +X y\n")],
    );
    let path = dir.join("sky.hdr");
    image_error(Environment::read(&path), &path, "cannot decode");
}

#[test]
fn hdr_environment_claiming_100000_by_100000_texels() {
    let header = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n";
    let dir = folder("env-hdr-huge", &[("sky.hdr", header)]);
    let path = dir.join("sky.hdr");
    image_error(Environment::read(&path), &path, "cannot decode");
}

#[test]
fn exr_environment_of_garbage() {
    let dir = folder(
        "env-exr",
        &[("sky.exr", &[0x76, 0x2f, 0x31, 0x01, 9, 9, 9, 9])],
    );
    let path = dir.join("sky.exr");
    image_error(Environment::read(&path), &path, "cannot read OpenEXR");
}

#[test]
fn exr_environment_cut_short() {
    let dir = folder("env-exr-cut", &[]);
    let path = dir.join("sky.exr");
    HdrImage::from_pixels(8, 4, vec![[1.0, 0.5, 0.25]; 32])
        .unwrap()
        .write_exr(&path)
        .unwrap();
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() * 2 / 3]).unwrap();
    image_error(Environment::read(&path), &path, "cannot read OpenEXR");
}

/// An environment texel that is NaN or infinite would reach every ray that escapes: an error
/// naming the texel.
#[test]
fn exr_environment_with_a_nan_texel() {
    let dir = folder("env-exr-nan", &[]);
    let path = dir.join("sky.exr");
    let mut pixels = vec![[1.0, 0.5, 0.25]; 32];
    pixels[8 + 3] = [0.0, f32::NAN, 0.0];
    HdrImage::from_pixels(8, 4, pixels)
        .unwrap()
        .write_exr(&path)
        .unwrap();
    image_error(Environment::read(&path), &path, "texel (3, 1) is NaN");
}

#[test]
fn missing_environment_file() {
    let path = std::env::temp_dir().join("gi-malformed-no-such-sky.exr");
    image_error(Environment::read(&path), &path, "cannot read: No such file");
}

// --- image requests and settings (the library API; `cli.rs` has the command line) -------------

fn settings() -> GiSettings {
    GiSettings::for_resolution(64, 36)
}

#[test]
fn zero_by_zero_image() {
    invalid_argument(settings().validate(0, 0), "resolution", "0x0");
}

#[test]
fn image_of_100000_by_100000() {
    invalid_argument(
        settings().validate(100_000, 100_000),
        "resolution",
        "100000x100000: each side must be 1 to 3840x2160",
    );
}

#[test]
fn hdr_image_of_zero_pixels() {
    invalid_argument(
        HdrImage::new(0, 0).map(drop),
        "image size",
        "0x0 has no pixels",
    );
}

#[test]
fn cache_of_zero_buckets() {
    let s = GiSettings {
        buckets_log2: 0,
        ..settings()
    };
    invalid_argument(
        s.validate(64, 36),
        "buckets_log2",
        "the cache needs at least 2 buckets",
    );
}

#[test]
fn cache_larger_than_a_storage_binding() {
    let s = GiSettings {
        buckets_log2: 40,
        ..settings()
    };
    invalid_argument(
        s.validate(64, 36),
        "buckets_log2",
        "tiles fit one storage binding",
    );
}

/// A shift count beyond `u32` must not overflow while it is checked.
#[test]
fn tiles_per_bucket_of_u32_max() {
    let s = GiSettings {
        tiles_per_bucket_log2: u32::MAX,
        ..settings()
    };
    invalid_argument(
        s.validate(64, 36),
        "buckets_log2",
        "tiles fit one storage binding",
    );
}

#[test]
fn nan_cell_size() {
    let s = GiSettings {
        cell_size_pixels: f32::NAN,
        ..settings()
    };
    invalid_argument(
        s.validate(64, 36),
        "cell_size_pixels",
        "NaN: must be a positive number of pixels",
    );
}

#[test]
fn zero_sample_cap() {
    let s = GiSettings {
        sample_cap: 0,
        ..settings()
    };
    invalid_argument(s.validate(64, 36), "sample_cap", "0: must be 1 to 1024");
}

#[test]
fn negative_min_cell_size() {
    let s = GiSettings {
        min_cell_size: -0.5,
        ..settings()
    };
    invalid_argument(s.validate(64, 36), "min_cell_size", "-0.5");
}

#[test]
fn zero_light_candidates() {
    let s = GiSettings {
        light_candidates: 0,
        ..settings()
    };
    invalid_argument(s.validate(64, 36), "light_candidates", "0: must be 1 to");
}

fn view() -> ViewOptions {
    ViewOptions {
        sky: Vec3::ZERO,
        emissive_multiplier: 1.0,
        seed: 0,
    }
}

#[test]
fn nan_emissive_multiplier() {
    let v = ViewOptions {
        emissive_multiplier: f32::NAN,
        ..view()
    };
    invalid_argument(v.validate(), "emissive_multiplier", "NaN");
}

#[test]
fn nan_sky() {
    let v = ViewOptions {
        sky: Vec3::new(1.0, f32::NAN, 1.0),
        ..view()
    };
    invalid_argument(v.validate(), "sky", "NaN");
}

#[test]
fn negative_sky() {
    let v = ViewOptions {
        sky: Vec3::new(-1.0, 0.0, 0.0),
        ..view()
    };
    invalid_argument(v.validate(), "sky", "-1");
}

#[test]
fn nan_exposure() {
    let dir = folder("nan-exposure", &[]);
    let image = HdrImage::from_pixels(2, 2, vec![[0.5; 3]; 4]).unwrap();
    let tone = ToneMap {
        exposure: f32::NAN,
        ..ToneMap::default()
    };
    invalid_argument(
        image.write_png(dir.join("out.png"), &tone),
        "exposure",
        "NaN",
    );
    assert!(!dir.join("out.png").exists());
}

// --- the command line: refused while parsing, before any device is opened -------------------

/// Runs `gi args`, which must fail with clap's usage error (exit status 2) whose first line names
/// `option` and says `why`.
fn cli_error(args: &[&str], option: &str, why: &str) {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/cornell-box.gltf");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_gi"))
        .args(args.iter().map(|a| if *a == "SCENE" { scene } else { a }))
        .env("VK_ICD_FILENAMES", "/nonexistent.json")
        .output()
        .expect("gi runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    let first = stderr.lines().next().unwrap_or_default();
    assert!(first.starts_with("error: invalid value"), "{stderr}");
    assert!(first.contains(option) && first.contains(why), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn cli_zero_width() {
    cli_error(
        &["render", "SCENE", "--width", "0"],
        "--width",
        "0 is not in 1..=8192",
    );
}

#[test]
fn cli_100000_by_100000() {
    cli_error(
        &["render", "SCENE", "--width", "100000", "--height", "100000"],
        "--width",
        "100000 is not in 1..=8192",
    );
}

#[test]
fn cli_negative_spp() {
    cli_error(
        &["render", "SCENE", "--spp=-4"],
        "--spp",
        "-4 is not in 1..=1048576",
    );
}

#[test]
fn cli_zero_frames() {
    cli_error(
        &["render", "SCENE", "--method", "gi", "--frames", "0"],
        "--frames",
        "0 is not in 1..=1048576",
    );
}

#[test]
fn cli_nan_exposure() {
    cli_error(
        &["render", "SCENE", "--exposure", "NaN"],
        "--exposure",
        "\"NaN\" is not a finite number",
    );
}

#[test]
fn cli_infinite_compare_exposure() {
    cli_error(
        &["compare", "a.exr", "b.exr", "--exposure", "inf"],
        "--exposure",
        "\"inf\" is not a finite number",
    );
}

#[test]
fn cli_zero_field_of_view() {
    cli_error(
        &["render", "SCENE", "--fov", "0"],
        "--fov",
        "not a field of view between 0 and 180 degrees",
    );
}

#[test]
fn cli_nan_sky() {
    cli_error(
        &["render", "SCENE", "--sky", "nan,0,0"],
        "--sky",
        "not a radiance r,g,b of three finite numbers ≥ 0",
    );
}

#[test]
fn cli_negative_emissive_multiplier() {
    cli_error(
        &["render", "SCENE", "--emissive-multiplier=-1"],
        "--emissive-multiplier",
        "\"-1\" is not a finite number ≥ 0",
    );
}
