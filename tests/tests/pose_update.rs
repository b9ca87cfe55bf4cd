//! Moving instances in place (issue 12): `GpuScene::set_pose` rewrites only what a pose changes,
//! in both tracing variants, with the validation layer silent.
//!
//! * [`set_pose_traces_the_new_pose`]: `scenes/moving-box.gltf`, its cube made emissive, posed
//!   three times: after each pose the device's closest hits match the CPU reference built from
//!   the posed scene (and differ from the pose before for thousands of rays, so a stale top level
//!   would fail), the lights on the device are the posed ones, and the upload is exactly the
//!   cube's instance record, the top level's share and the changed lights. No buffer or image is
//!   created or freed but the previous transforms (which grow to one entry per instance), and
//!   the geometry keeps its handles.
//! * [`pose_upload_does_not_grow_with_triangles`]: 27 instances of a sphere, one moved: the
//!   same bytes whether the sphere has 320 or 20 480 triangles.
//! * [`staged_writes_land_in_place_and_refuse_what_does_not_fit`]: the batched in-place writes.
//!
//! Milliseconds per pose are the `pose_update` benchmark's (`tests/benches/pose_update.rs`).

use gi_host::KernelVariant;
use gi_host::scene::Scene;
use gi_host::scene::bvh::{Bvh, tlas_node_count};
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::{Environment, LightSet};
use gi_host::scene::procedural::{icosphere, scene as procedural_scene};
use gi_host::scene::upload::{GeometryData, GpuScene, PoseUpdate};
use gi_host::trace_rays::TraceRays;
use gi_host::vulkan::{Buffer, Context, Resource, StagedWrites};
use gi_shared::bvh::BvhNode;
use gi_shared::light_clusters::LightCluster;
use gi_shared::lights::GpuLight;
use gi_shared::random::Random;
use gi_shared::ray::{HitRecord, Ray};
use gi_shared::sampling::sample_uniform_sphere;
use gi_shared::scene_data::GpuInstance;
use gi_tests::{context, finish_without_validation_messages, scene_path, variants};
use glam::{Mat4, Vec3};
use std::time::Instant;

/// Bytes of a `VkAccelerationStructureInstanceKHR`.
const TLAS_RECORD_BYTES: u64 = 64;
/// Random rays through the room, and rays aimed at the cube, per pose.
const RAYS: usize = 8_000;
const AIMED_RAYS: usize = 4_000;
/// Poses of the moving box, seconds.
const POSES: [f32; 4] = [0.3, 0.8, 1.4, 2.1];

fn moving_box() -> (Scene, usize) {
    let (mut scene, warnings) = Scene::load(scene_path("moving-box.gltf")).unwrap();
    assert!(warnings.is_empty(), "{warnings:#?}");
    let cube = scene
        .instances
        .iter()
        .position(|i| i.name == "cube")
        .expect("moving-box has a cube");
    // An emissive cube: moving it moves lights too.
    let mesh = &scene.meshes[scene.instances[cube].mesh as usize];
    let material = mesh.materials[0] as usize;
    assert!(mesh.materials.iter().all(|&m| m as usize == material));
    scene.materials[material].emissive = Vec3::new(0.5, 0.4, 0.3);
    scene.update_derived();
    (scene, cube)
}

/// A uniformly random point of the box from `lo` to `hi`.
fn point(rng: &mut Random, lo: Vec3, hi: Vec3) -> Vec3 {
    lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())
}

/// Rays from random points of the scene's bounds in random directions, and as many aimed at
/// random points of `target`'s bounds.
fn rays(scene: &Scene, target: (Vec3, Vec3), seed: u32) -> Vec<Ray> {
    let mut rng = Random::new(seed, 0);
    let (lo, hi) = (scene.bounds.min, scene.bounds.max);
    (0..RAYS + AIMED_RAYS)
        .map(|i| {
            let origin = point(&mut rng, lo, hi);
            let direction = if i < RAYS {
                sample_uniform_sphere(rng.next_vec2())
            } else {
                (point(&mut rng, target.0, target.1) - origin).normalize_or(Vec3::Y)
            };
            Ray {
                origin: origin.to_array(),
                t_min: 0.0,
                direction: direction.to_array(),
                t_max: f32::INFINITY,
            }
        })
        .collect()
}

/// World bounds of instance `i`'s vertices.
fn instance_box(scene: &Scene, i: usize) -> (Vec3, Vec3) {
    let inst = &scene.instances[i];
    scene.meshes[inst.mesh as usize].positions.iter().fold(
        (Vec3::INFINITY, Vec3::NEG_INFINITY),
        |(lo, hi), p| {
            let w = inst.transform.transform_point3(*p);
            (lo.min(w), hi.max(w))
        },
    )
}

/// Counts of `other` against `reference`: the same hit, ties (another triangle at the same
/// distance), misses on one side only; panics on any other disagreement.
fn agreement(name: &str, reference: &[HitRecord], other: &[HitRecord]) -> (usize, usize, usize) {
    let (mut same, mut ties, mut edge) = (0, 0, 0);
    let close = |a: f32, b: f32| (a - b).abs() <= 1e-4 * a.abs().max(b.abs()) + 1e-5;
    for (i, (r, o)) in reference.iter().zip(other).enumerate() {
        match (r.is_hit(), o.is_hit()) {
            (false, false) => same += 1,
            (true, true) if (r.instance, r.primitive) == (o.instance, o.primitive) => {
                assert!(
                    close(r.t, o.t) && r.front_face == o.front_face,
                    "{name}: ray {i}: {r:?} vs {o:?}"
                );
                same += 1;
            }
            (true, true) => {
                assert!(close(r.t, o.t), "{name}: ray {i}: {r:?} vs {o:?}");
                ties += 1;
            }
            _ => edge += 1,
        }
    }
    (same, ties, edge)
}

/// The device's lights, read back.
fn lights_on_device(ctx: &Context, gpu: &GpuScene) -> Vec<GpuLight> {
    let [Resource::Buffer(lights), ..] = gpu.lights.resources() else {
        panic!("the first light resource is the light buffer");
    };
    lights.read_back(ctx).unwrap()
}

/// The geometry's buffer and structure handles.
fn geometry_handles(gpu: &GpuScene) -> Vec<String> {
    match &gpu.geometry.data {
        GeometryData::Software { nodes } => nodes
            .chunks()
            .iter()
            .map(|c| format!("{:?}", c.handle))
            .collect(),
        GeometryData::RayQuery { blases, tlas } => blases
            .iter()
            .map(|b| format!("{:?}", b.handle))
            .chain([format!("{:?}", tlas.handle())])
            .collect(),
    }
}

/// Bytes a pose that moved `moved` instances and rewrote `lights` lights uploads in `variant`,
/// for a scene of `instances`.
fn expected_upload(
    variant: KernelVariant,
    instances: usize,
    moved: u64,
    [lights, clusters]: [u64; 2],
) -> u64 {
    let top = match variant {
        KernelVariant::Software if moved > 0 => {
            (tlas_node_count(instances) * size_of::<BvhNode>()) as u64
        }
        KernelVariant::Software => 0,
        KernelVariant::RayQuery => moved * TLAS_RECORD_BYTES,
    };
    moved * size_of::<GpuInstance>() as u64
        + top
        + lights * size_of::<GpuLight>() as u64
        + clusters * size_of::<LightCluster>() as u64
}

#[test]
fn set_pose_traces_the_new_pose() {
    let (mut scene, cube) = moving_box();
    let emitters = scene.emissive_triangles.len();
    let cube_lights = scene
        .emissive_triangles
        .iter()
        .filter(|t| t.instance as usize == cube)
        .count();
    assert!(
        cube_lights == 12 && emitters > cube_lights,
        "{emitters} emitters"
    );
    for variant in variants() {
        let ctx = context(variant);
        scene.set_time(POSES[0]);
        let lights = LightSet::new(&scene, None, true);
        let shading = ShadingData::new(&scene).unwrap();
        let mut gpu = GpuScene::upload(&ctx, &scene, None, &shading, &lights).unwrap();
        let pass = TraceRays::new(&ctx).unwrap();
        let handles = geometry_handles(&gpu);
        let images = ctx.live_images();
        let buffers = |ctx: &Context| {
            let mut b = ctx.live_buffers();
            b.retain(|b| b.name != "previous transforms");
            b
        };
        let before_poses = buffers(&ctx);
        for (p, &t) in POSES.iter().enumerate().skip(1) {
            let previous = scene.pose_at(POSES[p - 1]);
            let old_box = instance_box(&scene, cube);
            scene.set_time(t);
            let lights = LightSet::new(&scene, None, true);
            let start = Instant::now();
            gpu.set_pose(&ctx, &scene, &lights, &previous).unwrap();
            let ms = start.elapsed().as_secs_f64() * 1e3;
            let update = gpu.last_pose();
            let name = format!("{variant} pose {t} s");
            println!("{name}: {update:?} in {ms:.2} ms");
            // The cube moved, and its lights: the run from the first light that changed to the
            // last holds its twelve, and those of the ceiling where the rounding of the turned
            // cube's areas moved the alias table; each light its own cluster, whose bounds moved.
            assert_eq!(update.moved_instances, 1, "{name}");
            assert!(update.top_level_rebuilt, "{name}");
            assert!(
                (cube_lights..=emitters).contains(&(update.lights as usize)),
                "{name}"
            );
            assert!(
                (cube_lights..=emitters).contains(&(update.light_clusters as usize)),
                "{name}"
            );
            assert_eq!(
                update.uploaded_bytes,
                expected_upload(
                    variant,
                    scene.instances.len(),
                    1,
                    [update.lights, update.light_clusters].map(u64::from)
                ),
                "{name}"
            );
            assert_eq!(
                update.parameter_bytes,
                (scene.instances.len() * 64) as u64,
                "{name}: one previous transform per instance"
            );
            assert_eq!(lights_on_device(&ctx, &gpu), lights.lights, "{name}");
            // The device traces the new pose, as the CPU does from scratch.
            let new_box = instance_box(&scene, cube);
            let target = (old_box.0.min(new_box.0), old_box.1.max(new_box.1));
            let rays = rays(&scene, target, 11 + p as u32);
            let bvh = Bvh::new(&scene).unwrap();
            let shading = ShadingData::new(&scene).unwrap();
            let cpu: Vec<HitRecord> = rays.iter().map(|r| bvh.closest_hit(&shading, r)).collect();
            let on_cube = cpu.iter().filter(|h| h.instance as usize == cube).count();
            assert!(
                on_cube > AIMED_RAYS / 4,
                "{name}: {on_cube} rays hit the cube"
            );
            let hits = pass.run(&ctx, &gpu, &rays).unwrap().hits;
            let (same, ties, edge) = agreement(&name, &cpu, &hits);
            println!("{name}: {on_cube} on the cube, same {same}, ties {ties}, edge misses {edge}");
            assert!(ties <= rays.len() / 100, "{name}: {ties} ties");
            assert!(edge <= 4, "{name}: {edge} edge misses");
            // The same rays against the pose before: the move matters to many of them.
            let mut stale = scene.clone();
            for (inst, m) in stale.instances.iter_mut().zip(&previous) {
                inst.transform = *m;
            }
            let stale_bvh = Bvh::new(&stale).unwrap();
            let stale_shading = ShadingData::new(&stale).unwrap();
            let differ = rays
                .iter()
                .zip(&cpu)
                .filter(|(r, h)| {
                    let o = stale_bvh.closest_hit(&stale_shading, r);
                    (o.instance, o.primitive) != (h.instance, h.primitive)
                })
                .count();
            assert!(
                differ > AIMED_RAYS / 4,
                "{name}: only {differ} rays see the move"
            );
        }
        // Only the previous transforms were reallocated (to one entry per instance); the
        // geometry, textures and staging are as after the upload.
        assert_eq!(buffers(&ctx), before_poses, "{variant}");
        assert_eq!(ctx.live_images(), images, "{variant}");
        assert_eq!(geometry_handles(&gpu), handles, "{variant}");
        // A pose that is the device's and the previous one: nothing but the motion's end.
        let now = scene.pose_at(*POSES.last().unwrap());
        gpu.set_pose(&ctx, &scene, &lights_for(&scene), &now)
            .unwrap();
        assert_eq!(
            gpu.last_pose(),
            PoseUpdate {
                parameter_bytes: (scene.instances.len() * 64) as u64,
                ..PoseUpdate::default()
            }
        );
        assert!(!gpu.has_object_motion());
        gpu.set_pose(&ctx, &scene, &lights_for(&scene), &now)
            .unwrap();
        assert_eq!(gpu.last_pose(), PoseUpdate::default());
        // What a pose cannot change is refused, naming it.
        let sky = Environment::constant(Vec3::ONE).unwrap();
        let other = LightSet::new(&scene, Some(sky), true);
        let e = gpu.set_pose(&ctx, &scene, &other, &now).unwrap_err();
        assert!(e.to_string().contains("lights"), "{e}");
        let mut swapped = scene.clone();
        swapped.instances[cube].mesh = (scene.instances[cube].mesh + 1) % scene.meshes.len() as u32;
        let e = gpu
            .set_pose(&ctx, &swapped, &lights_for(&scene), &now)
            .unwrap_err();
        assert!(
            e.to_string().contains("instance") && e.to_string().contains("mesh"),
            "{e}"
        );
        drop((pass, gpu));
        finish_without_validation_messages(ctx);
    }
}

fn lights_for(scene: &Scene) -> LightSet {
    LightSet::new(scene, None, true)
}

/// 27 instances of an icosphere of `levels` subdivisions on a grid.
fn spheres(levels: u32) -> Scene {
    let instances: Vec<(u32, Mat4)> = (0..27)
        .map(|i| {
            let at = Vec3::new((i % 3) as f32, (i / 3 % 3) as f32, (i / 9) as f32) * 3.0;
            (0, Mat4::from_translation(at))
        })
        .collect();
    procedural_scene(vec![icosphere(levels)], &instances).unwrap()
}

#[test]
fn pose_upload_does_not_grow_with_triangles() {
    for variant in variants() {
        let ctx = context(variant);
        let mut uploads = vec![];
        for levels in [2, 5] {
            let mut scene = spheres(levels);
            let lights = LightSet::new(&scene, None, false);
            let shading = ShadingData::new(&scene).unwrap();
            let mut gpu = GpuScene::upload(&ctx, &scene, None, &shading, &lights).unwrap();
            let previous = scene.pose_at(0.0);
            scene.instances[13].transform *= Mat4::from_translation(Vec3::new(0.5, 0.25, 0.0));
            gpu.set_pose(&ctx, &scene, &lights, &previous).unwrap();
            let update = gpu.last_pose();
            assert_eq!(
                update.uploaded_bytes,
                expected_upload(variant, 27, 1, [0, 0]),
                "{variant}"
            );
            // A ray that passes 1.3 beside the sphere's old centre (3, 3, 3) and 0.8 beside its
            // new one (3.5, 3.25, 3): it hits the moved sphere near z = 3 − 0.6, and nothing else.
            let ray = Ray {
                origin: [4.3, 3.25, -5.0],
                t_min: 0.0,
                direction: [0.0, 0.0, 1.0],
                t_max: f32::INFINITY,
            };
            let hit = TraceRays::new(&ctx)
                .unwrap()
                .run(&ctx, &gpu, &[ray])
                .unwrap()
                .hits[0];
            let bvh = Bvh::new(&scene).unwrap();
            let cpu = bvh.closest_hit(&ShadingData::new(&scene).unwrap(), &ray);
            assert_eq!((hit.instance, cpu.instance), (13, 13), "{variant}");
            assert!(
                (hit.t - cpu.t).abs() < 1e-4 * cpu.t && (cpu.t - 7.4).abs() < 0.1,
                "{variant}: {hit:?} vs {cpu:?}"
            );
            uploads.push((scene.triangle_count(), update.uploaded_bytes));
        }
        println!("{variant}: (world triangles, bytes per pose) {uploads:?}");
        assert_eq!(uploads[0].1, uploads[1].1, "{variant}: {uploads:?}");
        finish_without_validation_messages(ctx);
    }
}

#[test]
fn staged_writes_land_in_place_and_refuse_what_does_not_fit() {
    let ctx = context(KernelVariant::Software);
    let target = Buffer::device_local(&ctx, "target", &[0u32; 16], Default::default()).unwrap();
    let other = Buffer::device_local(&ctx, "other", &[7u32; 4], Default::default()).unwrap();
    let handle = format!("{:?}", target.handle);
    let mut writes = StagedWrites::new();
    // Two neighbouring runs (one copy region), one apart, one in another buffer.
    writes.write(&target, 4, &[1u32, 2]).unwrap();
    writes.write(&target, 12, &[3u32]).unwrap();
    writes.write(&target, 40, &[4u32, 5]).unwrap();
    writes.write(&other, 0, &[9u32]).unwrap();
    let e = writes
        .write(&target, 60, &[6u32, 6])
        .unwrap_err()
        .to_string();
    assert!(e.contains("\"target\"") && e.contains("offset 60"), "{e}");
    assert_eq!(writes.bytes(), 24);
    writes.submit(&ctx, |_| ()).unwrap();
    let mut expected = [0u32; 16];
    expected[1..4].copy_from_slice(&[1, 2, 3]);
    expected[10..12].copy_from_slice(&[4, 5]);
    assert_eq!(target.read_back::<u32>(&ctx).unwrap(), expected);
    assert_eq!(other.read_back::<u32>(&ctx).unwrap(), [9, 7, 7, 7]);
    assert_eq!(format!("{:?}", target.handle), handle);
    // The staging buffer went with the submission.
    assert_eq!(ctx.live_buffers().len(), 2);
    drop((target, other));
    finish_without_validation_messages(ctx);
}
