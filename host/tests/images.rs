//! Image output and image metrics, on the CPU: OpenEXR round trips, the PNG tone curve's known
//! values, what non-finite pixels become, and the metrics on images with known differences.

use gi_host::Error;
use gi_host::image_io::{HdrImage, NAN_COLOUR, ToneCurve, ToneMap, srgb_decode, srgb_encode};
use gi_host::metrics::{self, CompareSettings, RELATIVE_MSE_EPSILON};
use std::path::PathBuf;

/// A fresh directory for one test's files.
fn scratch(test: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("images")
        .join(test);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

fn image(width: u32, height: u32, f: impl Fn(u32, u32) -> [f32; 3]) -> HdrImage {
    let pixels = (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| f(x, y))
        .collect();
    HdrImage::from_pixels(width, height, pixels).expect("valid image")
}

fn uniform(width: u32, height: u32, rgb: [f32; 3]) -> HdrImage {
    image(width, height, |_, _| rgb)
}

/// The 8-bit pixels of a PNG as written.
fn png_pixels(path: &std::path::Path) -> Vec<[u8; 3]> {
    image::open(path)
        .expect("PNG decodes")
        .into_rgb8()
        .pixels()
        .map(|p| p.0)
        .collect()
}

/// A PNG of a one-row image through `tone`, read back as 8-bit pixels.
fn through_png(test: &str, values: &[[f32; 3]], tone: ToneMap) -> Vec<[u8; 3]> {
    let path = scratch(test).join("row.png");
    HdrImage::from_pixels(values.len() as u32, 1, values.to_vec())
        .unwrap()
        .write_png(&path, &tone)
        .unwrap();
    png_pixels(&path)
}

/// Deterministic noise in [-1, 1] (xorshift), so tests need no random crate.
fn noise(seed: u64) -> impl FnMut() -> f32 {
    let mut state = seed.max(1);
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    }
}

fn gradient(width: u32, height: u32) -> HdrImage {
    image(width, height, |x, y| {
        let u = x as f32 / width as f32;
        let v = y as f32 / height as f32;
        [0.2 + 0.6 * u, 0.3 + 0.4 * v, 0.5]
    })
}

fn with_noise(reference: &HdrImage, amplitude: f32, seed: u64) -> HdrImage {
    let mut n = noise(seed);
    let pixels = reference
        .pixels()
        .iter()
        .map(|p| p.map(|c| (c + amplitude * n()).max(0.0)))
        .collect();
    HdrImage::from_pixels(reference.width(), reference.height(), pixels).unwrap()
}

#[test]
fn exr_round_trip_is_bit_exact_including_non_finite_values() {
    let path = scratch("exr_round_trip").join("image.exr");
    let special = [
        f32::NAN,
        f32::from_bits(0x7fc0_1234), // NaN with a payload
        f32::INFINITY,
        f32::NEG_INFINITY,
        -0.0,
        f32::MIN_POSITIVE / 8.0, // subnormal
        f32::MAX,
        -3.25,
        1.0e-30,
    ];
    let original = image(13, 7, |x, y| {
        let i = (y * 13 + x) as usize;
        let base = (i as f32 * 0.618_034).fract() * 100.0;
        let s = special[i % special.len()];
        [
            base,
            if i.is_multiple_of(3) { s } else { base / 7.0 },
            1.0 / (1.0 + i as f32),
        ]
    });
    original.write_exr(&path).unwrap();
    let read = HdrImage::read(&path).unwrap();
    assert_eq!((read.width(), read.height()), (13, 7));
    let bits = |i: &HdrImage| -> Vec<[u32; 3]> {
        i.pixels().iter().map(|p| p.map(f32::to_bits)).collect()
    };
    assert_eq!(bits(&read), bits(&original));
}

#[test]
fn read_picks_exr_by_extension_in_any_case() {
    let path = scratch("exr_extension_case").join("IMAGE.EXR");
    let original = uniform(3, 2, [2.5, 0.125, 1e6]);
    original.write_exr(&path).unwrap();
    assert_eq!(HdrImage::read(&path).unwrap(), original);
}

#[test]
fn png_clamp_curve_known_values() {
    let clamp = |exposure| ToneMap::new(exposure, ToneCurve::Clamp);
    let values = [[0.0; 3], [1.0; 3], [0.5; 3], [2.0; 3], [0.25, 0.5, 1.0]];
    let got = through_png("png_clamp", &values, clamp(0.0));
    assert_eq!(got, [[0; 3], [255; 3], [188; 3], [255; 3], [137, 188, 255]]);
    // +2 stops: 0.25 becomes 1.0 and 0.125 becomes 0.5.
    let got = through_png("png_clamp_plus_two", &[[0.25; 3], [0.125; 3]], clamp(2.0));
    assert_eq!(got, [[255; 3], [188; 3]]);
    // -1 stop: 1.0 becomes 0.5.
    let got = through_png("png_clamp_minus_one", &[[1.0; 3]], clamp(-1.0));
    assert_eq!(got, [[188; 3]]);
}

#[test]
fn png_aces_curve_known_values() {
    let aces = ToneMap::new(0.0, ToneCurve::Aces);
    assert_eq!(aces, ToneMap::default());
    // ACES(1) = 0.6 (2.51 0.6 + 0.03) / (0.6 (2.43 0.6 + 0.59) + 0.14) = 0.67329, sRGB 0.83968.
    let got = through_png(
        "png_aces",
        &[[0.0; 3], [1.0; 3], [12.2; 3], [1e30; 3], [f32::MAX; 3]],
        aces,
    );
    assert_eq!(got, [[0; 3], [214; 3], [255; 3], [255; 3], [255; 3]]);
    assert!((ToneCurve::Aces.apply(1.0) - 0.673_29).abs() < 1e-5);
}

#[test]
fn png_shows_nan_as_magenta_and_clamps_infinities_and_negatives() {
    for curve in [ToneCurve::Clamp, ToneCurve::Aces] {
        let values = [
            [f32::NAN, 0.5, 0.5],
            [0.0, 0.0, f32::NAN],
            [f32::INFINITY; 3],
            [f32::NEG_INFINITY; 3],
            [-1.0, -0.001, -1e30],
        ];
        let got = through_png("png_non_finite", &values, ToneMap::new(0.0, curve));
        assert_eq!(
            got,
            [NAN_COLOUR, NAN_COLOUR, [255; 3], [0; 3], [0; 3]],
            "{curve:?}"
        );
    }
}

#[test]
fn srgb_transfer_function_round_trips() {
    assert_eq!(srgb_encode(0.0), 0.0);
    assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
    assert_eq!((srgb_encode(0.5) * 255.0).round(), 188.0);
    for i in 0..=100 {
        let x = i as f32 / 100.0;
        assert!((srgb_decode(srgb_encode(x)) - x).abs() < 1e-5, "{x}");
    }
}

#[test]
fn png_reads_back_as_linear() {
    let path = scratch("png_reads_linear").join("row.png");
    let clamp = ToneMap::new(0.0, ToneCurve::Clamp);
    let original = HdrImage::from_pixels(3, 1, vec![[0.0; 3], [0.5; 3], [1.0, 0.2, 0.05]]).unwrap();
    original.write_png(&path, &clamp).unwrap();
    let read = HdrImage::read(&path).unwrap();
    assert_eq!((read.width(), read.height()), (3, 1));
    assert_eq!(read.pixel(0, 0), [0.0; 3]);
    assert_eq!(read.pixel(2, 0)[0], 1.0);
    // 8-bit sRGB steps near 0.5 are about 0.004 apart in linear.
    for (got, want) in read
        .pixels()
        .iter()
        .flatten()
        .zip(original.pixels().iter().flatten())
    {
        assert!((got - want).abs() < 0.003, "read {got}, wrote {want}");
    }
}

#[test]
fn jpeg_reads_back_as_linear() {
    let path = scratch("jpeg_reads_linear").join("grey.jpg");
    image::RgbImage::from_pixel(16, 8, image::Rgb([188, 188, 188]))
        .save(&path)
        .unwrap();
    let read = HdrImage::read(&path).unwrap();
    assert_eq!((read.width(), read.height()), (16, 8));
    for c in read.pixels().iter().flatten() {
        assert!((c - 0.5).abs() < 0.01, "{c}");
    }
}

#[test]
fn missing_or_broken_input_names_the_file() {
    let dir = scratch("missing_input");
    for name in ["absent.exr", "absent.png", "absent.jpg"] {
        let path = dir.join(name);
        let err = HdrImage::read(&path).unwrap_err();
        assert!(matches!(err, Error::Image { .. }), "{err:?}");
        assert!(err.to_string().contains(&*path.to_string_lossy()), "{err}");
    }
    for name in ["not-an-image.exr", "not-an-image.png"] {
        let path = dir.join(name);
        std::fs::write(&path, "plain text").unwrap();
        let err = HdrImage::read(&path).unwrap_err();
        assert!(err.to_string().contains(&*path.to_string_lossy()), "{err}");
    }
}

#[test]
fn unwritable_output_names_the_file() {
    let image = uniform(2, 2, [0.5; 3]);
    let dir = scratch("unwritable").join("no-such-directory");
    let exr = dir.join("out.exr");
    let err = image.write_exr(&exr).unwrap_err();
    assert!(err.to_string().contains(&*exr.to_string_lossy()), "{err}");
    let png = dir.join("out.png");
    let err = image.write_png(&png, &ToneMap::default()).unwrap_err();
    assert!(err.to_string().contains(&*png.to_string_lossy()), "{err}");
}

#[test]
fn image_size_must_match_its_pixels() {
    let err = HdrImage::from_pixels(4, 3, vec![[0.0; 3]; 11]).unwrap_err();
    assert!(err.to_string().contains("4x3"), "{err}");
    assert!(err.to_string().contains("11"), "{err}");
    let err = HdrImage::new(0, 3).unwrap_err();
    assert!(err.to_string().contains("0x3"), "{err}");
    assert_eq!(HdrImage::new(4, 3).unwrap().pixels(), [[0.0; 3]; 12]);
}

#[test]
fn identical_images_have_zero_distance_and_infinite_psnr() {
    let reference = gradient(48, 32);
    let result = metrics::compare(&reference, &reference, &CompareSettings::default()).unwrap();
    let m = result.metrics;
    assert_eq!(m.rmse, 0.0);
    assert_eq!(m.relative_mse, 0.0);
    assert_eq!(m.psnr, f64::INFINITY);
    assert_eq!(m.flip, 0.0);
    assert_eq!(m.mean_bias, 0.0);
    assert_eq!(m.non_finite, 0);
    assert!(result.flip_map.values().iter().all(|&v| v == 0.0));
    assert_eq!(
        m.to_string(),
        "RMSE 0.0000e0  relMSE 0.0000e0  PSNR inf dB  FLIP 0.0000  mean +0.00%  dark half +0.00%"
    );
}

#[test]
fn the_dark_half_is_the_darker_half_of_the_blocks() {
    // Three 8-pixel-wide columns of blocks (the last 4 pixels wide), two rows: a dark left column,
    // a bright middle one, a mid-grey partial one on the right.
    let (width, height) = (20, 16);
    let shade = |x: u32| match x {
        0..8 => 0.1,
        8..16 => 1.0,
        _ => 0.5,
    };
    let mut reference = HdrImage::new(width, height).unwrap();
    for (i, p) in reference.pixels_mut().iter_mut().enumerate() {
        *p = [shade(i as u32 % width); 3];
    }
    // The dark column at half its light, the bright one at twice: the mean rises, and the darker
    // half (the 3 darkest of 6 blocks: both dark ones and one mid-grey) reads low.
    let mut test = reference.clone();
    for (i, p) in test.pixels_mut().iter_mut().enumerate() {
        let x = i as u32 % width;
        let scale = match x {
            0..8 => 0.5,
            8..16 => 2.0,
            _ => 1.0,
        };
        *p = p.map(|c| c * scale);
    }
    let dark = metrics::dark_half_bias(&reference, &test).unwrap();
    // Sums over the three channels.
    let (r, t) = (
        3.0 * (2.0 * 64.0 * 0.1 + 32.0 * 0.5),
        3.0 * (2.0 * 64.0 * 0.05 + 32.0 * 0.5),
    );
    assert!((dark - (t / r - 1.0)).abs() < 1e-6, "{dark}");
    assert!(metrics::mean_bias(&reference, &test).unwrap() > 0.0);
    // Non-finite pixels are left out, a black reference reads 0, and sizes must match.
    let mut poisoned = test.clone();
    poisoned.pixels_mut()[0] = [f32::NAN; 3];
    let without = metrics::dark_half_bias(&reference, &poisoned).unwrap();
    let (r, t) = (r - 0.3, t - 0.15);
    assert!((without - (t / r - 1.0)).abs() < 1e-6, "{without}");
    let black = HdrImage::new(width, height).unwrap();
    assert_eq!(metrics::dark_half_bias(&black, &test).unwrap(), 0.0);
    assert!(metrics::dark_half_bias(&reference, &HdrImage::new(8, 8).unwrap()).is_err());
}

#[test]
fn known_difference_gives_analytic_values() {
    let reference = uniform(8, 4, [0.5; 3]);
    let test = uniform(8, 4, [0.6, 0.5, 0.5]);
    // One channel in three is off by 0.1.
    let rmse = metrics::rmse(&reference, &test).unwrap();
    assert!((rmse - (0.01f64 / 3.0).sqrt()).abs() < 1e-7, "{rmse}");
    let rel = metrics::relative_mse(&reference, &test).unwrap();
    let want = 0.01 / (0.25 + RELATIVE_MSE_EPSILON) / 3.0;
    assert!((rel - want).abs() < 1e-7, "{rel} vs {want}");
    // Clamp curve: the displayed red channels are srgb(0.5) and srgb(0.6).
    let tone = ToneMap::new(0.0, ToneCurve::Clamp);
    let d = f64::from(srgb_encode(0.6) - srgb_encode(0.5));
    let want = -10.0 * (d * d / 3.0).log10();
    let psnr = metrics::psnr(&reference, &test, &tone).unwrap();
    assert!((psnr - want).abs() < 1e-3, "{psnr} vs {want}");
    // The mean is 0.1 / 3 above 0.5.
    let bias = metrics::mean_bias(&reference, &test).unwrap();
    assert!((bias - 0.1 / 1.5).abs() < 1e-6, "{bias}");
}

#[test]
fn flip_grows_with_noise() {
    let reference = gradient(64, 64);
    let settings = CompareSettings::default();
    let flip = |amplitude| {
        let test = with_noise(&reference, amplitude, 7);
        metrics::compare(&reference, &test, &settings)
            .unwrap()
            .metrics
    };
    let (less, more) = (flip(0.02), flip(0.1));
    assert!(less.flip > 0.0, "{less}");
    assert!(more.flip > less.flip, "{more} vs {less}");
    assert!(
        more.rmse > less.rmse && more.psnr < less.psnr,
        "{more} vs {less}"
    );
}

#[test]
fn non_finite_pixels_are_counted_and_poison_linear_metrics_only() {
    let reference = gradient(16, 16);
    let mut test = reference.clone();
    test.pixels_mut()[5] = [f32::NAN, 0.0, 0.0];
    test.pixels_mut()[9] = [f32::INFINITY; 3];
    let m = metrics::compare(&reference, &test, &CompareSettings::default())
        .unwrap()
        .metrics;
    assert_eq!(m.non_finite, 2);
    assert!(m.rmse.is_nan(), "{m}");
    assert!(m.psnr.is_finite() && m.flip > 0.0, "{m}");
    assert!(m.to_string().ends_with("non-finite pixels 2"), "{m}");
}

#[test]
fn size_mismatch_names_both_sizes() {
    let reference = uniform(64, 32, [0.5; 3]);
    let test = uniform(32, 16, [0.5; 3]);
    let tone = ToneMap::default();
    let settings = CompareSettings::default();
    let errors = [
        metrics::compare(&reference, &test, &settings).unwrap_err(),
        metrics::rmse(&reference, &test).unwrap_err(),
        metrics::relative_mse(&reference, &test).unwrap_err(),
        metrics::psnr(&reference, &test, &tone).unwrap_err(),
        metrics::flip(&reference, &test, &settings).unwrap_err(),
    ];
    for err in errors {
        let text = err.to_string();
        assert!(text.contains("64x32") && text.contains("32x16"), "{text}");
    }
}

#[test]
fn heat_map_png_has_the_image_size() {
    let path = scratch("heat_map").join("flip.png");
    let reference = gradient(40, 24);
    let test = with_noise(&reference, 0.1, 3);
    let map = metrics::flip(&reference, &test, &CompareSettings::default()).unwrap();
    assert_eq!((map.width(), map.height()), (40, 24));
    map.write_heat_map(&path).unwrap();
    let decoded = image::open(&path).expect("heat map decodes").into_rgb8();
    assert_eq!(decoded.dimensions(), (40, 24));
    assert_eq!(decoded.as_raw(), &map.to_magma_rgb8());
    let first = decoded.get_pixel(0, 0);
    assert!(
        decoded.pixels().any(|p| p != first),
        "a noisy map is not uniform"
    );
}
