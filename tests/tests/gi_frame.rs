//! The whole GI-1.0 frame (issue 10) on the GPU, with the validation layer on. Images are small
//! (lavapipe is slow); every test prints what it measured, and the bounds are set from those
//! measurements with a margin that a 2× regression still breaks.
//!
//! * [`gi_converges_to_the_path_tracer`]: static frames of the Cornell box and `indirect-room`
//!   against the path tracer: relMSE, FLIP and the image mean (which a light path counted twice
//!   or not at all would move by tens of percent).
//! * [`switching_a_technique_off_moves_the_error_the_expected_way`]: hysteresis, reprojection,
//!   patching and the leak fixes, each measured with the metric its failure shows in.
//! * [`a_slow_orbit_stays_temporally_stable`]: frame-to-frame change with the stabilising
//!   techniques on and off.
//! * [`no_gi_buffer_holds_nan_or_inf_after_1000_moving_frames`] and
//!   [`both_tracing_variants_render_the_same_frame_cleanly`].

use gi_host::KernelVariant;
use gi_host::frame::FiniteCheck;
use gi_host::gbuffer::scene_camera;
use gi_host::gi::probe_debug_views::gi_debug_views;
use gi_host::gi::renderer::{GiFrameStats, GiRenderer};
use gi_host::gi::{GiSettings, Preset, ViewOptions};
use gi_host::image_io::HdrImage;
use gi_host::metrics::{CompareSettings, compare};
use gi_host::scene::Scene;
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::LightSet;
use gi_host::scene::upload::GpuScene;
use gi_host::vulkan::{Context, KernelModule};
use gi_shared::camera::CameraParams;
use gi_shared::hash::pcg_chain;
use gi_shared::light_grid::{
    LIGHT_GRID_RESERVOIRS_PER_CELL, LightGridEntry, LightGridParams, build_light_grid_cell,
};
use gi_shared::screen_probes::{PROBE_SIZE, ProbeRecord};
use gi_shared::world_cache::PASS_LIGHT_GRID;
use gi_tests::{
    context, finish_without_validation_messages, load_scene, reference_image, variants,
};
use glam::{Quat, Vec3};

/// Side of the test images.
const SIDE: u32 = 64;
/// Static frames before the image is compared.
const FRAMES: u32 = 48;
/// Paths per pixel of the committed references (`tests/data/reference/*-64.exr`, written by
/// `bash scripts/references.sh`: the path tracer at the scene's own camera, seed 0).
const REFERENCE_SPP: u32 = 4096;

/// A context with a scene uploaded.
struct Gpu {
    ctx: Context,
    lights: LightSet,
    scene: GpuScene,
}

impl Gpu {
    fn new(variant: KernelVariant, scene: &Scene) -> Self {
        let ctx = context(variant);
        let lights = LightSet::new(scene, None, true);
        let shading = ShadingData::new(scene).unwrap();
        let gpu = GpuScene::upload(&ctx, scene, None, &shading, &lights).unwrap();
        Self {
            ctx,
            lights,
            scene: gpu,
        }
    }

    fn renderer(&self, settings: GiSettings) -> GiRenderer {
        self.seeded_renderer(settings, 0)
    }

    fn seeded_renderer(&self, settings: GiSettings, seed: u32) -> GiRenderer {
        GiRenderer::new(
            &self.ctx,
            &self.lights,
            SIDE,
            SIDE,
            settings,
            ViewOptions {
                seed,
                ..ViewOptions::default()
            },
        )
        .unwrap()
    }

    /// Renders `frames` frames, `camera_at(frame)` seeing each; returns the last frame's stats.
    fn run(
        &self,
        gi: &mut GiRenderer,
        frames: u32,
        camera_at: impl Fn(u32) -> CameraParams,
    ) -> GiFrameStats {
        let mut last = GiFrameStats::default();
        for f in 0..frames {
            last = gi
                .render_frame(&self.ctx, &self.scene, &camera_at(gi.frames().max(f)))
                .unwrap();
        }
        last
    }

    /// `frames` static frames of the scene's camera with `settings`: the last image.
    fn converged(&self, scene: &Scene, settings: GiSettings, frames: u32) -> HdrImage {
        let camera = scene_camera(scene, SIDE, SIDE);
        let mut gi = self.renderer(settings);
        self.run(&mut gi, frames, |_| camera);
        gi.image(&self.ctx).unwrap()
    }

    fn finish(self) {
        let Self { ctx, scene, .. } = self;
        drop(scene);
        finish_without_validation_messages(ctx);
    }
}

fn settings() -> GiSettings {
    GiSettings::for_resolution(SIDE, SIDE)
}

/// What `gi render` runs by default: the reference's settings with multi-bounce.
fn balanced() -> GiSettings {
    Preset::Balanced.settings(SIDE, SIDE)
}

fn mean(image: &HdrImage) -> f64 {
    let p = image.pixels();
    p.iter()
        .map(|c| f64::from(c[0] + c[1] + c[2]) / 3.0)
        .sum::<f64>()
        / p.len() as f64
}

/// relMSE, FLIP and the relative bias of the mean of `test` against `reference`.
fn errors(reference: &HdrImage, test: &HdrImage) -> (f64, f64, f64) {
    let c = compare(reference, test, &CompareSettings::default()).unwrap();
    let bias = mean(test) / mean(reference) - 1.0;
    (c.metrics.relative_mse, c.metrics.flip, bias)
}

#[test]
fn gi_converges_to_the_path_tracer() {
    // Bounds: measured values (printed) × about 1.5, so that 2× fails. The references trace
    // pixel centres as the G-buffer does. Measured: Cornell box relMSE 0.0441, FLIP 0.256, mean
    // −5.5 % (−18 % before the probe filter's same-point test and the mean-preserving
    // hysteresis); indirect room 0.0019, 0.057, −11.3 % (at 48 frames the multi-bounce cache is
    // still warming up: README "Bias budget").
    for (file, max_relmse, max_flip, max_bias) in [
        ("cornell-box", 0.066, 0.38, 0.085),
        ("indirect-room", 0.0025, 0.085, 0.16),
    ] {
        let scene = load_scene(&format!("{file}.gltf"));
        let gpu = Gpu::new(KernelVariant::Software, &scene);
        let image = gpu.converged(&scene, balanced(), FRAMES);
        let (relmse, flip, bias) = errors(&reference_image(file, SIDE), &image);
        println!(
            "{file}: GI after {FRAMES} frames vs the path tracer at {REFERENCE_SPP} spp: relMSE \
             {relmse:.4}, FLIP {flip:.4}, mean {:+.1}%",
            bias * 100.0
        );
        assert!(relmse < max_relmse, "{file}: relMSE {relmse}");
        assert!(flip < max_flip, "{file}: FLIP {flip}");
        assert!(bias.abs() < max_bias, "{file}: mean off by {bias}");
        gpu.finish();
    }
}

/// Emitter sampling (`GiSettings::emitter_sampling`, on in every preset): the Cornell box's small
/// ceiling light, sampled at the primary hit instead of through the probes' cells, gives a frame
/// with under 0.3 of the error, its mean within 3 points of the probes'. Measured after 24
/// frames, off → on: relMSE 0.0366 → 0.0095, FLIP 0.239 → 0.152, mean −4.6 → −4.0 % (round 28,
/// whose weighted cache samples took the probes' path from 0.0668 to 0.0366 and left the sampled
/// one as it was; before it 0.0668 → 0.0096, FLIP 0.265 → 0.148, mean −0.9 → −2.9 %; round
/// 16: the estimate denoised, a one-tile jitter; before it, added undenoised with the jitter of
/// 2 tiles, 0.0563 → 0.0218, 0.254 → 0.167, −4.2 → −5.5 %; converged at 128 × 72, README
/// "Emitters sampled at the primary hit": relMSE 0.022 → 0.004, mean −4.0 → −3.8 %).
#[test]
fn emitter_sampling_lowers_the_error_of_a_small_emitters_light() {
    let scene = load_scene("cornell-box.gltf");
    let reference = reference_image("cornell-box", SIDE);
    let gpu = Gpu::new(KernelVariant::Software, &scene);
    let measure = |emitter_sampling: bool| {
        let image = gpu.converged(
            &scene,
            GiSettings {
                emitter_sampling,
                ..balanced()
            },
            24,
        );
        errors(&reference, &image)
    };
    let (off, on) = (measure(false), measure(true));
    println!(
        "emitter sampling off: relMSE {:.4}, FLIP {:.3}, mean {:+.1}%; on: relMSE {:.4}, FLIP \
         {:.3}, mean {:+.1}%",
        off.0,
        off.1,
        off.2 * 100.0,
        on.0,
        on.1,
        on.2 * 100.0
    );
    assert!(on.0 < 0.3 * off.0, "relMSE on {}, off {}", on.0, off.0);
    assert!(on.1 < off.1, "FLIP on {}, off {}", on.1, off.1);
    assert!(
        (on.2 - off.2).abs() < 0.03,
        "mean on {}, off {}",
        on.2,
        off.2
    );
    gpu.finish();
}

/// The light of `test` over the reference's in the light-leak scene's dark room (the columns
/// right of the wall, which stands in the middle, with a margin the screen-space filters do not
/// cross): light leaking through the wall raises it.
fn dark_ratio(reference: &HdrImage, test: &HdrImage) -> f64 {
    let lum = |c: &[f32; 3]| f64::from(0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]);
    let (mut r, mut t) = (0.0, 0.0);
    for (i, (a, b)) in reference.pixels().iter().zip(test.pixels()).enumerate() {
        if i as u32 % SIDE > SIDE / 2 + 6 {
            r += lum(a);
            t += lum(b);
        }
    }
    t / r.max(1e-12)
}

/// Fireflies of a still camera's `frames`: pixels brighter than twice the frames' own per-pixel
/// mean luminance plus 0.02, summed over the frames. Outliers in time, that is: an error every
/// frame shares (light the interpolation jitter moves across a shadow edge) is not one.
fn fireflies(frames: &[HdrImage]) -> usize {
    let lum = |c: &[f32; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let n = frames.len() as f32;
    let mut mean = vec![0.0f32; frames[0].pixels().len()];
    for frame in frames {
        for (m, p) in mean.iter_mut().zip(frame.pixels()) {
            *m += lum(p) / n;
        }
    }
    frames
        .iter()
        .map(|frame| {
            mean.iter()
                .zip(frame.pixels())
                .filter(|(m, p)| lum(p) > 2.0 * **m + 0.02)
                .count()
        })
        .sum()
}

/// The camera of `scene` turned about the vertical axis through the point 3 units ahead by
/// `degrees`.
fn turned(scene: &Scene, degrees: f32) -> CameraParams {
    let base = scene_camera(scene, SIDE, SIDE);
    let pivot = base.position() + base.forward() * 3.0;
    let turn = Quat::from_rotation_y(degrees.to_radians());
    CameraParams::new(
        pivot + turn * (base.position() - pivot),
        turn * base.forward(),
        Vec3::Y,
        2.0 * base.tan_half_fov_y.atan(),
        SIDE,
        SIDE,
    )
}

/// The camera of `scene` turned in place about the vertical axis by `degrees`.
fn panned(scene: &Scene, degrees: f32) -> CameraParams {
    let base = scene_camera(scene, SIDE, SIDE);
    CameraParams::new(
        base.position(),
        Quat::from_rotation_y(degrees.to_radians()) * base.forward(),
        Vec3::Y,
        2.0 * base.tan_half_fov_y.atan(),
        SIDE,
        SIDE,
    )
}

/// Random streams the firefly count of `switching_a_technique_off_…` sums over.
const FIREFLY_SEEDS: u32 = 4;

#[test]
fn switching_a_technique_off_moves_the_error_the_expected_way() {
    let scene = load_scene("cornell-box.gltf");
    let reference = reference_image("cornell-box", SIDE);
    let gpu = Gpu::new(KernelVariant::Software, &scene);
    let base = settings();
    let undenoised = GiSettings {
        denoiser_temporal: false,
        denoiser_spatial: false,
        ..base
    };
    // Hysteresis: single rays that find the light are fireflies without it (seen before the
    // denoiser averages them away): temporal outliers over frames 8 to 31 of four random
    // streams. Measured (round 11): on 2918, off 8118; with an interpolation jitter of 1 tile
    // 3251 and 6421, without jitter 1723 and 5442. Counted against the reference instead, the
    // jitter's light across shadow edges swamped them (1 tile: on 12550, off 11297). The
    // hysteresis keeps each cell's mean (issue 22), so it spreads a firefly over frames instead
    // of cutting it.
    let fireflies_over_frames = |hysteresis: bool| {
        let camera = scene_camera(&scene, SIDE, SIDE);
        (0..FIREFLY_SEEDS)
            .map(|seed| {
                let settings = GiSettings {
                    hysteresis,
                    ..undenoised
                };
                let mut gi = gpu.seeded_renderer(settings, seed);
                let frames: Vec<HdrImage> = (0..32)
                    .filter_map(|f| {
                        gi.render_frame(&gpu.ctx, &gpu.scene, &camera).unwrap();
                        (f >= 8).then(|| gi.image(&gpu.ctx).unwrap())
                    })
                    .collect();
                fireflies(&frames)
            })
            .sum::<usize>()
    };
    let (with, without) = (fireflies_over_frames(true), fireflies_over_frames(false));
    println!(
        "fireflies over 24 undenoised frames of {FIREFLY_SEEDS} streams: hysteresis on {with}, off {without}"
    );
    assert!(2 * without > 3 * with, "on {with}, off {without}");
    // Reprojection: without it, tiles not spawned this frame hold no probe and each frame's
    // probes start from nothing: a noisier frame (before the denoiser's temporal average).
    let (on, ..) = errors(&reference, &gpu.converged(&scene, undenoised, 24));
    let off_image = gpu.converged(
        &scene,
        GiSettings {
            reprojection: false,
            ..undenoised
        },
        24,
    );
    let (off, ..) = errors(&reference, &off_image);
    println!("relMSE of a frame (undenoised): reprojection on {on:.4}, off {off:.4}");
    assert!(off > on + 0.03, "on {on}, off {off}");
    gpu.finish();
    // Patching: a camera that jumps leaves disoccluded tiles; with patching they get probes at
    // once, without they wait for their spawn turn and interpolation finds nothing nearby.
    let scene = load_scene("indirect-room.gltf");
    let gpu = Gpu::new(KernelVariant::Software, &scene);
    let holes = |patching: bool| {
        let mut gi = gpu.renderer(GiSettings { patching, ..base });
        let mut holes = 0;
        let mut patched = 0;
        for f in 0..24u32 {
            let camera = panned(&scene, if f < 12 { 0.0 } else { 10.0 });
            let st = gi.render_frame(&gpu.ctx, &gpu.scene, &camera).unwrap();
            if f == 12 {
                holes += st.empty - st.patched;
                patched += st.patched;
            }
        }
        (holes, patched)
    };
    let (holes_on, patched) = holes(true);
    let (holes_off, _) = holes(false);
    println!(
        "empty tiles left in the frame of a camera jump: patching on {holes_on} ({patched} patched), off          {holes_off}"
    );
    assert!(
        patched > 0 && holes_off > holes_on,
        "on {holes_on}, off {holes_off}"
    );
    gpu.finish();
    // The leak fixes: light from the lit room crosses the thin wall without them. Measured with
    // multi-bounce off: its bounce rays read cells that straddle the wall whatever the fixes
    // (a known bias, README "Bias budget"), printed for the record.
    let scene = load_scene("light-leak.gltf");
    let reference = reference_image("light-leak", SIDE);
    let gpu = Gpu::new(KernelVariant::Software, &scene);
    let single = base;
    let on = dark_ratio(&reference, &gpu.converged(&scene, single, FRAMES));
    let off = dark_ratio(
        &reference,
        &gpu.converged(
            &scene,
            GiSettings {
                short_ray_flag: false,
                bypass: false,
                ..single
            },
            FRAMES,
        ),
    );
    let multi = dark_ratio(&reference, &gpu.converged(&scene, balanced(), FRAMES));
    println!(
        "light-leak scene, light in the dark room over the path tracer's: leak fixes on {on:.3}, \
         off {off:.3}; with multi-bounce {multi:.3}"
    );
    assert!(off > on + 0.03, "on {on}, off {off}");
    gpu.finish();
}

/// Mean relative frame-to-frame change over the last 16 of 48 frames of a slow orbit, over the
/// pixels that see a surface in both frames.
fn temporal_change(gpu: &Gpu, scene: &Scene, settings: GiSettings) -> f64 {
    let mut gi = gpu.renderer(settings);
    let mut previous: Option<HdrImage> = None;
    let (mut sum, mut n) = (0.0f64, 0u64);
    for f in 0..48u32 {
        gi.render_frame(&gpu.ctx, &gpu.scene, &turned(scene, 0.05 * f as f32))
            .unwrap();
        if f < 31 {
            continue;
        }
        let image = gi.image(&gpu.ctx).unwrap();
        if let Some(p) = &previous {
            for (a, b) in p.pixels().iter().zip(image.pixels()) {
                let (la, lb) = (a.iter().sum::<f32>(), b.iter().sum::<f32>());
                if la > 0.0 && lb > 0.0 {
                    sum += f64::from((lb - la).abs() / (la + 0.05));
                    n += 1;
                }
            }
        }
        previous = Some(image);
    }
    sum / n.max(1) as f64
}

#[test]
fn a_slow_orbit_stays_temporally_stable() {
    let scene = load_scene("cornell-box.gltf");
    let gpu = Gpu::new(KernelVariant::Software, &scene);
    let on = temporal_change(&gpu, &scene, settings());
    let off = temporal_change(
        &gpu,
        &scene,
        GiSettings {
            hysteresis: false,
            denoiser_temporal: false,
            denoiser_spatial: false,
            probe_filter: false,
            ..settings()
        },
    );
    println!(
        "frame-to-frame change under a 0.05°/frame orbit: stabilising techniques on {:.2}%, off \
         {:.2}%",
        on * 100.0,
        off * 100.0
    );
    assert!(on < 0.03, "{on}");
    assert!(off > 2.0 * on, "on {on}, off {off}");
    gpu.finish();
}

#[test]
#[ignore = "long (1000 frames, 31 s): scripts/long-tests.sh runs it, and .ci/run that"]
fn no_gi_buffer_holds_nan_or_inf_after_1000_moving_frames() {
    const SIDE_SMALL: u32 = 32;
    let scene = load_scene("cornell-box.gltf");
    let target = Vec3::new(0.0, 1.0, 0.0);
    let camera_at = |f: u32| {
        let angle = 1.2 * (f as f32 * std::f32::consts::TAU / 250.0).sin();
        let radius = 3.0 + 1.5 * (f as f32 * std::f32::consts::TAU / 170.0).cos();
        let eye = target + radius * Vec3::new(angle.sin(), 0.3 * angle.cos(), angle.cos());
        CameraParams::new(eye, target - eye, Vec3::Y, 0.7, SIDE_SMALL, SIDE_SMALL)
    };
    let gpu = Gpu::new(KernelVariant::Software, &scene);
    let check = FiniteCheck::new(&gpu.ctx, &KernelModule::new(&gpu.ctx).unwrap()).unwrap();
    let mut gi = GiRenderer::new(
        &gpu.ctx,
        &gpu.lights,
        SIDE_SMALL,
        SIDE_SMALL,
        GiSettings::for_resolution(SIDE_SMALL, SIDE_SMALL),
        ViewOptions::default(),
    )
    .unwrap();
    let mut checked = 0u64;
    let mut buffer_count = 0;
    for f in 0..1000 {
        gi.render_frame(&gpu.ctx, &gpu.scene, &camera_at(f))
            .unwrap();
        if (f + 1) % 100 != 0 {
            continue;
        }
        let buffers = gi.float_buffers().unwrap();
        buffer_count = buffers.len();
        checked += buffers.iter().map(|(b, _)| b.size / 4).sum::<u64>();
        let counts = check.count(&gpu.ctx, &buffers).unwrap();
        assert!(
            counts.iter().all(|(_, n)| *n == 0),
            "after frame {f}: non-finite words {counts:?}"
        );
    }
    println!(
        "1000 moving frames: 0 non-finite floats in {checked} words checked ({} buffers every \
         100 frames)",
        buffer_count
    );
    drop(check);
    drop(gi);
    gpu.finish();
}

#[test]
fn both_tracing_variants_render_the_same_frame_cleanly() {
    let variants = variants();
    if variants.len() < 2 {
        return; // `variants` said why
    }
    let scene = load_scene("indirect-room.gltf");
    let images: Vec<HdrImage> = variants
        .iter()
        .copied()
        .map(|variant| {
            let gpu = Gpu::new(variant, &scene);
            let image = gpu.converged(&scene, settings(), 8);
            gpu.finish();
            image
        })
        .collect();
    let (relmse, _, bias) = errors(&images[0], &images[1]);
    println!(
        "{} vs {}: relMSE {relmse:.2e}, mean {:+.3}%",
        variants[0],
        variants[1],
        bias * 100.0
    );
    // Not bit-identical: the driver's ray/triangle test is not ours, so the variants agree on
    // hits only up to rounding and ties, and the frame's random streams carry any difference on;
    // the traversal itself must not add a visible error.
    assert!(
        relmse < 1e-3 && bias.abs() < 0.01,
        "relMSE {relmse}, bias {bias}"
    );
}

/// Identical frames (issue 22): the same scene, settings, camera path and device give the same
/// image bit for bit, run after run, in each tracing variant: the GI frame along a pan (so that
/// reprojection fails at the edge and patching moves spawns) with multi-bounce carrying queries
/// over, and the cache view. Random streams are keyed by spawn tile, ray and frame, spawns own
/// fixed slots, and patching decides its winners by tile index, not by the GPU's order. A cache of
/// 64 tiles, which overflows, repeats the runs: a full bucket keeps its old keys and the smallest
/// new one whatever the order of the inserts (`gi_shared::hash_cells::full_buckets`). So does
/// world-space ReSTIR (`gi_shared::world_restir::ordered_reservoir_entry`).
#[test]
fn the_same_run_twice_gives_the_same_image_bit_for_bit() {
    let scene = load_scene("indirect-room.gltf");
    let base = scene_camera(&scene, SIDE, SIDE);
    let pan = |f: u32| {
        let yaw = Quat::from_rotation_y(0.02 * f as f32);
        let forward = yaw * base.forward();
        CameraParams::new(
            base.position(),
            forward,
            Vec3::Y,
            2.0 * base.tan_half_fov_y.atan(),
            SIDE,
            SIDE,
        )
    };
    // 4 buckets of 16 tiles: every frame refuses inserts.
    let full = GiSettings {
        buckets_log2: 2,
        ..balanced()
    };
    // World-space ReSTIR strides through each reservoir cell's list of the previous frame: the
    // lists are ordered by ray, not by the order of the atomics that filled them.
    let restir = GiSettings {
        restir: true,
        ..balanced()
    };
    for (variant, settings) in variants()
        .into_iter()
        .flat_map(|v| [(v, balanced()), (v, full), (v, restir)])
    {
        let overflows = settings.buckets_log2 == full.buckets_log2;
        let gpu = Gpu::new(variant, &scene);
        let runs: Vec<(HdrImage, HdrImage)> = (0..2)
            .map(|_| {
                let mut gi = gpu.renderer(settings);
                let stats = gpu.run(&mut gi, 12, pan);
                assert_eq!(
                    stats.cache.failed_inserts > 0,
                    overflows,
                    "failed inserts: {stats:?}"
                );
                let frame = gi.image(&gpu.ctx).unwrap();
                drop(gi);
                let mut view = gi_host::gi::CacheView::new(
                    &gpu.ctx,
                    &gpu.lights,
                    SIDE,
                    SIDE,
                    settings,
                    ViewOptions::default(),
                )
                .unwrap();
                let mut refused = 0;
                for f in 0..12 {
                    let o = view.render_frame(&gpu.ctx, &gpu.scene, &pan(f)).unwrap();
                    refused += o.failed_inserts;
                }
                assert_eq!(refused > 0, overflows, "failed inserts: {refused}");
                let cached = view.image(&gpu.ctx).unwrap();
                println!(
                    "{variant} (full cache: {overflows}, ReSTIR: {}): last frame {stats:?}",
                    settings.restir
                );
                (frame, cached)
            })
            .collect();
        gpu.finish();
        for (i, run) in runs.iter().enumerate().skip(1) {
            let same = |a: &HdrImage, b: &HdrImage| {
                a.pixels()
                    .iter()
                    .zip(b.pixels())
                    .filter(|(x, y)| {
                        x.iter()
                            .zip(y.iter())
                            .any(|(p, q)| p.to_bits() != q.to_bits())
                    })
                    .count()
            };
            let (gi_diff, view_diff) = (same(&runs[0].0, &run.0), same(&runs[0].1, &run.1));
            println!(
                "{variant} run {i}: {gi_diff} GI pixels and {view_diff} cache-view pixels differ"
            );
            assert_eq!(
                gi_diff, 0,
                "{variant}: run {i}'s GI frame differs in {gi_diff} pixels"
            );
            assert_eq!(
                view_diff, 0,
                "{variant}: run {i}'s cache view differs in {view_diff} pixels"
            );
        }
    }
}

/// UpdateLightGrid's build on the GPU (one workgroup per cell, its lanes sharing the pass over
/// the light clusters through workgroup memory) draws the CPU's entries: the same lights, each
/// with the probability the CPU computes. Twice: 256 lights, each its own cluster (every lane
/// streams four), and 1000 emissive triangles in clusters of 4.
#[test]
fn the_light_grid_build_matches_the_cpu() {
    let rooms = [
        (load_scene("many-lights.gltf"), 256),
        (
            gi_host::scene::procedural::emitter_room(0, 1000).unwrap(),
            1000,
        ),
    ];
    for (scene, lights) in rooms {
        let gpu = Gpu::new(KernelVariant::Software, &scene);
        let mut gi = gpu.renderer(settings());
        let camera = scene_camera(&scene, SIDE, SIDE);
        gpu.run(&mut gi, 1, |_| camera);
        let res = gi.cache_resources();
        let params: Vec<LightGridParams> = res.light_grid.read_back(&gpu.ctx).unwrap();
        let entries: Vec<LightGridEntry> = res.light_grid_entries.read_back(&gpu.ctx).unwrap();
        let params = params[0];
        assert_eq!(params.light_count, lights, "{params:?}");
        assert!(params.cell_count() > 1, "{params:?}");
        let clusters = &gpu.lights.clusters;
        assert_eq!(clusters.len() == lights as usize, lights <= 256);
        let (_, pass, _) = gi.last_frame().unwrap();
        let seed = pcg_chain([pass.view.seed, pass.view.frame_index, PASS_LIGHT_GRID]);
        let (mut same, mut total) = (0, 0);
        for cell in 0..params.cell_count() {
            let cpu = build_light_grid_cell(&params, &gpu.lights.lights, clusters, cell, seed);
            let gpu_cell =
                &entries[(cell * LIGHT_GRID_RESERVOIRS_PER_CELL) as usize..][..cpu.len()];
            for (c, g) in cpu.iter().zip(gpu_cell) {
                total += 1;
                if c.light == g.light {
                    same += 1;
                    assert!(
                        (c.pmf - g.pmf).abs() <= 1e-5 * c.pmf,
                        "{lights} lights, cell {cell}: {c:?} {g:?}"
                    );
                }
            }
        }
        // Rounding may flip a streaming pick in the last bit of a comparison, rarely.
        assert!(
            same * 100 >= total * 99,
            "{lights} lights: {same} of {total} entries agree"
        );
        drop(gi);
        gpu.finish();
    }
}

/// ProbeAgeView (a pass of its own, `gi render --debug-views`) colours each pixel as the CPU's
/// `ProbeRecord::age_colour` colours its tile's probe, with `fast`'s spread of ages.
#[test]
fn the_probe_age_view_matches_the_cpu() {
    let scene = load_scene("cornell-box.gltf");
    let gpu = Gpu::new(KernelVariant::Software, &scene);
    let mut gi = gpu.renderer(Preset::Fast.settings(SIDE, SIDE));
    gi.keep_interpolated_irradiance(&gpu.ctx).unwrap();
    gpu.run(&mut gi, 12, |_| scene_camera(&scene, SIDE, SIDE));
    let views = gi_debug_views(&gpu.ctx, &gi).unwrap();
    let view = views.iter().find(|v| v.name == "probe_age").unwrap();
    let probes = gi.probes();
    let records: Vec<ProbeRecord> = probes.records.current().read_back(&gpu.ctx).unwrap();
    let grid = probes.layout.probe_grid;
    let mut ages = std::collections::BTreeSet::new();
    for y in 0..SIDE {
        for x in 0..SIDE {
            let record = records[((y / PROBE_SIZE) * grid[0] + x / PROBE_SIZE) as usize];
            ages.insert(record.age);
            let want = record.age_colour().to_array();
            assert_eq!(
                view.image.pixel(x, y),
                want,
                "pixel ({x}, {y}), age {}",
                record.age
            );
        }
    }
    // `fast` traces a sixteenth of the probes a frame: young and old probes both show.
    assert!(ages.len() > 2, "ages {ages:?}");
    drop((gi, views));
    gpu.finish();
}
