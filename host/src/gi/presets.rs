//! Quality presets: named points of the error-against-cost curve that `gi bench` measures
//! (README, "Speed and accuracy", for each preset's measured point on each scene).
//!
//! The fourth preset of `gi`, `reference`, is the path tracer itself (`--method path`).

use super::settings::{GiSettings, SpawnRate};
use gi_shared::hash_cells::HISTORY_FRAMES;
use std::fmt;

/// The presets' interpolation jitter, in probe tiles: half the reference's reach. It lowers
/// relMSE, FLIP and flicker on every scene measured, as a shorter reach moves less light across
/// shadow edges (README, "Round 11" and "Round 16").
pub const PRESET_JITTER_TILES: f32 = 1.0;
/// The presets' screen-space GI radius, in pixels: two probe tiles, the detail the probes do not
/// resolve. At 320 × 180 (`balanced`, 96 frames) it took the Cornell box's dark half from +11.8 to
/// +7.5 % and the living room's from +5.5 to +0.9 % at about half its relMSE; 32 pixels did worse
/// on three of four scenes (README, "Round 27").
pub const PRESET_OCCLUSION_RADIUS: u32 = 16;

/// A named set of [`GiSettings`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Preset {
    /// The cheapest frame that stays clean: one probe traced per 32 × 32 pixels per frame
    /// (1/16 of the tiles) and cache cells of 64 pixels (fewer, longer-lived tiles). Slower to
    /// answer a change of light and a disocclusion, noisier while the camera moves.
    Fast,
    /// The reference's settings at this resolution (1/4 of the tiles traced per frame, 32-pixel
    /// cache cells, a 16-sample cap) with multi-bounce through the cache, emitter sampling and
    /// a one-tile interpolation jitter. The default.
    Balanced,
    /// Every probe tile traced every frame (four times the probe rays of `balanced`) and no
    /// probe filter: with four times the rays a probe needs no help from its neighbours, and
    /// the filter's blur across them is what the error then consists of (it halves the Cornell
    /// box's error). The least error, still and moving, for about twice the frame time.
    Quality,
}

impl Preset {
    /// Every preset, cheapest first.
    pub const ALL: [Preset; 3] = [Preset::Fast, Preset::Balanced, Preset::Quality];

    /// Its name on the command line and in tables.
    pub fn name(self) -> &'static str {
        match self {
            Self::Fast => "fast",
            Self::Balanced => "balanced",
            Self::Quality => "quality",
        }
    }

    /// The preset by name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Its settings for a `width × height` frame (the cache sized by
    /// [`GiSettings::with_cache_for`] for the preset's cell size).
    pub fn settings(self, width: u32, height: u32) -> GiSettings {
        // Every preset bounces light through the world cache, lets its cells' history fade
        // with time, adapts its blend to change, samples the emitters at the primary hit and
        // jitters interpolation by one tile (the reference does none of these), and reads the
        // probes through screen-space GI's occlusion (as the reference does). The cache's own
        // bounces replace temporal feedback, which fed the screen's biases back into the cache
        // (README, "Round 14"; "Round 16" for the emitters and the jitter).
        let base = GiSettings {
            multi_bounce: true,
            temporal_feedback: false,
            adaptive_cache_blend: true,
            cache_history_frames: HISTORY_FRAMES,
            emitter_sampling: true,
            interpolation_jitter_radius: PRESET_JITTER_TILES,
            occlusion_radius: PRESET_OCCLUSION_RADIUS,
            ..GiSettings::default()
        };
        match self {
            Self::Fast => GiSettings {
                spawn_rate: SpawnRate::Sixteenth,
                cell_size_pixels: 64.0,
                ..base
            },
            Self::Balanced => base,
            Self::Quality => GiSettings {
                spawn_rate: SpawnRate::Full,
                probe_filter: false,
                ..base
            },
        }
        .with_cache_for(width, height)
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_are_valid_distinct_and_named() {
        let settings: Vec<GiSettings> = Preset::ALL.iter().map(|p| p.settings(320, 180)).collect();
        for (p, s) in Preset::ALL.iter().zip(&settings) {
            s.validate(320, 180).unwrap();
            assert_eq!(Preset::from_name(p.name()), Some(*p));
        }
        assert_eq!(
            settings[1],
            GiSettings {
                multi_bounce: true,
                temporal_feedback: false,
                adaptive_cache_blend: true,
                cache_history_frames: HISTORY_FRAMES,
                emitter_sampling: true,
                interpolation_jitter_radius: PRESET_JITTER_TILES,
                occlusion_radius: PRESET_OCCLUSION_RADIUS,
                ..GiSettings::default()
            }
            .with_cache_for(320, 180)
        );
        assert_ne!(settings[0], settings[1]);
        assert_ne!(settings[2], settings[1]);
        assert_eq!(Preset::from_name("reference"), None);
    }
}
