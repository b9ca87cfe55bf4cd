//! Camera paths for multi-frame renders: a static camera, an orbit, a periodic swing, or one camera
//! per frame from a text file.

use crate::error::{Error, Result};
use gi_shared::camera::CameraParams;
use glam::{Quat, Vec3};
use std::path::Path;

/// How the camera moves from frame to frame.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraPath {
    /// The base camera every frame.
    Static,
    /// The base camera turned about the vertical axis through `pivot` by `degrees_per_frame`
    /// each frame (position and direction together, so frame 0 is the base camera).
    Orbit {
        /// A point on the axis.
        pivot: Vec3,
        /// Turn per frame, in degrees.
        degrees_per_frame: f32,
    },
    /// One camera per frame, the last one held after the list ends.
    Keyframes(Vec<Keyframe>),
    /// The base camera turned about the vertical axis through `pivot` by
    /// `amplitude_degrees · sin(2π · frame / period)`: back and forth, the same every `period`
    /// frames (frame 0 is the base camera).
    Swing {
        /// A point on the axis.
        pivot: Vec3,
        /// Largest turn either way, in degrees.
        amplitude_degrees: f32,
        /// Frames of one swing there and back (at least 1).
        period: u32,
    },
}

/// One camera of a [`CameraPath::Keyframes`] path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    /// Eye position.
    pub position: Vec3,
    /// The point looked at.
    pub target: Vec3,
    /// Vertical field of view in degrees (`None`: the base camera's).
    pub fov_degrees: Option<f32>,
}

impl CameraPath {
    /// An orbit of `base` turning `degrees_per_frame` about the vertical axis through the point
    /// `pivot_fraction` of the way (0: the camera itself, a pan; 1: the point looked at) toward
    /// the depth of `centre` (the scene's centre) along the view.
    pub fn orbit_toward(
        base: &CameraParams,
        centre: Vec3,
        degrees_per_frame: f32,
        pivot_fraction: f32,
    ) -> Self {
        let distance = (centre - base.position()).dot(base.forward()).max(0.0);
        Self::Orbit {
            pivot: base.position() + base.forward() * distance * pivot_fraction,
            degrees_per_frame,
        }
    }

    /// Reads a path file: one camera per line, `px py pz tx ty tz [fov_degrees]` (spaces or
    /// commas), `#` starts a comment. Errors name the file and the line.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::InvalidArgument {
            name: "camera path",
            why: format!("{}: {e}", path.display()),
        })?;
        Self::parse(&text).map_err(|why| Error::InvalidArgument {
            name: "camera path",
            why: format!("{}: {why}", path.display()),
        })
    }

    /// Parses the text of a path file (see [`CameraPath::read`]).
    pub fn parse(text: &str) -> std::result::Result<Self, String> {
        let mut frames = vec![];
        for (n, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let values: Vec<f32> = line
                .split(|c: char| c == ',' || c.is_whitespace())
                .filter(|s| !s.is_empty())
                .map(|s| {
                    s.parse::<f32>()
                        .map_err(|e| format!("line {}: {s:?}: {e}", n + 1))
                })
                .collect::<std::result::Result<_, _>>()?;
            if !(values.len() == 6 || values.len() == 7) || values.iter().any(|v| !v.is_finite()) {
                return Err(format!(
                    "line {}: expected 6 or 7 finite numbers (position, target, optional fov), got {line:?}",
                    n + 1
                ));
            }
            let position = Vec3::new(values[0], values[1], values[2]);
            let target = Vec3::new(values[3], values[4], values[5]);
            if (target - position).length_squared() == 0.0 {
                return Err(format!("line {}: the target equals the position", n + 1));
            }
            let fov = values.get(6).copied();
            if fov.is_some_and(|f| !(f > 0.0 && f < 180.0)) {
                return Err(format!("line {}: fov must be in (0, 180) degrees", n + 1));
            }
            frames.push(Keyframe {
                position,
                target,
                fov_degrees: fov,
            });
        }
        if frames.is_empty() {
            return Err("no camera in the file".into());
        }
        Ok(Self::Keyframes(frames))
    }

    /// The camera of frame `frame`, from `base` (which gives the image size and, for static and
    /// orbit and swing paths, the view).
    pub fn camera(&self, base: &CameraParams, frame: u32) -> CameraParams {
        let [width, height] = base.image_size;
        let fov = 2.0 * base.tan_half_fov_y.atan();
        match self {
            Self::Static => *base,
            Self::Orbit {
                pivot,
                degrees_per_frame,
            } => turned(base, *pivot, degrees_per_frame * frame as f32),
            Self::Swing {
                pivot,
                amplitude_degrees,
                period,
            } => {
                let period = (*period).max(1);
                let phase = (frame % period) as f32 / period as f32;
                let degrees = amplitude_degrees * (std::f32::consts::TAU * phase).sin();
                turned(base, *pivot, degrees)
            }
            Self::Keyframes(frames) => {
                let k = frames[(frame as usize).min(frames.len() - 1)];
                let fov = k.fov_degrees.map_or(fov, f32::to_radians);
                CameraParams::new(
                    k.position,
                    k.target - k.position,
                    Vec3::Y,
                    fov,
                    width,
                    height,
                )
            }
        }
    }

    /// Whether the camera moves.
    pub fn moves(&self) -> bool {
        match self {
            Self::Static => false,
            Self::Orbit {
                degrees_per_frame, ..
            } => *degrees_per_frame != 0.0,
            Self::Keyframes(k) => k.windows(2).any(|w| w[0] != w[1]),
            Self::Swing {
                amplitude_degrees,
                period,
                ..
            } => *amplitude_degrees != 0.0 && *period > 1,
        }
    }
}

/// `base` turned by `degrees` about the vertical axis through `pivot`.
fn turned(base: &CameraParams, pivot: Vec3, degrees: f32) -> CameraParams {
    let [width, height] = base.image_size;
    let fov = 2.0 * base.tan_half_fov_y.atan();
    let turn = Quat::from_rotation_y(degrees.to_radians());
    let position = pivot + turn * (base.position() - pivot);
    CameraParams::new(position, turn * base.forward(), Vec3::Y, fov, width, height)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> CameraParams {
        CameraParams::new(Vec3::new(0.0, 1.0, 5.0), -Vec3::Z, Vec3::Y, 0.8, 64, 48)
    }

    #[test]
    fn an_orbit_starts_at_the_base_camera_and_keeps_its_distance() {
        let path = CameraPath::Orbit {
            pivot: Vec3::new(0.0, 1.0, 0.0),
            degrees_per_frame: 90.0,
        };
        let c0 = path.camera(&base(), 0);
        assert!((c0.position() - base().position()).length() < 1e-5);
        let c1 = path.camera(&base(), 1);
        assert!(
            (c1.position() - Vec3::new(5.0, 1.0, 0.0)).length() < 1e-4,
            "{}",
            c1.position()
        );
        assert!((c1.forward() - (-Vec3::X)).length() < 1e-4);
        assert!(path.moves() && !CameraPath::Static.moves());
    }

    #[test]
    fn a_swing_repeats_every_period_and_turns_both_ways() {
        let path = CameraPath::Swing {
            pivot: Vec3::new(0.0, 1.0, 0.0),
            amplitude_degrees: 30.0,
            period: 8,
        };
        let at = |f| path.camera(&base(), f).position();
        assert!((at(0) - base().position()).length() < 1e-5);
        assert!((at(8) - at(0)).length() < 1e-5 && (at(11) - at(3)).length() < 1e-5);
        // A quarter period: the full 30° one way (x = 5 sin 30°), three quarters the other way.
        assert!((at(2).x - 2.5).abs() < 1e-4, "{}", at(2));
        assert!((at(6).x + 2.5).abs() < 1e-4, "{}", at(6));
        assert!(path.moves());
    }

    #[test]
    fn path_files_parse_and_bad_lines_are_named() {
        let p = CameraPath::parse("# eye, target\n0 1 5  0 1 0\n1,1,5, 0,1,0, 60\n").unwrap();
        let c = p.camera(&base(), 7);
        assert!((c.position() - Vec3::new(1.0, 1.0, 5.0)).length() < 1e-6);
        assert!((2.0 * c.tan_half_fov_y.atan() - 60f32.to_radians()).abs() < 1e-5);
        assert!(CameraPath::parse("").unwrap_err().contains("no camera"));
        assert!(
            CameraPath::parse("0 0 0 1 1")
                .unwrap_err()
                .contains("line 1")
        );
        assert!(
            CameraPath::parse("1 1 1 1 1 1")
                .unwrap_err()
                .contains("target")
        );
        assert!(
            CameraPath::parse("0 0 0 1 1 x")
                .unwrap_err()
                .contains("\"x\"")
        );
        assert!(
            CameraPath::parse("0 0 0 0 0 1 400")
                .unwrap_err()
                .contains("fov")
        );
    }
}
