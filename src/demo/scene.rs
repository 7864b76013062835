//! The demo's scene image: a small kitchen drawn with plain shapes, made at
//! run time so the repository holds no picture.

use image::{Rgb, RgbImage};

const WIDTH: u32 = 192;
const HEIGHT: u32 = 128;

fn fill(img: &mut RgbImage, x: u32, y: u32, w: u32, h: u32, colour: [u8; 3]) {
    for py in y..(y + h).min(img.height()) {
        for px in x..(x + w).min(img.width()) {
            img.put_pixel(px, py, Rgb(colour));
        }
    }
}

fn disc(img: &mut RgbImage, cx: i64, cy: i64, r: i64, colour: [u8; 3]) {
    for py in (cy - r).max(0)..(cy + r + 1).min(i64::from(img.height())) {
        for px in (cx - r).max(0)..(cx + r + 1).min(i64::from(img.width())) {
            let (dx, dy) = (px - cx, py - cy);
            if dx * dx + dy * dy <= r * r {
                img.put_pixel(px as u32, py as u32, Rgb(colour));
            }
        }
    }
}

/// The kitchen of the built-in demo: a window with a counter under it and the
/// blue mug on it, a table with a red mug, a sink with a tap on the left and a
/// coffee machine on a shelf.
pub fn scene_image() -> RgbImage {
    let mut img = RgbImage::from_pixel(WIDTH, HEIGHT, Rgb([226, 214, 190]));
    // floor
    fill(&mut img, 0, 88, WIDTH, 40, [150, 120, 92]);
    for x in (0..WIDTH).step_by(24) {
        fill(&mut img, x, 88, 1, 40, [128, 100, 76]);
    }
    // window with frame and sky, a plant on the sill
    fill(&mut img, 118, 12, 62, 42, [90, 70, 50]);
    fill(&mut img, 122, 16, 54, 34, [150, 200, 240]);
    fill(&mut img, 148, 16, 2, 34, [90, 70, 50]);
    fill(&mut img, 122, 32, 54, 2, [90, 70, 50]);
    fill(&mut img, 166, 44, 8, 8, [170, 90, 60]);
    disc(&mut img, 170, 40, 5, [60, 150, 70]);
    // counter under the window, blue mug on it
    fill(&mut img, 110, 58, 82, 6, [120, 84, 56]);
    fill(&mut img, 114, 64, 74, 30, [160, 116, 80]);
    fill(&mut img, 126, 46, 10, 12, [40, 90, 210]);
    fill(&mut img, 136, 49, 3, 6, [40, 90, 210]);
    // table in front with a red mug
    fill(&mut img, 62, 74, 60, 5, [110, 78, 52]);
    fill(&mut img, 66, 79, 4, 24, [110, 78, 52]);
    fill(&mut img, 114, 79, 4, 24, [110, 78, 52]);
    fill(&mut img, 86, 64, 9, 10, [200, 50, 50]);
    // sink cabinet on the left with a tap
    fill(&mut img, 4, 60, 50, 34, [200, 200, 205]);
    fill(&mut img, 10, 58, 38, 6, [150, 155, 165]);
    fill(&mut img, 27, 44, 4, 14, [120, 125, 135]);
    fill(&mut img, 27, 44, 12, 3, [120, 125, 135]);
    // shelf with the coffee machine
    fill(&mut img, 56, 30, 44, 4, [110, 78, 52]);
    fill(&mut img, 64, 8, 26, 22, [40, 40, 44]);
    fill(&mut img, 74, 18, 6, 6, [200, 200, 200]);
    disc(&mut img, 84, 12, 2, [220, 60, 60]);
    img
}

/// The demo's scene as the PNG file sent to the agents: the same bytes on
/// every run, so that its hash (part of each request's key) matches the
/// recording.
pub fn scene_png() -> Result<Vec<u8>, image::ImageError> {
    let mut bytes = Vec::new();
    scene_image().write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_scene_has_the_blue_mug_on_the_counter() {
        let img = super::scene_image();
        assert_eq!(img.dimensions(), (192, 128));
        assert_eq!(img.get_pixel(130, 50).0, [40, 90, 210]);
        assert_eq!(img.get_pixel(90, 70).0, [200, 50, 50]);
    }
}
