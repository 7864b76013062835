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
use ratatui_image::picker::Picker;
use ratatui_image::protocol::Protocol;
use ratatui_image::{Image, Resize};

/// An image encoded for the terminal, with the area it was encoded for.
pub type Encoded = (Rect, Box<Protocol>);

/// Why the scene image cannot be shown, in one line.
#[derive(Debug, thiserror::Error)]
pub enum SceneImageError {
    /// The file could not be read or decoded.
    #[error("{}: the scene image cannot be read ({error})", path.display())]
    Read {
        /// The image file.
        path: PathBuf,
        /// What went wrong.
        error: image::ImageError,
    },
    /// This terminal's graphics protocol cannot draw it.
    #[error(transparent)]
    Encode(#[from] ratatui_image::errors::Errors),
}

/// Reads a scene image (on a blocking task: decoding is slow).
pub fn read(path: &Path) -> Result<Arc<DynamicImage>, SceneImageError> {
    image::open(path)
        .map(Arc::new)
        .map_err(|error| SceneImageError::Read {
            path: path.to_path_buf(),
            error,
        })
}

/// Resizes and encodes `image` to fill `area` with the terminal's graphics
/// protocol: the slow part of showing it, done on a blocking task.
pub fn encode(
    picker: &Picker,
    image: &DynamicImage,
    area: Rect,
) -> Result<Encoded, SceneImageError> {
    let protocol = picker.new_protocol(image.clone(), area.as_size(), Resize::Scale(None))?;
    Ok((area, Box::new(protocol)))
}

/// Draws the image in `area` when it is encoded for exactly that area, and
/// `note` (wrapped, in `style`) otherwise.
pub fn draw(frame: &mut Frame, area: Rect, encoded: Option<&Encoded>, note: &str, style: Style) {
    match encoded {
        Some((at, protocol)) if *at == area => {
            frame.render_widget(Image::new(protocol.as_ref()), area);
        }
        _ => frame.render_widget(
            Paragraph::new(Span::styled(note, style)).wrap(Wrap { trim: true }),
            area,
        ),
    }
}
