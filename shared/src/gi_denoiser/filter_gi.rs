//! FilterGI (GI-1.0 step 25): a separable bilateral blur of the accumulated irradiance over each
//! pixel's blur radius (FilterBlurMask's), horizontal then vertical.
//!
//! For a pixel of radius `r > 0`, the taps `-r..=r` along the pass's axis (sky taps and taps
//! outside the image skipped) are averaged with weights ([`tap_weight`]):
//!
//! * depth `exp2(−k |1 − d_tap / d|)`, with `k` = [`DEPTH_SHARPNESS_HISTORY`] when the pixel has
//!   history (count > 1: only similar depths mix) or [`DEPTH_SHARPNESS_NO_HISTORY`] when it has
//!   none (a fresh pixel borrows more freely);
//! * normal `max(N · N_tap, 0)⁴`, only when the pixel has history.
//!
//! The centre tap has weight 1. Radius 0 (or sky, or `FLAG_DENOISER_SPATIAL` off) copies the
//! input. The output's w is the input's (the interpolation hint).
//!
//! The kernel runs the tap loop itself (it reads the G-buffer images) with these functions;
//! [`filter_gi_pixel`] is the same loop over slices for the CPU.

use glam::{UVec2, Vec3, Vec4};

use crate::math::{abs, min_u32, to_u32_clamped};
use crate::screen_probes::{FLAG_DENOISER_SPATIAL, GiFrameParams};

/// The push constant of a horizontal pass.
pub const FILTER_HORIZONTAL: u32 = 0;
/// The push constant of a vertical pass.
pub const FILTER_VERTICAL: u32 = 1;
/// Depth sharpness `k` of a pixel with history.
pub const DEPTH_SHARPNESS_HISTORY: f32 = 200.0;
/// Depth sharpness `k` of a pixel without history.
pub const DEPTH_SHARPNESS_NO_HISTORY: f32 = 20.0;
/// The largest radius a pass honours (FilterBlurMask gives at most 7).
pub const MAX_BLUR_RADIUS: u32 = 8;

/// What the weights of a pixel's taps depend on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterCentre {
    /// The pixel's linear depth.
    pub depth: f32,
    /// Its unit geometric normal.
    pub normal: Vec3,
    /// Depth sharpness `k`.
    pub sharpness: f32,
    /// Whether the normal weight applies (the pixel has history).
    pub use_normal: bool,
}

/// The centre of a pixel with linear `depth`, geometric normal texel `normal` and history count
/// `count` (the current history's w).
#[inline]
pub fn filter_centre(depth: f32, normal: Vec4, count: f32) -> FilterCentre {
    let has_history = count > 1.0;
    FilterCentre {
        depth,
        normal: normal.truncate().normalize_or_zero(),
        sharpness: if has_history {
            DEPTH_SHARPNESS_HISTORY
        } else {
            DEPTH_SHARPNESS_NO_HISTORY
        },
        use_normal: has_history,
    }
}

/// Whether a pixel with these G-buffer texels sees a surface.
#[inline]
pub fn is_surface(depth: f32, normal: Vec4) -> bool {
    depth > 0.0 && normal.w > 0.0
}

/// The weight of a tap with linear depth `depth` and geometric normal texel `normal`; 0 for a
/// sky tap.
#[inline]
pub fn tap_weight(centre: &FilterCentre, depth: f32, normal: Vec4) -> f32 {
    if !is_surface(depth, normal) || centre.depth <= 0.0 {
        return 0.0;
    }
    let mut w = num_traits::Float::exp2(-centre.sharpness * abs(1.0 - depth / centre.depth));
    if centre.use_normal {
        let c = centre.normal.dot(normal.truncate().normalize_or_zero());
        let c = if c > 0.0 { c } else { 0.0 };
        let c2 = c * c;
        w *= c2 * c2;
    }
    if w.is_finite() && w > 0.0 { w } else { 0.0 }
}

/// The taps each side of a pixel of blur radius `radius`: its value rounded down, at most
/// [`MAX_BLUR_RADIUS`]; 0 for sky (−1) or NaN.
#[inline]
pub fn tap_count(radius: f32) -> u32 {
    min_u32(to_u32_clamped(radius), MAX_BLUR_RADIUS)
}

/// The pixel `offset` taps from `pixel` along the pass's axis (`direction` 0: x, else y), or
/// `None` outside the image.
#[inline]
pub fn tap_pixel(pixel: UVec2, direction: u32, offset: i32, size: [u32; 2]) -> Option<UVec2> {
    let (x, y) = if direction == FILTER_HORIZONTAL {
        (pixel.x as i32 + offset, pixel.y as i32)
    } else {
        (pixel.x as i32, pixel.y as i32 + offset)
    };
    if x >= 0 && y >= 0 && (x as u32) < size[0] && (y as u32) < size[1] {
        Some(UVec2::new(x as u32, y as u32))
    } else {
        None
    }
}

/// A running weighted sum of taps' irradiance, starting with the centre at weight 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterSum {
    /// Σ w × rgb.
    pub sum: Vec3,
    /// Σ w.
    pub weight: f32,
}

impl FilterSum {
    /// The centre tap `[r, g, b, w]` alone.
    #[inline]
    pub fn new(centre: [f32; 4]) -> Self {
        let c = Vec3::new(centre[0], centre[1], centre[2]);
        if c.is_finite() {
            Self {
                sum: c,
                weight: 1.0,
            }
        } else {
            Self {
                sum: Vec3::ZERO,
                weight: 0.0,
            }
        }
    }

    /// Adds a tap's `[r, g, b, w]` with weight `w` (non-finite taps are skipped).
    #[inline]
    pub fn add(&mut self, tap: [f32; 4], w: f32) {
        let c = Vec3::new(tap[0], tap[1], tap[2]);
        if w > 0.0 && c.is_finite() {
            self.sum += c * w;
            self.weight += w;
        }
    }

    /// The weighted mean, with `hint` as w (black without weight).
    #[inline]
    pub fn finish(&self, hint: f32) -> [f32; 4] {
        if self.weight > 0.0 {
            let m = self.sum / self.weight;
            [m.x, m.y, m.z, hint]
        } else {
            [0.0, 0.0, 0.0, hint]
        }
    }
}

/// Whether a pixel filters at all: spatial filtering on, a surface, a radius of at least one tap.
#[inline]
pub fn filters(frame: &GiFrameParams, depth: f32, normal: Vec4, radius: f32) -> bool {
    frame.has(FLAG_DENOISER_SPATIAL) && is_surface(depth, normal) && tap_count(radius) > 0
}

/// What steers FilterGI on the CPU, per pixel row by row: the G-buffer's depth and normal, the
/// blur radius, and the denoiser's history (its sample count, `w`).
#[derive(Clone, Copy, Debug)]
pub struct FilterGuides<'a> {
    /// Linear depth.
    pub depth: &'a [f32],
    /// Geometric normal texels.
    pub normal: &'a [Vec4],
    /// Blur radius, pixels.
    pub radius: &'a [f32],
    /// `[r, g, b, count]`.
    pub history: &'a [[f32; 4]],
}

/// One pass for `pixel` on the CPU, the kernel's loop over slices (`guides` and `input`, row by
/// row).
#[inline]
pub fn filter_gi_pixel(
    frame: &GiFrameParams,
    pixel: UVec2,
    direction: u32,
    guides: FilterGuides<'_>,
    input: &[[f32; 4]],
) -> [f32; 4] {
    let FilterGuides {
        depth,
        normal,
        radius,
        history,
    } = guides;
    let size = frame.image_size;
    let i = (pixel.y * size[0] + pixel.x) as usize;
    let centre = input[i];
    if !filters(frame, depth[i], normal[i], radius[i]) {
        return centre;
    }
    let c = filter_centre(depth[i], normal[i], history[i][3]);
    let n = tap_count(radius[i]) as i32;
    let mut acc = FilterSum::new(centre);
    let mut o = -n;
    while o <= n {
        if o != 0
            && let Some(t) = tap_pixel(pixel, direction, o, size)
        {
            let j = (t.y * size[0] + t.x) as usize;
            acc.add(input[j], tap_weight(&c, depth[j], normal[j]));
        }
        o += 1;
    }
    acc.finish(centre[3])
}

/// Both passes over the whole image on the CPU (horizontal into `scratch`, vertical into
/// `output`).
pub fn filter_gi_image(
    frame: &GiFrameParams,
    guides: FilterGuides<'_>,
    input: &[[f32; 4]],
    scratch: &mut [[f32; 4]],
    output: &mut [[f32; 4]],
) {
    let [w, h] = frame.image_size;
    for y in 0..h {
        for x in 0..w {
            scratch[(y * w + x) as usize] =
                filter_gi_pixel(frame, UVec2::new(x, y), FILTER_HORIZONTAL, guides, input);
        }
    }
    for y in 0..h {
        for x in 0..w {
            output[(y * w + x) as usize] =
                filter_gi_pixel(frame, UVec2::new(x, y), FILTER_VERTICAL, guides, scratch);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Random;

    const W: u32 = 20;
    const H: u32 = 12;
    const N: usize = (W * H) as usize;

    fn frame() -> GiFrameParams {
        GiFrameParams {
            image_size: [W, H],
            flags: FLAG_DENOISER_SPATIAL,
            ..Default::default()
        }
    }

    fn run(
        f: &GiFrameParams,
        depth: &[f32],
        normal: &[Vec4],
        radius: &[f32],
        input: &[[f32; 4]],
        count: f32,
    ) -> Vec<[f32; 4]> {
        let history = vec![[0.0, 0.0, 0.0, count]; N];
        let mut scratch = vec![[0.0; 4]; N];
        let mut out = vec![[0.0; 4]; N];
        let guides = FilterGuides {
            depth,
            normal,
            radius,
            history: &history,
        };
        filter_gi_image(f, guides, input, &mut scratch, &mut out);
        out
    }

    #[test]
    fn a_constant_image_stays_constant() {
        let f = frame();
        let mut depth: Vec<f32> = (0..N).map(|i| 2.0 + (i % 7) as f32 * 0.3).collect();
        depth[5] = 0.0;
        let normal: Vec<Vec4> = (0..N)
            .map(|i| {
                let n = Vec3::new((i % 3) as f32 * 0.2, 0.1, 1.0).normalize();
                n.extend(if i == 5 { 0.0 } else { 1.0 })
            })
            .collect();
        let radius: Vec<f32> = (0..N)
            .map(|i| if i == 5 { -1.0 } else { (i % 8) as f32 })
            .collect();
        let mut input = vec![[0.7, 1.5, 3.0, 1.0]; N];
        input[5] = [0.0, 0.0, 0.0, -1.0];
        for count in [1.0, 30.0] {
            let out = run(&f, &depth, &normal, &radius, &input, count);
            for (i, o) in out.iter().enumerate() {
                if i == 5 {
                    assert_eq!(*o, [0.0, 0.0, 0.0, -1.0]);
                } else {
                    for c in 0..3 {
                        assert!((o[c] - input[i][c]).abs() < 1e-5, "{i}: {o:?}");
                    }
                    assert_eq!(o[3], 1.0);
                }
            }
        }
    }

    #[test]
    fn a_depth_edge_is_not_blurred_across() {
        let f = frame();
        // Left half at depth 2 with irradiance 1, right half at depth 4 with irradiance 10.
        let depth: Vec<f32> = (0..N)
            .map(|i| if (i as u32 % W) < 10 { 2.0 } else { 4.0 })
            .collect();
        let normal = vec![Vec4::new(0.0, 0.0, 1.0, 1.0); N];
        let radius = vec![7.0f32; N];
        let input: Vec<[f32; 4]> = (0..N)
            .map(|i| {
                let v = if (i as u32 % W) < 10 { 1.0 } else { 10.0 };
                [v, v, v, 1.0]
            })
            .collect();
        for count in [1.0, 30.0] {
            let out = run(&f, &depth, &normal, &radius, &input, count);
            // Next to the edge, a tap across it weighs exp2(−k/2) seen from the far side and
            // exp2(−k) from the near side: with k = 20 (no history) the far side takes under
            // 0.1 % of the other's light, with k = 200 nothing measurable.
            let left = out[(5 * W + 9) as usize][0];
            let right = out[(5 * W + 10) as usize][0];
            let tolerance = if count > 1.0 { 1e-5 } else { 1e-3 };
            assert!((left - 1.0).abs() < tolerance, "{count}: {left}");
            assert!((right - 10.0).abs() < 10.0 * tolerance, "{count}: {right}");
            // Without the depth weight the edge would be smeared.
            assert!(out[(5 * W + 3) as usize][0] < 1.0 + tolerance);
        }
    }

    #[test]
    fn noise_is_smoothed_and_radius_zero_copies() {
        let mut f = frame();
        let depth = vec![3.0f32; N];
        let normal = vec![Vec4::new(0.0, 0.0, 1.0, 1.0); N];
        let mut rng = Random::new(1, 0);
        let input: Vec<[f32; 4]> = (0..N)
            .map(|_| {
                let v = 2.0 * rng.next_f32();
                [v, v, v, 0.0]
            })
            .collect();
        let variance = |v: &[[f32; 4]]| {
            let m = v.iter().map(|x| x[0]).sum::<f32>() / v.len() as f32;
            v.iter().map(|x| (x[0] - m) * (x[0] - m)).sum::<f32>() / v.len() as f32
        };
        let out = run(&f, &depth, &normal, &vec![3.0; N], &input, 30.0);
        assert!(variance(&out) < 0.1 * variance(&input));
        assert!(out.iter().all(|o| o[3] == 0.0));
        let out = run(&f, &depth, &normal, &vec![0.0; N], &input, 30.0);
        assert_eq!(out, input);
        // Spatial filtering off: a copy whatever the radius.
        f.flags = 0;
        let out = run(&f, &depth, &normal, &vec![5.0; N], &input, 30.0);
        assert_eq!(out, input);
    }

    #[test]
    fn weights() {
        let c = filter_centre(2.0, Vec4::new(0.0, 0.0, 1.0, 1.0), 5.0);
        assert!(c.use_normal && c.sharpness == DEPTH_SHARPNESS_HISTORY);
        let fresh = filter_centre(2.0, Vec4::new(0.0, 0.0, 1.0, 1.0), 1.0);
        assert!(!fresh.use_normal && fresh.sharpness == DEPTH_SHARPNESS_NO_HISTORY);
        let up = Vec4::new(0.0, 0.0, 1.0, 1.0);
        assert_eq!(tap_weight(&c, 2.0, up), 1.0);
        // 1 % depth difference: exp2(−2) with history, exp2(−0.2) without.
        assert!((tap_weight(&c, 2.02, up) - 0.25).abs() < 1e-4);
        assert!((tap_weight(&fresh, 2.02, up) - 2f32.powf(-0.2)).abs() < 1e-4);
        // Normal dot 0.8: 0.8⁴ with history, ignored without.
        let tilted = Vec4::new(0.6, 0.0, 0.8, 1.0);
        assert!((tap_weight(&c, 2.0, tilted) - 0.8f32.powi(4)).abs() < 1e-5);
        assert_eq!(tap_weight(&fresh, 2.0, tilted), 1.0);
        // Sky taps.
        assert_eq!(tap_weight(&c, 0.0, up), 0.0);
        assert_eq!(tap_weight(&c, 2.0, Vec4::ZERO), 0.0);
        assert_eq!(tap_count(-1.0), 0);
        assert_eq!(tap_count(f32::NAN), 0);
        assert_eq!(tap_count(3.0), 3);
        assert_eq!(tap_count(30.0), MAX_BLUR_RADIUS);
        assert_eq!(
            tap_pixel(UVec2::new(0, 0), FILTER_HORIZONTAL, -1, [4, 4]),
            None
        );
        assert_eq!(
            tap_pixel(UVec2::new(0, 0), FILTER_VERTICAL, 3, [4, 4]),
            Some(UVec2::new(0, 3))
        );
    }
}
