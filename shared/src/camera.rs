//! The pinhole camera of the primary rays, and the projection that turns world positions back into
//! screen positions (motion vectors).
//!
//! # Conventions
//!
//! * Pixels: `(x, y)` with `x` to the right and `y` **down**, row 0 at the top; the centre of pixel
//!   `(x, y)` is `(x + 0.5, y + 0.5)`. Screen uv is the pixel position divided by the image size.
//! * The camera looks down [`CameraParams::forward`] with [`CameraParams::up`] up and
//!   [`CameraParams::right`] to the right (an orthonormal, right-handed basis:
//!   `right = forward × up`).
//! * Primary ray directions are **not** normalised: their component along `forward` is 1, so a
//!   hit's `t` is its linear depth (distance along the forward axis).
//! * View-projection matrices ([`view_projection`]) are 4 rows of 4, applied to column vectors
//!   `(p, 1)`: `clip.x / clip.w` and `clip.y / clip.w` are the normalised device coordinates in
//!   `[-1, 1]` (y down, like Vulkan), and `clip.w` is the linear depth. Row 2 (clip z) is zero:
//!   nothing here needs a depth range. Matrices carry no jitter.

use bytemuck::{Pod, Zeroable};
use glam::{UVec2, Vec2, Vec3, Vec4};
use num_traits::Float;

use crate::ray::Ray;

/// A camera and its frame, as the G-buffer kernel reads it from a storage buffer (208 bytes).
///
/// | offset | field                   |
/// |--------|-------------------------|
/// | 0      | `position`              |
/// | 12     | `tan_half_fov_y`        |
/// | 16     | `right`                 |
/// | 28     | `aspect`                |
/// | 32     | `up`                    |
/// | 44     | `texture_footprint`     |
/// | 48     | `forward`               |
/// | 60     | `_pad1`                 |
/// | 64     | `image_size`            |
/// | 72     | `jitter`                |
/// | 80     | `view_proj`             |
/// | 144    | `previous_view_proj`    |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CameraParams {
    /// World-space position of the eye.
    pub position: [f32; 3],
    /// `tan(yfov / 2)`.
    pub tan_half_fov_y: f32,
    /// World-space unit right vector.
    pub right: [f32; 3],
    /// Width over height of the image.
    pub aspect: f32,
    /// World-space unit up vector.
    pub up: [f32; 3],
    /// Scale of each pixel's footprint for the G-buffer's texture reads ([`crate::ray_cone`]):
    /// 1 (what [`CameraParams::new`] sets) filters the texture over the pixel, right for an image
    /// made of one frame; 0 reads the texture at the sample point alone, right for a view that
    /// integrates the pixel itself over jittered frames (the cache view's running mean, like the
    /// path tracer), which a prefiltered footprint would blur twice.
    pub texture_footprint: f32,
    /// World-space unit viewing direction.
    pub forward: [f32; 3],
    /// Explicit padding.
    pub _pad1: f32,
    /// Image width and height in pixels.
    pub image_size: [u32; 2],
    /// Sub-pixel offset of this frame's primary rays from the pixel centres, in pixels (each
    /// component in `[-0.5, 0.5]`; zero for none).
    pub jitter: [f32; 2],
    /// This frame's (unjittered) view-projection, rows; see the [module](self).
    pub view_proj: [[f32; 4]; 4],
    /// The previous frame's view-projection, rows: motion vectors project hit points with it.
    /// Equal to `view_proj` for a static camera.
    pub previous_view_proj: [[f32; 4]; 4],
}

impl CameraParams {
    /// A camera at `position` looking along `forward`, with `up_hint` roughly up, a vertical field
    /// of view of `fov_y` radians and an image of `width × height` pixels. No jitter; the previous
    /// frame is this one (static camera).
    ///
    /// `forward` need not be normalised. When `up_hint` is parallel to `forward` (or zero), another
    /// axis is used, so the basis is always orthonormal for a non-zero finite `forward`.
    pub fn new(
        position: Vec3,
        forward: Vec3,
        up_hint: Vec3,
        fov_y: f32,
        width: u32,
        height: u32,
    ) -> Self {
        let forward = forward.normalize_or(Vec3::NEG_Z);
        let mut right = forward.cross(up_hint);
        if right.length_squared() < 1e-12 {
            // Looking straight along the hint: any perpendicular will do.
            right = forward.cross(if forward.y.abs() < 0.9 {
                Vec3::Y
            } else {
                Vec3::X
            });
        }
        let right = right.normalize();
        let up = right.cross(forward);
        let height_f = if height == 0 { 1.0 } else { height as f32 };
        let mut camera = Self {
            position: position.to_array(),
            tan_half_fov_y: Float::tan(0.5 * fov_y),
            right: right.to_array(),
            aspect: width as f32 / height_f,
            up: up.to_array(),
            texture_footprint: 1.0,
            forward: forward.to_array(),
            _pad1: 0.0,
            image_size: [width, height],
            jitter: [0.0; 2],
            view_proj: [[0.0; 4]; 4],
            previous_view_proj: [[0.0; 4]; 4],
        };
        camera.view_proj = view_projection(&camera);
        camera.previous_view_proj = camera.view_proj;
        camera
    }

    /// This camera with `previous`'s view-projection as the previous frame's (for motion vectors).
    pub fn with_previous(mut self, previous: &CameraParams) -> Self {
        self.previous_view_proj = previous.view_proj;
        self
    }

    /// Eye position.
    #[inline]
    pub fn position(&self) -> Vec3 {
        Vec3::from_array(self.position)
    }

    /// Unit viewing direction.
    #[inline]
    pub fn forward(&self) -> Vec3 {
        Vec3::from_array(self.forward)
    }

    /// Unit right vector.
    #[inline]
    pub fn right(&self) -> Vec3 {
        Vec3::from_array(self.right)
    }

    /// Unit up vector.
    #[inline]
    pub fn up(&self) -> Vec3 {
        Vec3::from_array(self.up)
    }

    /// Image size in pixels, as floats.
    #[inline]
    pub fn image_size_f32(&self) -> Vec2 {
        Vec2::new(self.image_size[0] as f32, self.image_size[1] as f32)
    }

    /// This frame's jitter in pixels.
    #[inline]
    pub fn jitter(&self) -> Vec2 {
        Vec2::from_array(self.jitter)
    }
}

/// The view-projection of `camera`'s position, basis, field of view and aspect (see the
/// [module](self) for its conventions). Ignores `camera.view_proj`.
pub fn view_projection(camera: &CameraParams) -> [[f32; 4]; 4] {
    let p = camera.position();
    let sx = 1.0 / (camera.tan_half_fov_y * camera.aspect);
    let sy = 1.0 / camera.tan_half_fov_y;
    let right = camera.right() * sx;
    // y down on screen while `up` points up.
    let down = -camera.up() * sy;
    let forward = camera.forward();
    [
        [right.x, right.y, right.z, -right.dot(p)],
        [down.x, down.y, down.z, -down.dot(p)],
        [0.0; 4],
        [forward.x, forward.y, forward.z, -forward.dot(p)],
    ]
}

/// The primary ray through pixel `pixel` offset by `jitter` pixels from its centre: from the eye,
/// direction with a forward component of exactly 1 (so `t` is linear depth), `t` in `[0, ∞]`.
#[inline]
pub fn primary_ray(camera: &CameraParams, pixel: UVec2, jitter: Vec2) -> Ray {
    let size = camera.image_size_f32();
    let sample = Vec2::new(pixel.x as f32 + 0.5, pixel.y as f32 + 0.5) + jitter;
    // Normalised device coordinates, y down.
    let ndc = sample / size * 2.0 - Vec2::ONE;
    let direction = camera.forward()
        + camera.right() * (ndc.x * camera.tan_half_fov_y * camera.aspect)
        - camera.up() * (ndc.y * camera.tan_half_fov_y);
    Ray {
        origin: camera.position,
        t_min: 0.0,
        direction: direction.to_array(),
        t_max: f32::INFINITY,
    }
}

/// Clip-space position `view_proj · (p, 1)`; its `w` is the linear depth under that camera.
#[inline]
pub fn to_clip(view_proj: &[[f32; 4]; 4], p: Vec3) -> Vec4 {
    let h = p.extend(1.0);
    Vec4::new(
        Vec4::from_array(view_proj[0]).dot(h),
        Vec4::from_array(view_proj[1]).dot(h),
        Vec4::from_array(view_proj[2]).dot(h),
        Vec4::from_array(view_proj[3]).dot(h),
    )
}

/// Screen uv of the world position `p` under `view_proj` (`(0, 0)` top left, `(1, 1)` bottom
/// right; outside `[0, 1]²` when off screen). Meaningless for points with a linear depth
/// (`to_clip(..).w`) that is not positive; callers check it.
#[inline]
pub fn project(view_proj: &[[f32; 4]; 4], p: Vec3) -> Vec2 {
    uv_of_clip(to_clip(view_proj, p))
}

/// Screen uv of a clip-space position.
#[inline]
pub fn uv_of_clip(clip: Vec4) -> Vec2 {
    Vec2::new(clip.x, clip.y) / clip.w * 0.5 + Vec2::splat(0.5)
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::{offset_of, size_of};

    #[test]
    fn layout() {
        assert_eq!(size_of::<CameraParams>(), 208);
        assert_eq!(offset_of!(CameraParams, position), 0);
        assert_eq!(offset_of!(CameraParams, tan_half_fov_y), 12);
        assert_eq!(offset_of!(CameraParams, right), 16);
        assert_eq!(offset_of!(CameraParams, aspect), 28);
        assert_eq!(offset_of!(CameraParams, up), 32);
        assert_eq!(offset_of!(CameraParams, texture_footprint), 44);
        assert_eq!(offset_of!(CameraParams, forward), 48);
        assert_eq!(offset_of!(CameraParams, _pad1), 60);
        assert_eq!(offset_of!(CameraParams, image_size), 64);
        assert_eq!(offset_of!(CameraParams, jitter), 72);
        assert_eq!(offset_of!(CameraParams, view_proj), 80);
        assert_eq!(offset_of!(CameraParams, previous_view_proj), 144);
    }

    fn camera() -> CameraParams {
        CameraParams::new(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(-1.0, -0.5, -2.0),
            Vec3::Y,
            0.8,
            64,
            48,
        )
    }

    #[test]
    fn basis_is_orthonormal_and_right_handed() {
        let c = camera();
        let (r, u, f) = (c.right(), c.up(), c.forward());
        for v in [r, u, f] {
            assert!((v.length() - 1.0).abs() < 1e-6);
        }
        assert!(r.dot(u).abs() < 1e-6 && r.dot(f).abs() < 1e-6 && u.dot(f).abs() < 1e-6);
        assert!((f.cross(u) - r).length() < 1e-6);
        assert!(u.y > 0.0, "up stays on the side of the hint");
        // Looking straight down the hint still gives a basis.
        let down = CameraParams::new(Vec3::ZERO, -Vec3::Y, Vec3::Y, 1.0, 8, 8);
        assert!((down.right().length() - 1.0).abs() < 1e-6);
        assert!(down.right().dot(down.forward()).abs() < 1e-6);
    }

    #[test]
    fn rays_project_back_to_their_pixels() {
        let c = camera();
        for (x, y) in [(0, 0), (63, 47), (10, 30), (32, 24)] {
            for jitter in [Vec2::ZERO, Vec2::new(0.25, -0.4)] {
                let ray = primary_ray(&c, UVec2::new(x, y), jitter);
                let d = Vec3::from_array(ray.direction);
                assert!(
                    (d.dot(c.forward()) - 1.0).abs() < 1e-6,
                    "forward component is 1"
                );
                let p = c.position() + d * 2.5;
                let clip = to_clip(&c.view_proj, p);
                assert!((clip.w - 2.5).abs() < 1e-5, "w is linear depth: {}", clip.w);
                let pixel = project(&c.view_proj, p) * c.image_size_f32();
                let expected = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + jitter;
                assert!((pixel - expected).length() < 1e-3, "{pixel} vs {expected}");
            }
        }
    }

    #[test]
    fn pixel_rows_go_down_and_columns_right() {
        let c = CameraParams::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 4, 4);
        let top_left = Vec3::from_array(primary_ray(&c, UVec2::new(0, 0), Vec2::ZERO).direction);
        assert!(top_left.x < 0.0 && top_left.y > 0.0);
        let uv = project(&c.view_proj, Vec3::new(1.0, -1.0, -1.0));
        assert!(uv.x > 0.5 && uv.y > 0.5, "right and down: {uv}");
    }

    #[test]
    fn static_camera_has_equal_matrices_and_moves_are_tracked() {
        let c = camera();
        assert_eq!(c.view_proj, c.previous_view_proj);
        let mut moved = c;
        moved.position = (c.position() + Vec3::new(0.1, 0.0, 0.0)).to_array();
        moved.view_proj = view_projection(&moved);
        let next = moved.with_previous(&c);
        assert_eq!(next.previous_view_proj, c.view_proj);
        assert_ne!(next.previous_view_proj, next.view_proj);
    }
}
