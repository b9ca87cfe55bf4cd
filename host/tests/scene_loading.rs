//! Scene loading: our scenes and a real Blender export load with the expected contents, and every
//! kind of bad input gives an error or a warning that names the file and the element at fault.
//! CPU only: no Vulkan device needed.

use gi_host::Error;
use gi_host::scene::{LUMENS_PER_WATT, LightKind, Scene, Warning, Wrap};
use glam::{Vec3, Vec4};
use std::path::{Path, PathBuf};

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
}

fn load(path: &str) -> (Scene, Vec<Warning>) {
    match Scene::load(repo(path)) {
        Ok(loaded) => loaded,
        Err(e) => panic!("{path} does not load: {e}"),
    }
}

/// Loads a file that must fail, checks that the message names the file, and returns the element
/// and the reason.
fn scene_error(path: &str) -> (String, String) {
    let file = repo(path);
    match Scene::load(&file) {
        Ok(_) => panic!("{path} loads, but it should fail"),
        Err(e @ Error::Scene { .. }) => {
            let message = e.to_string();
            let Error::Scene {
                file: at,
                element,
                why,
            } = e
            else {
                unreachable!()
            };
            assert_eq!(at, file);
            assert!(message.contains(&*file.to_string_lossy()), "{message}");
            (element, why)
        }
        Err(e) => panic!("{path}: not a scene error: {e}"),
    }
}

/// The one warning whose message contains `what`.
fn warning<'w>(warnings: &'w [Warning], what: &str) -> &'w Warning {
    let found: Vec<_> = warnings
        .iter()
        .filter(|w| w.message.contains(what))
        .collect();
    assert_eq!(found.len(), 1, "warnings about {what:?}: {warnings:#?}");
    found[0]
}

// --- bad input ------------------------------------------------------------------------------

#[test]
fn malformed_json_is_an_error_with_its_position() {
    let (element, why) = scene_error("tests/data/bad/malformed-json.gltf");
    assert_eq!(element, "JSON");
    assert!(
        why.contains("malformed glTF JSON") && why.contains("line"),
        "{why}"
    );
}

#[test]
fn missing_bin_names_the_buffer_and_the_file() {
    let (element, why) = scene_error("tests/data/bad/missing-bin.gltf");
    assert_eq!(element, "buffers[0] (uri \"missing.bin\")");
    assert!(
        why.contains("missing.bin") && why.contains("cannot read"),
        "{why}"
    );
}

#[test]
fn accessor_past_its_buffer_view_is_an_error() {
    let (element, why) = scene_error("tests/data/bad/accessor-out-of-range.gltf");
    assert_eq!(
        element,
        "accessors[0] (POSITION of meshes[0] (\"tri\").primitives[0])"
    );
    assert!(why.contains("bufferViews[0], which has 36 bytes"), "{why}");
}

#[test]
fn reference_to_a_missing_accessor_is_an_error() {
    let (element, why) = scene_error("tests/data/bad/accessor-reference-out-of-range.gltf");
    assert_eq!(element, "meshes[0].primitives[0].indices");
    assert!(why.contains("does not exist"), "{why}");
}

#[test]
fn index_past_the_last_vertex_is_an_error() {
    let (element, why) = scene_error("tests/data/bad/index-out-of-range.gltf");
    assert_eq!(
        element,
        "accessors[1] (indices of meshes[0] (\"tri\").primitives[0])"
    );
    assert!(
        why.contains("index 5 at position 2") && why.contains("3 vertices"),
        "{why}"
    );
}

#[test]
fn non_finite_positions_drop_their_triangles_with_a_warning() {
    let file = "tests/data/bad/nan-positions.gltf";
    let (scene, warnings) = load(file);
    assert_eq!(scene.triangle_count(), 1);
    let w = warning(&warnings, "NaN or infinite");
    assert_eq!(w.file, repo(file));
    assert_eq!(w.element, "meshes[0] (\"tri\").primitives[0]");
    assert_eq!(w.count, 2);
    assert!(w.to_string().contains("nan-positions.gltf"));
    assert!(scene.bounds.min.is_finite() && scene.bounds.max.is_finite());
}

#[test]
fn degenerate_triangles_are_dropped_with_one_counting_warning() {
    let (scene, warnings) = load("tests/data/bad/degenerate-triangles.gltf");
    assert_eq!(scene.triangle_count(), 2);
    assert_eq!(warnings.len(), 1, "{warnings:#?}");
    let w = warning(&warnings, "degenerate (zero-area) triangles are dropped");
    assert_eq!(
        (w.element.as_str(), w.count),
        ("meshes[0] (\"tri\").primitives[0]", 2)
    );
    // The vertex used only by dropped triangles is gone too.
    assert_eq!(scene.meshes[0].positions.len(), 4);
}

#[test]
fn a_scene_without_triangles_is_an_error_that_says_what_was_skipped() {
    let (element, why) = scene_error("tests/data/bad/no-triangles.gltf");
    assert_eq!(element, "scenes[0] (\"scene\")");
    assert!(why.contains("no triangles"), "{why}");
    assert!(why.contains("Points primitives are skipped"), "{why}");
}

#[test]
fn a_missing_texture_falls_back_to_the_factor_with_a_warning() {
    let (scene, warnings) = load("tests/data/bad/missing-texture.gltf");
    let w = warning(&warnings, "missing.png");
    assert_eq!(w.element, "images[0] (uri \"missing.png\")");
    assert!(
        w.message
            .contains("materials[0] (\"checker\").baseColorTexture"),
        "{w}"
    );
    assert!(scene.textures.is_empty());
    let material = &scene.materials[0];
    assert_eq!(material.base_color_texture, None);
    assert_eq!(material.base_color, Vec4::new(0.5, 0.25, 1.0, 1.0));
    assert_eq!(scene.triangle_count(), 1);
}

#[test]
fn an_unsupported_required_extension_is_an_error_naming_it() {
    let (element, why) = scene_error("tests/data/bad/unsupported-required-extension.gltf");
    assert_eq!(element, "extensionsRequired[0]");
    assert!(why.contains("KHR_draco_mesh_compression"), "{why}");
}

#[test]
fn a_truncated_glb_is_an_error() {
    let (element, why) = scene_error("tests/data/bad/truncated.glb");
    assert_eq!(element, "GLB container");
    assert!(why.contains("4096"), "{why}");
}

#[test]
fn a_missing_file_is_an_error() {
    let (element, why) = scene_error("tests/data/bad/no-such-file.gltf");
    assert_eq!(element, "file");
    assert!(why.contains("cannot read"), "{why}");
}

/// Replaces every number of two documents in turn by hostile values, and cuts a document and a
/// GLB short at many places: the loader must answer each with a result, never a panic.
#[test]
fn mutated_documents_never_panic() {
    let dir = std::env::temp_dir().join(format!("gi-scene-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // The textured scene's buffer and image beside the mutated files, so that loading gets past
    // them to materials and textures.
    for file in ["textured.bin", "checker.png"] {
        std::fs::copy(repo("scenes").join(file), dir.join(file)).unwrap();
    }
    let path = dir.join("mutated.gltf");
    let try_load = |bytes: &[u8]| {
        std::fs::write(&path, bytes).unwrap();
        let _ = Scene::load(&path);
    };
    for source in [
        "tests/data/bad/missing-texture.gltf",
        "scenes/textured.gltf",
        // Embedded, so every mutation reaches the animation parser.
        "scenes/moving-box.gltf",
    ] {
        let text = std::fs::read_to_string(repo(source)).unwrap();
        let numbers = number_spans(&text);
        assert!(numbers.len() > 30, "{source}: {} numbers", numbers.len());
        for &(start, end) in &numbers {
            for value in [
                "-1",
                "0",
                "3",
                "5125",
                "4294967295",
                "18446744073709551616",
                "1e39",
            ] {
                try_load(format!("{}{value}{}", &text[..start], &text[end..]).as_bytes());
            }
        }
        for cut in (0..text.len()).step_by(37) {
            try_load(&text.as_bytes()[..cut]);
        }
    }
    let glb = std::fs::read(repo("scenes/cornell-box.glb")).unwrap();
    for at in 0..64 {
        for value in [0x00, 0xff] {
            let mut bytes = glb.clone();
            bytes[at] = value;
            try_load(&bytes);
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Byte ranges of the JSON numbers outside strings.
fn number_spans(json: &str) -> Vec<(usize, usize)> {
    let bytes = json.as_bytes();
    let (mut spans, mut in_string, mut i) = (Vec::new(), false, 0);
    while i < bytes.len() {
        let c = bytes[i];
        if in_string {
            match c {
                b'\\' => i += 1,
                b'"' => in_string = false,
                _ => {}
            }
            i += 1;
        } else if c == b'"' {
            in_string = true;
            i += 1;
        } else if c == b'-' || c.is_ascii_digit() {
            let start = i;
            while i < bytes.len()
                && matches!(bytes[i], b'-' | b'+' | b'.' | b'e' | b'E' | b'0'..=b'9')
            {
                i += 1;
            }
            spans.push((start, i));
        } else {
            i += 1;
        }
    }
    spans
}

// --- our scenes -----------------------------------------------------------------------------

#[test]
fn cornell_box_loads_with_its_light_boxes_and_camera() {
    let (scene, warnings) = load("scenes/cornell-box.gltf");
    assert!(warnings.is_empty(), "{warnings:#?}");
    // Five walls and the ceiling light of two triangles each, two boxes of twelve.
    assert_eq!(scene.triangle_count(), 36);
    assert_eq!((scene.meshes.len(), scene.instances.len()), (3, 4));
    assert_eq!(scene.materials.len(), 4);
    assert!(scene.textures.is_empty() && scene.lights.is_empty());
    assert!(scene.meshes.iter().all(|m| m.uvs.is_none()));
    // The walls are one mesh with a material per wall (its triangles in its BVH's leaf order).
    let room = &scene.meshes[scene.instances[0].mesh as usize];
    let mut materials = room.materials.clone();
    materials.sort_unstable();
    assert_eq!(materials, [0, 0, 0, 0, 0, 0, 1, 1, 2, 2]);

    let light = &scene.materials[3];
    assert_eq!(light.emissive, Vec3::new(1.0, 0.78, 0.47) * 17.0);
    assert_eq!(scene.emissive_triangles.len(), 2);
    let area: f32 = scene.emissive_triangles.iter().map(|t| t.area).sum();
    assert!((area - 0.2).abs() < 1e-6, "{area}");
    for t in &scene.emissive_triangles {
        let world = scene.world_triangle(t.instance, t.primitive).unwrap();
        assert_eq!(world.vertices, t.vertices);
        assert_eq!(world.material, 3);
        assert!(t.vertices.iter().all(|v| (v.y - 1.98).abs() < 1e-6));
    }

    assert!(
        scene
            .bounds
            .min
            .abs_diff_eq(Vec3::new(-1.0, 0.0, -1.0), 1e-6)
    );
    assert!(scene.bounds.max.abs_diff_eq(Vec3::new(1.0, 2.0, 1.0), 1e-6));

    let [camera] = &scene.cameras[..] else {
        panic!("{:?}", scene.cameras)
    };
    assert!(
        camera
            .position()
            .abs_diff_eq(Vec3::new(0.0, 1.0, 3.9), 1e-6)
    );
    assert!(camera.forward().abs_diff_eq(Vec3::NEG_Z, 1e-6));
    assert!(camera.up().abs_diff_eq(Vec3::Y, 1e-6));
    assert!((camera.yfov - 39.3f32.to_radians()).abs() < 1e-6);
    assert_eq!(camera.aspect_ratio, Some(1.0));

    // The two boxes share one mesh and sit on the floor inside the room.
    let boxes: Vec<_> = scene
        .instances
        .iter()
        .filter(|i| i.name.ends_with("box"))
        .collect();
    assert_eq!(boxes.len(), 2);
    assert_eq!(boxes[0].mesh, boxes[1].mesh);
    for b in boxes {
        let mesh = &scene.meshes[b.mesh as usize];
        let ys = mesh
            .positions
            .iter()
            .map(|&p| b.transform.transform_point3(p).y);
        let lowest = ys.fold(f32::INFINITY, f32::min);
        assert!(lowest.abs() < 1e-6, "{} floats at {lowest}", b.name);
    }
}

#[test]
fn world_triangles_agree_with_meshes_and_instances() {
    let (scene, _) = load("scenes/cornell-box.gltf");
    let all: Vec<_> = scene.world_triangles().collect();
    assert_eq!(all.len(), scene.triangle_count());
    for t in &all {
        assert_eq!(scene.world_triangle(t.instance, t.primitive), Some(*t));
        let instance = &scene.instances[t.instance as usize];
        let mesh = &scene.meshes[instance.mesh as usize];
        let object = mesh.triangle(t.primitive as usize);
        let rows = instance.transform_3x4();
        for (w, o) in t.vertices.iter().zip(object) {
            // The 3x4 rows are what a VkTransformMatrixKHR holds.
            let by_rows = Vec3::from_array(std::array::from_fn(|r| {
                Vec4::from_array(rows[r]).dot(o.extend(1.0))
            }));
            assert!(by_rows.abs_diff_eq(*w, 1e-5), "{by_rows} vs {w}");
        }
    }
    assert_eq!(scene.world_triangle(0, 10_000), None);
    assert_eq!(scene.world_triangle(99, 0), None);
}

#[test]
fn glb_round_trip_loads_identically() {
    let (gltf, _) = load("scenes/cornell-box.gltf");
    let (glb, warnings) = load("scenes/cornell-box.glb");
    assert!(warnings.is_empty(), "{warnings:#?}");
    assert_eq!(glb.meshes, gltf.meshes);
    assert_eq!(glb.instances, gltf.instances);
    assert_eq!(glb.materials, gltf.materials);
    assert_eq!(glb.cameras, gltf.cameras);
    assert_eq!(glb.emissive_triangles, gltf.emissive_triangles);
    assert_eq!(glb.bounds, gltf.bounds);
}

#[test]
fn indirect_room_has_a_sun_and_a_hidden_spot_light() {
    let (scene, warnings) = load("scenes/indirect-room.gltf");
    assert!(warnings.is_empty(), "{warnings:#?}");
    // Eight wall pieces and the floor, two furniture boxes (not indexed).
    assert_eq!(scene.triangle_count(), 18 + 24);
    assert!(scene.emissive_triangles.is_empty() && scene.textures.is_empty());
    assert_eq!(scene.cameras.len(), 1);
    let [sun, spot] = &scene.lights[..] else {
        panic!("{:?}", scene.lights)
    };
    assert_eq!(sun.kind, LightKind::Directional);
    // 3 W/m² were written as 3 × 683 lux.
    assert!(
        sun.intensity
            .abs_diff_eq(Vec3::new(1.0, 0.93, 0.8) * 3.0, 1e-5)
    );
    assert!(
        sun.direction
            .abs_diff_eq(Vec3::new(-1.0, -0.55, 0.25).normalize(), 1e-5)
    );
    let LightKind::Spot {
        inner_cone_angle,
        outer_cone_angle,
    } = spot.kind
    else {
        panic!("{spot:?}")
    };
    assert!((inner_cone_angle - 20f32.to_radians()).abs() < 1e-6);
    assert!((outer_cone_angle - 35f32.to_radians()).abs() < 1e-6);
    assert!(spot.direction.abs_diff_eq(Vec3::Y, 1e-5));
    assert!(spot.position.abs_diff_eq(Vec3::new(2.2, 0.3, 2.2), 1e-6));
    assert!(
        spot.intensity
            .abs_diff_eq(Vec3::new(1.0, 0.85, 0.6) * 4.0, 1e-5)
    );
}

#[test]
fn many_lights_has_256_point_lights() {
    let (scene, warnings) = load("scenes/many-lights.gltf");
    assert!(warnings.is_empty(), "{warnings:#?}");
    assert_eq!(scene.lights.len(), 256);
    assert!(
        scene
            .lights
            .iter()
            .all(|l| l.kind == LightKind::Point && l.range == Some(3.0))
    );
    // 0.25 W/sr each, written as candela; the colours' largest channel is 1.
    for light in &scene.lights {
        assert!(
            (light.intensity.max_element() - 0.25).abs() < 1e-5,
            "{light:?}"
        );
        assert!((light.position.y - 0.4).abs() < 1e-6);
    }
    let first = &scene.lights[0];
    assert!(first.position.abs_diff_eq(Vec3::new(-7.5, 0.4, -7.5), 1e-6));
    assert_eq!(scene.triangle_count(), 2 + 16 * 12);
    assert_eq!(scene.instances.len(), 17);
    assert!(scene.emissive_triangles.is_empty() && scene.textures.is_empty());
}

#[test]
fn textured_scene_decodes_its_checkerboard() {
    let (scene, warnings) = load("scenes/textured.gltf");
    assert!(warnings.is_empty(), "{warnings:#?}");
    // A floor drawn as a two-triangle strip, and a box.
    assert_eq!(scene.triangle_count(), 2 + 12);
    let [texture] = &scene.textures[..] else {
        panic!("{} textures", scene.textures.len())
    };
    assert_eq!((texture.width, texture.height), (64, 64));
    assert_eq!(texture.levels[0].len(), 64 * 64 * 4);
    assert!(texture.srgb);
    assert_eq!(texture.wrap, [Wrap::Repeat; 2]);
    assert_eq!(&texture.levels[0][..4], &[230, 230, 230, 255]);
    assert_eq!(&texture.levels[0][8 * 4..8 * 4 + 4], &[40, 40, 40, 255]);
    // The mips, generated down to 1×1: at 8×8 each texel is one 8×8 square of the checkerboard.
    assert_eq!(texture.levels.len(), 7);
    assert_eq!(texture.level_size(3), (8, 8));
    assert_eq!(
        &texture.levels[3][..8],
        &[230, 230, 230, 255, 40, 40, 40, 255]
    );
    assert_eq!(
        texture.bytes(),
        (0..7).map(|l| (64 >> l) * (64 >> l) * 4).sum::<usize>()
    );
    // Both materials use it, and every mesh has UVs.
    assert!(
        scene
            .materials
            .iter()
            .all(|m| m.base_color_texture == Some(0))
    );
    assert!(scene.meshes.iter().all(|m| {
        m.uvs
            .as_ref()
            .is_some_and(|uv| uv.len() == m.positions.len())
    }));
    assert!(scene.emissive_triangles.is_empty());
    assert_eq!(scene.lights.len(), 2);
    // The strip keeps the front face up.
    let floor = scene.world_triangles().find(|t| t.instance == 0).unwrap();
    let [a, b, c] = floor.vertices;
    assert!((b - a).cross(c - a).normalize().abs_diff_eq(Vec3::Y, 1e-6));
}

#[test]
fn node_transforms_compose_parent_first() {
    let (scene, warnings) = load("tests/data/transforms.gltf");
    assert!(warnings.is_empty(), "{warnings:#?}");
    assert_eq!(scene.instances.len(), 2);
    // Vertex (1, 0, 0): the child turns it 90° about Z, the parent scales by 2 and moves +10 X;
    // the grandchild's matrix first moves it +5 Z.
    let landed: Vec<Vec3> = scene.world_triangles().map(|t| t.vertices[1]).collect();
    assert!(
        landed[0].abs_diff_eq(Vec3::new(10.0, 2.0, 0.0), 1e-5),
        "{}",
        landed[0]
    );
    assert!(
        landed[1].abs_diff_eq(Vec3::new(10.0, 2.0, 10.0), 1e-5),
        "{}",
        landed[1]
    );
    // Without NORMAL the mesh shades flat (glTF): zero vertex normals, so the shading normal is
    // the geometric one.
    assert_eq!(scene.meshes[0].normals, vec![Vec3::ZERO; 3]);
}

// --- a real export ----------------------------------------------------------------------------

#[test]
#[cfg_attr(
    not(third_party_scenes),
    ignore = "../shared/scenes/third-party is absent (third-party scenes are not in the repository)"
)]
fn blender_export_loads() {
    let (scene, warnings) =
        load("../shared/scenes/third-party/cornell-box-vinc3r/cornellBox-2.80-Eevee-gltf.gltf");
    // It carries a second UV set, which is reported, not silently dropped.
    let uv = warning(&warnings, "UV sets after TEXCOORD_0");
    assert!(uv.element.ends_with(".attributes.TEXCOORD_1"), "{uv}");
    assert_eq!(warnings.len(), 1, "{warnings:#?}");
    assert_eq!(scene.meshes.len(), 12);
    assert_eq!(scene.instances.len(), 12);
    assert_eq!(scene.textures.len(), 2);
    assert!(
        scene
            .textures
            .iter()
            .all(|t| t.srgb && t.levels[0].len() == (t.width * t.height * 4) as usize)
    );
    assert!(scene.cameras.is_empty() && scene.lights.is_empty());
    // The emissive quad ("light.000", emissiveFactor 1) hangs under the ceiling at y = 3.
    assert_eq!(scene.emissive_triangles.len(), 10);
    assert!(
        scene
            .emissive_triangles
            .iter()
            .all(|t| t.emission == Vec3::ONE)
    );
    assert!(
        scene
            .emissive_triangles
            .iter()
            .all(|t| t.vertices.iter().all(|v| (v.y - 3.0).abs() < 0.05))
    );
    assert_eq!(scene.triangle_count(), 4410);
    let size = scene.bounds.size();
    assert!(
        size.max_element() < 10.0 && size.min_element() > 1.0,
        "{:?}",
        scene.bounds
    );
    // The logo parts sit under a rotated parent at y = 1.5: their world positions are near it.
    let logo = scene
        .instances
        .iter()
        .find(|i| i.name == "BJS-3D-logo_green.000")
        .unwrap();
    assert!(
        (logo.transform.w_axis.y - 1.5).abs() < 0.3,
        "{:?}",
        logo.transform
    );
    // Light-unit conversion is the documented one.
    assert_eq!(LUMENS_PER_WATT, 683.0);
}

#[test]
#[cfg_attr(
    not(third_party_scenes),
    ignore = "../shared/scenes/third-party is absent (third-party scenes are not in the repository)"
)]
fn bitterli_textures_decode_the_same_in_parallel_as_one_by_one() {
    for file in [
        "../shared/scenes/third-party/bitterli/bathroom/bathroom.glb",
        "../shared/scenes/third-party/bitterli/living-room/living-room.glb",
    ] {
        let one_thread = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let (sequential, sequential_warnings) = one_thread.install(|| load(file));
        let (parallel, warnings) = load(file);
        eprintln!("{file}, 1 thread:  {}", sequential.load_report());
        eprintln!(
            "{file}, {} threads: {}",
            rayon::current_num_threads(),
            parallel.load_report()
        );
        assert_eq!(warnings, sequential_warnings);
        assert_eq!(parallel.textures, sequential.textures);
        assert_eq!(parallel.materials, sequential.materials);
        assert!(!parallel.textures.is_empty());
        for t in &parallel.textures {
            let last = t.levels.len() - 1;
            assert_eq!(t.level_size(last), (1, 1), "{}", t.name);
            assert_eq!(t.levels.len(), (t.width.max(t.height).ilog2() + 1) as usize);
        }
        let names: Vec<&str> = parallel.load_stages.iter().map(|s| s.name).collect();
        assert_eq!(names, ["parse", "geometry", "textures", "derived"]);
    }
}
