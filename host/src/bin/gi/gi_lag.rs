//! `gi lag`: how many frames the GI image takes to follow a light switched off, switched on and
//! moved, for every preset (`gi_host::bench::light_change`).

use super::gi_render::{Technique, switch_off};
use super::load_scene;
use gi_host::bench::light_change::{self, Frames, LightChange, SETTLED};
use gi_host::gbuffer::scene_camera;
use gi_host::gi::Preset;
use gi_host::vulkan::Context;
use std::path::PathBuf;

/// The options of `gi lag`.
#[derive(clap::Args)]
pub struct LagArgs {
    /// The glTF scene: its brightest emissive material is the light that changes.
    #[arg(default_value = "scenes/cornell-box.gltf")]
    pub scene: PathBuf,
    /// Image width in pixels.
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(8..=8192))]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 72, value_parser = clap::value_parser!(u32).range(8..=8192))]
    pub height: u32,
    /// Still frames before the change, and of the run that finds the new steady state.
    #[arg(long, default_value_t = 160, value_parser = clap::value_parser!(u32).range(1..))]
    pub warm_up: u32,
    /// The last frames of the warm-up whose mean is a steady state.
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..))]
    pub steady: u32,
    /// Frames measured after the change.
    #[arg(long, default_value_t = 96, value_parser = clap::value_parser!(u32).range(1..))]
    pub after: u32,
    /// Measure these presets only (default: all three).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub preset: Vec<PresetName>,
    /// Techniques to switch off in every preset (to find where the lag comes from).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub no: Vec<Technique>,
    /// Random streams each figure is the mean of (one stream is one noisy realisation of the
    /// response).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub seeds: u32,
    /// Temporal radiance feedback on in every preset (the presets leave it off).
    #[arg(long)]
    pub feedback: bool,
    /// The cache's sample cap in every preset, instead of the preset's (1 to 1024; with
    /// `--no adaptive-blend`, a fixed cap: how fast the cache alone can follow).
    #[arg(long)]
    pub sample_cap: Option<u32>,
}

/// A preset named on the command line (`gi lag`, `gi memory`).
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PresetName {
    /// `Preset::Fast`.
    Fast,
    /// `Preset::Balanced`.
    Balanced,
    /// `Preset::Quality`.
    Quality,
}

impl From<PresetName> for Preset {
    fn from(p: PresetName) -> Self {
        match p {
            PresetName::Fast => Preset::Fast,
            PresetName::Balanced => Preset::Balanced,
            PresetName::Quality => Preset::Quality,
        }
    }
}

/// Measures and prints the table.
pub fn run_lag(ctx: &Context, args: &LagArgs) -> Result<(), Box<dyn std::error::Error>> {
    let scene = load_scene(&args.scene)?;
    let camera = scene_camera(&scene, args.width, args.height);
    let frames = Frames {
        warm_up: args.warm_up,
        steady: args.steady,
        after: args.after,
    };
    println!(
        "{}, {}x{}: share of the change still missing after 5, 15 and 30 frames (the mean of {} \
         random stream(s)); frames until it stays at most {:.0} %",
        args.scene.display(),
        args.width,
        args.height,
        args.seeds,
        SETTLED * 100.0
    );
    println!(
        "| preset | change | after 5 | after 15 | after 30 | frames to {:.0} % |",
        SETTLED * 100.0
    );
    println!("|---|---|---|---|---|---|");
    let presets: Vec<Preset> = if args.preset.is_empty() {
        Preset::ALL.to_vec()
    } else {
        args.preset.iter().map(|&p| p.into()).collect()
    };
    for preset in presets {
        for change in LightChange::ALL {
            let mut settings = preset.settings(args.width, args.height);
            settings.temporal_feedback |= args.feedback;
            switch_off(&mut settings, &args.no);
            if let Some(cap) = args.sample_cap {
                settings.sample_cap = cap;
            }
            let r =
                light_change::measure(ctx, &scene, change, &camera, settings, frames, args.seeds)?;
            let share = |f| r.after(f).map_or("-".to_owned(), |s| format!("{:.3}", s));
            let settle = r
                .frames_to_settle()
                .map_or(format!("> {}", args.after), |f| f.to_string());
            println!(
                "| {} | {} | {} | {} | {} | {settle} |",
                preset.name(),
                change.name(),
                share(5),
                share(15),
                share(30)
            );
        }
    }
    Ok(())
}
