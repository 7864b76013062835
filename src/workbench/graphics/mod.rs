//! How the scene image is drawn on this terminal: the graphics protocol,
//! the cell size in pixels, the largest picture the terminal takes, whether
//! it goes through tmux, and why that choice (the header shows it). The
//! choice is made from what the terminal answered at start
//! ([`super::terminal_query`]) or from what the user asked (`--graphics`).
//!
//! The protocols' encoders are ratatui-image's; the bytes for tmux are
//! wrapped here ([`tmux::wrap`]), and pictures drawn by an escape sequence
//! (sixel, iTerm2, kitty's direct placement) are placed by [`Drawing`],
//! which can hold one back while something covers it.

pub mod luminance;
pub mod tmux;

use std::num::NonZeroU16;
use std::sync::atomic::{AtomicU32, Ordering};

use base64::Engine;
use image::{DynamicImage, Rgba};
use ratatui::buffer::{Buffer, CellDiffOption};
use ratatui::layout::{Rect, Size};
use ratatui::widgets::Widget;
use ratatui_image::errors::Errors;
use ratatui_image::protocol::halfblocks::Halfblocks;
use ratatui_image::protocol::iterm2::Iterm2;
use ratatui_image::protocol::kitty::Kitty;
use ratatui_image::protocol::sixel::Sixel;
use ratatui_image::protocol::Protocol;
use ratatui_image::{FontSize, Image, Resize};

/// What the user asks for (`--graphics`, or `graphics` in the config file).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Request {
    /// Ask the terminal and use the best it draws.
    #[default]
    Auto,
    /// Sixel graphics.
    Sixel,
    /// kitty's graphics protocol (placeholders where the version has them).
    Kitty,
    /// iTerm2's inline images.
    Iterm2,
    /// Coloured half-block characters (any terminal).
    Halfblocks,
    /// No image.
    None,
}

/// The way pictures are drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Sixel graphics, within the terminal's largest graphic.
    Sixel,
    /// kitty's graphics placed by Unicode placeholders (kitty ≥ 0.28).
    KittyPlaceholders,
    /// kitty's graphics placed at the cursor (kitty before 0.28).
    KittyDirect,
    /// iTerm2's inline images.
    Iterm2,
    /// Coloured half-block characters.
    Halfblocks,
    /// Characters chosen by luminance, without colour (`NO_COLOR`).
    Luminance,
}

impl Kind {
    /// The name the header shows.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Sixel => "sixel",
            Kind::KittyPlaceholders => "kitty",
            Kind::KittyDirect => "kitty (direct placement)",
            Kind::Iterm2 => "iterm2",
            Kind::Halfblocks => "halfblocks",
            Kind::Luminance => "characters",
        }
    }

    /// Whether a picture of this kind is one escape sequence the terminal
    /// paints over cells (rather than characters in them).
    fn by_escape(self) -> bool {
        matches!(self, Kind::Sixel | Kind::KittyDirect | Kind::Iterm2)
    }
}

/// The cell size assumed when the terminal does not say (1:2, as most fonts).
pub const DEFAULT_FONT: FontSize = FontSize::new(10, 20);
/// The largest graphic assumed when the terminal does not say (xterm's
/// default `maxGraphicSize`).
pub const DEFAULT_MAX_PIXELS: (u32, u32) = (1000, 1000);

/// How this terminal draws the scene image, and why.
#[derive(Debug, Clone)]
pub struct Graphics {
    /// The protocol.
    pub kind: Kind,
    /// A cell's size in pixels.
    pub font: FontSize,
    /// Whether the bytes go through tmux's pass-through wrapper.
    pub tmux: bool,
    /// The largest picture (width, height in pixels) the terminal draws.
    pub max_pixels: (u32, u32),
    /// Why this protocol, as the header says it.
    pub why: String,
}

impl Graphics {
    /// Text drawing for any terminal: coloured half-blocks, or luminance
    /// characters without colour when `no_color`.
    pub fn text(no_color: bool, why: impl Into<String>) -> Graphics {
        Graphics {
            kind: if no_color {
                Kind::Luminance
            } else {
                Kind::Halfblocks
            },
            font: DEFAULT_FONT,
            tmux: false,
            max_pixels: DEFAULT_MAX_PIXELS,
            why: why.into(),
        }
    }

    /// Coloured half-blocks (the tests' and benchmarks' drawing).
    pub fn halfblocks() -> Graphics {
        Graphics::text(false, "asked for")
    }

    /// What the header says: the protocol and why.
    pub fn summary(&self) -> String {
        format!("{}: {}", self.kind.name(), self.why)
    }

    /// Resizes `image` to fit `area` (and, for an escape-drawn picture, the
    /// terminal's largest graphic) and encodes it, the cells it does not
    /// fill padded with `background` (transparent without one): the slow
    /// part of drawing it, done on a blocking task.
    pub fn encode(
        &self,
        image: &DynamicImage,
        area: Rect,
        background: Option<[u8; 3]>,
    ) -> Result<Drawing, Errors> {
        let mut available = area.as_size();
        if self.kind.by_escape() {
            let cells = |pixels: u32, cell: u16| {
                u16::try_from(pixels / u32::from(cell.max(1))).unwrap_or(u16::MAX)
            };
            available.width = available
                .width
                .min(cells(self.max_pixels.0, self.font.width));
            available.height = available
                .height
                .min(cells(self.max_pixels.1, self.font.height));
        }
        let resize = Resize::Scale(None);
        let size = resize.size_for(image, self.font, available);
        if size.width == 0 || size.height == 0 {
            return Ok(Drawing::Text(Vec::new()));
        }
        let background = background.map(|[r, g, b]| Rgba([r, g, b, u8::MAX]));
        let picture = resize.resize(image, self.font, size, background);
        let escape = |bytes: String| Drawing::Escape {
            bytes: if self.tmux { tmux::wrap(&bytes) } else { bytes },
            size,
        };
        Ok(match self.kind {
            Kind::Sixel => escape(Sixel::new(picture, size, false)?.data),
            Kind::Iterm2 => escape(Iterm2::new(picture, size, false)?.data),
            Kind::KittyDirect => Drawing::Escape {
                bytes: kitty_direct(&picture, size, self.tmux),
                size,
            },
            Kind::KittyPlaceholders => Drawing::Protocol(Box::new(Protocol::Kitty(Kitty::new(
                picture,
                size,
                kitty_id(),
                self.tmux,
                false,
            )?))),
            Kind::Halfblocks => Drawing::Protocol(Box::new(Protocol::Halfblocks(Halfblocks::new(
                picture, size,
            )?))),
            Kind::Luminance => Drawing::Text(luminance::rows(&picture, size)),
        })
    }
}

/// A fresh kitty image id: non-zero, with a non-zero colour part, distinct
/// within this process and unlikely to meet another program's.
fn kitty_id() -> u32 {
    static NEXT: AtomicU32 = AtomicU32::new(1);
    let n = NEXT.fetch_add(1, Ordering::Relaxed) & 0xff;
    let pid = std::process::id() & 0xffff;
    0x0100_0000 | (pid << 8) | n.max(1)
}

/// kitty's graphics placed at the cursor, `size` cells, the cursor left
/// where it was, drawn under text (for kitty before 0.28, which has no
/// placeholders), after the text in those cells is erased; the image data
/// in 4096-byte chunks, each wrapped for tmux on its own when `tmux`.
fn kitty_direct(picture: &DynamicImage, size: Size, tmux: bool) -> String {
    let rgba = picture.to_rgba8();
    let (w, h) = (rgba.width(), rgba.height());
    let data = base64::engine::general_purpose::STANDARD.encode(rgba.as_raw());
    let chunks: Vec<&[u8]> = data.as_bytes().chunks(4096).collect();
    let mut out = String::with_capacity(data.len() + chunks.len() * 40);
    // The text under it erased first (it is drawn under text).
    for _ in 0..size.height {
        out.push_str(&format!("\x1b[{}X\x1b[1B", size.width));
    }
    out.push_str(&format!("\x1b[{}A", size.height));
    for (i, chunk) in chunks.iter().enumerate() {
        let more = u8::from(i + 1 < chunks.len());
        let head = if i == 0 {
            format!(
                "a=T,f=32,s={w},v={h},c={},r={},C=1,z=-1,q=2,m={more}",
                size.width, size.height
            )
        } else {
            format!("m={more}")
        };
        let seq = format!("\x1b_G{head};{}\x1b\\", String::from_utf8_lossy(chunk));
        out.push_str(&if tmux { tmux::wrap(&seq) } else { seq });
    }
    out
}

/// The bytes that take every picture kitty placed directly off the screen
/// (sent when one is held back or replaced).
pub fn kitty_direct_clear(tmux: bool) -> String {
    let seq = "\x1b_Ga=d,d=A,q=2\x1b\\".to_string();
    if tmux {
        tmux::wrap(&seq)
    } else {
        seq
    }
}

/// An encoded picture, ready to be drawn.
pub enum Drawing {
    /// Drawn by ratatui-image's widget (characters in cells).
    Protocol(Box<Protocol>),
    /// One escape sequence the terminal paints over `size` cells.
    Escape {
        /// The sequence (wrapped for tmux when it goes through tmux).
        bytes: String,
        /// The cells it covers.
        size: Size,
    },
    /// Rows of characters without colour.
    Text(Vec<String>),
}

impl Drawing {
    /// Draws the picture at the top left of `area`. With `held` (something
    /// covers it, or is about to), an escape-drawn picture is not sent: its
    /// cells are left as the terminal has them, and the first frame without
    /// `held` sends it once, which paints over whatever covered it.
    pub fn render(&self, area: Rect, buf: &mut Buffer, held: bool) {
        match self {
            Drawing::Protocol(protocol) => Image::new(protocol).render(area, buf),
            Drawing::Escape { bytes, size } => {
                let covered = Rect {
                    width: size.width.min(area.width),
                    height: size.height.min(area.height),
                    ..area
                };
                for y in covered.top()..covered.bottom() {
                    for x in covered.left()..covered.right() {
                        if let Some(cell) = buf.cell_mut((x, y)) {
                            cell.set_diff_option(CellDiffOption::Skip);
                        }
                    }
                }
                if held || covered.is_empty() {
                    return;
                }
                if let Some(cell) = buf.cell_mut((covered.x, covered.y)) {
                    cell.set_symbol(bytes)
                        .set_diff_option(CellDiffOption::ForcedWidth(NonZeroU16::MIN));
                }
            }
            Drawing::Text(rows) => {
                for (y, row) in (area.top()..area.bottom()).zip(rows) {
                    buf.set_string(area.x, y, row, ratatui::style::Style::default());
                }
            }
        }
    }

    /// Whether this picture is painted by an escape sequence.
    pub fn by_escape(&self) -> bool {
        matches!(self, Drawing::Escape { .. })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{Rgb, RgbImage};

    fn picture() -> DynamicImage {
        DynamicImage::ImageRgb8(RgbImage::from_fn(64, 48, |x, y| {
            Rgb([(x * 4) as u8, (y * 5) as u8, 128])
        }))
    }

    fn graphics(kind: Kind, tmux: bool) -> Graphics {
        Graphics {
            kind,
            font: FontSize::new(8, 16),
            tmux,
            max_pixels: DEFAULT_MAX_PIXELS,
            why: "test".into(),
        }
    }

    /// The bytes the picture puts on the terminal: the symbols of its cells.
    fn written(drawing: &Drawing, area: Rect) -> String {
        let mut buf = Buffer::empty(area);
        drawing.render(area, &mut buf, false);
        buf.content().iter().map(|c| c.symbol()).collect()
    }

    #[test]
    fn a_sixel_for_tmux_is_one_well_formed_pass_through_of_the_plain_sixel() {
        let area = Rect::new(0, 0, 8, 3);
        let plain = graphics(Kind::Sixel, false)
            .encode(&picture(), area, None)
            .unwrap();
        let wrapped = graphics(Kind::Sixel, true)
            .encode(&picture(), area, None)
            .unwrap();
        let (Drawing::Escape { bytes: plain, .. }, Drawing::Escape { bytes, .. }) =
            (&plain, &wrapped)
        else {
            panic!("a sixel is an escape sequence");
        };
        assert!(plain.contains(";0q\"") && plain.ends_with("\x1b\\"));
        assert_eq!(tmux::unwrap_all(bytes), Ok(vec![plain.clone()]));
    }

    #[test]
    fn kitty_for_tmux_is_nothing_but_well_formed_pass_throughs() {
        let area = Rect::new(0, 0, 8, 3);
        for kind in [Kind::KittyPlaceholders, Kind::KittyDirect] {
            let drawing = graphics(kind, true).encode(&picture(), area, None).unwrap();
            let bytes: String = written(&drawing, area)
                .chars()
                .filter(|c| *c == '\x1b' || !(c.is_whitespace() || *c >= '\u{300}'))
                .collect();
            let start = bytes.find(tmux::START).unwrap();
            let end = bytes.rfind('\\').unwrap() + 1;
            let inner = tmux::unwrap_all(&bytes[start..end]).unwrap();
            assert!(!inner.is_empty(), "{kind:?}");
            assert!(
                inner
                    .iter()
                    .all(|s| s.starts_with("\x1b_G") && s.ends_with("\x1b\\")),
                "{kind:?}: {inner:?}"
            );
        }
    }

    #[test]
    fn a_sixel_stays_within_the_largest_graphic() {
        let wide = DynamicImage::ImageRgb8(RgbImage::new(1600, 400));
        let mut g = graphics(Kind::Sixel, false);
        g.max_pixels = (1000, 1000);
        let Ok(Drawing::Escape { size, .. }) = g.encode(&wide, Rect::new(0, 0, 200, 50), None)
        else {
            panic!("a sixel");
        };
        assert!(u32::from(size.width) * 8 <= 1000, "{size:?}");
        assert!(size.width >= 120, "scaled to fit, not dropped: {size:?}");
    }

    #[test]
    fn the_cells_a_picture_does_not_fill_are_padded_with_the_background_given() {
        // 64×40 at 16 px rows fills 3 rows and 77 of 10 cells' 80 columns.
        let red = DynamicImage::ImageRgb8(RgbImage::from_pixel(64, 40, Rgb([255, 0, 0])));
        let area = Rect::new(0, 0, 20, 3);
        let sixel = |background| match graphics(Kind::Sixel, false).encode(&red, area, background) {
            Ok(Drawing::Escape { bytes, size }) => (bytes, size),
            _ => panic!("a sixel"),
        };
        let (padded, size) = sixel(Some([0, 0, 255]));
        assert_eq!((size.width, size.height), (10, 3));
        assert!(
            padded.contains(";2;0;0;100"),
            "blue in the palette: {padded:.80}"
        );
        assert!(
            padded.contains(";2;100;0;0"),
            "red in the palette: {padded:.80}"
        );
        let (transparent, _) = sixel(None);
        assert!(!transparent.contains(";2;0;0;100"), "{transparent:.80}");
    }

    #[test]
    fn a_held_escape_picture_sends_nothing_and_skips_its_cells() {
        let area = Rect::new(0, 0, 8, 3);
        let drawing = graphics(Kind::Sixel, false)
            .encode(&picture(), area, None)
            .unwrap();
        let mut buf = Buffer::empty(area);
        drawing.render(area, &mut buf, true);
        assert!(buf
            .content()
            .iter()
            .all(|c| c.symbol() == " " && c.diff_option == CellDiffOption::Skip));
    }
}
