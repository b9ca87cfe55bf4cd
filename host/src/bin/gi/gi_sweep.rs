//! `gi sweep`: the speed-and-accuracy sweep of `gi_host::bench` from the command line.

use gi_host::bench::scaling::{Axis, ScalingConfig};
use gi_host::bench::{self, BenchConfig, BenchScene, Sweeps};
use gi_host::vulkan::{Context, ContextOptions};
use gi_host::{KernelVariant, TraceMode};
use std::path::PathBuf;

/// The Bitterli living room (132k triangles) and its sky, beside the repository.
const LIVING_ROOM: &str = "../shared/scenes/third-party/bitterli/living-room/living-room.glb+../shared/scenes/third-party/bitterli/living-room/sky-19.exr";

/// A group of sweep points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SweepGroup {
    /// The presets.
    Presets,
    /// Each knob alone from `balanced`.
    Knobs,
    /// Half and twice the resolution.
    Resolution,
    /// The other tracing variant.
    Variant,
}

/// The options of `gi sweep`.
#[derive(clap::Args)]
pub struct SweepArgs {
    /// Scenes: glTF files, each optionally followed by `+ENVIRONMENT` (an OpenEXR or Radiance
    /// HDR image lighting it). Default: the repository's Cornell box and indirect room, and
    /// the Bitterli living room from ../shared (skipped, saying so, where absent); with
    /// --scaling, none: only the scaling sweeps run.
    scenes: Vec<String>,
    /// Output folder: references/, results.csv, results.json, table.md, equal-time.md,
    /// scaling.csv, and the plots (PNG and SVG).
    #[arg(long, default_value = "out/sweep")]
    out: PathBuf,
    /// Base image width.
    #[arg(long, default_value_t = 320, value_parser = clap::value_parser!(u32).range(2..=4096))]
    width: u32,
    /// Base image height.
    #[arg(long, default_value_t = 180, value_parser = clap::value_parser!(u32).range(2..=4096))]
    height: u32,
    /// Frames of a static run (the converged error is the last frame's).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(2..=1 << 16))]
    frames: u32,
    /// Frames of an orbit run (the error under motion); 0 for none.
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(0..=1 << 16))]
    motion_frames: u32,
    /// Paths per pixel of the references.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    reference_spp: u32,
    /// Point groups to measure, comma-separated.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "presets,knobs,resolution,variant"
    )]
    sweep: Vec<SweepGroup>,
    /// The equal-time comparison renders the path tracer at 1, 2, 4 … up to this many spp; 0
    /// skips it.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(0..=1 << 16))]
    equal_time_max_spp: u32,
    /// Also run the scaling sweeps (pixels, triangles, lights, emissive triangles) on generated
    /// scenes.
    #[arg(long)]
    scaling: bool,
    /// With --scaling, the sweeps to run.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "pixels,triangles,lights,emitters"
    )]
    scaling_axes: Vec<Axis>,
    /// Measure nothing: write the tables and plots of DIR again from its results.json.
    #[arg(long, value_name = "DIR")]
    pub replot: Option<PathBuf>,
}

/// `gi sweep --replot DIR`: the outputs of DIR again from its results.json.
pub fn replot(dir: &std::path::Path) -> Result<(), Box<dyn std::error::Error>> {
    let (_, files) = gi_host::bench::report::replot(dir)?;
    for f in files {
        println!("wrote                {}", f.display());
    }
    Ok(())
}

/// Runs the sweep on `ctx` (and a context of the other tracing variant where the device has
/// both and the variant group is on).
pub fn run_sweep(
    ctx: &Context,
    options: &ContextOptions,
    args: &SweepArgs,
) -> Result<(), Box<dyn std::error::Error>> {
    let has = |g| args.sweep.contains(&g);
    let sweeps = Sweeps {
        presets: has(SweepGroup::Presets),
        knobs: has(SweepGroup::Knobs),
        resolution: has(SweepGroup::Resolution),
        variant: has(SweepGroup::Variant),
    };
    let scenes = if args.scenes.is_empty() && !args.scaling {
        vec![
            "scenes/cornell-box.gltf".to_owned(),
            "scenes/indirect-room.gltf".to_owned(),
            LIVING_ROOM.to_owned(),
        ]
    } else {
        args.scenes.clone()
    };
    let config = BenchConfig {
        scenes: scenes.iter().map(|s| BenchScene::parse(s)).collect(),
        width: args.width,
        height: args.height,
        frames: args.frames,
        motion_frames: args.motion_frames,
        reference_spp: args.reference_spp,
        sweeps,
        equal_time_max_spp: args.equal_time_max_spp,
        scaling: args
            .scaling
            .then(|| ScalingConfig::full(args.width, args.height).keep(&args.scaling_axes)),
        out: args.out.clone(),
    };
    let other_trace = match ctx.variant() {
        KernelVariant::RayQuery => Some(TraceMode::Software),
        KernelVariant::Software if ctx.capabilities().ray_query => Some(TraceMode::RayQuery),
        KernelVariant::Software => None,
    };
    let other = match other_trace.filter(|_| sweeps.variant) {
        Some(trace) => Some(Context::new(&ContextOptions {
            trace,
            ..options.clone()
        })?),
        None => {
            if sweeps.variant {
                println!("tracing variant: this device has only {}", ctx.variant());
            }
            None
        }
    };
    let (report, files) = bench::run(ctx, other.as_ref(), &config)?;
    println!(
        "\n{}",
        gi_host::bench::report::markdown_table(&report).trim_end()
    );
    if !report.equal_time.is_empty() {
        println!(
            "\n{}",
            gi_host::bench::report::equal_time_table(&report).trim_end()
        );
    }
    for f in files {
        println!("wrote                {}", f.display());
    }
    if let Some(o) = &other {
        super::check_validation(o)?;
    }
    Ok(())
}
