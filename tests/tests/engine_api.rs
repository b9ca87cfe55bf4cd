//! The engine integration API (issue 14): the `headless` example's code (an engine's own
//! instance, device, output image and command buffer, our passes recorded into it) against
//! `GiRenderer::render_frame` on a context of ours, and the API's refusals and resize.
//!
//! One test, so that instances and devices are never created on two threads at once.

#[path = "../../host/examples/common/integration.rs"]
mod integration;

use ash::vk;
use gi_host::engine::{
    FrameInputs, FrameOutputs, GiRenderer, GiSettings, GpuScene, OUTPUT_FORMAT, OutputImage,
    ViewOptions,
};
use gi_host::gbuffer::scene_camera;
use gi_host::image_io::HdrImage;
use gi_host::metrics::{CompareSettings, compare};
use gi_host::{KernelVariant, TraceMode};
use gi_tests::{context, finish_without_validation_messages, load_scene};

/// Side of the images.
const SIDE: u32 = 64;
/// Frames rendered by each path.
const FRAMES: u32 = 8;

fn mean(image: &HdrImage) -> f64 {
    let pixels = image.pixels();
    pixels.iter().flatten().map(|&c| f64::from(c)).sum::<f64>() / (pixels.len() * 3) as f64
}

fn assert_finite_and_lit(image: &HdrImage, what: &str) {
    assert!(
        image.pixels().iter().flatten().all(|c| c.is_finite()),
        "{what}: a pixel is not finite"
    );
    assert!(mean(image) > 0.01, "{what}: black (mean {})", mean(image));
}

#[test]
fn an_engine_device_renders_what_render_frame_renders() {
    let scene = load_scene("cornell-box.gltf");
    let engine =
        integration::render(&scene, (SIDE, SIDE), FRAMES, TraceMode::Software, true).unwrap();
    assert!(
        engine.validation_messages.is_empty(),
        "{} validation messages on the engine's device:\n{}",
        engine.validation_messages.len(),
        engine.validation_messages.join("\n")
    );
    assert_finite_and_lit(&engine.image, "engine's image");

    let ctx = context(KernelVariant::Software);
    let (lights, gpu) = GpuScene::upload_lit(&ctx, &scene, None, true).unwrap();
    let settings = GiSettings::for_resolution(SIDE, SIDE);
    let mut gi =
        GiRenderer::new(&ctx, &lights, SIDE, SIDE, settings, ViewOptions::default()).unwrap();
    let camera = scene_camera(&scene, SIDE, SIDE);
    for _ in 0..FRAMES {
        gi.render_frame(&ctx, &gpu, &camera).unwrap();
    }
    let ours = gi.image(&ctx).unwrap();
    let metrics = compare(&ours, &engine.image, &CompareSettings::default())
        .unwrap()
        .metrics;
    println!("engine's device against render_frame: {metrics}");
    assert!(metrics.relative_mse < 1e-3, "{metrics}");
    assert!(metrics.mean_bias.abs() < 0.01, "{metrics}");

    // Refusals name the output at fault, before anything is recorded.
    let mut gpu = gpu;
    let output = OutputImage {
        image: vk::Image::null(),
        format: OUTPUT_FORMAT,
        width: SIDE,
        height: SIDE,
        layout: vk::ImageLayout::GENERAL,
    };
    let cases = [
        (
            OutputImage {
                format: vk::Format::R16G16B16A16_SFLOAT,
                ..output
            },
            "format",
        ),
        (
            OutputImage {
                width: SIDE / 2,
                ..output
            },
            "32 × 64",
        ),
        (
            OutputImage {
                layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                ..output
            },
            "layout",
        ),
    ];
    for (image, words) in cases {
        let outputs = FrameOutputs {
            image: None,
            irradiance: Some(image),
        };
        let inputs = FrameInputs::new(camera);
        let err = gi
            .record(&ctx, vk::CommandBuffer::null(), &mut gpu, &inputs, &outputs)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("irradiance image") && err.contains(words),
            "{err}"
        );
    }
    assert_eq!(gi.frames(), FRAMES, "a refused frame was counted");

    // Resize keeps the world cache's hash grid (same buffers) and renders at the new size.
    let keys = gi.cache_resources().keys.handle;
    let live = gi.frame_stats(&ctx).unwrap().cache.live_tiles;
    assert!(live > 0);
    let (width, height) = (48, 32);
    gi.resize(&ctx, width, height).unwrap();
    assert_eq!(gi.cache_resources().keys.handle, keys);
    let camera = scene_camera(&scene, width, height);
    let stats = gi.render_frame(&ctx, &gpu, &camera).unwrap();
    assert!(stats.cache.live_tiles >= live / 2, "{stats:?} after {live}");
    let resized = gi.image(&ctx).unwrap();
    assert_eq!((resized.width(), resized.height()), (width, height));
    assert_finite_and_lit(&resized, "resized image");
    drop((gi, gpu));
    finish_without_validation_messages(ctx);
}
