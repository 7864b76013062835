//! The scene image as every screen shows it (the workbench's Scene pane and
//! the annotation screen): read on a blocking task, encoded for exactly the
//! area it is drawn in, and a one-line note in that area until it is.

use std::path::Path;
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

/// Reads a scene image; the error is one line naming the file and the cause.
pub fn read(path: &Path) -> Result<Arc<DynamicImage>, String> {
    image::open(path)
        .map(Arc::new)
        .map_err(|e| format!("{}: the scene image cannot be read ({e})", path.display()))
}

/// Encodes `image` to fill `area` with the terminal's graphics protocol;
/// the error says why this terminal cannot draw it.
pub fn encode(picker: &Picker, image: &DynamicImage, area: Rect) -> Result<Encoded, String> {
    picker
        .new_protocol(image.clone(), area.as_size(), Resize::Scale(None))
        .map(|protocol| (area, Box::new(protocol)))
        .map_err(|e| e.to_string())
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
