//! The G-buffer pass in both tracing variants, against the CPU running the same per-pixel
//! function, against analytic expectations (wall colours, the emissive ceiling, depths, motion of a
//! known camera move, checker texels), with the validation layer silent.
//!
//! Tolerances: depth 1e-4 relative; normals 1e-3 per component (the images are half floats);
//! albedo 1.5/255 (8-bit unorm); emission 1e-3 relative; motion exactly zero for a static camera
//! and within 0.01 pixel of the analytic displacement for a moving one. The CPU and the GPU may
//! pick different triangles where a pixel's ray hits a shared edge at the same distance (ties):
//! accepted when the depths agree, and at most 1% of the pixels. A ray through a shared edge can
//! also slip between the two triangles in one tracer and not in the other (Möller–Trumbore, which
//! the CPU and the software kernel run, is not watertight; lavapipe's ray queries are), and the
//! CPU's and the GPU's primary rays may differ in the last bit: such edge leaks must stay at or
//! below 0.2% of the pixels.
//!
//! The debug PNGs of the Cornell box go to `$TMPDIR/gi-gbuffer/cornell-box-<variant>/`; the test
//! prints the directory.

use gi_host::KernelVariant;
use gi_host::gbuffer::{
    GBufferData, GBufferImages, GBufferPass, render_on_cpu, scene_camera, write_debug_pngs,
};
use gi_host::scene::Scene;
use gi_host::scene::bvh::Bvh;
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::LightSet;
use gi_host::scene::upload::GpuScene;
use gi_shared::camera::{CameraParams, primary_ray, view_projection};
use gi_shared::color::srgb_to_linear;
use gi_shared::gbuffer::GBufferTexel;
use gi_tests::{context, finish_without_validation_messages, scene_path, variants};
use glam::{UVec2, Vec2, Vec3};

const WIDTH: u32 = 64;
const HEIGHT: u32 = 48;

struct Loaded {
    scene: Scene,
    bvh: Bvh,
    shading: ShadingData,
}

fn load(file: &str) -> Loaded {
    let (scene, _warnings) = Scene::load(scene_path(file)).unwrap();
    let bvh = Bvh::new(&scene).unwrap();
    let shading = ShadingData::new(&scene).unwrap();
    Loaded {
        scene,
        bvh,
        shading,
    }
}

/// Renders the G-buffer of each camera on the device, in one context of `variant`.
fn render(variant: KernelVariant, loaded: &Loaded, cameras: &[CameraParams]) -> Vec<GBufferData> {
    let ctx = context(variant);
    let lights = LightSet::new(&loaded.scene, None, false);
    let scene = GpuScene::upload(
        &ctx,
        &loaded.scene,
        Some(&loaded.bvh),
        &loaded.shading,
        &lights,
    )
    .unwrap();
    // Texture storage exists only for a scene with textures.
    let textured = !loaded.scene.textures.is_empty();
    assert_eq!(scene.shading.has_buffer("textures"), textured);
    assert_eq!(scene.shading.texture_bytes() > 0, textured);
    let mut pass = GBufferPass::new(&ctx).unwrap();
    let images = GBufferImages::new(&ctx, WIDTH, HEIGHT).unwrap();
    let mut out = vec![];
    for camera in cameras {
        let ms = pass.run(&ctx, &scene, camera, &images).unwrap();
        println!(
            "{} {variant}: G-buffer {WIDTH}x{HEIGHT} in {ms:.3?} ms GPU time",
            loaded.scene.source.display()
        );
        out.push(images.read_back(&ctx).unwrap());
    }
    drop(images);
    drop(pass);
    drop(scene);
    finish_without_validation_messages(ctx);
    out
}

fn relative_close(a: f32, b: f32, tolerance: f32) -> bool {
    (a - b).abs() <= tolerance * a.abs().max(b.abs())
}

#[derive(Default, Debug)]
struct Agreement {
    same: usize,
    ties: usize,
    leaks: usize,
    mismatches: Vec<String>,
}

/// Compares a device G-buffer with a reference (the CPU's, or the other variant's).
fn compare(name: &str, reference: &GBufferData, other: &GBufferData) -> Agreement {
    assert_eq!(
        (reference.width, reference.height),
        (other.width, other.height)
    );
    let mut a = Agreement::default();
    for (i, (r, o)) in reference.texels.iter().zip(&other.texels).enumerate() {
        let pixel = (i as u32 % reference.width, i as u32 / reference.width);
        let mut bad = |what: &str| {
            a.mismatches
                .push(format!("{name} pixel {pixel:?}: {what}: {r:?} vs {o:?}"))
        };
        if r.is_surface() != o.is_surface() {
            a.leaks += 1;
            continue;
        }
        if !r.is_surface() {
            if *o != GBufferTexel::SKY {
                bad("sky");
            } else {
                a.same += 1;
            }
            continue;
        }
        if !relative_close(r.depth, o.depth, 1e-4) {
            bad("depth");
            continue;
        }
        if (r.ids.x, r.ids.y) != (o.ids.x, o.ids.y) {
            a.ties += 1;
            continue;
        }
        let close4 = |x: glam::Vec4, y: glam::Vec4, tol: f32| (x - y).abs().max_element() <= tol;
        if !close4(r.geometric_normal, o.geometric_normal, 1e-3) {
            bad("geometric normal");
        } else if !close4(r.shading_normal, o.shading_normal, 1e-3) {
            bad("shading normal");
        } else if !close4(r.albedo, o.albedo, 1.5 / 255.0) {
            bad("albedo");
        } else if !close4(
            r.emissive,
            o.emissive,
            1e-3 * r.emissive.max_element().max(1.0),
        ) {
            bad("emissive");
        } else if (r.ids.z, r.ids.w) != (o.ids.z, o.ids.w) {
            bad("material or facing");
        } else if !close4(r.motion, o.motion, 1e-3 * r.motion.z.max(1.0)) {
            bad("motion");
        } else {
            a.same += 1;
        }
    }
    a
}

fn assert_agree(name: &str, reference: &GBufferData, other: &GBufferData) {
    let a = compare(name, reference, other);
    println!(
        "{name:<48} same {:>5}, ties {:>3}, edge leaks {}, mismatches {}",
        a.same,
        a.ties,
        a.leaks,
        a.mismatches.len()
    );
    assert!(
        a.mismatches.is_empty(),
        "{}",
        a.mismatches[..a.mismatches.len().min(5)].join("\n")
    );
    assert!(
        a.ties <= reference.texels.len() / 100,
        "{name}: {} ties",
        a.ties
    );
    assert!(
        a.leaks <= reference.texels.len() / 500,
        "{name}: {} edge leaks",
        a.leaks
    );
}

fn material(scene: &Scene, name: &str) -> u32 {
    scene
        .materials
        .iter()
        .position(|m| m.name == name)
        .unwrap_or_else(|| panic!("no material {name:?}")) as u32
}

fn variant_dir(variant: KernelVariant) -> &'static str {
    match variant {
        KernelVariant::RayQuery => "ray-query",
        KernelVariant::Software => "software",
    }
}

/// What the Cornell box must look like whichever tracer made the G-buffer.
fn check_cornell_box_content(name: &str, scene: &Scene, g: &GBufferData) {
    let red = material(scene, "red");
    let light = material(scene, "light");
    let white = material(scene, "white");
    let (mut reds, mut lights, mut back_wall) = (0, 0, 0);
    for t in g.texels.iter().filter(|t| t.is_surface()) {
        let close3 = |a: Vec3, b: Vec3, tol: f32| (a - b).abs().max_element() <= tol;
        if t.ids.z == red {
            reds += 1;
            assert!(
                close3(
                    t.albedo.truncate(),
                    Vec3::new(0.65, 0.05, 0.05),
                    1.5 / 255.0
                ),
                "{name}: red wall albedo {:?}",
                t.albedo
            );
            // The left wall at x = -1 faces +X, towards the camera's side.
            assert!(
                close3(t.geometric_normal.truncate(), Vec3::X, 1e-3),
                "{t:?}"
            );
            assert!(close3(t.shading_normal.truncate(), Vec3::X, 1e-3), "{t:?}");
            assert_eq!(t.emissive.truncate(), Vec3::ZERO);
        } else if t.ids.z == light {
            lights += 1;
            let expected = Vec3::new(1.0, 0.78, 0.47) * 17.0;
            assert!(
                close3(t.emissive.truncate(), expected, 1e-3 * 17.0),
                "{name}: ceiling light emission {:?}",
                t.emissive
            );
            assert!(
                close3(t.geometric_normal.truncate(), -Vec3::Y, 1e-3),
                "{t:?}"
            );
        } else {
            assert_eq!(t.emissive.truncate(), Vec3::ZERO, "{name}: {t:?}");
        }
        // The back wall (z = -1, facing +Z) is 4.9 in front of the camera at z = 3.9.
        if t.ids.z == white && close3(t.geometric_normal.truncate(), Vec3::Z, 1e-3) {
            back_wall += 1;
            assert!(
                relative_close(t.depth, 4.9, 1e-4),
                "{name}: back wall {t:?}"
            );
        }
    }
    assert!(reds > 50, "{name}: only {reds} red-wall pixels");
    assert!(lights > 5, "{name}: only {lights} ceiling-light pixels");
    assert!(back_wall > 200, "{name}: only {back_wall} back-wall pixels");
    // Left of the centre row, inside the room: the red wall.
    assert_eq!(g.texel(12, HEIGHT / 2).ids.z, red, "{name}");
    // The open front of the box shows sky at the image's left and right edges.
    assert!(!g.texel(0, HEIGHT / 2).is_surface(), "{name}");
    assert!(!g.texel(WIDTH - 1, HEIGHT / 2).is_surface(), "{name}");
}

#[test]
fn cornell_box_matches_the_cpu_in_both_variants() {
    let loaded = load("cornell-box.gltf");
    let camera = scene_camera(&loaded.scene, WIDTH, HEIGHT);
    let cpu = render_on_cpu(&loaded.shading, &loaded.bvh, &camera, &[]);
    check_cornell_box_content("cpu", &loaded.scene, &cpu);
    let mut per_variant = vec![];
    for variant in variants() {
        let gpu = render(variant, &loaded, &[camera]).remove(0);
        let name = format!("cornell-box {variant}");
        assert_agree(&format!("{name} vs cpu"), &cpu, &gpu);
        check_cornell_box_content(&name, &loaded.scene, &gpu);
        // A static camera: motion is exactly zero, and valid wherever there is a surface.
        for t in &gpu.texels {
            assert_eq!((t.motion.x, t.motion.y), (0.0, 0.0), "{name}: {t:?}");
            assert_eq!(t.motion.w, if t.is_surface() { 1.0 } else { 0.0 });
        }

        let dir = std::env::temp_dir()
            .join("gi-gbuffer")
            .join(format!("cornell-box-{}", variant_dir(variant)));
        let files = write_debug_pngs(&gpu, &dir).unwrap();
        assert_eq!(files.len(), 8);
        for f in &files {
            let decoded = image::open(f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
            assert_eq!((decoded.width(), decoded.height()), (WIDTH, HEIGHT));
        }
        println!("{name}: debug images in {}", dir.display());
        per_variant.push(gpu);
    }
    if let [software, ray_query] = &per_variant[..] {
        assert_agree("cornell-box software vs ray query", software, ray_query);
    }
}

/// `a · b` in f64.
fn dot64(a: [f64; 3], b: Vec3) -> f64 {
    a[0] * f64::from(b.x) + a[1] * f64::from(b.y) + a[2] * f64::from(b.z)
}

/// Where `p` lands on `camera`'s screen, in pixels, and its linear depth, in f64.
fn project_f64(camera: &CameraParams, p: [f64; 3]) -> (f64, f64, f64) {
    let d: [f64; 3] = std::array::from_fn(|i| p[i] - f64::from(camera.position[i]));
    let depth = dot64(d, camera.forward());
    let tan = f64::from(camera.tan_half_fov_y);
    let ndc_x = dot64(d, camera.right()) / (depth * tan * f64::from(camera.aspect));
    let ndc_y = -dot64(d, camera.up()) / (depth * tan);
    (
        (ndc_x + 1.0) * 0.5 * f64::from(camera.image_size[0]),
        (ndc_y + 1.0) * 0.5 * f64::from(camera.image_size[1]),
        depth,
    )
}

#[test]
fn motion_vectors_follow_a_known_camera_move() {
    let loaded = load("cornell-box.gltf");
    let camera = scene_camera(&loaded.scene, WIDTH, HEIGHT);
    // The camera moved by `offset` since the previous frame.
    let offset = Vec3::new(0.12, -0.07, 0.3);
    let mut previous = camera;
    previous.position = (camera.position() - offset).to_array();
    previous.view_proj = view_projection(&previous);
    let moving = camera.with_previous(&previous);
    let cpu = render_on_cpu(&loaded.shading, &loaded.bvh, &moving, &[]);
    for variant in variants() {
        let gpu = render(variant, &loaded, &[moving]).remove(0);
        let name = format!("cornell-box {variant}, moving camera");
        assert_agree(&format!("{name} vs cpu"), &cpu, &gpu);
        let (mut checked, mut largest) = (0, 0.0f64);
        for y in 0..HEIGHT {
            for x in 0..WIDTH {
                let t = gpu.texel(x, y);
                if !t.is_surface() {
                    assert_eq!(t.motion, glam::Vec4::ZERO);
                    continue;
                }
                // The hit point, from the pixel's ray and the stored depth (the ray's forward
                // component is 1).
                let ray = primary_ray(&moving, UVec2::new(x, y), Vec2::ZERO);
                let p: [f64; 3] = std::array::from_fn(|i| {
                    f64::from(ray.origin[i]) + f64::from(ray.direction[i]) * f64::from(t.depth)
                });
                let (px, py, previous_depth) = project_f64(&previous, p);
                let expected = (f64::from(x) + 0.5 - px, f64::from(y) + 0.5 - py);
                let error = (f64::from(t.motion.x) - expected.0)
                    .abs()
                    .max((f64::from(t.motion.y) - expected.1).abs());
                assert!(
                    error < 0.01,
                    "{name}: pixel ({x}, {y}): motion {:?}, expected {expected:?}",
                    t.motion
                );
                assert!(
                    (f64::from(t.motion.z) - previous_depth).abs() <= 1e-4 * previous_depth,
                    "{name}: previous depth {} vs {previous_depth}",
                    t.motion.z
                );
                assert_eq!(t.motion.w, 1.0);
                checked += 1;
                largest = largest.max(expected.0.abs().max(expected.1.abs()));
            }
        }
        println!("{name}: {checked} motion vectors within 0.01 px, largest {largest:.2} px");
        assert!(checked > (WIDTH * HEIGHT / 2) as usize);
        assert!(largest > 2.0, "the move must be visible: {largest} px");
    }
}

#[test]
fn textured_scene_shows_the_checker() {
    let mut loaded = load("textured.gltf");
    // Level 0 alone: at this size the floor is minified, and every mip level would blend the
    // squares (mip selection has its own test below).
    loaded.scene.textures[0].levels.truncate(1);
    loaded.shading = ShadingData::new(&loaded.scene).unwrap();
    let texture = &loaded.scene.textures[0];
    assert_eq!(
        (texture.width, texture.height, texture.srgb),
        (64, 64, true)
    );
    let camera = scene_camera(&loaded.scene, WIDTH, HEIGHT);
    let cpu = render_on_cpu(&loaded.shading, &loaded.bvh, &camera, &[]);
    let floor = material(&loaded.scene, "checker floor");
    let light = srgb_to_linear(230.0 / 255.0);
    let dark = srgb_to_linear(40.0 / 255.0);
    for variant in variants() {
        let gpu = render(variant, &loaded, &[camera]).remove(0);
        let name = format!("textured {variant}");
        assert_agree(&format!("{name} vs cpu"), &cpu, &gpu);
        let (mut lights, mut darks) = (0, 0);
        for y in 0..HEIGHT {
            for x in 0..WIDTH {
                let t = gpu.texel(x, y);
                if t.ids.z != floor {
                    continue;
                }
                let ray = primary_ray(&camera, UVec2::new(x, y), Vec2::ZERO);
                let p = Vec3::from_array(ray.origin) + Vec3::from_array(ray.direction) * t.depth;
                // The floor's UVs (scenes/generate.py): u = z/2 + 2, v = 2 - x/2, tiling 4 × 4
                // times a 64-texel checker of 8-texel squares.
                let u = (p.z / 2.0 + 2.0).rem_euclid(1.0) * 64.0;
                let v = (2.0 - p.x / 2.0).rem_euclid(1.0) * 64.0;
                // Bilinear filtering and the anisotropic taps along the footprint's long side
                // blend neighbouring squares near their edges.
                let [a, b] = floor_footprint(&camera, x, y, t.depth);
                let reach = 1.0 + 0.5 * a.length().max(b.length());
                let inside = |c: f32| (reach..=8.0 - reach).contains(&c.rem_euclid(8.0));
                if !(inside(u) && inside(v)) {
                    continue;
                }
                let is_light = ((u / 8.0) as u32 + (v / 8.0) as u32).is_multiple_of(2);
                let expected = if is_light { light } else { dark };
                assert!(
                    (t.albedo.truncate() - Vec3::splat(expected))
                        .abs()
                        .max_element()
                        <= 1.5 / 255.0,
                    "{name} ({x}, {y}), texel ({u:.1}, {v:.1}): albedo {:?}, not {expected}",
                    t.albedo
                );
                if is_light {
                    lights += 1;
                } else {
                    darks += 1;
                }
            }
        }
        println!("{name}: {lights} light and {darks} dark checker texels where expected");
        assert!(
            lights >= 10 && darks >= 10,
            "{name}: {lights} light, {darks} dark"
        );
    }
}

/// The footprint of pixel (`x`, `y`) of `camera` on the floor of `textured.gltf` (hit at linear
/// `depth`), in texels of its 64-texel checker: where the rays through the pixel's edges meet the
/// floor's plane (its UVs are u = z/2 + 2, v = 2 - x/2), across the pixel along x and along y.
fn floor_footprint(camera: &CameraParams, x: u32, y: u32, depth: f32) -> [Vec2; 2] {
    let pixel = UVec2::new(x, y);
    let ray = primary_ray(camera, pixel, Vec2::ZERO);
    let origin = Vec3::from_array(ray.origin);
    let height = (origin + Vec3::from_array(ray.direction) * depth).y;
    let texel_at = |offset: Vec2| {
        let d = Vec3::from_array(primary_ray(camera, pixel, offset).direction);
        let p = origin + d * ((height - origin.y) / d.y);
        Vec2::new(p.z, -p.x) * 0.5 * 64.0
    };
    [
        texel_at(Vec2::new(0.5, 0.0)) - texel_at(Vec2::new(-0.5, 0.0)),
        texel_at(Vec2::new(0.0, 0.5)) - texel_at(Vec2::new(0.0, -0.5)),
    ]
}

/// Mip selection by ray differentials: the checker floor's texture replaced by a chain whose
/// every level is one known grey (level `l`: 60 + 20·l of 255, linear), so the albedo tells which
/// level the G-buffer read. The device (both variants) agrees with the CPU's filter, and the level
/// read matches the pixel's footprint found independently, by intersecting the floor with the
/// rays through the pixel's edges: the level of its short side in texels, or of its long side
/// over 16 (`MAX_ANISOTROPY`) where that is coarser. Coarser with distance and grazing.
#[test]
fn pixel_footprints_pick_the_mip_level_they_need() {
    let mut loaded = load("textured.gltf");
    let grey = |l: u32| 60 + 20 * l;
    {
        let t = &mut loaded.scene.textures[0];
        t.srgb = false;
        t.levels = (0..gi_shared::textures::mip_levels(t.width, t.height))
            .map(|l| {
                let (w, h) = gi_shared::textures::level_size(t.width, t.height, l);
                let v = grey(l) as u8;
                [v, v, v, 255].repeat((w * h) as usize)
            })
            .collect();
        assert_eq!(t.levels.len(), 7);
    }
    loaded.shading = ShadingData::new(&loaded.scene).unwrap();
    let camera = scene_camera(&loaded.scene, WIDTH, HEIGHT);
    let cpu = render_on_cpu(&loaded.shading, &loaded.bvh, &camera, &[]);
    let floor = material(&loaded.scene, "checker floor");
    let factor = loaded.scene.materials[floor as usize].base_color.x;
    let mut checked = 0;
    let (mut finest, mut coarsest, mut most_taps) = (f32::MAX, f32::MIN, 0.0f32);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let t = cpu.texel(x, y);
            if t.ids.z != floor {
                continue;
            }
            let [across, along] = floor_footprint(&camera, x, y, t.depth).map(|a| a.length());
            let (long, short) = (across.max(along), across.min(along));
            let taps = (long / short).ceil().min(16.0);
            let expected = short.max(long / 16.0).log2().clamp(0.0, 6.0);
            let grey_read = t.albedo.x / factor * 255.0;
            let level_read = (grey_read - 60.0) / 20.0;
            assert!(
                (level_read - expected).abs() < 0.1,
                "pixel ({x}, {y}): level {level_read:.3} read, {expected:.3} expected"
            );
            finest = finest.min(level_read);
            coarsest = coarsest.max(level_read);
            most_taps = most_taps.max(taps);
            checked += 1;
        }
    }
    println!(
        "floor: {checked} pixels, levels {finest:.2} to {coarsest:.2}, up to {most_taps} taps"
    );
    assert!(checked > 200, "{checked} floor pixels");
    assert!(coarsest - finest > 1.0, "levels {finest} to {coarsest}");
    assert!(
        most_taps > 2.0,
        "the view must be grazing somewhere: {most_taps} taps"
    );
    for variant in variants() {
        let gpu = render(variant, &loaded, &[camera]).remove(0);
        assert_agree(&format!("mip levels {variant} vs cpu"), &cpu, &gpu);
    }
}
