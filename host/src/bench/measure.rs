//! One measured run: a GI renderer with given settings renders a number of frames along a camera
//! path; the GPU time of every frame and pass, the memory it holds, the last frame's error
//! against the reference, the error after every frame, and the frame-to-frame change.

use super::{LoadedScene, Motion};
use crate::error::Result;
use crate::frame::MemoryTable;
use crate::gi::GiSettings;
use crate::gi::renderer::GiRenderer;
use crate::image_io::HdrImage;
use crate::metrics::{self, CompareSettings};
use crate::vulkan::{Context, FrameTimings};
use gi_shared::color::luminance;
use serde::{Deserialize, Serialize};

/// Frames at the end of a run over which the frame-to-frame change is averaged.
pub const CHANGE_FRAMES: u32 = 16;
/// Frames at the start of a run left out of its times: drivers compile kernels at their first
/// dispatch (lavapipe's first frame takes seconds).
pub const WARMUP_FRAMES: u32 = 2;

/// What to render.
#[derive(Clone, Copy, Debug)]
pub struct RunSpec {
    /// The GI settings.
    pub settings: GiSettings,
    /// Rendered width (the error is taken at the reference's size).
    pub width: u32,
    /// Rendered height.
    pub height: u32,
    /// The camera path.
    pub motion: Motion,
    /// Frames rendered; the last one is compared.
    pub frames: u32,
}

/// GPU time of one pass, averaged over the frames that ran it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PassMs {
    /// The pass (the talk's name).
    pub pass: String,
    /// Milliseconds.
    pub ms: f64,
}

/// What a run measured.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct RunResult {
    /// GPU milliseconds per frame, mean over the frames after [`WARMUP_FRAMES`].
    pub ms_mean: f64,
    /// GPU milliseconds per frame, 95th percentile.
    pub ms_p95: f64,
    /// Per pass, over the same frames.
    pub passes: Vec<PassMs>,
    /// Device memory the GI frame's resources hold (the scene's not counted).
    pub gi_bytes: u64,
    /// relMSE of the last frame against the reference.
    pub relmse: f64,
    /// Mean LDR-FLIP of the last frame against the reference.
    pub flip: f64,
    /// The last frame's mean over the reference's, minus one.
    pub mean_bias: f64,
    /// Mean absolute luminance change between consecutive frames over their mean luminance,
    /// averaged over the last [`CHANGE_FRAMES`] frames: flicker when the camera is still; under
    /// motion it also holds the view's real change, so compare it between points only.
    pub temporal_change: f64,
    /// relMSE against the reference after each frame (the static path's convergence curve).
    pub relmse_per_frame: Vec<f64>,
}

/// Renders `spec` on `scene` and compares it with `reference`.
pub fn run_gi(
    ctx: &Context,
    scene: &LoadedScene,
    spec: &RunSpec,
    reference: &HdrImage,
) -> Result<RunResult> {
    let before = MemoryTable::of(ctx).total_bytes();
    let mut gi = GiRenderer::new(
        ctx,
        &scene.lights,
        spec.width,
        spec.height,
        spec.settings,
        scene.options,
    )?;
    let gi_bytes = MemoryTable::of(ctx).total_bytes().saturating_sub(before);
    let mut times = FrameTimes::default();
    // Short runs keep at least their last frame's time.
    let warmup = WARMUP_FRAMES.min(spec.frames - 1);
    let mut relmse_per_frame = Vec::with_capacity(spec.frames as usize);
    let mut changes = Vec::new();
    let mut previous: Option<HdrImage> = None;
    let change_from = spec.frames.saturating_sub(CHANGE_FRAMES + 1);
    for f in 0..spec.frames {
        let camera = scene.camera_at(spec.motion, f, spec.width, spec.height);
        gi.render_frame(ctx, &scene.gpu, &camera)?;
        if f >= warmup {
            times.add(gi.timings());
        }
        let image = resample(&gi.image(ctx)?, reference.width(), reference.height())?;
        relmse_per_frame.push(metrics::relative_mse(reference, &image)?);
        if f >= change_from {
            if let Some(p) = &previous {
                changes.push(relative_change(p, &image));
            }
            previous = Some(image);
        }
    }
    let last = previous.unwrap_or(reference.clone());
    let compared = metrics::compare(reference, &last, &CompareSettings::default())?.metrics;
    Ok(RunResult {
        ms_mean: times.mean_ms(),
        ms_p95: percentile(&times.frame_ms, 0.95),
        passes: times.passes(),
        gi_bytes,
        relmse: compared.relative_mse,
        flip: compared.flip,
        mean_bias: compared.mean_bias,
        temporal_change: mean(&changes),
        relmse_per_frame,
    })
}

/// The GPU times of the frames a run times.
#[derive(Clone, Debug, Default)]
pub struct FrameTimes {
    /// Each frame's total, in milliseconds.
    pub frame_ms: Vec<f64>,
    /// Each pass's time summed over the frames.
    pass_sums: Vec<PassMs>,
}

impl FrameTimes {
    /// Adds the last frame of `timings`.
    pub fn add(&mut self, timings: &FrameTimings) {
        self.frame_ms.push(timings.last_total_ms());
        for p in timings.passes() {
            match self.pass_sums.iter_mut().find(|q| q.pass == p.name) {
                Some(q) => q.ms += p.last_ms,
                None => self.pass_sums.push(PassMs {
                    pass: p.name.clone(),
                    ms: p.last_ms,
                }),
            }
        }
    }

    /// Mean milliseconds per frame.
    pub fn mean_ms(&self) -> f64 {
        mean(&self.frame_ms)
    }

    /// Mean milliseconds per frame of each pass.
    pub fn passes(&self) -> Vec<PassMs> {
        let n = self.frame_ms.len().max(1) as f64;
        self.pass_sums
            .iter()
            .map(|p| PassMs {
                pass: p.pass.clone(),
                ms: p.ms / n,
            })
            .collect()
    }
}

/// The `q`-quantile (nearest rank) of `values`; 0 for none.
pub fn percentile(values: &[f64], q: f64) -> f64 {
    let mut sorted: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if sorted.is_empty() {
        return 0.0;
    }
    sorted.sort_by(f64::total_cmp);
    let rank = (q.clamp(0.0, 1.0) * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

fn mean(values: &[f64]) -> f64 {
    if values.is_empty() {
        0.0
    } else {
        values.iter().sum::<f64>() / values.len() as f64
    }
}

/// Mean `|Y(b) − Y(a)|` over mean `Y(b)` (non-finite pixels skipped); 0 for a black image.
pub fn relative_change(a: &HdrImage, b: &HdrImage) -> f64 {
    let (mut diff, mut sum) = (0.0, 0.0);
    for (&pa, &pb) in a.pixels().iter().zip(b.pixels()) {
        let y = |rgb: [f32; 3]| f64::from(luminance(glam::Vec3::from_array(rgb)));
        let (ya, yb) = (y(pa), y(pb));
        if ya.is_finite() && yb.is_finite() {
            diff += (yb - ya).abs();
            sum += yb.abs();
        }
    }
    if sum > 0.0 { diff / sum } else { 0.0 }
}

/// `image` at `width × height`: itself when the size matches; when downscaling, each target
/// pixel the mean of the source pixels whose centres fall in its footprint; otherwise the
/// bilinear sample at its centre.
pub fn resample(image: &HdrImage, width: u32, height: u32) -> Result<HdrImage> {
    if (image.width(), image.height()) == (width, height) {
        return Ok(image.clone());
    }
    let (sx, sy) = (
        image.width() as f32 / width as f32,
        image.height() as f32 / height as f32,
    );
    let downscale = sx >= 1.0 && sy >= 1.0;
    let mut pixels = Vec::with_capacity(width as usize * height as usize);
    for y in 0..height {
        for x in 0..width {
            let (x0, x1) = (x as f32 * sx, (x + 1) as f32 * sx);
            let (y0, y1) = (y as f32 * sy, (y + 1) as f32 * sy);
            let xs =
                (x0 - 0.5).ceil().max(0.0) as u32..((x1 - 0.5).ceil() as u32).min(image.width());
            let ys =
                (y0 - 0.5).ceil().max(0.0) as u32..((y1 - 0.5).ceil() as u32).min(image.height());
            let mut sum = [0.0f32; 3];
            let mut n = 0;
            for py in ys.clone() {
                for px in xs.clone() {
                    let p = image.pixel(px, py);
                    (0..3).for_each(|c| sum[c] += p[c]);
                    n += 1;
                }
            }
            pixels.push(if n > 0 && downscale {
                sum.map(|s| s / n as f32)
            } else {
                bilinear(image, 0.5 * (x0 + x1), 0.5 * (y0 + y1))
            });
        }
    }
    HdrImage::from_pixels(width, height, pixels)
}

/// The bilinear sample of `image` at continuous pixel coordinates `(x, y)` (pixel centres at
/// half-integers), clamped at the edges.
fn bilinear(image: &HdrImage, x: f32, y: f32) -> [f32; 3] {
    let (w, h) = (image.width() as f32, image.height() as f32);
    let (fx, fy) = ((x - 0.5).clamp(0.0, w - 1.0), (y - 0.5).clamp(0.0, h - 1.0));
    let (ix, iy) = (fx.floor() as u32, fy.floor() as u32);
    let (tx, ty) = (fx - ix as f32, fy - iy as f32);
    let (jx, jy) = (
        (ix + 1).min(image.width() - 1),
        (iy + 1).min(image.height() - 1),
    );
    let [a, b, c, d] = [
        image.pixel(ix, iy),
        image.pixel(jx, iy),
        image.pixel(ix, jy),
        image.pixel(jx, jy),
    ];
    std::array::from_fn(|i| {
        (a[i] * (1.0 - tx) + b[i] * tx) * (1.0 - ty) + (c[i] * (1.0 - tx) + d[i] * tx) * ty
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> f32) -> HdrImage {
        let pixels = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| [f(x, y); 3])
            .collect();
        HdrImage::from_pixels(w, h, pixels).unwrap()
    }

    #[test]
    fn resampling_averages_down_and_interpolates_up() {
        let fine = image(4, 2, |x, _| x as f32);
        let coarse = resample(&fine, 2, 1).unwrap();
        assert_eq!(coarse.pixels(), &[[0.5; 3], [2.5; 3]]);
        let up = resample(&image(2, 1, |x, _| 2.0 * x as f32), 4, 1).unwrap();
        // Centres at 0.25 and 0.75 of the first source pixel's span: clamped, then halfway.
        let v: Vec<f32> = up.pixels().iter().map(|p| p[0]).collect();
        assert_eq!(v, [0.0, 0.5, 1.5, 2.0]);
        let same = image(3, 3, |x, y| (x * y) as f32);
        assert_eq!(resample(&same, 3, 3).unwrap().pixels(), same.pixels());
    }

    #[test]
    fn percentiles_and_change() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 0.95), 95.0);
        assert_eq!(percentile(&v, 1.0), 100.0);
        assert_eq!(percentile(&[f64::NAN, 3.0], 0.5), 3.0);
        assert_eq!(percentile(&[], 0.5), 0.0);
        let a = image(2, 2, |_, _| 1.0);
        let b = image(2, 2, |x, _| if x == 0 { 1.0 } else { 2.0 });
        assert!((relative_change(&a, &b) - 2.0 / 6.0).abs() < 1e-9);
        assert_eq!(relative_change(&a, &a), 0.0);
        let black = image(2, 2, |_, _| 0.0);
        assert_eq!(relative_change(&black, &black), 0.0);
    }
}
