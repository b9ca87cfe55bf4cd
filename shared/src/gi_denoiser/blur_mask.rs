//! FilterBlurMask (GI-1.0 step 24): the blur radius of each pixel for FilterGI.
//!
//! 1. **Dilation** ([`dilated_blur_mask`]): the blur mask (ReprojectGI's `8 − history` pixels)
//!    max-dilated over a radius of [`BLUR_MASK_RADIUS`] pixels with the falloff
//!    `1 − d / (4√2)`, rounded: a pixel next to a disocclusion is blurred too, so the seam between
//!    blurred and converged pixels fades.
//! 2. **Cost** ([`blur_cost`]): each 8 × 8 workgroup sums the taps `(2r + 1)²` its pixels would
//!    take (workgroup memory, one atomic add per pixel) and adds the sum to the GI counters'
//!    `BLUR_TAPS` word.
//! 3. **Budget** ([`adaptive_radius`]): with `avg` the group's taps per pixel (sum / 64), a pixel
//!    with `r > 0` gets `round(max(r − max(0.5 √max(avg − 25, 0) − 1, 0), 1))`: above 25 taps
//!    per pixel (radius 2 everywhere) radii shrink, so a large disocclusion costs little more than
//!    a small one.
//!
//! Sky pixels get −1. Without `FLAG_DENOISER_SPATIAL` every surface pixel gets 0 (FilterGI then
//! copies) and nothing is counted.
//!
//! The kernel's phases ([`begin_blur_cost`], barrier, [`add_blur_cost`], barrier,
//! [`finish_blur_radius`] and [`count_blur_taps`]) are the CPU's too: [`filter_blur_mask_group`]
//! runs a workgroup's lanes phase after phase.

use glam::UVec2;

use crate::atomics::AtomicWords;
use crate::math::{floor, max, sqrt, to_u32_clamped};
use crate::screen_probes::{BLUR_TAPS, FLAG_DENOISER_SPATIAL, GiFrameParams};

/// Radius of the blur mask's dilation, in pixels.
pub const BLUR_MASK_RADIUS: i32 = 4;
/// Workgroup side of FilterBlurMask, in pixels.
pub const BLUR_GROUP_SIZE: u32 = 8;
/// Pixels of a FilterBlurMask workgroup: the divisor of the average cost.
pub const BLUR_GROUP_PIXELS: u32 = BLUR_GROUP_SIZE * BLUR_GROUP_SIZE;
/// Taps per pixel the budget allows before radii shrink (`(2 · 2 + 1)²`).
pub const BLUR_TAP_BUDGET: f32 = 25.0;
/// Blur radius of a sky pixel.
pub const BLUR_RADIUS_SKY: f32 = -1.0;

/// `1 / (4√2)`: the dilation's falloff reaches zero at the corner of the 9 × 9 square.
const INV_DILATION_REACH: f32 = 1.0 / (4.0 * core::f32::consts::SQRT_2);

/// `x` rounded half up (for `x ≥ 0`; the same operations on every device).
#[inline]
pub fn round_half_up(x: f32) -> f32 {
    floor(x + 0.5)
}

/// The dilated blur radius of `pixel`: `round(max over taps within 4 pixels of mask × (1 −
/// d / (4√2)))`, sky taps and taps outside the image skipped; −1 for a sky pixel (mask < 0) or a
/// pixel outside the image or buffer.
#[inline]
pub fn dilated_blur_mask(frame: &GiFrameParams, mask: &[f32], pixel: UVec2) -> f32 {
    let [w, h] = frame.image_size;
    if pixel.x >= w || pixel.y >= h {
        return BLUR_RADIUS_SKY;
    }
    let i = (pixel.y * w + pixel.x) as usize;
    if i >= mask.len() {
        return BLUR_RADIUS_SKY;
    }
    let own = mask[i];
    if own.is_nan() || own < 0.0 {
        return BLUR_RADIUS_SKY;
    }
    let mut best = own;
    let mut dy = -BLUR_MASK_RADIUS;
    while dy <= BLUR_MASK_RADIUS {
        let mut dx = -BLUR_MASK_RADIUS;
        while dx <= BLUR_MASK_RADIUS {
            let x = pixel.x as i32 + dx;
            let y = pixel.y as i32 + dy;
            if x >= 0 && y >= 0 && (x as u32) < w && (y as u32) < h {
                let t = (y as u32 * w + x as u32) as usize;
                if t < mask.len() {
                    let m = mask[t];
                    let d = sqrt((dx * dx + dy * dy) as f32);
                    let weighted = m * (1.0 - d * INV_DILATION_REACH);
                    if m > 0.0 && weighted > best {
                        best = weighted;
                    }
                }
            }
            dx += 1;
        }
        dy += 1;
    }
    round_half_up(best)
}

/// Taps a pixel of radius `r` would take: `(2r + 1)²`, none for sky (`r < 0`).
#[inline]
pub fn blur_cost(r: f32) -> u32 {
    if r >= 0.0 {
        let side = 2 * to_u32_clamped(r) + 1;
        side * side
    } else {
        0
    }
}

/// The budgeted radius of a pixel with dilated radius `r` in a workgroup whose pixels take `sum`
/// taps: `round(max(r − max(0.5 √max(avg − 25, 0) − 1, 0), 1))` with `avg = sum / 64` when
/// `r > 0`; 0 for `r = 0`, −1 for sky.
#[inline]
pub fn adaptive_radius(r: f32, sum: u32) -> f32 {
    if r < 0.0 {
        return BLUR_RADIUS_SKY;
    }
    if r <= 0.0 {
        return 0.0;
    }
    let average = sum as f32 / BLUR_GROUP_PIXELS as f32;
    let cut = max(0.5 * sqrt(max(average - BLUR_TAP_BUDGET, 0.0)) - 1.0, 0.0);
    round_half_up(max(r - cut, 1.0))
}

/// Phase 0 (before the first barrier): lane 0 zeroes the workgroup's tap sum (word 0 of
/// `shared`).
#[inline]
pub fn begin_blur_cost<S: AtomicWords + ?Sized>(shared: &mut S, lane: u32) {
    if lane == 0 && shared.word_count() > 0 {
        shared.store(0, 0);
    }
}

/// Phase 1 (between the barriers): the dilated radius of `pixel` (sky −1; 0 without
/// `FLAG_DENOISER_SPATIAL`), its taps added to the workgroup's sum.
#[inline]
pub fn add_blur_cost<S: AtomicWords + ?Sized>(
    frame: &GiFrameParams,
    mask: &[f32],
    pixel: UVec2,
    shared: &mut S,
) -> f32 {
    let r = dilated_blur_mask(frame, mask, pixel);
    if r < 0.0 {
        return BLUR_RADIUS_SKY;
    }
    if !frame.has(FLAG_DENOISER_SPATIAL) {
        return 0.0;
    }
    if shared.word_count() > 0 {
        shared.fetch_add(0, blur_cost(r));
    }
    r
}

/// Phase 2 (after the second barrier): the pixel's budgeted radius from its dilated radius `r`
/// and the workgroup's sum.
#[inline]
pub fn finish_blur_radius<S: AtomicWords + ?Sized>(r: f32, shared: &S) -> f32 {
    let sum = if shared.word_count() > 0 {
        shared.load(0)
    } else {
        0
    };
    adaptive_radius(r, sum)
}

/// Phase 2: lane 0 adds the workgroup's taps to the GI counters' [`BLUR_TAPS`] word.
#[inline]
pub fn count_blur_taps<S: AtomicWords + ?Sized, C: AtomicWords + ?Sized>(
    shared: &S,
    counters: &mut C,
    lane: u32,
) {
    if lane == 0 && shared.word_count() > 0 && BLUR_TAPS < counters.word_count() {
        let sum = shared.load(0);
        if sum > 0 {
            counters.fetch_add(BLUR_TAPS, sum);
        }
    }
}

/// The pixel of lane `lane` of workgroup `group`.
#[inline]
pub fn group_pixel(group: UVec2, lane: u32) -> UVec2 {
    group * BLUR_GROUP_SIZE + UVec2::new(lane % BLUR_GROUP_SIZE, lane / BLUR_GROUP_SIZE)
}

/// One FilterBlurMask workgroup on the CPU: its 64 lanes phase after phase, as the kernel runs
/// them, writing `radius` (row by row) for the pixels inside the image.
pub fn filter_blur_mask_group<C: AtomicWords + ?Sized>(
    frame: &GiFrameParams,
    mask: &[f32],
    group: UVec2,
    radius: &mut [f32],
    counters: &mut C,
) {
    let mut shared = [0u32; 1];
    for lane in 0..BLUR_GROUP_PIXELS {
        begin_blur_cost(&mut shared[..], lane);
    }
    let mut dilated = [0.0f32; BLUR_GROUP_PIXELS as usize];
    for lane in 0..BLUR_GROUP_PIXELS {
        dilated[lane as usize] =
            add_blur_cost(frame, mask, group_pixel(group, lane), &mut shared[..]);
    }
    for lane in 0..BLUR_GROUP_PIXELS {
        let pixel = group_pixel(group, lane);
        let r = finish_blur_radius(dilated[lane as usize], &shared[..]);
        if pixel.x < frame.image_size[0] && pixel.y < frame.image_size[1] {
            let i = (pixel.y * frame.image_size[0] + pixel.x) as usize;
            if i < radius.len() {
                radius[i] = r;
            }
        }
        count_blur_taps(&shared[..], counters, lane);
    }
}

/// The whole pass on the CPU: every workgroup of the image.
pub fn filter_blur_mask_image<C: AtomicWords + ?Sized>(
    frame: &GiFrameParams,
    mask: &[f32],
    radius: &mut [f32],
    counters: &mut C,
) {
    let groups = UVec2::new(
        frame.image_size[0].div_ceil(BLUR_GROUP_SIZE),
        frame.image_size[1].div_ceil(BLUR_GROUP_SIZE),
    );
    for gy in 0..groups.y {
        for gx in 0..groups.x {
            filter_blur_mask_group(frame, mask, UVec2::new(gx, gy), radius, counters);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::screen_probes::GI_COUNTER_WORDS;

    const W: u32 = 24;
    const H: u32 = 16;

    fn frame() -> GiFrameParams {
        GiFrameParams {
            image_size: [W, H],
            flags: FLAG_DENOISER_SPATIAL,
            ..Default::default()
        }
    }

    #[test]
    fn dilation_spreads_with_falloff() {
        let f = frame();
        let mut mask = vec![0.0f32; (W * H) as usize];
        // One pixel with 7 frames to blur at (10, 8).
        mask[(8 * W + 10) as usize] = 7.0;
        let at = |x: u32, y: u32| dilated_blur_mask(&f, &mask, UVec2::new(x, y));
        assert_eq!(at(10, 8), 7.0);
        // One pixel away: 7 × (1 − 1/(4√2)) = 5.76 → 6.
        assert_eq!(at(11, 8), 6.0);
        // Four pixels away along an axis: 7 × (1 − 4/(4√2)) = 2.05 → 2.
        assert_eq!(at(14, 8), 2.0);
        // The corner of the window: weight 0; beyond: untouched.
        assert_eq!(at(14, 12), 0.0);
        assert_eq!(at(15, 8), 0.0);
        assert_eq!(at(W, 0), BLUR_RADIUS_SKY);
        // Sky stays sky and does not spread.
        mask[0] = -1.0;
        assert_eq!(
            dilated_blur_mask(&f, &mask, UVec2::new(0, 0)),
            BLUR_RADIUS_SKY
        );
        assert_eq!(dilated_blur_mask(&f, &mask, UVec2::new(1, 0)), 0.0);
    }

    #[test]
    fn the_budget_shrinks_radii_when_the_group_is_expensive() {
        assert_eq!(blur_cost(0.0), 1);
        assert_eq!(blur_cost(2.0), 25);
        assert_eq!(blur_cost(-1.0), 0);
        // Within budget: unchanged.
        assert_eq!(adaptive_radius(2.0, 25 * 64), 2.0);
        assert_eq!(adaptive_radius(7.0, 25 * 64), 7.0);
        // Every pixel at 7: 225 taps each, cut 0.5 √200 − 1 = 6.07: radius 1.
        assert_eq!(adaptive_radius(7.0, 225 * 64), 1.0);
        // Average 61: cut 2: 5 → 3.
        assert_eq!(adaptive_radius(5.0, 61 * 64), 3.0);
        assert_eq!(adaptive_radius(0.0, 225 * 64), 0.0);
        assert_eq!(adaptive_radius(-1.0, 0), BLUR_RADIUS_SKY);
    }

    #[test]
    fn groups_run_their_phases_and_count_taps() {
        let mut f = frame();
        let n = (W * H) as usize;
        // Columns 0..10 are fresh (7), the rest converged (0); one sky pixel.
        let mut mask: Vec<f32> = (0..n)
            .map(|i| if (i as u32 % W) < 10 { 7.0 } else { 0.0 })
            .collect();
        mask[(3 * W + 20) as usize] = -1.0;
        let mut radius = vec![9.0f32; n];
        let mut counters = [0u32; GI_COUNTER_WORDS];
        filter_blur_mask_image(&f, &mask, &mut radius, &mut counters[..]);
        assert!(
            radius
                .iter()
                .all(|&r| r == r.floor() && (-1.0..=7.0).contains(&r))
        );
        assert_eq!(radius[(3 * W + 20) as usize], BLUR_RADIUS_SKY);
        // The expensive left groups (all 7) shrink to 1.
        assert_eq!(radius[(4 * W + 2) as usize], 1.0);
        // The middle groups' columns 8..16 dilate to 7, 7, 6, 5, 3, 2, 0, 0: 102 taps per pixel
        // on average, a cut of 0.5 √77 − 1 = 3.39.
        assert_eq!(radius[(4 * W + 8) as usize], 4.0);
        assert_eq!(radius[(4 * W + 10) as usize], 3.0);
        assert_eq!(radius[(4 * W + 13) as usize], 1.0);
        assert_eq!(radius[(4 * W + 14) as usize], 0.0);
        // Out of the dilation's reach.
        assert_eq!(radius[(4 * W + 16) as usize], 0.0);
        // The counter holds every group's taps of the dilated radii.
        let mut expected = 0u32;
        for y in 0..H {
            for x in 0..W {
                let r = dilated_blur_mask(&f, &mask, UVec2::new(x, y));
                expected += blur_cost(r);
            }
        }
        assert_eq!(counters[BLUR_TAPS], expected);
        // Spatial filtering off: zero radii, nothing counted.
        f.flags = 0;
        let mut counters = [0u32; GI_COUNTER_WORDS];
        filter_blur_mask_image(&f, &mask, &mut radius, &mut counters[..]);
        assert!(radius.iter().all(|&r| r == 0.0 || r == BLUR_RADIUS_SKY));
        assert_eq!(counters[BLUR_TAPS], 0);
    }
}
