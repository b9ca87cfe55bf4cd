//! The scene's split arrays (`gi_shared::elements`): the vertices, triangles and BVH nodes of a
//! scene forced into 4 KiB storage bindings (several chunks each, boundaries inside a mesh)
//! render exactly the G-buffer and the path-traced image of the same scene uploaded whole, in both
//! tracing variants, with the validation layer silent; an array that no [`SCENE_BUFFER_CHUNKS`]
//! bindings hold is an error naming it.

use gi_host::KernelVariant;
use gi_host::gbuffer::{GBufferData, GBufferImages, GBufferPass, scene_camera};
use gi_host::image_io::HdrImage;
use gi_host::path_tracer::{PathTracerPass, PathTracerSettings};
use gi_host::scene::Scene;
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::LightSet;
use gi_host::scene::procedural::scaling_room;
use gi_host::scene::upload::{GeometryData, GpuScene};
use gi_host::vulkan::Context;
use gi_shared::gbuffer::SKY_DEPTH;
use gi_shared::layout::SCENE_BUFFER_CHUNKS;
use gi_tests::{context, finish_without_validation_messages, variants};

const SIDE: u32 = 32;
/// Bindings of 4 KiB: 128 vertices, 256 triangles or 64 BVH nodes each.
const TINY_BINDING: u64 = 4096;

/// The room of `gi bench`'s sweeps with 16 instances of a 320-triangle icosphere: 186 vertices,
/// 332 triangles, ~200 nodes, so that every split array has 2 to 8 chunks.
fn room() -> Scene {
    scaling_room(2, 2).expect("a room with lights")
}

struct Output {
    gbuffer: GBufferData,
    image: HdrImage,
    /// Chunks of the vertices, triangles and (software) BVH nodes.
    chunks: [usize; 3],
}

/// The G-buffer and a path-traced image of `scene` uploaded with `max_binding_bytes`, rendered
/// with `ctx`'s passes.
fn render(
    ctx: &Context,
    passes: &mut (GBufferPass, PathTracerPass),
    scene: &Scene,
    max_binding_bytes: u64,
) -> Output {
    let shading = ShadingData::new(scene).unwrap();
    let lights = LightSet::new(scene, None, false);
    let gpu =
        GpuScene::upload_with_binding_limit(ctx, scene, None, &shading, &lights, max_binding_bytes)
            .unwrap();
    let [vertices, triangles] = gpu.shading.chunk_counts();
    let nodes = match &gpu.geometry.data {
        GeometryData::Software { nodes } => nodes.chunks().len(),
        GeometryData::RayQuery { .. } => 0,
    };
    let camera = scene_camera(scene, SIDE, SIDE);
    let images = GBufferImages::new(ctx, SIDE, SIDE).unwrap();
    passes.0.run(ctx, &gpu, &camera, &images).unwrap();
    let gbuffer = images.read_back(ctx).unwrap();
    let settings = PathTracerSettings {
        samples: 4,
        max_bounces: 3,
        ..Default::default()
    };
    let image = passes
        .1
        .render(ctx, &gpu, &camera, &settings, |_, _| {})
        .unwrap()
        .image;
    Output {
        gbuffer,
        image,
        chunks: [vertices, triangles, nodes],
    }
}

#[test]
fn tiny_bindings_render_exactly_like_whole_buffers() {
    let scene = room();
    for variant in variants() {
        let ctx = context(variant);
        let mut passes = (
            GBufferPass::new(&ctx).unwrap(),
            PathTracerPass::new(&ctx).unwrap(),
        );
        let whole = render(&ctx, &mut passes, &scene, u64::MAX);
        let split = render(&ctx, &mut passes, &scene, TINY_BINDING);
        drop(passes);
        finish_without_validation_messages(ctx);
        let software = variant == KernelVariant::Software;
        assert_eq!(whole.chunks, [1, 1, usize::from(software)], "{variant}");
        let [vertices, triangles, nodes] = split.chunks;
        assert!(
            (2..=SCENE_BUFFER_CHUNKS).contains(&vertices)
                && (2..=SCENE_BUFFER_CHUNKS).contains(&triangles),
            "{variant}: {:?}",
            split.chunks
        );
        assert!(
            !software || (2..=SCENE_BUFFER_CHUNKS).contains(&nodes),
            "{nodes}"
        );
        // Something is in view and lit, so the comparison means something.
        let hits = whole
            .gbuffer
            .texels
            .iter()
            .filter(|t| t.depth != SKY_DEPTH)
            .count();
        assert!(
            hits > (SIDE * SIDE / 2) as usize,
            "{variant}: {hits} pixels hit"
        );
        let lit = whole.image.pixels().iter().filter(|p| p[0] > 0.0).count();
        assert!(
            lit > (SIDE * SIDE / 2) as usize,
            "{variant}: {lit} pixels lit"
        );
        let differ = whole
            .gbuffer
            .texels
            .iter()
            .zip(&split.gbuffer.texels)
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(
            differ, 0,
            "{variant}: G-buffer pixels that differ when split"
        );
        assert!(
            whole.image.pixels() == split.image.pixels(),
            "{variant}: the split path-traced image differs"
        );
        println!(
            "{variant}: identical with {vertices} vertex, {triangles} triangle and {nodes} node \
             chunks of {TINY_BINDING} bytes"
        );
    }
}

#[test]
fn arrays_beyond_every_binding_are_errors_naming_them() {
    let scene = room();
    let ctx = context(KernelVariant::Software);
    let shading = ShadingData::new(&scene).unwrap();
    let lights = LightSet::new(&scene, None, false);
    // 256-byte bindings: 4 nodes each, 8 bindings for ~200 nodes.
    let err = GpuScene::upload_with_binding_limit(&ctx, &scene, None, &shading, &lights, 256)
        .err()
        .expect("the nodes do not fit");
    let text = err.to_string();
    assert!(text.contains("bvh nodes"), "{text}");
    assert!(
        text.contains(&format!("{SCENE_BUFFER_CHUNKS} storage bindings")),
        "{text}"
    );
    finish_without_validation_messages(ctx);
}
