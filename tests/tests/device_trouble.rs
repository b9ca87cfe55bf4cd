//! Device trouble that lavapipe can provoke: requests no device can hold get an error naming the
//! resource and its size, before any Vulkan call the validation layer would flag, and the context
//! stays usable (and silent) afterwards.
//!
//! What lavapipe cannot provoke (a lost or hung device, a driver that runs out of memory below
//! its limits) is covered by the host's unit tests of the messages (`error.rs`) and documented in
//! the README ("Device trouble").

use gi_host::Error;
use gi_host::KernelVariant;
use gi_host::gbuffer::GBufferImages;
use gi_host::gi::renderer::GiRenderer;
use gi_host::gi::{GiSettings, ViewOptions};
use gi_host::path_tracer::{PathTracerPass, PathTracerSettings};
use gi_host::scene::Scene;
use gi_host::scene::upload::GpuScene;
use gi_host::vulkan::Buffer;
use gi_shared::camera::CameraParams;
use gi_tests::{context, finish_without_validation_messages, scene_path};
use glam::Vec3;

/// The allocation error of `result`: it names `what` and gives `bytes`, on one line.
fn allocation_error<T>(result: gi_host::Result<T>, what: &str, bytes: u64) -> String {
    let Err(e) = result else {
        panic!("{what}: {bytes} bytes were granted")
    };
    let message = e.to_string();
    match e {
        Error::Allocation {
            what: w, bytes: b, ..
        } => {
            assert_eq!((w.as_str(), b), (what, Some(bytes)), "{message}");
        }
        other => panic!("not an allocation error: {other}"),
    }
    assert!(
        message.contains(&format!("{what:?} ({bytes} bytes")),
        "{message}"
    );
    assert!(!message.contains('\n'), "{message}");
    message
}

/// A terabyte buffer, device-local and host-visible: refused by name and size (lavapipe's
/// largest buffer is 4 GiB), and the device goes on working.
#[test]
fn a_terabyte_buffer_is_refused_by_name_and_size() {
    let ctx = context(KernelVariant::Software);
    let tib = 1u64 << 40;
    for made in [
        Buffer::device_zeroed::<u8>(&ctx, "terabyte", tib as usize),
        Buffer::readback::<u8>(&ctx, "terabyte", tib as usize),
    ] {
        let message = allocation_error(made, "terabyte", tib);
        assert!(message.contains("1024.000 GiB"), "{message}");
        assert!(message.contains("larger than the device's"), "{message}");
    }
    assert!(ctx.live_buffers().is_empty(), "{:?}", ctx.live_buffers());
    let small = Buffer::device_zeroed::<u32>(&ctx, "after", 16).unwrap();
    assert_eq!(small.read_back::<u32>(&ctx).unwrap(), vec![0; 16]);
    drop(small);
    assert!(!ctx.is_lost());
    finish_without_validation_messages(ctx);
}

/// A 100000 × 100000 request: images beyond the device's largest side are refused by name,
/// the path tracer's accumulation buffer (160 GB) by name and size, and the GI frame by its
/// resolution setting.
#[test]
fn a_100000_by_100000_image_is_refused_by_name() {
    let ctx = context(KernelVariant::Software);
    let side = 100_000;
    match GBufferImages::new(&ctx, side, side) {
        Err(
            e @ Error::InvalidArgument {
                name: "image size", ..
            },
        ) => {
            let message = e.to_string();
            assert!(
                message.contains("\"G-buffer depth\" of 100000×100000")
                    && message.contains("maxImageDimension2D"),
                "{message}"
            );
        }
        Err(e) => panic!("not an image size error: {e}"),
        Ok(_) => panic!("a 100000×100000 image was made"),
    }

    let (scene, _) = Scene::load(scene_path("cornell-box.gltf")).unwrap();
    let (lights, gpu) = GpuScene::upload_lit(&ctx, &scene, None, false).unwrap();
    let camera = CameraParams::new(
        Vec3::new(0.0, 1.0, 3.9),
        Vec3::NEG_Z,
        Vec3::Y,
        0.7,
        side,
        side,
    );
    let mut pass = PathTracerPass::new(&ctx).unwrap();
    let settings = PathTracerSettings {
        samples: 1,
        ..Default::default()
    };
    let pixels = u64::from(side) * u64::from(side);
    allocation_error(
        pass.render(&ctx, &gpu, &camera, &settings, |_, _| {}),
        "path tracer accumulation",
        pixels * 16,
    );

    let view = ViewOptions {
        sky: Vec3::ZERO,
        emissive_multiplier: 1.0,
        seed: 0,
    };
    let gi = GiRenderer::new(
        &ctx,
        &lights,
        side,
        side,
        GiSettings::for_resolution(side, side),
        view,
    );
    match gi {
        Err(Error::InvalidArgument { name, why }) => {
            assert_eq!(name, "resolution");
            assert!(why.starts_with("100000x100000"), "{why}");
        }
        Err(e) => panic!("not a resolution error: {e}"),
        Ok(_) => panic!("a 100000×100000 GI frame was made"),
    }
    drop((pass, gpu));
    finish_without_validation_messages(ctx);
}
