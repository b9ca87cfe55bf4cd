//! ReprojectGI (GI-1.0 step 23): temporal accumulation of the interpolated irradiance, and the
//! blur mask that tells the spatial filter how little history each pixel has.
//!
//! Per pixel:
//!
//! 1. Its surface point ([`primary_surface`]) is found in the previous image at a sub-pixel
//!    position, with its previous world position ([`previous_point`]: the previous camera's
//!    projection, or with [`FLAG_OBJECT_MOTION`] the G-buffer's motion vector where the object
//!    moved, so that the history follows a moving object).
//! 2. The 3 × 3 previous pixels around the nearest one are weighted by
//!    `1 − subpixel distance / √2` ([`history_tap_weight`]); a tap counts when its history exists,
//!    its stored surface lies within `cell × lerp(1, 5, (1 − N·V)^6)` of the point's previous
//!    position (more at
//!    grazing angles, where positions spread along the view ray) and its normal agrees
//!    (`dot > 0.95`) ([`accepts_history`]). The taps' history (mean, count) and luma delta are
//!    blended with these weights.
//! 3. The luma delta (this frame's luminance minus the history's) is smoothed with
//!    [`LUMA_DELTA_SMOOTHING`]; a lasting change makes it large and `alpha = saturate(1 − |Δ| /
//!    lum(history))` small ([`history_alpha`]), which shortens the history. The cap takes the
//!    delta tracked up to the previous frame, not this frame's: a weight that looked at its own
//!    sample would give a bright outlier (a rare light sample that finds a small emitter) up to
//!    16 times the weight of a dark one, and brighten the mean (+6.9 % in the GI furnace of
//!    albedo 0.8 with emitter sampling; README, "Round 16"). The cap is
//!    `max(lerp(4, 8 × min(count, 8), alpha) × vignette, 1)` ([`history_cap`]), the vignette
//!    `(16 u(1−u) v(1−v))^¼` ([`vignette`]; the reference's factor is 15, this port uses 16 so
//!    that the image centre reaches the full 64 frames) keeping the border, where disocclusions
//!    enter, responsive.
//! 4. `count = min(count + 1/2, cap)` ([`HISTORY_GROWTH_PER_FRAME`]: linear weights while the
//!    history is young), `mean = lerp(mean, current, 1 / count)`; the blur mask is
//!    `max(8 − count, 0)` pixels ([`blur_mask_of`]), −1 for sky.
//!
//! 5. The image's trend caps the count too ([`trend_cap`]). Every pixel with a history adds its
//!    luma delta and its luminance to sums over the image ([`add_trend`]: 64-bit fixed point
//!    from integer atomics, so the sums do not depend on the order of the adds); the next frame
//!    reads their ratio, weighted by how far the deltas agree in sign ([`image_trend`]). While
//!    the whole image rises (the world cache warming up, each further bounce arriving), that is
//!    the history's lag behind its input, and the cap `max(16, count × target / |trend|)`
//!    ([`TREND_MIN_CAP`]) holds the lag toward [`TREND_LAG_TARGET`]; a sudden trend (a light
//!    switched, [`TREND_SUDDEN`]) lowers the floor of 16 toward 4. One pixel's delta cannot tell
//!    a rise from noise (a per-pixel test followed the cache's warm-up as if it were a change and doubled the relMSE
//!    of a scene offset by 10⁵: README, "Response to change"); the image's sums can, and an
//!    image whose deltas cancel (converged, or noisy) keeps its full history.
//!
//! Without [`FLAG_DENOISER_TEMPORAL`] or [`FLAG_HISTORY`], or with no accepted tap, the history
//! restarts: `mean = current`, `count = 1`, luma delta 0.
//!
//! # Buffers (per pixel, `y × W + x`, ping-ponged between frames)
//!
//! * history `[f32; 4]`: rgb mean irradiance, w = count (`≤ 0`: none);
//! * surface `[f32; 4]`: xyz world position, w = `f32::from_bits(pack_snorm10x3(normal))` (bits 0:
//!   none);
//! * luma delta `f32`; blur mask `f32` (this frame only);
//! * trend `[u32; TREND_WORDS]` ([`add_trend`]), one per image, cleared before the pass.

use glam::{UVec2, Vec2, Vec3, Vec4};

use crate::atomics::AtomicWords;
use crate::camera::CameraParams;
use crate::color::luminance;
use crate::fixed_point;
use crate::gbuffer::{PreviousPoint, ReprojectionTexel, previous_point};
use crate::math::{abs, floor, max, min, saturate, sqrt, to_i32_clamped};
use crate::packing::{pack_snorm10x3, unpack_snorm10x3};
use crate::primary_surface::primary_surface;
use crate::screen_probes::{
    FLAG_DENOISER_TEMPORAL, FLAG_HISTORY, FLAG_OBJECT_MOTION, GiFrameParams,
};

/// Smoothing of the tracked luma delta per frame.
pub const LUMA_DELTA_SMOOTHING: f32 = 1.0 / 8.0;
/// History cap when the lighting changes (`alpha = 0`).
pub const HISTORY_MIN_CAP: f32 = 4.0;
/// History cap per frame of history when the lighting holds (`alpha = 1`), up to
/// [`HISTORY_COUNT_CLAMP`] frames: `8 × 8 = 64` at most.
pub const HISTORY_CAP_PER_FRAME: f32 = 8.0;
/// The count above which the cap stops growing.
pub const HISTORY_COUNT_CLAMP: f32 = 8.0;
/// How much the count grows per frame. With `1 / 2` the new frame weighs `2 / (n + 1)` after `n`
/// frames: frame `i` weighs in proportion to `i` (linear weights) until the cap, not `1 / n` each.
/// The world cache warms up over tens of frames (each further bounce arrives through its blend),
/// and a plain average keeps every dark early frame at full weight until frame 64 (it held
/// `balanced` 2–9 points below its own cache after 64 frames); linear weights halve that lag for
/// a third less effective history (`3n / 4` samples). The cap is reached after `2 × 64` frames.
pub const HISTORY_GROWTH_PER_FRAME: f32 = 0.5;
/// The history's lag behind its input, relative, that the image's trend holds it to
/// ([`trend_cap`]).
pub const TREND_LAG_TARGET: f32 = 0.005;
/// The least count a modest trend leaves a history ([`trend_cap`]). The cap is applied every
/// frame, so while the trend stays above its target the count falls geometrically: with a floor
/// of 4 a warming Cornell box's slow orbit changed by 3.8 % from frame to frame (`gi_frame`'s
/// bound is 3 %), with 16 by 2.2 %. A change of the light still brings the count to 4 through
/// each pixel's own delta ([`history_alpha`]).
pub const TREND_MIN_CAP: f32 = 16.0;
/// The trend above which the floor [`TREND_MIN_CAP`] falls, in proportion, down to
/// [`HISTORY_MIN_CAP`] (4 frames from 4 × this trend on). A warming cache's trend peaks at a few
/// per cent (the staircase 4.5 %, the Cornell box 3.5 %; a room lit only indirectly 15.5 %, whose
/// warm-up then lags a little less); a light switched off reaches tens of per cent within ten
/// frames, and then every frame of history is lag. README, "Round 22".
pub const TREND_SUDDEN: f32 = 0.1;
/// Words of the trend buffer: three [`fixed_point`] sums (low word, high word) of the positive
/// luma deltas, of the negative ones and of the luminances, each value in reference luminances
/// ([`trend_reference`]) times [`TREND_SAMPLE_SCALE`]; the pixels counted; the reference
/// luminance (`f32` bits).
pub const TREND_WORDS: usize = 8;
/// The sums hold `value / reference / 16`: at [`fixed_point`]'s resolution of `2^-20`, steps of
/// `2^-16` reference luminances (the figures of README "Round 21" were measured with these steps).
pub const TREND_SAMPLE_SCALE: f32 = 1.0 / 16.0;
/// A pixel's delta and luminance are clamped to this many reference luminances, so that the
/// sums of `2^28` pixels (a 16384² image) stay below [`fixed_point::MAX_TOTAL`].
pub const TREND_CLAMP: f32 = 256.0;
/// The vignette's scale: `16 u(1−u) v(1−v)` is 1 at the centre (the reference uses 15).
pub const VIGNETTE_SCALE: f32 = 16.0;
/// A history tap's normal must have a dot product above this with the pixel's.
pub const HISTORY_MIN_NORMAL_DOT: f32 = 0.95;
/// The position tolerance grows up to this many cell sizes at grazing angles.
pub const HISTORY_GRAZING_CELLS: f32 = 5.0;
/// Frames of history under which a pixel is blurred (by `8 − count` pixels).
pub const BLUR_MASK_FRAMES: f32 = 8.0;
/// The blur mask of a sky pixel.
pub const BLUR_MASK_SKY: f32 = -1.0;

/// `1 / √2`: the weight of a tap falls to zero at a distance of `√2` pixels.
const INV_SQRT_2: f32 = core::f32::consts::FRAC_1_SQRT_2;

/// The weight of a history tap at `offset` pixels from the reprojected position:
/// `saturate(1 − |offset| / √2)`.
#[inline]
pub fn history_tap_weight(offset: Vec2) -> f32 {
    saturate(1.0 - offset.length() * INV_SQRT_2)
}

/// Whether a previous pixel's stored surface `previous` (`[x, y, z, normal bits]`) is the surface
/// at `position` with unit normal `normal`: within `cell × lerp(1, 5, (1 − N·V)^6)` of it (`cell`
/// the probe cell size at its distance from the eye, `V` toward the eye) and normals with a dot
/// product above [`HISTORY_MIN_NORMAL_DOT`].
#[inline]
pub fn accepts_history(
    frame: &GiFrameParams,
    position: Vec3,
    normal: Vec3,
    previous: [f32; 4],
) -> bool {
    let bits = previous[3].to_bits();
    if bits == 0 {
        return false;
    }
    let to_eye = Vec3::from_array(frame.eye) - position;
    let distance = to_eye.length();
    let cell = frame.probe_cell_size(distance);
    let n_dot_v = if distance > 0.0 {
        saturate(normal.dot(to_eye / distance))
    } else {
        1.0
    };
    let g = 1.0 - n_dot_v;
    let g2 = g * g;
    let grazing = g2 * g2 * g2;
    let tolerance = cell * (1.0 + (HISTORY_GRAZING_CELLS - 1.0) * grazing);
    let previous_position = Vec3::new(previous[0], previous[1], previous[2]);
    let previous_normal = unpack_snorm10x3(bits).normalize_or_zero();
    let close = (previous_position - position).length() < tolerance;
    close && normal.dot(previous_normal) > HISTORY_MIN_NORMAL_DOT
}

/// The float words of a [`surface_record`]: the position (the normal's bits are not a float).
pub const SURFACE_RECORD_FLOAT_WORDS: &[u32] = &[0, 1, 2];

/// The surface record a pixel leaves for the next frame: position and packed normal.
#[inline]
pub fn surface_record(position: Vec3, normal: Vec3) -> [f32; 4] {
    [
        position.x,
        position.y,
        position.z,
        f32::from_bits(pack_snorm10x3(normal)),
    ]
}

/// How much of the history to keep: `saturate(1 − |delta| / lum(history))` (1 when both are
/// zero).
#[inline]
pub fn history_alpha(luma_delta: f32, history_luma: f32) -> f32 {
    saturate(1.0 - abs(luma_delta) / max(history_luma, 1e-6))
}

/// The border vignette of `pixel` in an image of `size`: `(16 u(1−u) v(1−v))^¼` with `(u, v)` the
/// pixel centre's uv; 1 at the centre, toward 0 at the border.
#[inline]
pub fn vignette(pixel: UVec2, size: [u32; 2]) -> f32 {
    let u = (pixel.x as f32 + 0.5) / max(size[0] as f32, 1.0);
    let v = (pixel.y as f32 + 0.5) / max(size[1] as f32, 1.0);
    let x = saturate(VIGNETTE_SCALE * u * (1.0 - u) * v * (1.0 - v));
    sqrt(sqrt(x))
}

/// The history cap: `max(lerp(4, 8 × min(|count|, 8), alpha) × vignette, 1)`.
#[inline]
pub fn history_cap(count: f32, alpha: f32, vignette: f32) -> f32 {
    let full = HISTORY_CAP_PER_FRAME * min(abs(count), HISTORY_COUNT_CLAMP);
    let cap = HISTORY_MIN_CAP + (full - HISTORY_MIN_CAP) * alpha;
    max(cap * vignette, 1.0)
}

/// The blur mask of a pixel with `count` frames of history: `max(8 − count, 0)` pixels.
#[inline]
pub fn blur_mask_of(count: f32) -> f32 {
    max(BLUR_MASK_FRAMES - count, 0.0)
}

/// The luminance this frame's trend sums are in units of: the mean luminance the previous frame
/// summed (`previous`, [`TREND_WORDS`]), 1 where that is not a positive finite number. Every
/// invocation computes the same value, so the sums share it.
#[inline]
pub fn trend_reference(previous: &[u32]) -> f32 {
    if previous.len() < TREND_WORDS || previous[6] == 0 {
        return 1.0;
    }
    let reference = f32::from_bits(previous[7]);
    let mean = trend_sum(previous, 4) * reference / previous[6] as f32;
    if mean.is_finite() && mean > 1e-30 {
        mean
    } else {
        1.0
    }
}

/// The trend sum at words `lo`, `lo + 1`, in reference luminances.
#[inline]
fn trend_sum(words: &[u32], lo: usize) -> f32 {
    fixed_point::decode([words[lo], words[lo + 1]]) * (1.0 / TREND_SAMPLE_SCALE)
}

/// Adds `x / reference`, clamped to `[0, TREND_CLAMP]` (nothing when not finite), to the trend
/// sum at words `lo`, `lo + 1`.
#[inline]
fn add_to_trend_sum<W: AtomicWords + ?Sized>(words: &mut W, lo: usize, x: f32, reference: f32) {
    let r = x / reference;
    if r.is_finite() {
        let r = min(max(r, 0.0), TREND_CLAMP);
        fixed_point::atomic_add(words, lo, r * TREND_SAMPLE_SCALE);
    }
}

/// Adds pixel result `pixel`'s luma delta and luminance to the trend words `words`
/// ([`TREND_WORDS`]) in units of `reference` ([`trend_reference`]), where it had a history.
/// One invocation records the reference beside them ([`store_trend_reference`]).
#[inline]
pub fn add_trend<W: AtomicWords + ?Sized>(words: &mut W, reference: f32, pixel: &GiHistory) {
    if !pixel.has_history || words.word_count() < TREND_WORDS {
        return;
    }
    let d = pixel.luma_delta;
    if d >= 0.0 {
        add_to_trend_sum(words, 0, d, reference);
    } else {
        add_to_trend_sum(words, 2, -d, reference);
    }
    add_to_trend_sum(words, 4, pixel.luma, reference);
    words.fetch_add(6, 1);
}

/// Records the `reference` this frame's trend sums are in ([`trend_reference`]), for the next
/// frame: once per frame, by one invocation.
#[inline]
pub fn store_trend_reference<W: AtomicWords + ?Sized>(words: &mut W, reference: f32) {
    if words.word_count() >= TREND_WORDS {
        words.store(7, reference.to_bits());
    }
}

/// The image's trend from the words [`add_trend`] summed: the luma deltas' sum over the
/// luminances' sum, times how far the deltas agree in sign (`|Σ Δ| / Σ |Δ|`); 0 without any
/// luminance. A ratio of sums: a ratio per pixel would weigh a dark pixel's noise as much as a
/// lit one's, and its mean moves with the noise. The agreement: a warming image's pixels rise
/// together, while noise, whose deltas cancel, leaves a small remainder that is not a lag; a
/// history shortened for it would only be noisier.
#[inline]
pub fn image_trend(words: &[u32]) -> f32 {
    if words.len() < TREND_WORDS {
        return 0.0;
    }
    let luminance = trend_sum(words, 4);
    let (rising, falling) = (trend_sum(words, 0), trend_sum(words, 2));
    let moved = rising + falling;
    let summed = luminance > 0.0 && moved > 0.0;
    if !summed {
        return 0.0;
    }
    let net = rising - falling;
    net / luminance * (abs(net) / moved)
}

/// The count's cap from the image's `trend` for a history of `count` frames: none (`∞`) while
/// `|trend|` is within [`TREND_LAG_TARGET`], else `max(floor, count × target / |trend|)`: a lag
/// that grows with the history's length is held near the target. The floor is 16 frames
/// ([`TREND_MIN_CAP`]) up to a sudden trend ([`TREND_SUDDEN`]), then falls with `1 / |trend|`
/// to 4 ([`HISTORY_MIN_CAP`]).
#[inline]
pub fn trend_cap(count: f32, trend: f32) -> f32 {
    let t = abs(trend);
    let lagging = t > TREND_LAG_TARGET;
    if !lagging {
        return f32::INFINITY;
    }
    let floor = min(
        TREND_MIN_CAP,
        max(HISTORY_MIN_CAP, TREND_MIN_CAP * TREND_SUDDEN / t),
    );
    max(floor, abs(count) * TREND_LAG_TARGET / t)
}

/// Each component clamped to `[0, ∞)`, non-finite components zero.
#[inline]
fn clean(v: Vec3) -> Vec3 {
    let c = |x: f32| if x.is_finite() && x > 0.0 { x } else { 0.0 };
    Vec3::new(c(v.x), c(v.y), c(v.z))
}

/// What ReprojectGI writes for one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GiHistory {
    /// `[r, g, b, count]`.
    pub history: [f32; 4],
    /// `[x, y, z, normal bits]`.
    pub surface: [f32; 4],
    /// The smoothed luma delta.
    pub luma_delta: f32,
    /// The blur mask (pixels; −1 for sky).
    pub blur_mask: f32,
    /// Whether the pixel had a history: only then does it join the image's trend.
    pub has_history: bool,
    /// The luminance of its new mean.
    pub luma: f32,
}

impl GiHistory {
    /// A sky pixel: no history, no surface.
    pub const SKY: Self = Self {
        history: [0.0; 4],
        surface: [0.0; 4],
        luma_delta: 0.0,
        blur_mask: BLUR_MASK_SKY,
        has_history: false,
        luma: 0.0,
    };
}

/// The previous frame's history at a pixel, blended from the accepted taps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReprojectedHistory {
    /// Mean irradiance.
    pub mean: Vec3,
    /// Frames of history.
    pub count: f32,
    /// Smoothed luma delta.
    pub luma_delta: f32,
    /// Sum of the accepted taps' weights (0: no history).
    pub weight: f32,
}

/// The history of the surface that was at `previous_position` (unit normal `normal`), at the
/// continuous pixel position `p` of the previous image, in the previous frame's buffers: the
/// accepted 3 × 3 taps around `p`, blended by [`history_tap_weight`].
#[inline]
pub fn gather_history(
    frame: &GiFrameParams,
    p: Vec2,
    previous_position: Vec3,
    normal: Vec3,
    previous: PreviousGiHistory<'_>,
) -> ReprojectedHistory {
    let PreviousGiHistory {
        history: previous_history,
        surface: previous_surface,
        luma_delta: previous_luma_delta,
        ..
    } = previous;
    let mut out = ReprojectedHistory {
        mean: Vec3::ZERO,
        count: 0.0,
        luma_delta: 0.0,
        weight: 0.0,
    };
    let [w, h] = frame.image_size;
    let nearest_x = to_i32_clamped(floor(p.x + 0.5));
    let nearest_y = to_i32_clamped(floor(p.y + 0.5));
    let mut sum = Vec4::ZERO;
    let mut delta = 0.0;
    let mut weight = 0.0;
    let mut j = -1;
    while j <= 1 {
        let mut i = -1;
        while i <= 1 {
            let x = nearest_x.wrapping_add(i);
            let y = nearest_y.wrapping_add(j);
            if x >= 0 && y >= 0 && (x as u32) < w && (y as u32) < h {
                let t = (y as u32 * w + x as u32) as usize;
                let tw = history_tap_weight(p - Vec2::new(x as f32, y as f32));
                if tw > 0.0
                    && t < previous_history.len()
                    && t < previous_surface.len()
                    && t < previous_luma_delta.len()
                {
                    let hist = Vec4::from_array(previous_history[t]);
                    let d = previous_luma_delta[t];
                    if hist.w > 0.0
                        && hist.is_finite()
                        && d.is_finite()
                        && accepts_history(frame, previous_position, normal, previous_surface[t])
                    {
                        sum += hist * tw;
                        delta += d * tw;
                        weight += tw;
                    }
                }
            }
            i += 1;
        }
        j += 1;
    }
    if weight > 0.0 {
        let m = sum / weight;
        out.mean = clean(m.truncate());
        out.count = m.w;
        out.luma_delta = delta / weight;
        out.weight = weight;
    }
    out
}

/// The temporal update of a pixel at `pixel` with `current` irradiance and its reprojected
/// `history` (weight 0: none), under the previous frame's `image_trend` ([`image_trend`]): the
/// new history, luma delta and blur mask. `surface` is the pixel's record for the next frame.
#[inline]
pub fn accumulate(
    frame: &GiFrameParams,
    pixel: UVec2,
    current: Vec3,
    history: &ReprojectedHistory,
    surface: [f32; 4],
    image_trend: f32,
) -> GiHistory {
    let current = clean(current);
    if history.weight <= 0.0 || history.count <= 0.0 {
        return GiHistory {
            history: [current.x, current.y, current.z, 1.0],
            surface,
            luma_delta: 0.0,
            blur_mask: blur_mask_of(1.0),
            has_history: false,
            luma: 0.0,
        };
    }
    let history_luma = luminance(history.mean);
    // The weight of `current` must not depend on `current` (module doc, step 3).
    let alpha = history_alpha(history.luma_delta, history_luma);
    let delta = history.luma_delta
        + (luminance(current) - history_luma - history.luma_delta) * LUMA_DELTA_SMOOTHING;
    let cap = min(
        history_cap(history.count, alpha, vignette(pixel, frame.image_size)),
        trend_cap(history.count, image_trend),
    );
    let count = min(history.count + HISTORY_GROWTH_PER_FRAME, cap);
    let mean = history.mean + (current - history.mean) * (1.0 / count);
    let delta = if delta.is_finite() { delta } else { 0.0 };
    GiHistory {
        history: [mean.x, mean.y, mean.z, count],
        surface,
        luma_delta: delta,
        blur_mask: blur_mask_of(count),
        has_history: true,
        luma: luminance(mean),
    }
}

/// The previous frame's denoiser history, as ReprojectGI reads it.
#[derive(Clone, Copy, Debug)]
pub struct PreviousGiHistory<'a> {
    /// `[r, g, b, count]` per pixel.
    pub history: &'a [[f32; 4]],
    /// The pixels' surface records ([`surface_record`]).
    pub surface: &'a [[f32; 4]],
    /// The pixels' smoothed luminance change.
    pub luma_delta: &'a [f32],
    /// The previous frame's trend words ([`TREND_WORDS`]).
    pub trend: &'a [u32],
}

/// ReprojectGI for one pixel: `texel` is its G-buffer, `current` this frame's interpolated
/// `[r, g, b, hint]`, `previous` the previous frame's history.
#[inline]
pub fn reproject_gi_pixel(
    frame: &GiFrameParams,
    camera: &CameraParams,
    pixel: UVec2,
    texel: ReprojectionTexel,
    current: [f32; 4],
    previous: PreviousGiHistory<'_>,
) -> GiHistory {
    let ReprojectionTexel {
        depth,
        geometric_normal,
        motion,
    } = texel;
    let surface = primary_surface(camera, pixel, depth, geometric_normal, geometric_normal);
    if !surface.valid {
        return GiHistory::SKY;
    }
    let n = surface.geometric_normal;
    let record = surface_record(surface.position, n);
    let point = if frame.has(FLAG_DENOISER_TEMPORAL | FLAG_HISTORY) {
        previous_point(
            camera,
            pixel,
            surface.position,
            motion,
            frame.has(FLAG_OBJECT_MOTION),
        )
    } else {
        PreviousPoint::NONE
    };
    let history = if point.valid {
        gather_history(frame, point.pixel_position, point.position, n, previous)
    } else {
        ReprojectedHistory {
            mean: Vec3::ZERO,
            count: 0.0,
            luma_delta: 0.0,
            weight: 0.0,
        }
    };
    accumulate(
        frame,
        pixel,
        Vec3::new(current[0], current[1], current[2]),
        &history,
        record,
        image_trend(previous.trend),
    )
}

/// The whole pass on the CPU: every pixel of the G-buffer (`gbuffer(i)` for pixel `i`, row by
/// row) reprojected from `previous` into `out`, its trend added to `trend` (cleared before).
pub fn reproject_gi_image(
    frame: &GiFrameParams,
    camera: &CameraParams,
    gbuffer: impl Fn(usize) -> ReprojectionTexel,
    irradiance: &[[f32; 4]],
    previous: PreviousGiHistory<'_>,
    out: &mut [GiHistory],
    trend: &mut [u32],
) {
    let [w, h] = frame.image_size;
    let reference = trend_reference(previous.trend);
    store_trend_reference(trend, reference);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            out[i] = reproject_gi_pixel(
                frame,
                camera,
                UVec2::new(x, y),
                gbuffer(i),
                irradiance[i],
                previous,
            );
            add_trend(trend, reference, &out[i]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{primary_ray, view_projection};
    use crate::random::Random;

    const W: u32 = 32;
    const H: u32 = 24;
    /// Pixels of the test image, and the index of a pixel near its centre.
    const N: usize = (W * H) as usize;
    const CENTRE: usize = (12 * W + 16) as usize;

    fn camera() -> CameraParams {
        CameraParams::new(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z, Vec3::Y, 0.8, W, H)
    }

    /// The host's screen-probe cell constant for this camera: about 8 pixels' angle.
    const CELL_CONST: f32 = 0.8 * 8.0 / H as f32;

    fn frame(flags: u32) -> GiFrameParams {
        GiFrameParams {
            image_size: [W, H],
            eye: [0.0, 0.0, 5.0],
            probe_cell_const: CELL_CONST,
            flags,
            ..Default::default()
        }
    }

    /// A wall at z = 0 seen by `c`; sky where `sky(x, y)`.
    fn wall(c: &CameraParams, sky: impl Fn(u32, u32) -> bool) -> (Vec<f32>, Vec<Vec4>) {
        let mut depth = Vec::new();
        let mut normals = Vec::new();
        for y in 0..H {
            for x in 0..W {
                if sky(x, y) {
                    depth.push(0.0);
                    normals.push(Vec4::ZERO);
                    continue;
                }
                let ray = primary_ray(c, UVec2::new(x, y), c.jitter());
                let d = Vec3::from_array(ray.direction);
                let t = c.position().z / -d.z;
                depth.push(t * d.dot(c.forward()));
                normals.push(Vec4::new(0.0, 0.0, 1.0, 1.0));
            }
        }
        (depth, normals)
    }

    /// The test camera, a frame with the temporal history on, and a wall without sky.
    fn temporal_wall() -> (CameraParams, GiFrameParams, (Vec<f32>, Vec<Vec4>)) {
        let c = camera();
        let g = wall(&c, |_, _| false);
        (c, frame(FLAG_DENOISER_TEMPORAL | FLAG_HISTORY), g)
    }

    struct Buffers {
        history: Vec<[f32; 4]>,
        surface: Vec<[f32; 4]>,
        delta: Vec<f32>,
        mask: Vec<f32>,
        trend: [u32; TREND_WORDS],
    }

    impl Buffers {
        fn new() -> Self {
            Self {
                history: vec![[0.0; 4]; N],
                surface: vec![[0.0; 4]; N],
                delta: vec![0.0; N],
                mask: vec![0.0; N],
                trend: [0; TREND_WORDS],
            }
        }
    }

    fn step(
        f: &GiFrameParams,
        c: &CameraParams,
        g: &(Vec<f32>, Vec<Vec4>),
        input: &[[f32; 4]],
        prev: &Buffers,
    ) -> Buffers {
        let mut out = vec![GiHistory::SKY; input.len()];
        // No motion texels: the camera reprojects.
        let gbuffer = |i: usize| ReprojectionTexel {
            depth: g.0[i],
            geometric_normal: g.1[i],
            motion: Vec4::ZERO,
        };
        let previous = PreviousGiHistory {
            history: &prev.history,
            surface: &prev.surface,
            luma_delta: &prev.delta,
            trend: &prev.trend,
        };
        let mut next = Buffers::new();
        reproject_gi_image(f, c, gbuffer, input, previous, &mut out, &mut next.trend);
        for (i, r) in out.iter().enumerate() {
            next.history[i] = r.history;
            next.surface[i] = r.surface;
            next.delta[i] = r.luma_delta;
            next.mask[i] = r.blur_mask;
        }
        next
    }

    #[test]
    fn the_cap_grows_to_64_in_the_centre_and_less_at_the_border() {
        assert_eq!(history_cap(1.0, 1.0, 1.0), 8.0);
        assert_eq!(history_cap(20.0, 1.0, 1.0), 64.0);
        assert_eq!(history_cap(20.0, 0.0, 1.0), 4.0);
        assert_eq!(history_cap(20.0, 0.5, 1.0), 34.0);
        assert_eq!(history_cap(20.0, 1.0, 0.0), 1.0);
        assert!((vignette(UVec2::new(15, 11), [31, 23]) - 1.0).abs() < 1e-6);
        assert!(vignette(UVec2::new(0, 0), [W, H]) < 0.3);
        assert_eq!(blur_mask_of(1.0), 7.0);
        assert_eq!(blur_mask_of(30.0), 0.0);
        assert_eq!(history_alpha(0.0, 0.0), 1.0);
        assert_eq!(history_alpha(0.5, 1.0), 0.5);
        assert_eq!(history_alpha(-2.0, 1.0), 0.0);
    }

    /// A static pixel: its history grows to the cap (64 × vignette) and its mean converges to the
    /// input's mean; the border's cap is lower; sky stays sky.
    #[test]
    fn a_static_history_grows_to_the_cap_and_converges() {
        let c = camera();
        let f = frame(FLAG_DENOISER_TEMPORAL | FLAG_HISTORY);
        let g = wall(&c, |x, y| x == 31 && y == 0);
        let corner = 0usize;
        // Constant input: the count climbs to the cap.
        let input = vec![[2.0, 1.0, 0.5, 1.0]; N];
        let mut b = Buffers::new();
        for frame_index in 0..200 {
            b = step(&f, &c, &g, &input, &b);
            if frame_index == 0 {
                assert_eq!(b.history[CENTRE][3], 1.0);
                assert_eq!(b.mask[CENTRE], 7.0);
            }
        }
        let cap_centre = 64.0 * vignette(UVec2::new(16, 12), [W, H]);
        let cap_corner = history_cap(64.0, 1.0, vignette(UVec2::new(0, 0), [W, H]));
        assert!(
            (b.history[CENTRE][3] - cap_centre).abs() < 1e-3,
            "{:?}",
            b.history[CENTRE]
        );
        assert!(cap_centre > 60.0);
        assert!(
            (b.history[corner][3] - cap_corner).abs() < 1e-3,
            "{:?}",
            b.history[corner]
        );
        assert!(cap_corner < 0.5 * cap_centre);
        assert_eq!(b.mask[CENTRE], 0.0);
        assert_eq!(&b.history[CENTRE][..3], &[2.0, 1.0, 0.5]);
        assert_eq!(b.mask[31], BLUR_MASK_SKY);
        assert_eq!(b.history[31], [0.0; 4]);
        assert_eq!(b.surface[31][3].to_bits(), 0);
        // Noisy input of mean 1 (±25 %): the mean converges to it.
        let mut rng = Random::new(3, 0);
        let mut b = Buffers::new();
        let mut late = 0.0f64;
        let mut late_n = 0;
        for frame_index in 0..600 {
            let input: Vec<[f32; 4]> = (0..N)
                .map(|_| {
                    let v = 0.75 + 0.5 * rng.next_f32();
                    [v, v, v, 1.0]
                })
                .collect();
            b = step(&f, &c, &g, &input, &b);
            if frame_index >= 200 {
                late += f64::from(b.history[CENTRE][0]);
                late_n += 1;
            }
        }
        let late = late / f64::from(late_n);
        assert!((late - 1.0).abs() < 0.01, "{late}");
        assert!((b.history[CENTRE][0] - 1.0).abs() < 0.05);
        // The noise keeps alpha below 1, but the history stays long.
        assert!(b.history[CENTRE][3] > 32.0, "{:?}", b.history[CENTRE]);
    }

    /// The cache's further bounces arriving over tens of frames: a warming input.
    fn warming(t: usize) -> f32 {
        1.0 - 0.5 * (-(t as f32) / 15.0).exp()
    }

    #[test]
    fn the_trend_sums_carry_and_ignore_what_is_not_finite() {
        let pixel = |delta: f32, luma: f32| GiHistory {
            has_history: true,
            luma_delta: delta,
            luma,
            ..GiHistory::SKY
        };
        let mut words = [0u32; TREND_WORDS];
        store_trend_reference(&mut words[..], 1.0);
        // Sums past 2^32 units carry into the high word, in any order.
        for i in 0..600 {
            add_trend(
                &mut words[..],
                1.0,
                &pixel(if i % 3 == 0 { -1.0 } else { 2.0 }, 200.0),
            );
        }
        assert_eq!(words[6], 600);
        assert!(words[5] > 0, "the luminance sum carried: {words:?}");
        let mut reversed = [0u32; TREND_WORDS];
        store_trend_reference(&mut reversed[..], 1.0);
        for i in (0..600).rev() {
            add_trend(
                &mut reversed[..],
                1.0,
                &pixel(if i % 3 == 0 { -1.0 } else { 2.0 }, 200.0),
            );
        }
        assert_eq!(words, reversed);
        // (400 × 2 − 200 × 1) / (600 × 200), times the agreement 600 / 1000.
        assert!((image_trend(&words) - 0.6 * 600.0 / 120_000.0).abs() < 1e-6);
        // The next frame's reference is this frame's mean luminance.
        assert_eq!(trend_reference(&words), 200.0);
        // Not finite: no delta, no luminance; the sky is not counted; beyond the clamp, clamped.
        let mut words = [0u32; TREND_WORDS];
        add_trend(&mut words[..], 1.0, &pixel(f32::NAN, f32::INFINITY));
        add_trend(&mut words[..], 1.0, &GiHistory::SKY);
        assert_eq!(words[6], 1);
        assert_eq!(image_trend(&words), 0.0);
        assert_eq!(trend_reference(&words), 1.0);
        add_trend(&mut words[..], 1.0, &pixel(-1e30, 1e30));
        assert_eq!(image_trend(&words), -1.0);
        // A tiny image (1e-30) keeps its trend: the reference follows it.
        let mut tiny = [0u32; TREND_WORDS];
        add_trend(&mut tiny[..], 1e-30, &pixel(1e-32, 1e-30));
        assert!((image_trend(&tiny) - 0.01).abs() < 1e-4);
        assert_eq!(image_trend(&[0; TREND_WORDS]), 0.0);
        assert_eq!(trend_reference(&[0; TREND_WORDS]), 1.0);
        // Within the target, no cap; beyond, the count scaled down to the target, at least 16
        // up to a sudden trend, then at least 16 × sudden / |trend|, and 4.
        assert_eq!(trend_cap(40.0, 0.5 * TREND_LAG_TARGET), f32::INFINITY);
        assert_eq!(trend_cap(40.0, f32::NAN), f32::INFINITY);
        assert_eq!(trend_cap(80.0, -4.0 * TREND_LAG_TARGET), 20.0);
        assert_eq!(trend_cap(40.0, TREND_SUDDEN), TREND_MIN_CAP);
        assert_eq!(trend_cap(40.0, -2.0 * TREND_SUDDEN), 0.5 * TREND_MIN_CAP);
        assert_eq!(trend_cap(40.0, 1.0), HISTORY_MIN_CAP);
        assert_eq!(trend_cap(40.0, f32::INFINITY), HISTORY_MIN_CAP);
    }

    /// A warming input is followed with linear weights (here without the image's trend): after
    /// 64 frames the history lags behind by about half of what a plain average of the 64 frames
    /// would.
    #[test]
    fn a_warming_input_is_followed_with_linear_weights() {
        let (c, f, g) = temporal_wall();
        let mut b = Buffers::new();
        let mut plain = 0.0;
        for t in 0..64 {
            b.trend = [0; TREND_WORDS];
            b = step(&f, &c, &g, &vec![[warming(t); 4]; N], &b);
            plain += warming(t) / 64.0;
        }
        let lag = warming(63) - b.history[CENTRE][0];
        let plain_lag = warming(63) - plain;
        assert!(
            lag > 0.0 && lag < 0.5 * plain_lag,
            "{lag} against {plain_lag}"
        );
        assert!((b.history[CENTRE][3] - 32.5).abs() < 1e-4);
    }

    /// With the image's trend, a warming image's history is shortened toward
    /// [`TREND_MIN_CAP`] frames, and its lag behind the input falls well below the linear
    /// weights'; it grows back once the input holds.
    #[test]
    fn the_image_trend_shortens_a_warming_image_s_lag() {
        let (c, f, g) = temporal_wall();
        let mut b = Buffers::new();
        let mut linear = Buffers::new();
        for t in 0..64 {
            b = step(&f, &c, &g, &vec![[warming(t); 4]; N], &b);
            linear.trend = [0; TREND_WORDS];
            linear = step(&f, &c, &g, &vec![[warming(t); 4]; N], &linear);
        }
        let lag = |b: &Buffers| (warming(63) - b.history[CENTRE][0]) / warming(63);
        let count = b.history[CENTRE][3];
        // 2.7 % against 4.6 %.
        assert!(
            lag(&b) > 0.0 && lag(&b) < 0.6 * lag(&linear),
            "{} against {}",
            lag(&b),
            lag(&linear)
        );
        assert!(lag(&linear) > 3.0 * TREND_LAG_TARGET, "{}", lag(&linear));
        assert!((TREND_MIN_CAP..32.5).contains(&count), "{count}");
        // The input holds: the trend falls within its target and the history grows again.
        for _ in 0..64 {
            b = step(&f, &c, &g, &vec![[warming(200); 4]; N], &b);
        }
        assert!(
            b.history[CENTRE][3] > count + 8.0,
            "{:?}",
            b.history[CENTRE]
        );
    }

    /// A lasting change of the lighting shortens the history: the mean follows within a few
    /// frames, not 64.
    #[test]
    fn a_lighting_change_shortens_the_history() {
        let (c, f, g) = temporal_wall();
        let mut b = Buffers::new();
        for _ in 0..100 {
            b = step(&f, &c, &g, &vec![[1.0, 1.0, 1.0, 1.0]; N], &b);
        }
        for _ in 0..16 {
            b = step(&f, &c, &g, &vec![[4.0, 4.0, 4.0, 1.0]; N], &b);
        }
        // A fixed 64-frame average would be at 1 + 3 × (1 − (63/64)^16) ≈ 1.67.
        assert!(b.history[CENTRE][0] > 2.5, "{:?}", b.history[CENTRE]);
        assert!(b.history[CENTRE][3] < 32.0);
    }

    /// Rare bright samples (16 with probability 1/16, else 0: mean 1, as a light sample that
    /// seldom finds a small emitter) keep their mean: the history's weight of a sample does not
    /// look at the sample. With the cap taken from the delta that included the sample, the mean
    /// read 1.55.
    #[test]
    fn rare_bright_samples_keep_their_mean() {
        let (c, f, g) = temporal_wall();
        let mut rng = Random::new(3, 0);
        let mut b = Buffers::new();
        let (mut sum, mut count) = (0.0f64, 0u32);
        for frame in 0..600 {
            let input: Vec<[f32; 4]> = (0..N)
                .map(|_| {
                    let v = if rng.next_f32() < 1.0 / 16.0 {
                        16.0
                    } else {
                        0.0
                    };
                    [v, v, v, 1.0]
                })
                .collect();
            b = step(&f, &c, &g, &input, &b);
            if frame >= 100 {
                sum += b.history.iter().map(|h| f64::from(h[0])).sum::<f64>();
                count += N as u32;
            }
        }
        let mean = sum / f64::from(count);
        assert!((mean - 1.0).abs() < 0.03, "{mean}");
    }

    /// Temporal off, no history flag, or a camera move that disoccludes: the history restarts.
    #[test]
    fn history_restarts_without_temporal_or_a_match() {
        let c = camera();
        let g = wall(&c, |_, _| false);
        let input = vec![[1.0, 1.0, 1.0, 1.0]; N];
        for flags in [
            FLAG_HISTORY,
            FLAG_DENOISER_TEMPORAL,
            FLAG_DENOISER_TEMPORAL | FLAG_HISTORY,
        ] {
            let f = frame(flags);
            let mut b = Buffers::new();
            for _ in 0..10 {
                b = step(&f, &c, &g, &input, &b);
            }
            let expected = if flags == FLAG_DENOISER_TEMPORAL | FLAG_HISTORY {
                1.0 + 9.0 * HISTORY_GROWTH_PER_FRAME
            } else {
                1.0
            };
            assert!(
                (b.history[CENTRE][3] - expected).abs() < 1e-4,
                "flags {flags}"
            );
        }
        // The eye moves 3 units toward the wall (the same depths: a new surface 3 units in front
        // of the old one, more than the 1.35 tolerance): nothing is accepted.
        let f = frame(FLAG_DENOISER_TEMPORAL | FLAG_HISTORY);
        let mut b = Buffers::new();
        for _ in 0..10 {
            b = step(&f, &c, &g, &input, &b);
        }
        let mut near = c;
        near.position = [0.0, 0.0, 2.0];
        near.view_proj = view_projection(&near);
        near.previous_view_proj = c.view_proj;
        let f_near = GiFrameParams {
            eye: [0.0, 0.0, 2.0],
            ..f
        };
        let b2 = step(&f_near, &near, &g, &input, &b);
        assert_eq!(b2.history[CENTRE][3], 1.0);
        assert_eq!(b2.mask[CENTRE], 7.0);
    }

    /// A camera that pans by a pixel finds its history through the sub-pixel taps.
    #[test]
    fn a_panning_camera_keeps_its_history() {
        let (c, f, g) = temporal_wall();
        let input = vec![[1.0, 1.0, 1.0, 1.0]; N];
        let mut b = Buffers::new();
        for _ in 0..10 {
            b = step(&f, &c, &g, &input, &b);
        }
        // Move right by 0.7 pixels' worth at the wall.
        let pixel_size = 2.0 * 5.0 * c.tan_half_fov_y / H as f32;
        let mut moved = c;
        moved.position = [0.7 * pixel_size, 0.0, 5.0];
        moved.view_proj = view_projection(&moved);
        moved.previous_view_proj = c.view_proj;
        let f2 = GiFrameParams {
            eye: moved.position,
            ..f
        };
        let g2 = wall(&moved, |_, _| false);
        let b2 = step(&f2, &moved, &g2, &input, &b);
        assert!(
            (b2.history[CENTRE][3] - (1.0 + 10.0 * HISTORY_GROWTH_PER_FRAME)).abs() < 1e-3,
            "{:?}",
            b2.history[CENTRE]
        );
        // The rightmost column came from off screen on the right: restarts.
        let edge = (12 * W + 31) as usize;
        assert!(b2.history[edge][3] < 1.0 + 10.0 * HISTORY_GROWTH_PER_FRAME);
    }

    #[test]
    fn history_taps_need_surface_and_normal() {
        let f = GiFrameParams {
            probe_cell_const: 0.01,
            ..frame(0)
        };
        let p = Vec3::new(0.0, 0.0, 0.0);
        // Cell 0.05 at distance 5, facing the eye: tolerance 0.05.
        assert!(accepts_history(
            &f,
            p,
            Vec3::Z,
            surface_record(p + Vec3::X * 0.04, Vec3::Z)
        ));
        assert!(!accepts_history(
            &f,
            p,
            Vec3::Z,
            surface_record(p + Vec3::X * 0.06, Vec3::Z)
        ));
        let tilted = Vec3::new(0.4, 0.0, 1.0).normalize();
        assert!(!accepts_history(&f, p, Vec3::Z, surface_record(p, tilted)));
        assert!(!accepts_history(&f, p, Vec3::Z, [0.0; 4]));
        // Grazing: up to 5 cells.
        let grazing = Vec3::new(0.0, 1.0, 0.0);
        assert!(accepts_history(
            &f,
            p,
            grazing,
            surface_record(p + Vec3::X * 0.2, grazing)
        ));
        assert!(!accepts_history(
            &f,
            p,
            grazing,
            surface_record(p + Vec3::X * 0.3, grazing)
        ));
        assert_eq!(history_tap_weight(Vec2::ZERO), 1.0);
        assert!(history_tap_weight(Vec2::new(1.0, 1.0)) < 1e-6);
        assert_eq!(history_tap_weight(Vec2::new(1.0, 1.5)), 0.0);
        assert!((history_tap_weight(Vec2::new(0.5, 0.0)) - (1.0 - 0.5 / 2f32.sqrt())).abs() < 1e-6);
    }
}
