//! `gi render --method gi`: GI-1.0 frames of a scene along a camera path, the last one written
//! out, with optional metrics against a reference and debug views.

use super::{Output, Sky, describe, load_scene, on_off, view_camera, write_image};
use crate::upload;
use gi_host::gi::camera_path::CameraPath;
use gi_host::gi::probe_debug_views::{gi_debug_views, write_gi_debug_views};
use gi_host::gi::renderer::{DEFAULT_GI_FRAMES, GiRenderer};
use gi_host::gi::{GiSettings, Preset, SpawnRate, ViewOptions};
use gi_host::image_io::{HdrImage, ToneMap};
use gi_host::metrics::{self, CompareSettings};
use gi_host::scene::lights::LightSet;
use gi_host::vulkan::Context;
use gi_shared::camera::CameraParams;
use gi_shared::hash_cells::{MAX_NUM_TILES_LOG2, TILES_PER_BUCKET_LOG2};
use glam::Vec3;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Which renderer `gi render` runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// The reference path tracer (the ground truth).
    Path,
    /// GI-1.0: screen probes over the world-space radiance cache, denoised.
    Gi,
}

/// A GI technique that `--no` switches off.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Technique {
    /// Temporal reprojection of the probes.
    Reprojection,
    /// Parallax-corrected re-binning.
    Parallax,
    /// Radiance backup of empty cells.
    Backup,
    /// Probe patching of disoccluded tiles.
    Patching,
    /// Ray guiding.
    Guiding,
    /// Shadow-preserving temporal hysteresis.
    Hysteresis,
    /// The 7×7 probe filter.
    Filter,
    /// Blue-noise jitter of interpolation.
    Jitter,
    /// The relaxed interpolation fallback.
    Relaxed,
    /// The denoiser's temporal reprojection.
    Temporal,
    /// The denoiser's bilateral blur.
    Spatial,
    /// Multi-bounce through the world cache (bounce rays from the cache's hits).
    MultiBounce,
    /// The cache's change-adaptive blend (its history cut while a tile's light changes).
    AdaptiveBlend,
    /// The cache's light-leak fixes (short-ray flag and bypass).
    LeakFixes,
    /// Per-object reprojection of moving objects.
    ObjectMotion,
    /// Emitter sampling at the primary hit (the emitters' direct light through the probes
    /// instead).
    EmitterSampling,
    /// Screen-space GI's occlusion and near-field light (an occlusion radius of 0).
    Occlusion,
}

/// A quality preset of `gi render` (README, "Speed and accuracy": each one's measured cost and
/// error).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PresetArg {
    /// GI, 1/16 of the probes traced per frame, coarser cache cells.
    Fast,
    /// GI with the reference's settings.
    Balanced,
    /// GI, every probe traced every frame, no probe filter.
    Quality,
    /// The path tracer (`--method path`).
    Reference,
}

/// The options of `gi render` for `--method gi`.
#[derive(clap::Args)]
pub struct GiArgs {
    /// Renderer: `path` (the reference path tracer, the ground truth) or `gi` (GI-1.0).
    #[arg(long, value_enum, default_value_t = Method::Path)]
    pub method: Method,
    /// A quality preset: `fast`, `balanced` or `quality` (GI, its settings before --spawn-rate,
    /// --no, --restir and --feedback), or `reference` (the path tracer);
    /// instead of --method.
    #[arg(long, value_enum, conflicts_with = "method")]
    pub preset: Option<PresetArg>,
    /// GI: frames to render; the last is written. The default lets the denoiser's history
    /// reach its 64-frame cap.
    #[arg(long, default_value_t = DEFAULT_GI_FRAMES, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    pub frames: u32,
    /// GI: camera path: `static`, `orbit` or `orbit:DEGREES_PER_FRAME` (about the vertical
    /// axis through the point the camera looks at, at the scene's centre distance), or a file
    /// with one camera per line (`px py pz tx ty tz [fov]`).
    #[arg(long, default_value = "static")]
    pub camera_path: String,
    /// GI: a reference image (OpenEXR, e.g. `gi render --method path` at many spp): relMSE and
    /// FLIP of the last frame against it.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// GI: also write relMSE and FLIP of every frame against --reference as CSV here.
    #[arg(long, requires = "reference")]
    pub metrics_csv: Option<PathBuf>,
    /// GI: write (and compare) the mean of the last N frames instead of the last frame: the
    /// converged still image's bias, free of one frame's noise (the bias budget uses it). 1 by
    /// default (the last frame); at most --frames.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub average_last: u32,
    /// GI: write every stage as a PNG into this folder (probe atlas, mask, spawn and patch
    /// tiles, ray-guiding PDFs, cache cells, blur mask, irradiance before and after the
    /// denoiser).
    #[arg(long)]
    pub debug_views: Option<PathBuf>,
    /// GI: probes traced per frame: `1` (every probe tile), `1/4` or `1/16`; default: the
    /// preset's (`balanced`: 1/4).
    #[arg(long, value_parser = parse_spawn_rate)]
    pub spawn_rate: Option<SpawnRate>,
    /// GI: the world cache's sample cap (1 to 1024), instead of the preset's (16).
    #[arg(long)]
    pub sample_cap: Option<u32>,
    /// GI: how far the interpolation jitter reaches, in probe tiles of 8 pixels (0 to 4),
    /// instead of the preset's (`GiSettings::interpolation_jitter_radius`).
    #[arg(long)]
    pub jitter_radius: Option<f32>,
    /// GI: the world cache's cell size in pixels of the screen at the cell's distance, instead of
    /// the preset's (`GiSettings::cell_size_pixels`).
    #[arg(long)]
    pub cell_size_pixels: Option<f32>,
    /// GI: the world cache's size in tiles, a power of two (each tile about 3.1 KiB with
    /// multi-bounce), instead of the size `GiSettings::with_cache_for` gives the resolution (one
    /// tile per 32 pixels, twice that with multi-bounce, 2048 to 65536). Too few tiles and
    /// inserts fail: `gi cache-view` counts them.
    #[arg(long, value_parser = parse_cache_tiles)]
    pub cache_tiles: Option<u32>,
    /// GI: screen-space GI's occlusion radius in pixels (0 to 64; 0: off), instead of the
    /// preset's (`GiSettings::occlusion_radius`).
    #[arg(long)]
    pub occlusion_radius: Option<u32>,
    /// GI: techniques to switch off, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub no: Vec<Technique>,
    /// GI: world-space ReSTIR temporal reuse of the cache's light samples.
    #[arg(long)]
    pub restir: bool,
    /// GI: temporal radiance feedback at secondary hits (`GiSettings::temporal_feedback`; off in
    /// every preset, whose cache bounces light itself).
    #[arg(long)]
    pub feedback: bool,
    /// GI: frames per second at which the scene's animation (glTF node animations) plays: frame
    /// `f` shows time `f / fps`, looped. `0` holds the scene in its rest pose. Scenes without
    /// animation ignore it.
    #[arg(long, default_value_t = 30.0, value_parser = parse_fps)]
    pub fps: f32,
}

fn parse_fps(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(fps) if fps.is_finite() && fps >= 0.0 => Ok(fps),
        _ => Err(format!(
            "{s:?} is not a frame rate (a number of frames per second, 0 or more)"
        )),
    }
}

fn parse_cache_tiles(s: &str) -> Result<u32, String> {
    // At least two buckets of the presets' tiles per bucket; at most one storage binding's worth.
    let min = 2u32 << TILES_PER_BUCKET_LOG2;
    let max = 1u32 << MAX_NUM_TILES_LOG2;
    match s.parse::<u32>() {
        Ok(n) if n.is_power_of_two() && (min..=max).contains(&n) => Ok(n),
        _ => Err(format!("{s:?} is not a power of two from {min} to {max}")),
    }
}

fn parse_spawn_rate(s: &str) -> Result<SpawnRate, String> {
    match s {
        "1" => Ok(SpawnRate::Full),
        "1/4" => Ok(SpawnRate::Quarter),
        "1/16" => Ok(SpawnRate::Sixteenth),
        _ => Err(format!("{s:?} is not one of 1, 1/4, 1/16")),
    }
}

impl GiArgs {
    /// The renderer: the preset's, else `--method`'s.
    pub fn method(&self) -> Method {
        match self.preset {
            Some(PresetArg::Reference) => Method::Path,
            Some(_) => Method::Gi,
            None => self.method,
        }
    }

    /// The settings for a `width × height` frame.
    pub fn settings(&self, width: u32, height: u32) -> GiSettings {
        let preset = match self.preset {
            Some(PresetArg::Fast) => Preset::Fast,
            Some(PresetArg::Quality) => Preset::Quality,
            _ => Preset::Balanced,
        };
        let mut s = preset.settings(width, height);
        if let Some(rate) = self.spawn_rate {
            s.spawn_rate = rate;
        }
        if let Some(cap) = self.sample_cap {
            s.sample_cap = cap;
        }
        if let Some(radius) = self.jitter_radius {
            s.interpolation_jitter_radius = radius;
        }
        if let Some(pixels) = self.cell_size_pixels {
            s.cell_size_pixels = pixels;
            s = s.with_cache_for(width, height);
        }
        if let Some(radius) = self.occlusion_radius {
            s.occlusion_radius = radius;
        }
        if let Some(tiles) = self.cache_tiles {
            s = s.with_tiles_log2(tiles.trailing_zeros());
        }
        s.restir |= self.restir;
        s.temporal_feedback |= self.feedback;
        switch_off(&mut s, &self.no);
        s
    }

    /// The camera path around `base` in `scene_centre`'s neighbourhood.
    fn camera_path(&self, base: &CameraParams, scene_centre: Vec3) -> gi_host::Result<CameraPath> {
        let orbit = |degrees: f32| CameraPath::orbit_toward(base, scene_centre, degrees, 1.0);
        match self.camera_path.as_str() {
            "static" => Ok(CameraPath::Static),
            "orbit" => Ok(orbit(0.5)),
            s if s.starts_with("orbit:") => s[6..]
                .parse::<f32>()
                .ok()
                .filter(|d| d.is_finite())
                .map(orbit)
                .ok_or_else(|| gi_host::Error::InvalidArgument {
                    name: "camera path",
                    why: format!("{s:?}: expected orbit:DEGREES_PER_FRAME"),
                }),
            file => CameraPath::read(Path::new(file)),
        }
    }
}

/// Renders `args.frames` GI frames of the scene at `path` and writes the last one.
pub fn render_gi(
    ctx: &Context,
    path: &Path,
    output: &Output<'_>,
    view: Option<(Vec3, Vec3, f32)>,
    sky: Sky,
    options: ViewOptions,
    args: &GiArgs,
) -> Result<(), Box<dyn std::error::Error>> {
    let Output {
        path: out,
        width,
        height,
        exposure,
    } = *output;
    let settings = args.settings(width, height);
    settings.validate(width, height)?;
    let reference = args.reference.as_deref().map(HdrImage::read).transpose()?;
    let start = Instant::now();
    let mut scene = load_scene(path)?;
    describe(path, &scene);
    let base = view_camera(view, &scene, width, height);
    let camera_path = args.camera_path(&base, scene.bounds.center())?;
    let environment = sky.environment.clone();
    let sample_environment = sky.sample;
    let (mut lights, mut gpu) = upload(ctx, &scene, sky)?;
    let animated = scene.animation.is_some() && args.fps > 0.0;
    if animated {
        println!(
            "animation:           played at {} frames per second",
            args.fps
        );
    }
    // Whether the last frame moved an instance: the next one then updates the previous
    // transforms even if nothing moves.
    let mut moving = false;
    let s = &settings;
    println!(
        "gi:                  {} frames, spawn tile {} px, cache cells {} px, cache tiles {}, \
         sample cap {}, reprojection {}, parallax {}, backup {}, patching {}, guiding {}, hysteresis {}, \
         probe filter {}, jitter {} px, occlusion {} px, relaxed {}, temporal {}, spatial {}, feedback {}, \
         multi-bounce {}, adaptive blend {}, leak fixes {}, object motion {}, ReSTIR {}, \
         emitter sampling {}",
        args.frames,
        s.spawn_rate.tile(),
        s.cell_size_pixels,
        s.tile_count(),
        s.sample_cap,
        on_off(s.reprojection),
        on_off(s.parallax),
        on_off(s.radiance_backup),
        on_off(s.patching),
        on_off(s.ray_guiding),
        on_off(s.hysteresis),
        on_off(s.probe_filter),
        s.interpolation_jitter_pixels(),
        s.occlusion_radius,
        on_off(s.relaxed_fallback),
        on_off(s.denoiser_temporal),
        on_off(s.denoiser_spatial),
        on_off(s.temporal_feedback),
        on_off(s.multi_bounce),
        on_off(s.adaptive_cache_blend),
        on_off(s.short_ray_flag && s.bypass),
        on_off(s.object_motion),
        on_off(s.restir),
        on_off(s.emitter_sampling)
    );
    let mut gi = GiRenderer::new(ctx, &lights, width, height, settings, options)?;
    if args.debug_views.is_some() {
        gi.keep_interpolated_irradiance(ctx)?;
    }
    let compare = CompareSettings {
        tone: ToneMap {
            exposure,
            ..ToneMap::default()
        },
        ..CompareSettings::default()
    };
    let mut csv = match &args.metrics_csv {
        Some(p) => {
            let mut f = std::fs::File::create(p)
                .map_err(|e| format!("--metrics-csv {}: {e}", p.display()))?;
            writeln!(f, "frame,relmse,flip,mean")?;
            Some(f)
        }
        None => None,
    };
    let average_last = args.average_last.min(args.frames);
    let mut average: Option<Vec<[f64; 3]>> = None;
    let rendered = (|| -> Result<_, Box<dyn std::error::Error>> {
        for f in 0..args.frames {
            if animated && f > 0 {
                let before = scene.pose_at((f - 1) as f32 / args.fps);
                let moved = !scene.set_time(f as f32 / args.fps).is_empty();
                if moved || moving {
                    lights = LightSet::new(&scene, environment.clone(), sample_environment);
                    gpu.set_pose(ctx, &scene, &lights, &before)?;
                }
                moving = moved;
            }
            let camera = camera_path.camera(&base, f);
            let st = gi.render_frame(ctx, &gpu, &camera)?;
            let last = f + 1 == args.frames;
            if last || f % 16 == 0 {
                println!(
                    "frame {f:>5}: probes spawned {:>5} reprojected {:>5} overrides {:>5} empty {:>4} \
                     patched {:>4} relaxed px {:>6} | cache live tiles {:>6} queries {:>7} fed back \
                     {:>7}",
                    st.spawned,
                    st.reprojected,
                    st.overrides,
                    st.empty,
                    st.patched,
                    st.relaxed,
                    st.cache.live_tiles,
                    st.cache.queries,
                    st.cache.fed_back
                );
            }
            let averaged = average_last > 1 && args.frames - f <= average_last;
            if averaged || csv.is_some() {
                let frame = gi.image(ctx)?;
                if let (Some(r), Some(file)) = (&reference, csv.as_mut()) {
                    let c = metrics::compare(r, &frame, &compare)?;
                    writeln!(
                        file,
                        "{f},{},{},{}",
                        c.metrics.relative_mse, c.metrics.flip, c.metrics.mean_bias
                    )?;
                }
                if averaged {
                    let sum =
                        average.get_or_insert_with(|| vec![[0.0f64; 3]; frame.pixels().len()]);
                    for (s, p) in sum.iter_mut().zip(frame.pixels()) {
                        for c in 0..3 {
                            s[c] += f64::from(p[c]);
                        }
                    }
                }
            }
        }
        let image = match average {
            Some(sum) => {
                let n = f64::from(average_last);
                let mean = sum.iter().map(|s| s.map(|c| (c / n) as f32)).collect();
                HdrImage::from_pixels(width, height, mean)?
            }
            None => gi.image(ctx)?,
        };
        let views = match args.debug_views {
            Some(_) => gi_debug_views(ctx, &gi)?,
            None => vec![],
        };
        println!("GPU time per pass:\n{}", gi.timings());
        let b = gi.barrier_counts();
        println!(
            "barriers:            {} in the last frame ({} buffer, {} image barriers), placed by \
             the frame recorder",
            b.barriers, b.buffer_barriers, b.image_barriers
        );
        println!("memory:\n{}", gi_host::frame::MemoryTable::of(ctx));
        Ok((image, views))
    })();
    drop(gi);
    drop(gpu);
    let (image, views) = rendered?;
    let png = write_image(out, &image, exposure)?;
    println!(
        "gi render:           {width}x{height}, {} frames in {:.1} s",
        args.frames,
        start.elapsed().as_secs_f64()
    );
    if let Some(r) = &reference {
        let c = metrics::compare(r, &image, &compare)?;
        println!("against reference:   {}", c.metrics);
    }
    println!("wrote                {}", out.display());
    println!("wrote                {}", png.display());
    if let Some(dir) = &args.debug_views {
        for f in write_gi_debug_views(&views, dir, exposure)? {
            println!("wrote                {}", f.display());
        }
    }
    Ok(())
}

/// `settings` with each technique of `off` switched off.
pub fn switch_off(s: &mut GiSettings, off: &[Technique]) {
    for t in off {
        match t {
            Technique::Reprojection => s.reprojection = false,
            Technique::Parallax => s.parallax = false,
            Technique::Backup => s.radiance_backup = false,
            Technique::Patching => s.patching = false,
            Technique::Guiding => s.ray_guiding = false,
            Technique::Hysteresis => s.hysteresis = false,
            Technique::Filter => s.probe_filter = false,
            Technique::Jitter => s.interpolation_jitter = false,
            Technique::Relaxed => s.relaxed_fallback = false,
            Technique::Temporal => s.denoiser_temporal = false,
            Technique::Spatial => s.denoiser_spatial = false,
            Technique::MultiBounce => s.multi_bounce = false,
            Technique::AdaptiveBlend => s.adaptive_cache_blend = false,
            Technique::ObjectMotion => s.object_motion = false,
            Technique::EmitterSampling => s.emitter_sampling = false,
            Technique::Occlusion => s.occlusion_radius = 0,
            Technique::LeakFixes => {
                s.short_ray_flag = false;
                s.bypass = false;
            }
        }
    }
}
