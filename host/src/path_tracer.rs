//! The reference path tracer on the host: the `path_tracer::path_tracer` kernel in either tracing
//! variant, progressive accumulation (one path per pixel per dispatch) read back after every
//! submission and summed in `f64` on the host, so that 64k samples lose nothing to an `f32`
//! running sum, and the CPU running the same per-path code (`gi_shared::path_tracer`) with the
//! host's BVH.

use crate::error::{Error, Result};
use crate::image_io::HdrImage;
use crate::scene::bvh::Bvh;
use crate::scene::gpu_data::ShadingData;
use crate::scene::lights::{LightParams, LightSet};
use crate::scene::upload::GpuScene;
use crate::vulkan::{
    Buffer, Context, Kernel, KernelModule, compute_barrier, submit_timed, transfer_barrier,
};
use gi_shared::camera::CameraParams;
use gi_shared::lights::MAX_LIGHT_CANDIDATES;
use gi_shared::path_tracer::{
    MAX_BOUNCES, PATH_TRACER_TILE, PRIMARY_JITTERED, PRIMARY_PIXEL_CENTRE, PathTracerParams,
    STRATEGY_BSDF_ONLY, STRATEGY_LIGHTS_ONLY, STRATEGY_MIS, begin_path, finite_radiance, shade,
};
use glam::{UVec2, Vec3};

/// Fewest samples per submission: few enough for a responsive progress report and to stay well
/// inside a driver's submission timeout, enough to amortise the submission.
const MIN_SAMPLES_PER_SUBMIT: u32 = 8;
/// Most samples per submission. Each submission sums at most this many samples per pixel in
/// `f32` on the device (a relative error of at most this many half-ULPs, 3.8e-6), and the host
/// adds the submissions in `f64`: the error does not grow with the sample count.
pub const MAX_SAMPLES_PER_SUBMIT: u32 = 64;
/// Paths per submission that small images are batched up to (between the two bounds above).
const PATHS_PER_SUBMIT: u64 = 1 << 18;

/// How next-event estimation and BSDF sampling are combined.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Strategy {
    /// Both, weighted by multiple importance sampling: the reference.
    #[default]
    Mis,
    /// Light sampling alone for what it can sample (comparisons, tests).
    LightsOnly,
    /// BSDF sampling alone: no next-event estimation; punctual lights are invisible.
    BsdfOnly,
}

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
    /// Light samples resampled per next-event estimate (1 to
    /// [`MAX_LIGHT_CANDIDATES`]). Cost: each candidate is one light sample without a shadow ray
    /// (a few ALU operations and reads per bounce). Quality: 1 is plain power-proportional
    /// selection; more candidates choose the light by its unshadowed contribution at the
    /// point, which cuts noise most where many lights of unequal reach share a scene.
    pub light_candidates: u32,
    /// How light sampling and BSDF sampling are combined.
    pub strategy: Strategy,
    /// Every path through its pixel's centre (no antialiasing), the camera hit's textures read
    /// over the pixel as the G-buffer reads them: the GI frame's primary visibility, so that
    /// relMSE and FLIP against GI measure its lighting, not its edges or texture aliasing.
    pub pixel_centre: bool,
}

impl Default for PathTracerSettings {
    /// 64 paths per pixel, 30 bounces (as AMD's reference), no sky, emission as in the file, 8
    /// light candidates, MIS, antialiased.
    fn default() -> Self {
        Self {
            samples: 64,
            max_bounces: 30,
            emissive_multiplier: 1.0,
            sky: Vec3::ZERO,
            seed: 0,
            light_candidates: 8,
            strategy: Strategy::Mis,
            pixel_centre: false,
        }
    }
}

impl PathTracerSettings {
    /// The kernel's push constants for sample `sample_index` with the lights `lights`.
    pub fn params(&self, lights: &LightParams, sample_index: u32) -> PathTracerParams {
        PathTracerParams {
            sky: self.sky.to_array(),
            sample_index,
            max_bounces: self.max_bounces.min(MAX_BOUNCES),
            emissive_multiplier: self.emissive_multiplier,
            light_count: lights.count,
            seed: self.seed,
            environment_size: lights.environment_size,
            environment_light: lights.environment_light,
            light_candidates: self.light_candidates.clamp(1, MAX_LIGHT_CANDIDATES),
            strategy: match self.strategy {
                Strategy::Mis => STRATEGY_MIS,
                Strategy::LightsOnly => STRATEGY_LIGHTS_ONLY,
                Strategy::BsdfOnly => STRATEGY_BSDF_ONLY,
            },
            primary: if self.pixel_centre {
                PRIMARY_PIXEL_CENTRE
            } else {
                PRIMARY_JITTERED
            },
            _pad: [0; 2],
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

crate::bindings! {
    /// The path tracer's set 0 (`kernels::path_tracer::path_tracer`).
    pub(crate) struct PathTracerSet<'a> {
        camera: &'a Buffer,
        accumulation: &'a Buffer,
    }
}

/// The `path_tracer::path_tracer` pipeline and its camera parameters.
pub struct PathTracerPass {
    kernel: Kernel,
    camera: Buffer,
}

impl PathTracerPass {
    /// Creates the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let module = KernelModule::new(ctx)?;
        // The camera and the accumulation.
        let kernel = Kernel::new::<PathTracerSet>(
            ctx,
            &module,
            "path_tracer::path_tracer",
            std::mem::size_of::<PathTracerParams>() as u32,
        )?;
        let camera = Buffer::parameters(ctx, "path tracer camera", &[CameraParams::default()])?;
        Ok(Self { kernel, camera })
    }

    /// Renders `settings.samples` paths per pixel of `camera`'s image, calling `progress(done,
    /// total)` after each submission, and returns the mean.
    ///
    /// Each submission clears a device-local accumulation buffer, adds a batch of samples to it
    /// and copies it to a read-back buffer; the host adds the batches in `f64`.
    pub fn render(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
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
        let accumulation =
            Buffer::device_zeroed::<[f32; 4]>(ctx, "path tracer accumulation", pixels)?;
        let mut readback = Buffer::readback::<[f32; 4]>(ctx, "path tracer read-back", pixels)?;
        let per_submit = (PATHS_PER_SUBMIT / pixels as u64).clamp(
            u64::from(MIN_SAMPLES_PER_SUBMIT),
            u64::from(MAX_SAMPLES_PER_SUBMIT),
        ) as u32;
        let groups = [
            width.div_ceil(PATH_TRACER_TILE),
            height.div_ceil(PATH_TRACER_TILE),
            1,
        ];
        let light_params = scene.lights.params();
        let mut sums = vec![[0.0f64; 4]; pixels];
        let mut total_ms: Option<f64> = Some(0.0);
        let mut done = 0;
        let bindings = PathTracerSet {
            camera: &self.camera,
            accumulation: &accumulation,
        };
        while done < settings.samples {
            let batch = per_submit.min(settings.samples - done);
            let ms = submit_timed(ctx, "path tracer", |cmd| {
                accumulation.record_fill_zero(ctx, cmd);
                transfer_barrier(ctx, cmd);
                for s in 0..batch {
                    if s > 0 {
                        compute_barrier(ctx, cmd);
                    }
                    let params = settings.params(&light_params, done + s);
                    self.kernel.dispatch_traced(
                        ctx,
                        cmd,
                        scene.sets(),
                        &bindings,
                        bytemuck::bytes_of(&params),
                        groups,
                    )?;
                }
                compute_barrier(ctx, cmd);
                accumulation.record_copy_to(ctx, cmd, &readback)?;
                transfer_barrier(ctx, cmd);
                Ok(())
            })?;
            for (sum, s) in sums.iter_mut().zip(readback.read::<[f32; 4]>()?) {
                for c in 0..4 {
                    sum[c] += f64::from(s[c]);
                }
            }
            total_ms = total_ms.zip(ms).map(|(a, b)| a + b);
            done += batch;
            progress(done, settings.samples);
        }
        let image = HdrImage::from_pixels(
            width,
            height,
            sums.iter()
                .map(|s| {
                    let n = s[3].max(1.0);
                    [(s[0] / n) as f32, (s[1] / n) as f32, (s[2] / n) as f32]
                })
                .collect(),
        )?;
        Ok(Render {
            image,
            gpu_ms: total_ms,
        })
    }
}

/// The mean of `settings.samples` paths through `pixel`, computed on the CPU by the kernel's
/// per-path code, tracing with `bvh` (built from the same scene as `shading` and `lights`).
pub fn render_pixel_on_cpu(
    shading: &ShadingData,
    lights: &LightSet,
    bvh: &Bvh,
    camera: &CameraParams,
    settings: &PathTracerSettings,
    pixel: UVec2,
) -> Vec3 {
    let light_params = lights.params();
    let mut sum = [0.0f64; 3];
    for sample in 0..settings.samples {
        let params = settings.params(&light_params, sample);
        let mut path = begin_path(camera, &params, pixel);
        let mut steps = 0;
        while path.active && steps <= MAX_BOUNCES {
            let hit = bvh.closest_hit(shading, &path.ray);
            shade(
                &mut path,
                &hit,
                camera,
                &params,
                shading.surfaces(),
                &shading.texels[..],
                lights.scene_lights(),
            );
            if path.shadow_pending && !bvh.any_hit(shading, &path.shadow_ray) {
                path.radiance += path.shadow_radiance;
            }
            steps += 1;
        }
        let r = finite_radiance(path.radiance);
        for (s, c) in sum.iter_mut().zip(r.to_array()) {
            *s += f64::from(c);
        }
    }
    let n = f64::from(settings.samples.max(1));
    Vec3::new(
        (sum[0] / n) as f32,
        (sum[1] / n) as f32,
        (sum[2] / n) as f32,
    )
}

/// The whole image of `camera` rendered on the CPU (see [`render_pixel_on_cpu`]).
pub fn render_on_cpu(
    shading: &ShadingData,
    lights: &LightSet,
    bvh: &Bvh,
    camera: &CameraParams,
    settings: &PathTracerSettings,
) -> Result<HdrImage> {
    let [width, height] = camera.image_size;
    let pixels = (0..height)
        .flat_map(|y| (0..width).map(move |x| UVec2::new(x, y)))
        .map(|p| render_pixel_on_cpu(shading, lights, bvh, camera, settings, p).to_array())
        .collect();
    HdrImage::from_pixels(width, height, pixels)
}
