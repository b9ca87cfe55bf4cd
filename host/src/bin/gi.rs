//! `gi`: the command-line program of the GI-1.0 port.

use clap::{Parser, Subcommand};
use gi_host::gbuffer::{GBufferData, GBufferImages, GBufferPass, scene_camera, write_debug_pngs};
use gi_host::image_io::{HdrImage, ToneMap};
use gi_host::metrics::{self, CompareSettings};
use gi_host::scene::Scene;
use gi_host::scene::gpu_data::{GpuShadingData, ShadingData};
use gi_host::scene::upload::{SceneGeometry, build_bvh};
use gi_host::vulkan::{Context, ContextOptions};
use gi_host::{KernelVariant, TraceMode};
use gi_shared::camera::CameraParams;
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
    /// Turn the Vulkan validation layer on and fail on any message it prints.
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
    /// Compare a test image with a reference: RMSE, relative MSE, PSNR and FLIP, and optionally
    /// FLIP's error heat map. Images are OpenEXR (linear) or PNG/JPEG (sRGB).
    Compare {
        /// The reference (ground truth).
        reference: PathBuf,
        /// The image under test.
        test: PathBuf,
        /// Exposure in stops applied before tone mapping, for PSNR and FLIP.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        exposure: f32,
        /// Write FLIP's error heat map (PNG) here.
        #[arg(long)]
        heat_map: Option<PathBuf>,
    },
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
    let options = ContextOptions {
        validation: cli.validation,
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
    let (scene, warnings) = Scene::load(path)?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    let shading = ShadingData::new(&scene)?;
    let bvh = match ctx.variant() {
        KernelVariant::Software => Some(build_bvh(&scene)?),
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
    let geometry = SceneGeometry::new(ctx, &scene, bvh.as_ref())?;
    let result = GpuShadingData::new(ctx, &shading).and_then(|gpu| {
        let camera = scene_camera(&scene, width, height);
        let rendered = render_gbuffer(ctx, &geometry, &gpu, &camera);
        gpu.destroy(ctx);
        rendered
    });
    geometry.destroy(ctx);
    let (ms, data) = result?;
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

/// Runs the G-buffer pass once, freeing what it created whatever happens.
fn render_gbuffer(
    ctx: &Context,
    geometry: &SceneGeometry,
    shading: &GpuShadingData,
    camera: &CameraParams,
) -> gi_host::Result<(Option<f64>, GBufferData)> {
    let [width, height] = camera.image_size;
    let mut pass = GBufferPass::new(ctx, geometry)?;
    let images = match GBufferImages::new(ctx, width, height) {
        Ok(i) => i,
        Err(e) => {
            pass.destroy(ctx);
            return Err(e);
        }
    };
    let result = pass
        .run(ctx, geometry, shading, camera, &images)
        .and_then(|ms| Ok((ms, images.read_back(ctx)?)));
    images.destroy(ctx);
    pass.destroy(ctx);
    result
}
