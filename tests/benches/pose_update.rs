//! Milliseconds per `GpuScene::set_pose` (one instance moved) against what a pose cost before
//! in-place updates (the shading data laid out and the whole scene uploaded again), and bytes
//! uploaded per pose, in both tracing variants: on `scenes/moving-box.gltf`, on a generated scene
//! of `GI_POSE_TRIANGLES` triangles (1M by default) and on the Bitterli bathroom (or
//! `GI_POSE_SCENE`; skipped, saying so, where `../shared` is absent).
//!
//! `cargo bench --profile dev -p gi-tests --bench pose_update`

use gi_host::scene::Scene;
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::LightSet;
use gi_host::scene::synthetic::{SyntheticParams, parse_count, write};
use gi_host::scene::upload::GpuScene;
use gi_host::vulkan::Context;
use gi_tests::{
    context, finish_without_validation_messages, scene_path, third_party_scene_path, variants,
};
use glam::{Mat4, Vec3};
use std::time::Instant;

/// Milliseconds of `f`, best of `n` runs.
fn best_ms(n: u32, mut f: impl FnMut()) -> f64 {
    (0..n)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64() * 1e3
        })
        .fold(f64::INFINITY, f64::min)
}

/// Milliseconds per pose of one moving instance, against what a pose cost before (the shading
/// data laid out and the whole scene uploaded again), and bytes per pose.
fn time_poses(name: &str, ctx: &Context, scene: &mut Scene, moving: usize) {
    let lights = LightSet::new(scene, None, false);
    let full = best_ms(3, || {
        let shading = ShadingData::new(scene).unwrap();
        drop(GpuScene::upload(ctx, scene, None, &shading, &lights).unwrap());
    });
    let shading = ShadingData::new(scene).unwrap();
    let mut gpu = GpuScene::upload(ctx, scene, None, &shading, &lights).unwrap();
    let mut step = 0;
    let pose = best_ms(20, || {
        let previous: Vec<Mat4> = scene.instances.iter().map(|i| i.transform).collect();
        step += 1;
        let offset = Vec3::new(0.01 * step as f32, 0.0, 0.0);
        scene.instances[moving].transform *= Mat4::from_translation(offset);
        gpu.set_pose(ctx, scene, &lights, &previous).unwrap();
    });
    println!(
        "{name} {}: {} instances, {} triangles: full upload {full:.1} ms, set_pose {pose:.2} ms, \
         {:?}",
        ctx.variant(),
        scene.instances.len(),
        scene.triangle_count(),
        gpu.last_pose()
    );
}

fn main() {
    let (mut boxes, _) = Scene::load(scene_path("moving-box.gltf")).unwrap();
    let cube = boxes
        .instances
        .iter()
        .position(|i| i.name == "cube")
        .expect("moving-box has a cube");
    let triangles = std::env::var("GI_POSE_TRIANGLES")
        .map(|t| parse_count(&t).unwrap())
        .unwrap_or(1_000_000);
    let path = std::env::temp_dir().join(format!("gi-pose-{triangles}.glb"));
    let params = SyntheticParams {
        triangles,
        ..SyntheticParams::default()
    };
    write(&params, &path).unwrap();
    let (generated, _) = Scene::load(&path).unwrap();
    // A textured interior: what a pose re-uploaded before includes its textures.
    let interior = std::env::var_os("GI_POSE_SCENE")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| third_party_scene_path("bitterli/bathroom/bathroom.glb"));
    let mut scenes = vec![("generated", generated)];
    match Scene::load(&interior) {
        Ok((scene, _)) => scenes.push(("interior", scene)),
        Err(e) => println!("no interior ({e}): set GI_POSE_SCENE"),
    }
    for variant in variants() {
        let ctx = context(variant);
        time_poses("moving-box", &ctx, &mut boxes, cube);
        for (name, scene) in &mut scenes {
            let middle = scene.instances.len() / 2;
            time_poses(name, &ctx, scene, middle);
        }
        finish_without_validation_messages(ctx);
    }
}
