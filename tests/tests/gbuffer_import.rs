//! Importing an engine's G-buffer: our G-buffer of the Cornell box (32 × 32, a moving and
//! jittered camera), re-encoded on the CPU as an engine would store it in three sets of formats
//! and conventions, uploaded, imported, read back and compared channel by channel with ours; and
//! images the import cannot read refused by name. The validation layer stays silent.
//!
//! Bounds, from the formats' precision:
//! * depth: a standard depth gives 1/z as 1/near minus a number of about 1/near, so f32 rounding
//!   of a few 2⁻²⁰ in 1/z is z² · 1e-6 in z, and the stored depth's own rounding z²/near · 2⁻²⁴
//!   as much again: ≤ 1e-5 · z². Reversed-Z with an infinite far plane is near/d: a few f32
//!   roundings, ≤ 1e-6 · z. Linear depth is copied: exact.
//! * shading normal: ours and the import's are half floats (2⁻¹¹ relative): ≤ 1e-3 per component
//!   through half or 16-bit octahedral storage; a 10-bit UNORM step is 2/1023 in [-1, 1], half a
//!   step ≈ 1e-3 per component before normalising: ≤ 3e-3.
//! * geometric normal (rebuilt from depth): where our four neighbours lie on the pixel's plane,
//!   ≤ 2e-3 per component: ours is a half float (≤ 5e-4), and the worst depth error, z² · 1e-5
//!   (standard depth), over a pixel of about z/20 tilts the normal by ≤ 1e-3.
//! * albedo: the same 8-bit value through UNORM (≤ 0.5/255); through sRGB 8 bits, half an sRGB
//!   step near white spans up to 1.2/255 in linear, plus the UNORM output's half step: ≤ 2/255.
//! * motion: half-float vectors keep 2⁻¹¹ of their size: ≤ |m| · 2⁻¹¹ + 1e-4 pixel; f32 uv
//!   vectors ≤ 1e-4 pixel; rebuilt from depth and the previous camera ≤ 1e-3 pixel; the previous
//!   depth as the depth plus 1e-5 relative.
//! * emission: half floats copied: ≤ 1e-6 relative.

use gi_host::gbuffer::{GBufferData, GBufferImages, GBufferPass, scene_camera};
use gi_host::gi::gbuffer_import::{
    Conventions, DepthEncoding, ExternalGBuffer, ExternalImage, GBufferImport, MotionUnits,
    MotionVectors,
};
use gi_host::scene::bvh::Bvh;
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::LightSet;
use gi_host::scene::upload::GpuScene;
use gi_host::vulkan::{Context, SampledImage};
use gi_host::{Error, KernelVariant};
use gi_shared::camera::{CameraParams, primary_ray, view_projection};
use gi_shared::color::linear_to_srgb;
use gi_shared::gbuffer::GBufferTexel;
use gi_shared::gbuffer_import::{IMPORTED_ID, NormalEncoding};
use gi_shared::octahedral::octahedral_encode;
use gi_shared::packing::f32_to_f16;
use gi_tests::{context, finish_without_validation_messages, load_scene};
use glam::{UVec2, UVec4, Vec2, Vec3, Vec4};

use ash::vk;

const SIZE: u32 = 32;
const EXTENT: vk::Extent2D = vk::Extent2D {
    width: SIZE,
    height: SIZE,
};

/// One way an engine stores its G-buffer.
struct Case {
    name: &'static str,
    conventions: Conventions,
    depth_format: vk::Format,
    depth_layout: vk::ImageLayout,
    normal_format: vk::Format,
    albedo_format: vk::Format,
    motion_format: Option<vk::Format>,
    emissive: bool,
}

fn cases() -> [Case; 3] {
    let pixels = MotionVectors {
        units: MotionUnits::Pixels,
        toward_previous: false,
    };
    [
        Case {
            name: "standard D32, RGBA16F normals, sRGB albedo, RG16F pixel motion",
            conventions: Conventions {
                depth: DepthEncoding::Standard {
                    near: 0.1,
                    far: 100.0,
                },
                normal: NormalEncoding::World,
                motion: pixels,
            },
            depth_format: vk::Format::D32_SFLOAT,
            depth_layout: vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
            normal_format: vk::Format::R16G16B16A16_SFLOAT,
            albedo_format: vk::Format::R8G8B8A8_SRGB,
            motion_format: Some(vk::Format::R16G16_SFLOAT),
            emissive: true,
        },
        Case {
            name: "reversed-Z D32, octahedral RG16 normals, RG32F uv motion to previous",
            conventions: Conventions {
                depth: DepthEncoding::ReversedZ {
                    near: 0.1,
                    far: f32::INFINITY,
                },
                normal: NormalEncoding::Octahedral,
                motion: MotionVectors {
                    units: MotionUnits::Uv,
                    toward_previous: true,
                },
            },
            depth_format: vk::Format::D32_SFLOAT,
            depth_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            normal_format: vk::Format::R16G16_UNORM,
            albedo_format: vk::Format::R8G8B8A8_UNORM,
            motion_format: Some(vk::Format::R32G32_SFLOAT),
            emissive: false,
        },
        Case {
            name: "linear R32F, RGB10A2 normals, no motion",
            conventions: Conventions {
                depth: DepthEncoding::Linear { far: f32::INFINITY },
                normal: NormalEncoding::World,
                motion: pixels,
            },
            depth_format: vk::Format::R32_SFLOAT,
            depth_layout: vk::ImageLayout::GENERAL,
            normal_format: vk::Format::A2B10G10R10_UNORM_PACK32,
            albedo_format: vk::Format::R8G8B8A8_SRGB,
            motion_format: None,
            emissive: true,
        },
    ]
}

fn halves(v: &[f32]) -> Vec<u8> {
    v.iter()
        .flat_map(|x| (f32_to_f16(*x) as u16).to_le_bytes())
        .collect()
}

fn unorm(x: f32, max: f32) -> u32 {
    (x.clamp(0.0, 1.0) * max).round() as u32
}

/// The engine's texels of `ours` in `format`.
fn encode(
    ours: &GBufferData,
    format: vk::Format,
    texel: impl Fn(&GBufferTexel) -> Vec4,
) -> Vec<u8> {
    let values: Vec<Vec4> = ours.texels.iter().map(texel).collect();
    use vk::Format as F;
    match format {
        F::D32_SFLOAT | F::R32_SFLOAT => values.iter().flat_map(|v| v.x.to_le_bytes()).collect(),
        F::R32G32_SFLOAT => values
            .iter()
            .flat_map(|v| [v.x, v.y])
            .flat_map(f32::to_le_bytes)
            .collect(),
        F::R16G16_SFLOAT => halves(&values.iter().flat_map(|v| [v.x, v.y]).collect::<Vec<_>>()),
        F::R16G16B16A16_SFLOAT => {
            halves(&values.iter().flat_map(|v| v.to_array()).collect::<Vec<_>>())
        }
        F::R16G16_UNORM => values
            .iter()
            .flat_map(|v| [v.x, v.y])
            .flat_map(|x| (unorm(x, 65535.0) as u16).to_le_bytes())
            .collect(),
        F::A2B10G10R10_UNORM_PACK32 => values
            .iter()
            .flat_map(|v| {
                let c = |x: f32| unorm(x, 1023.0);
                (c(v.x) | c(v.y) << 10 | c(v.z) << 20 | unorm(v.w, 3.0) << 30).to_le_bytes()
            })
            .collect(),
        F::R8G8B8A8_UNORM => values
            .iter()
            .flat_map(|v| v.to_array().map(|x| unorm(x, 255.0) as u8))
            .collect(),
        F::R8G8B8A8_SRGB => values
            .iter()
            .flat_map(|v| {
                let s = |x: f32| unorm(linear_to_srgb(x), 255.0) as u8;
                [s(v.x), s(v.y), s(v.z), unorm(v.w, 255.0) as u8]
            })
            .collect(),
        _ => panic!("the test does not encode {format:?}"),
    }
}

/// The engine's images of `ours` as `case` stores them.
fn engine_images(ctx: &Context, ours: &GBufferData, case: &Case) -> Vec<SampledImage> {
    let c = &case.conventions;
    let read = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
    let upload = |name: &str, format, layout, texels: Vec<u8>| {
        SampledImage::upload(ctx, name, EXTENT, format, &texels, layout).unwrap()
    };
    let depth = encode(ours, case.depth_format, |t| {
        let d = if t.is_surface() {
            c.depth.encode(t.depth)
        } else {
            c.depth.sky()
        };
        Vec4::splat(d)
    });
    let unorm_normals = case.normal_format != vk::Format::R16G16B16A16_SFLOAT;
    let normal = encode(ours, case.normal_format, |t| {
        let n = t.shading_normal.truncate();
        let v = match c.normal {
            NormalEncoding::World => n.extend(0.0),
            NormalEncoding::Octahedral => octahedral_encode(n).extend(0.0).extend(0.0),
        };
        if unorm_normals {
            v * 0.5 + Vec4::splat(0.5)
        } else {
            v
        }
    });
    let mut images = vec![
        upload("engine depth", case.depth_format, case.depth_layout, depth),
        upload(
            "engine normal",
            case.normal_format,
            vk::ImageLayout::GENERAL,
            normal,
        ),
        upload(
            "engine albedo",
            case.albedo_format,
            read,
            encode(ours, case.albedo_format, |t| t.albedo),
        ),
    ];
    if let Some(format) = case.motion_format {
        let scale = match c.motion.units {
            MotionUnits::Pixels => Vec2::ONE,
            MotionUnits::Uv => Vec2::splat(1.0 / SIZE as f32),
        } * if c.motion.toward_previous { -1.0 } else { 1.0 };
        let motion = encode(ours, format, |t| {
            (Vec2::new(t.motion.x, t.motion.y) * scale)
                .extend(0.0)
                .extend(0.0)
        });
        images.push(upload("engine motion", format, read, motion));
    }
    if case.emissive {
        let format = vk::Format::R16G16B16A16_SFLOAT;
        images.push(upload(
            "engine emissive",
            format,
            read,
            encode(ours, format, |t| t.emissive),
        ));
    }
    images
}

fn external(case: &Case, images: &[SampledImage]) -> ExternalGBuffer {
    let mut rest = images[3..].iter().map(ExternalImage::from);
    ExternalGBuffer {
        depth: (&images[0]).into(),
        normal: (&images[1]).into(),
        albedo: (&images[2]).into(),
        motion: case.motion_format.and_then(|_| rest.next()),
        emissive: if case.emissive { rest.next() } else { None },
        conventions: case.conventions,
    }
}

/// Largest differences seen, per channel.
#[derive(Default, Debug)]
struct Worst {
    depth: f32,
    shading: f32,
    geometric: f32,
    albedo: f32,
    motion: f32,
    emissive: f32,
    planar_pixels: usize,
    surface_pixels: usize,
    /// Pixels off planes (edges) whose rebuilt geometric normal is off ours by more than 0.1.
    edge_misses: usize,
}

fn max_diff(a: Vec4, b: Vec4) -> f32 {
    (a - b).abs().max_element()
}

/// Whether our pixel `(x, y)` and its four neighbours are surface points of one plane (within
/// 1e-4 of their depth): where a normal rebuilt from depth must be the geometric normal.
fn on_a_plane(camera: &CameraParams, ours: &GBufferData, x: u32, y: u32) -> bool {
    if x == 0 || y == 0 || x + 1 >= SIZE || y + 1 >= SIZE {
        return false;
    }
    let point = |i: u32, j: u32| {
        let ray = primary_ray(camera, UVec2::new(i, j), camera.jitter());
        Vec3::from_array(ray.origin) + Vec3::from_array(ray.direction) * ours.texel(i, j).depth
    };
    let p = point(x, y);
    let n = ours.texel(x, y).geometric_normal.truncate();
    [(x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)]
        .iter()
        .all(|&(i, j)| {
            let t = ours.texel(i, j);
            t.is_surface() && (point(i, j) - p).dot(n).abs() <= 1e-4 * t.depth
        })
}

fn compare(
    case: &Case,
    camera: &CameraParams,
    ours: &GBufferData,
    imported: &GBufferData,
) -> Worst {
    let c = &case.conventions;
    let mut w = Worst::default();
    let mut surfaces = 0;
    for y in 0..SIZE {
        for x in 0..SIZE {
            let (o, i) = (ours.texel(x, y), imported.texel(x, y));
            let at = format!("{}: pixel ({x}, {y})", case.name);
            assert_eq!(o.is_surface(), i.is_surface(), "{at}: sky");
            if !o.is_surface() {
                assert_eq!(*i, GBufferTexel::SKY, "{at}");
                continue;
            }
            surfaces += 1;
            let z = o.depth;
            let depth_bound = match c.depth {
                DepthEncoding::Standard { .. } => 1e-5 * z * z,
                DepthEncoding::ReversedZ { .. } => 1e-6 * z,
                DepthEncoding::Linear { .. } => 0.0,
            };
            let d = (i.depth - z).abs();
            assert!(d <= depth_bound, "{at}: depth {} vs {z}", i.depth);
            w.depth = w.depth.max(d / z);

            let normal_bound = if case.normal_format == vk::Format::A2B10G10R10_UNORM_PACK32 {
                3e-3
            } else {
                1e-3
            };
            let d = max_diff(i.shading_normal, o.shading_normal);
            assert!(
                d <= normal_bound,
                "{at}: shading {} vs {}",
                i.shading_normal,
                o.shading_normal
            );
            w.shading = w.shading.max(d);
            assert_eq!(i.geometric_normal.w, 1.0, "{at}");
            if on_a_plane(camera, ours, x, y) {
                let d = max_diff(i.geometric_normal, o.geometric_normal);
                assert!(
                    d <= 2e-3,
                    "{at}: geometric {} vs {}",
                    i.geometric_normal,
                    o.geometric_normal
                );
                w.geometric = w.geometric.max(d);
                w.planar_pixels += 1;
            } else if max_diff(i.geometric_normal, o.geometric_normal) > 0.1 {
                w.edge_misses += 1;
            }

            let albedo_bound = if case.albedo_format == vk::Format::R8G8B8A8_SRGB {
                2.0 / 255.0
            } else {
                0.5 / 255.0
            };
            let d = max_diff(i.albedo, o.albedo);
            assert!(
                d <= albedo_bound,
                "{at}: albedo {} vs {}",
                i.albedo,
                o.albedo
            );
            w.albedo = w.albedo.max(d);

            let m = Vec2::new(o.motion.x, o.motion.y);
            let motion_bound = match case.motion_format {
                Some(vk::Format::R16G16_SFLOAT) => m.abs().max_element() / 2048.0 + 1e-4,
                Some(_) => 1e-4,
                None => 1e-3,
            };
            let d = (Vec2::new(i.motion.x, i.motion.y) - m).abs().max_element();
            assert!(
                d <= motion_bound,
                "{at}: motion {} vs {}",
                i.motion,
                o.motion
            );
            w.motion = w.motion.max(d);
            assert!(
                (i.motion.z - o.motion.z).abs() <= depth_bound + 1e-5 * o.motion.z,
                "{at}: previous depth {} vs {}",
                i.motion.z,
                o.motion.z
            );
            assert_eq!(i.motion.w, o.motion.w, "{at}");

            let expected = if case.emissive {
                o.emissive
            } else {
                Vec4::ZERO
            };
            let d = max_diff(i.emissive, expected);
            assert!(
                d <= 1e-6 * expected.max_element(),
                "{at}: emission {} vs {expected}",
                i.emissive
            );
            w.emissive = w.emissive.max(d);
            assert_eq!(
                i.ids,
                UVec4::new(IMPORTED_ID, IMPORTED_ID, IMPORTED_ID, 1),
                "{at}"
            );
        }
    }
    assert!(
        surfaces > (SIZE * SIZE / 2) as usize,
        "the box fills the view"
    );
    assert!(
        w.planar_pixels * 2 > surfaces,
        "{}: {} of {surfaces} pixels on planes",
        case.name,
        w.planar_pixels
    );
    w.surface_pixels = surfaces;
    // Off planes, a pixel with no neighbour on its plane along an axis (a corner, a feature one
    // pixel wide) gets another plane's normal: 57 of 961 surface pixels here (6%).
    assert!(
        w.edge_misses * 100 <= surfaces * 8,
        "{}: {} of {surfaces} geometric normals off by more than 0.1",
        case.name,
        w.edge_misses
    );
    w
}

/// The Cornell box's camera at 32 × 32, jittered, having moved since the previous frame.
fn camera(scene: &gi_host::scene::Scene) -> CameraParams {
    let mut camera = scene_camera(scene, SIZE, SIZE);
    camera.jitter = [0.25, -0.125];
    let mut previous = camera;
    previous.position = (camera.position() + Vec3::new(0.06, -0.03, 0.1)).to_array();
    previous.view_proj = view_projection(&previous);
    camera.with_previous(&previous)
}

struct Rendered {
    ctx: Context,
    camera: CameraParams,
    ours: GBufferData,
}

/// Our G-buffer of the Cornell box, and the context it was made in.
fn render_ours() -> Rendered {
    let ctx = context(KernelVariant::Software);
    let scene = load_scene("cornell-box.gltf");
    let bvh = Bvh::new(&scene).unwrap();
    let shading = ShadingData::new(&scene).unwrap();
    let lights = LightSet::new(&scene, None, false);
    let gpu = GpuScene::upload(&ctx, &scene, Some(&bvh), &shading, &lights).unwrap();
    let camera = camera(&scene);
    let images = GBufferImages::new(&ctx, SIZE, SIZE).unwrap();
    GBufferPass::new(&ctx)
        .unwrap()
        .run(&ctx, &gpu, &camera, &images)
        .unwrap();
    let ours = images.read_back(&ctx).unwrap();
    assert!(
        ours.texels.iter().any(|t| t.motion.x.abs() > 0.5),
        "the camera moved by pixels"
    );
    assert!(
        ours.texels.iter().any(|t| t.emissive.max_element() > 0.0),
        "the light is in view"
    );
    Rendered { ctx, camera, ours }
}

#[test]
fn imported_g_buffers_match_ours_channel_by_channel() {
    let Rendered { ctx, camera, ours } = render_ours();
    let import = GBufferImport::new(&ctx).unwrap();
    let out = GBufferImages::new(&ctx, SIZE, SIZE).unwrap();
    for case in cases() {
        let images = engine_images(&ctx, &ours, &case);
        let engine = external(&case, &images);
        ctx.submit(|cmd| import.record(&ctx, cmd, &engine, &camera, &out))
            .unwrap()
            .unwrap();
        let imported = out.read_back(&ctx).unwrap();
        let w = compare(&case, &camera, &ours, &imported);
        println!(
            "{}: worst depth {:.1e} relative, shading normal {:.1e}, geometric normal {:.1e} \
             ({} of {} pixels on planes; off planes {} beyond 0.1), albedo {:.2}/255, motion \
             {:.1e} px, emission {:.1e}",
            case.name,
            w.depth,
            w.shading,
            w.geometric,
            w.planar_pixels,
            w.surface_pixels,
            w.edge_misses,
            w.albedo * 255.0,
            w.motion,
            w.emissive
        );
    }
    drop(out);
    drop(import);
    finish_without_validation_messages(ctx);
}

/// The message of an import that must fail.
fn refusal(
    ctx: &Context,
    import: &GBufferImport,
    engine: &ExternalGBuffer,
    camera: &CameraParams,
) -> String {
    let out = GBufferImages::new(ctx, SIZE, SIZE).unwrap();
    match ctx
        .submit(|cmd| import.record(ctx, cmd, engine, camera, &out))
        .unwrap()
    {
        Err(e @ Error::InvalidArgument { .. }) => e.to_string(),
        other => panic!("not refused: {other:?}"),
    }
}

#[test]
fn images_the_import_cannot_read_are_refused_by_name() {
    let Rendered { ctx, camera, ours } = render_ours();
    let import = GBufferImport::new(&ctx).unwrap();
    let [case, ..] = cases();
    let images = engine_images(&ctx, &ours, &case);
    let good = external(&case, &images);

    let mut bad = good;
    bad.normal.format = vk::Format::R8_UNORM;
    let why = refusal(&ctx, &import, &bad, &camera);
    assert!(
        why.contains("normal image") && why.contains("R8_UNORM"),
        "{why}"
    );

    // RGBA16F holds no octahedral normals (the encoding decides the accepted formats).
    let mut bad = good;
    bad.conventions.normal = NormalEncoding::Octahedral;
    let why = refusal(&ctx, &import, &bad, &camera);
    assert!(
        why.contains("normal image") && why.contains("R16G16B16A16_SFLOAT"),
        "{why}"
    );

    let mut bad = good;
    bad.depth.layout = vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    let why = refusal(&ctx, &import, &bad, &camera);
    assert!(
        why.contains("depth image") && why.contains("DEPTH_STENCIL_ATTACHMENT_OPTIMAL"),
        "{why}"
    );

    let mut bad = good;
    if let Some(m) = &mut bad.motion {
        m.extent.width = SIZE / 2;
    }
    let why = refusal(&ctx, &import, &bad, &camera);
    assert!(
        why.contains("motion image") && why.contains("16×32"),
        "{why}"
    );

    let mut bad = good;
    bad.conventions.depth = DepthEncoding::Standard {
        near: 1.0,
        far: 0.5,
    };
    let why = refusal(&ctx, &import, &bad, &camera);
    assert!(
        why.contains("depth image") && why.contains("far > near"),
        "{why}"
    );

    drop(images);
    drop(import);
    finish_without_validation_messages(ctx);
}
