//! The G-buffer pass on the host: camera set-up, the storage images, the `gbuffer::gbuffer`
//! kernel in either tracing variant, read-back, the CPU reference of the same per-pixel function,
//! and debug PNGs.
//!
//! The GI passes read the G-buffer's images ([`GBufferImages`]), never the scene, so that an
//! engine can bring its own G-buffer in the same formats (see `gi_shared::gbuffer` for the formats
//! and what each channel holds).

use crate::error::{Error, Result};
use crate::frame::Recorder;
use crate::scene::Scene;
use crate::scene::bvh::Bvh;
use crate::scene::gpu_data::ShadingData;
use crate::scene::upload::GpuScene;
use crate::vulkan::{Buffer, Context, Image, Kernel, KernelModule, submit_timed};
use ash::vk;
use gi_shared::camera::{CameraParams, primary_ray};
use gi_shared::color::linear_to_srgb;
use gi_shared::gbuffer::{GBUFFER_TILE, GBufferTexel, PreviousTransform, gbuffer_texel};
use gi_shared::hash::pcg_chain;
use gi_shared::packing::f16_to_f32;
use glam::{UVec2, UVec4, Vec3, Vec4};
use std::path::{Path, PathBuf};

/// Vertical field of view of the camera of a scene without one: 45°.
pub const DEFAULT_FOV_Y: f32 = std::f32::consts::FRAC_PI_4;

/// The camera for a `width × height` image of `scene`: its first glTF camera (with the image's
/// aspect ratio, not the file's), or, for a scene without cameras, one that looks at the centre
/// of the scene's bounds from slightly above the +Z side, far enough for the bounding sphere to
/// fit the vertical field of view [`DEFAULT_FOV_Y`]. Static: the previous frame is this one.
pub fn scene_camera(scene: &Scene, width: u32, height: u32) -> CameraParams {
    match scene.cameras.first() {
        Some(c) => CameraParams::new(c.position(), c.forward(), c.up(), c.yfov, width, height),
        None => {
            let center = scene.bounds.center();
            let radius = (0.5 * scene.bounds.size().length()).max(1e-3);
            let distance = radius / (0.5 * DEFAULT_FOV_Y).sin();
            let back = Vec3::new(0.0, 0.25, 1.0).normalize();
            CameraParams::new(
                center + back * distance,
                -back,
                Vec3::Y,
                DEFAULT_FOV_Y,
                width,
                height,
            )
        }
    }
}

/// Vulkan formats of the G-buffer images, in binding order: depth, geometric normal, shading
/// normal, albedo, emissive, motion, ids (what each holds: `gi_shared::gbuffer`).
pub const FORMATS: [vk::Format; 7] = [
    vk::Format::R32_SFLOAT,
    vk::Format::R16G16B16A16_SFLOAT,
    vk::Format::R16G16B16A16_SFLOAT,
    vk::Format::R8G8B8A8_UNORM,
    vk::Format::R16G16B16A16_SFLOAT,
    vk::Format::R32G32B32A32_SFLOAT,
    vk::Format::R32G32B32A32_UINT,
];

/// Names of the G-buffer images, in binding order.
pub const IMAGE_NAMES: [&str; 7] = [
    "depth",
    "geometric normal",
    "shading normal",
    "albedo",
    "emissive",
    "motion",
    "ids",
];

/// The G-buffer's storage images, all `width × height`, in the `GENERAL` layout.
pub struct GBufferImages {
    /// Linear depth.
    pub depth: Image,
    /// Geometric normal.
    pub geometric_normal: Image,
    /// Shading normal.
    pub shading_normal: Image,
    /// Albedo.
    pub albedo: Image,
    /// Emission.
    pub emissive: Image,
    /// Motion vectors.
    pub motion: Image,
    /// Instance, primitive and material ids, front face.
    pub ids: Image,
}

crate::bindings! {
    /// The G-buffer pass's set 0 (`kernels::gbuffer::gbuffer`): [`GBufferImages::bindings`].
    pub struct GBufferBindings<'a> {
        /// The camera ([`CameraParams`]).
        camera: &'a Buffer,
        /// Linear depth.
        depth: &'a Image,
        /// Geometric normal.
        geometric_normal: &'a Image,
        /// Shading normal.
        shading_normal: &'a Image,
        /// Albedo.
        albedo: &'a Image,
        /// Emission.
        emissive: &'a Image,
        /// Motion vectors.
        motion: &'a Image,
        /// Instance and primitive ids.
        ids: &'a Image,
        /// The instances' previous transforms.
        previous_transforms: &'a Buffer,
    }
}

impl GBufferImages {
    /// Creates the images for a `width × height` G-buffer.
    pub fn new(ctx: &Context, width: u32, height: u32) -> Result<Self> {
        let made = IMAGE_NAMES
            .iter()
            .zip(FORMATS)
            .map(|(name, format)| {
                Image::new(ctx, &format!("G-buffer {name}"), width, height, format)
            })
            .collect::<Result<Vec<Image>>>()?;
        let [
            depth,
            geometric_normal,
            shading_normal,
            albedo,
            emissive,
            motion,
            ids,
        ] = made
            .try_into()
            .map_err(|unexpected: Vec<Image>| Error::InvalidArgument {
                name: "G-buffer",
                why: format!("{} images made for 7", unexpected.len()),
            })?;
        Ok(Self {
            depth,
            geometric_normal,
            shading_normal,
            albedo,
            emissive,
            motion,
            ids,
        })
    }

    /// The images in binding order (formats in [`FORMATS`], names in [`IMAGE_NAMES`]).
    pub fn all(&self) -> [&Image; 7] {
        [
            &self.depth,
            &self.geometric_normal,
            &self.shading_normal,
            &self.albedo,
            &self.emissive,
            &self.motion,
            &self.ids,
        ]
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.depth.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.depth.height
    }

    /// The G-buffer pass's set 0 writing these images, with the pass's `camera` and the
    /// instances' `previous_transforms`.
    pub fn bindings<'a>(
        &'a self,
        camera: &'a Buffer,
        previous_transforms: &'a Buffer,
    ) -> GBufferBindings<'a> {
        GBufferBindings {
            camera,
            depth: &self.depth,
            geometric_normal: &self.geometric_normal,
            shading_normal: &self.shading_normal,
            albedo: &self.albedo,
            emissive: &self.emissive,
            motion: &self.motion,
            ids: &self.ids,
            previous_transforms,
        }
    }

    /// Copies every image to the host (after the pass that wrote them was submitted).
    pub fn read_back(&self, ctx: &Context) -> Result<GBufferData> {
        let [depth, gn, sn, albedo, emissive, motion, ids] = self.all();
        let depth = depth.read_back(ctx)?;
        let gn = gn.read_back(ctx)?;
        let sn = sn.read_back(ctx)?;
        let albedo = albedo.read_back(ctx)?;
        let emissive = emissive.read_back(ctx)?;
        let motion = motion.read_back(ctx)?;
        let ids = ids.read_back(ctx)?;
        // Texels as the device wrote them (little-endian, like every host we run on).
        let depth: Vec<f32> = bytemuck::pod_collect_to_vec(&depth);
        let halves = |b: &[u8]| -> Vec<Vec4> {
            bytemuck::pod_collect_to_vec::<u8, [u16; 4]>(b)
                .into_iter()
                .map(|h| Vec4::from_array(h.map(|x| f16_to_f32(u32::from(x)))))
                .collect()
        };
        let (gn, sn, emissive) = (halves(&gn), halves(&sn), halves(&emissive));
        let albedo: Vec<[u8; 4]> = bytemuck::pod_collect_to_vec(&albedo);
        let motion: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&motion);
        let ids: Vec<[u32; 4]> = bytemuck::pod_collect_to_vec(&ids);
        let texels = (0..depth.len())
            .map(|i| GBufferTexel {
                depth: depth[i],
                geometric_normal: gn[i],
                shading_normal: sn[i],
                albedo: Vec4::from_array(albedo[i].map(|c| f32::from(c) / 255.0)),
                emissive: emissive[i],
                motion: Vec4::from_array(motion[i]),
                ids: UVec4::from_array(ids[i]),
            })
            .collect();
        Ok(GBufferData {
            width: self.width(),
            height: self.height(),
            texels,
        })
    }
}

/// A G-buffer on the host: every image's pixel, row by row from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct GBufferData {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` pixels; as read back, channels carry their image format's precision.
    pub texels: Vec<GBufferTexel>,
}

impl GBufferData {
    /// The pixel at column `x`, row `y`.
    ///
    /// # Panics
    /// If `(x, y)` is outside the image.
    pub fn texel(&self, x: u32, y: u32) -> &GBufferTexel {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside the G-buffer"
        );
        &self.texels[(y * self.width + x) as usize]
    }
}

/// The G-buffer pass (`gbuffer::gbuffer`): the camera's primary rays traced into
/// [`GBufferImages`]. The GI frame and the cache view record it; [`GBufferPass`] runs it alone.
pub struct GBufferKernel {
    kernel: Kernel,
}

impl GBufferKernel {
    /// Creates the pipeline from `module`.
    pub fn new(ctx: &Context, module: &KernelModule) -> Result<Self> {
        Ok(Self {
            kernel: Kernel::new::<GBufferBindings>(ctx, module, "gbuffer::gbuffer", 0)?,
        })
    }

    /// Records the pass GBuffer: the camera `camera` holds (a [`CameraParams`] of the images'
    /// size) seen into `images`.
    pub fn record(
        &self,
        rec: &mut Recorder<'_>,
        scene: &GpuScene,
        camera: &Buffer,
        images: &GBufferImages,
    ) -> Result<()> {
        let groups = [
            images.width().div_ceil(GBUFFER_TILE),
            images.height().div_ceil(GBUFFER_TILE),
            1,
        ];
        let bindings = images.bindings(camera, scene.previous_transforms());
        rec.pass("GBuffer", |rec| {
            rec.dispatch_traced(&self.kernel, scene.sets(), &bindings, &[], groups)
        })
    }
}

/// The G-buffer pass run on its own, with its camera buffer.
pub struct GBufferPass {
    kernel: GBufferKernel,
    camera: Buffer,
}

impl GBufferPass {
    /// Creates the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let module = KernelModule::new(ctx)?;
        let kernel = GBufferKernel::new(ctx, &module)?;
        let camera = Buffer::parameters(ctx, "G-buffer camera", &[CameraParams::default()])?;
        Ok(Self { kernel, camera })
    }

    /// Renders the G-buffer of `camera` into `images`, submits and waits; returns the GPU time in
    /// milliseconds when the device has compute timestamps. The camera's image size must be the
    /// images'.
    pub fn run(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        camera: &CameraParams,
        images: &GBufferImages,
    ) -> Result<Option<f64>> {
        let (width, height) = (images.width(), images.height());
        if camera.image_size != [width, height] {
            return Err(Error::InvalidArgument {
                name: "camera",
                why: format!(
                    "image size {:?} differs from the G-buffer's {width}×{height}",
                    camera.image_size
                ),
            });
        }
        // The previous submission has finished (submissions wait), so the buffer is free.
        self.camera.write(bytemuck::bytes_of(camera))?;
        submit_timed(ctx, "gbuffer", |cmd| {
            let mut rec = Recorder::new(ctx, cmd, None);
            self.kernel.record(&mut rec, scene, &self.camera, images)?;
            rec.finish();
            Ok(())
        })
    }
}

/// The G-buffer computed on the CPU by the kernel's per-pixel function, tracing with `bvh` (built
/// from the same scene as `shading`), with the instances' previous transforms `previous` (as
/// [`crate::scene::upload::previous_transforms`] makes them; `&[]` for none). Channels keep full
/// `f32` precision.
pub fn render_on_cpu(
    shading: &ShadingData,
    bvh: &Bvh,
    camera: &CameraParams,
    previous: &[PreviousTransform],
) -> GBufferData {
    let [width, height] = camera.image_size;
    let texels = (0..height)
        .flat_map(|y| (0..width).map(move |x| UVec2::new(x, y)))
        .map(|pixel| {
            let ray = primary_ray(camera, pixel, camera.jitter());
            let hit = bvh.closest_hit(shading, &ray);
            gbuffer_texel(
                camera,
                &ray,
                &hit,
                previous,
                shading.surfaces(),
                &shading.texels[..],
            )
        })
        .collect();
    GBufferData {
        width,
        height,
        texels,
    }
}

/// A random colour for the pixel's instance (and primitive), black for sky.
fn id_colour(t: &GBufferTexel, with_primitive: bool) -> [u8; 3] {
    if !t.is_surface() {
        return [0; 3];
    }
    let h = pcg_chain([t.ids.x, if with_primitive { t.ids.y } else { 0 }]);
    // Away from black, which is sky.
    [h, h >> 8, h >> 16].map(|c| 64 + (c & 0xff) as u8 % 192)
}

fn unit(x: f32) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// Writes each G-buffer image of `data` to an 8-bit sRGB PNG in `dir` (created if missing) and
/// returns the files' paths:
///
/// * `depth.png`: near white, far dark (linear between the nearest and farthest surface), sky
///   black;
/// * `geometric_normal.png`, `shading_normal.png`: world-space normals as `0.5 + 0.5 · n` (+X red,
///   +Y green, +Z blue), sky black;
/// * `albedo.png`: the linear albedo, sRGB-encoded;
/// * `emissive.png`: the emitted radiance tone-mapped by `e / (1 + e)`, sRGB-encoded;
/// * `motion.png`: `0.5 + 0.5 · m / max |m|` in red (x) and green (y), blue 0.5: a static camera
///   gives a flat grey; invalid pixels (sky, behind the previous camera) black;
/// * `instance_ids.png`, `primitive_ids.png`: a random colour per instance and per (instance,
///   primitive) pair, sky black.
pub fn write_debug_pngs(data: &GBufferData, dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::Image {
        path: dir.to_path_buf(),
        why: format!("cannot create the directory: {e}"),
    })?;
    let surfaces = data.texels.iter().filter(|t| t.is_surface());
    let (near, far) = surfaces.fold((f32::INFINITY, 0.0f32), |(n, f), t| {
        (n.min(t.depth), f.max(t.depth))
    });
    let max_motion = data
        .texels
        .iter()
        .filter(|t| t.motion.w > 0.0)
        .map(|t| t.motion.x.abs().max(t.motion.y.abs()))
        .fold(0.0f32, f32::max);
    let normal = |n: Vec4| -> [u8; 3] {
        if n.w > 0.0 {
            [n.x, n.y, n.z].map(|c| unit(0.5 + 0.5 * c))
        } else {
            [0; 3]
        }
    };
    let srgb = |c: Vec4| -> [u8; 3] { [c.x, c.y, c.z].map(|v| unit(linear_to_srgb(v))) };
    type View<'a> = (&'a str, Box<dyn Fn(&GBufferTexel) -> [u8; 3] + 'a>);
    let views: Vec<View<'_>> = vec![
        (
            "depth",
            Box::new(move |t: &GBufferTexel| {
                if !t.is_surface() {
                    return [0; 3];
                }
                let range = (far - near).max(1e-6);
                [unit(1.0 - 0.8 * (t.depth - near) / range); 3]
            }),
        ),
        (
            "geometric_normal",
            Box::new(move |t| normal(t.geometric_normal)),
        ),
        (
            "shading_normal",
            Box::new(move |t| normal(t.shading_normal)),
        ),
        ("albedo", Box::new(move |t| srgb(t.albedo))),
        (
            "emissive",
            Box::new(move |t| srgb(t.emissive / (Vec4::ONE + t.emissive))),
        ),
        (
            "motion",
            Box::new(move |t: &GBufferTexel| {
                if t.motion.w <= 0.0 {
                    return [0; 3];
                }
                let scale = if max_motion > 0.0 {
                    0.5 / max_motion
                } else {
                    0.0
                };
                [
                    unit(0.5 + scale * t.motion.x),
                    unit(0.5 + scale * t.motion.y),
                    128,
                ]
            }),
        ),
        ("instance_ids", Box::new(|t| id_colour(t, false))),
        ("primitive_ids", Box::new(|t| id_colour(t, true))),
    ];
    let mut paths = Vec::with_capacity(views.len());
    for (name, view) in views {
        let path = dir.join(format!("{name}.png"));
        let pixels: Vec<u8> = data.texels.iter().flat_map(&view).collect();
        image::save_buffer_with_format(
            &path,
            &pixels,
            data.width,
            data.height,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| Error::Image {
            path: path.clone(),
            why: format!("cannot write PNG: {e}"),
        })?;
        paths.push(path);
    }
    Ok(paths)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::test_scene;
    use gi_shared::camera::{project, to_clip};

    #[test]
    fn the_scene_camera_comes_from_the_file() {
        let s = test_scene("cornell-box.gltf");
        let c = scene_camera(&s, 64, 48);
        assert_eq!(c.position(), Vec3::new(0.0, 1.0, 3.9));
        assert!((c.forward() - Vec3::NEG_Z).length() < 1e-6);
        assert!((c.up() - Vec3::Y).length() < 1e-6);
        assert!((c.tan_half_fov_y - (0.5 * s.cameras[0].yfov).tan()).abs() < 1e-6);
        // The image's aspect ratio, not the file's 1.0.
        assert_eq!(c.aspect, 64.0 / 48.0);
    }

    #[test]
    fn without_a_camera_the_whole_scene_is_in_view() {
        let mut s = test_scene("cornell-box.gltf");
        s.cameras.clear();
        let c = scene_camera(&s, 64, 48);
        let uv = project(&c.view_proj, s.bounds.center());
        assert!((uv - glam::Vec2::splat(0.5)).length() < 1e-5, "{uv}");
        for i in 0..8 {
            let corner = Vec3::select(
                glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0),
                s.bounds.max,
                s.bounds.min,
            );
            assert!(to_clip(&c.view_proj, corner).w > 0.0);
            let uv = project(&c.view_proj, corner);
            assert!(
                uv.cmpge(glam::Vec2::ZERO).all() && uv.cmple(glam::Vec2::ONE).all(),
                "corner {corner} at {uv}"
            );
        }
    }

    #[test]
    fn debug_pngs_of_a_cpu_g_buffer() {
        let s = test_scene("textured.gltf");
        let shading = ShadingData::new(&s).unwrap();
        let bvh = crate::scene::bvh::Bvh::new(&s).unwrap();
        let data = render_on_cpu(&shading, &bvh, &scene_camera(&s, 16, 12), &[]);
        assert_eq!(data.texels.len(), 16 * 12);
        assert!(data.texels.iter().any(|t| t.is_surface()));
        assert!(
            data.texels.iter().any(|t| !t.is_surface()),
            "the sky is in view"
        );
        let dir = std::env::temp_dir().join(format!("gi-gbuffer-unit-{}", std::process::id()));
        let files = write_debug_pngs(&data, &dir).unwrap();
        assert_eq!(files.len(), 8);
        for f in &files {
            let (w, h) = image::image_dimensions(f).unwrap();
            assert_eq!((w, h), (16, 12), "{}", f.display());
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
