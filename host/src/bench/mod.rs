//! `gi bench`: what each knob costs and what it buys, measured on the device at hand.
//!
//! For each scene, a path-traced reference ([`reference`](mod@reference)) at the last frame's camera of each
//! camera path (static, and an orbit for "under motion"), then every point of the sweep
//! ([`sweep`]: the presets, each knob one at a time from `balanced`, other resolutions, the other
//! tracing variant) rendered for a number of frames ([`measure`]: GPU ms per frame and per pass,
//! memory, relMSE / FLIP / mean against the reference, frame-to-frame change). Then the
//! equal-time comparison with the path tracer ([`equal_time`]) and the cost against pixels,
//! triangles and lights on generated scenes ([`scaling`]). [`report`] writes CSV, JSON and
//! Markdown, [`plot`] the error-against-ms and scaling plots (PNG and SVG).
//!
//! Failure modes: the reference's own noise is part of every error (1024 spp at 320 × 180 puts
//! a floor near relMSE 1e-3 on the test scenes); GPU times on lavapipe are CPU times and move
//! with anything else the machine runs, so compare points of one run only.

pub mod equal_time;
pub mod light_change;
pub mod measure;
pub mod memory;
pub mod plot;
pub mod reference;
pub mod report;
pub mod scaling;
pub mod sweep;

use crate::error::{Error, Result};
use crate::gbuffer::scene_camera;
use crate::gi::ViewOptions;
use crate::gi::camera_path::CameraPath;
use crate::scene::Scene;
use crate::scene::lights::{Environment, LightSet};
use crate::scene::upload::GpuScene;
use crate::vulkan::Context;
use gi_shared::camera::CameraParams;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Degrees the orbit camera path turns per frame ("under motion"): 0.5° at 60 frames per second
/// is a slow pan of 30° per second.
pub const ORBIT_DEGREES_PER_FRAME: f32 = 0.5;
/// Where the orbit's axis stands, as a fraction of the distance to the point looked at: the
/// camera turns (a pan) while moving a little sideways (parallax), and stays in the room it
/// starts in (an orbit about the point looked at took a camera near a wall through it).
pub const ORBIT_PIVOT_FRACTION: f32 = 0.25;

/// A scene to measure: a glTF file and, optionally, the environment image that lights it.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchScene {
    /// Its name in tables and file names: the file's stem.
    pub name: String,
    /// The glTF file.
    pub path: PathBuf,
    /// An equirectangular environment (OpenEXR or Radiance HDR), importance-sampled.
    pub environment: Option<PathBuf>,
}

impl BenchScene {
    /// Parses `SCENE` or `SCENE+ENVIRONMENT`.
    pub fn parse(spec: &str) -> Self {
        let (scene, environment) = match spec.split_once('+') {
            Some((s, e)) => (s, Some(PathBuf::from(e))),
            None => (spec, None),
        };
        let path = PathBuf::from(scene);
        let name = path
            .file_stem()
            .map_or_else(|| scene.to_owned(), |s| s.to_string_lossy().into_owned());
        Self {
            name,
            path,
            environment,
        }
    }
}

/// How the camera moves during a measured run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Motion {
    /// The scene's camera, still: the converged error.
    Static,
    /// Turning [`ORBIT_DEGREES_PER_FRAME`] about a vertical axis in front of the camera
    /// ([`ORBIT_PIVOT_FRACTION`] of the way to the point looked at): the error under motion.
    Orbit,
}

impl Motion {
    /// Its name in tables and file names.
    pub fn name(self) -> &'static str {
        match self {
            Self::Static => "static",
            Self::Orbit => "orbit",
        }
    }

    /// The camera path of `base`, looking toward the scene's `centre`.
    pub fn path(self, base: &CameraParams, centre: glam::Vec3) -> CameraPath {
        match self {
            Self::Static => CameraPath::Static,
            Self::Orbit => CameraPath::orbit_toward(
                base,
                centre,
                ORBIT_DEGREES_PER_FRAME,
                ORBIT_PIVOT_FRACTION,
            ),
        }
    }
}

/// Which points the sweep measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sweeps {
    /// The presets (`fast`, `balanced`, `quality`).
    pub presets: bool,
    /// Each knob changed alone from `balanced`.
    pub knobs: bool,
    /// `balanced` at half and twice the resolution, compared at the base resolution.
    pub resolution: bool,
    /// `balanced` with the other tracing variant, where the device has both.
    pub variant: bool,
}

impl Sweeps {
    /// Every group.
    pub const ALL: Sweeps = Sweeps {
        presets: true,
        knobs: true,
        resolution: true,
        variant: true,
    };
}

/// What `gi bench` measures and where it writes.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    /// The scenes.
    pub scenes: Vec<BenchScene>,
    /// Base image width.
    pub width: u32,
    /// Base image height.
    pub height: u32,
    /// Frames of a static run (the converged error is the last frame's).
    pub frames: u32,
    /// Frames of an orbit run (the error under motion is the last frame's); 0: no motion runs.
    pub motion_frames: u32,
    /// Paths per pixel of the references.
    pub reference_spp: u32,
    /// The sweep's point groups.
    pub sweeps: Sweeps,
    /// The equal-time comparison renders the path tracer at 1, 2, 4 … up to this many spp
    /// (64 or more for the lavapipe goal); 0 skips it.
    pub equal_time_max_spp: u32,
    /// The scaling sweeps, if any.
    pub scaling: Option<scaling::ScalingConfig>,
    /// Output folder (created): references, reports, plots.
    pub out: PathBuf,
}

impl BenchConfig {
    /// Checks the sizes and counts, naming the first that makes no sense.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, why: String| Err(Error::InvalidArgument { name, why });
        if self.scenes.is_empty() && self.scaling.is_none() {
            return bad("scenes", "none given, and no scaling sweep".into());
        }
        if self.frames < 2 {
            return bad(
                "frames",
                format!(
                    "{}: at least 2 (the frame-to-frame change needs two)",
                    self.frames
                ),
            );
        }
        if self.motion_frames == 1 {
            return bad(
                "motion_frames",
                "1: 0 (no motion runs) or at least 2".into(),
            );
        }
        if self.reference_spp == 0 {
            return bad("reference_spp", "0: the reference needs samples".into());
        }
        if self.width < 2 || self.height < 2 {
            return bad(
                "resolution",
                format!(
                    "{}x{}: at least 2x2 (the sweep halves it)",
                    self.width, self.height
                ),
            );
        }
        crate::gi::GiSettings::for_resolution(self.width * 2, self.height * 2)
            .validate(self.width * 2, self.height * 2)
    }
}

impl BenchConfig {
    /// Frames of a run along `motion`.
    pub fn frames_of(&self, motion: Motion) -> u32 {
        match motion {
            Motion::Static => self.frames,
            Motion::Orbit => self.motion_frames,
        }
    }
}

/// A scene loaded, uploaded to one context, with its camera.
pub struct LoadedScene {
    /// The scene.
    pub scene: Scene,
    /// Its lights (and environment) as uploaded.
    pub lights: LightSet,
    /// On the device.
    pub gpu: GpuScene,
    /// What the GI frame needs besides the scene: no constant sky (an environment is a light),
    /// emission as in the file, seed 0.
    pub options: ViewOptions,
}

impl LoadedScene {
    /// Loads `bench.path` (and its environment) and uploads it to `ctx`.
    pub fn load(ctx: &Context, bench: &BenchScene) -> Result<Self> {
        let (scene, _warnings) = Scene::load(&bench.path)?;
        Self::upload(ctx, scene, bench.environment.as_deref())
    }

    /// Uploads a scene (loaded or generated) lit by its lights and `environment`.
    pub fn upload(ctx: &Context, scene: Scene, environment: Option<&Path>) -> Result<Self> {
        let environment = environment.map(Environment::read).transpose()?;
        let (lights, gpu) = GpuScene::upload_lit(ctx, &scene, environment, true)?;
        Ok(Self {
            scene,
            lights,
            gpu,
            options: ViewOptions {
                sky: glam::Vec3::ZERO,
                emissive_multiplier: 1.0,
                seed: 0,
            },
        })
    }

    /// The scene's camera for a `width × height` image.
    pub fn camera(&self, width: u32, height: u32) -> CameraParams {
        scene_camera(&self.scene, width, height)
    }

    /// The camera of frame `frame` of `motion` at `width × height`.
    pub fn camera_at(&self, motion: Motion, frame: u32, width: u32, height: u32) -> CameraParams {
        let base = self.camera(width, height);
        motion
            .path(&base, self.scene.bounds.center())
            .camera(&base, frame)
    }
}

/// Everything a bench run measured.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct BenchReport {
    /// The device it ran on.
    pub device: String,
    /// Its driver.
    pub driver: String,
    /// The tracing variant of the base context.
    pub variant: String,
    /// Base resolution.
    pub width: u32,
    /// Base resolution.
    pub height: u32,
    /// One record per point, scene and camera path.
    pub points: Vec<report::PointRecord>,
    /// One per scene, when measured.
    pub equal_time: Vec<equal_time::EqualTime>,
    /// The scaling sweeps' points.
    pub scaling: Vec<scaling::ScalingPoint>,
    /// Scenes skipped and why (a missing file, say).
    pub skipped: Vec<String>,
}

/// The tracing variant's short name: `ray-query` or `software`.
pub fn variant_name(ctx: &Context) -> String {
    match ctx.variant() {
        crate::KernelVariant::RayQuery => "ray-query",
        crate::KernelVariant::Software => "software",
    }
    .to_owned()
}

/// Runs the whole bench on `ctx` (and the other tracing variant's `other`, where the device has
/// both), printing progress, and writes every output into `config.out`. Returns what it
/// measured and the files it wrote.
pub fn run(
    ctx: &Context,
    other: Option<&Context>,
    config: &BenchConfig,
) -> Result<(BenchReport, Vec<PathBuf>)> {
    config.validate()?;
    let out = &config.out;
    std::fs::create_dir_all(out).map_err(|e| Error::Output {
        path: out.clone(),
        why: e.to_string(),
    })?;
    let mut report = BenchReport {
        device: ctx.capabilities().name.clone(),
        driver: ctx.capabilities().driver.clone(),
        variant: variant_name(ctx),
        width: config.width,
        height: config.height,
        ..BenchReport::default()
    };
    let motions: Vec<Motion> = if config.motion_frames > 0 {
        vec![Motion::Static, Motion::Orbit]
    } else {
        vec![Motion::Static]
    };
    for bench in &config.scenes {
        if !bench.path.exists() {
            let why = format!("{}: skipped, the file is absent", bench.path.display());
            println!("{why}");
            report.skipped.push(why);
            continue;
        }
        let scene = LoadedScene::load(ctx, bench)?;
        let other_scene = match other {
            Some(o) if config.sweeps.variant => Some((o, LoadedScene::load(o, bench)?)),
            _ => None,
        };
        println!(
            "{}: {} triangles, {} punctual lights{}",
            bench.name,
            scene.scene.triangle_count(),
            scene.scene.lights.len(),
            if bench.environment.is_some() {
                ", environment"
            } else {
                ""
            }
        );
        let mut references = Vec::new();
        for &motion in &motions {
            references.push(reference::reference(
                ctx,
                &scene,
                bench,
                motion,
                config.frames_of(motion),
                config,
            )?);
        }
        let points = sweep::points(
            config.width,
            config.height,
            config.sweeps,
            other_scene.as_ref().map(|(o, _)| variant_name(o)),
        );
        let mut balanced_static = None;
        for point in &points {
            for (&motion, reference) in motions.iter().zip(&references) {
                let (run_ctx, run_scene) = match (&point.group, &other_scene) {
                    (sweep::Group::Variant, Some((o, s))) => (*o, s),
                    _ => (ctx, &scene),
                };
                let frames = config.frames_of(motion);
                let result = measure::run_gi(
                    run_ctx,
                    run_scene,
                    &measure::RunSpec {
                        settings: point.settings,
                        width: point.width,
                        height: point.height,
                        motion,
                        frames,
                    },
                    reference,
                )?;
                println!(
                    "{:<16} {:<7} {:<28} {:>8.2} ms (p95 {:>8.2}) relMSE {:.4} FLIP {:.3} mean {:+.1}% change {:.4}",
                    bench.name,
                    motion.name(),
                    point.label(),
                    result.ms_mean,
                    result.ms_p95,
                    result.relmse,
                    result.flip,
                    100.0 * result.mean_bias,
                    result.temporal_change
                );
                if motion == Motion::Static && point.label() == crate::gi::Preset::Balanced.name() {
                    balanced_static = Some(result.clone());
                }
                report.points.push(report::PointRecord::new(
                    &bench.name,
                    scene.scene.triangle_count(),
                    point,
                    variant_name(run_ctx),
                    motion,
                    frames,
                    result,
                ));
            }
        }
        // `sweep::points` always holds `balanced`: the equal-time comparison reuses its run.
        if let Some(balanced) = balanced_static.filter(|_| config.equal_time_max_spp > 0) {
            let e =
                equal_time::measure(ctx, &scene, &bench.name, &balanced, &references[0], config)?;
            println!("{e}");
            report.equal_time.push(e);
        }
    }
    if let Some(s) = &config.scaling {
        report.scaling = scaling::run(ctx, s)?;
    }
    let files = report::write_all(&report, out)?;
    Ok((report, files))
}
