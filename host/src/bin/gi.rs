//! `gi`: the command-line program of the GI-1.0 port.

#[path = "gi/gi_lag.rs"]
mod gi_lag;
#[path = "gi/gi_memory.rs"]
mod gi_memory;
#[path = "gi/gi_render.rs"]
mod gi_render;
#[path = "gi/gi_soak.rs"]
mod gi_soak;
#[path = "gi/gi_sweep.rs"]
mod gi_sweep;
#[path = "gi/gi_view.rs"]
mod gi_view;

use clap::{Parser, Subcommand};
use gi_host::gbuffer::{GBufferData, GBufferImages, GBufferPass, scene_camera, write_debug_pngs};
use gi_host::gi::debug_views::write_debug_views;
use gi_host::gi::{CacheView, GiSettings, ViewOptions};
use gi_host::image_io::{HdrImage, ToneMap};
use gi_host::metrics::{self, CompareSettings};
use gi_host::path_tracer::{PathTracerPass, PathTracerSettings, Render, Strategy};
use gi_host::scene::Scene;
use gi_host::scene::bvh::Bvh;
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::{Environment, LightSet};
use gi_host::scene::synthetic::{self, SyntheticParams};
use gi_host::scene::upload::GpuScene;
use gi_host::vulkan::{Context, ContextOptions};
use gi_host::{KernelVariant, TraceMode};
use gi_lag::{LagArgs, run_lag};
use gi_memory::{MemoryArgs, run_memory};
use gi_render::{GiArgs, Method, render_gi};
use gi_shared::camera::CameraParams;
use gi_soak::{SoakArgs, run_soak};
use gi_sweep::{SweepArgs, run_sweep};
use gi_view::{ViewerArgs, run_view};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// Real-time global illumination (GI-1.0 two-level radiance caching) on any Vulkan device.
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    /// Device to use: index or part of its name (also GI_DEVICE). Default: discrete GPU, then
    /// integrated, then CPU (lavapipe).
    #[arg(long, global = true)]
    device: Option<String>,
    /// How rays are traced: ray queries where available (auto), forced ray queries, or the
    /// software BVH traversal that runs everywhere.
    #[arg(long, value_enum, default_value_t = TraceMode::Auto, global = true)]
    trace: TraceMode,
    /// Turn the Vulkan validation layer on, with its synchronization checks, and fail on any
    /// message it prints.
    #[arg(long, global = true)]
    validation: bool,
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Report the chosen device and its capabilities, then run a smoke dispatch (the default).
    Info {
        /// Invocations of the smoke kernel.
        #[arg(long, default_value_t = 1 << 16)]
        invocations: u32,
    },
    /// Render a scene's G-buffer (the primary-visibility images the GI passes read) and write
    /// each image as a PNG debug view: depth, geometric and shading normals, albedo, emissive,
    /// motion vectors, instance and primitive ids.
    Gbuffer {
        /// The glTF scene (.gltf or .glb).
        scene: PathBuf,
        /// Folder for the PNGs (created if missing).
        #[arg(long, default_value = "out/gbuffer")]
        out: PathBuf,
        /// Image width in pixels.
        #[arg(long, default_value_t = 320, value_parser = clap::value_parser!(u32).range(1..=8192))]
        width: u32,
        /// Image height in pixels.
        #[arg(long, default_value_t = 240, value_parser = clap::value_parser!(u32).range(1..=8192))]
        height: u32,
    },
    /// Render a scene: with the reference path tracer (`--method path`, the default:
    /// progressive, one path per pixel per dispatch), or with GI-1.0 (`--method gi`: frames along
    /// a camera path, the last one written, then the GPU time per pass and the memory table).
    /// Writes the linear image as OpenEXR and a tone-mapped PNG beside it.
    Render {
        /// The glTF scene (.gltf or .glb).
        scene: PathBuf,
        /// Output image: OpenEXR (linear radiance); the PNG goes beside it with the same name.
        #[arg(long, default_value = "out/render.exr")]
        out: PathBuf,
        /// Image width in pixels.
        #[arg(long, default_value_t = 320, value_parser = clap::value_parser!(u32).range(1..=8192))]
        width: u32,
        /// Image height in pixels.
        #[arg(long, default_value_t = 240, value_parser = clap::value_parser!(u32).range(1..=8192))]
        height: u32,
        /// Paths per pixel.
        #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
        spp: u32,
        /// Reflections per path (0: emitters only, 1: direct lighting); at most 64.
        #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u32).range(0..=64))]
        max_bounces: u32,
        #[command(flatten)]
        view: ViewArgs,
        /// Light samples resampled per next-event estimate: 1 is power-proportional selection;
        /// more choose by each light's unshadowed contribution (cheap: no extra rays).
        #[arg(long, default_value_t = PathTracerSettings::default().light_candidates,
              value_parser = clap::value_parser!(u32).range(1..=gi_shared::lights::MAX_LIGHT_CANDIDATES as i64))]
        light_candidates: u32,
        /// How light sampling and BSDF sampling combine: mis (the reference), lights or bsdf
        /// (one technique alone, for comparisons).
        #[arg(long, default_value = "mis", value_parser = parse_strategy)]
        strategy: Strategy,
        /// Trace every path through its pixel's centre (no antialiasing), its textures read over
        /// the pixel as the G-buffer reads them: the GI frame's primary visibility, the reference
        /// to measure GI's lighting error against.
        #[arg(long)]
        pixel_centre: bool,
        #[command(flatten)]
        gi: GiArgs,
    },
    /// Show the world-space radiance cache on its own (GI-1.0's hash cells): each G-buffer pixel
    /// casts one cosine-distributed ray per frame, whose hit queries and feeds the cache; the
    /// image is the running mean of emission + albedo × (direct + cache-lit indirect). Prints the
    /// cache's occupancy per frame, then the GPU time per pass and the memory table.
    CacheView {
        /// The glTF scene (.gltf or .glb).
        scene: PathBuf,
        /// Output image: OpenEXR (linear radiance); the PNG goes beside it with the same name.
        #[arg(long, default_value = "out/cache-view.exr")]
        out: PathBuf,
        /// Image width in pixels.
        #[arg(long, default_value_t = 320, value_parser = clap::value_parser!(u32).range(1..=8192))]
        width: u32,
        /// Image height in pixels.
        #[arg(long, default_value_t = 240, value_parser = clap::value_parser!(u32).range(1..=8192))]
        height: u32,
        /// Frames to render (the image is their running mean).
        #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
        frames: u32,
        #[command(flatten)]
        view: ViewArgs,
        /// log2 of the hash grid's bucket count (default: scaled with the resolution and the
        /// cell size).
        #[arg(long)]
        buckets_log2: Option<u32>,
        /// log2 of the tiles per bucket.
        #[arg(long, default_value_t = GiSettings::default().tiles_per_bucket_log2)]
        tiles_per_bucket_log2: u32,
        /// Angular size of a cache cell in pixels.
        #[arg(long, default_value_t = GiSettings::default().cell_size_pixels)]
        cell_size_pixels: f32,
        /// Smallest world-space cell size in metres.
        #[arg(long, default_value_t = GiSettings::default().min_cell_size, allow_negative_numbers = true)]
        min_cell_size: f32,
        /// Turn temporal radiance feedback off (secondary hits then get direct light only).
        #[arg(long)]
        no_feedback: bool,
        /// Turn multi-bounce through the cache on (bounce rays from the cache's hits; off, as in
        /// the reference, cells hold direct light only).
        #[arg(long)]
        multi_bounce: bool,
        /// Turn the descriptor's short-ray flag and the short-ray bypass off (light-leak fixes).
        #[arg(long)]
        no_leak_fixes: bool,
        /// Turn world-space ReSTIR temporal reuse of the light samples on.
        #[arg(long)]
        restir: bool,
        /// Write debug views of the cache (PNGs: cells by hash, LOD, sample count, cached
        /// radiance, evicted tiles) into this folder.
        #[arg(long)]
        debug_views: Option<PathBuf>,
    },
    /// Measure the path tracer's speed: paths per second for each scene in each tracing variant
    /// the device has (ignores --trace).
    Benchmark {
        /// glTF scenes.
        #[arg(default_values = ["scenes/cornell-box.gltf", "scenes/indirect-room.gltf", "scenes/many-lights.gltf"])]
        scenes: Vec<PathBuf>,
        /// Image width in pixels.
        #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..=8192))]
        width: u32,
        /// Image height in pixels.
        #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..=8192))]
        height: u32,
        /// Paths per pixel.
        #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
        spp: u32,
        /// Reflections per path.
        #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u32).range(0..=64))]
        max_bounces: u32,
    },
    /// Measure what each GI setting costs and buys: every preset, each knob alone, other
    /// resolutions and the other tracing variant, on each scene, static and orbiting, against
    /// path-traced references; the equal-time comparison with the path tracer; optionally how
    /// the cost scales with pixels, triangles and lights. Writes CSV, JSON, Markdown tables and
    /// plots (PNG and SVG).
    Sweep(SweepArgs),
    /// Run the GI frame for many frames (default 10 000) with a moving camera, a moving point
    /// light and the scene's animated object, with the validation layer on (synchronization
    /// checks included; --no-validation checks the host's memory instead). Every --check-every
    /// frames the GPU counts NaN and infinite floats in every float buffer and float image of the
    /// frame, and host and device memory are sampled; cache occupancy and frame time are recorded
    /// every frame. Prints a summary table; exits non-zero when a check fails.
    Soak(SoakArgs),
    /// Measure the response to a change of light: the scene's brightest emitter switched off,
    /// switched on and moved, for every preset; prints the share of the change still missing
    /// after 5, 15 and 30 frames and the frames until it stays within 5 %.
    Lag(LagArgs),
    /// Report what the GI frame allocates for each preset at each resolution (default 720p,
    /// 1080p and 4K), without rendering: bytes per pixel, the world cache and the total.
    Memory(MemoryArgs),
    /// Open a scene in a window: a fly camera (WASD, mouse drag), GI or the path tracer
    /// (accumulating while the camera stands still) or the cache view, every technique's
    /// toggle and debug view, a timing overlay; drop a scene or an environment on the window
    /// to load it. With --frames (and --screenshot) it renders that many frames and closes.
    View(ViewerArgs),
    /// Write a synthetic instanced scene (GLB) for scaling tests: a closed room lit by an
    /// emissive ceiling panel, a camera, and many instances of a few tessellated meshes (spheres,
    /// tori, boxes) on a seeded grid, up to the requested world triangle count.
    Generate {
        /// World triangles: a count such as 10000, 10k, 1.5M or 2G.
        #[arg(long, value_parser = synthetic::parse_count)]
        triangles: u64,
        /// The GLB file to write.
        #[arg(long)]
        out: PathBuf,
        /// Distinct meshes the instances share.
        #[arg(long, default_value_t = SyntheticParams::default().unique_meshes)]
        unique_meshes: u32,
        /// Seed of the placement and mesh choice.
        #[arg(long, default_value_t = SyntheticParams::default().seed)]
        seed: u64,
    },
    /// Compare a test image with a reference: RMSE, relative MSE, PSNR and FLIP, and optionally
    /// FLIP's error heat map. Images are OpenEXR (linear) or PNG/JPEG (sRGB).
    Compare {
        /// The reference (ground truth).
        reference: PathBuf,
        /// The image under test.
        test: PathBuf,
        /// Exposure in stops applied before tone mapping, for PSNR and FLIP.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = parse_finite)]
        exposure: f32,
        /// Write FLIP's error heat map (PNG) here.
        #[arg(long)]
        heat_map: Option<PathBuf>,
    },
}

/// How a scene is lit and seen: the options `render` and `cache-view` share.
#[derive(clap::Args)]
struct ViewArgs {
    /// Factor on the emission of every surface.
    #[arg(long, default_value_t = 1.0, value_parser = parse_non_negative)]
    emissive_multiplier: f32,
    /// Constant sky radiance as r,g,b (W/(sr·m²)), sampled as a uniform environment image;
    /// none by default (glTF has no environment).
    #[arg(long, value_parser = parse_radiance, conflicts_with = "environment")]
    sky: Option<Vec3>,
    /// Equirectangular environment image lighting the scene instead of --sky: Radiance .hdr
    /// or OpenEXR, linear, +Y up, its middle column looking along -Z.
    #[arg(long)]
    environment: Option<PathBuf>,
    /// Exposure of the PNG in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = parse_finite)]
    exposure: f32,
    /// Seed of the random streams.
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// Camera position x,y,z (with --camera-target); default: the scene's first camera, else a
    /// view of the whole scene.
    #[arg(long, value_parser = parse_vec3, requires = "camera_target", allow_negative_numbers = true)]
    camera_position: Option<Vec3>,
    /// Point the camera looks at, x,y,z.
    #[arg(long, value_parser = parse_vec3, requires = "camera_position", allow_negative_numbers = true)]
    camera_target: Option<Vec3>,
    /// Vertical field of view in degrees, with --camera-position.
    #[arg(long, default_value_t = 45.0, value_parser = parse_fov)]
    fov: f32,
    /// Do not importance-sample the environment image (BSDF sampling alone finds it).
    #[arg(long, requires = "environment")]
    no_environment_sampling: bool,
}

impl ViewArgs {
    /// The camera given on the command line, if any: position, target and field of view.
    fn camera(&self) -> Option<(Vec3, Vec3, f32)> {
        self.camera_position
            .zip(self.camera_target)
            .map(|(p, t)| (p, t, self.fov))
    }

    /// The sky as a light: the environment image, else a non-zero constant sky.
    fn sky(&self) -> gi_host::Result<Sky> {
        Ok(Sky {
            environment: sky_environment(self.environment.as_deref(), self.sky)?,
            sample: !self.no_environment_sampling,
        })
    }

    /// Where the image goes and how it is exposed.
    fn output<'a>(&self, path: &'a Path, width: u32, height: u32) -> Output<'a> {
        Output {
            path,
            width,
            height,
            exposure: self.exposure,
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: &Cli) -> Result<(), Box<dyn std::error::Error>> {
    if let Some(Command::Compare {
        reference,
        test,
        exposure,
        heat_map,
    }) = &cli.command
    {
        return compare(reference, test, *exposure, heat_map.as_deref());
    }
    if let Some(Command::Generate {
        triangles,
        out,
        unique_meshes,
        seed,
    }) = &cli.command
    {
        let params = SyntheticParams {
            triangles: *triangles,
            unique_meshes: *unique_meshes,
            seed: *seed,
        };
        let start = Instant::now();
        let scene = synthetic::write(&params, out)?;
        println!(
            "{}: {} world triangles ({} unique), {} instances, {:.1} MB, {:.2} s",
            out.display(),
            scene.world_triangles,
            scene.unique_triangles,
            scene.instances,
            scene.glb.len() as f64 / 1e6,
            start.elapsed().as_secs_f64()
        );
        return Ok(());
    }
    if let Some(Command::Sweep(args)) = &cli.command
        && let Some(dir) = &args.replot
    {
        return gi_sweep::replot(dir);
    }
    if let Some(Command::Benchmark {
        scenes,
        width,
        height,
        spp,
        max_bounces,
    }) = &cli.command
    {
        let settings = PathTracerSettings {
            samples: *spp,
            max_bounces: *max_bounces,
            ..PathTracerSettings::default()
        };
        return benchmark(cli, scenes, *width, *height, &settings);
    }
    let options = ContextOptions {
        // A soak proves there are no validation messages: the layer is on for it unless the
        // run checks the host's memory instead.
        validation: cli.validation
            || matches!(&cli.command, Some(Command::Soak(s)) if !s.no_validation),
        device: cli.device.clone(),
        trace: cli.trace,
    };
    let invocations = match cli.command {
        Some(Command::Info { invocations }) => invocations,
        _ => 1 << 16,
    };
    let ctx = Context::new(&options)?;
    println!("{}", ctx.capabilities());
    println!("kernels:             {}", ctx.variant());
    // Every device command first proves the chain (kernels, binding, dispatch, read-back) works.
    smoke(&ctx, invocations)?;
    if let Some(Command::Gbuffer {
        scene,
        out,
        width,
        height,
    }) = &cli.command
    {
        gbuffer(&ctx, scene, out, *width, *height)?;
    }
    if let Some(Command::Render {
        scene,
        out,
        width,
        height,
        spp,
        max_bounces,
        view,
        light_candidates,
        strategy,
        pixel_centre,
        gi,
    }) = &cli.command
    {
        if gi.method() == Method::Gi {
            let options = ViewOptions {
                sky: view.sky.unwrap_or(Vec3::ZERO),
                emissive_multiplier: view.emissive_multiplier,
                seed: view.seed,
            };
            let output = view.output(out, *width, *height);
            render_gi(
                &ctx,
                scene,
                &output,
                view.camera(),
                view.sky()?,
                options,
                gi,
            )?;
            return check_validation(&ctx);
        }
        let settings = PathTracerSettings {
            samples: *spp,
            max_bounces: *max_bounces,
            emissive_multiplier: view.emissive_multiplier,
            sky: view.sky.unwrap_or(Vec3::ZERO),
            seed: view.seed,
            light_candidates: *light_candidates,
            strategy: *strategy,
            pixel_centre: *pixel_centre,
        };
        let output = view.output(out, *width, *height);
        render(&ctx, scene, &output, view.camera(), view.sky()?, &settings)?;
    }
    if let Some(Command::Sweep(args)) = &cli.command {
        run_sweep(&ctx, &options, args)?;
    }
    if let Some(Command::Soak(args)) = &cli.command {
        run_soak(&ctx, args)?;
    }
    if let Some(Command::Lag(args)) = &cli.command {
        run_lag(&ctx, args)?;
    }
    if let Some(Command::Memory(args)) = &cli.command {
        run_memory(&ctx, args)?;
    }
    if let Some(Command::CacheView {
        scene,
        out,
        width,
        height,
        frames,
        view,
        buckets_log2,
        tiles_per_bucket_log2,
        cell_size_pixels,
        min_cell_size,
        no_feedback,
        multi_bounce,
        no_leak_fixes,
        restir,
        debug_views,
    }) = &cli.command
    {
        let sized = GiSettings {
            tiles_per_bucket_log2: *tiles_per_bucket_log2,
            cell_size_pixels: *cell_size_pixels,
            multi_bounce: *multi_bounce,
            ..GiSettings::default()
        }
        .with_cache_for(*width, *height);
        let settings = GiSettings {
            buckets_log2: buckets_log2.unwrap_or(sized.buckets_log2),
            min_cell_size: *min_cell_size,
            temporal_feedback: !*no_feedback,
            multi_bounce: *multi_bounce,
            short_ray_flag: !*no_leak_fixes,
            bypass: !*no_leak_fixes,
            restir: *restir,
            ..sized
        };
        let options = ViewOptions {
            sky: view.sky.unwrap_or(Vec3::ZERO),
            emissive_multiplier: view.emissive_multiplier,
            seed: view.seed,
        };
        let output = view.output(out, *width, *height);
        let run = CacheViewRun {
            frames: *frames,
            settings,
            options,
            debug_views: debug_views.as_deref(),
        };
        cache_view(&ctx, scene, &output, view.camera(), view.sky()?, &run)?;
    }
    if let Some(Command::View(args)) = &cli.command {
        run_view(&ctx, args)?;
    }
    check_validation(&ctx)
}

fn smoke(ctx: &Context, invocations: u32) -> Result<(), Box<dyn std::error::Error>> {
    let report = gi_host::smoke::run(ctx, invocations)?;
    if report.mismatches > 0 {
        return Err(format!(
            "smoke dispatch: {} of {} results differ from the CPU",
            report.mismatches, report.invocations
        )
        .into());
    }
    let timing = report
        .gpu_ms
        .map(|ms| format!(" in {ms:.3} ms GPU time"))
        .unwrap_or_default();
    println!(
        "smoke dispatch:      ok, {} invocations match the CPU{timing}",
        report.invocations
    );
    Ok(())
}

fn compare(
    reference: &Path,
    test: &Path,
    exposure: f32,
    heat_map: Option<&Path>,
) -> Result<(), Box<dyn std::error::Error>> {
    let settings = CompareSettings {
        tone: ToneMap {
            exposure,
            ..ToneMap::default()
        },
        ..CompareSettings::default()
    };
    let comparison = metrics::compare(
        &HdrImage::read(reference)?,
        &HdrImage::read(test)?,
        &settings,
    )
    .map_err(|e| format!("{} vs {}: {e}", reference.display(), test.display()))?;
    println!("{}", comparison.metrics);
    if let Some(path) = heat_map {
        comparison.flip_map.write_heat_map(path)?;
        println!("heat map: {}", path.display());
    }
    Ok(())
}

fn check_validation(ctx: &Context) -> Result<(), Box<dyn std::error::Error>> {
    match ctx.validation_messages() {
        Some(messages) if !messages.is_empty() => {
            Err(format!("{} validation messages (printed above)", messages.len()).into())
        }
        _ => Ok(()),
    }
}

fn gbuffer(
    ctx: &Context,
    path: &Path,
    out: &Path,
    width: u32,
    height: u32,
) -> Result<(), Box<dyn std::error::Error>> {
    let start = Instant::now();
    let scene = load_scene(path)?;
    let shading = ShadingData::new(&scene)?;
    let bvh = match ctx.variant() {
        KernelVariant::Software => Some(Bvh::new(&scene)?),
        KernelVariant::RayQuery => None,
    };
    println!(
        "scene:               {} ({} triangles, {} instances, {} lights, loaded in {:.0} ms)",
        path.display(),
        scene.triangle_count(),
        scene.instances.len(),
        scene.lights.len(),
        start.elapsed().as_secs_f64() * 1e3
    );
    // The G-buffer reads no lights, but they are part of the scene's set.
    let lights = LightSet::new(&scene, None, false);
    let gpu = GpuScene::upload(ctx, &scene, bvh.as_ref(), &shading, &lights)?;
    let (ms, data) = render_gbuffer(ctx, &gpu, &scene_camera(&scene, width, height))?;
    let files = write_debug_pngs(&data, out)?;
    let timing = ms
        .map(|ms| format!(" in {ms:.2} ms GPU time"))
        .unwrap_or_default();
    println!("G-buffer:            {width}x{height}{timing}");
    for f in files {
        println!("wrote                {}", f.display());
    }
    Ok(())
}

/// Runs the G-buffer pass once.
fn render_gbuffer(
    ctx: &Context,
    scene: &GpuScene,
    camera: &CameraParams,
) -> gi_host::Result<(Option<f64>, GBufferData)> {
    let [width, height] = camera.image_size;
    let mut pass = GBufferPass::new(ctx)?;
    let images = GBufferImages::new(ctx, width, height)?;
    let ms = pass.run(ctx, scene, camera, &images)?;
    Ok((ms, images.read_back(ctx)?))
}

/// Parses `x,y,z`.
fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>().map_err(|e| format!("{p:?}: {e}")))
        .collect::<Result<_, _>>()?;
    match parts[..] {
        [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("{s:?} is not three finite numbers x,y,z")),
    }
}

/// A radiance r,g,b: three finite numbers ≥ 0.
fn parse_radiance(s: &str) -> Result<Vec3, String> {
    parse_vec3(s)
        .ok()
        .filter(|v| v.min_element() >= 0.0)
        .ok_or_else(|| format!("{s:?} is not a radiance r,g,b of three finite numbers ≥ 0"))
}

fn parse_finite(s: &str) -> Result<f32, String> {
    s.trim()
        .parse::<f32>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("{s:?} is not a finite number"))
}

fn parse_non_negative(s: &str) -> Result<f32, String> {
    parse_finite(s)
        .ok()
        .filter(|&x| x >= 0.0)
        .ok_or_else(|| format!("{s:?} is not a finite number ≥ 0"))
}

/// A vertical field of view in degrees, strictly between 0 and 180.
fn parse_fov(s: &str) -> Result<f32, String> {
    parse_finite(s)
        .ok()
        .filter(|&x| x > 0.0 && x < 180.0)
        .ok_or_else(|| format!("{s:?} is not a field of view between 0 and 180 degrees"))
}

fn parse_strategy(s: &str) -> Result<Strategy, String> {
    match s {
        "mis" => Ok(Strategy::Mis),
        "lights" => Ok(Strategy::LightsOnly),
        "bsdf" => Ok(Strategy::BsdfOnly),
        _ => Err(format!("{s:?} is not one of mis, lights, bsdf")),
    }
}

/// The environment image lighting a render, and whether it is importance-sampled.
/// The environment of `--environment`, else a constant `--sky` as a uniform environment image
/// (so that light sampling finds it too), else none.
fn sky_environment(path: Option<&Path>, sky: Option<Vec3>) -> gi_host::Result<Option<Environment>> {
    match (path, sky) {
        (Some(p), _) => Environment::read(p).map(Some),
        (None, Some(s)) if s.max_element() > 0.0 => Environment::constant(s).map(Some),
        _ => Ok(None),
    }
}

struct Sky {
    environment: Option<Environment>,
    sample: bool,
}

/// A scene on the device, ready for the path tracer.
struct Uploaded(GpuScene);

impl Uploaded {
    fn new(ctx: &Context, scene: &Scene, sky: Sky) -> gi_host::Result<Self> {
        upload(ctx, scene, sky).map(|(_, gpu)| Self(gpu))
    }

    /// Renders `settings.samples` paths per pixel of `camera`, reporting progress to `progress`.
    fn render(
        &self,
        ctx: &Context,
        camera: &CameraParams,
        settings: &PathTracerSettings,
        progress: impl FnMut(u32, u32),
    ) -> gi_host::Result<Render> {
        PathTracerPass::new(ctx)?.render(ctx, &self.0, camera, settings, progress)
    }
}

/// Writes `image` to `out` (OpenEXR, linear) and a PNG beside it, tone-mapped with `exposure`
/// stops, creating the folder; returns the PNG's path.
fn write_image(
    out: &Path,
    image: &HdrImage,
    exposure: f32,
) -> Result<PathBuf, Box<dyn std::error::Error>> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let png = out.with_extension("png");
    image.write_exr(out)?;
    image.write_png(
        &png,
        &ToneMap {
            exposure,
            ..ToneMap::default()
        },
    )?;
    Ok(png)
}

/// Prints what the scene at `path` holds.
fn describe(path: &Path, scene: &Scene) {
    println!(
        "scene:               {} ({} triangles, {} punctual lights, {} emissive triangles)",
        path.display(),
        scene.triangle_count(),
        scene.lights.len(),
        scene.emissive_triangles.len()
    );
}

/// The camera given on the command line (position, target, fov in degrees), else the scene's.
fn view_camera(
    view: Option<(Vec3, Vec3, f32)>,
    scene: &Scene,
    width: u32,
    height: u32,
) -> CameraParams {
    match view {
        Some((position, target, fov)) => CameraParams::new(
            position,
            target - position,
            Vec3::Y,
            fov.to_radians(),
            width,
            height,
        ),
        None => scene_camera(scene, width, height),
    }
}

/// Uploads `scene` lit by its emitters and `sky`, printing the time it took and the scene's
/// device memory by part.
fn upload(ctx: &Context, scene: &Scene, sky: Sky) -> gi_host::Result<(LightSet, GpuScene)> {
    let start = Instant::now();
    let (lights, gpu) = GpuScene::upload_lit(ctx, scene, sky.environment, sky.sample)?;
    println!(
        "upload:              {:.2} s (acceleration structure, textures, lights)",
        start.elapsed().as_secs_f64()
    );
    println!("scene memory:        {}", gpu.memory());
    Ok((lights, gpu))
}

fn load_scene(path: &Path) -> Result<Scene, Box<dyn std::error::Error>> {
    let (scene, warnings) = Scene::load(path)?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    println!("{}", scene.load_report());
    Ok(scene)
}

/// Where and how `gi render` writes its image.
struct Output<'a> {
    path: &'a Path,
    width: u32,
    height: u32,
    exposure: f32,
}

fn render(
    ctx: &Context,
    path: &Path,
    output: &Output<'_>,
    view: Option<(Vec3, Vec3, f32)>,
    sky: Sky,
    settings: &PathTracerSettings,
) -> Result<(), Box<dyn std::error::Error>> {
    let Output {
        path: out,
        width,
        height,
        exposure,
    } = *output;
    let start = Instant::now();
    let scene = load_scene(path)?;
    describe(path, &scene);
    let camera = view_camera(view, &scene, width, height);
    let uploaded = Uploaded::new(ctx, &scene, sky)?;
    println!("memory:\n{}", gi_host::frame::MemoryTable::of(ctx));
    let bar = ProgressBar::new(u64::from(settings.samples)).with_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} spp, eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let rendered = uploaded.render(ctx, &camera, settings, |done, _| {
        bar.set_position(u64::from(done))
    });
    bar.finish_and_clear();
    drop(uploaded);
    let rendered = rendered?;
    let png = write_image(out, &rendered.image, exposure)?;
    let seconds = start.elapsed().as_secs_f64();
    let paths = f64::from(width) * f64::from(height) * f64::from(settings.samples);
    let gpu = rendered
        .gpu_ms
        .map(|ms| format!(", {:.2} Mpaths/s GPU time", paths / ms / 1e3))
        .unwrap_or_default();
    println!(
        "render:              {width}x{height}, {} spp, {} bounces in {seconds:.1} s{gpu}",
        settings.samples, settings.max_bounces
    );
    println!("wrote                {}", out.display());
    println!("wrote                {}", png.display());
    Ok(())
}

fn benchmark(
    cli: &Cli,
    scenes: &[PathBuf],
    width: u32,
    height: u32,
    settings: &PathTracerSettings,
) -> Result<(), Box<dyn std::error::Error>> {
    let loaded: Vec<(String, Scene)> = scenes
        .iter()
        .map(|p| Ok((p.display().to_string(), load_scene(p)?)))
        .collect::<Result<_, Box<dyn std::error::Error>>>()?;
    println!(
        "path tracer, {width}x{height}, {} spp, {} bounces",
        settings.samples, settings.max_bounces
    );
    println!(
        "{:<32} {:>10} {:>22} {:>14} {:>14}",
        "scene", "triangles", "variant", "GPU ms", "Mpaths/s"
    );
    for trace in [TraceMode::RayQuery, TraceMode::Software] {
        let ctx = match Context::new(&ContextOptions {
            validation: cli.validation,
            device: cli.device.clone(),
            trace,
        }) {
            Ok(ctx) => ctx,
            Err(e) => {
                println!("{trace:?}: skipped ({e})");
                continue;
            }
        };
        for (name, scene) in &loaded {
            let camera = scene_camera(scene, width, height);
            let sky = Sky {
                environment: None,
                sample: false,
            };
            let uploaded = Uploaded::new(&ctx, scene, sky)?;
            // A first small render compiles the pipeline and warms the caches.
            let warm = PathTracerSettings {
                samples: 1,
                ..*settings
            };
            uploaded.render(&ctx, &camera, &warm, |_, _| {})?;
            let rendered = uploaded.render(&ctx, &camera, settings, |_, _| {})?;
            drop(uploaded);
            let ms = rendered.gpu_ms.unwrap_or(f64::NAN);
            let paths = f64::from(width) * f64::from(height) * f64::from(settings.samples);
            println!(
                "{name:<32} {:>10} {:>22} {ms:>14.1} {:>14.3}",
                scene.triangle_count(),
                ctx.variant().to_string(),
                paths / ms / 1e3
            );
        }
        check_validation(&ctx)?;
    }
    Ok(())
}

/// What `gi cache-view` runs besides the scene and the output.
struct CacheViewRun<'a> {
    frames: u32,
    settings: GiSettings,
    options: ViewOptions,
    debug_views: Option<&'a Path>,
}

fn cache_view(
    ctx: &Context,
    path: &Path,
    output: &Output<'_>,
    view: Option<(Vec3, Vec3, f32)>,
    sky: Sky,
    run: &CacheViewRun<'_>,
) -> Result<(), Box<dyn std::error::Error>> {
    let Output {
        path: out,
        width,
        height,
        exposure,
    } = *output;
    run.settings.validate(width, height)?;
    let start = Instant::now();
    let scene = load_scene(path)?;
    describe(path, &scene);
    let camera = view_camera(view, &scene, width, height);
    let (lights, gpu) = upload(ctx, &scene, sky)?;
    let s = &run.settings;
    println!(
        "cache:               {} buckets x {} tiles = {} tiles, cells of {} px (min {} m), \
         feedback {}, multi-bounce {}, short-ray flag {}, bypass {}, ReSTIR {}",
        1u32 << s.buckets_log2,
        1u32 << s.tiles_per_bucket_log2,
        s.tile_count(),
        s.cell_size_pixels,
        s.min_cell_size,
        on_off(s.temporal_feedback),
        on_off(s.multi_bounce),
        on_off(s.short_ray_flag),
        on_off(s.bypass),
        on_off(s.restir)
    );
    let mut cache = CacheView::new(ctx, &lights, width, height, *s, run.options)?;
    let rendered = (|| -> Result<_, Box<dyn std::error::Error>> {
        let mut keys_before = vec![];
        for f in 0..run.frames {
            if run.debug_views.is_some() && f + 1 == run.frames {
                keys_before = cache.read_back_state(ctx)?.keys;
            }
            let o = cache.render_frame(ctx, &gpu, &camera)?;
            println!(
                "frame {:>5}: live tiles {:>6}  inserted {:>5}  failed inserts {:>5}  evicted {:>5}  \
                 | queries {:>7}  fed back {:>7}  shadow rays {:>7}  bypassed {:>6}  \
                 bounce misses {:>6}  carried {:>6}",
                o.frame,
                o.live_tiles,
                o.inserted,
                o.failed_inserts,
                o.evicted,
                o.queries,
                o.fed_back,
                o.shadow_rays,
                o.bypassed,
                o.bounce_misses,
                o.carried
            );
        }
        let image = cache.image(ctx)?;
        let views = match run.debug_views {
            Some(_) => cache.debug_views(ctx, &keys_before)?,
            None => vec![],
        };
        println!("GPU time per pass:\n{}", cache.timings());
        println!("memory:\n{}", gi_host::frame::MemoryTable::of(ctx));
        Ok((image, views))
    })();
    drop(cache);
    drop(gpu);
    let (image, views) = rendered?;
    let png = write_image(out, &image, exposure)?;
    println!(
        "cache view:          {width}x{height}, {} frames in {:.1} s",
        run.frames,
        start.elapsed().as_secs_f64()
    );
    println!("wrote                {}", out.display());
    println!("wrote                {}", png.display());
    if let Some(dir) = run.debug_views {
        for f in write_debug_views(&views, dir, exposure)? {
            println!("wrote                {}", f.display());
        }
    }
    Ok(())
}

fn on_off(on: bool) -> &'static str {
    if on { "on" } else { "off" }
}
