//! Where buffers live: long-lived scene, BVH and output buffers must ask for device-local memory,
//! only named parameter and staging buffers may be host-visible, and device-local data must make
//! the round trip through staging copies intact.
//!
//! On lavapipe every memory type is both device-local and host-visible, so these tests check the
//! location each buffer asked for (recorded by the context), not the memory type it got: they
//! catch a regression without a discrete GPU.

use gi_host::KernelVariant;
use gi_host::gbuffer::{GBufferImages, GBufferPass};
use gi_host::scene::Scene;
use gi_host::scene::gpu_data::{BUFFER_NAMES, ShadingData};
use gi_host::scene::lights::LightSet;
use gi_host::scene::upload::GpuScene;
use gi_host::vulkan::{
    Buffer, Context, Kernel, KernelModule, MemoryLocation, compute_barrier, transfer_barrier,
};
use gi_shared::abi::WORKGROUP_SIZE;
use gi_tests::{
    assert_device_local_except, context, finish_without_validation_messages, scene_path, variants,
};

/// The only host-visible buffers a scene and a G-buffer pass keep alive: parameters the host
/// rewrites per frame (the camera, and the instances' previous transforms `GpuScene::set_pose`
/// writes; one 64-byte entry for a still scene).
const PARAMETERS: [&str; 2] = ["G-buffer camera", "previous transforms"];

fn location_of(ctx: &Context, name: &str) -> Vec<MemoryLocation> {
    ctx.live_buffers()
        .into_iter()
        .filter(|b| b.name == name)
        .map(|b| b.location)
        .collect()
}

#[test]
fn scene_bvh_and_outputs_are_device_local_in_both_variants() {
    // The textured scene has every kind of shading data, textures and texels included.
    let (scene, _warnings) = Scene::load(scene_path("textured.gltf")).unwrap();
    let shading_data = ShadingData::new(&scene).unwrap();
    for variant in variants() {
        let ctx = context(variant);
        assert!(
            ctx.live_buffers().is_empty(),
            "{variant}: a new context holds buffers"
        );
        let lights = LightSet::new(&scene, None, false);
        let gpu = GpuScene::upload(&ctx, &scene, None, &shading_data, &lights).unwrap();
        let pass = GBufferPass::new(&ctx).unwrap();
        let images = GBufferImages::new(&ctx, 8, 8).unwrap();

        let live = ctx.live_buffers();
        println!("{variant}: {live:#?}");
        assert_device_local_except(&live, &PARAMETERS);
        let geometry_buffers: &[&str] = match variant {
            KernelVariant::Software => &["bvh nodes"],
            KernelVariant::RayQuery => &["acceleration structure"],
        };
        for name in BUFFER_NAMES.iter().chain(geometry_buffers) {
            let found = location_of(&ctx, name);
            assert!(
                !found.is_empty() && found.iter().all(|l| *l == MemoryLocation::GpuOnly),
                "{variant}: buffer {name:?} is {found:?}, not device-local"
            );
        }
        if variant == KernelVariant::RayQuery {
            // One bottom level per mesh and the top level.
            assert_eq!(
                location_of(&ctx, "acceleration structure").len(),
                scene.meshes.len() + 1
            );
        }
        // The camera is rewritten per frame, so it stays host-visible.
        assert_eq!(
            location_of(&ctx, "G-buffer camera"),
            [MemoryLocation::CpuToGpu]
        );
        // Build inputs and staging buffers are gone once the upload returned.
        assert!(
            live.iter()
                .all(|b| !b.name.contains("staging") && !b.name.starts_with("blas")),
            "{variant}: {live:?}"
        );

        drop(images);
        drop(pass);
        drop(gpu);
        assert_eq!(
            ctx.live_buffers(),
            [],
            "{variant}: destroyed buffers still listed"
        );
        finish_without_validation_messages(ctx);
    }
}

#[test]
fn the_check_rejects_a_host_visible_scene_buffer() {
    let ctx = context(KernelVariant::Software);
    let camera = Buffer::parameters(&ctx, "camera", &[0u32; 4]).unwrap();
    let readback = Buffer::readback::<u32>(&ctx, "readback", 4).unwrap();
    let live = ctx.live_buffers();
    assert_eq!(live.len(), 2);
    assert_eq!(live[0].bytes, 16);
    assert_eq!(camera.location(), MemoryLocation::CpuToGpu);
    assert_eq!(readback.location(), MemoryLocation::GpuToCpu);
    assert_device_local_except(&live, &["camera", "readback"]);
    let rejected = std::panic::catch_unwind(|| assert_device_local_except(&live, &["camera"]));
    let message = *rejected
        .expect_err("a host-visible buffer that is not named must fail the check")
        .downcast::<String>()
        .unwrap();
    assert!(
        message.contains("\"readback\": 16 bytes in GpuToCpu"),
        "{message}"
    );
    drop(camera);
    drop(readback);
    finish_without_validation_messages(ctx);
}

#[test]
fn device_local_data_round_trips_and_is_not_host_accessible() {
    let ctx = context(KernelVariant::Software);
    let data: Vec<u32> = (0..1000).map(|i| i * 7 + 3).collect();
    let mut buffer = Buffer::device_local(&ctx, "round trip", &data, Default::default()).unwrap();
    assert_eq!(buffer.location(), MemoryLocation::GpuOnly);
    assert_eq!(buffer.read_back::<u32>(&ctx).unwrap(), data);
    let zeroed = Buffer::device_zeroed::<[u32; 2]>(&ctx, "zeroed", 500).unwrap();
    assert_eq!(zeroed.location(), MemoryLocation::GpuOnly);
    assert_eq!(
        zeroed.read_back::<[u32; 2]>(&ctx).unwrap(),
        vec![[0; 2]; 500]
    );

    // The host cannot map device-local memory: an error naming the buffer, not a panic.
    let err = buffer.write(&[0; 4]).unwrap_err().to_string();
    assert!(
        err.contains("round trip") && err.contains("read_back"),
        "{err}"
    );
    assert!(buffer.read::<u32>().is_err());
    // A copy into a smaller buffer records nothing and says why.
    let small = Buffer::readback::<u32>(&ctx, "small", 10).unwrap();
    let err = ctx
        .submit(|cmd| buffer.record_copy_to(&ctx, cmd, &small))
        .unwrap()
        .unwrap_err()
        .to_string();
    assert!(err.contains("does not fit"), "{err}");
    assert!(Buffer::device_local::<u32>(&ctx, "empty", &[], Default::default()).is_err());
    assert!(Buffer::device_zeroed::<u32>(&ctx, "empty", 0).is_err());
    assert_eq!(ctx.live_buffers().len(), 3, "{:?}", ctx.live_buffers());

    drop(small);
    drop(zeroed);
    drop(buffer);
    finish_without_validation_messages(ctx);
}

gi_host::bindings! {
    /// The smoke kernel's set 0.
    struct Smoke<'a> {
        out: &'a Buffer,
    }
}

/// What the path tracer records: clear a device-local buffer, run a kernel on it, copy it to a
/// read-back buffer, all in one submission.
#[test]
fn clear_dispatch_and_copy_in_one_submission() {
    let ctx = context(KernelVariant::Software);
    let n = 1000u32;
    let data: Vec<u32> = vec![u32::MAX; n as usize];
    // Filled with a pattern first, so that a missing clear or dispatch shows.
    let out = Buffer::device_local(&ctx, "smoke output", &data, Default::default()).unwrap();
    let mut readback = Buffer::readback::<u32>(&ctx, "smoke readback", n as usize).unwrap();
    let module = KernelModule::new(&ctx).unwrap();
    let kernel = Kernel::new::<Smoke>(&ctx, &module, "smoke::smoke", 0).unwrap();
    drop(module);
    ctx.submit(|cmd| -> gi_host::Result<()> {
        out.record_fill_zero(&ctx, cmd);
        transfer_barrier(&ctx, cmd);
        // Half the work groups: the rest of the buffer must read back as the clear left it.
        let groups = n.div_ceil(WORKGROUP_SIZE) / 2;
        kernel.dispatch(&ctx, cmd, &Smoke { out: &out }, &[], [groups, 1, 1])?;
        compute_barrier(&ctx, cmd);
        out.record_copy_to(&ctx, cmd, &readback)?;
        transfer_barrier(&ctx, cmd);
        Ok(())
    })
    .unwrap()
    .unwrap();
    let values = readback.read::<u32>().unwrap();
    let written = (n.div_ceil(WORKGROUP_SIZE) / 2 * WORKGROUP_SIZE) as usize;
    for (i, v) in values.iter().enumerate() {
        let expected = if i < written {
            gi_shared::hash::pcg(i as u32)
        } else {
            0
        };
        assert_eq!(*v, expected, "element {i}");
    }
    drop(kernel);
    drop(readback);
    drop(out);
    finish_without_validation_messages(ctx);
}

/// The path tracer's lights, environment and accumulation are device-local while it renders;
/// only its camera and the read-back buffer are host-visible.
#[test]
fn path_tracer_buffers_are_device_local_while_rendering() {
    use gi_host::path_tracer::{PathTracerPass, PathTracerSettings};
    use gi_host::scene::lights::Environment;
    let (scene, _warnings) = Scene::load(scene_path("cornell-box.gltf")).unwrap();
    let shading_data = ShadingData::new(&scene).unwrap();
    let environment = Environment::new([2, 1], vec![[1.0; 4]; 2]).unwrap();
    let set = LightSet::new(&scene, Some(environment), true);
    for variant in variants() {
        let ctx = context(variant);
        let gpu = GpuScene::upload(&ctx, &scene, None, &shading_data, &set).unwrap();
        let mut pass = PathTracerPass::new(&ctx).unwrap();
        let camera = gi_host::gbuffer::scene_camera(&scene, 8, 8);
        let settings = PathTracerSettings {
            samples: 2,
            ..Default::default()
        };
        let mut seen = vec![];
        pass.render(&ctx, &gpu, &camera, &settings, |_, _| {
            seen = ctx.live_buffers()
        })
        .unwrap();
        assert_device_local_except(
            &seen,
            &[
                "path tracer camera",
                "path tracer read-back",
                "previous transforms",
            ],
        );
        for name in [
            "lights",
            "light table",
            "environment",
            "environment distribution",
            "path tracer accumulation",
        ] {
            assert!(
                seen.iter()
                    .any(|b| b.name == name && b.location == MemoryLocation::GpuOnly),
                "{variant}: {name:?} missing or host-visible in {seen:?}"
            );
        }
        drop(pass);
        drop(gpu);
        finish_without_validation_messages(ctx);
    }
}
