//! Alpha-masked geometry (`alphaMode: MASK`) in tracing: a fence, a quad whose texture's alpha is
//! a 2 × 2 checker tiled 4 × 4 times (holes where alpha is 0), held 2 m above a floor. Closest
//! hits (the `trace_rays` kernel), the G-buffer's primary rays and the path tracer's shadow rays
//! (any hit) go through the holes and stop at the solid texels, on the CPU and in both device
//! variants, as an analytic model of the texture says. The floor is opaque: with ray queries only
//! the fence's bottom level is non-opaque.
//!
//! The model: Vulkan's bilinear filter of level 0 with repeat wrapping, texel `(i, j)` opaque
//! when `i + j` is odd, against the cutoff 0.5. Rays whose fence point has a filtered alpha within
//! [`EDGE`] of the cutoff are left out: there the CPU's exact filter and the device's 8-bit
//! sub-texel weights, or the two tracers' barycentrics, may fall on either side.
//!
//! Images are tiny (lavapipe): G-buffer 32 × 32, path tracer 24 × 24 at 4 samples.

use gi_host::gbuffer::{GBufferImages, GBufferPass};
use gi_host::path_tracer::{PathTracerPass, PathTracerSettings};
use gi_host::scene::bvh::Bvh;
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::LightSet;
use gi_host::scene::upload::GpuScene;
use gi_host::scene::{Instance, Light, LightKind, Material, Mesh, Scene, Texture, Wrap};
use gi_host::trace_rays::TraceRays;
use gi_shared::camera::{CameraParams, primary_ray};
use gi_shared::path_tracer::path_random;
use gi_shared::random::Random;
use gi_shared::ray::{HitRecord, Ray};
use gi_shared::scene_data::MESH_ALPHA_TESTED;
use gi_tests::{context, finish_without_validation_messages, variants};
use glam::{Mat4, UVec2, Vec2, Vec3};
use std::f32::consts::PI;

/// Rays whose filtered alpha on the fence is this close to the cutoff are not judged.
const EDGE: f32 = 0.02;

/// The fence: corner, edges, height.
const FENCE_MIN: Vec2 = Vec2::new(-3.0, -1.0);
const FENCE_SIZE: f32 = 2.0;
const FENCE_Z: f32 = 2.0;
/// UV repeats of the 2 × 2 texture across the fence.
const TILES: f32 = 4.0;

const FLOOR: u32 = 0;
const FENCE: u32 = 1;

fn quad(name: &str, o: Vec3, u: Vec3, v: Vec3, material: u32, uvs: bool) -> Mesh {
    let n = u.cross(v).normalize();
    Mesh {
        name: name.to_owned(),
        positions: vec![o, o + u, o + u + v, o + v],
        normals: vec![n; 4],
        uvs: uvs.then(|| {
            vec![
                Vec2::ZERO,
                Vec2::new(TILES, 0.0),
                Vec2::splat(TILES),
                Vec2::new(0.0, TILES),
            ]
        }),
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        materials: vec![material; 2],
    }
}

/// The floor (instance 0, red, `[-3, 3]²` at z = 0) and the fence (instance 1, green, masked),
/// lit by `lights`.
fn fence_scene(lights: Vec<Light>) -> Scene {
    let lambertian = |c: Vec3| Material {
        base_color: c.extend(1.0),
        metallic: 0.0,
        ..Default::default()
    };
    let fence = Material {
        base_color_texture: Some(0),
        alpha_cutoff: Some(0.5),
        ..lambertian(Vec3::new(0.2, 0.8, 0.2))
    };
    // White, alpha 0 at texels (0, 0) and (1, 1).
    let texel = |a: u8| [255, 255, 255, a];
    let texture = Texture {
        name: "holes".into(),
        width: 2,
        height: 2,
        levels: vec![[texel(0), texel(255), texel(255), texel(0)].concat()],
        srgb: true,
        wrap: [Wrap::Repeat; 2],
    };
    let instance = |name: &str, mesh: u32| Instance {
        name: name.to_owned(),
        node: mesh,
        mesh,
        transform: Mat4::IDENTITY,
    };
    Scene::from_parts(
        "alpha-fence",
        vec![
            quad(
                "floor",
                Vec3::new(-3.0, -3.0, 0.0),
                Vec3::X * 6.0,
                Vec3::Y * 6.0,
                FLOOR,
                false,
            ),
            quad(
                "fence",
                FENCE_MIN.extend(FENCE_Z),
                Vec3::X * FENCE_SIZE,
                Vec3::Y * FENCE_SIZE,
                FENCE,
                true,
            ),
        ],
        vec![instance("floor", 0), instance("fence", 1)],
        vec![lambertian(Vec3::new(0.8, 0.3, 0.2)), fence],
        vec![texture],
        lights,
    )
}

/// The fence's filtered alpha at world point `q` (on its plane), or `None` off the fence.
fn fence_alpha(q: Vec3) -> Option<f32> {
    let local = (q.truncate() - FENCE_MIN) / FENCE_SIZE;
    if local.min_element() < 0.0 || local.max_element() > 1.0 {
        return None;
    }
    // Texel space of the 2-texel-wide texture, centres at integers + 0.5.
    let t = local * TILES * 2.0 - Vec2::splat(0.5);
    let (i, j) = (t.x.floor(), t.y.floor());
    let (fx, fy) = (t.x - i, t.y - j);
    let alpha = |i: f32, j: f32| ((i + j).rem_euclid(2.0) == 1.0) as u32 as f32;
    Some(
        alpha(i, j) * (1.0 - fx) * (1.0 - fy)
            + alpha(i + 1.0, j) * fx * (1.0 - fy)
            + alpha(i, j + 1.0) * (1.0 - fx) * fy
            + alpha(i + 1.0, j + 1.0) * fx * fy,
    )
}

/// Whether the fence stops a ray at `q` on its plane: `Some(true)` on a solid texel, `Some(false)`
/// in a hole or off the fence, `None` too near an alpha edge or the rim to judge.
fn fence_at(q: Vec3) -> Option<bool> {
    let rim = (q.truncate() - FENCE_MIN - Vec2::splat(FENCE_SIZE / 2.0))
        .abs()
        .max_element();
    if (rim - FENCE_SIZE / 2.0).abs() < 1e-3 {
        return None;
    }
    match fence_alpha(q) {
        Some(a) if (a - 0.5).abs() < EDGE => None,
        Some(a) => Some(a >= 0.5),
        None => Some(false),
    }
}

/// What a ray from above should hit first by the model (the fence, the floor, or `u32::MAX` for
/// nothing), or `None` when it is too near an edge to judge.
fn expected_instance(ray: &Ray) -> Option<u32> {
    let o = Vec3::from_array(ray.origin);
    let d = Vec3::from_array(ray.direction);
    if fence_at(o + d * ((FENCE_Z - o.z) / d.z))? {
        return Some(FENCE);
    }
    let floor = (o + d * (-o.z / d.z)).truncate().abs().max_element();
    if (floor - 3.0).abs() < 1e-3 {
        return None;
    }
    Some(if floor < 3.0 { FLOOR } else { u32::MAX })
}

fn gpu_scene(ctx: &gi_host::vulkan::Context, scene: &Scene, shading: &ShadingData) -> GpuScene {
    let lights = LightSet::new(scene, None, false);
    GpuScene::upload(ctx, scene, None, shading, &lights).unwrap()
}

/// Closest hits through holes and solid texels: texel centres straight down (the fence at
/// t = 2, or the floor at t = 4), then random rays from above, on the CPU against the model and
/// on the device (both variants) against the CPU.
#[test]
fn closest_hits_pass_through_the_holes_in_both_variants() {
    let scene = fence_scene(vec![]);
    let shading = ShadingData::new(&scene).unwrap();
    assert_eq!(shading.meshes[FLOOR as usize].flags, 0);
    assert_eq!(shading.meshes[FENCE as usize].flags, MESH_ALPHA_TESTED);
    let bvh = Bvh::new(&scene).unwrap();
    let down = |x: f32, y: f32| Ray {
        origin: [x, y, 4.0],
        t_min: 0.0,
        direction: [0.0, 0.0, -1.0],
        t_max: f32::INFINITY,
    };
    let texels = 2 * TILES as u32;
    let mut rays: Vec<Ray> = (0..texels * texels)
        .map(|k| {
            let (i, j) = ((k % texels) as f32, (k / texels) as f32);
            let step = FENCE_SIZE / texels as f32;
            down(
                FENCE_MIN.x + (i + 0.5) * step,
                FENCE_MIN.y + (j + 0.5) * step,
            )
        })
        .collect();
    let centres = rays.len();
    let mut rng = Random::new(5, 0);
    rays.extend((0..4000).map(|_| {
        let o = Vec3::new(
            -4.0 + 4.0 * rng.next_f32(),
            -2.0 + 4.0 * rng.next_f32(),
            4.0,
        );
        let target = Vec3::new(
            -4.0 + 4.0 * rng.next_f32(),
            -2.0 + 4.0 * rng.next_f32(),
            0.0,
        );
        Ray {
            direction: (target - o).to_array(),
            ..down(o.x, o.y)
        }
    }));
    let cpu: Vec<HitRecord> = rays.iter().map(|r| bvh.closest_hit(&shading, r)).collect();
    let (mut holes, mut solid, mut judged) = (0, 0, 0);
    for (i, (ray, hit)) in rays.iter().zip(&cpu).enumerate() {
        let Some(want) = expected_instance(ray) else {
            continue;
        };
        judged += 1;
        let got = if hit.is_hit() { hit.instance } else { u32::MAX };
        assert_eq!(got, want, "cpu ray {i}: {ray:?} gave {hit:?}");
        if i < centres {
            // Texel centres: a hole iff i + j is even, exactly at t = 4 or 2.
            let (ti, tj) = (i as u32 % texels, i as u32 / texels);
            let hole = (ti + tj) % 2 == 0;
            assert_eq!(want, if hole { FLOOR } else { FENCE }, "texel ({ti}, {tj})");
            let t = if hole { 4.0 } else { 2.0 };
            assert!((hit.t - t).abs() < 1e-6, "texel ({ti}, {tj}): {hit:?}");
            if hole {
                holes += 1;
            } else {
                solid += 1;
            }
        }
    }
    assert_eq!((holes, solid), (32, 32));
    assert!(judged > rays.len() * 3 / 4, "only {judged} rays judged");
    for variant in variants() {
        let ctx = context(variant);
        let gpu_scene = gpu_scene(&ctx, &scene, &shading);
        let pass = TraceRays::new(&ctx).unwrap();
        let gpu = pass.run(&ctx, &gpu_scene, &rays).unwrap().hits;
        drop(pass);
        drop(gpu_scene);
        finish_without_validation_messages(ctx);
        let mut same = 0;
        for (i, ((ray, c), g)) in rays.iter().zip(&cpu).zip(&gpu).enumerate() {
            if i >= centres && expected_instance(ray).is_none() {
                continue;
            }
            assert_eq!(
                (c.is_hit(), c.instance, c.primitive),
                (g.is_hit(), g.instance, g.primitive),
                "{variant} ray {i}: {ray:?}: cpu {c:?}, gpu {g:?}"
            );
            assert!(
                !c.is_hit() || (c.t - g.t).abs() <= 1e-4 * c.t,
                "{variant} ray {i}: t {} vs {}",
                c.t,
                g.t
            );
            same += 1;
        }
        println!(
            "{variant}: {same} of {} rays agree with the CPU",
            rays.len()
        );
    }
}

/// The G-buffer seen from above the fence: the floor's material and colour through the holes, the
/// fence's on solid texels, on the CPU and in both variants.
#[test]
fn the_gbuffer_shows_the_floor_through_the_holes() {
    let scene = fence_scene(vec![]);
    let shading = ShadingData::new(&scene).unwrap();
    let bvh = Bvh::new(&scene).unwrap();
    let (w, h) = (32, 32);
    let camera = CameraParams::new(Vec3::new(-2.0, 0.0, 4.0), Vec3::NEG_Z, Vec3::Y, 0.6, w, h);
    let cpu = gi_host::gbuffer::render_on_cpu(&shading, &bvh, &camera, &[]);
    let mut outputs = vec![("cpu".to_owned(), cpu)];
    for variant in variants() {
        let ctx = context(variant);
        let gpu_scene = gpu_scene(&ctx, &scene, &shading);
        let mut pass = GBufferPass::new(&ctx).unwrap();
        let images = GBufferImages::new(&ctx, w, h).unwrap();
        pass.run(&ctx, &gpu_scene, &camera, &images).unwrap();
        outputs.push((variant.to_string(), images.read_back(&ctx).unwrap()));
        drop(images);
        drop(pass);
        drop(gpu_scene);
        finish_without_validation_messages(ctx);
    }
    let floor_albedo = Vec3::new(0.8, 0.3, 0.2);
    let fence_albedo = Vec3::new(0.2, 0.8, 0.2);
    for (name, g) in &outputs {
        let (mut holes, mut solid) = (0, 0);
        for y in 0..h {
            for x in 0..w {
                let ray = primary_ray(&camera, UVec2::new(x, y), camera.jitter());
                let Some(want) = expected_instance(&ray) else {
                    continue;
                };
                let t = g.texel(x, y);
                if want == u32::MAX {
                    // Past the floor's edge: sky.
                    assert!(!t.is_surface(), "{name} ({x}, {y}): {:?}", t.ids);
                    continue;
                }
                let (material, albedo) = if want == FLOOR {
                    holes += 1;
                    (FLOOR, floor_albedo)
                } else {
                    solid += 1;
                    (FENCE, fence_albedo)
                };
                assert_eq!(
                    (t.ids.x, t.ids.z),
                    (want, material),
                    "{name} ({x}, {y}): {:?}",
                    t.ids
                );
                assert!(
                    (t.albedo.truncate() - albedo).abs().max_element() <= 1.5 / 255.0,
                    "{name} ({x}, {y}): albedo {:?}, not {albedo}",
                    t.albedo
                );
            }
        }
        println!("{name}: floor through {holes} pixels, fence on {solid}");
        // About half of the view is holes (the checker's filtered alpha is below 1/2 on half).
        let judged = holes + solid;
        assert!(judged > (w * h) as usize / 2, "{name}: {judged} judged");
        assert!(
            holes.abs_diff(solid) * 5 < judged,
            "{name}: {holes} holes, {solid} solid"
        );
    }
}

/// The floor under the fence, lit by a sun at 45° whose light passes the holes: each pixel's
/// direct light (one bounce) matches the model at its samples' points (the path tracer's own
/// jitter, replayed), on the CPU and in both variants, and the shadow lets through the fraction
/// of light the holes cover, about half.
#[test]
fn sunlight_reaches_the_floor_through_the_holes() {
    let sun = Light {
        name: "sun".into(),
        kind: LightKind::Directional,
        intensity: Vec3::splat(2.0),
        position: Vec3::ZERO,
        direction: Vec3::new(1.0, 0.0, -1.0).normalize(),
        range: None,
    };
    let scene = fence_scene(vec![sun.clone()]);
    let shading = ShadingData::new(&scene).unwrap();
    let set = LightSet::new(&scene, None, false);
    // The fence is out of view (x <= -1 at z = 2); its shadow covers x, y in [-1, 1].
    let n = 24;
    let camera = CameraParams::new(Vec3::new(0.0, 0.0, 4.0), Vec3::NEG_Z, Vec3::Y, 0.6, n, n);
    let settings = PathTracerSettings {
        samples: 4,
        max_bounces: 1,
        ..Default::default()
    };
    let lit = 0.8 / PI * sun.intensity.x * -sun.direction.z;
    // Per pixel: the expected red radiance, or `None` when a sample is too near an edge.
    let (mut shadow_samples, mut shadow_lit) = (0, 0);
    let expected: Vec<Option<f32>> = (0..n * n)
        .map(|i| {
            let pixel = UVec2::new(i % n, i / n);
            let mut sum = 0.0;
            for sample in 0..settings.samples {
                let params = settings.params(&set.params(), sample);
                let jitter = path_random(&params, pixel).next_vec2() - Vec2::splat(0.5);
                let ray = primary_ray(&camera, pixel, jitter);
                let o = Vec3::from_array(ray.origin);
                let d = Vec3::from_array(ray.direction);
                let p = o + d * (-o.z / d.z);
                // Where the shadow ray crosses the fence's plane.
                let q = p - sun.direction * (FENCE_Z / -sun.direction.z);
                let blocked = fence_at(q)?;
                if fence_alpha(q).is_some() {
                    shadow_samples += 1;
                    shadow_lit += usize::from(!blocked);
                }
                if !blocked {
                    sum += lit;
                }
            }
            Some(sum / settings.samples as f32)
        })
        .collect();
    let fraction = shadow_lit as f32 / shadow_samples as f32;
    println!("model: {shadow_lit} of {shadow_samples} samples under the fence are lit");
    assert!(
        shadow_samples > 500,
        "{shadow_samples} samples under the fence"
    );
    assert!((0.4..=0.6).contains(&fraction), "lit fraction {fraction}");
    let bvh = Bvh::new(&scene).unwrap();
    let cpu =
        gi_host::path_tracer::render_on_cpu(&shading, &set, &bvh, &camera, &settings).unwrap();
    let mut images = vec![("cpu".to_owned(), cpu)];
    for variant in variants() {
        let ctx = context(variant);
        let gpu_scene = gpu_scene(&ctx, &scene, &shading);
        let mut pass = PathTracerPass::new(&ctx).unwrap();
        let render = pass
            .render(&ctx, &gpu_scene, &camera, &settings, |_, _| {})
            .unwrap();
        images.push((variant.to_string(), render.image));
        drop(pass);
        drop(gpu_scene);
        finish_without_validation_messages(ctx);
    }
    for (name, image) in &images {
        let mut judged = 0;
        let (mut got_sum, mut want_sum) = (0.0, 0.0);
        for (i, (got, want)) in image.pixels().iter().zip(&expected).enumerate() {
            let Some(want) = want else {
                continue;
            };
            judged += 1;
            got_sum += got[0];
            want_sum += want;
            assert!(
                (got[0] - want).abs() <= 1e-3 * lit,
                "{name} pixel ({}, {}): {} not {want}",
                i as u32 % n,
                i as u32 / n,
                got[0]
            );
        }
        println!("{name}: {judged} pixels judged, mean {got_sum} vs {want_sum} expected");
        assert!(judged > (n * n) as usize / 2, "{name}: {judged} judged");
    }
}
