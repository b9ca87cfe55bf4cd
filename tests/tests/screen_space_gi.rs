//! Screen-space GI's occlusion and near-field light on the GPU (`gi_shared::screen_space_gi`,
//! read by InterpolateScreenProbes).

use gi_host::KernelVariant;
use gi_host::gbuffer::scene_camera;
use gi_host::gi::gi_denoiser::DenoiserStage;
use gi_host::gi::renderer::GiRenderer;
use gi_host::gi::{GiSettings, Preset, ViewOptions};
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::LightSet;
use gi_host::scene::upload::GpuScene;
use gi_shared::primary_surface::primary_surface;
use gi_shared::screen_space_gi::{NoNearField, RowMajor, horizon_occlusion};
use gi_tests::{context, finish_without_validation_messages, load_scene};
use glam::{UVec2, Vec3, Vec4};

const W: u32 = 64;
const H: u32 = 48;
/// The search radius the test renders with.
const RADIUS: u32 = 16;

/// The interpolated irradiance of frames 1 and 3 of the Cornell box under `settings`, with the
/// first frame's camera, G-buffer and frame parameters.
struct Run {
    frames: Vec<Vec<[f32; 4]>>,
    camera: gi_shared::camera::CameraParams,
    frame: gi_shared::screen_probes::GiFrameParams,
    gbuffer: gi_host::gbuffer::GBufferData,
}

fn run(ctx: &gi_host::vulkan::Context, gpu: &GpuScene, lights: &LightSet, s: GiSettings) -> Run {
    let scene = load_scene("cornell-box.gltf");
    let camera = scene_camera(&scene, W, H);
    let mut gi = GiRenderer::new(ctx, lights, W, H, s, ViewOptions::default()).unwrap();
    gi.keep_interpolated_irradiance(ctx).unwrap();
    let mut frames = Vec::new();
    let mut first = None;
    for f in 0..3 {
        gi.render_frame(ctx, gpu, &camera).unwrap();
        if f == 0 {
            let (camera, _, frame) = *gi.last_frame().unwrap();
            first = Some((camera, frame, gi.gbuffer().read_back(ctx).unwrap()));
        }
        if f != 1 {
            let irradiance = gi.denoiser().output(DenoiserStage::Interpolated);
            frames.push(irradiance.read_back::<[f32; 4]>(ctx).unwrap());
        }
    }
    let (camera, frame, gbuffer) = first.unwrap();
    Run {
        frames,
        camera,
        frame,
        gbuffer,
    }
}

fn luminance(p: [f32; 4]) -> f64 {
    f64::from(p[0] + p[1] + p[2])
}

/// On the first frame (no previous light, so no near-field term) every pixel the CPU model finds
/// open has the same irradiance bits as without occlusion, the occluded ones read darker in sum,
/// and the GPU and the CPU model agree on which pixels are occluded. By the third frame the
/// occluders' own light (the near-field term) gives some of it back.
#[test]
fn occlusion_darkens_the_pixels_the_shared_model_finds_occluded() {
    let scene = load_scene("cornell-box.gltf");
    let ctx = context(KernelVariant::Software);
    let lights = LightSet::new(&scene, None, true);
    let shading = ShadingData::new(&scene).unwrap();
    let gpu = GpuScene::upload(&ctx, &scene, None, &shading, &lights).unwrap();
    let base = Preset::Balanced.settings(W, H);
    let off = run(
        &ctx,
        &gpu,
        &lights,
        GiSettings {
            occlusion_radius: 0,
            ..base
        },
    );
    let on = run(
        &ctx,
        &gpu,
        &lights,
        GiSettings {
            occlusion_radius: RADIUS,
            ..base
        },
    );
    assert_eq!(off.gbuffer.texels, on.gbuffer.texels);
    let g = &on.gbuffer;
    let depth: Vec<f32> = g.texels.iter().map(|t| t.depth).collect();
    let albedo: Vec<Vec3> = g.texels.iter().map(|t| t.albedo.truncate()).collect();
    let normals: Vec<Vec4> = g.texels.iter().map(|t| t.geometric_normal).collect();
    let (mut open, mut occluded, mut disagree) = (0, Vec::new(), 0);
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let t = &g.texels[i];
            let pixel = UVec2::new(x, y);
            let surface = primary_surface(
                &on.camera,
                pixel,
                t.depth,
                t.geometric_normal,
                t.shading_normal,
            );
            if !surface.valid {
                continue;
            }
            let o = horizon_occlusion(
                &on.camera,
                on.frame.horizon_search(),
                pixel,
                t.depth,
                surface.geometric_normal,
                surface.shading_normal,
                (
                    &RowMajor {
                        texels: &depth,
                        width: W,
                    },
                    &RowMajor {
                        texels: &normals,
                        width: W,
                    },
                    &RowMajor {
                        texels: &albedo,
                        width: W,
                    },
                ),
                &NoNearField,
            );
            let same = on.frames[0][i] == off.frames[0][i];
            if o.occluded() {
                occluded.push(i);
                disagree += usize::from(same);
            } else {
                open += 1;
                disagree += usize::from(!same);
            }
        }
    }
    let sum = |frame: &[[f32; 4]]| occluded.iter().map(|&i| luminance(frame[i])).sum::<f64>();
    let first = sum(&on.frames[0]) / sum(&off.frames[0]);
    let third = sum(&on.frames[1]) / sum(&off.frames[1]);
    println!(
        "{open} open, {} occluded surface pixels, {disagree} where the GPU and the CPU model \
         disagree; occluded pixels' irradiance against no occlusion: frame 1 {first:.3}, \
         frame 3 {third:.3}",
        occluded.len()
    );
    // The Cornell box's corners, edges and its boxes' contacts; at 64 × 48 a radius of 16
    // pixels reaches a wall from most of the floor.
    let surface = open + occluded.len();
    assert!(
        occluded.len() * 20 > surface && occluded.len() * 10 < surface * 9,
        "{open} {}",
        occluded.len()
    );
    // Rounding differs between the CPU and the GPU (fused multiply-adds, `acos`): a pixel whose
    // sample lies at the tangent bias may flip.
    assert!(disagree * 100 <= surface, "{disagree}");
    assert!(first < 0.95, "{first}");
    assert!(third > first + 0.02 && third < 1.1, "{first} → {third}");
    drop(gpu);
    finish_without_validation_messages(ctx);
}
