//! The window's pixels: our images tone-mapped exactly as `gi render` writes its PNG
//! ([`ToneMap::to_srgb8`]), packed as `0x00RRGGBB` (softbuffer's format), and back to RGB8 for a
//! screenshot.

use crate::image_io::{HdrImage, ToneMap};

/// `image` through `tone`, one `0x00RRGGBB` per pixel.
pub fn to_window_pixels(image: &HdrImage, tone: &ToneMap) -> Vec<u32> {
    image
        .pixels()
        .iter()
        .map(|&p| {
            let [r, g, b] = tone.to_srgb8(p);
            u32::from(r) << 16 | u32::from(g) << 8 | u32::from(b)
        })
        .collect()
}

/// Window pixels (`0x??RRGGBB`: the top byte is ignored) as packed RGB8 triples.
pub fn to_rgb8(pixels: &[u32]) -> Vec<u8> {
    pixels
        .iter()
        .flat_map(|&p| [(p >> 16) as u8, (p >> 8) as u8, p as u8])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_pixels_are_the_png_pixels() {
        let image = HdrImage::from_pixels(
            3,
            1,
            vec![[0.0, 0.5, 1.0], [4.0, 0.01, 0.2], [f32::NAN, 1.0, 0.0]],
        )
        .unwrap();
        let tone = ToneMap::default();
        let window = to_window_pixels(&image, &tone);
        assert_eq!(to_rgb8(&window), image.to_srgb8(&tone));
        assert_eq!(to_rgb8(&[0xff12_3456]), vec![0x12, 0x34, 0x56]);
    }
}
