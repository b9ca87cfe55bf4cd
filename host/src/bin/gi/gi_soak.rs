//! `gi soak`: the GI frame for thousands of frames with a moving camera, light and object,
//! checked throughout (`gi_host::soak`); a summary table, and a non-zero exit when a check fails.

use super::load_scene;
use gi_host::soak::{self, SoakLimits, SoakReport, SoakSettings};
use gi_host::vulkan::Context;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The options of `gi soak`.
#[derive(clap::Args)]
pub struct SoakArgs {
    /// The glTF scene: it must have an animation (the moving object).
    #[arg(default_value = "scenes/moving-box.gltf")]
    pub scene: PathBuf,
    /// Frames to render.
    #[arg(long, default_value_t = SoakSettings::default().frames,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub frames: u32,
    /// Frames between two checks (NaN/Inf on the GPU, memory, validation messages).
    #[arg(long, default_value_t = SoakSettings::default().check_every,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub check_every: u32,
    /// Frames after which every motion repeats: the warm-up, and the length of the first and
    /// last windows whose frame time and occupancy are compared. At most a third of --frames.
    #[arg(long, default_value_t = SoakSettings::default().period,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub period: u32,
    /// Image width in pixels.
    #[arg(long, default_value_t = SoakSettings::default().width,
          value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = SoakSettings::default().height,
          value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub height: u32,
    /// Largest turn of the camera's swing either way, degrees.
    #[arg(long, default_value_t = SoakSettings::default().swing_degrees)]
    pub swing_degrees: f32,
    /// Radiant intensity of the moving point light, W/sr.
    #[arg(long, default_value_t = SoakSettings::default().light_intensity)]
    pub light_intensity: f32,
    /// Most growth of the host's resident memory after the warm-up, MiB.
    #[arg(long, default_value_t = SoakLimits::default().host_growth_mib)]
    pub max_host_growth_mib: f64,
    /// Most change of the mean frame time from the first window to the last, percent.
    #[arg(long, default_value_t = SoakLimits::default().frame_time_drift * 100.0)]
    pub max_frame_time_drift: f64,
    /// Most growth of the peak cache occupancy from the first window to the last, percent.
    #[arg(long, default_value_t = SoakLimits::default().occupancy_growth * 100.0)]
    pub max_occupancy_growth: f64,
    /// Also write every frame's figures (frame time, wall time, live tiles) as CSV here.
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Run without the validation layer: the host's resident memory is then checked (the
    /// layer's own bookkeeping grows with every submission), validation messages are not.
    #[arg(long)]
    pub no_validation: bool,
}

impl SoakArgs {
    fn settings(&self) -> SoakSettings {
        SoakSettings {
            frames: self.frames,
            check_every: self.check_every,
            period: self.period,
            width: self.width,
            height: self.height,
            swing_degrees: self.swing_degrees,
            light_intensity: self.light_intensity,
            limits: SoakLimits {
                host_growth_mib: self.max_host_growth_mib,
                device_growth_bytes: 0,
                frame_time_drift: self.max_frame_time_drift / 100.0,
                occupancy_growth: self.max_occupancy_growth / 100.0,
            },
        }
    }
}

/// Runs the soak and prints its figures; an error when a check failed.
pub fn run_soak(ctx: &Context, args: &SoakArgs) -> Result<(), Box<dyn std::error::Error>> {
    let settings = args.settings();
    settings.validate()?;
    let scene = load_scene(&args.scene)?;
    println!(
        "soak:                {} frames of {} at {}x{}, checks every {}, motions repeating every \
         {} frames",
        settings.frames,
        args.scene.display(),
        settings.width,
        settings.height,
        settings.check_every,
        settings.period
    );
    let report = soak::run(ctx, scene, &settings, |s| {
        let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
        println!(
            "frame {:>6}: non-finite {:>3} buffers | RSS {:>8.1} MiB | device {:>7.2} MiB in {} \
             allocations | validation messages {}",
            s.frame,
            s.non_finite.len(),
            s.host_bytes.map_or(f64::NAN, mib),
            mib(s.device.allocated),
            s.device.allocations,
            s.validation_messages
                .map_or("off".to_string(), |n| n.to_string())
        );
    })?;
    if let Some(path) = &args.csv {
        write_csv(path, &report)?;
        println!("wrote                {}", path.display());
    }
    print!("{report}");
    let failed = report
        .verdicts(&settings.limits)
        .iter()
        .filter(|v| !v.passed)
        .count();
    if failed > 0 {
        return Err(format!("soak: {failed} checks failed (FAIL above)").into());
    }
    Ok(())
}

fn write_csv(path: &Path, report: &SoakReport) -> Result<(), Box<dyn std::error::Error>> {
    let io = |e: std::io::Error| format!("--csv {}: {e}", path.display());
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
    let time = if report.gpu_timed {
        "gpu_ms"
    } else {
        "render_ms"
    };
    writeln!(out, "frame,{time},wall_ms,live_tiles").map_err(io)?;
    for (f, ((ms, wall), tiles)) in report
        .frame_ms
        .iter()
        .zip(&report.wall_ms)
        .zip(&report.live_tiles)
        .enumerate()
    {
        writeln!(out, "{f},{ms},{wall},{tiles}").map_err(io)?;
    }
    out.flush().map_err(io)?;
    Ok(())
}
