//! The reference path tracer on the host: the `path_tracer::path_tracer` kernel in either tracing
//! variant, progressive accumulation over N dispatches (one path per pixel each), read-back as an
//! [`HdrImage`], and the CPU running the same per-path code (`gi_shared::path_tracer`) with the
//! host's BVH.

use crate::error::{Error, Result};
use crate::image_io::HdrImage;
use crate::scene::bvh::Bvh;
use crate::scene::gpu_data::{GpuShadingData, ShadingData};
use crate::scene::lights::GpuLights;
use crate::scene::upload::SceneGeometry;
use crate::vulkan::{
    BindingKind, Buffer, Context, Kernel, KernelModule, Resource, compute_barrier, submit_timed,
};
use ash::vk;
use gi_shared::camera::CameraParams;
use gi_shared::layout::MAX_STORAGE_BUFFER_BYTES;
use gi_shared::lights::GpuLight;
use gi_shared::path_tracer::{
    MAX_BOUNCES, PATH_TRACER_TILE, PathTracerParams, begin_path, finite_radiance, shade,
};
use glam::{UVec2, Vec3};

/// Samples per submission: few enough for a responsive progress report and to stay well inside a
/// driver's submission timeout, enough to amortise the submission.
const SAMPLES_PER_SUBMIT: u32 = 8;

/// What to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathTracerSettings {
    /// Paths per pixel.
    pub samples: u32,
    /// Reflections per path (0: emitters only, 1: direct lighting); at most
    /// [`MAX_BOUNCES`].
    pub max_bounces: u32,
    /// Factor on every surface's emission.
    pub emissive_multiplier: f32,
    /// Constant sky radiance (zero for none); unused with an environment image.
    pub sky: Vec3,
    /// Seed of the random streams.
    pub seed: u32,
}

impl Default for PathTracerSettings {
    /// 64 paths per pixel, 30 bounces (as AMD's reference), no sky, emission as in the file.
    fn default() -> Self {
        Self {
            samples: 64,
            max_bounces: 30,
            emissive_multiplier: 1.0,
            sky: Vec3::ZERO,
            seed: 0,
        }
    }
}

impl PathTracerSettings {
    /// The kernel's push constants for sample `sample_index` with `light_count` lights and an
    /// environment of `environment_size` texels (zero for none).
    pub fn params(
        &self,
        light_count: u32,
        sample_index: u32,
        environment_size: [u32; 2],
    ) -> PathTracerParams {
        PathTracerParams {
            sky: self.sky.to_array(),
            sample_index,
            max_bounces: self.max_bounces.min(MAX_BOUNCES),
            emissive_multiplier: self.emissive_multiplier,
            light_count,
            seed: self.seed,
            environment_size,
            _pad: [0; 2],
        }
    }
}

/// An equirectangular environment image in the kernel's layout (see
/// `gi_shared::path_tracer::sky_radiance` for its orientation).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Environment {
    /// Width and height in texels; zero for none.
    pub size: [u32; 2],
    /// Texels row by row from the top, RGB and an unused fourth channel.
    pub texels: Vec<[f32; 4]>,
}

impl Environment {
    /// The environment of an equirectangular image.
    pub fn from_image(image: &HdrImage) -> Self {
        Self {
            size: [image.width(), image.height()],
            texels: image
                .pixels()
                .iter()
                .map(|p| [p[0], p[1], p[2], 0.0])
                .collect(),
        }
    }
}

/// A finished render.
#[derive(Clone, Debug)]
pub struct Render {
    /// Mean radiance per pixel.
    pub image: HdrImage,
    /// GPU time of all dispatches in milliseconds, when the device has compute timestamps.
    pub gpu_ms: Option<f64>,
}

/// The `path_tracer::path_tracer` pipeline, its camera buffer and the environment image.
pub struct PathTracerPass {
    kernel: Kernel,
    camera: Buffer,
    /// The environment's texels, or a one-texel placeholder.
    environment: Buffer,
    environment_size: [u32; 2],
}

impl PathTracerPass {
    /// Creates the pipeline for the geometry's binding layout.
    pub fn new(ctx: &Context, geometry: &SceneGeometry) -> Result<Self> {
        let module = KernelModule::new(ctx)?;
        let mut bindings = geometry.binding_kinds();
        bindings.push(BindingKind::StorageBuffer);
        bindings.extend(GpuShadingData::binding_kinds());
        bindings.extend([BindingKind::StorageBuffer; 3]);
        let kernel = Kernel::new(
            ctx,
            &module,
            "path_tracer::path_tracer",
            &bindings,
            std::mem::size_of::<PathTracerParams>() as u32,
        );
        module.destroy(ctx);
        let kernel = kernel?;
        let usage = vk::BufferUsageFlags::empty();
        let camera = match Buffer::from_slice(
            ctx,
            "path tracer camera",
            &[CameraParams::default()],
            usage,
        ) {
            Ok(c) => c,
            Err(e) => {
                kernel.destroy(ctx);
                return Err(e);
            }
        };
        match Buffer::from_slice(ctx, "no environment", &[[0.0f32; 4]], usage) {
            Ok(environment) => Ok(Self {
                kernel,
                camera,
                environment,
                environment_size: [0; 2],
            }),
            Err(e) => {
                camera.destroy(ctx);
                kernel.destroy(ctx);
                Err(e)
            }
        }
    }

    /// Lights escaping rays with `environment` instead of the constant sky (from the next render
    /// on); `None` goes back to the constant sky. An environment must fit one storage binding
    /// (`MAX_STORAGE_BUFFER_BYTES`: up to 4096 × 2048 texels).
    pub fn set_environment(
        &mut self,
        ctx: &Context,
        environment: Option<&Environment>,
    ) -> Result<()> {
        let usage = vk::BufferUsageFlags::empty();
        if let Some(e) = environment {
            let bytes = std::mem::size_of_val(e.texels.as_slice()) as u64;
            if bytes > MAX_STORAGE_BUFFER_BYTES as u64 {
                return Err(Error::InvalidArgument {
                    name: "environment",
                    why: format!(
                        "{}x{} texels take {bytes} bytes, more than the {} MiB a storage buffer \
                         binding may hold on every device: use a smaller image",
                        e.size[0],
                        e.size[1],
                        MAX_STORAGE_BUFFER_BYTES >> 20
                    ),
                });
            }
        }
        let (buffer, size) = match environment {
            Some(e)
                if !e.texels.is_empty()
                    && e.size[0] as usize * e.size[1] as usize == e.texels.len() =>
            {
                (
                    Buffer::from_slice(ctx, "environment", &e.texels, usage)?,
                    e.size,
                )
            }
            Some(e) => {
                return Err(Error::InvalidArgument {
                    name: "environment",
                    why: format!("{} texels for {:?}", e.texels.len(), e.size),
                });
            }
            None => (
                Buffer::from_slice(ctx, "no environment", &[[0.0f32; 4]], usage)?,
                [0; 2],
            ),
        };
        std::mem::replace(&mut self.environment, buffer).destroy(ctx);
        self.environment_size = size;
        Ok(())
    }

    /// Renders `settings.samples` paths per pixel of `camera`'s image, calling `progress(done,
    /// total)` after each submission, and returns the mean.
    #[allow(
        clippy::too_many_arguments,
        reason = "the scene's three device parts, the view, the settings and the callback"
    )]
    pub fn render(
        &mut self,
        ctx: &Context,
        geometry: &SceneGeometry,
        shading: &GpuShadingData,
        lights: &GpuLights,
        camera: &CameraParams,
        settings: &PathTracerSettings,
        mut progress: impl FnMut(u32, u32),
    ) -> Result<Render> {
        let [width, height] = camera.image_size;
        if width == 0 || height == 0 || settings.samples == 0 {
            return Err(Error::InvalidArgument {
                name: "path tracer",
                why: format!(
                    "{width}x{height} pixels, {} samples: nothing to render",
                    settings.samples
                ),
            });
        }
        self.camera.write(bytemuck::bytes_of(camera))?;
        let pixels = width as usize * height as usize;
        let mut accumulation = Buffer::zeroed::<[f32; 4]>(ctx, "path tracer accumulation", pixels)?;
        let groups = [
            width.div_ceil(PATH_TRACER_TILE),
            height.div_ceil(PATH_TRACER_TILE),
            1,
        ];
        let mut total_ms: Option<f64> = Some(0.0);
        let mut done = 0;
        let outcome = (|| -> Result<()> {
            while done < settings.samples {
                let batch = SAMPLES_PER_SUBMIT.min(settings.samples - done);
                let mut resources = geometry.resources();
                resources.push(Resource::Buffer(&self.camera));
                resources.extend(shading.resources());
                resources.push(lights.resource());
                resources.push(Resource::Buffer(&self.environment));
                resources.push(Resource::Buffer(&accumulation));
                let ms = submit_timed(ctx, "path tracer", |cmd| {
                    for s in 0..batch {
                        if s > 0 {
                            compute_barrier(ctx, cmd);
                        }
                        let params =
                            settings.params(lights.count(), done + s, self.environment_size);
                        self.kernel.dispatch(
                            ctx,
                            cmd,
                            &resources,
                            bytemuck::bytes_of(&params),
                            groups,
                        )?;
                    }
                    Ok(())
                })?;
                total_ms = total_ms.zip(ms).map(|(a, b)| a + b);
                done += batch;
                progress(done, settings.samples);
            }
            Ok(())
        })();
        let sums = outcome.and_then(|()| accumulation.read::<[f32; 4]>());
        accumulation.destroy(ctx);
        let sums = sums?;
        let image = HdrImage::from_pixels(
            width,
            height,
            sums.iter()
                .map(|s| {
                    let n = s[3].max(1.0);
                    [s[0] / n, s[1] / n, s[2] / n]
                })
                .collect(),
        )?;
        Ok(Render {
            image,
            gpu_ms: total_ms,
        })
    }

    /// Frees the pipeline and the buffers.
    pub fn destroy(self, ctx: &Context) {
        self.kernel.destroy(ctx);
        self.camera.destroy(ctx);
        self.environment.destroy(ctx);
    }
}

/// The mean of `settings.samples` paths through `pixel`, computed on the CPU by the kernel's
/// per-path code, tracing with `bvh` (built from the same scene as `shading` and `lights`), the
/// sky from `environment`.
pub fn render_pixel_on_cpu(
    shading: &ShadingData,
    lights: &[GpuLight],
    environment: &Environment,
    bvh: &Bvh,
    camera: &CameraParams,
    settings: &PathTracerSettings,
    pixel: UVec2,
) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for sample in 0..settings.samples {
        let params = settings.params(lights.len() as u32, sample, environment.size);
        let mut path = begin_path(camera, &params, pixel);
        let mut steps = 0;
        while path.active && steps <= MAX_BOUNCES {
            let hit = bvh.closest_hit(&path.ray);
            shade(
                &mut path,
                &hit,
                &params,
                &shading.instances,
                &shading.meshes,
                &shading.vertices,
                &shading.triangles,
                &shading.materials,
                &shading.textures,
                &shading.texels,
                lights,
                &environment.texels,
            );
            if path.shadow_pending && !bvh.any_hit(&path.shadow_ray) {
                path.radiance += path.shadow_radiance;
            }
            steps += 1;
        }
        sum += finite_radiance(path.radiance);
    }
    sum / settings.samples.max(1) as f32
}

/// The whole image of `camera` rendered on the CPU (see [`render_pixel_on_cpu`]).
pub fn render_on_cpu(
    shading: &ShadingData,
    lights: &[GpuLight],
    environment: &Environment,
    bvh: &Bvh,
    camera: &CameraParams,
    settings: &PathTracerSettings,
) -> Result<HdrImage> {
    let [width, height] = camera.image_size;
    let pixels = (0..height)
        .flat_map(|y| (0..width).map(move |x| UVec2::new(x, y)))
        .map(|p| {
            render_pixel_on_cpu(shading, lights, environment, bvh, camera, settings, p).to_array()
        })
        .collect();
    HdrImage::from_pixels(width, height, pixels)
}
