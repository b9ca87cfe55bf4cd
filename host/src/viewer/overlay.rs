//! The viewer's overlay: lines of text over a darkened box in the window's top-left corner,
//! drawn on the CPU into the window's pixels (`0x00RRGGBB`) with `ab_glyph` and the embedded
//! DejaVu Sans Mono that the plots already use (no font needed on the machine).

use crate::error::{Error, Result};
use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};

/// Text height in pixels.
const TEXT_PX: f32 = 13.0;
/// Margin around the text, in pixels.
const PAD: f32 = 4.0;
/// What remains of the image under the box.
pub const BOX_DIM: f32 = 0.3;

/// The overlay's font at its size.
pub struct Overlay {
    font: FontRef<'static>,
    scale: PxScale,
}

impl Overlay {
    /// Loads the embedded font.
    pub fn new() -> Result<Self> {
        let font = FontRef::try_from_slice(dejavu::sans_mono::regular()).map_err(|e| {
            Error::InvalidArgument {
                name: "overlay font",
                why: format!("DejaVu Sans Mono: {e}"),
            }
        })?;
        Ok(Self {
            font,
            scale: PxScale::from(TEXT_PX),
        })
    }

    /// Width in pixels of `line`.
    fn width(&self, line: &str) -> f32 {
        let scaled = self.font.as_scaled(self.scale);
        line.chars()
            .map(|c| scaled.h_advance(scaled.glyph_id(c)))
            .sum()
    }

    /// Draws `lines` into `pixels` (`width × height`, row-major `0x00RRGGBB`): a box dimmed to
    /// [`BOX_DIM`] behind them, white text. Whatever falls outside the image is clipped.
    pub fn draw(&self, pixels: &mut [u32], width: u32, height: u32, lines: &[String]) {
        if lines.is_empty() || pixels.len() < width as usize * height as usize {
            return;
        }
        let scaled = self.font.as_scaled(self.scale);
        let line_height = scaled.height() + scaled.line_gap();
        let box_w = lines.iter().map(|l| self.width(l)).fold(0.0, f32::max) + 2.0 * PAD;
        let box_h = line_height * lines.len() as f32 + 2.0 * PAD;
        let (bw, bh) = (
            (box_w.ceil() as u32).min(width),
            (box_h.ceil() as u32).min(height),
        );
        for y in 0..bh {
            for p in &mut pixels[(y * width) as usize..(y * width + bw) as usize] {
                *p = blend(*p, 0, 1.0 - BOX_DIM);
            }
        }
        for (i, line) in lines.iter().enumerate() {
            let mut x = PAD;
            let baseline = PAD + scaled.ascent() + line_height * i as f32;
            for c in line.chars() {
                let id = scaled.glyph_id(c);
                let glyph = id.with_scale_and_position(self.scale, point(x, baseline));
                x += scaled.h_advance(id);
                let Some(outline) = self.font.outline_glyph(glyph) else {
                    continue;
                };
                let bounds = outline.px_bounds();
                outline.draw(|gx, gy, coverage| {
                    let px = bounds.min.x as i64 + i64::from(gx);
                    let py = bounds.min.y as i64 + i64::from(gy);
                    if (0..i64::from(width)).contains(&px) && (0..i64::from(height)).contains(&py) {
                        let p = &mut pixels[(py * i64::from(width) + px) as usize];
                        *p = blend(*p, 0x00ff_ffff, coverage);
                    }
                });
            }
        }
    }
}

/// `a` toward `b` by `t` in `[0, 1]`, per 8-bit channel.
fn blend(a: u32, b: u32, t: f32) -> u32 {
    let t = t.clamp(0.0, 1.0);
    (0..3).fold(0, |out, i| {
        let shift = 8 * i;
        let ca = ((a >> shift) & 0xff) as f32;
        let cb = ((b >> shift) & 0xff) as f32;
        out | (((ca + (cb - ca) * t).round() as u32) << shift)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_drawn_inside_its_box_only() {
        let (w, h) = (200, 60);
        let grey = 0x0080_8080;
        let mut pixels = vec![grey; w * h];
        let overlay = Overlay::new().unwrap();
        let lines = vec!["GI 12.3 ms".to_string(), "F feedback on".to_string()];
        overlay.draw(&mut pixels, w as u32, h as u32, &lines);
        let box_w = overlay.width(&lines[1]) + 2.0 * PAD;
        // Text is white over a box dimmed to 0x26: count the pixels it mostly covers.
        let text = pixels.iter().filter(|&&p| p & 0xff > 0xc0).count();
        assert!(text > 50, "{text} text pixels");
        for y in 0..h {
            for x in 0..w {
                let p = pixels[y * w + x];
                if x as f32 > box_w + 1.0 || y > 40 {
                    assert_eq!(p, grey, "({x}, {y}) outside the box changed");
                }
            }
        }
        // The box is dimmed where there is no text.
        assert_eq!(pixels[w - 1], grey);
        assert_eq!(pixels[0], blend(grey, 0, 1.0 - BOX_DIM));
        assert!(pixels[0] < grey);
    }

    #[test]
    fn tiny_images_and_no_lines_are_fine() {
        let overlay = Overlay::new().unwrap();
        let mut one = vec![0x0012_3456];
        overlay.draw(&mut one, 1, 1, &["a long line that does not fit".into()]);
        let mut same = vec![0x0012_3456; 4];
        overlay.draw(&mut same, 2, 2, &[]);
        assert_eq!(same, vec![0x0012_3456; 4]);
    }

    #[test]
    fn blending_is_per_channel() {
        assert_eq!(blend(0x0000_0000, 0x00ff_ffff, 1.0), 0x00ff_ffff);
        assert_eq!(blend(0x00ff_0000, 0x0000_00ff, 0.0), 0x00ff_0000);
        assert_eq!(blend(0x0010_2030, 0x0010_2030, 0.5), 0x0010_2030);
        assert_eq!(blend(0x0000_0000, 0x00ff_ffff, 0.5), 0x0080_8080);
    }
}
