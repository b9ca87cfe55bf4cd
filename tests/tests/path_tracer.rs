//! The reference path tracer against closed-form answers (a white furnace, a point light over a
//! plane), against the CPU running the same per-path code, and across the two tracing variants,
//! with the validation layer silent. Images are small (lavapipe is slow).
//!
//! Agreement tests use the same seeds on both sides, so most paths are the same path; where float
//! rounding makes a path take another turn it becomes an independent sample. So two renders with
//! the same seed must differ by no more than two renders with different seeds (the noise at that
//! sample count), and their image means must agree within three standard errors.

use gi_host::KernelVariant;
use gi_host::gbuffer::scene_camera;
use gi_host::image_io::HdrImage;
use gi_host::path_tracer::{
    MAX_SAMPLES_PER_SUBMIT, PathTracerPass, PathTracerSettings, Render, Strategy, render_on_cpu,
};
use gi_host::scene::bvh::Bvh;
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::{Environment, LightSet};
use gi_host::scene::procedural::transformed;
use gi_host::scene::upload::GpuScene;
use gi_host::scene::{Light, LightKind, Scene};
use gi_shared::camera::{CameraParams, primary_ray};
use gi_shared::path_tracer::path_random;
use gi_tests::{
    context, finish_without_validation_messages, furnace, lambertian, quad_scene, scene_path,
    variants,
};
use glam::{Mat4, UVec2, Vec2, Vec3};
use std::f32::consts::PI;

/// Renders `scene` from `camera` on the device with `variant`.
fn render_gpu(
    variant: KernelVariant,
    scene: &Scene,
    camera: &CameraParams,
    settings: &PathTracerSettings,
) -> Render {
    render_gpu_lit(
        variant,
        scene,
        &LightSet::new(scene, None, false),
        camera,
        settings,
    )
}

/// Renders `scene` lit by `lights` from `camera` on the device with `variant`.
fn render_gpu_lit(
    variant: KernelVariant,
    scene: &Scene,
    set: &LightSet,
    camera: &CameraParams,
    settings: &PathTracerSettings,
) -> Render {
    let ctx = context(variant);
    let shading = ShadingData::new(scene).unwrap();
    let gpu = GpuScene::upload(&ctx, scene, None, &shading, set).unwrap();
    assert_eq!(gpu.lights.count() as usize, set.lights.len());
    let mut pass = PathTracerPass::new(&ctx).unwrap();
    let mut reports = vec![];
    let render = pass
        .render(&ctx, &gpu, camera, settings, |done, total| {
            reports.push((done, total))
        })
        .unwrap();
    // Progress rises to the total, once per submission.
    assert_eq!(reports.last(), Some(&(settings.samples, settings.samples)));
    assert!(reports.windows(2).all(|w| w[0].0 < w[1].0));
    let [w, h] = camera.image_size;
    println!(
        "{} {variant}: {w}x{h}, {} spp in {:.1?} ms GPU time",
        scene.source.display(),
        settings.samples,
        render.gpu_ms
    );
    drop(pass);
    drop(gpu);
    finish_without_validation_messages(ctx);
    render
}

fn render_cpu(scene: &Scene, camera: &CameraParams, settings: &PathTracerSettings) -> HdrImage {
    let shading = ShadingData::new(scene).unwrap();
    let bvh = Bvh::new(scene).unwrap();
    render_on_cpu(
        &shading,
        &LightSet::new(scene, None, false),
        &bvh,
        camera,
        settings,
    )
    .unwrap()
}

/// Mean of all channels of all pixels.
fn mean(image: &HdrImage) -> f64 {
    let sum: f64 = image.pixels().iter().flatten().map(|&c| f64::from(c)).sum();
    sum / (3 * image.pixels().len()) as f64
}

/// Root-mean-square difference of two images, over all channels.
fn rmse(a: &HdrImage, b: &HdrImage) -> f64 {
    let sum: f64 = a
        .pixels()
        .iter()
        .flatten()
        .zip(b.pixels().iter().flatten())
        .map(|(&x, &y)| f64::from(x - y).powi(2))
        .sum();
    (sum / (3 * a.pixels().len()) as f64).sqrt()
}

/// White furnace: radiance `E / (1 - a)` everywhere inside, whatever the view, in both variants
/// and on the CPU. Every path sees emission at every vertex, by light sampling and by BSDF
/// sampling: the MIS weights must sum to one for the mean to come out right.
#[test]
fn white_furnace_converges_to_the_geometric_series() {
    let (albedo, emission) = (0.5, 1.0);
    let scene = furnace(albedo, emission);
    let settings = PathTracerSettings {
        samples: 64,
        ..Default::default()
    };
    let expected = assert_furnace("furnace", &scene, albedo, emission, &settings);
    let cpu = mean(&render_cpu(&scene, &furnace_camera(), &settings));
    println!("furnace CPU: mean {cpu:.5}");
    assert!((cpu - expected).abs() / expected < FURNACE_BOUND);
}

/// Inside the furnace, looking into a corner.
fn furnace_camera() -> CameraParams {
    CameraParams::new(
        Vec3::new(0.2, 0.1, 0.3),
        Vec3::new(-1.0, -0.3, -1.0),
        Vec3::Y,
        1.2,
        16,
        16,
    )
}

/// Renders the furnace `scene` in both variants and asserts its mean radiance, `E / (1 − a)`,
/// within [`FURNACE_BOUND`]; returns that expected value.
fn assert_furnace(
    name: &str,
    scene: &Scene,
    albedo: f32,
    emission: f32,
    settings: &PathTracerSettings,
) -> f64 {
    let expected = f64::from(emission / (1.0 - albedo));
    for variant in variants() {
        let m = mean(&render_gpu(variant, scene, &furnace_camera(), settings).image);
        let error = (m - expected).abs() / expected;
        println!(
            "{name} {variant}: mean {m:.5}, expected {expected}, error {:.3}%",
            error * 100.0
        );
        assert!(error < FURNACE_BOUND, "{name} {variant}: {m} vs {expected}");
    }
    expected
}

/// The bound the README claims for the white furnace (measured: 0.03% flat, 0.05% tilted).
const FURNACE_BOUND: f64 = 0.002;

/// The furnace with smooth normals as DCC tools export them: each vertex's normal points along
/// the cube's diagonal through it, so normals tilt from 0° at a face's centre to 54.7° at its
/// corners. The answer does not depend on the normals: interpolated normals must change the
/// shading, not the energy (killing the directions below the geometric surface lost 9% here).
#[test]
fn white_furnace_with_tilted_normals_keeps_its_energy() {
    let (albedo, emission) = (0.5, 1.0);
    let mut scene = furnace(albedo, emission);
    let mesh = &mut scene.meshes[0];
    for (p, n) in mesh.positions.iter().zip(mesh.normals.iter_mut()) {
        let diagonal = p.normalize();
        *n = if diagonal.dot(*n) > 0.0 {
            diagonal
        } else {
            -diagonal
        };
    }
    let tilt = mesh
        .normals
        .iter()
        .zip(mesh.positions.chunks(4).flat_map(|q| {
            let f = (q[1] - q[0]).cross(q[3] - q[0]).normalize();
            [f; 4]
        }))
        .map(|(n, f)| n.dot(f).acos().to_degrees())
        .fold(0.0, f32::max);
    assert!((tilt - 54.7).abs() < 0.1, "{tilt}");
    // More samples than the flat furnace: the tilted lobes make each path noisier.
    let settings = PathTracerSettings {
        samples: 256,
        ..Default::default()
    };
    assert_furnace("tilted-normal furnace", &scene, albedo, emission, &settings);
}

/// Where `camera`'s ray of `pixel` with sub-pixel offset `jitter` meets the plane z = 0.
fn plane_hit(camera: &CameraParams, pixel: UVec2, jitter: Vec2) -> Vec3 {
    let ray = primary_ray(camera, pixel, jitter);
    let o = Vec3::from_array(ray.origin);
    let d = Vec3::from_array(ray.direction);
    o + d * (-o.z / d.z)
}

/// Irradiance at `p` on the plane z = 0 (normal +Z) from `light`, written from glTF's
/// `KHR_lights_punctual` definitions independently of `gi_shared::lights`.
fn analytic_irradiance(light: &Light, p: Vec3) -> f32 {
    let i = light.intensity.x;
    match light.kind {
        LightKind::Directional => i * (-light.direction.z).max(0.0),
        LightKind::Point | LightKind::Spot { .. } => {
            let to = light.position - p;
            let cos = to.normalize().z.max(0.0);
            let cone = match light.kind {
                LightKind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                } => {
                    let cd = light.direction.dot(-to.normalize());
                    let (ci, co) = (inner_cone_angle.cos(), outer_cone_angle.cos());
                    ((cd - co) / (ci - co)).clamp(0.0, 1.0).powi(2)
                }
                _ => 1.0,
            };
            i * cone * cos / to.length_squared()
        }
    }
}

/// One punctual light (point, spot, directional) over a large plane: a point's radiance is
/// `albedo / π · E` with `E = I cos θ / d²` (times the cone falloff) or the directional light's
/// irradiance times `cos θ`. Direct lighting from one punctual light involves no random choice but
/// the pixel jitter, which the test replays from the path's random stream: each pixel must match
/// the mean of the analytic radiance at its samples' points within 1e-4 (1e-3 for the spot, whose
/// falloff ramp amplifies rounding; relative to the brightest pixel for pixels outside its cone).
#[test]
fn punctual_lights_over_a_plane_match_the_analytic_irradiance() {
    let albedo = 0.8;
    let position = Vec3::new(0.3, -0.2, 1.0);
    let light = |name: &str, kind, direction: Vec3| Light {
        name: name.to_owned(),
        kind,
        intensity: Vec3::splat(2.0),
        position,
        direction: direction.normalize(),
        range: None,
    };
    let lights = [
        light("point", LightKind::Point, Vec3::NEG_Z),
        light(
            "spot",
            LightKind::Spot {
                inner_cone_angle: 0.2,
                outer_cone_angle: 0.45,
            },
            Vec3::new(-0.2, 0.1, -1.0),
        ),
        light("sun", LightKind::Directional, Vec3::new(0.3, -0.2, -1.0)),
    ];
    let camera = CameraParams::new(Vec3::new(0.0, 0.0, 4.0), Vec3::NEG_Z, Vec3::Y, 0.6, 16, 16);
    let settings = PathTracerSettings {
        samples: 4,
        max_bounces: 4,
        ..Default::default()
    };
    for light in lights {
        let name = light.name.clone();
        // Just larger than the view: the hit point's rounding scales with the triangle's size.
        let scene = quad_scene(
            "plane",
            &[[Vec3::new(-2.0, -2.0, 0.0), Vec3::X * 4.0, Vec3::Y * 4.0]],
            vec![lambertian(albedo, 0.0)],
            vec![light.clone()],
        );
        let expected: Vec<f32> = (0..16 * 16)
            .map(|i| {
                let pixel = UVec2::new(i % 16, i / 16);
                (0..settings.samples)
                    .map(|sample| {
                        let params =
                            settings.params(&LightSet::new(&scene, None, false).params(), sample);
                        let jitter = path_random(&params, pixel).next_vec2() - Vec2::splat(0.5);
                        let p = plane_hit(&camera, pixel, jitter);
                        albedo / PI * analytic_irradiance(&light, p)
                    })
                    .sum::<f32>()
                    / settings.samples as f32
            })
            .collect();
        let peak = expected.iter().copied().fold(0.0, f32::max);
        for variant in variants() {
            let image = render_gpu(variant, &scene, &camera, &settings).image;
            let worst = image
                .pixels()
                .iter()
                .zip(&expected)
                .map(|(got, &e)| (got[0] - e).abs() / e.max(0.01 * peak))
                .fold(0.0, f32::max);
            println!(
                "{name} light {variant}: worst pixel error {:.3}%",
                worst * 100.0
            );
            // The spot's ramp multiplies the device's rounding of the light direction (a few
            // ULPs for sqrt and division on Vulkan) by 2 / (cos_inner − cos_outer) ≈ 25.
            let bound = if name == "spot" { 1e-3 } else { 1e-4 };
            assert!(worst < bound, "{name} {variant}: {worst}");
        }
    }
}

/// The Cornell box (area light, MIS, indirect bounces) on the CPU and on the device, and in the
/// two variants, agree within the noise of the sample count (see the module).
#[test]
fn cpu_and_both_variants_agree_within_noise() {
    let (scene, _) = Scene::load(scene_path("cornell-box.gltf")).unwrap();
    let camera = scene_camera(&scene, 12, 12);
    let settings = PathTracerSettings {
        samples: 16,
        max_bounces: 8,
        ..Default::default()
    };
    let cpu = render_cpu(&scene, &camera, &settings);
    let other_seed = render_cpu(
        &scene,
        &camera,
        &PathTracerSettings {
            seed: 1,
            ..settings
        },
    );
    let noise = rmse(&cpu, &other_seed);
    // Standard error of the image mean, from the spread of the pixel differences between seeds.
    let n = cpu.pixels().len() as f64;
    let mean_error = noise / n.sqrt();
    let mut gpu = vec![];
    for variant in variants() {
        let image = render_gpu(variant, &scene, &camera, &settings).image;
        let d = rmse(&cpu, &image);
        let dm = (mean(&cpu) - mean(&image)).abs();
        println!(
            "{variant} vs CPU: RMSE {d:.5} (seed-to-seed noise {noise:.5}), mean {:.5} vs {:.5}",
            mean(&image),
            mean(&cpu)
        );
        // Independent estimates (another seed on the CPU) must agree in the mean, too.
        let independent = (mean(&other_seed) - mean(&image)).abs();
        println!(
            "{variant} vs CPU with another seed: means differ by {independent:.5} \
             ({:.2} standard errors)",
            independent / mean_error
        );
        assert!(d <= noise, "{variant}: RMSE {d} above the noise {noise}");
        // Same seeds, same paths: only the rare path that float rounding turns elsewhere differs.
        assert!(d <= 0.1 * noise, "{variant}: RMSE {d}, noise {noise}");
        assert!(
            dm <= 3.0 * mean_error.max(1e-6),
            "{variant}: means differ by {dm}"
        );
        assert!(
            independent <= 4.0 * mean_error,
            "{variant}: means differ by {independent} from an independent render"
        );
        gpu.push(image);
    }
    let d = rmse(&gpu[0], &gpu[1]);
    println!("ray query vs software: RMSE {d:.5}");
    assert!(d <= 0.1 * noise);
    assert!(noise > 0.0, "different seeds must give different images");
}

/// A plane under a constant sky: a camera ray that misses sees the sky, and a point of the plane
/// reflects `albedo × sky` after one bounce, whatever the direction sampled (every reflected ray
/// escapes), so both are exact at any sample count; with no bounce allowed the plane is black.
#[test]
fn a_constant_sky_lights_a_plane() {
    let (albedo, sky) = (0.5, Vec3::new(1.0, 0.5, 0.25));
    let scene = quad_scene(
        "plane under the sky",
        &[[
            Vec3::new(-200.0, -50.0, 0.0),
            Vec3::X * 400.0,
            Vec3::Y * 100.0,
        ]],
        vec![lambertian(albedo, 0.0)],
        vec![],
    );
    // Looking at the plane's far edge: it lies on the line between the image's upper half, which
    // sees the sky beyond it, and its lower half, which sees the plane.
    let position = Vec3::new(0.0, -49.0, 1.0);
    let camera = CameraParams::new(
        position,
        Vec3::new(0.0, 50.0, 0.0) - position,
        Vec3::Z,
        1.0,
        8,
        8,
    );
    for variant in variants() {
        for bounces in [0, 1, 5] {
            let settings = PathTracerSettings {
                samples: 4,
                max_bounces: bounces,
                sky,
                ..Default::default()
            };
            let image = render_gpu(variant, &scene, &camera, &settings).image;
            for (i, p) in image.pixels().iter().enumerate() {
                let expected = if i < 32 {
                    sky
                } else if bounces == 0 {
                    Vec3::ZERO
                } else {
                    sky * albedo
                };
                let got = Vec3::from_array(*p);
                assert!(
                    (got - expected).abs().max_element() < 1e-4,
                    "{variant}, {bounces} bounces, pixel {i}: {got} vs {expected}"
                );
            }
        }
    }
}

/// A plane (normal +Y) under an equirectangular environment whose upper half is `a` and lower
/// half `b`: every reflected ray goes up, so the plane shows `albedo × a` exactly; the image's top
/// row looks up into `a`; the CPU computes the same image.
#[test]
fn an_environment_image_lights_a_plane() {
    let (albedo, a, b) = (0.5, [1.0, 0.5, 0.25], [0.0, 3.0, 0.0]);
    let scene = quad_scene(
        "plane under an environment",
        &[[
            Vec3::new(-200.0, 0.0, -50.0),
            Vec3::Z * 100.0,
            Vec3::X * 400.0,
        ]],
        vec![lambertian(albedo, 0.0)],
        vec![],
    );
    let environment = Environment::new(
        [8, 4],
        (0..32)
            .map(|i| {
                let c = if i < 16 { a } else { b };
                [c[0], c[1], c[2], 0.0]
            })
            .collect(),
    )
    .unwrap();
    // Not importance-sampled: BSDF sampling alone makes every sample exact here.
    let set = LightSet::new(&scene, Some(environment), false);
    let position = Vec3::new(0.0, 1.0, 49.0);
    let camera = CameraParams::new(
        position,
        Vec3::new(0.0, 0.0, -50.0) - position,
        Vec3::Y,
        1.0,
        8,
        8,
    );
    let settings = PathTracerSettings {
        samples: 4,
        max_bounces: 3,
        ..Default::default()
    };
    let shading = ShadingData::new(&scene).unwrap();
    let bvh = Bvh::new(&scene).unwrap();
    let cpu = render_on_cpu(&shading, &set, &bvh, &camera, &settings).unwrap();
    for variant in variants() {
        let ctx = context(variant);
        let gpu = GpuScene::upload(&ctx, &scene, None, &shading, &set).unwrap();
        assert_eq!(gpu.lights.count(), 0);
        let mut pass = PathTracerPass::new(&ctx).unwrap();
        let image = pass
            .render(&ctx, &gpu, &camera, &settings, |_, _| {})
            .unwrap()
            .image;
        drop(pass);
        drop(gpu);
        finish_without_validation_messages(ctx);
        for (i, p) in image.pixels().iter().enumerate() {
            let got = Vec3::from_array(*p);
            let expected = match i {
                0..8 => Some(Vec3::from_array(a)),
                32.. => Some(Vec3::from_array(a) * albedo),
                _ => None,
            };
            if let Some(e) = expected {
                assert!(
                    (got - e).abs().max_element() < 1e-4,
                    "{variant}, pixel {i}: {got} vs {e}"
                );
            } else {
                assert!(
                    got == Vec3::from_array(a) || got == Vec3::from_array(b) || {
                        // A sky pixel whose samples straddle the horizon mixes the two halves.
                        let t = (got.y - a[1]) / (b[1] - a[1]);
                        (got - Vec3::from_array(a).lerp(Vec3::from_array(b), t)).length() < 1e-4
                    }
                );
            }
        }
        let d = rmse(&cpu, &image);
        println!("environment {variant}: RMSE to the CPU {d:.2e}");
        assert!(d < 1e-5, "{variant}: {d}");
    }
}

/// Irradiance at `p` (normal +Z) from a unit-radiance polygon: Lambert's formula
/// `½ Σ θ_i (n · γ_i)`, in f64, independent of the path tracer's code.
fn polygon_irradiance(vertices: &[Vec3], p: Vec3) -> f64 {
    let mut e = 0.0f64;
    for i in 0..vertices.len() {
        let a = (vertices[i] - p).as_dvec3().normalize();
        let b = (vertices[(i + 1) % vertices.len()] - p)
            .as_dvec3()
            .normalize();
        let theta = a.dot(b).clamp(-1.0, 1.0).acos();
        e += theta * a.cross(b).normalize().z;
    }
    0.5 * e.abs()
}

/// Mean and standard error of the mean of `values`.
fn mean_and_error(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let m = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// A one-sided square light facing down over a diffuse plane, direct light only
/// (`max_bounces` 1): each pixel's expected radiance is `albedo/π · L ·` the polygon form factor
/// at its samples' points (replayed from the path's random stream). The residuals must average
/// to zero within 4 standard errors, and the error must be small enough to mean something.
#[test]
fn a_quad_light_over_a_plane_matches_the_form_factor() {
    let (albedo, radiance, height) = (0.7, 5.0, 1.0);
    let corner = Vec3::new(-0.2, -0.4, height);
    // Wound so that its front (u × v) faces down, toward the plane.
    let (u, v) = (Vec3::Y * 0.8, Vec3::X * 0.6);
    let scene = quad_scene(
        "quad light",
        &[
            [
                Vec3::new(-50.0, -50.0, 0.0),
                Vec3::X * 100.0,
                Vec3::Y * 100.0,
            ],
            [corner, u, v],
        ],
        vec![lambertian(albedo, 0.0), lambertian(0.0, radiance)],
        vec![],
    );
    let quad = [corner, corner + u, corner + u + v, corner + v];
    let camera = CameraParams::new(Vec3::new(0.0, 0.0, 0.6), Vec3::NEG_Z, Vec3::Y, 2.0, 16, 16);
    let settings = PathTracerSettings {
        samples: 64,
        max_bounces: 1,
        ..Default::default()
    };
    let set = LightSet::new(&scene, None, false);
    let expected: Vec<f64> = (0..16 * 16)
        .map(|i| {
            let pixel = UVec2::new(i % 16, i / 16);
            (0..settings.samples)
                .map(|sample| {
                    let params = settings.params(&set.params(), sample);
                    let jitter = path_random(&params, pixel).next_vec2() - Vec2::splat(0.5);
                    let p = plane_hit(&camera, pixel, jitter);
                    f64::from(albedo) / std::f64::consts::PI
                        * f64::from(radiance)
                        * polygon_irradiance(&quad, p)
                })
                .sum::<f64>()
                / f64::from(settings.samples)
        })
        .collect();
    let peak = expected.iter().copied().fold(0.0, f64::max);
    for variant in variants() {
        let image = render_gpu(variant, &scene, &camera, &settings).image;
        let residuals: Vec<f64> = image
            .pixels()
            .iter()
            .zip(&expected)
            .map(|(got, &e)| f64::from(got[0]) - e)
            .collect();
        let (bias, error) = mean_and_error(&residuals);
        println!("quad light {variant}: mean residual {bias:.2e} ± {error:.2e} (peak {peak:.4})");
        assert!(bias.abs() <= 4.0 * error, "{variant}: {bias} ± {error}");
        assert!(
            error < 2e-3 * peak,
            "{variant}: error {error} too large to test"
        );
    }
}

/// Light sampling alone, BSDF sampling alone and their MIS combination estimate the same image:
/// the Cornell box's means agree within 4 standard errors (estimated from a second seed).
#[test]
fn nee_bsdf_and_mis_agree_in_the_mean() {
    let (scene, _) = Scene::load(scene_path("cornell-box.gltf")).unwrap();
    let camera = scene_camera(&scene, 16, 16);
    let mut results = vec![];
    for strategy in [Strategy::Mis, Strategy::LightsOnly, Strategy::BsdfOnly] {
        let render = |seed| {
            let settings = PathTracerSettings {
                samples: 64,
                max_bounces: 4,
                seed,
                strategy,
                ..Default::default()
            };
            render_gpu(KernelVariant::Software, &scene, &camera, &settings).image
        };
        let (a, b) = (render(0), render(1));
        // Per-pixel variance of one render from the two seeds' differences.
        let n = a.pixels().len() as f64 * 3.0;
        let var = rmse(&a, &b).powi(2) / 2.0;
        let m = (mean(&a) + mean(&b)) / 2.0;
        let error = (var / n / 2.0).sqrt();
        println!("{strategy:?}: mean {m:.5} ± {error:.5}");
        results.push((strategy, m, error));
    }
    for (s, m, e) in &results {
        for (t, n, f) in &results {
            let bound = 4.0 * (e * e + f * f).sqrt();
            assert!(
                (m - n).abs() <= bound,
                "{s:?} {m} vs {t:?} {n}: bound {bound}"
            );
        }
    }
    // MIS is as good as light sampling alone here (a small light), and far better than BSDF
    // sampling alone.
    assert!(results[0].2 <= 1.1 * results[1].2 && 2.0 * results[0].2 < results[2].2);
}

/// `original` with every vertex moved to `place(world position)`, baked into one mesh per
/// instance (identity transforms), so that both tracing variants see the same f32 vertices.
fn baked(original: &Scene, place: impl Fn(Vec3) -> Vec3) -> Scene {
    let mut scene = original.clone();
    scene.meshes = original
        .instances
        .iter()
        .map(|inst| {
            let mut mesh = transformed(&original.meshes[inst.mesh as usize], inst.transform);
            for p in &mut mesh.positions {
                *p = place(*p);
            }
            mesh
        })
        .collect();
    for (i, inst) in scene.instances.iter_mut().enumerate() {
        inst.mesh = i as u32;
        inst.transform = Mat4::IDENTITY;
    }
    scene.update_derived();
    scene
}

/// The Cornell box scaled by 1e-3 and 1e3, and translated by 1e5, renders the same image:
/// radiance does not depend on units, and ray offsets must not either. The means agree within 4
/// standard errors of the noise at this sample count.
///
/// At 1e5, f32 vertices lie on a 2⁻⁷ m grid: the light's 0.4 m side becomes 0.40625 m, so the
/// scene itself is brighter (about +3%; printed). The translated box is therefore compared with
/// the same rounded geometry placed back at the origin, which isolates what tracing and ray
/// offsets do far from the origin.
#[test]
fn the_cornell_box_renders_the_same_at_any_scale_and_offset() {
    let (original, _) = Scene::load(scene_path("cornell-box.gltf")).unwrap();
    let settings = PathTracerSettings {
        samples: 64,
        max_bounces: 8,
        ..Default::default()
    };
    // From the file's camera position, a narrower view below the light: the lit walls and boxes
    // without the light's own pixels, whose noise would hide a bias.
    let camera = |place: &dyn Fn(Vec3) -> Vec3| {
        CameraParams::new(
            place(Vec3::new(0.0, 1.0, 3.9)),
            Vec3::new(0.0, -0.2, -3.9),
            Vec3::Y,
            25f32.to_radians(),
            24,
            24,
        )
    };
    let offset = 1e5f32;
    let identity = |p: Vec3| p;
    let rounded = |p: Vec3| (p + Vec3::splat(offset)) - Vec3::splat(offset);
    let light_area = |scene: &Scene| scene.emissive_triangles.iter().map(|t| t.area).sum::<f32>();
    let flat = baked(&original, identity);
    let back = baked(&original, rounded);
    println!(
        "light area {} at the origin, {} once rounded at 1e5",
        light_area(&flat),
        light_area(&back)
    );
    for variant in variants() {
        let render = |scene: &Scene, place: &dyn Fn(Vec3) -> Vec3, seed| {
            let settings = PathTracerSettings { seed, ..settings };
            mean(&render_gpu(variant, scene, &camera(place), &settings).image)
        };
        let image = render_gpu(variant, &flat, &camera(&identity), &settings).image;
        let other_seed = render_gpu(
            variant,
            &flat,
            &camera(&identity),
            &PathTracerSettings {
                seed: 1,
                ..settings
            },
        )
        .image;
        let n = image.pixels().len() as f64 * 3.0;
        let error = (rmse(&image, &other_seed).powi(2) / n).sqrt();
        let m = mean(&image);
        let m_rounded = render(&back, &rounded, 0);
        type Placement = Box<dyn Fn(Vec3) -> Vec3>;
        let cases: [(&str, Placement, f64); 3] = [
            ("scale 1e-3", Box::new(|p: Vec3| p * 1e-3), m),
            ("scale 1e3", Box::new(|p: Vec3| p * 1e3), m),
            (
                "offset 1e5",
                Box::new(move |p: Vec3| p + Vec3::splat(offset)),
                m_rounded,
            ),
        ];
        for (name, place, expected) in cases {
            let got = render(&baked(&original, &place), &*place, 0);
            let d = got - expected;
            println!(
                "{variant}: {name}: mean {got:.5} vs {expected:.5} ({:+.3}%, {:.2} standard \
                 errors; {:+.3}% from the unrounded box)",
                100.0 * d / expected,
                d.abs() / error,
                100.0 * (got - m) / m
            );
            assert!(d.abs() <= 4.0 * error, "{variant} {name}: {d} vs {error}");
        }
    }
}

/// A small, bright sun in an environment image over a plane: importance-sampling the
/// environment converges at least 10× faster (relMSE at equal samples) than BSDF sampling alone.
#[test]
fn a_sampled_environment_sun_converges_ten_times_faster() {
    let (w, h) = (64u32, 32u32);
    let sun = (40u32, 9u32);
    let texels: Vec<[f32; 4]> = (0..w * h)
        .map(|i| {
            if (i % w, i / w) == sun {
                [2000.0, 1800.0, 1500.0, 0.0]
            } else {
                [0.05, 0.07, 0.1, 0.0]
            }
        })
        .collect();
    let environment = Environment::new([w, h], texels).unwrap();
    let scene = quad_scene(
        "plane under a sun",
        &[[
            Vec3::new(-200.0, 0.0, -200.0),
            Vec3::Z * 400.0,
            Vec3::X * 400.0,
        ]],
        vec![lambertian(0.5, 0.0)],
        vec![],
    );
    let position = Vec3::new(0.0, 2.0, 3.0);
    let camera = CameraParams::new(position, -position, Vec3::Y, 0.5, 12, 12);
    let render = |sample: bool, samples: u32| {
        let set = LightSet::new(&scene, Some(environment.clone()), sample);
        let settings = PathTracerSettings {
            samples,
            max_bounces: 1,
            seed: samples,
            ..Default::default()
        };
        render_gpu_lit(KernelVariant::Software, &scene, &set, &camera, &settings).image
    };
    let reference = render(true, 2048);
    let rel_mse = |image: &HdrImage| {
        let sum: f64 = image
            .pixels()
            .iter()
            .zip(reference.pixels())
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c], b[c])))
            .map(|(a, b)| f64::from(a - b).powi(2) / (f64::from(b).powi(2) + 1e-4))
            .sum();
        sum / (3 * image.pixels().len()) as f64
    };
    let sampled = rel_mse(&render(true, 16));
    let bsdf = rel_mse(&render(false, 16));
    println!(
        "environment sun, 16 spp: relMSE {sampled:.3e} sampled, {bsdf:.3e} BSDF only: {:.0}x",
        bsdf / sampled
    );
    assert!(bsdf >= 10.0 * sampled, "{sampled} vs {bsdf}");
}

/// 65 536 samples of a constant sky lose no precision: each submission sums at most
/// `MAX_SAMPLES_PER_SUBMIT` samples in f32 and the host adds them in f64, so the error stays
/// within that batch's rounding, where one f32 running sum drifts by up to N·ε/2 (4e-3 here).
#[test]
fn accumulation_loses_no_precision_at_64k_samples() {
    let sky = 0.1f32;
    // One small triangle behind the camera: everything the camera sees is sky.
    let scene = quad_scene(
        "sky",
        &[[Vec3::new(0.0, 0.0, 5.0), Vec3::X * 0.01, Vec3::Y * 0.01]],
        vec![lambertian(0.5, 0.0)],
        vec![],
    );
    let camera = CameraParams::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 4, 4);
    let settings = PathTracerSettings {
        samples: 1 << 16,
        sky: Vec3::splat(sky),
        ..Default::default()
    };
    let image = render_gpu(KernelVariant::Software, &scene, &camera, &settings).image;
    let worst = image
        .pixels()
        .iter()
        .flatten()
        .map(|&c| (f64::from(c) - f64::from(sky)).abs() / f64::from(sky))
        .fold(0.0, f64::max);
    let bound = f64::from(MAX_SAMPLES_PER_SUBMIT - 1) * f64::from(f32::EPSILON) / 2.0;
    println!("64k samples of sky {sky}: worst relative error {worst:.2e} (bound {bound:.2e})");
    assert!(worst <= bound, "{worst}");
}
