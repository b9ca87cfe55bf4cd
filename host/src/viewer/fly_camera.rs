//! The viewer's fly camera: WASD moves, Q and E go down and up, a mouse drag turns (yaw about the
//! world's +Y, pitch below ±89°), the wheel scales the speed and Shift quadruples it.

use gi_shared::camera::CameraParams;
use glam::Vec3;

/// Radians of turn per pixel of mouse drag.
const TURN_PER_PIXEL: f32 = 0.004;
/// Pitch stays this far from straight up or down, where yaw would be undefined.
const MAX_PITCH: f32 = 89.0 * std::f32::consts::PI / 180.0;
/// Factor on the speed per wheel step.
pub const SPEED_PER_STEP: f32 = 1.25;
/// Factor on the speed while Shift is held.
pub const FAST: f32 = 4.0;

/// Which way the held keys push the camera, each in `[-1, 1]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Movement {
    /// Along the view direction (W +, S −).
    pub forward: f32,
    /// Along the camera's right (D +, A −).
    pub right: f32,
    /// Along the world's +Y (E +, Q −).
    pub up: f32,
    /// Shift: [`FAST`] times the speed.
    pub fast: bool,
}

impl Movement {
    /// Whether the keys push at all.
    pub fn is_still(&self) -> bool {
        self.forward == 0.0 && self.right == 0.0 && self.up == 0.0
    }
}

/// A free-flying camera. It holds the [`CameraParams`] it shows and rebuilds them only when it
/// moves, so that an untouched camera renders exactly the scene's view (the one `gi render`
/// renders).
#[derive(Clone, Copy, Debug)]
pub struct FlyCamera {
    params: CameraParams,
    yaw: f32,
    pitch: f32,
    fov_y: f32,
    speed: f32,
}

impl FlyCamera {
    /// Starts at `camera`, moving at `speed` scene units per second.
    pub fn new(camera: CameraParams, speed: f32) -> Self {
        let f = camera.forward();
        Self {
            params: camera,
            yaw: f.x.atan2(-f.z),
            pitch: f.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH),
            fov_y: 2.0 * camera.tan_half_fov_y.atan(),
            speed,
        }
    }

    /// The camera to render.
    pub fn params(&self) -> &CameraParams {
        &self.params
    }

    /// Speed in scene units per second.
    pub fn speed(&self) -> f32 {
        self.speed
    }

    /// The unit view direction of the current yaw and pitch (yaw 0, pitch 0: −Z).
    pub fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(cp * sy, sp, -cp * cy)
    }

    fn rebuild(&mut self, position: Vec3) {
        let [w, h] = self.params.image_size;
        self.params = CameraParams::new(position, self.forward(), Vec3::Y, self.fov_y, w, h);
    }

    /// Moves for `seconds` as `m` pushes; returns whether the camera moved.
    pub fn step(&mut self, m: Movement, seconds: f32) -> bool {
        if m.is_still() || seconds.is_nan() || seconds <= 0.0 {
            return false;
        }
        let speed = self.speed * if m.fast { FAST } else { 1.0 };
        let forward = self.forward();
        let right = forward.cross(Vec3::Y).normalize_or_zero();
        let delta = (forward * m.forward + right * m.right + Vec3::Y * m.up) * speed * seconds;
        self.rebuild(self.params.position() + delta);
        true
    }

    /// Turns by a mouse drag of `dx`, `dy` pixels (right and down positive); returns whether
    /// the camera turned.
    pub fn turn(&mut self, dx: f32, dy: f32) -> bool {
        if dx == 0.0 && dy == 0.0 {
            return false;
        }
        self.yaw += dx * TURN_PER_PIXEL;
        self.pitch = (self.pitch - dy * TURN_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
        self.rebuild(self.params.position());
        true
    }

    /// Scales the speed by [`SPEED_PER_STEP`] per wheel step (up: faster).
    pub fn scale_speed(&mut self, steps: f32) {
        self.speed = (self.speed * SPEED_PER_STEP.powf(steps)).clamp(1e-4, 1e6);
    }

    /// The same view for a `width × height` image.
    pub fn resize(&mut self, width: u32, height: u32) {
        let p = self.params;
        self.params =
            CameraParams::new(p.position(), p.forward(), p.up(), self.fov_y, width, height);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> FlyCamera {
        let c = CameraParams::new(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(1.0, -0.5, -1.0),
            Vec3::Y,
            0.8,
            64,
            48,
        );
        FlyCamera::new(c, 2.0)
    }

    #[test]
    fn an_untouched_camera_is_the_one_it_started_from() {
        let c = camera();
        let start = CameraParams::new(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(1.0, -0.5, -1.0),
            Vec3::Y,
            0.8,
            64,
            48,
        );
        assert_eq!(bytemuck::bytes_of(c.params()), bytemuck::bytes_of(&start));
        assert!((c.forward() - start.forward()).length() < 1e-5);
        assert!(!camera().step(Movement::default(), 1.0));
        assert!(!camera().turn(0.0, 0.0));
    }

    #[test]
    fn keys_move_along_the_view_at_the_speed() {
        let mut c = camera();
        let before = c.params().position();
        let forward = c.forward();
        let m = Movement {
            forward: 1.0,
            ..Movement::default()
        };
        assert!(c.step(m, 0.5));
        assert!((c.params().position() - (before + forward * 1.0)).length() < 1e-5);
        let fast = Movement { fast: true, ..m };
        let mid = c.params().position();
        c.step(fast, 0.5);
        assert!(((c.params().position() - mid).length() - 4.0).abs() < 1e-4);
        let up = Movement {
            up: -1.0,
            ..Movement::default()
        };
        let mid = c.params().position();
        c.step(up, 1.0);
        assert!((c.params().position() - (mid - Vec3::Y * 2.0)).length() < 1e-5);
        // Strafing keeps the height.
        let right = Movement {
            right: 1.0,
            ..Movement::default()
        };
        let mid = c.params().position();
        c.step(right, 1.0);
        assert!((c.params().position().y - mid.y).abs() < 1e-5);
        assert!((c.params().position().distance(mid) - 2.0).abs() < 1e-4);
    }

    #[test]
    fn dragging_turns_and_pitch_stops_short_of_the_pole() {
        let mut c = camera();
        let f = c.forward();
        assert!(c.turn(100.0, 0.0));
        let g = c.params().forward();
        assert!((f.y - g.y).abs() < 1e-5, "yaw keeps the pitch");
        assert!(f.dot(g) < 0.99, "yaw turned the view: {f} -> {g}");
        c.turn(0.0, -1e6);
        assert!(c.params().forward().y > 0.99 && c.params().forward().y < 1.0);
        assert!(c.params().forward().is_finite() && c.params().up().is_finite());
        c.scale_speed(2.0);
        assert!((c.speed() - 2.0 * 1.5625).abs() < 1e-5);
    }

    #[test]
    fn resizing_keeps_the_view() {
        let mut c = camera();
        let f = c.params().forward();
        c.resize(128, 32);
        assert_eq!(c.params().image_size, [128, 32]);
        assert!((c.params().forward() - f).length() < 1e-6);
        assert!((c.params().aspect - 4.0).abs() < 1e-6);
    }
}
