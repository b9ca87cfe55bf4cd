//! Distances between a test image and a reference image of the same size, and a heat map of
//! where they differ.
//!
//! Two kinds of measure, with different inputs:
//! - On linear values: [`rmse`] and [`relative_mse`]. They see every value as rendered, so a NaN
//!   or infinity in either image makes them NaN or infinite; [`Metrics::non_finite`] counts the
//!   pixels responsible.
//! - On the displayed image, i.e. what [`HdrImage::write_png`] shows through the same
//!   [`ToneMap`]: [`psnr`] and [`flip`]. A NaN pixel counts as [`NAN_COLOUR`] there.
//!
//! FLIP is LDR-FLIP (Andersson et al. 2020) from NVIDIA's implementation through the `nv-flip`
//! crate, on both images tone-mapped at one fixed exposure and quantised to 8-bit sRGB. It is not
//! HDR-FLIP's sweep over exposures: pick the exposure at which the images are looked at.

use crate::image_io::{HdrImage, NAN_COLOUR, ToneMap};
use crate::{Error, Result};
use std::fmt;
use std::path::Path;

/// The `eps` of [`relative_mse`]: it keeps near-black reference pixels from dominating.
pub const RELATIVE_MSE_EPSILON: f64 = 1e-2;

/// How the displayed-image measures ([`psnr`], [`flip`]) see the images.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompareSettings {
    /// The tone map from linear values to the displayed image.
    pub tone: ToneMap,
    /// FLIP's viewing condition: pixels per degree of visual angle (see
    /// [`nv_flip::pixels_per_degree`]); more pixels per degree hides finer differences.
    pub pixels_per_degree: f32,
}

impl Default for CompareSettings {
    /// [`ToneMap::default`] (exposure 0, ACES) and FLIP's default 67 pixels per degree (a 0.7 m
    /// wide 4K monitor seen from 0.7 m).
    fn default() -> Self {
        Self {
            tone: ToneMap::default(),
            pixels_per_degree: nv_flip::DEFAULT_PIXELS_PER_DEGREE,
        }
    }
}

/// Every measure between a test image and its reference; its `Display` is one line for reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    /// See [`rmse`].
    pub rmse: f64,
    /// See [`relative_mse`].
    pub relative_mse: f64,
    /// See [`psnr`]; `+inf` for identical displayed images.
    pub psnr: f64,
    /// Mean LDR-FLIP error in `[0, 1]`: see [`flip`].
    pub flip: f64,
    /// The test image's mean over the reference's, minus one (finite pixels): a light path
    /// counted twice or missed shows here even where noise hides it per pixel.
    pub mean_bias: f64,
    /// The same over the darker half of the image: see [`dark_half_bias`]. Light that fails to
    /// reach the indirectly lit regions shows here, where a bright region's excess would hide
    /// it in [`Self::mean_bias`].
    pub dark_half_bias: f64,
    /// Pixels with a NaN or infinite channel in either image.
    pub non_finite: usize,
}

impl fmt::Display for Metrics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "RMSE {:.4e}  relMSE {:.4e}  PSNR {:.2} dB  FLIP {:.4}  mean {:+.2}%  dark half {:+.2}%",
            self.rmse,
            self.relative_mse,
            self.psnr,
            self.flip,
            self.mean_bias * 100.0,
            self.dark_half_bias * 100.0
        )?;
        if self.non_finite > 0 {
            write!(f, "  non-finite pixels {}", self.non_finite)?;
        }
        Ok(())
    }
}

/// The per-pixel LDR-FLIP error, each in `[0, 1]`, row-major from the top left.
#[derive(Clone, Debug, PartialEq)]
pub struct FlipMap {
    width: u32,
    height: u32,
    values: Vec<f32>,
}

impl FlipMap {
    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The per-pixel errors, row-major from the top left.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// The mean error: the single number FLIP's authors recommend.
    pub fn mean(&self) -> f64 {
        self.values.iter().map(|&v| f64::from(v)).sum::<f64>() / self.values.len() as f64
    }

    /// The heat map as tightly packed 8-bit RGB: each error through FLIP's magma colour map
    /// (black for 0, pale yellow for 1).
    pub fn to_magma_rgb8(&self) -> Vec<u8> {
        nv_flip::FlipImageFloat::with_data(self.width, self.height, &self.values)
            .apply_color_lut(&nv_flip::magma_lut())
            .to_vec()
    }

    /// Writes [`FlipMap::to_magma_rgb8`] as a PNG.
    pub fn write_heat_map(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        image::save_buffer_with_format(
            path,
            &self.to_magma_rgb8(),
            self.width,
            self.height,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| Error::Image {
            path: path.to_owned(),
            why: format!("cannot write the FLIP heat map: {e}"),
        })
    }
}

/// The result of [`compare`]: the numbers and the FLIP map behind [`Metrics::flip`].
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// Every measure.
    pub metrics: Metrics,
    /// The per-pixel FLIP error, for a heat map.
    pub flip_map: FlipMap,
}

/// Every measure of `test` against `reference`; an error when their sizes differ.
pub fn compare(
    reference: &HdrImage,
    test: &HdrImage,
    settings: &CompareSettings,
) -> Result<Comparison> {
    let flip_map = flip(reference, test, settings)?;
    let non_finite = pairs(reference, test)?
        .filter(|(r, t)| r.iter().chain(t.iter()).any(|c| !c.is_finite()))
        .count();
    Ok(Comparison {
        metrics: Metrics {
            rmse: rmse(reference, test)?,
            relative_mse: relative_mse(reference, test)?,
            psnr: psnr(reference, test, &settings.tone)?,
            flip: flip_map.mean(),
            mean_bias: mean_bias(reference, test)?,
            dark_half_bias: dark_half_bias(reference, test)?,
            non_finite,
        },
        flip_map,
    })
}

/// `mean(test) / mean(reference) − 1` over the finite pixels and the three channels (0 when the
/// reference's mean is 0).
pub fn mean_bias(reference: &HdrImage, test: &HdrImage) -> Result<f64> {
    let (mut r, mut t) = (0.0f64, 0.0f64);
    for (a, b) in pairs(reference, test)? {
        if a.iter().chain(b.iter()).all(|c| c.is_finite()) {
            r += a.iter().map(|&c| f64::from(c)).sum::<f64>();
            t += b.iter().map(|&c| f64::from(c)).sum::<f64>();
        }
    }
    Ok(if r > 0.0 { t / r - 1.0 } else { 0.0 })
}

/// Side in pixels of the blocks [`dark_half_bias`] ranks: blocks rather than pixels, so that the
/// reference's own noise does not choose the pixels it measures (a noisy reference's darkest
/// pixels are its low outliers, which any test image would exceed).
pub const DARK_HALF_BLOCK: u32 = 8;

/// [`mean_bias`] over the darker half of the reference: its [`DARK_HALF_BLOCK`]-pixel blocks
/// (partial at the right and bottom edges) ranked by their mean over the finite pixels, and
/// `Σ test / Σ reference − 1` over the finite pixels of the darker half of them (the lower
/// `⌈blocks / 2⌉`). 0 when those sum to 0 in the reference.
pub fn dark_half_bias(reference: &HdrImage, test: &HdrImage) -> Result<f64> {
    let pixels = pairs(reference, test)?;
    let (width, height) = (reference.width() as usize, reference.height() as usize);
    let side = DARK_HALF_BLOCK as usize;
    let columns = width.div_ceil(side);
    // Per block: the reference's sum, the test's sum, finite pixels.
    let mut blocks = vec![(0.0f64, 0.0f64, 0u32); columns * height.div_ceil(side)];
    for (i, (a, b)) in pixels.enumerate() {
        if a.iter().chain(b.iter()).all(|c| c.is_finite()) {
            let block = &mut blocks[(i / width) / side * columns + (i % width) / side];
            block.0 += a.iter().map(|&c| f64::from(c)).sum::<f64>();
            block.1 += b.iter().map(|&c| f64::from(c)).sum::<f64>();
            block.2 += 1;
        }
    }
    blocks.retain(|b| b.2 > 0);
    blocks.sort_by(|x, y| (x.0 / f64::from(x.2)).total_cmp(&(y.0 / f64::from(y.2))));
    let (r, t) = blocks[..blocks.len().div_ceil(2)]
        .iter()
        .fold((0.0, 0.0), |(r, t), b| (r + b.0, t + b.1));
    Ok(if r > 0.0 { t / r - 1.0 } else { 0.0 })
}

/// Root mean square error of the linear values over all pixels and the three channels:
/// `sqrt(mean((t - r)²))`.
pub fn rmse(reference: &HdrImage, test: &HdrImage) -> Result<f64> {
    Ok(mean_over_channels(reference, test, |r, t| (t - r).powi(2))?.sqrt())
}

/// Relative mean square error of the linear values over all pixels and the three channels:
/// `mean((t - r)² / (r² + eps))` with `eps` = [`RELATIVE_MSE_EPSILON`], normalised by the
/// reference `r`.
pub fn relative_mse(reference: &HdrImage, test: &HdrImage) -> Result<f64> {
    mean_over_channels(reference, test, |r, t| {
        (t - r).powi(2) / (r * r + RELATIVE_MSE_EPSILON)
    })
}

/// Peak signal-to-noise ratio in dB of the displayed images: `-10 log10(mean((t - r)²))` over the
/// sRGB-encoded values in `[0, 1]` (peak 1) through `tone`, before 8-bit rounding. `+inf` when
/// they are identical.
pub fn psnr(reference: &HdrImage, test: &HdrImage, tone: &ToneMap) -> Result<f64> {
    let displayed = |p| {
        tone.to_srgb(p)
            .unwrap_or(NAN_COLOUR.map(|c| f32::from(c) / 255.0))
            .map(f64::from)
    };
    let mut sum = 0.0;
    let mut count = 0usize;
    for (r, t) in pairs(reference, test)? {
        let (r, t) = (displayed(r), displayed(t));
        sum += (0..3).map(|c| (t[c] - r[c]).powi(2)).sum::<f64>();
        count += 3;
    }
    Ok(-10.0 * (sum / count as f64).log10())
}

/// The per-pixel LDR-FLIP error of the displayed images: both through `settings.tone` to 8-bit
/// sRGB (as [`HdrImage::write_png`] stores them), then NVIDIA's FLIP at
/// `settings.pixels_per_degree`. Identical displayed images give 0 everywhere.
pub fn flip(reference: &HdrImage, test: &HdrImage, settings: &CompareSettings) -> Result<FlipMap> {
    check_sizes(reference, test)?;
    let (width, height) = (reference.width(), reference.height());
    let displayed = |image: &HdrImage| {
        nv_flip::FlipImageRgb8::with_data(width, height, &image.to_srgb8(&settings.tone))
    };
    let error = nv_flip::flip(
        displayed(reference),
        displayed(test),
        settings.pixels_per_degree,
    );
    Ok(FlipMap {
        width,
        height,
        values: error.to_vec(),
    })
}

fn check_sizes(reference: &HdrImage, test: &HdrImage) -> Result<()> {
    let size = |i: &HdrImage| (i.width(), i.height());
    if size(reference) == size(test) {
        return Ok(());
    }
    Err(Error::InvalidArgument {
        name: "test image",
        why: format!(
            "it is {}x{} but the reference image is {}x{}; comparing needs equal sizes",
            test.width(),
            test.height(),
            reference.width(),
            reference.height()
        ),
    })
}

fn pairs<'a>(
    reference: &'a HdrImage,
    test: &'a HdrImage,
) -> Result<impl Iterator<Item = ([f32; 3], [f32; 3])> + 'a> {
    check_sizes(reference, test)?;
    Ok(reference
        .pixels()
        .iter()
        .copied()
        .zip(test.pixels().iter().copied()))
}

/// The mean of `f(r, t)` over every channel of every pixel, in f64.
fn mean_over_channels(
    reference: &HdrImage,
    test: &HdrImage,
    f: impl Fn(f64, f64) -> f64,
) -> Result<f64> {
    let mut sum = 0.0;
    let mut count = 0usize;
    for (r, t) in pairs(reference, test)? {
        for c in 0..3 {
            sum += f(f64::from(r[c]), f64::from(t[c]));
        }
        count += 3;
    }
    Ok(sum / count as f64)
}
