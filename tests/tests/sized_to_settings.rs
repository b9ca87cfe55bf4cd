//! The frame holds only what its settings use (issue 24): a technique switched off frees its
//! buffers (a one-element placeholder stays where a pass still binds it) and takes its passes
//! out of the frame; a scene of at most `EXACT_DIRECT_LIGHTS` lights has no light grid; buffers
//! whose contents never live at the same time share one.

use gi_host::KernelVariant;
use gi_host::frame::MemoryTable;
use gi_host::gbuffer::scene_camera;
use gi_host::gi::renderer::GiRenderer;
use gi_host::gi::{GiSettings, Preset, ViewOptions};
use gi_host::scene::Scene;
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::LightSet;
use gi_host::scene::upload::GpuScene;
use gi_host::vulkan::Context;
use gi_shared::camera::CameraParams;
use gi_shared::light_grid::light_grid_needed;
use gi_tests::{context, finish_without_validation_messages, load_scene};
use glam::Vec3;

const SIDE: u32 = 64;

/// Largest a placeholder may be: one element of the largest record.
const PLACEHOLDER_BYTES: u64 = 128;

/// What one frame of `settings` kept: every live buffer and image by name, and the passes.
struct Footprint {
    rows: Vec<(String, u64)>,
    total: u64,
    passes: Vec<String>,
}

impl Footprint {
    fn bytes(&self, name: &str) -> u64 {
        self.rows
            .iter()
            .filter(|(n, _)| n == name)
            .map(|(_, b)| b)
            .sum()
    }
}

fn footprint(
    ctx: &Context,
    scene: &Scene,
    gpu: &GpuScene,
    lights: &LightSet,
    settings: GiSettings,
) -> Footprint {
    let mut gi =
        GiRenderer::new(ctx, lights, SIDE, SIDE, settings, ViewOptions::default()).unwrap();
    gi.render_frame(ctx, gpu, &scene_camera(scene, SIDE, SIDE))
        .unwrap();
    let passes = gi
        .timings()
        .passes()
        .iter()
        .map(|p| p.name.clone())
        .collect();
    let table = MemoryTable::of(ctx);
    drop(gi);
    Footprint {
        rows: table
            .rows
            .iter()
            .map(|r| (r.name.clone(), r.bytes))
            .collect(),
        total: table.total_bytes(),
        passes,
    }
}

type Switch = fn(&mut GiSettings);

#[test]
fn a_technique_switched_off_frees_its_memory_and_passes() {
    let scene = load_scene("cornell-box.gltf");
    let ctx = context(KernelVariant::Software);
    let lights = LightSet::new(&scene, None, true);
    let shading = ShadingData::new(&scene).unwrap();
    let gpu = GpuScene::upload(&ctx, &scene, None, &shading, &lights).unwrap();
    let all = GiSettings {
        restir: true,
        temporal_feedback: true,
        ..Preset::Balanced.settings(SIDE, SIDE)
    };
    let full = footprint(&ctx, &scene, &gpu, &lights, all);
    let cases: [(&str, Switch, &[&str], &[&str]); 6] = [
        (
            // Its horizontal output lives in the per-pixel scratch (`the_scratch_holds_...`).
            "probe_filter",
            |s| s.probe_filter = false,
            &[],
            &["FilterScreenProbes"],
        ),
        (
            "denoiser_spatial",
            |s| s.denoiser_spatial = false,
            &["filtered GI (horizontal)"],
            &["FilterGI"],
        ),
        (
            "restir",
            |s| s.restir = false,
            &[
                "reservoirs (a)",
                "reservoirs (b)",
                "reservoir hits (a)",
                "reservoir places",
            ],
            &["ClearReservoirs", "CompactReservoirs", "ResampleReservoirs"],
        ),
        (
            "multi_bounce",
            |s| s.multi_bounce = false,
            &["carried queries", "hash grid bounce values"],
            &[],
        ),
        (
            "patching",
            |s| s.patching = false,
            &[],
            &["PatchScreenProbes"],
        ),
        (
            "temporal_feedback",
            |s| s.temporal_feedback = false,
            &["feedback history"],
            &[],
        ),
    ];
    for (name, switch_off, buffers, passes) in cases {
        let mut settings = all;
        switch_off(&mut settings);
        let off = footprint(&ctx, &scene, &gpu, &lights, settings);
        let mut freed = 0;
        for b in buffers {
            let (with, without) = (full.bytes(b), off.bytes(b));
            println!("{name} off: {b} {with} -> {without} bytes");
            assert!(
                with > 16 * PLACEHOLDER_BYTES,
                "{name}: {b} holds {with} bytes"
            );
            assert!(
                without <= PLACEHOLDER_BYTES,
                "{name} off: {b} holds {without} bytes"
            );
            freed += with - without;
        }
        for p in passes {
            assert!(full.passes.iter().any(|q| q == p), "{name}: no {p}");
            assert!(!off.passes.iter().any(|q| q == p), "{name} off: {p} ran");
        }
        assert!(
            off.total + freed <= full.total,
            "{name} off: {} bytes, {} with it, {freed} freed",
            off.total,
            full.total
        );
    }
    drop(gpu);
    finish_without_validation_messages(ctx);
}

/// A scene of at most `EXACT_DIRECT_LIGHTS` lights builds no light grid: its entries are a
/// placeholder (the Cornell box's 2 lights), where 256 lights (`many-lights.gltf`) fill the grid.
#[test]
fn few_lights_build_no_light_grid() {
    let ctx = context(KernelVariant::Software);
    let settings = Preset::Balanced.settings(SIDE, SIDE);
    let mut grid_bytes = Vec::new();
    for name in ["cornell-box.gltf", "many-lights.gltf"] {
        let scene = load_scene(name);
        let lights = LightSet::new(&scene, None, true);
        let shading = ShadingData::new(&scene).unwrap();
        let gpu = GpuScene::upload(&ctx, &scene, None, &shading, &lights).unwrap();
        let f = footprint(&ctx, &scene, &gpu, &lights, settings);
        let bytes = f.bytes("light grid entries");
        println!(
            "{name}: {} lights, light grid entries {bytes} bytes",
            lights.params().count
        );
        grid_bytes.push((lights.params().count, bytes));
    }
    let [(few, none), (many, full)] = grid_bytes[..] else {
        unreachable!()
    };
    assert!(
        !light_grid_needed(few) && light_grid_needed(many),
        "{few}, {many}"
    );
    assert!(none <= PLACEHOLDER_BYTES, "{few} lights: {none} bytes");
    assert!(
        full > 1024 * PLACEHOLDER_BYTES,
        "{many} lights: {full} bytes"
    );
    finish_without_validation_messages(ctx);
}

/// The frame's per-pixel scratch, the interpolated irradiance, also holds the probe filter's
/// horizontal output (before InterpolateScreenProbes writes it), FilterGI's (after ReprojectGI
/// has read it) and the GI image (after that): none of those three has a buffer of its own, and
/// the images are the same bits as with buffers of their own
/// (`GiRenderer::keep_interpolated_irradiance`, which temporal feedback and the debug views
/// need), frame after frame of a moving camera.
#[test]
fn the_scratch_holds_the_horizontal_outputs_and_the_image_bit_for_bit() {
    let scene = load_scene("cornell-box.gltf");
    let ctx = context(KernelVariant::Software);
    let lights = LightSet::new(&scene, None, true);
    let shading = ShadingData::new(&scene).unwrap();
    let gpu = GpuScene::upload(&ctx, &scene, None, &shading, &lights).unwrap();
    let settings = Preset::Balanced.settings(SIDE, SIDE);
    assert!(settings.probe_filter && settings.denoiser_spatial && !settings.temporal_feedback);
    let base = scene_camera(&scene, SIDE, SIDE);
    let pixels = u64::from(SIDE * SIDE);
    let mut runs = Vec::new();
    for keep in [false, true] {
        let mut gi =
            GiRenderer::new(&ctx, &lights, SIDE, SIDE, settings, ViewOptions::default()).unwrap();
        if keep {
            gi.keep_interpolated_irradiance(&ctx).unwrap();
        }
        let mut images = Vec::new();
        for f in 0..6 {
            let eye = base.position() + Vec3::new(0.02 * f as f32, 0.0, 0.0);
            let camera = CameraParams::new(eye, base.forward(), base.up(), 0.7, SIDE, SIDE);
            gi.render_frame(&ctx, &gpu, &camera).unwrap();
            images.push(gi.image(&ctx).unwrap());
        }
        let table = MemoryTable::of(&ctx);
        let bytes = |name: &str| -> u64 {
            table
                .rows
                .iter()
                .filter(|r| r.name == name)
                .map(|r| r.bytes)
                .sum()
        };
        let own = [
            bytes("filtered probes (horizontal)"),
            bytes("filtered GI (horizontal)"),
            bytes("GI image"),
        ];
        println!("keep {keep}: filtered probes, filtered GI, GI image {own:?} bytes");
        assert!(own[0] <= PLACEHOLDER_BYTES, "keep {keep}: {own:?}");
        if keep {
            assert_eq!(own[1..], [pixels * 16, pixels * 16], "{own:?}");
        } else {
            assert!(own[1..].iter().all(|&b| b <= PLACEHOLDER_BYTES), "{own:?}");
        }
        drop(gi);
        runs.push(images);
    }
    for (f, (a, b)) in runs[0].iter().zip(&runs[1]).enumerate() {
        assert!(a.pixels().iter().any(|p| p[0] > 0.0), "frame {f}: black");
        assert!(a.pixels() == b.pixels(), "frame {f}: the images differ");
    }
    drop(gpu);
    finish_without_validation_messages(ctx);
}
