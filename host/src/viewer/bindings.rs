//! The viewer's keys: one table binds each key to an [`Action`], and every on/off technique of
//! [`GiSettings`] is a [`Toggle`] with its own key. The overlay's help is made from the same
//! table, so it cannot disagree with what the keys do.

use crate::gi::GiSettings;
use winit::keyboard::KeyCode;

/// An on/off GI technique of [`GiSettings`] (the talk's names; see each field for its cost and
/// quality effect).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Toggle {
    /// [`GiSettings::reprojection`].
    Reprojection,
    /// [`GiSettings::parallax`].
    Parallax,
    /// [`GiSettings::radiance_backup`].
    RadianceBackup,
    /// [`GiSettings::patching`].
    Patching,
    /// [`GiSettings::ray_guiding`].
    RayGuiding,
    /// [`GiSettings::hysteresis`].
    Hysteresis,
    /// [`GiSettings::probe_filter`].
    ProbeFilter,
    /// [`GiSettings::interpolation_jitter`].
    InterpolationJitter,
    /// [`GiSettings::relaxed_fallback`].
    RelaxedFallback,
    /// [`GiSettings::denoiser_temporal`].
    DenoiserTemporal,
    /// [`GiSettings::denoiser_spatial`].
    DenoiserSpatial,
    /// [`GiSettings::temporal_feedback`].
    TemporalFeedback,
    /// [`GiSettings::multi_bounce`].
    MultiBounce,
    /// [`GiSettings::short_ray_flag`].
    ShortRayFlag,
    /// [`GiSettings::bypass`].
    Bypass,
    /// [`GiSettings::restir`].
    Restir,
    /// [`GiSettings::object_motion`].
    ObjectMotion,
}

impl Toggle {
    /// Every toggle, in the frame's order.
    pub const ALL: [Self; 17] = [
        Self::Reprojection,
        Self::Parallax,
        Self::RadianceBackup,
        Self::Patching,
        Self::RayGuiding,
        Self::Hysteresis,
        Self::ProbeFilter,
        Self::InterpolationJitter,
        Self::RelaxedFallback,
        Self::DenoiserTemporal,
        Self::DenoiserSpatial,
        Self::TemporalFeedback,
        Self::MultiBounce,
        Self::ShortRayFlag,
        Self::Bypass,
        Self::Restir,
        Self::ObjectMotion,
    ];

    /// Its short name in the overlay.
    pub fn name(self) -> &'static str {
        match self {
            Self::Reprojection => "reprojection",
            Self::Parallax => "parallax",
            Self::RadianceBackup => "backup",
            Self::Patching => "patching",
            Self::RayGuiding => "guiding",
            Self::Hysteresis => "hysteresis",
            Self::ProbeFilter => "probe filter",
            Self::InterpolationJitter => "jitter",
            Self::RelaxedFallback => "relaxed",
            Self::DenoiserTemporal => "denoise temporal",
            Self::DenoiserSpatial => "denoise spatial",
            Self::TemporalFeedback => "feedback",
            Self::MultiBounce => "multi-bounce",
            Self::ShortRayFlag => "short-ray flag",
            Self::Bypass => "bypass",
            Self::Restir => "ReSTIR",
            Self::ObjectMotion => "object motion",
        }
    }

    /// Its key.
    pub fn key(self) -> KeyCode {
        match self {
            Self::Reprojection => KeyCode::Digit1,
            Self::Parallax => KeyCode::Digit2,
            Self::RadianceBackup => KeyCode::Digit3,
            Self::Patching => KeyCode::Digit4,
            Self::RayGuiding => KeyCode::Digit5,
            Self::Hysteresis => KeyCode::Digit6,
            Self::ProbeFilter => KeyCode::Digit7,
            Self::InterpolationJitter => KeyCode::Digit8,
            Self::RelaxedFallback => KeyCode::Digit9,
            Self::DenoiserTemporal => KeyCode::Digit0,
            Self::DenoiserSpatial => KeyCode::Minus,
            Self::TemporalFeedback => KeyCode::KeyF,
            Self::MultiBounce => KeyCode::KeyN,
            Self::ShortRayFlag => KeyCode::KeyL,
            Self::Bypass => KeyCode::KeyB,
            Self::Restir => KeyCode::KeyT,
            Self::ObjectMotion => KeyCode::KeyM,
        }
    }

    /// The setting it switches.
    pub fn field(self, s: &mut GiSettings) -> &mut bool {
        match self {
            Self::Reprojection => &mut s.reprojection,
            Self::Parallax => &mut s.parallax,
            Self::RadianceBackup => &mut s.radiance_backup,
            Self::Patching => &mut s.patching,
            Self::RayGuiding => &mut s.ray_guiding,
            Self::Hysteresis => &mut s.hysteresis,
            Self::ProbeFilter => &mut s.probe_filter,
            Self::InterpolationJitter => &mut s.interpolation_jitter,
            Self::RelaxedFallback => &mut s.relaxed_fallback,
            Self::DenoiserTemporal => &mut s.denoiser_temporal,
            Self::DenoiserSpatial => &mut s.denoiser_spatial,
            Self::TemporalFeedback => &mut s.temporal_feedback,
            Self::MultiBounce => &mut s.multi_bounce,
            Self::ShortRayFlag => &mut s.short_ray_flag,
            Self::Bypass => &mut s.bypass,
            Self::Restir => &mut s.restir,
            Self::ObjectMotion => &mut s.object_motion,
        }
    }

    /// Whether it is on in `s`.
    pub fn is_on(self, s: &GiSettings) -> bool {
        let mut copy = *s;
        *self.field(&mut copy)
    }
}

/// What a key does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Action {
    /// Close the viewer.
    Quit,
    /// Next renderer: GI, the path tracer (accumulating while the camera stands still), the
    /// world cache on its own.
    NextMode,
    /// Next debug view of the renderer (after the last: the image itself).
    NextDebugView,
    /// Next quality preset (its settings replace the toggles).
    NextPreset,
    /// Next probe spawn rate (1, 1/4, 1/16 of the probe tiles per frame).
    NextSpawnRate,
    /// Show or hide the overlay.
    ToggleOverlay,
    /// Back to the scene's camera.
    ResetCamera,
    /// Brighter by a stop.
    ExposureUp,
    /// Darker by a stop.
    ExposureDown,
    /// Switch a GI technique on or off.
    Toggle(Toggle),
}

/// The keys of the actions other than toggles, with their help text.
const BINDINGS: [(KeyCode, Action, &str); 9] = [
    (KeyCode::Escape, Action::Quit, "quit"),
    (KeyCode::Tab, Action::NextMode, "GI / path tracer / cache"),
    (KeyCode::KeyV, Action::NextDebugView, "next debug view"),
    (KeyCode::KeyP, Action::NextPreset, "next preset"),
    (KeyCode::KeyR, Action::NextSpawnRate, "next spawn rate"),
    (KeyCode::KeyH, Action::ToggleOverlay, "overlay"),
    (KeyCode::KeyC, Action::ResetCamera, "scene camera"),
    (KeyCode::BracketRight, Action::ExposureUp, "exposure +1"),
    (KeyCode::BracketLeft, Action::ExposureDown, "exposure -1"),
];

/// The action of `key`, if it has one (movement keys have none: they are held, not pressed).
pub fn action(key: KeyCode) -> Option<Action> {
    BINDINGS
        .iter()
        .find(|(k, ..)| *k == key)
        .map(|&(_, a, _)| a)
        .or_else(|| {
            Toggle::ALL
                .into_iter()
                .find(|t| t.key() == key)
                .map(Action::Toggle)
        })
}

/// The movement keys: W/S forward and back, A/D left and right, Q/E down and up.
pub fn movement_axis(key: KeyCode) -> Option<(usize, f32)> {
    match key {
        KeyCode::KeyW => Some((0, 1.0)),
        KeyCode::KeyS => Some((0, -1.0)),
        KeyCode::KeyD => Some((1, 1.0)),
        KeyCode::KeyA => Some((1, -1.0)),
        KeyCode::KeyE => Some((2, 1.0)),
        KeyCode::KeyQ => Some((2, -1.0)),
        _ => None,
    }
}

/// A key's label in the help: `Digit1` is `1`, `KeyV` is `V`.
fn label(key: KeyCode) -> String {
    let name = format!("{key:?}");
    match key {
        KeyCode::Minus => "-".into(),
        KeyCode::BracketLeft => "[".into(),
        KeyCode::BracketRight => "]".into(),
        KeyCode::Escape => "Esc".into(),
        _ => name
            .strip_prefix("Digit")
            .or_else(|| name.strip_prefix("Key"))
            .unwrap_or(&name)
            .to_string(),
    }
}

/// The overlay's help: movement, then each binding, then each toggle with its state in `s`.
pub fn help(s: &GiSettings) -> Vec<String> {
    let mut lines = vec![
        "WASD move, Q/E down/up, drag turn, wheel speed, Shift fast".to_string(),
        BINDINGS
            .iter()
            .map(|&(k, _, what)| format!("{} {what}", label(k)))
            .collect::<Vec<_>>()
            .join(", "),
    ];
    for row in Toggle::ALL.chunks(4) {
        lines.push(
            row.iter()
                .map(|t| {
                    let state = if t.is_on(s) { "on" } else { "off" };
                    format!("{} {} {state}", label(t.key()), t.name())
                })
                .collect::<Vec<_>>()
                .join(", "),
        );
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn each_toggle_switches_its_own_setting_only() {
        let base = GiSettings::default();
        let mut seen = HashSet::new();
        for t in Toggle::ALL {
            let mut s = base;
            *t.field(&mut s) ^= true;
            assert_ne!(s, base, "{t:?}");
            assert_eq!(t.is_on(&s), !t.is_on(&base));
            for other in Toggle::ALL.into_iter().filter(|&o| o != t) {
                assert_eq!(other.is_on(&s), other.is_on(&base), "{t:?} moved {other:?}");
            }
            *t.field(&mut s) ^= true;
            assert_eq!(s, base);
            assert!(seen.insert(t.name()), "two toggles named {}", t.name());
        }
    }

    #[test]
    fn every_key_does_one_thing() {
        let mut keys = HashSet::new();
        for (k, a, _) in BINDINGS {
            assert!(keys.insert(k), "{k:?} bound twice");
            assert_eq!(action(k), Some(a));
        }
        for t in Toggle::ALL {
            assert!(keys.insert(t.key()), "{:?} bound twice", t.key());
            assert_eq!(action(t.key()), Some(Action::Toggle(t)));
        }
        for k in [
            KeyCode::KeyW,
            KeyCode::KeyA,
            KeyCode::KeyS,
            KeyCode::KeyD,
            KeyCode::KeyQ,
            KeyCode::KeyE,
        ] {
            assert!(movement_axis(k).is_some());
            assert!(!keys.contains(&k), "{k:?} moves and acts");
            assert_eq!(action(k), None);
        }
    }

    #[test]
    fn the_help_shows_each_toggle_state() {
        let s = GiSettings {
            probe_filter: false,
            ..GiSettings::default()
        };
        let help = help(&s).join("\n");
        assert!(help.contains("7 probe filter off"), "{help}");
        assert!(help.contains("1 reprojection on"), "{help}");
        assert!(help.contains("Tab GI / path tracer / cache"), "{help}");
    }
}
