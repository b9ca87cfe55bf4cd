//! `gi memory`: what the GI frame allocates for each preset at each resolution, without
//! rendering (`gi_host::bench::memory`), as a Markdown table.

use super::gi_lag::PresetName;
use super::load_scene;
use gi_host::bench::memory::measure_memory;
use gi_host::gi::Preset;
use gi_host::scene::lights::LightSet;
use gi_host::vulkan::Context;
use std::path::PathBuf;

/// Bytes per MiB.
const MIB: f64 = 1024.0 * 1024.0;

/// The options of `gi memory`.
#[derive(clap::Args)]
pub struct MemoryArgs {
    /// The glTF scene whose lights the frame is sized for (at most 16 lights need no light grid).
    #[arg(default_value = "scenes/cornell-box.gltf")]
    pub scene: PathBuf,
    /// Presets to measure (default: all three).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub preset: Vec<PresetName>,
    /// Resolutions to measure, as `WIDTHxHEIGHT`.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = parse_resolution,
        default_value = "1280x720,1920x1080,3840x2160"
    )]
    pub resolution: Vec<(u32, u32)>,
}

/// `WIDTHxHEIGHT`, each 8 to 16384.
fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("resolution {s:?}: expected WIDTHxHEIGHT, each 8 to 16384");
    let (w, h) = s.split_once('x').ok_or_else(bad)?;
    let side = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|v| (8..=16384).contains(v))
    };
    Ok((side(w).ok_or_else(bad)?, side(h).ok_or_else(bad)?))
}

/// Measures and prints the table.
pub fn run_memory(ctx: &Context, args: &MemoryArgs) -> Result<(), Box<dyn std::error::Error>> {
    let scene = load_scene(&args.scene)?;
    let lights = LightSet::new(&scene, None, true);
    let presets: Vec<Preset> = if args.preset.is_empty() {
        vec![Preset::Fast, Preset::Balanced, Preset::Quality]
    } else {
        args.preset.iter().map(|p| Preset::from(*p)).collect()
    };
    println!(
        "| preset | resolution | bytes per pixel | cache tiles | cache MiB | total MiB |\n\
         |---|---|---|---|---|---|"
    );
    for preset in presets {
        for &(width, height) in &args.resolution {
            let m = measure_memory(ctx, &lights, preset, width, height)?;
            println!(
                "| {preset:?} | {width} × {height} | {:.1} | {} | {:.1} | {:.1} |",
                m.bytes_per_pixel(),
                m.cache_tiles,
                m.cache_bytes as f64 / MIB,
                m.total_bytes as f64 / MIB
            );
        }
    }
    Ok(())
}
