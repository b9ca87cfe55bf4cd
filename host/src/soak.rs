//! The long-run soak (`gi soak`): the GI frame for thousands of frames while the camera, a light
//! and an object move, checked as it goes.
//!
//! Every motion repeats every [`SoakSettings::period`] frames: the camera swings about the
//! vertical axis ([`CameraPath::Swing`]), a point light added to the scene circles under the
//! ceiling, and the scene's own animation (a rigid object crossing the room in
//! `scenes/moving-box.gltf`) plays a whole number of loops. So the first period after the warm-up
//! and the last one render the same sequence of views, and whatever differs between them (frame
//! time, cache occupancy, memory) is drift, not content.
//!
//! Every [`SoakSettings::check_every`] frames, and after the last: the GPU counts the NaN and
//! infinite floats of every float buffer of the frame ([`GiRenderer::float_buffers`]) and of its
//! 32-bit float images ([`GiRenderer::float_images`]) with [`FiniteCheck`]; the host's resident memory (`VmRSS`), the allocator's device memory and the
//! validation messages are sampled. The cache occupancy (live tiles) and the frame time are
//! recorded every frame. [`SoakReport::verdicts`] turns the figures into pass/fail against
//! [`SoakLimits`]. The host's resident memory is judged only in a run without the validation
//! layer, whose own bookkeeping grows with every submission; validation messages only in a run
//! with it.

use crate::error::{Error, Result};
use crate::frame::FiniteCheck;
use crate::gbuffer::scene_camera;
use crate::gi::camera_path::CameraPath;
use crate::gi::renderer::GiRenderer;
use crate::gi::{GiSettings, ViewOptions};
use crate::scene::gpu_data::ShadingData;
use crate::scene::lights::LightSet;
use crate::scene::upload::GpuScene;
use crate::scene::{Light, LightKind, Scene};
use crate::vulkan::{Context, DeviceMemoryUse, KernelModule};
use glam::Vec3;
use std::fmt;
use std::time::Instant;

/// Frames per second at which the scene's animation plays, as in `gi render`: the loops per
/// period are rounded to keep that pace.
const PLAYBACK_FPS: f32 = 30.0;

/// Bytes per MiB.
const MIB: f64 = 1024.0 * 1024.0;

/// What a soak runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SoakSettings {
    /// Frames to render.
    pub frames: u32,
    /// Frames between two checks (NaN/Inf, memory, validation); the last frame is always checked.
    pub check_every: u32,
    /// Frames after which every motion repeats: the warm-up and each drift window.
    pub period: u32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Largest turn of the camera's swing either way, in degrees.
    pub swing_degrees: f32,
    /// Radiant intensity of the moving point light, W/sr.
    pub light_intensity: f32,
    /// Where a check fails.
    pub limits: SoakLimits,
}

impl Default for SoakSettings {
    /// 10 000 frames at 32×32 (about half an hour on lavapipe), checked every 100, motions
    /// repeating every 500 frames.
    fn default() -> Self {
        Self {
            frames: 10_000,
            check_every: 100,
            period: 500,
            width: 32,
            height: 32,
            swing_degrees: 20.0,
            light_intensity: 2.0,
            limits: SoakLimits::default(),
        }
    }
}

/// Where a soak's checks fail.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SoakLimits {
    /// Growth of the host's resident memory from the end of the warm-up to the end, MiB.
    pub host_growth_mib: f64,
    /// Growth of the device memory the allocator holds (allocated and reserved), bytes.
    pub device_growth_bytes: u64,
    /// Relative change of the mean frame time from the first window to the last.
    pub frame_time_drift: f64,
    /// Relative growth of the peak cache occupancy from the first window to the last.
    pub occupancy_growth: f64,
}

impl Default for SoakLimits {
    /// Host memory within 16 MiB (the allocator's arenas and the driver's caches settle in steps
    /// of a few MiB; a leak of 2 KiB per frame crosses it within 10 000 frames), device memory
    /// exactly flat, frame time within 25 % (other processes on a shared CPU move lavapipe's by
    /// about 10 %), peak occupancy within 25 %.
    fn default() -> Self {
        Self {
            host_growth_mib: 16.0,
            device_growth_bytes: 0,
            frame_time_drift: 0.25,
            occupancy_growth: 0.25,
        }
    }
}

impl SoakSettings {
    /// Checks the settings, naming the first that is out of range.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, why: String| Err(Error::InvalidArgument { name, why });
        if self.period == 0 {
            return bad("period", "0 frames: must be at least 1".into());
        }
        if self.frames < 3 * self.period {
            return bad(
                "frames",
                format!(
                    "{} frames: need at least 3 periods of {} (warm-up, first and last window)",
                    self.frames, self.period
                ),
            );
        }
        if self.check_every == 0 {
            return bad("check_every", "0 frames: must be at least 1".into());
        }
        if !self.swing_degrees.is_finite() {
            return bad("swing_degrees", format!("{}", self.swing_degrees));
        }
        if !(self.light_intensity.is_finite() && self.light_intensity >= 0.0) {
            return bad(
                "light_intensity",
                format!("{}: must be finite and ≥ 0", self.light_intensity),
            );
        }
        let l = &self.limits;
        if !(l.host_growth_mib >= 0.0 && l.frame_time_drift >= 0.0 && l.occupancy_growth >= 0.0) {
            return bad("limits", format!("{l:?}: must be ≥ 0"));
        }
        Ok(())
    }
}

/// The figures of one check.
#[derive(Clone, Debug, PartialEq)]
pub struct SoakSample {
    /// Frames rendered before it.
    pub frame: u32,
    /// Buffers that held NaN or infinite floats, with their count (empty when clean).
    pub non_finite: Vec<(String, u32)>,
    /// Words of the buffers checked.
    pub words_checked: u64,
    /// The host's resident memory, bytes (`None` where `/proc/self/status` does not exist).
    pub host_bytes: Option<u64>,
    /// The allocator's device memory.
    pub device: DeviceMemoryUse,
    /// Validation messages so far (`None` with validation off).
    pub validation_messages: Option<usize>,
}

/// Everything a soak measured.
#[derive(Clone, Debug, PartialEq)]
pub struct SoakReport {
    /// What ran.
    pub settings: SoakSettings,
    /// Tiles of the hash cache: the most that can be live.
    pub tile_capacity: u32,
    /// Each frame's time, milliseconds: GPU time where the device has timestamps, else the wall
    /// time of rendering it.
    pub frame_ms: Vec<f32>,
    /// Whether [`SoakReport::frame_ms`] is GPU time.
    pub gpu_timed: bool,
    /// Each frame's wall time, milliseconds: moving the scene (re-upload) and rendering.
    pub wall_ms: Vec<f32>,
    /// Live tiles of the cache after each frame.
    pub live_tiles: Vec<u32>,
    /// The checks, in order.
    pub samples: Vec<SoakSample>,
    /// Wall time of the whole soak, seconds.
    pub seconds: f64,
}

/// One line of a soak's verdict.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SoakVerdict {
    /// What is checked.
    pub check: &'static str,
    /// The figures behind it.
    pub figures: String,
    /// Whether it held.
    pub passed: bool,
}

/// Resident memory of this process in bytes (`VmRSS` of `/proc/self/status`), where there is one.
pub fn resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Where the soak's light is at `phase` (0 to 1) of a period: on a circle under the ceiling of
/// `bounds` (the scene's at rest), a quarter of the smaller horizontal extent from the centre.
fn light_position(bounds: &crate::scene::Aabb, phase: f32) -> Vec3 {
    let size = bounds.size();
    let radius = 0.25 * size.x.min(size.z);
    let angle = std::f32::consts::TAU * phase;
    bounds.center() + Vec3::new(radius * angle.cos(), 0.35 * size.y, radius * angle.sin())
}

/// Runs the soak on `scene` (which must have an animation: the moving object), calling
/// `on_check` after each check. Errors: bad settings, a scene without animation, a device error.
/// Failed checks are not errors: see [`SoakReport::verdicts`].
pub fn run(
    ctx: &Context,
    mut scene: Scene,
    settings: &SoakSettings,
    mut on_check: impl FnMut(&SoakSample),
) -> Result<SoakReport> {
    settings.validate()?;
    let s = *settings;
    let duration = scene
        .animation
        .as_ref()
        .map(|a| a.duration())
        .filter(|d| *d > 0.0)
        .ok_or_else(|| Error::InvalidArgument {
            name: "scene",
            why: format!(
                "{} has no playable animation: the soak needs a moving object (as in \
                 scenes/moving-box.gltf)",
                scene.source.display()
            ),
        })?;
    let loops = (s.period as f32 / (duration * PLAYBACK_FPS))
        .round()
        .max(1.0);
    let time_at = |frame: u32| (frame % s.period) as f32 / s.period as f32 * loops * duration;
    let rest = scene.bounds;
    let light = scene.lights.len();
    scene.lights.push(Light {
        name: "soak light".into(),
        kind: LightKind::Point,
        intensity: Vec3::splat(s.light_intensity),
        position: light_position(&rest, 0.0),
        direction: -Vec3::Y,
        range: None,
    });
    scene.set_time(time_at(0));
    let base = scene_camera(&scene, s.width, s.height);
    let depth = (rest.center() - base.position())
        .dot(base.forward())
        .max(0.0);
    let path = CameraPath::Swing {
        pivot: base.position() + base.forward() * depth,
        amplitude_degrees: s.swing_degrees,
        period: s.period,
    };

    let start = Instant::now();
    let lights = LightSet::new(&scene, None, true);
    let mut gpu = GpuScene::upload(ctx, &scene, None, &ShadingData::new(&scene)?, &lights)?;
    let mut gi = GiRenderer::new(
        ctx,
        &lights,
        s.width,
        s.height,
        GiSettings::for_resolution(s.width, s.height),
        ViewOptions::default(),
    )?;
    let check = FiniteCheck::new(ctx, &KernelModule::new(ctx)?)?;
    let frames = s.frames as usize;
    // Written in place, never grown: the soak's own bookkeeping must not move the memory figures.
    let mut report = SoakReport {
        settings: s,
        tile_capacity: gi.cache_resources().tile_count(),
        frame_ms: vec![0.0; frames],
        gpu_timed: false,
        wall_ms: vec![0.0; frames],
        live_tiles: vec![0; frames],
        samples: Vec::with_capacity(frames.div_ceil(s.check_every as usize) + 1),
        seconds: 0.0,
    };
    for f in 0..s.frames {
        let frame_start = Instant::now();
        if f > 0 {
            let before = scene.pose_at(time_at(f - 1));
            scene.set_time(time_at(f));
            let phase = (f % s.period) as f32 / s.period as f32;
            scene.lights[light].position = light_position(&rest, phase);
            let lights = LightSet::new(&scene, None, true);
            gpu.set_pose(ctx, &scene, &lights, &before)?;
        }
        let render_start = Instant::now();
        let stats = gi.render_frame(ctx, &gpu, &path.camera(&base, f))?;
        let now = Instant::now();
        let i = f as usize;
        report.live_tiles[i] = stats.cache.live_tiles;
        report.wall_ms[i] = (now - frame_start).as_secs_f32() * 1e3;
        report.gpu_timed = gi.timings().frames() == f + 1;
        report.frame_ms[i] = if report.gpu_timed {
            gi.timings().last_total_ms() as f32
        } else {
            (now - render_start).as_secs_f32() * 1e3
        };
        if (f + 1) % s.check_every == 0 || f + 1 == s.frames {
            // Memory first: the check's own counts buffer is not the frame's.
            let host_bytes = resident_bytes();
            let device = ctx.device_memory();
            let buffers = gi.float_buffers()?;
            let images = gi.float_images();
            let words_checked = buffers.iter().map(|(b, _)| b.size / 4).sum::<u64>()
                + images.iter().map(|i| i.byte_size() / 4).sum::<u64>();
            let mut counts = check.count(ctx, &buffers)?;
            counts.extend(check.count_images(ctx, &images)?);
            let non_finite = counts.into_iter().filter(|(_, n)| *n > 0).collect();
            let sample = SoakSample {
                frame: f + 1,
                non_finite,
                words_checked,
                host_bytes,
                device,
                validation_messages: ctx.validation_messages().map(|m| m.len()),
            };
            on_check(&sample);
            report.samples.push(sample);
        }
    }
    report.seconds = start.elapsed().as_secs_f64();
    Ok(report)
}

/// Mean of `values` as f64 (0 for none).
fn mean(values: &[f32]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.iter().map(|&v| f64::from(v)).sum::<f64>() / values.len() as f64
}

impl SoakReport {
    /// The frames of the first window (the period after the warm-up) and of the last.
    fn windows(&self) -> (std::ops::Range<usize>, std::ops::Range<usize>) {
        let (p, n) = (self.settings.period as usize, self.frame_ms.len());
        (p..2 * p, n - p..n)
    }

    /// Mean frame time of the first and the last window, milliseconds.
    pub fn frame_time_windows(&self) -> (f64, f64) {
        let (first, last) = self.windows();
        (mean(&self.frame_ms[first]), mean(&self.frame_ms[last]))
    }

    /// Peak live tiles in the first and the last window.
    pub fn occupancy_windows(&self) -> (u32, u32) {
        let (first, last) = self.windows();
        let peak =
            |r: std::ops::Range<usize>| self.live_tiles[r].iter().copied().max().unwrap_or(0);
        (peak(first), peak(last))
    }

    /// The first check at or after the warm-up (the memory baseline) and the last check.
    fn memory_span(&self) -> Option<(&SoakSample, &SoakSample)> {
        let period = self.settings.period;
        let baseline = self.samples.iter().find(|s| s.frame >= period)?;
        Some((baseline, self.samples.last()?))
    }

    /// Every check against `limits`: NaN/Inf, host memory, device memory, cache occupancy, frame
    /// time drift and validation.
    pub fn verdicts(&self, limits: &SoakLimits) -> Vec<SoakVerdict> {
        let mut out = vec![];
        let bad: Vec<String> = self
            .samples
            .iter()
            .filter(|s| !s.non_finite.is_empty())
            .map(|s| format!("after frame {}: {:?}", s.frame, s.non_finite))
            .collect();
        let words = self.samples.last().map_or(0, |s| s.words_checked);
        out.push(SoakVerdict {
            check: "no NaN/Inf",
            figures: if bad.is_empty() {
                format!(
                    "{} GPU checks of {words} words each: 0 non-finite",
                    self.samples.len()
                )
            } else {
                format!(
                    "{} of {} checks failed: {}",
                    bad.len(),
                    self.samples.len(),
                    bad[0]
                )
            },
            passed: bad.is_empty() && !self.samples.is_empty(),
        });
        let span = self.memory_span();
        let host = span.and_then(|(a, b)| Some((a.frame, a.host_bytes?, b.frame, b.host_bytes?)));
        let validation = self.samples.last().and_then(|s| s.validation_messages);
        out.push(match host {
            // The layer keeps bookkeeping per submission and object (about 65 KiB per frame with
            // layer 1.3.239, measured: `gi render --method gi` grows 16 MiB over 250 frames with
            // it, 0.8 MiB without), which would hide or fake a leak of ours.
            Some((fa, a, fb, b)) if validation.is_some() => SoakVerdict {
                check: "host memory flat",
                figures: format!(
                    "not checked: RSS {:.1} MiB at frame {fa}, {:.1} MiB at frame {fb} includes \
                     the validation layer's own growth (check without validation)",
                    a as f64 / MIB,
                    b as f64 / MIB
                ),
                passed: true,
            },
            Some((fa, a, fb, b)) => {
                let growth = (b as f64 - a as f64) / MIB;
                SoakVerdict {
                    check: "host memory flat",
                    figures: format!(
                        "RSS {:.1} MiB at frame {fa}, {:.1} MiB at frame {fb} ({growth:+.2} MiB, \
                         limit {} MiB)",
                        a as f64 / MIB,
                        b as f64 / MIB,
                        limits.host_growth_mib
                    ),
                    passed: growth <= limits.host_growth_mib,
                }
            }
            None => SoakVerdict {
                check: "host memory flat",
                figures: "no resident-memory figure on this system".into(),
                passed: true,
            },
        });
        out.push(match span {
            Some((a, b)) => {
                let grew = |x: u64, y: u64| y.saturating_sub(x);
                let (da, db) = (a.device, b.device);
                SoakVerdict {
                    check: "device memory flat",
                    figures: format!(
                        "allocated {:.2} → {:.2} MiB ({} → {} allocations), reserved {:.2} → \
                         {:.2} MiB (frames {} → {})",
                        da.allocated as f64 / MIB,
                        db.allocated as f64 / MIB,
                        da.allocations,
                        db.allocations,
                        da.reserved as f64 / MIB,
                        db.reserved as f64 / MIB,
                        a.frame,
                        b.frame
                    ),
                    passed: grew(da.allocated, db.allocated) <= limits.device_growth_bytes
                        && grew(da.reserved, db.reserved) <= limits.device_growth_bytes,
                }
            }
            None => SoakVerdict {
                check: "device memory flat",
                figures: "no check after the warm-up".into(),
                passed: false,
            },
        });
        let (first, last) = self.occupancy_windows();
        let (min, max) = self
            .live_tiles
            .iter()
            .fold((u32::MAX, 0), |(lo, hi), &t| (lo.min(t), hi.max(t)));
        out.push(SoakVerdict {
            check: "cache occupancy bounded",
            figures: format!(
                "live tiles {min}..{max} of {}; peak {first} in the first window, {last} in the last",
                self.tile_capacity
            ),
            passed: max < self.tile_capacity
                && f64::from(last) <= f64::from(first) * (1.0 + limits.occupancy_growth),
        });
        let (a, b) = self.frame_time_windows();
        let drift = if a > 0.0 { b / a - 1.0 } else { 0.0 };
        out.push(SoakVerdict {
            check: "frame time steady",
            figures: format!(
                "{} {a:.2} ms (first window) → {b:.2} ms (last) = {:+.1}% (limit ±{:.0}%)",
                if self.gpu_timed { "GPU" } else { "wall" },
                drift * 100.0,
                limits.frame_time_drift * 100.0
            ),
            passed: drift.abs() <= limits.frame_time_drift,
        });
        out.push(SoakVerdict {
            check: "zero validation messages",
            figures: match validation {
                Some(n) => format!("{n} messages (synchronization checks on)"),
                None => "not checked: validation off".into(),
            },
            passed: validation.is_none_or(|n| n == 0),
        });
        out
    }

    /// Whether every check of [`SoakReport::verdicts`] held.
    pub fn passed(&self, limits: &SoakLimits) -> bool {
        self.verdicts(limits).iter().all(|v| v.passed)
    }
}

impl fmt::Display for SoakReport {
    /// The run in one line, then one line per check of [`SoakReport::verdicts`] (with the
    /// settings' limits).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.settings;
        writeln!(
            f,
            "{} frames at {}x{} in {:.0} s ({:.1} ms per frame wall time), motions repeating \
             every {} frames, checks every {}",
            self.frame_ms.len(),
            s.width,
            s.height,
            self.seconds,
            mean(&self.wall_ms),
            s.period,
            s.check_every
        )?;
        let verdicts = self.verdicts(&s.limits);
        let width = verdicts.iter().map(|v| v.check.len()).max().unwrap_or(0);
        for v in verdicts {
            writeln!(
                f,
                "{:<width$}  {}  {}",
                v.check,
                if v.passed { "ok  " } else { "FAIL" },
                v.figures
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(frame_ms: Vec<f32>, live_tiles: Vec<u32>, samples: Vec<SoakSample>) -> SoakReport {
        SoakReport {
            settings: SoakSettings {
                frames: frame_ms.len() as u32,
                period: 2,
                check_every: 2,
                ..SoakSettings::default()
            },
            tile_capacity: 100,
            gpu_timed: true,
            wall_ms: frame_ms.clone(),
            frame_ms,
            live_tiles,
            samples,
            seconds: 1.0,
        }
    }

    fn sample(frame: u32, host_mib: u64, allocated: u64) -> SoakSample {
        SoakSample {
            frame,
            non_finite: vec![],
            words_checked: 10,
            host_bytes: Some(host_mib << 20),
            device: DeviceMemoryUse {
                allocated,
                reserved: 1 << 20,
                allocations: 3,
                blocks: 1,
            },
            validation_messages: Some(0),
        }
    }

    fn failed(r: &SoakReport) -> Vec<&'static str> {
        r.verdicts(&SoakLimits::default())
            .into_iter()
            .filter(|v| !v.passed)
            .map(|v| v.check)
            .collect()
    }

    /// A clean run passes; each kind of trouble fails its own check and no other.
    #[test]
    fn each_check_fails_on_its_own_trouble() {
        let clean = || {
            report(
                vec![10.0; 6],
                vec![50, 60, 55, 60, 58, 60],
                vec![
                    sample(2, 100, 500),
                    sample(4, 101, 500),
                    sample(6, 102, 500),
                ],
            )
        };
        assert!(failed(&clean()).is_empty(), "{}", clean());
        let mut r = clean();
        r.samples[1].non_finite = vec![("GI image".into(), 3)];
        assert_eq!(failed(&r), ["no NaN/Inf"]);
        let mut r = clean();
        r.samples[2].host_bytes = Some(200 << 20);
        // Resident memory is checked without the validation layer only (its bookkeeping grows).
        assert!(failed(&r).is_empty());
        for s in &mut r.samples {
            s.validation_messages = None;
        }
        assert_eq!(failed(&r), ["host memory flat"]);
        let mut r = clean();
        r.samples[2].device.allocated += 256;
        assert_eq!(failed(&r), ["device memory flat"]);
        let mut r = clean();
        r.live_tiles[5] = 80;
        assert_eq!(failed(&r), ["cache occupancy bounded"]);
        let mut r = clean();
        r.live_tiles[1] = 100;
        assert_eq!(failed(&r), ["cache occupancy bounded"]);
        let mut r = clean();
        r.frame_ms[4] = 16.0;
        r.frame_ms[5] = 16.0;
        assert_eq!(failed(&r), ["frame time steady"]);
        let mut r = clean();
        r.samples[2].validation_messages = Some(1);
        assert_eq!(failed(&r), ["zero validation messages"]);
        // The warm-up period is not a window: slow first frames are no drift.
        let mut r = clean();
        r.frame_ms[0] = 500.0;
        assert!(failed(&r).is_empty());
    }

    #[test]
    fn bad_settings_are_named() {
        let err = |s: SoakSettings| s.validate().unwrap_err().to_string();
        let d = SoakSettings::default();
        assert!(err(SoakSettings { frames: 999, ..d }).contains("frames"));
        assert!(err(SoakSettings { period: 0, ..d }).contains("period"));
        assert!(
            err(SoakSettings {
                check_every: 0,
                ..d
            })
            .contains("check_every")
        );
        let nan = SoakSettings {
            light_intensity: f32::NAN,
            ..d
        };
        assert!(err(nan).contains("light_intensity"));
        assert!(d.validate().is_ok());
    }

    #[test]
    fn the_light_circles_inside_the_bounds() {
        let bounds = crate::scene::Aabb {
            min: Vec3::new(-1.0, 0.0, -2.0),
            max: Vec3::new(1.0, 2.0, 2.0),
        };
        for i in 0..16 {
            let p = light_position(&bounds, i as f32 / 16.0);
            assert!((p.y - 1.7).abs() < 1e-6, "{p}");
            assert!(
                ((p - Vec3::new(0.0, 1.7, 0.0)).length() - 0.5).abs() < 1e-5,
                "{p}"
            );
        }
        assert!((light_position(&bounds, 1.0) - light_position(&bounds, 0.0)).length() < 1e-5);
    }
}
