//! A picture as characters chosen by luminance, without colour: what the
//! scene is under `NO_COLOR` on a terminal with no graphics protocol. Each
//! cell shows the character whose ink matches the mean luminance of the
//! pixels it covers (a light terminal text on a dark background: more ink
//! is lighter).

use image::DynamicImage;
use ratatui::layout::Size;

/// The characters from least to most ink.
pub const RAMP: [char; 10] = [' ', '.', ':', '-', '=', '+', '*', '#', '%', '@'];

/// The luminance (0 to 1) a character of [`RAMP`] stands for; `None` for
/// a character not in it.
pub fn level(c: char) -> Option<f64> {
    let i = RAMP.iter().position(|r| *r == c)?;
    Some(i as f64 / (RAMP.len() - 1) as f64)
}

/// Rows of `size` cells for `picture` (already resized to whole cells):
/// each cell the character of its pixels' mean Rec. 709 luminance.
pub fn rows(picture: &DynamicImage, size: Size) -> Vec<String> {
    let grey = picture.to_luma8();
    let (w, h) = (grey.width(), grey.height());
    let (cols, lines) = (u32::from(size.width.max(1)), u32::from(size.height.max(1)));
    (0..lines)
        .map(|row| {
            (0..cols)
                .map(|col| {
                    let (x0, x1) = (
                        col * w / cols,
                        ((col + 1) * w / cols).max(col * w / cols + 1),
                    );
                    let (y0, y1) = (
                        row * h / lines,
                        ((row + 1) * h / lines).max(row * h / lines + 1),
                    );
                    let (mut sum, mut n) = (0u64, 0u64);
                    for y in y0..y1.min(h) {
                        for x in x0..x1.min(w) {
                            sum += u64::from(grey.get_pixel(x, y).0[0]);
                            n += 1;
                        }
                    }
                    let mean = if n == 0 {
                        0.0
                    } else {
                        sum as f64 / n as f64 / 255.0
                    };
                    let i = (mean * (RAMP.len() - 1) as f64).round() as usize;
                    RAMP[i.min(RAMP.len() - 1)]
                })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{GrayImage, Luma};

    #[test]
    fn dark_is_blank_and_light_is_full() {
        let picture = DynamicImage::ImageLuma8(GrayImage::from_fn(20, 10, |x, _| {
            Luma([if x < 10 { 0 } else { 255 }])
        }));
        let rows = rows(&picture, Size::new(2, 1));
        assert_eq!(rows, vec![" @".to_string()]);
        assert_eq!(level('@'), Some(1.0));
        assert_eq!(level(' '), Some(0.0));
    }
}
