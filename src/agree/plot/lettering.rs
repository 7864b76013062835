//! The figure's text as outlines of the embedded font's glyphs (DejaVu
//! Sans), the same in both formats: in the SVG as `<path>` elements, so it
//! looks the same on a machine without the font (a `<text>` element would
//! be set in whatever font the viewer finds), and in the PNG as those
//! outlines filled with anti-aliasing. One layout serves both, so the two
//! files agree to the pixel up to the rasteriser.
//!
//! [`Lettered`] wraps a plotters backend and takes over its text: plotters
//! lays out the chart, asks the wrapper how large a text is and hands it
//! every text to draw. Text is drawn last, above every shape, in the order
//! plotters gave it (nothing in the figure is meant to cover a label).

use std::fmt::Write as _;

use ab_glyph::{point, Font as _, FontRef, InvalidFont, OutlineCurve, Point};
use ab_glyph_rasterizer::Rasterizer;
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
    FontStyle, FontTransform,
};

/// The two faces the figure is set in.
pub struct Faces {
    regular: FontRef<'static>,
    bold: FontRef<'static>,
}

impl Faces {
    /// DejaVu Sans regular and bold, as the `dejavu` crate ships them.
    pub fn embedded() -> Result<Self, InvalidFont> {
        Ok(Self {
            regular: FontRef::try_from_slice(dejavu::sans::regular())?,
            bold: FontRef::try_from_slice(dejavu::sans::bold())?,
        })
    }

    fn face(&self, style: FontStyle) -> &FontRef<'static> {
        match style {
            FontStyle::Bold => &self.bold,
            _ => &self.regular,
        }
    }
}

/// Where the text of a [`Lettered`] backend goes.
pub enum Letters<'s> {
    /// Appended to this string as SVG `<path>` elements, one `<g>` per text
    /// (its `aria-label` the text itself, for readers and for search).
    Svg(&'s mut String),
    /// Filled into the backend's pixels.
    Pixels,
}

/// One text waiting to be drawn: its outline in backend pixels, its colour
/// and the text itself.
struct Run {
    curves: Vec<OutlineCurve>,
    color: BackendColor,
    text: String,
}

/// A plotters backend whose text is drawn from the glyph outlines of
/// [`Faces`] (see the module documentation).
pub struct Lettered<'f, 's, DB> {
    inner: DB,
    faces: &'f Faces,
    letters: Letters<'s>,
    runs: Vec<Run>,
}

impl<'f, 's, DB: DrawingBackend> Lettered<'f, 's, DB> {
    /// Wraps `inner`; its text goes to `letters`.
    pub fn new(inner: DB, faces: &'f Faces, letters: Letters<'s>) -> Self {
        Self {
            inner,
            faces,
            letters,
            runs: Vec::new(),
        }
    }

    /// Draws the waiting texts into the backend or the SVG string.
    fn flush(&mut self) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
        for run in std::mem::take(&mut self.runs) {
            match &mut self.letters {
                Letters::Svg(out) => svg_path(out, &run),
                Letters::Pixels => fill(&mut self.inner, &run)?,
            }
        }
        Ok(())
    }
}

/// The scale from font units to pixels for a text of `size` pixels: the
/// font's ascent to descent spans `size`.
fn scale(face: &FontRef<'_>, size: f64) -> f32 {
    size as f32 / face.height_unscaled()
}

/// The advance of every glyph of `text` (with kerning), in font units:
/// (glyph, pen position before it), and the whole width.
fn advances(face: &FontRef<'_>, text: &str) -> (Vec<(ab_glyph::GlyphId, f32)>, f32) {
    let mut pen = 0.0f32;
    let mut previous = None;
    let mut glyphs = Vec::new();
    for c in text.chars() {
        let id = face.glyph_id(c);
        if let Some(p) = previous {
            pen += face.kern_unscaled(p, id);
        }
        glyphs.push((id, pen));
        pen += face.h_advance_unscaled(id);
        previous = Some(id);
    }
    (glyphs, pen)
}

/// The width and height in pixels of `text` set horizontally.
fn extent(face: &FontRef<'_>, size: f64, text: &str) -> (f32, f32) {
    let s = scale(face, size);
    (advances(face, text).1 * s, face.height_unscaled() * s)
}

/// The outline of `text` in backend pixels (y down), anchored at `pos` the
/// way plotters anchors text: the anchor picks a point of the text's box,
/// the box is rotated about it.
fn layout(
    face: &FontRef<'_>,
    size: f64,
    text: &str,
    anchor: plotters_backend::text_anchor::Pos,
    transform: &FontTransform,
    pos: BackendCoord,
) -> Vec<OutlineCurve> {
    let s = scale(face, size);
    let (glyphs, width) = advances(face, text);
    let (width, height) = (width * s, face.height_unscaled() * s);
    let ascent = face.ascent_unscaled() * s;
    let dx = match anchor.h_pos {
        HPos::Left => 0.0,
        HPos::Center => -width / 2.0,
        HPos::Right => -width,
    };
    let dy = match anchor.v_pos {
        VPos::Top => 0.0,
        VPos::Center => -height / 2.0,
        VPos::Bottom => -height,
    };
    let (px, py) = (pos.0 as f32, pos.1 as f32);
    let place = |pen: f32, p: Point| -> Point {
        let x = (pen + p.x) * s + dx;
        let y = ascent - p.y * s + dy;
        let (x, y) = match transform {
            FontTransform::None => (x, y),
            FontTransform::Rotate90 => (-y, x),
            FontTransform::Rotate180 => (-x, -y),
            FontTransform::Rotate270 => (y, -x),
        };
        point(px + x, py + y)
    };
    let mut curves = Vec::new();
    for (id, pen) in glyphs {
        let Some(outline) = face.outline(id) else {
            continue;
        };
        curves.extend(outline.curves.iter().map(|c| match *c {
            OutlineCurve::Line(a, b) => OutlineCurve::Line(place(pen, a), place(pen, b)),
            OutlineCurve::Quad(a, b, c) => {
                OutlineCurve::Quad(place(pen, a), place(pen, b), place(pen, c))
            }
            OutlineCurve::Cubic(a, b, c, d) => {
                OutlineCurve::Cubic(place(pen, a), place(pen, b), place(pen, c), place(pen, d))
            }
        }));
    }
    curves
}

/// The first and last point of a curve.
fn ends(curve: &OutlineCurve) -> (Point, Point) {
    match *curve {
        OutlineCurve::Line(a, b)
        | OutlineCurve::Quad(a, _, b)
        | OutlineCurve::Cubic(a, _, _, b) => (a, b),
    }
}

/// `#rrggbb` of a colour.
pub fn hex(color: BackendColor) -> String {
    let (r, g, b) = color.rgb;
    format!("#{r:02x}{g:02x}{b:02x}")
}

/// Text escaped for an XML attribute.
pub fn xml_escaped(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            c if c.is_control() => {}
            c => out.push(c),
        }
    }
    out
}

/// Appends one text as an SVG group of one path (nonzero fill, so the
/// counters of `o` or `e` stay open as the font's contours wind).
fn svg_path(out: &mut String, run: &Run) {
    let mut d = String::new();
    let mut at: Option<Point> = None;
    for curve in &run.curves {
        let (start, end) = ends(curve);
        if at != Some(start) {
            if at.is_some() {
                d.push('Z');
            }
            let _ = write!(d, "M{:.2} {:.2}", start.x, start.y);
        }
        let _ = match *curve {
            OutlineCurve::Line(_, b) => write!(d, "L{:.2} {:.2}", b.x, b.y),
            OutlineCurve::Quad(_, c, b) => {
                write!(d, "Q{:.2} {:.2} {:.2} {:.2}", c.x, c.y, b.x, b.y)
            }
            OutlineCurve::Cubic(_, c1, c2, b) => write!(
                d,
                "C{:.2} {:.2} {:.2} {:.2} {:.2} {:.2}",
                c1.x, c1.y, c2.x, c2.y, b.x, b.y
            ),
        };
        at = Some(end);
    }
    if at.is_some() {
        d.push('Z');
    }
    let opacity = if run.color.alpha < 1.0 {
        format!(" fill-opacity=\"{:.3}\"", run.color.alpha)
    } else {
        String::new()
    };
    let _ = writeln!(
        out,
        "<g aria-label=\"{}\"><path fill=\"{}\"{opacity} d=\"{d}\"/></g>",
        xml_escaped(&run.text),
        hex(run.color),
    );
}

/// Fills one text into a backend's pixels, anti-aliased by coverage.
fn fill<DB: DrawingBackend>(
    backend: &mut DB,
    run: &Run,
) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
    let mut lo = point(f32::INFINITY, f32::INFINITY);
    let mut hi = point(f32::NEG_INFINITY, f32::NEG_INFINITY);
    for curve in &run.curves {
        let points: &[Point] = match curve {
            OutlineCurve::Line(a, b) => &[*a, *b],
            OutlineCurve::Quad(a, b, c) => &[*a, *b, *c],
            OutlineCurve::Cubic(a, b, c, d) => &[*a, *b, *c, *d],
        };
        for p in points {
            lo = point(lo.x.min(p.x), lo.y.min(p.y));
            hi = point(hi.x.max(p.x), hi.y.max(p.y));
        }
    }
    if !lo.x.is_finite() {
        return Ok(());
    }
    let origin = point(lo.x.floor(), lo.y.floor());
    let width = (hi.x.ceil() - origin.x) as usize + 1;
    let height = (hi.y.ceil() - origin.y) as usize + 1;
    let mut raster = Rasterizer::new(width, height);
    let at = |p: Point| point(p.x - origin.x, p.y - origin.y);
    for curve in &run.curves {
        match *curve {
            OutlineCurve::Line(a, b) => raster.draw_line(at(a), at(b)),
            OutlineCurve::Quad(a, b, c) => raster.draw_quad(at(a), at(b), at(c)),
            OutlineCurve::Cubic(a, b, c, d) => raster.draw_cubic(at(a), at(b), at(c), at(d)),
        }
    }
    let mut covered = Vec::new();
    raster.for_each_pixel_2d(|x, y, coverage| {
        if coverage > 0.0 {
            covered.push((x, y, coverage.min(1.0)));
        }
    });
    for (x, y, coverage) in covered {
        let color = BackendColor {
            alpha: run.color.alpha * f64::from(coverage),
            rgb: run.color.rgb,
        };
        backend.draw_pixel(
            (origin.x as i32 + x as i32, origin.y as i32 + y as i32),
            color,
        )?;
    }
    Ok(())
}

impl<DB: DrawingBackend> DrawingBackend for Lettered<'_, '_, DB> {
    type ErrorType = DB::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.flush()?;
        self.inner.present()
    }

    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_pixel(point, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_line(from, to, style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_path(path, style)
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.fill_polygon(vert, style)
    }

    fn draw_text<TStyle: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &TStyle,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 || text.is_empty() {
            return Ok(());
        }
        let face = self.faces.face(style.style());
        let curves = layout(
            face,
            style.size(),
            text,
            style.anchor(),
            &style.transform(),
            pos,
        );
        self.runs.push(Run {
            curves,
            color,
            text: text.to_string(),
        });
        Ok(())
    }

    fn estimate_text_size<TStyle: BackendTextStyle>(
        &self,
        text: &str,
        style: &TStyle,
    ) -> Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        let (w, h) = extent(self.faces.face(style.style()), style.size(), text);
        Ok((w.ceil() as u32, h.ceil() as u32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotters_backend::text_anchor::Pos;

    fn faces() -> Faces {
        Faces::embedded().unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn a_text_is_laid_out_inside_its_box_at_its_anchor() {
        let f = faces();
        let (w, h) = extent(&f.regular, 20.0, "KAS");
        assert!((h - 20.0).abs() < 1e-3, "{h}");
        assert!(w > 20.0 && w < 60.0, "{w}");
        let anchor = Pos::new(HPos::Left, VPos::Top);
        let curves = layout(
            &f.regular,
            20.0,
            "KAS",
            anchor,
            &FontTransform::None,
            (100, 50),
        );
        let points: Vec<Point> = curves.iter().flat_map(|c| [ends(c).0, ends(c).1]).collect();
        assert!(points.iter().all(|p| p.x >= 99.0 && p.x <= 100.0 + w + 1.0));
        assert!(points.iter().all(|p| p.y >= 50.0 && p.y <= 70.0));
        // Turned a quarter anticlockwise, the same text runs upwards from
        // the anchor.
        let turned = layout(
            &f.regular,
            20.0,
            "KAS",
            anchor,
            &FontTransform::Rotate270,
            (100, 50),
        );
        let points: Vec<Point> = turned.iter().flat_map(|c| [ends(c).0, ends(c).1]).collect();
        assert!(points.iter().all(|p| p.y <= 51.0 && p.y >= 50.0 - w - 1.0));
        assert!(points.iter().all(|p| p.x >= 99.0 && p.x <= 121.0));
    }

    #[test]
    fn an_svg_text_is_a_closed_path_named_by_its_text() {
        let f = faces();
        let anchor = Pos::new(HPos::Left, VPos::Top);
        let run = Run {
            curves: layout(&f.regular, 20.0, "o", anchor, &FontTransform::None, (0, 0)),
            color: BackendColor {
                alpha: 1.0,
                rgb: (0, 0, 0),
            },
            text: "a <b> & \"c\"".into(),
        };
        let mut out = String::new();
        svg_path(&mut out, &run);
        assert!(
            out.starts_with(
                "<g aria-label=\"a &lt;b&gt; &amp; &quot;c&quot;\"><path fill=\"#000000\" d=\"M"
            ),
            "{out}"
        );
        // "o" has two contours, its outside and its counter.
        assert_eq!(out.matches('M').count(), 2, "{out}");
        assert_eq!(out.matches('Z').count(), 2, "{out}");
    }
}
