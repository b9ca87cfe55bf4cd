//! How a GI frame's cost scales: against pixels (expected linear), against triangles (tracing
//! expected logarithmic: a BVH), against punctual lights (expected flat: above
//! [`gi_shared::lights::EXACT_DIRECT_LIGHTS`] the primary hit resamples one light, and
//! the cache's light grid keeps a few candidates per cell), against emissive triangles (expected
//! flat: every light the grid weighs is a cluster of them). Each sweep renders
//! [`procedural::scaling_room`] ([`procedural::emitter_room`] for emissive triangles) with the
//! `balanced` preset, static camera, and averages the GPU time of the frames after a warm-up.

use crate::error::{Error, Result};
use crate::gi::Preset;
use crate::gi::renderer::GiRenderer;
use crate::scene::procedural::{self, ROOM_SPHERES};
use crate::vulkan::Context;
use serde::{Deserialize, Serialize};

use super::LoadedScene;
use super::measure::{FrameTimes, WARMUP_FRAMES};

/// The passes that trace rays: their sum is the frame's tracing time.
pub const TRACING_PASSES: [&str; 4] = [
    "GBuffer",
    "PopulateScreenProbes",
    "PopulateRadianceCache",
    "DirectLight",
];

/// What the scaling sweeps vary.
#[derive(Clone, Debug, PartialEq)]
pub struct ScalingConfig {
    /// Resolutions of the pixel sweep (room with `base_levels` spheres and `base_lights`).
    pub resolutions: Vec<(u32, u32)>,
    /// Icosphere subdivisions of the triangle sweep (`16 · 20 · 4^levels` triangles).
    pub sphere_levels: Vec<u32>,
    /// Light counts of the light sweep.
    pub light_counts: Vec<u32>,
    /// Emissive triangle counts of the emitter sweep (even).
    pub emitter_counts: Vec<u32>,
    /// Resolution of the triangle and light sweeps.
    pub width: u32,
    /// Resolution of the triangle and light sweeps.
    pub height: u32,
    /// Subdivisions where the sweep does not vary them.
    pub base_levels: u32,
    /// Lights where the sweep does not vary them.
    pub base_lights: u32,
    /// Frames timed (after [`WARMUP_FRAMES`]).
    pub frames: u32,
}

impl ScalingConfig {
    /// The full sweeps at a `width × height` base: resolutions from a quarter to four times its
    /// pixels, 1.3 k to 1.3 M triangles, 1 to 1024 lights, 16 to 100k emissive triangles.
    pub fn full(width: u32, height: u32) -> Self {
        Self {
            resolutions: vec![
                (width / 2, height / 2),
                (width, height),
                (width * 2, height * 2),
                (width * 4, height * 4),
            ],
            sphere_levels: vec![1, 2, 3, 4, 5, 6],
            light_counts: vec![1, 4, 16, 64, 256, 1024],
            emitter_counts: vec![16, 1000, 10_000, 100_000],
            width,
            height,
            base_levels: 3,
            base_lights: 4,
            frames: 8,
        }
    }

    /// Keeps only the sweeps along `axes` (the others' lists emptied).
    pub fn keep(mut self, axes: &[Axis]) -> Self {
        let off = |a| !axes.contains(&a);
        if off(Axis::Pixels) {
            self.resolutions.clear();
        }
        if off(Axis::Triangles) {
            self.sphere_levels.clear();
        }
        if off(Axis::Lights) {
            self.light_counts.clear();
        }
        if off(Axis::Emitters) {
            self.emitter_counts.clear();
        }
        self
    }
}

/// Which sweep a point belongs to (`gi sweep --scaling-axes` names them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// Pixels.
    Pixels,
    /// Triangles.
    Triangles,
    /// Punctual lights.
    Lights,
    /// Emissive triangles.
    Emitters,
}

impl Axis {
    /// Its name in files and tables.
    pub fn name(self) -> &'static str {
        match self {
            Self::Pixels => "pixels",
            Self::Triangles => "triangles",
            Self::Lights => "lights",
            Self::Emitters => "emitters",
        }
    }
}

/// One measured point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScalingPoint {
    /// The sweep.
    pub axis: Axis,
    /// Its x: pixels, triangles, lights or emissive triangles.
    pub x: f64,
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Triangles.
    pub triangles: usize,
    /// Punctual lights.
    pub lights: u32,
    /// Emissive triangles (lights of the light grid).
    #[serde(default)]
    pub emitters: usize,
    /// GPU ms per frame.
    pub ms: f64,
    /// GPU ms per frame of the [`TRACING_PASSES`].
    pub tracing_ms: f64,
    /// GPU ms per frame of UpdateLightGrid (its passes over the lights).
    #[serde(default)]
    pub light_grid_ms: f64,
}

/// Runs the four sweeps on `ctx` (each skipped where its list is empty), printing each point.
pub fn run(ctx: &Context, config: &ScalingConfig) -> Result<Vec<ScalingPoint>> {
    let mut points = Vec::new();
    let room = |levels: u32, lights: u32| {
        procedural::scaling_room(levels, lights).ok_or(Error::InvalidArgument {
            name: "scaling",
            why: format!("no room of {levels} subdivisions and {lights} lights"),
        })
    };
    if !config.resolutions.is_empty() {
        let base = LoadedScene::upload(ctx, room(config.base_levels, config.base_lights)?, None)?;
        for &(w, h) in &config.resolutions {
            points.push(point(ctx, &base, Axis::Pixels, w, h, config)?);
        }
    }
    for &levels in &config.sphere_levels {
        let scene = LoadedScene::upload(ctx, room(levels, config.base_lights)?, None)?;
        points.push(point(
            ctx,
            &scene,
            Axis::Triangles,
            config.width,
            config.height,
            config,
        )?);
    }
    for &lights in &config.light_counts {
        let scene = LoadedScene::upload(ctx, room(config.base_levels, lights)?, None)?;
        points.push(point(
            ctx,
            &scene,
            Axis::Lights,
            config.width,
            config.height,
            config,
        )?);
    }
    for &emitters in &config.emitter_counts {
        let room = procedural::emitter_room(config.base_levels, emitters).ok_or(
            Error::InvalidArgument {
                name: "scaling",
                why: format!("no room of {emitters} emissive triangles (an even count)"),
            },
        )?;
        let scene = LoadedScene::upload(ctx, room, None)?;
        points.push(point(
            ctx,
            &scene,
            Axis::Emitters,
            config.width,
            config.height,
            config,
        )?);
    }
    Ok(points)
}

fn point(
    ctx: &Context,
    scene: &LoadedScene,
    axis: Axis,
    width: u32,
    height: u32,
    config: &ScalingConfig,
) -> Result<ScalingPoint> {
    let mut gi = GiRenderer::new(
        ctx,
        &scene.lights,
        width,
        height,
        Preset::Balanced.settings(width, height),
        scene.options,
    )?;
    let camera = scene.camera(width, height);
    let mut times = FrameTimes::default();
    for f in 0..WARMUP_FRAMES + config.frames {
        gi.render_frame(ctx, &scene.gpu, &camera)?;
        if f >= WARMUP_FRAMES {
            times.add(gi.timings());
        }
    }
    let ms_of = |passes: &[&str]| -> f64 {
        times
            .passes()
            .iter()
            .filter(|p| passes.contains(&p.pass.as_str()))
            .map(|p| p.ms)
            .sum()
    };
    let tracing_ms = ms_of(&TRACING_PASSES);
    let light_grid_ms = ms_of(&["UpdateLightGrid"]);
    let triangles = scene.scene.triangle_count();
    let lights = scene.scene.lights.len() as u32;
    let emitters = scene.scene.emissive_triangles.len();
    let p = ScalingPoint {
        axis,
        x: match axis {
            Axis::Pixels => f64::from(width) * f64::from(height),
            Axis::Triangles => triangles as f64,
            Axis::Lights => f64::from(lights),
            Axis::Emitters => emitters as f64,
        },
        width,
        height,
        triangles,
        lights,
        emitters,
        ms: times.mean_ms(),
        tracing_ms,
        light_grid_ms,
    };
    println!(
        "scaling {:<9} {:>10}: {:>9.2} ms per frame, {:>9.2} ms tracing, {:>8.2} ms light grid ({}x{}, {} triangles in {} spheres, {} lights, {} emissive triangles)",
        axis.name(),
        p.x,
        p.ms,
        p.tracing_ms,
        p.light_grid_ms,
        width,
        height,
        triangles,
        ROOM_SPHERES,
        lights,
        emitters
    );
    Ok(p)
}
