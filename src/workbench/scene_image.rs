//! The scene image as every screen shows it (the workbench's Scene pane and
//! the annotation screen): read on a blocking task, encoded for exactly the
//! area it is drawn in, and a one-line note in that area until it is.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use image::DynamicImage;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::Span;
use ratatui::widgets::{Paragraph, Wrap};
use ratatui::Frame;

use super::graphics::{Drawing, Graphics};

/// An image encoded for the terminal, with the area it was encoded for.
pub type Encoded = (Rect, Box<Drawing>);

/// Why the scene image cannot be shown, in one line.
#[derive(Debug, thiserror::Error)]
pub enum SceneImageError {
    /// The file could not be read or decoded, or is cut short: refused as
    /// a provider would be spared it.
    #[error("{}: the scene image cannot be shown: {reason}", crate::sanitize::one_line(&path.display().to_string()))]
    Read {
        /// The image file.
        path: PathBuf,
        /// Why, in words for the user.
        reason: String,
    },
    /// This terminal's graphics protocol cannot draw it.
    #[error(transparent)]
    Encode(#[from] ratatui_image::errors::Errors),
}

/// Reads a scene image (on a blocking task: decoding is slow), refused for
/// the reasons a run refuses it ([`crate::agents::images::read_image`]).
pub fn read(path: &Path) -> Result<Arc<DynamicImage>, SceneImageError> {
    crate::agents::images::read_image(path)
        .map(|(_, _, image)| Arc::new(image))
        .map_err(|reason| SceneImageError::Read {
            path: path.to_path_buf(),
            reason,
        })
}

/// What encoding the workbench's scene needs, handed from the app to the
/// task that encodes it.
pub struct ImageRequest {
    /// The cells it is drawn in.
    pub area: Rect,
    /// The decoded scene.
    pub image: Arc<DynamicImage>,
    /// The theme's background, for the cells the picture does not fill
    /// ([`crate::workbench::theme::Theme::picture_background`]).
    pub background: Option<[u8; 3]>,
}

/// Resizes and encodes `image` to fill `area` with the terminal's graphics
/// protocol, the cells it leaves padded with `background`: the slow part
/// of showing it, done on a blocking task.
pub fn encode(
    graphics: &Graphics,
    image: &DynamicImage,
    area: Rect,
    background: Option<[u8; 3]>,
) -> Result<Encoded, SceneImageError> {
    let drawing = graphics.encode(image, area, background)?;
    Ok((area, Box::new(drawing)))
}

/// Draws the image in `area` when it is encoded for exactly that area, and
/// `note` (wrapped, in `style`) otherwise. With `held` (an overlay is open
/// over the screen), a picture the terminal paints is not sent until the
/// overlay has gone, so it never covers the overlay and is sent once after.
pub fn draw(
    frame: &mut Frame,
    area: Rect,
    encoded: Option<&Encoded>,
    note: &str,
    style: Style,
    held: bool,
) {
    match encoded {
        Some((at, drawing)) if *at == area => {
            drawing.render(area, frame.buffer_mut(), held);
        }
        _ => frame.render_widget(
            Paragraph::new(Span::styled(note, style)).wrap(Wrap { trim: true }),
            area,
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cut_jpeg_is_refused_as_a_run_refuses_it_and_a_whole_one_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let picture =
            image::RgbImage::from_fn(64, 48, |x, y| image::Rgb([x as u8 * 4, y as u8 * 5, 90]));
        let mut jpeg = Vec::new();
        DynamicImage::ImageRgb8(picture)
            .write_to(
                &mut std::io::Cursor::new(&mut jpeg),
                image::ImageFormat::Jpeg,
            )
            .unwrap();
        let whole = dir.path().join("whole.jpg");
        std::fs::write(&whole, &jpeg).unwrap();
        assert_eq!(read(&whole).unwrap().width(), 64);
        let cut = dir.path().join("cut.jpg");
        std::fs::write(&cut, &jpeg[..jpeg.len() * 2 / 3]).unwrap();
        let err = read(&cut).unwrap_err().to_string();
        assert!(
            err.contains("cut.jpg: the scene image cannot be shown: the JPEG file is truncated"),
            "{err}"
        );
        let run = crate::agents::images::prepare_image(&cut, 1024)
            .unwrap_err()
            .to_string();
        assert!(run.contains("the JPEG file is truncated"), "{run}");
    }
}
