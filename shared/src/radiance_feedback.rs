//! Temporal radiance feedback (GI-1.0 talk; Capsaicin's `GenerateReservoirs`, step 10b): a
//! secondary hit that the previous frame saw takes the previous frame's final (direct + indirect)
//! radiance at that pixel instead of a shadow ray — "(limited) infinite multi-bounce for free".
//! That radiance is resolved from the pixel's irradiance *before* the denoiser (ResolveGI writes
//! it beside the image): the denoised image lags behind a warming cache by its history's length,
//! and fed back that lag darkened the converged image by 2–9 % of its mean.
//!
//! The hit is projected with the previous frame's view-projection
//! ([`CameraParams::previous_view_proj`]) into the previous frame's image ([`reproject`]); the
//! reuse is accepted ([`accepts`]) when the pixel lies on screen, the previous frame's linear
//! depth there is within [`RADIANCE_FEEDBACK_DEPTH_TOLERANCE`] of the hit's depth under the
//! previous camera (the same surface, not an occluder or the sky), and the previous normal
//! agrees with the hit's (dot above [`RADIANCE_FEEDBACK_MIN_NORMAL_DOT`]: the same side of the
//! same surface). Depths are the G-buffer's: distance along the camera's forward axis, 0 for sky
//! ([`crate::gbuffer`]).

use glam::{UVec2, Vec3};

use crate::cache_view::running_mean;
use crate::camera::{CameraParams, to_clip, uv_of_clip};
use crate::math::{abs, to_u32_clamped};
use crate::packing::{pack_snorm10x3, unpack_snorm10x3};
use crate::world_cache::{CacheQuery, RayRecord};
use bytemuck::{Pod, Zeroable};

/// Largest relative difference between the previous frame's depth and the hit's depth there.
pub const RADIANCE_FEEDBACK_DEPTH_TOLERANCE: f32 = 0.05;
/// The previous frame's normal must have a dot product above this with the hit's normal.
pub const RADIANCE_FEEDBACK_MIN_NORMAL_DOT: f32 = 0.5;

/// Where a secondary hit lies in the previous frame's image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeedbackPixel {
    /// The previous frame's pixel holding the hit.
    pub pixel: UVec2,
    /// The hit's linear depth under the previous camera: the depth that pixel must have.
    pub depth: f32,
}

/// The previous frame's pixel of the world position `position` under `camera`'s previous
/// view-projection, or `None` when it lies behind the previous camera, off its image, or is not
/// finite.
#[inline]
pub fn reproject(camera: &CameraParams, position: Vec3) -> Option<FeedbackPixel> {
    let clip = to_clip(&camera.previous_view_proj, position);
    // False for NaN too.
    if !(clip.w > 0.0 && clip.is_finite()) {
        return None;
    }
    let uv = uv_of_clip(clip);
    let inside = uv.x >= 0.0 && uv.x < 1.0 && uv.y >= 0.0 && uv.y < 1.0;
    if !inside {
        return None;
    }
    let size = UVec2::from_array(camera.image_size);
    let pixel = UVec2::new(
        to_u32_clamped(uv.x * size.x as f32),
        to_u32_clamped(uv.y * size.y as f32),
    );
    // Rounding of `uv × size` can reach the size for uv just below 1.
    if pixel.x >= size.x || pixel.y >= size.y {
        return None;
    }
    Some(FeedbackPixel {
        pixel,
        depth: clip.w,
    })
}

/// Whether the previous frame's radiance at `at` may stand for the hit of unit normal
/// `hit_normal`, given the previous frame's linear depth `previous_depth` and unit normal
/// `previous_normal` there (see the [module](self)). Sky pixels (depth 0) and NaNs are rejected.
#[inline]
pub fn accepts(
    at: &FeedbackPixel,
    hit_normal: Vec3,
    previous_depth: f32,
    previous_normal: Vec3,
) -> bool {
    let same_depth = abs(previous_depth - at.depth) <= RADIANCE_FEEDBACK_DEPTH_TOLERANCE * at.depth;
    same_depth && hit_normal.dot(previous_normal) > RADIANCE_FEEDBACK_MIN_NORMAL_DOT
}

/// One pixel of the previous frame's image as temporal feedback reads it (20 bytes), written by the
/// composite after feedback has read it. The normal travels as `pack_snorm10x3` (feedback only
/// compares it with a hit's normal, [`RADIANCE_FEEDBACK_MIN_NORMAL_DOT`]), the source flag in its
/// free bit 30 ([`FEEDBACK_SOURCE_BIT`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FeedbackTexel {
    /// The pixel's radiance toward the camera, resolved from its irradiance before the denoiser
    /// (the denoised image lags).
    pub radiance: [f32; 3],
    /// Linear depth; 0 for sky.
    pub depth: f32,
    /// Unit geometric normal facing the camera (`pack_snorm10x3`), with [`FEEDBACK_SOURCE_BIT`].
    pub normal: u32,
}

/// Bit of [`FeedbackTexel::normal`] set when the pixel is a source of feedback: it saw a
/// surface that does not emit toward the camera. `pack_snorm10x3` leaves it zero.
pub const FEEDBACK_SOURCE_BIT: u32 = 1 << 30;

impl crate::layout::FloatLayout for FeedbackTexel {
    const FLOAT_WORDS: &'static [u32] = &[0, 1, 2, 3];
}

impl FeedbackTexel {
    /// A texel of `radiance` at `depth` facing `normal`; `source` when feedback may read it.
    #[inline]
    pub fn new(radiance: Vec3, depth: f32, normal: Vec3, source: bool) -> Self {
        Self {
            radiance: radiance.to_array(),
            depth,
            normal: pack_snorm10x3(normal) | if source { FEEDBACK_SOURCE_BIT } else { 0 },
        }
    }

    /// Whether feedback may read this texel.
    #[inline]
    pub fn is_source(&self) -> bool {
        self.normal & FEEDBACK_SOURCE_BIT != 0
    }

    /// The geometric normal (within `0.5 / 511` per component).
    #[inline]
    pub fn geometric_normal(&self) -> Vec3 {
        unpack_snorm10x3(self.normal)
    }
}

/// What temporal radiance feedback found for a query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeedbackLookup {
    /// The previous image's radiance at the reprojected hit.
    pub radiance: Vec3,
    /// Whether the hit reprojected and passed the depth and normal tests.
    pub accepted: bool,
}

/// Temporal radiance feedback (`crate::radiance_feedback`): the query's hit reprojected into the
/// previous frame's image; when that pixel passes the depth and normal tests, its radiance is the
/// hit's outgoing radiance (diffuse: the same toward every direction). `history` holds the
/// previous frame's [`FeedbackTexel`]s, row by row.
pub fn feedback_lookup(
    camera: &CameraParams,
    query: &CacheQuery,
    history: &[FeedbackTexel],
) -> FeedbackLookup {
    let mut out = FeedbackLookup {
        radiance: Vec3::ZERO,
        accepted: false,
    };
    let Some(at) = reproject(camera, query.position()) else {
        return out;
    };
    let i = (at.pixel.y * camera.image_size[0] + at.pixel.x) as usize;
    if i >= history.len() {
        return out;
    }
    let texel = history[i];
    let normal = unpack_snorm10x3(query.geometric_normal);
    if !texel.is_source()
        || texel.depth <= 0.0
        || !accepts(&at, normal, texel.depth, texel.geometric_normal())
    {
        return out;
    }
    let radiance = Vec3::from_array(texel.radiance);
    if radiance.is_finite() && radiance.min_element() >= 0.0 {
        out.radiance = radiance;
        out.accepted = true;
    }
    out
}

/// The [`FeedbackTexel`] a pixel leaves for the next frame: the running mean `sum` of its
/// image, its G-buffer depth and geometric normal; no source where it saw no surface or an
/// emitter.
#[inline]
pub fn feedback_texel(pixel: &RayRecord, sum: [f32; 4], depth: f32, normal: Vec3) -> FeedbackTexel {
    FeedbackTexel::new(
        running_mean(sum),
        depth,
        normal,
        pixel.surface != 0 && pixel.emissive == 0 && depth > 0.0,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{primary_ray, view_projection};
    use crate::primary_surface::tests::camera as wall_camera;
    use crate::world_cache::tests::query_at;
    use glam::Vec2;

    fn camera() -> CameraParams {
        CameraParams::new(
            Vec3::new(0.0, 1.0, 4.0),
            Vec3::new(0.0, -0.2, -1.0),
            Vec3::Y,
            1.0,
            64,
            48,
        )
    }

    #[test]
    fn points_reproject_to_the_pixel_that_saw_them() {
        let c = camera();
        for (x, y) in [(0u32, 0u32), (63, 47), (20, 31)] {
            let ray = primary_ray(&c, UVec2::new(x, y), Vec2::ZERO);
            let p = Vec3::from_array(ray.origin) + Vec3::from_array(ray.direction) * 3.0;
            let at = reproject(&c, p).unwrap();
            assert_eq!(at.pixel, UVec2::new(x, y));
            assert!((at.depth - 3.0).abs() < 1e-5);
        }
        // Behind the camera, at the eye, off screen, NaN: nothing.
        let eye = c.position();
        assert_eq!(reproject(&c, eye - c.forward()), None);
        assert_eq!(reproject(&c, eye), None);
        assert_eq!(reproject(&c, eye + c.forward() + c.right() * 10.0), None);
        assert_eq!(reproject(&c, eye + c.forward() - c.up() * 10.0), None);
        assert_eq!(reproject(&c, Vec3::splat(f32::NAN)), None);
        assert_eq!(reproject(&c, Vec3::splat(f32::INFINITY)), None);
    }

    /// The previous frame's matrix is used, not this frame's.
    #[test]
    fn reprojection_uses_the_previous_camera() {
        let previous = camera();
        let mut moved = previous;
        moved.position = (previous.position() + Vec3::new(0.1, 0.0, 0.0)).to_array();
        moved.view_proj = view_projection(&moved);
        let current = moved.with_previous(&previous);
        let ray = primary_ray(&previous, UVec2::new(30, 20), Vec2::ZERO);
        let p = Vec3::from_array(ray.origin) + Vec3::from_array(ray.direction) * 2.0;
        assert_eq!(reproject(&current, p).unwrap().pixel, UVec2::new(30, 20));
        let static_moved = moved.with_previous(&moved);
        assert_ne!(
            reproject(&static_moved, p).unwrap().pixel,
            UVec2::new(30, 20)
        );
    }

    #[test]
    fn acceptance_edges() {
        let at = FeedbackPixel {
            pixel: UVec2::ZERO,
            depth: 10.0,
        };
        let n = Vec3::Y;
        assert!(accepts(&at, n, 10.0, n));
        // 5 % either way is in; just past it is out.
        assert!(accepts(&at, n, 10.5, n));
        assert!(accepts(&at, n, 9.5, n));
        assert!(!accepts(&at, n, 10.51, n));
        assert!(!accepts(&at, n, 9.49, n));
        // Sky, an occluder in front, NaN depth.
        assert!(!accepts(&at, n, 0.0, n));
        assert!(!accepts(&at, n, 3.0, n));
        assert!(!accepts(&at, n, f32::NAN, n));
        // Normals: above 0.5 in, at 0.5 and below out, the other side out, NaN out.
        let tilted = |c: f32| Vec3::new((1.0 - c * c).sqrt(), c, 0.0);
        assert!(accepts(&at, n, 10.0, tilted(0.51)));
        assert!(!accepts(&at, n, 10.0, tilted(0.5)));
        assert!(!accepts(&at, n, 10.0, tilted(0.49)));
        assert!(!accepts(&at, n, 10.0, -n));
        assert!(!accepts(&at, n, 10.0, Vec3::splat(f32::NAN)));
        assert!(!accepts(&at, Vec3::ZERO, 10.0, n));
    }

    #[test]
    fn feedback_accepts_the_same_surface_and_rejects_others() {
        let c = wall_camera();
        let [w, h] = c.image_size;
        let history: Vec<FeedbackTexel> = (0..w * h)
            .map(|i| FeedbackTexel::new(Vec3::new(i as f32, 1.0, 2.0), 5.0, Vec3::Z, true))
            .collect();
        let p = Vec3::new(0.1, -0.2, 0.0);
        let hit = feedback_lookup(&c, &query_at(p, Vec3::Z), &history);
        assert!(hit.accepted);
        let uv = crate::camera::project(&c.view_proj, p);
        let expected = (uv.y * h as f32) as u32 * w + (uv.x * w as f32) as u32;
        assert_eq!(hit.radiance, Vec3::new(expected as f32, 1.0, 2.0));
        // A point 6 % nearer the camera, the back of the wall, a point off screen: rejected.
        assert!(!feedback_lookup(&c, &query_at(p + Vec3::Z * 0.3, Vec3::Z), &history).accepted);
        assert!(!feedback_lookup(&c, &query_at(p, Vec3::NEG_Z), &history).accepted);
        assert!(
            !feedback_lookup(&c, &query_at(Vec3::new(50.0, 0.0, 0.0), Vec3::Z), &history).accepted
        );
        // 4 % nearer passes.
        assert!(feedback_lookup(&c, &query_at(p + Vec3::Z * 0.2, Vec3::Z), &history).accepted);
        // No history.
        assert!(!feedback_lookup(&c, &query_at(p, Vec3::Z), &[]).accepted);
    }

    #[test]
    fn feedback_texel_layout() {
        use crate::layout::{FloatLayout, float_field_words};
        use core::mem::offset_of;
        assert_eq!(
            FeedbackTexel::FLOAT_WORDS,
            float_field_words(&[
                (offset_of!(FeedbackTexel, radiance), 3),
                (offset_of!(FeedbackTexel, depth), 1)
            ])
        );
        assert_eq!(core::mem::size_of::<FeedbackTexel>(), 20);
        // The source bit survives every normal, and no normal sets it.
        for n in [Vec3::X, -Vec3::ONE, Vec3::NAN, Vec3::splat(1e6)] {
            for source in [false, true] {
                let t = FeedbackTexel::new(Vec3::ONE, 1.0, n, source);
                assert_eq!(t.is_source(), source, "{n}");
                assert_eq!(t.geometric_normal(), unpack_snorm10x3(pack_snorm10x3(n)));
            }
        }
    }
}
