//! Extreme scenes (issue 13), each against the same scene at normal scale: the GI image must be
//! finite, and its error against the path tracer (relMSE) must stay within [`FACTOR`] × the
//! normal case's + [`SLACK`] (a looser, stated factor where the extreme case is meant to cost
//! quality; for the offset room, whose rounding costs a fixed error, a bound against the room at
//! the origin, [`OFFSET_ROUNDING_ERROR`]). Images are 64 × 64 (the committed references' size) with the validation layer on;
//! every case prints its README row ("Extreme scenes").
//!
//! * [`the_indirect_room_at_1e_3_and_1e3_scale_and_offset_by_1e5`]: the room moved by
//!   [`Scene::scale_and_offset`] renders as the room does, against the committed reference;
//!   and the same room with a cache far smaller than it needs.
//! * [`the_cornell_box_at_1e6_emission_black_and_seen_from_inside_a_box`]: emission of 10⁶
//!   (far above the half-float range), no light at all, black materials, and a camera inside
//!   the tall box.
//! * [`ten_thousand_lights_light_the_room_as_256_do`] and
//!   [`a_sky_alone_lights_the_ground_as_the_path_tracer_does`]: references rendered here.

use gi_host::KernelVariant;
use gi_host::gbuffer::scene_camera;
use gi_host::gi::renderer::{GiFrameStats, GiRenderer};
use gi_host::gi::{GiSettings, ViewOptions};
use gi_host::image_io::HdrImage;
use gi_host::metrics::{CompareSettings, compare};
use gi_host::path_tracer::{PathTracerPass, PathTracerSettings};
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::{Environment, LightSet};
use gi_host::scene::upload::GpuScene;
use gi_host::scene::{Camera, Light, LightKind, Material, Scene, procedural};
use gi_host::vulkan::Context;
use gi_shared::camera::CameraParams;
use gi_tests::{context, finish_without_validation_messages, load_scene, reference_image};
use glam::{Mat4, Quat, Vec3, Vec4};

/// Side of the images.
const SIDE: u32 = 64;
/// GI frames before the image is compared (the cache's cells reach their 16 samples, the
/// denoiser's history most of its length).
const FRAMES: u32 = 32;
/// Paths per pixel of the references rendered here.
const REFERENCE_SPP: u32 = 256;
/// An extreme case's relMSE may be this many times the normal case's (plus [`SLACK`]).
const FACTOR: f64 = 1.5;
/// The room offset by 1e5 against itself at the origin (relMSE): world positions rounded to
/// 7.8 mm cost 3.3e-3 (README, "Extreme scenes"), whatever the normal case's own error.
const OFFSET_ROUNDING_ERROR: f64 = 5e-3;
/// Absolute slack of the bound: keeps a normal case with almost no error from failing its
/// extreme one on noise alone.
const SLACK: f64 = 2e-3;

/// A scene uploaded, lit by its emitters and `sky`.
struct Lit {
    lights: LightSet,
    scene: GpuScene,
}

impl Lit {
    fn new(ctx: &Context, scene: &Scene, sky: Option<Vec3>) -> Self {
        let environment = sky.map(|s| Environment::constant(s).unwrap());
        let lights = LightSet::new(scene, environment, true);
        let shading = ShadingData::new(scene).unwrap();
        let scene = GpuScene::upload(ctx, scene, None, &shading, &lights).unwrap();
        Self { lights, scene }
    }

    /// [`FRAMES`] static frames from `camera`: the last image and its stats.
    fn gi(
        &self,
        ctx: &Context,
        camera: &CameraParams,
        settings: GiSettings,
    ) -> (HdrImage, GiFrameStats) {
        let mut gi = GiRenderer::new(
            ctx,
            &self.lights,
            SIDE,
            SIDE,
            settings,
            ViewOptions::default(),
        )
        .unwrap();
        let mut stats = GiFrameStats::default();
        for _ in 0..FRAMES {
            stats = gi.render_frame(ctx, &self.scene, camera).unwrap();
        }
        (gi.image(ctx).unwrap(), stats)
    }

    /// The path tracer's image from `camera`, [`REFERENCE_SPP`] paths per pixel.
    fn path_traced(&self, ctx: &Context, camera: &CameraParams) -> HdrImage {
        let mut pass = PathTracerPass::new(ctx).unwrap();
        let settings = PathTracerSettings {
            samples: REFERENCE_SPP,
            ..PathTracerSettings::default()
        };
        pass.render(ctx, &self.scene, camera, &settings, |_, _| {})
            .unwrap()
            .image
    }
}

/// The GI image of `scene` (lit by its emitters and `sky`) from `camera`, and the path tracer's
/// when `reference` is set.
fn render(
    ctx: &Context,
    scene: &Scene,
    sky: Option<Vec3>,
    camera: &CameraParams,
    settings: GiSettings,
    reference: bool,
) -> (HdrImage, GiFrameStats, Option<HdrImage>) {
    let lit = Lit::new(ctx, scene, sky);
    let (image, stats) = lit.gi(ctx, camera, settings);
    let path_traced = reference.then(|| lit.path_traced(ctx, camera));
    (image, stats, path_traced)
}

fn settings() -> GiSettings {
    GiSettings::for_resolution(SIDE, SIDE)
}

/// Pixels with a NaN or infinite channel.
fn non_finite(image: &HdrImage) -> usize {
    image
        .pixels()
        .iter()
        .filter(|p| !p.iter().all(|c| c.is_finite()))
        .count()
}

fn relmse(reference: &HdrImage, test: &HdrImage) -> f64 {
    compare(reference, test, &CompareSettings::default())
        .unwrap()
        .metrics
        .relative_mse
}

/// `image` × `k`.
fn scaled(image: &HdrImage, k: f32) -> HdrImage {
    let mut out = image.clone();
    out.pixels_mut()
        .iter_mut()
        .for_each(|p| p.iter_mut().for_each(|c| *c *= k));
    out
}

/// Checks an extreme case against its normal one and prints its README row: the image is
/// finite and its relMSE at most `factor` × the normal case's + [`SLACK`].
fn check(case: &str, image: &HdrImage, error: f64, normal: f64, factor: f64) {
    let bad = non_finite(image);
    println!(
        "| {case} | {error:.4} | {:.2} | {} |",
        error / normal,
        if bad == 0 { "yes" } else { "no" }
    );
    assert_eq!(bad, 0, "{case}: {bad} pixels not finite");
    assert!(
        error <= factor * normal + SLACK,
        "{case}: relMSE {error} against {normal} at normal scale (at most × {factor} + {SLACK})"
    );
}

/// Renders the normal case, prints its row and returns its relMSE.
fn normal_case(case: &str, image: &HdrImage, reference: &HdrImage) -> f64 {
    let error = relmse(reference, image);
    assert_eq!(non_finite(image), 0, "{case}");
    println!("| {case} (normal) | {error:.4} | 1.00 | yes |");
    error
}

#[test]
fn the_indirect_room_at_1e_3_and_1e3_scale_and_offset_by_1e5() {
    let reference = reference_image("indirect-room", SIDE);
    let room = load_scene("indirect-room.gltf");
    let ctx = context(KernelVariant::Software);
    let camera = scene_camera(&room, SIDE, SIDE);
    let (normal_image, ..) = render(&ctx, &room, None, &camera, settings(), false);
    let normal = normal_case("indirect room", &normal_image, &reference);
    for (case, scale, offset) in [
        ("indirect room × 1e-3", 1e-3, Vec3::ZERO),
        ("indirect room × 1e3", 1e3, Vec3::ZERO),
        ("indirect room + 1e5", 1.0, Vec3::splat(1e5)),
    ] {
        let mut moved = room.clone();
        moved.scale_and_offset(scale, offset).unwrap();
        // The minimum cell size is a length in scene units (see `GiSettings::min_cell_size`).
        let settings = GiSettings {
            min_cell_size: settings().min_cell_size * scale,
            ..settings()
        };
        let camera = scene_camera(&moved, SIDE, SIDE);
        let (image, ..) = render(&ctx, &moved, None, &camera, settings, false);
        let to_normal = relmse(&normal_image, &image);
        println!("{case}: relMSE against the GI image at normal scale {to_normal:.2e}");
        if offset == Vec3::ZERO {
            // The path tracer sees the same image at every scale, so the room's reference stands.
            check(case, &image, relmse(&reference, &image), normal, FACTOR);
        } else {
            // Float rounding at 1e5 costs a fixed amount of error, not a share of the normal
            // case's: it is bounded against the GI image at normal scale.
            let error = relmse(&reference, &image);
            println!("| {case} | {error:.4} | {:.2} | yes |", error / normal);
            assert_eq!(non_finite(&image), 0, "{case}");
            assert!(
                to_normal <= OFFSET_ROUNDING_ERROR,
                "{case}: relMSE {to_normal} against the GI image at normal scale \
                 (at most {OFFSET_ROUNDING_ERROR})"
            );
        }
    }
    // A cache of 2^5 tiles where the room needs hundreds: most inserts fail and those rays get no
    // cache light, so quality may drop (× 3), but nothing may break.
    let tiny = GiSettings {
        buckets_log2: 1,
        tiles_per_bucket_log2: 4,
        ..settings()
    };
    let (image, stats, _) = render(&ctx, &room, None, &camera, tiny, false);
    println!(
        "cache of {} tiles: {} live, {} failed inserts in the last frame",
        tiny.tile_count(),
        stats.cache.live_tiles,
        stats.cache.failed_inserts
    );
    assert!(stats.cache.failed_inserts > 0, "{stats:?}");
    assert!(stats.cache.live_tiles <= tiny.tile_count(), "{stats:?}");
    check(
        "indirect room, cache of 32 tiles",
        &image,
        relmse(&reference, &image),
        normal,
        3.0,
    );
    finish_without_validation_messages(ctx);
}

/// The Cornell box with every emission multiplied by `k` and base colours by `albedo`.
fn cornell(k: f32, albedo: f32) -> Scene {
    let mut scene = load_scene("cornell-box.gltf");
    for m in &mut scene.materials {
        m.emissive *= k;
        m.base_color = (m.base_color.truncate() * albedo).extend(m.base_color.w);
    }
    scene.update_derived();
    scene
}

#[test]
fn the_cornell_box_at_1e6_emission_black_and_seen_from_inside_a_box() {
    let reference = reference_image("cornell-box", SIDE);
    let box_scene = cornell(1.0, 1.0);
    let camera = scene_camera(&box_scene, SIDE, SIDE);
    let ctx = context(KernelVariant::Software);
    let (image, ..) = render(&ctx, &box_scene, None, &camera, settings(), false);
    let normal = normal_case("Cornell box", &image, &reference);

    // Emission of 10⁶ (the lamp's brightest channel): 15 times the largest half float.
    let k = 1e6
        / box_scene
            .materials
            .iter()
            .map(|m| m.emissive.max_element())
            .fold(0.0, f32::max);
    let bright = cornell(k, 1.0);
    let (image, ..) = render(&ctx, &bright, None, &camera, settings(), false);
    // The path tracer's image is linear in the emission: the reference × k.
    check(
        "Cornell box, emission 1e6",
        &image,
        relmse(&reference, &scaled(&image, 1.0 / k)),
        normal,
        FACTOR,
    );

    // No light at all: black, exactly.
    let dark = cornell(0.0, 1.0);
    let (image, ..) = render(&ctx, &dark, None, &camera, settings(), false);
    let brightest = image
        .pixels()
        .iter()
        .flatten()
        .fold(0.0f32, |m, &c| m.max(c));
    assert_eq!(brightest, 0.0, "no light, yet a pixel of {brightest}");
    check("Cornell box, no light", &image, 0.0, normal, FACTOR);

    // Black materials: the lamp alone, no bounce.
    let black = cornell(1.0, 0.0);
    let (image, _, path_traced) = render(&ctx, &black, None, &camera, settings(), true);
    check(
        "Cornell box, black materials",
        &image,
        relmse(&path_traced.unwrap(), &image),
        normal,
        FACTOR,
    );

    // Inside the tall box (centre (-0.33, 0.6, -0.35), 0.55 × 1.2 × 0.55 m), looking at its side.
    let inside = CameraParams::new(
        Vec3::new(-0.33, 0.6, -0.35),
        Vec3::Z,
        Vec3::Y,
        camera.tan_half_fov_y.atan() * 2.0,
        SIDE,
        SIDE,
    );
    let (image, _, path_traced) = render(&ctx, &box_scene, None, &inside, settings(), true);
    check(
        "Cornell box, camera inside the tall box",
        &image,
        relmse(&path_traced.unwrap(), &image),
        normal,
        FACTOR,
    );
    finish_without_validation_messages(ctx);
}

#[test]
fn ten_thousand_lights_light_the_room_as_256_do() {
    let ctx = context(KernelVariant::Software);
    let mut errors = Vec::new();
    // Normal: 256 lights, as `many-lights` has (beyond 16 the primary hit resamples them, so
    // both cases take the same path).
    for lights in [256, 10_000] {
        let room = procedural::scaling_room(0, lights).unwrap();
        let camera = scene_camera(&room, SIDE, SIDE);
        let (image, _, path_traced) = render(&ctx, &room, None, &camera, settings(), true);
        let error = relmse(&path_traced.unwrap(), &image);
        errors.push((image, error));
    }
    let normal = errors[0].1;
    println!("| room, 256 point lights (normal) | {normal:.4} | 1.00 | yes |");
    check(
        "room, 10 000 point lights",
        &errors[1].0,
        errors[1].1,
        normal,
        FACTOR,
    );
    finish_without_validation_messages(ctx);
}

/// A 20 × 20 m grey ground with a 1 m grey cube on it, seen from 4 m away.
fn ground_and_cube() -> Scene {
    let ground = Mat4::from_scale_rotation_translation(
        Vec3::new(10.0, 0.05, 10.0),
        Quat::IDENTITY,
        Vec3::new(0.0, -0.05, 0.0),
    );
    let cube = Mat4::from_scale_rotation_translation(
        Vec3::splat(0.5),
        Quat::from_rotation_y(0.5),
        Vec3::new(0.0, 0.5, 0.0),
    );
    let mut scene = procedural::scene(vec![procedural::cube()], &[(0, ground), (0, cube)]).unwrap();
    scene.materials = vec![Material {
        name: "grey".into(),
        base_color: Vec4::new(0.6, 0.6, 0.6, 1.0),
        metallic: 0.0,
        ..Material::default()
    }];
    let eye = Vec3::new(2.5, 1.6, 3.0);
    let forward = (Vec3::new(0.0, 0.4, 0.0) - eye).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    scene.cameras = vec![Camera {
        name: "outside".into(),
        yfov: 50f32.to_radians(),
        aspect_ratio: None,
        znear: 0.01,
        zfar: None,
        transform: Mat4::from_cols(
            right.extend(0.0),
            right.cross(forward).extend(0.0),
            (-forward).extend(0.0),
            eye.extend(1.0),
        ),
    }];
    scene.update_derived();
    scene
}

#[test]
fn a_sky_alone_lights_the_ground_as_the_path_tracer_does() {
    let sky = Vec3::new(0.5, 0.7, 1.0);
    // Normal: a sun as well, as outdoor scenes have.
    let mut sunny = ground_and_cube();
    sunny.lights = vec![Light {
        name: "sun".into(),
        kind: LightKind::Directional,
        intensity: Vec3::new(3.0, 2.8, 2.4),
        position: Vec3::ZERO,
        direction: Vec3::new(-0.4, -1.0, -0.3).normalize(),
        range: None,
    }];
    let ctx = context(KernelVariant::Software);
    let mut errors = Vec::new();
    for scene in [sunny, ground_and_cube()] {
        let camera = scene_camera(&scene, SIDE, SIDE);
        let (image, _, path_traced) = render(&ctx, &scene, Some(sky), &camera, settings(), true);
        let error = relmse(&path_traced.unwrap(), &image);
        errors.push((image, error));
    }
    let normal = errors[0].1;
    println!("| ground and cube, sun and sky (normal) | {normal:.4} | 1.00 | yes |");
    check(
        "ground and cube, sky alone",
        &errors[1].0,
        errors[1].1,
        normal,
        FACTOR,
    );
    finish_without_validation_messages(ctx);
}
