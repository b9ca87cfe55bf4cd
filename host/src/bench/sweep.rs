//! The sweep's points: the presets, then each knob changed alone from `balanced` (so that each
//! point's difference from `balanced` is that knob's cost and effect), then `balanced` at other
//! resolutions and with the other tracing variant.

use super::Sweeps;
use crate::gi::{GiSettings, Preset, SpawnRate};
use gi_shared::hash_cells::MAX_NUM_TILES_LOG2;
use serde::{Deserialize, Serialize};

/// What a point varies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Group {
    /// A preset.
    Preset,
    /// One knob away from `balanced`.
    Knob,
    /// `balanced` at another resolution.
    Resolution,
    /// `balanced` traced by the other kernel variant.
    Variant,
}

/// A switch point: the knob, its value, and how it changes `balanced`.
type Switch = (&'static str, &'static str, fn(&mut GiSettings));

/// One setting to measure.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepPoint {
    /// What it varies.
    pub group: Group,
    /// The knob (`preset` for presets).
    pub knob: &'static str,
    /// The knob's value here.
    pub value: String,
    /// The settings.
    pub settings: GiSettings,
    /// Rendered width (compared at the base width).
    pub width: u32,
    /// Rendered height.
    pub height: u32,
}

impl SweepPoint {
    /// `fast`, `spawn_rate=1/16`, ...
    pub fn label(&self) -> String {
        match self.group {
            Group::Preset => self.value.clone(),
            _ => format!("{}={}", self.knob, self.value),
        }
    }
}

/// The points of `sweeps` at a `width × height` base resolution; `other_variant` names the
/// other tracing variant where the device has it.
pub fn points(
    width: u32,
    height: u32,
    sweeps: Sweeps,
    other_variant: Option<String>,
) -> Vec<SweepPoint> {
    let balanced = Preset::Balanced.settings(width, height);
    let at = |group, knob, value: String, settings| SweepPoint {
        group,
        knob,
        value,
        settings,
        width,
        height,
    };
    let knob = |knob, value: String, settings: GiSettings| at(Group::Knob, knob, value, settings);
    let mut points = Vec::new();
    if sweeps.presets {
        points.extend(Preset::ALL.iter().map(|p| {
            at(
                Group::Preset,
                "preset",
                p.name().into(),
                p.settings(width, height),
            )
        }));
    } else {
        points.push(at(
            Group::Preset,
            "preset",
            Preset::Balanced.name().into(),
            balanced,
        ));
    }
    if sweeps.knobs {
        let b = balanced;
        for (rate, name) in [(SpawnRate::Full, "1"), (SpawnRate::Sixteenth, "1/16")] {
            points.push(knob(
                "spawn_rate",
                name.into(),
                GiSettings {
                    spawn_rate: rate,
                    ..b
                },
            ));
        }
        for cell in [16.0, 64.0] {
            points.push(knob(
                "cell_size_pixels",
                format!("{cell}"),
                GiSettings {
                    cell_size_pixels: cell,
                    ..b
                }
                .with_cache_for(width, height),
            ));
        }
        // The bucket count alone: the cache's size (and memory) moves.
        for delta in [-2i32, 2] {
            let log2 = b.buckets_log2 as i32 + delta;
            if log2 >= 1 && log2 as u32 + b.tiles_per_bucket_log2 <= MAX_NUM_TILES_LOG2 {
                points.push(knob(
                    "buckets",
                    format!("{}", 1u32 << log2),
                    GiSettings {
                        buckets_log2: log2 as u32,
                        ..b
                    },
                ));
            }
        }
        // Tiles per bucket at a constant tile count: only the probe length and the collisions
        // it absorbs change.
        for delta in [-2i32, 2] {
            let per_bucket = b.tiles_per_bucket_log2 as i32 + delta;
            let buckets = b.buckets_log2 as i32 - delta;
            if per_bucket >= 0 && buckets >= 1 {
                points.push(knob(
                    "tiles_per_bucket",
                    format!("{}", 1u32 << per_bucket),
                    GiSettings {
                        tiles_per_bucket_log2: per_bucket as u32,
                        buckets_log2: buckets as u32,
                        ..b
                    },
                ));
            }
        }
        for cap in [4, 64] {
            points.push(knob(
                "sample_cap",
                cap.to_string(),
                GiSettings {
                    sample_cap: cap,
                    ..b
                },
            ));
        }
        // 0: the history never fades (the reference).
        for frames in [0, 4, 32] {
            points.push(knob(
                "cache_history_frames",
                frames.to_string(),
                GiSettings {
                    cache_history_frames: frames,
                    ..b
                },
            ));
        }
        // The jitter's reach around the default: the probe grid's blocks against light moved
        // across shadow edges.
        for radius in [0.5f32, 1.0, 2.0] {
            if radius != b.interpolation_jitter_radius {
                points.push(knob(
                    "interpolation_jitter_radius",
                    radius.to_string(),
                    GiSettings {
                        interpolation_jitter_radius: radius,
                        ..b
                    },
                ));
            }
        }
        let switches: [Switch; 9] = [
            ("probe_filter", "off", |s| s.probe_filter = false),
            ("restir", "on", |s| s.restir = true),
            ("temporal_feedback", "on", |s| s.temporal_feedback = true),
            ("multi_bounce", "off", |s| s.multi_bounce = false),
            ("adaptive_cache_blend", "off", |s| {
                s.adaptive_cache_blend = false
            }),
            ("hysteresis", "off", |s| s.hysteresis = false),
            ("emitter_sampling", "off", |s| s.emitter_sampling = false),
            ("occlusion_radius", "0", |s| s.occlusion_radius = 0),
            ("denoiser", "off", |s| {
                s.denoiser_temporal = false;
                s.denoiser_spatial = false;
            }),
        ];
        for (name, value, set) in switches {
            let mut s = b;
            set(&mut s);
            points.push(knob(name, value.into(), s));
        }
    }
    if sweeps.resolution {
        for (w, h, name) in [(width / 2, height / 2, "1/2"), (width * 2, height * 2, "2")] {
            points.push(SweepPoint {
                group: Group::Resolution,
                knob: "resolution",
                value: format!("{name} ({w}x{h})"),
                settings: Preset::Balanced.settings(w, h),
                width: w,
                height: h,
            });
        }
    }
    if let Some(variant) = other_variant.filter(|_| sweeps.variant) {
        points.push(at(Group::Variant, "tracing", variant, balanced));
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_point_is_valid_and_knobs_differ_from_balanced_alone() {
        let points = points(320, 180, Sweeps::ALL, Some("software".into()));
        let balanced = Preset::Balanced.settings(320, 180);
        let mut labels = std::collections::HashSet::new();
        for p in &points {
            p.settings.validate(p.width, p.height).unwrap();
            assert!(labels.insert(p.label()), "{} twice", p.label());
            if p.group == Group::Knob {
                assert_ne!(p.settings, balanced, "{}", p.label());
                assert_eq!((p.width, p.height), (320, 180));
            }
        }
        let knobs: std::collections::HashSet<_> = points.iter().map(|p| p.knob).collect();
        for k in [
            "preset",
            "spawn_rate",
            "cell_size_pixels",
            "buckets",
            "tiles_per_bucket",
            "sample_cap",
            "cache_history_frames",
            "interpolation_jitter_radius",
            "probe_filter",
            "restir",
            "temporal_feedback",
            "multi_bounce",
            "adaptive_cache_blend",
            "hysteresis",
            "emitter_sampling",
            "occlusion_radius",
            "denoiser",
            "resolution",
            "tracing",
        ] {
            assert!(knobs.contains(k), "no {k} point");
        }
        // The tile count stays put when only the tiles per bucket change.
        for p in points.iter().filter(|p| p.knob == "tiles_per_bucket") {
            assert_eq!(p.settings.tile_count(), balanced.tile_count());
        }
        let none = Sweeps {
            presets: false,
            knobs: false,
            resolution: false,
            variant: false,
        };
        assert_eq!(points_labels(none), ["balanced"]);
    }

    fn points_labels(sweeps: Sweeps) -> Vec<String> {
        points(64, 36, sweeps, None)
            .iter()
            .map(SweepPoint::label)
            .collect()
    }
}
