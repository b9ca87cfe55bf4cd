//! Moving objects (issue 12): the G-buffer's per-object motion vectors and the GI frame's
//! per-object reprojection, on `scenes/moving-box.gltf` (a cube sliding across a Cornell room while
//! it turns), in both tracing variants, with the validation layer silent.
//!
//! * [`motion_vectors_follow_a_moving_box`]: the cube's motion vectors match the analytic
//!   displacement of its points between two poses within 0.01 pixel, the CPU reference agrees,
//!   and every other pixel's motion is exactly zero (static camera, static instances).
//! * [`a_moving_box_leaves_no_trail`]: the trail metric. The cube moves for [`TRAIL_FRAMES`]
//!   frames at 30 frames per second; the last frame, pooled over [`TRAIL_SEEDS`] random streams
//!   (`TRAIL_SEEDS=N` in the environment pools N, to measure the spread), is compared with a
//!   converged static render of the last pose in the trail (pixels the cube covered in the
//!   frames before but not in the last one) and on the cube, with per-object reprojection and
//!   with camera-only reprojection: neither leaves the dark trail of a shadow-holding hysteresis
//!   (bias above −0.28).

use gi_host::gbuffer::{GBufferData, GBufferImages, GBufferPass, render_on_cpu, scene_camera};
use gi_host::gi::renderer::GiRenderer;
use gi_host::gi::{GiSettings, ViewOptions};
use gi_host::image_io::HdrImage;
use gi_host::scene::Scene;
use gi_host::scene::bvh::Bvh;
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::LightSet;
use gi_host::scene::upload::{GpuScene, previous_transforms};
use gi_host::vulkan::Context;
use gi_shared::camera::{CameraParams, primary_ray};
use gi_shared::gbuffer::GBufferTexel;
use gi_tests::{context, finish_without_validation_messages, scene_path, variants};
use glam::{DVec3, DVec4, Mat4, UVec2, Vec2};

const WIDTH: u32 = 128;
const HEIGHT: u32 = 96;
/// Seconds per frame.
const STEP: f32 = 1.0 / 30.0;
/// Frames the cube moves in the trail test.
const TRAIL_FRAMES: u32 = 24;
/// Random streams the trail test pools. One frame's noise is correlated over a probe tile and a
/// cache cell: at 64 × 48, where the trail covered one or two tiles, a single stream read the
/// trail's bias anywhere from −0.50 to +0.38 (streams 0–7); at 128 × 96, −0.17 to +0.27.
const TRAIL_SEEDS: u32 = 3;
/// Static frames of the trail test's reference.
const REFERENCE_FRAMES: u32 = 48;
/// The reference is the mean of its last this many frames.
const REFERENCE_AVERAGED: u32 = 24;
/// When the trail test's animation starts: the cube is then well inside the room.
const TRAIL_START: f32 = 0.2;
/// The old trail: pixels the cube left at least this many frames before the last.
const OLD_TRAIL_FRAMES: u32 = 8;

fn load() -> (Scene, u32) {
    let (scene, warnings) = Scene::load(scene_path("moving-box.gltf")).unwrap();
    assert!(warnings.is_empty(), "{warnings:#?}");
    let cube = scene
        .instances
        .iter()
        .position(|i| i.name == "cube")
        .expect("moving-box has a cube") as u32;
    (scene, cube)
}

/// Where `p` lands on `camera`'s screen, in pixels, and its linear depth, in f64.
fn project_f64(camera: &CameraParams, p: DVec3) -> (f64, f64, f64) {
    let d = p - camera.position().as_dvec3();
    let depth = d.dot(camera.forward().as_dvec3());
    let tan = f64::from(camera.tan_half_fov_y);
    let ndc_x = d.dot(camera.right().as_dvec3()) / (depth * tan * f64::from(camera.aspect));
    let ndc_y = -d.dot(camera.up().as_dvec3()) / (depth * tan);
    (
        (ndc_x + 1.0) * 0.5 * f64::from(camera.image_size[0]),
        (ndc_y + 1.0) * 0.5 * f64::from(camera.image_size[1]),
        depth,
    )
}

/// Checks `data`'s motion against the analytic motion of `cube` from `previous` to `current`
/// (object-to-world transforms) under the static `camera`; returns the cube's pixel count and
/// its largest motion.
fn check_motion(
    name: &str,
    data: &GBufferData,
    camera: &CameraParams,
    cube: u32,
    current: Mat4,
    previous: Mat4,
) -> (u32, f64) {
    let to_object = current.as_dmat4().inverse();
    let previous = previous.as_dmat4();
    let (mut on_cube, mut largest) = (0, 0.0f64);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let t = data.texel(x, y);
            if !t.is_surface() {
                assert_eq!(t.motion, glam::Vec4::ZERO, "{name}: sky ({x}, {y})");
                continue;
            }
            if t.ids.x != cube {
                // A static instance under a static camera: exactly zero.
                assert_eq!(
                    (t.motion.x, t.motion.y, t.motion.w),
                    (0.0, 0.0, 1.0),
                    "{name}: static pixel ({x}, {y})"
                );
                continue;
            }
            // The hit point from the pixel's ray and depth (the ray's forward component is 1),
            // carried back to where the cube held it.
            let ray = primary_ray(camera, UVec2::new(x, y), Vec2::ZERO);
            let p = DVec3::from_array(ray.origin.map(f64::from))
                + DVec3::from_array(ray.direction.map(f64::from)) * f64::from(t.depth);
            let object = to_object * DVec4::from((p, 1.0));
            let before = (previous * object).truncate();
            let (px, py, previous_depth) = project_f64(camera, before);
            let expected = (f64::from(x) + 0.5 - px, f64::from(y) + 0.5 - py);
            let error = (f64::from(t.motion.x) - expected.0)
                .abs()
                .max((f64::from(t.motion.y) - expected.1).abs());
            assert!(
                error < 0.01,
                "{name}: cube pixel ({x}, {y}): motion {:?}, expected {expected:?}",
                t.motion
            );
            assert!(
                (f64::from(t.motion.z) - previous_depth).abs() <= 1e-4 * previous_depth,
                "{name}: previous depth {} vs {previous_depth}",
                t.motion.z
            );
            on_cube += 1;
            largest = largest.max(expected.0.abs().max(expected.1.abs()));
        }
    }
    (on_cube, largest)
}

#[test]
fn motion_vectors_follow_a_moving_box() {
    let (mut scene, cube) = load();
    let (t0, t1) = (0.5, 0.5 + 2.0 * STEP);
    scene.set_time(t0);
    let before = scene.pose_at(t0);
    scene.set_time(t1);
    let now = scene.pose_at(t1);
    let camera = scene_camera(&scene, WIDTH, HEIGHT);
    let previous = previous_transforms(&now, &before);
    assert_eq!(previous.len(), scene.instances.len());
    let shading = ShadingData::new(&scene).unwrap();
    let bvh = Bvh::new(&scene).unwrap();
    let cpu = render_on_cpu(&shading, &bvh, &camera, &previous);
    let (c, m) = (now[cube as usize], before[cube as usize]);
    let (pixels, largest) = check_motion("cpu", &cpu, &camera, cube, c, m);
    println!("cpu: {pixels} cube pixels, largest motion {largest:.3} px");
    assert!(pixels > 40, "the cube covers {pixels} pixels");
    assert!(largest > 0.5, "the cube moved {largest} px");
    // Without previous transforms the cube's motion is the camera's: zero.
    let still = render_on_cpu(&shading, &bvh, &camera, &[]);
    assert!(
        still
            .texels
            .iter()
            .all(|t| t.motion.x == 0.0 && t.motion.y == 0.0)
    );
    for variant in variants() {
        let ctx = context(variant);
        let lights = LightSet::new(&scene, None, false);
        let mut gpu = GpuScene::upload(&ctx, &scene, None, &shading, &lights).unwrap();
        gpu.set_pose(&ctx, &scene, &lights, &before).unwrap();
        let mut pass = GBufferPass::new(&ctx).unwrap();
        let images = GBufferImages::new(&ctx, WIDTH, HEIGHT).unwrap();
        pass.run(&ctx, &gpu, &camera, &images).unwrap();
        let data = images.read_back(&ctx).unwrap();
        let name = format!("{variant}");
        let (gpu_pixels, _) = check_motion(&name, &data, &camera, cube, c, m);
        // Ties between the tracers move a pixel or two between instances at most.
        assert!(
            gpu_pixels.abs_diff(pixels) <= 2,
            "{name}: {gpu_pixels} vs {pixels}"
        );
        // A pose that is the previous one: no object motion.
        gpu.set_pose(&ctx, &scene, &lights, &now).unwrap();
        pass.run(&ctx, &gpu, &camera, &images).unwrap();
        let data = images.read_back(&ctx).unwrap();
        assert!(
            data.texels
                .iter()
                .all(|t| t.motion.x == 0.0 && t.motion.y == 0.0)
        );
        // A wrong transform count names what is wrong.
        let e = gpu.set_pose(&ctx, &scene, &lights, &now[1..]).unwrap_err();
        assert!(e.to_string().contains("previous transforms"), "{e}");
        drop((pass, images, gpu));
        finish_without_validation_messages(ctx);
    }
}

/// Luminance-like mean of a pixel.
fn value(c: [f32; 3]) -> f64 {
    f64::from(c[0] + c[1] + c[2]) / 3.0
}

/// The trail test's run: `frames` frames of the animation from [`TRAIL_START`]; returns the last
/// image and, per pixel, whether the cube covered it in any frame before the last.
fn animate(
    ctx: &Context,
    scene: &mut Scene,
    settings: GiSettings,
    seed: u32,
) -> (HdrImage, Vec<bool>, Vec<bool>, GBufferData) {
    let frames = TRAIL_FRAMES;
    scene.set_time(TRAIL_START);
    let lights = LightSet::new(scene, None, true);
    let shading = ShadingData::new(scene).unwrap();
    let mut gpu = GpuScene::upload(ctx, scene, None, &shading, &lights).unwrap();
    let camera = scene_camera(scene, WIDTH, HEIGHT);
    let mut gi = GiRenderer::new(
        ctx,
        &lights,
        WIDTH,
        HEIGHT,
        settings,
        ViewOptions {
            seed,
            ..ViewOptions::default()
        },
    )
    .unwrap();
    let cube = scene
        .instances
        .iter()
        .position(|i| i.name == "cube")
        .unwrap() as u32;
    let mut covered = vec![false; (WIDTH * HEIGHT) as usize];
    let mut old = vec![false; (WIDTH * HEIGHT) as usize];
    let mut last = None;
    for f in 0..frames {
        let t = TRAIL_START + f as f32 * STEP;
        if f > 0 {
            let before = scene.pose_at(t - STEP);
            scene.set_time(t);
            gpu.set_pose(ctx, scene, &lights, &before).unwrap();
        }
        gi.render_frame(ctx, &gpu, &camera).unwrap();
        let g = gi.gbuffer().read_back(ctx).unwrap();
        if f + 1 < frames {
            for (c, t) in covered.iter_mut().zip(&g.texels) {
                *c |= t.ids.x == cube;
            }
        }
        if f + OLD_TRAIL_FRAMES < frames {
            for (c, t) in old.iter_mut().zip(&g.texels) {
                *c |= t.ids.x == cube;
            }
        } else {
            for (c, t) in old.iter_mut().zip(&g.texels) {
                *c &= t.ids.x != cube;
            }
        }
        last = Some(g);
    }
    let image = gi.image(ctx).unwrap();
    (image, covered, old, last.unwrap())
}

/// The trail test's reference: `scene` held at the trail's last pose, the mean of frames
/// [`REFERENCE_FRAMES`] − [`REFERENCE_AVERAGED`] + 1 ..= [`REFERENCE_FRAMES`].
fn still_reference(ctx: &Context, scene: &mut Scene, settings: GiSettings) -> Vec<f64> {
    scene.set_time(TRAIL_START + (TRAIL_FRAMES - 1) as f32 * STEP);
    let lights = LightSet::new(scene, None, true);
    let shading = ShadingData::new(scene).unwrap();
    let gpu = GpuScene::upload(ctx, scene, None, &shading, &lights).unwrap();
    let camera = scene_camera(scene, WIDTH, HEIGHT);
    let mut gi = GiRenderer::new(
        ctx,
        &lights,
        WIDTH,
        HEIGHT,
        settings,
        ViewOptions::default(),
    )
    .unwrap();
    let mut mean = vec![0.0; (WIDTH * HEIGHT) as usize];
    for f in 0..REFERENCE_FRAMES {
        gi.render_frame(ctx, &gpu, &camera).unwrap();
        if f + REFERENCE_AVERAGED >= REFERENCE_FRAMES {
            let image = gi.image(ctx).unwrap();
            for (m, p) in mean.iter_mut().zip(image.pixels()) {
                *m += value(*p) / f64::from(REFERENCE_AVERAGED);
            }
        }
    }
    mean
}

/// Sums over the pixels of a mask, pooled over the runs: |test − reference|, test − reference
/// and the reference.
#[derive(Clone, Copy, Default)]
struct ErrorSums {
    absolute: f64,
    signed: f64,
    reference: f64,
}

impl ErrorSums {
    /// Adds `image`'s pixels where `mask` holds.
    fn add(&mut self, image: &HdrImage, reference: &[f64], mask: &[bool]) {
        for ((a, b), m) in image.pixels().iter().zip(reference).zip(mask) {
            if *m {
                self.absolute += (value(*a) - b).abs();
                self.signed += value(*a) - b;
                self.reference += b;
            }
        }
    }

    /// The mean absolute difference over the reference's mean, and the mean signed difference
    /// over the same (the bias).
    fn relative(&self) -> (f64, f64) {
        assert!(self.reference > 0.0, "empty mask");
        (self.absolute / self.reference, self.signed / self.reference)
    }
}

#[test]
fn a_moving_box_leaves_no_trail() {
    let (mut scene, cube) = load();
    let base = GiSettings::for_resolution(WIDTH, HEIGHT);
    let camera_only = GiSettings {
        object_motion: false,
        ..base
    };
    let seeds: u32 = std::env::var("TRAIL_SEEDS").map_or(TRAIL_SEEDS, |s| s.parse().unwrap());
    for variant in variants() {
        let ctx = context(variant);
        let reference = still_reference(&ctx, &mut scene, base);
        // Per mode (per-object, camera-only), per mask (trail, old trail, cube, elsewhere).
        let mut sums = [[ErrorSums::default(); 4]; 2];
        let mut counts = [0; 4];
        for seed in 0..seeds {
            for (mode, settings) in [base, camera_only].into_iter().enumerate() {
                let (image, covered, old, last) = animate(&ctx, &mut scene, settings, seed);
                let on_cube: Vec<bool> = last.texels.iter().map(|t| t.ids.x == cube).collect();
                let trail: Vec<bool> = covered
                    .iter()
                    .zip(&on_cube)
                    .map(|(c, now)| *c && !now)
                    .collect();
                // Far from the cube's path: the noise floor of a frame against the reference.
                let elsewhere: Vec<bool> = covered
                    .iter()
                    .zip(&last.texels)
                    .map(|(c, t): (&bool, &GBufferTexel)| !c && t.ids.x != cube && t.is_surface())
                    .collect();
                let masks = [&trail, &old, &on_cube, &elsewhere];
                for (m, mask) in masks.iter().enumerate() {
                    sums[mode][m].add(&image, &reference, mask);
                    counts[m] = mask.iter().filter(|x| **x).count();
                }
                let f = masks.map(|mask| {
                    let mut one = ErrorSums::default();
                    one.add(&image, &reference, mask);
                    one.relative().1
                });
                println!(
                    "{variant}, random stream {seed}, {}: bias trail {:+.4}, old trail {:+.4}, \
                     cube {:+.4}, elsewhere {:+.4}",
                    ["per-object", "camera-only"][mode],
                    f[0],
                    f[1],
                    f[2],
                    f[3]
                );
            }
        }
        println!(
            "{variant}: {} trail ({} old), {} cube, {} other pixels; over {seeds} random streams:",
            counts[0], counts[1], counts[2], counts[3]
        );
        let figures = sums.map(|mode| mode.map(|s| s.relative()));
        for (name, f) in ["per-object", "camera-only"].iter().zip(&figures) {
            println!(
                "  {name}: relative error (bias) trail {:.4} ({:+.4}), old trail {:.4} ({:+.4}), \
                 cube {:.4} ({:+.4}), elsewhere {:.4} ({:+.4})",
                f[0].0, f[0].1, f[1].0, f[1].1, f[2].0, f[2].1, f[3].0, f[3].1
            );
        }
        assert!(counts[0] > 40, "trail of {} pixels", counts[0]);
        assert!(counts[1] > 20, "old trail of {} pixels", counts[1]);
        let [trail_with, old_with, cube_with, elsewhere_with] = figures[0];
        let [trail_without, old_without, cube_without, _] = figures[1];
        // The probes' hysteresis adapts to change (issue 22): it does not hold the cube's shadow
        // where the cube left, in either mode. Measured (streams 0–7, one at a time, software):
        // per-object trail bias −0.17 to +0.27 (mean −0.04), camera-only −0.22 to +0.32, cube
        // −0.31 to +0.42. With the reference's shadow-preserving hysteresis camera-only left
        // −0.29 to −0.38 (one stream at 64 × 48), and per-object mode had to suspend it.
        for (name, bias) in [
            ("trail", trail_with.1),
            ("old trail", old_with.1),
            ("camera-only trail", trail_without.1),
            ("camera-only old trail", old_without.1),
        ] {
            assert!(bias > -0.28, "{variant}: {name} bias {bias}");
        }
        assert!(
            cube_with.1.abs() < 0.25 && cube_without.1.abs() < 0.25,
            "{variant}: cube {cube_with:?}, camera-only {cube_without:?}"
        );
        assert!(
            elsewhere_with.0 < 0.15,
            "{variant}: elsewhere {elsewhere_with:?}"
        );
        finish_without_validation_messages(ctx);
    }
}
