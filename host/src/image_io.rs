//! Images in and out: linear HDR as OpenEXR, tone-mapped 8-bit sRGB as PNG, and PNG/JPEG read
//! back as linear values for comparisons.
//!
//! An [`HdrImage`] holds linear RGB in `f32`, row-major from the top-left pixel. What happens to
//! values a renderer should not produce:
//! - OpenEXR keeps every `f32` bit for bit, NaN and infinities included, so a broken render can be
//!   inspected as it was.
//! - PNG shows a pixel with any NaN channel as magenta (255, 0, 255), so it stands out; `+inf`
//!   saturates to 255 and `-inf` and negative values to 0, like any out-of-range value.

use crate::{Error, Result};
use exr::prelude::{
    Encoding, Image as ExrImage, ReadChannels, ReadLayers, SpecificChannels, WritableImage,
};
use std::path::Path;

/// A linear RGB image in `f32`, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct HdrImage {
    width: u32,
    height: u32,
    pixels: Vec<[f32; 3]>,
}

/// The colour a PNG shows for a pixel with a NaN channel.
pub const NAN_COLOUR: [u8; 3] = [255, 0, 255];

/// How linear values become display values in `[0, 1]`: scaled by `2^exposure`, then the curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneMap {
    /// Exposure in stops: linear values are multiplied by `2^exposure` before the curve.
    pub exposure: f32,
    /// The tone curve applied after the exposure.
    pub curve: ToneCurve,
}

/// A tone curve from exposed linear values to display-linear values in `[0, 1]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ToneCurve {
    /// `clamp(x, 0, 1)`: exact below 1, so 0.5 shows as sRGB 188; everything above 1 is white.
    Clamp,
    /// Narkowicz's 2015 fit of the ACES filmic curve with its 0.6 pre-scale, the tone mapper of
    /// HDR-FLIP: `f(x) = clamp(y (2.51 y + 0.03) / (y (2.43 y + 0.59) + 0.14), 0, 1)` with
    /// `y = 0.6 x`. It rolls highlights off (1.0 shows as 0.673 before sRGB encoding) and
    /// saturates at `x ≈ 12.1`.
    #[default]
    Aces,
}

impl Default for ToneMap {
    /// Exposure 0 (no scaling) and the ACES curve.
    fn default() -> Self {
        Self {
            exposure: 0.0,
            curve: ToneCurve::default(),
        }
    }
}

impl ToneCurve {
    /// Maps one exposed linear value to `[0, 1]`: NaN stays NaN, negative values (and `-inf`)
    /// give 0, `+inf` gives 1.
    pub fn apply(self, x: f32) -> f32 {
        if x.is_nan() {
            return x;
        }
        if x <= 0.0 {
            // The ACES fit is positive for negative inputs too: clamp before it, not after.
            return 0.0;
        }
        let y = match self {
            Self::Clamp => x,
            Self::Aces if x == f32::INFINITY => 1.0,
            Self::Aces => {
                // In f64 so that y² cannot overflow to inf/inf = NaN for large finite inputs.
                let y = 0.6 * f64::from(x);
                (y * (2.51 * y + 0.03) / (y * (2.43 * y + 0.59) + 0.14)) as f32
            }
        };
        y.min(1.0)
    }
}

impl ToneMap {
    /// A tone map with `exposure` stops and `curve`.
    pub fn new(exposure: f32, curve: ToneCurve) -> Self {
        Self { exposure, curve }
    }

    /// Linear RGB to display-linear RGB in `[0, 1]`; a NaN channel stays NaN.
    pub fn apply(&self, rgb: [f32; 3]) -> [f32; 3] {
        let scale = self.exposure.exp2();
        rgb.map(|c| self.curve.apply(c * scale))
    }

    /// Linear RGB to sRGB-encoded values in `[0, 1]` (not quantised), or `None` when a channel is
    /// NaN.
    pub fn to_srgb(&self, rgb: [f32; 3]) -> Option<[f32; 3]> {
        let display = self.apply(rgb);
        (!display.iter().any(|c| c.is_nan())).then(|| display.map(srgb_encode))
    }

    /// Linear RGB to the 8-bit sRGB pixel a PNG stores: [`NAN_COLOUR`] where a channel is NaN.
    pub fn to_srgb8(&self, rgb: [f32; 3]) -> [u8; 3] {
        // Values are in [0, 1], so the cast cannot saturate.
        self.to_srgb(rgb)
            .map_or(NAN_COLOUR, |s| s.map(|c| (c * 255.0).round() as u8))
    }
}

/// The sRGB transfer function (IEC 61966-2-1): display-linear `[0, 1]` to encoded `[0, 1]`.
pub fn srgb_encode(linear: f32) -> f32 {
    if linear <= 0.003_130_8 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse sRGB transfer function: encoded `[0, 1]` to linear `[0, 1]`.
pub fn srgb_decode(encoded: f32) -> f32 {
    if encoded <= 0.040_45 {
        encoded / 12.92
    } else {
        ((encoded + 0.055) / 1.055).powf(2.4)
    }
}

fn image_error(path: &Path, why: impl std::fmt::Display) -> Error {
    Error::Image {
        path: path.to_owned(),
        why: why.to_string(),
    }
}

impl HdrImage {
    /// A black image of `width` × `height` pixels; both must be non-zero.
    pub fn new(width: u32, height: u32) -> Result<Self> {
        Self::from_pixels(
            width,
            height,
            vec![[0.0; 3]; width as usize * height as usize],
        )
    }

    /// An image from its pixels, row-major from the top left; there must be `width * height` of
    /// them and both sizes must be non-zero.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<[f32; 3]>) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(Error::InvalidArgument {
                name: "image size",
                why: format!("{width}x{height} has no pixels"),
            });
        }
        let expected = width as usize * height as usize;
        if pixels.len() != expected {
            return Err(Error::InvalidArgument {
                name: "image pixels",
                why: format!(
                    "{} pixels given for a {width}x{height} image, which needs {expected}",
                    pixels.len()
                ),
            });
        }
        Ok(Self {
            width,
            height,
            pixels,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixels, row-major from the top left.
    pub fn pixels(&self) -> &[[f32; 3]] {
        &self.pixels
    }

    /// The pixels, mutable; the size stays fixed.
    pub fn pixels_mut(&mut self) -> &mut [[f32; 3]] {
        &mut self.pixels
    }

    /// The pixel at column `x`, row `y` (row 0 at the top).
    ///
    /// # Panics
    /// If `(x, y)` is outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> [f32; 3] {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside a {}x{} image",
            self.width,
            self.height
        );
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Reads an image by the file's extension: `.exr` (any case) as OpenEXR, `.hdr` as Radiance
    /// RGBE (linear, as it is), anything else as PNG/JPEG through [`HdrImage::read_ldr`].
    pub fn read(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        Self::decode(path, &read_file(path)?)
    }

    /// Decodes the bytes of an image file as [`HdrImage::read`] reads the file at `path` (the
    /// format by `path`'s extension, errors naming `path`), for images already in memory.
    pub fn decode(path: impl AsRef<Path>, bytes: &[u8]) -> Result<Self> {
        let path = path.as_ref();
        let extension = |x: &str| path.extension().is_some_and(|e| e.eq_ignore_ascii_case(x));
        if extension("exr") {
            decode_exr(path, bytes)
        } else if extension("hdr") {
            decode_image(path, bytes, |v| v)
        } else {
            decode_image(path, bytes, srgb_decode)
        }
    }

    /// Reads a Radiance RGBE (`.hdr`) image; its values are linear already.
    pub fn read_radiance_hdr(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        decode_image(path, &read_file(path)?, |v| v)
    }

    /// Writes the image as OpenEXR: channels R, G, B in `f32`, lossless ZIP compression, every
    /// value bit for bit (NaN and infinities included).
    pub fn write_exr(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let width = self.width as usize;
        let channels = SpecificChannels::rgb(|pos: exr::math::Vec2<usize>| {
            let [r, g, b] = self.pixels[pos.y() * width + pos.x()];
            (r, g, b)
        });
        ExrImage::from_encoded_channels(
            (width, self.height as usize),
            Encoding::SMALL_LOSSLESS,
            channels,
        )
        .write()
        .to_file(path)
        .map_err(|e| image_error(path, format_args!("cannot write OpenEXR: {e}")))
    }

    /// Reads the R, G and B channels of the first RGB layer of an OpenEXR file (half, float or
    /// uint samples, converted to `f32`), at its largest resolution level.
    pub fn read_exr(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        decode_exr(path, &read_file(path)?)
    }

    /// Writes the image as an 8-bit sRGB PNG through `tone`: see [`ToneMap::to_srgb8`]. A
    /// non-finite exposure is an error (it would make every pixel NaN).
    pub fn write_png(&self, path: impl AsRef<Path>, tone: &ToneMap) -> Result<()> {
        let path = path.as_ref();
        if !tone.exposure.is_finite() {
            return Err(Error::InvalidArgument {
                name: "exposure",
                why: format!(
                    "{} stops for {}: must be a finite number",
                    tone.exposure,
                    path.display()
                ),
            });
        }
        image::save_buffer_with_format(
            path,
            &self.to_srgb8(tone),
            self.width,
            self.height,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| image_error(path, format_args!("cannot write PNG: {e}")))
    }

    /// The image as tightly packed 8-bit sRGB triples through `tone`, as [`HdrImage::write_png`]
    /// stores them.
    pub fn to_srgb8(&self, tone: &ToneMap) -> Vec<u8> {
        self.pixels.iter().flat_map(|&p| tone.to_srgb8(p)).collect()
    }

    /// Reads a PNG or JPEG (format from its content) as linear values: each channel is decoded
    /// with the inverse sRGB transfer function, whatever colour profile the file names; 16-bit
    /// PNGs keep their precision and alpha is dropped.
    pub fn read_ldr(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        decode_image(path, &read_file(path)?, srgb_decode)
    }
}

fn read_file(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| image_error(path, format_args!("cannot read: {e}")))
}

/// Decodes an image the `image` crate reads (format from the content, else from `path`'s
/// extension), each channel through `transfer`.
fn decode_image(path: &Path, bytes: &[u8], transfer: fn(f32) -> f32) -> Result<HdrImage> {
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes));
    if let Ok(format) = image::ImageFormat::from_path(path) {
        reader.set_format(format);
    }
    let decoded = reader
        .with_guessed_format()
        .map_err(|e| image_error(path, format_args!("cannot read: {e}")))?
        .decode()
        .map_err(|e| image_error(path, format_args!("cannot decode: {e}")))?
        .into_rgb32f();
    let (width, height) = decoded.dimensions();
    let pixels = decoded.pixels().map(|p| p.0.map(transfer)).collect();
    HdrImage::from_pixels(width, height, pixels).map_err(|e| image_error(path, e))
}

/// Largest OpenEXR layer read, in pixels (8192 × 8192, 768 MiB as `f32` RGB): the header alone
/// sizes the pixel buffer, so a corrupt one could ask for any amount of memory.
const MAX_EXR_PIXELS: usize = 1 << 26;

/// Decodes the first RGB layer of an OpenEXR file at its largest resolution level.
fn decode_exr(path: &Path, bytes: &[u8]) -> Result<HdrImage> {
    let cannot_read =
        |e: exr::error::Error| image_error(path, format_args!("cannot read OpenEXR: {e}"));
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false)
        .map_err(cannot_read)?;
    for (i, header) in meta.headers.iter().enumerate() {
        let (width, height) = (header.layer_size.width(), header.layer_size.height());
        if width.checked_mul(height).is_none_or(|n| n > MAX_EXR_PIXELS) {
            return Err(image_error(
                path,
                format_args!(
                    "OpenEXR layer {i} of {width}x{height} pixels is larger than the \
                     {MAX_EXR_PIXELS} pixels an image may have"
                ),
            ));
        }
    }
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |size, _| (size.width(), vec![[0.0f32; 3]; size.area()]),
            |(width, pixels): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b): (f32, f32, f32)| {
                pixels[pos.y() * *width + pos.x()] = [r, g, b];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(cannot_read)?;
    let size = image.layer_data.size;
    let (_, pixels) = image.layer_data.channel_data.pixels;
    let dimension = |n: usize| {
        u32::try_from(n).map_err(|_| image_error(path, format_args!("{n} pixels is too large")))
    };
    HdrImage::from_pixels(dimension(size.width())?, dimension(size.height())?, pixels)
        .map_err(|e| image_error(path, e))
}
