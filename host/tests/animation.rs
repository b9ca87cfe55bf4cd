//! glTF node animation: `scenes/moving-box.gltf` poses as its generator says, emissive triangles,
//! lights and bounds follow moving instances, and channels that cannot be played are dropped with
//! a warning naming them. CPU only.

use base64::Engine;
use gi_host::scene::{Scene, Warning};
use glam::{Mat4, Quat, Vec3};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
}

fn close(a: Mat4, b: Mat4) -> bool {
    a.abs_diff_eq(b, 1e-5)
}

/// The cube's world transform at `t` as `scenes/generate.py` describes it:
/// T(-0.6 + 0.6 t, 0.2, 0) R_y(90° t) S(0.4), for t in [0, 2].
fn cube_at(t: f32) -> Mat4 {
    Mat4::from_scale_rotation_translation(
        Vec3::splat(0.4),
        Quat::from_rotation_y(t * std::f32::consts::FRAC_PI_2),
        Vec3::new(-0.6 + 0.6 * t, 0.2, 0.0),
    )
}

#[test]
fn moving_box_poses_as_generated() {
    let (mut scene, warnings) = Scene::load(repo("scenes/moving-box.gltf")).unwrap();
    assert!(warnings.is_empty(), "{warnings:#?}");
    let cube = scene
        .instances
        .iter()
        .position(|i| i.name == "cube")
        .unwrap();
    let animation = scene.animation.as_ref().expect("moving-box is animated");
    assert_eq!(animation.duration(), 2.0);
    assert_eq!(animation.channel_count(), 2);
    assert_eq!(
        animation.dynamic_instances().collect::<Vec<_>>(),
        [cube as u32]
    );
    // Loaded in its rest pose, which is the pose at t = 0.
    assert!(close(scene.instances[cube].transform, cube_at(0.0)));
    let still: Vec<Mat4> = scene.instances.iter().map(|i| i.transform).collect();
    let emissive = scene.emissive_triangles.clone();

    for t in [0.25, 0.5, 1.0, 1.5, 1.9] {
        let pose = scene.pose_at(t);
        let moved = scene.set_time(t).to_vec();
        assert_eq!(moved, [cube as u32], "t = {t}");
        let transform = scene.instances[cube].transform;
        assert!(close(transform, cube_at(t)), "t = {t}: {transform}");
        assert_eq!(pose[cube], transform);
        for (i, instance) in scene.instances.iter().enumerate() {
            if i != cube {
                assert_eq!(instance.transform, still[i]);
            }
        }
        // The light does not move; the bounds hold the cube.
        assert_eq!(scene.emissive_triangles, emissive);
        let centre = transform.transform_point3(Vec3::ZERO);
        assert!(
            scene.bounds.min.cmple(centre - 0.2).all()
                && scene.bounds.max.cmpge(centre + 0.2).all()
        );
    }
    // Same time again: nothing moves.
    assert!(scene.set_time(1.9).is_empty());
    // The clock loops over the 2 s: 2.5 s is 0.5 s, -0.5 s is 1.5 s, and 2 s is the start.
    scene.set_time(2.5);
    assert!(close(scene.instances[cube].transform, cube_at(0.5)));
    scene.set_time(-0.5);
    assert!(close(scene.instances[cube].transform, cube_at(1.5)));
    scene.set_time(2.0);
    assert!(close(scene.instances[cube].transform, cube_at(0.0)));
    scene.set_time(f32::NAN);
    assert!(close(scene.instances[cube].transform, cube_at(0.0)));
}

#[test]
fn scenes_without_animation_have_none() {
    let (mut scene, _) = Scene::load(repo("scenes/cornell-box.gltf")).unwrap();
    assert!(scene.animation.is_none());
    let before: Vec<Mat4> = scene.instances.iter().map(|i| i.transform).collect();
    assert!(scene.set_time(1.0).is_empty());
    assert_eq!(scene.pose_at(1.0), before);
}

/// A glTF document in the making: one buffer of floats (embedded), accessors over it.
struct Doc {
    floats: Vec<f32>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Doc {
    fn new() -> Self {
        Self {
            floats: Vec::new(),
            views: Vec::new(),
            accessors: Vec::new(),
        }
    }

    /// An accessor of `ty` over `values` (floats).
    fn floats(&mut self, ty: &str, values: &[f32]) -> usize {
        let width = match ty {
            "SCALAR" => 1,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => unreachable!(),
        };
        self.views.push(json!({
            "buffer": 0,
            "byteOffset": 4 * self.floats.len(),
            "byteLength": 4 * values.len(),
        }));
        self.floats.extend_from_slice(values);
        let mut accessor = json!({
            "bufferView": self.views.len() - 1,
            "componentType": 5126,
            "count": values.len() / width,
            "type": ty,
        });
        if ty == "VEC3" && values.len() == 9 {
            // The triangle's POSITION needs bounds.
            accessor["min"] = json!([0.0, 0.0, 0.0]);
            accessor["max"] = json!([1.0, 1.0, 0.0]);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// Writes the document with `nodes` and `animations` (the triangle is mesh 0, emissive) and
    /// loads it.
    fn load(mut self, name: &str, nodes: Value, animations: Value) -> (Scene, Vec<Warning>) {
        let position = self.floats("VEC3", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
        let bytes: Vec<u8> = self.floats.iter().flat_map(|f| f.to_le_bytes()).collect();
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bytes)
        );
        let doc = json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": nodes,
            "meshes": [{"primitives": [{"attributes": {"POSITION": position}, "material": 0}]}],
            "materials": [{"emissiveFactor": [1.0, 1.0, 1.0]}],
            "cameras": [{"type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.1}}],
            "extensionsUsed": ["KHR_lights_punctual"],
            "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 683.0}]}},
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{"byteLength": bytes.len(), "uri": uri}],
            "animations": animations,
        });
        let dir = std::env::temp_dir().join(format!("gi-animation-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(format!("{name}.gltf"));
        std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
        let loaded = Scene::load(&path);
        std::fs::remove_file(&path).unwrap();
        match loaded {
            Ok(loaded) => loaded,
            Err(e) => panic!("{name} does not load: {e}"),
        }
    }
}

fn linear(input: usize, output: usize) -> Value {
    json!({"input": input, "output": output, "interpolation": "LINEAR"})
}

#[test]
fn an_animated_parent_moves_its_children_lights_cameras_and_emissive_triangles() {
    let mut doc = Doc::new();
    let times = doc.floats("SCALAR", &[0.0, 1.0]);
    let moves = doc.floats("VEC3", &[0.0, 0.0, 0.0, 4.0, 0.0, 0.0]);
    // Node 1 (animated), under a still node 0 that moves it 2 m along +Z, carries node 2 (a
    // still child, offset 1 m up) with the triangle and a light.
    let nodes = json!([
        {"name": "base", "translation": [0.0, 0.0, 2.0], "children": [1]},
        {"name": "parent", "children": [2]},
        {"name": "child", "translation": [0.0, 1.0, 0.0], "mesh": 0, "camera": 0,
         "extensions": {"KHR_lights_punctual": {"light": 0}}},
    ]);
    let animations = json!([{
        "channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}}],
        "samplers": [linear(times, moves)],
    }]);
    let (mut scene, warnings) = doc.load("hierarchy", nodes, animations);
    assert!(warnings.is_empty(), "{warnings:#?}");
    assert_eq!(scene.set_time(0.25), [0]);
    let offset = Vec3::new(1.0, 1.0, 2.0);
    assert!(close(
        scene.instances[0].transform,
        Mat4::from_translation(offset)
    ));
    assert_eq!(scene.lights[0].position, offset);
    assert_eq!(scene.cameras[0].position(), offset);
    let [a, b, c] = scene.emissive_triangles[0].vertices;
    assert_eq!([a, b, c], [offset, offset + Vec3::X, offset + Vec3::Y]);
    assert_eq!(scene.emissive_triangles[0].area, 0.5);
    // The bounds follow the triangle, with none left at its rest place.
    assert_eq!(scene.bounds.min, offset);
    assert_eq!(scene.bounds.max, offset + Vec3::new(1.0, 1.0, 0.0));
}

#[test]
fn channels_that_cannot_be_played_are_dropped_with_a_warning() {
    let mut doc = Doc::new();
    let times = doc.floats("SCALAR", &[0.0, 1.0]);
    let backwards = doc.floats("SCALAR", &[1.0, 0.5]);
    let nan_time = doc.floats("SCALAR", &[0.0, f32::NAN]);
    let moves = doc.floats("VEC3", &[0.0, 0.0, 0.0, 4.0, 0.0, 0.0]);
    let three = doc.floats("VEC3", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0]);
    let nan = doc.floats("VEC3", &[0.0, 0.0, 0.0, f32::NAN, 0.0, 0.0]);
    let zero_rotation = doc.floats("VEC4", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
    let nodes = json!([
        {"name": "root", "children": [1], "mesh": 0},
        {"name": "fixed", "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "mesh": 0},
    ]);
    let animations = json!([
        {
            "name": "good",
            "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}],
            "samplers": [linear(times, moves)],
        },
        {
            "name": "bad",
            "channels": [
                {"sampler": 0, "target": {"node": 99, "path": "translation"}},
                {"sampler": 1, "target": {"node": 0, "path": "translation"}},
                {"sampler": 2, "target": {"node": 0, "path": "translation"}},
                {"sampler": 3, "target": {"node": 0, "path": "scale"}},
                {"sampler": 4, "target": {"node": 0, "path": "rotation"}},
                {"sampler": 5, "target": {"node": 0, "path": "rotation"}},
                {"sampler": 0, "target": {"node": 1, "path": "translation"}},
                {"sampler": 0, "target": {"node": 0, "path": "weights"}},
                {"sampler": 6, "target": {"node": 0, "path": "translation"}},
                {"sampler": 7, "target": {"node": 0, "path": "translation"}},
                {"sampler": 9, "target": {"node": 0, "path": "translation"}},
            ],
            "samplers": [
                linear(times, moves),
                linear(backwards, moves),
                linear(times, three),
                linear(times, nan),
                linear(times, moves),
                linear(times, zero_rotation),
                linear(moves, moves),
                linear(nan_time, moves),
            ],
        },
    ]);
    let (scene, warnings) = doc.load("bad-channels", nodes, animations);
    let expect = [
        ("channels[0]", "target node 99 does not exist"),
        ("channels[1]", "do not increase at keyframe 1"),
        ("channels[2]", "has 3 values for 2 keyframes"),
        ("channels[3]", "non-finite values"),
        ("channels[4]", "has type Vec3, expected Vec4"),
        ("channels[5]", "rotation 1 of its output"),
        ("channels[6]", "is given by a matrix"),
        ("channels[7]", "morph target weights are not animated"),
        ("channels[8]", "has type Vec3, expected Scalar"),
        ("channels[9]", "is not a finite time"),
        ("channels[10]", "its sampler 9 does not exist"),
    ];
    for (channel, what) in expect {
        let element = format!("animations[1] (\"bad\").{channel}");
        let found = warnings
            .iter()
            .any(|w| w.element == element && w.message.contains(what));
        assert!(
            found,
            "no warning on {element} about {what:?}: {warnings:#?}"
        );
    }
    // A channel is dropped, not the scene: the good one plays.
    let animation = scene.animation.as_ref().unwrap();
    assert_eq!(animation.channel_count(), 1);
    assert_eq!(animation.duration(), 1.0);
    assert_eq!(
        scene.pose_at(0.5)[0],
        Mat4::from_translation(Vec3::new(2.0, 0.0, 0.0))
    );
}
