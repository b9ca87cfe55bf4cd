//! The talk's claim, measured: the path tracer against a GI frame at equal time.
//!
//! The path tracer renders the static camera at 1, 2, 4 … spp (another seed than the
//! reference's); its GPU time per spp comes from the largest run. Then:
//! - how many spp fit the time of one GI frame, and the error they reach (interpolated in
//!   log-log between the measured spp; below 1 spp, relMSE(1 spp) / spp, Monte Carlo's rate);
//! - how long the path tracer takes to reach the error GI has after its N frames (interpolated
//!   the same way, or extrapolated at the 1/spp rate past the largest spp, and then flagged);
//! - the lavapipe goal: the frames GI needs to reach the error of 64 spp, and the path tracer's
//!   time for 64 spp over GI's time for those frames (goal: 20 or more).

use super::measure::RunResult;
use super::reference::REFERENCE_SEED;
use super::{BenchConfig, LoadedScene, Motion};
use crate::error::Result;
use crate::image_io::HdrImage;
use crate::metrics;
use crate::path_tracer::{PathTracerPass, PathTracerSettings};
use crate::vulkan::Context;
use serde::{Deserialize, Serialize};
use std::fmt;

/// The path tracer's spp of the lavapipe goal.
pub const GOAL_SPP: u32 = 64;
/// The goal: GI reaches [`GOAL_SPP`]'s error in this fraction of the path tracer's time or less.
pub const GOAL_SPEEDUP: f64 = 20.0;

/// One path-traced image of the curve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PtSample {
    /// Paths per pixel.
    pub spp: u32,
    /// relMSE against the reference.
    pub relmse: f64,
    /// GPU milliseconds.
    pub ms: f64,
}

/// The comparison for one scene.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct EqualTime {
    /// The scene.
    pub scene: String,
    /// GI frames rendered (the `balanced` preset, static camera).
    pub gi_frames: u32,
    /// GI's GPU ms per frame.
    pub gi_ms: f64,
    /// GI's relMSE after its frames.
    pub gi_relmse: f64,
    /// The path tracer's curve.
    pub pt: Vec<PtSample>,
    /// The path tracer's GPU ms per spp.
    pub pt_ms_per_spp: f64,
    /// Path-traced spp that fit one GI frame's time.
    pub spp_per_gi_frame: f64,
    /// The relMSE those spp reach.
    pub pt_relmse_at_gi_frame_time: f64,
    /// Path-traced spp that reach GI's relMSE.
    pub pt_spp_for_gi_error: f64,
    /// Their GPU ms.
    pub pt_ms_for_gi_error: f64,
    /// Whether that needed extrapolation past the largest spp measured.
    pub extrapolated: bool,
    /// `pt_ms_for_gi_error / gi_ms`: path-tracing time for GI's error, in GI frames.
    pub ratio_per_frame: f64,
    /// `pt_ms_for_gi_error / (gi_ms · gi_frames)`: the same over GI's whole run.
    pub ratio_whole_run: f64,
    /// The path tracer's relMSE at [`GOAL_SPP`], when measured.
    pub goal_pt_relmse: Option<f64>,
    /// GI frames until its relMSE is at most that, if it got there.
    pub goal_gi_frames: Option<u32>,
    /// The path tracer's time for [`GOAL_SPP`] over GI's time to the same error.
    pub goal_speedup: Option<f64>,
}

/// Runs the comparison on `scene`, whose `balanced` static run measured `gi`.
pub fn measure(
    ctx: &Context,
    scene: &LoadedScene,
    name: &str,
    gi: &RunResult,
    reference: &HdrImage,
    config: &BenchConfig,
) -> Result<EqualTime> {
    let camera = scene.camera_at(Motion::Static, 0, config.width, config.height);
    let mut pass = PathTracerPass::new(ctx)?;
    let mut pt = Vec::new();
    let mut spp = 1;
    while spp <= config.equal_time_max_spp.max(1) {
        let settings = PathTracerSettings {
            samples: spp,
            seed: REFERENCE_SEED ^ spp.wrapping_mul(0x9e37_79b9),
            // As the reference and GI: pixel-centre primaries, so both compare lighting alone.
            pixel_centre: true,
            ..PathTracerSettings::default()
        };
        let render = pass.render(ctx, &scene.gpu, &camera, &settings, |_, _| {})?;
        pt.push(PtSample {
            spp,
            relmse: metrics::relative_mse(reference, &render.image)?,
            ms: render.gpu_ms.unwrap_or(f64::NAN),
        });
        spp *= 2;
    }
    Ok(compare(name, gi, config.frames, pt))
}

/// The comparison from GI's run and the path tracer's curve (sorted by spp, at least one).
pub fn compare(name: &str, gi: &RunResult, gi_frames: u32, pt: Vec<PtSample>) -> EqualTime {
    let last = pt.last().copied().unwrap_or(PtSample {
        spp: 1,
        relmse: f64::NAN,
        ms: f64::NAN,
    });
    let pt_ms_per_spp = last.ms / f64::from(last.spp);
    let spp_per_gi_frame = gi.ms_mean / pt_ms_per_spp;
    let (pt_spp_for_gi_error, extrapolated) = spp_for_error(&pt, gi.relmse);
    let pt_ms_for_gi_error = pt_spp_for_gi_error * pt_ms_per_spp;
    let goal = pt.iter().find(|s| s.spp == GOAL_SPP).copied();
    let goal_gi_frames = goal.and_then(|g| {
        gi.relmse_per_frame
            .iter()
            .position(|&e| e <= g.relmse)
            .map(|f| f as u32 + 1)
    });
    EqualTime {
        scene: name.to_owned(),
        gi_frames,
        gi_ms: gi.ms_mean,
        gi_relmse: gi.relmse,
        pt_ms_per_spp,
        spp_per_gi_frame,
        pt_relmse_at_gi_frame_time: error_at_spp(&pt, spp_per_gi_frame),
        pt_spp_for_gi_error,
        pt_ms_for_gi_error,
        extrapolated,
        ratio_per_frame: pt_ms_for_gi_error / gi.ms_mean,
        ratio_whole_run: pt_ms_for_gi_error / (gi.ms_mean * f64::from(gi_frames)),
        goal_pt_relmse: goal.map(|g| g.relmse),
        goal_gi_frames,
        goal_speedup: goal
            .zip(goal_gi_frames)
            .map(|(g, f)| g.ms / (gi.ms_mean * f64::from(f))),
        pt,
    }
}

/// The path tracer's relMSE at `spp` (fractional): log-log interpolation between the measured
/// points, the 1/spp rate outside them.
pub fn error_at_spp(pt: &[PtSample], spp: f64) -> f64 {
    let (Some(first), Some(last)) = (pt.first(), pt.last()) else {
        return f64::NAN;
    };
    if spp <= f64::from(first.spp) {
        return first.relmse * f64::from(first.spp) / spp;
    }
    if spp >= f64::from(last.spp) {
        return last.relmse * f64::from(last.spp) / spp;
    }
    for w in pt.windows(2) {
        let (a, b) = (w[0], w[1]);
        if spp <= f64::from(b.spp) {
            let t = (spp.ln() - f64::from(a.spp).ln())
                / (f64::from(b.spp).ln() - f64::from(a.spp).ln());
            return (a.relmse.ln() + t * (b.relmse.ln() - a.relmse.ln())).exp();
        }
    }
    last.relmse
}

/// The (fractional) spp at which the path tracer's relMSE falls to `error`, and whether that
/// lies past the largest spp measured (extrapolated at the 1/spp rate).
pub fn spp_for_error(pt: &[PtSample], error: f64) -> (f64, bool) {
    let (Some(first), Some(last)) = (pt.first(), pt.last()) else {
        return (f64::NAN, true);
    };
    if error >= first.relmse {
        return (f64::from(first.spp) * first.relmse / error, false);
    }
    for w in pt.windows(2) {
        let (a, b) = (w[0], w[1]);
        if error >= b.relmse {
            let t = (error.ln() - a.relmse.ln()) / (b.relmse.ln() - a.relmse.ln());
            let ln = f64::from(a.spp).ln() + t * (f64::from(b.spp).ln() - f64::from(a.spp).ln());
            return (ln.exp(), false);
        }
    }
    (f64::from(last.spp) * last.relmse / error, true)
}

impl fmt::Display for EqualTime {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}: one GI frame ({:.2} ms) = {:.2} path-traced spp ({:.2} ms/spp), which reach relMSE {:.4}",
            self.scene,
            self.gi_ms,
            self.spp_per_gi_frame,
            self.pt_ms_per_spp,
            self.pt_relmse_at_gi_frame_time
        )?;
        writeln!(
            f,
            "{}: GI after {} frames: relMSE {:.4}; the path tracer needs {:.1} spp{} = {:.1} ms for it: {:.1}x one GI frame, {:.2}x GI's {} frames",
            self.scene,
            self.gi_frames,
            self.gi_relmse,
            self.pt_spp_for_gi_error,
            if self.extrapolated {
                " (extrapolated)"
            } else {
                ""
            },
            self.pt_ms_for_gi_error,
            self.ratio_per_frame,
            self.ratio_whole_run,
            self.gi_frames
        )?;
        match (self.goal_pt_relmse, self.goal_gi_frames, self.goal_speedup) {
            (Some(e), Some(n), Some(s)) => write!(
                f,
                "{}: {GOAL_SPP} spp reach relMSE {e:.4}; GI gets there in {n} frames: {s:.1}x faster (goal {GOAL_SPEEDUP}x: {})",
                self.scene,
                if s >= GOAL_SPEEDUP { "met" } else { "not met" }
            ),
            (Some(e), None, _) => write!(
                f,
                "{}: {GOAL_SPP} spp reach relMSE {e:.4}; GI does not get there in {} frames (goal not met)",
                self.scene, self.gi_frames
            ),
            _ => write!(f, "{}: {GOAL_SPP} spp not measured", self.scene),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve() -> Vec<PtSample> {
        // relMSE = 0.8 / spp exactly, 10 ms per spp.
        [1, 2, 4, 8, 16, 32, 64]
            .iter()
            .map(|&spp| PtSample {
                spp,
                relmse: 0.8 / f64::from(spp),
                ms: 10.0 * f64::from(spp),
            })
            .collect()
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * b.abs().max(1.0)
    }

    #[test]
    fn interpolation_follows_the_monte_carlo_rate() {
        let pt = curve();
        for spp in [0.25, 1.0, 3.0, 20.0, 64.0, 300.0] {
            assert!(close(error_at_spp(&pt, spp), 0.8 / spp), "{spp}");
            let (s, extrapolated) = spp_for_error(&pt, 0.8 / spp);
            assert!(close(s, spp), "{spp}: {s}");
            assert_eq!(extrapolated, spp > 64.0);
        }
    }

    #[test]
    fn ratios_and_goal() {
        let gi = RunResult {
            ms_mean: 5.0,
            relmse: 0.8 / 32.0,
            // Reaches 64 spp's 0.0125 after 10 frames.
            relmse_per_frame: (1..=20).map(|f| 0.125 / f64::from(f)).collect(),
            ..RunResult::default()
        };
        let e = compare("s", &gi, 20, curve());
        assert!(close(e.pt_ms_per_spp, 10.0));
        assert!(close(e.spp_per_gi_frame, 0.5));
        assert!(close(e.pt_relmse_at_gi_frame_time, 1.6));
        assert!(close(e.pt_spp_for_gi_error, 32.0));
        assert!(close(e.ratio_per_frame, 320.0 / 5.0));
        assert!(close(e.ratio_whole_run, 320.0 / 100.0));
        assert_eq!(e.goal_gi_frames, Some(10));
        assert!(close(e.goal_speedup.unwrap(), 640.0 / 50.0));
        assert!(e.to_string().contains("not met"));
    }
}
