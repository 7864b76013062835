//! The figure of `agree --plot`: one panel per metric against the human
//! score, as SVG or PNG, for a paper. Each panel shows the items as points
//! spread sideways within their human score (deterministic jitter) and
//! coloured by corruption kind, or past [`DENSITY_FROM`] points as shaded
//! cells counting them; a box per human score; the least-squares line with
//! the panel's tau-b; every metric axis runs from 0 to 1.
//!
//! Drawn with plotters; the text is set from the embedded font (DejaVu
//! Sans, shipped by the `dejavu` crate) as glyph outlines in both formats
//! (see [`lettering`]), so the SVG needs no font where it is viewed and no
//! font file lives in this repository.

mod lettering;
mod marks;

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle};

use self::lettering::{Faces, Lettered, Letters};
use self::marks::{least_squares, shade, BoxStats, Columns, Density};
use super::HumanAgreement;
use crate::stats::Estimate;

/// A panel with more points than this shows their density instead.
pub const DENSITY_FROM: usize = 2000;
/// The kind of an item that is no corruption.
pub const UNCORRUPTED: &str = "uncorrupted";
/// The default size in pixels and resolution.
pub const DEFAULT_SIZE: (u32, u32) = (1200, 900);
/// The default resolution: 96 dots per inch, the CSS pixel.
pub const DEFAULT_DPI: u32 = 96;
/// The figure's sides may be this long at most (pixels)...
const MAX_SIDE: u32 = 10_000;
/// ...and this short at least.
const MIN_SIDE: u32 = 200;
/// The resolutions a figure may have.
const DPI: std::ops::RangeInclusive<u32> = 24..=1200;
/// The metric axis: 0 to 1, a little margin so points on 0 and 1 show whole.
const METRIC_AXIS: std::ops::Range<f64> = -0.03..1.03;

/// The colours of the kinds, in order: Okabe and Ito's palette, which
/// readers with a colour-vision deficiency can tell apart; the first is
/// the uncorrupted items'.
const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(120, 120, 120),
];
/// The grid: darker lines at the labels, lighter ones between.
const GRID: RGBColor = RGBColor(205, 205, 205);
const GRID_LIGHT: RGBColor = RGBColor(235, 235, 235);
/// The boxes and the axes.
const INK: RGBColor = RGBColor(40, 40, 40);
/// The least-squares line.
const FIT: RGBColor = RGBColor(200, 20, 40);

/// Why the figure could not be written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The file name ends neither in `.svg` nor in `.png`.
    #[error("{0}: a figure is written as .svg or .png; name the file so")]
    Format(String),
    /// The size or resolution asked for is out of range.
    #[error(
        "a figure of {0}x{1} pixels at {2} dpi: each side must be {MIN_SIDE} to {MAX_SIDE} pixels and the resolution 24 to 1200 dpi"
    )]
    Size(u32, u32, u32),
    /// Drawing failed.
    #[error("drawing {path}: {message}")]
    Draw {
        /// The figure's file.
        path: String,
        /// What plotters said.
        message: String,
    },
    /// A file could not be written whole (see [`crate::fsutil`]).
    #[error(transparent)]
    Write(#[from] crate::fsutil::FsError),
}

/// The size and resolution of a figure, and the seed of its jitter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Width and height in pixels (the PNG's; the SVG's user units).
    pub size: (u32, u32),
    /// Dots per inch: the physical size is `size / dpi` inches, and text,
    /// lines and points are drawn `dpi / 96` times their size at 96 dpi.
    pub dpi: u32,
    /// The seed of the jitter (ChaCha20, as the resampling statistics).
    pub seed: u64,
}

impl Layout {
    /// A layout, refused when a side or the resolution is out of range.
    pub fn new(size: (u32, u32), dpi: u32, seed: u64) -> Result<Self, PlotError> {
        let side = MIN_SIDE..=MAX_SIDE;
        if !side.contains(&size.0) || !side.contains(&size.1) || !DPI.contains(&dpi) {
            return Err(PlotError::Size(size.0, size.1, dpi));
        }
        Ok(Self { size, dpi, seed })
    }

    /// `x` pixels at 96 dpi in this layout's pixels.
    fn px(&self, x: f64) -> u32 {
        (x * f64::from(self.dpi) / 96.0).round().max(1.0) as u32
    }
}

/// One point of a panel: an item's human score, its metric value and its
/// corruption kind.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    /// The item's human score.
    pub human: f64,
    /// The metric's value.
    pub value: f64,
    /// Its kind: the corruption's, or [`UNCORRUPTED`].
    pub kind: String,
}

/// One metric's panel.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// The metric's display name (PG2S, S_plan, S_goal, KAS).
    pub title: &'static str,
    /// Kendall's tau-b of the metric against the human score.
    pub tau_b: Estimate,
    /// The items compared.
    pub points: Vec<Point>,
}

/// What the figure shows, independent of how it is drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// The line above the panels.
    pub title: String,
    /// The name of the human axis.
    pub human_axis: String,
    /// The panels, in the order of [`super::METRICS`].
    pub panels: Vec<Panel>,
}

/// The name a paper gives a metric of [`super::METRICS`].
pub fn display_name(metric: &str) -> &'static str {
    match metric {
        "pg2s" => "PG2S",
        "s_plan" => "S_plan",
        "s_goal" => "S_goal",
        "kas" => "KAS",
        _ => "metric",
    }
}

impl Figure {
    /// The figure of an analysis; `kinds` maps the id of each corrupted
    /// item to its corruption's kind (the others are [`UNCORRUPTED`]).
    pub fn of(human: &HumanAgreement, kinds: &HashMap<String, String>) -> Self {
        Self {
            title: format!(
                "Metrics against the mean human rating ({} items, {} annotators)",
                human.items,
                human.annotators.len()
            ),
            human_axis: "mean human rating".into(),
            panels: human
                .metrics
                .iter()
                .map(|m| Panel {
                    title: display_name(m.metric),
                    tau_b: m.correlations.kendall_tau_b,
                    points: m
                        .points
                        .iter()
                        .zip(&m.point_items)
                        .map(|((human, value), item)| Point {
                            human: *human,
                            value: *value,
                            kind: kinds
                                .get(item)
                                .cloned()
                                .unwrap_or_else(|| UNCORRUPTED.into()),
                        })
                        .collect(),
                })
                .collect(),
        }
    }

    /// Every kind with its number of points in the fullest panel:
    /// uncorrupted first, then by name; past the palette the rarest share
    /// the last colour as "other kinds".
    fn kinds(&self) -> Vec<(String, usize)> {
        let mut most: BTreeMap<&str, usize> = BTreeMap::new();
        for panel in &self.panels {
            let mut here: BTreeMap<&str, usize> = BTreeMap::new();
            for p in &panel.points {
                *here.entry(&p.kind).or_default() += 1;
            }
            for (k, n) in here {
                let entry = most.entry(k).or_default();
                *entry = (*entry).max(n);
            }
        }
        let mut kinds: Vec<(String, usize)> =
            most.into_iter().map(|(k, n)| (k.to_string(), n)).collect();
        kinds.sort_by_key(|(k, _)| k != UNCORRUPTED);
        if kinds.len() > PALETTE.len() {
            let mut rest = kinds.split_off(PALETTE.len() - 1);
            rest.sort_by_key(|(_, n)| std::cmp::Reverse(*n));
            kinds.push(("other kinds".into(), rest.iter().map(|(_, n)| n).sum()));
        }
        kinds
    }

    /// Whether the figure shows density rather than points.
    fn dense(&self) -> bool {
        self.panels.iter().any(|p| p.points.len() > DENSITY_FROM)
    }
}

/// Draws the figure into `path` (`.svg` or `.png`), written atomically.
pub fn write_figure(figure: &Figure, layout: &Layout, path: &Path) -> Result<(), PlotError> {
    let name = path.display().to_string();
    let fail = |message: String| PlotError::Draw {
        path: name.clone(),
        message,
    };
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let bytes = match extension.as_deref() {
        Some("svg") => svg(figure, layout).map_err(fail)?.into_bytes(),
        Some("png") => png(figure, layout).map_err(fail)?,
        _ => return Err(PlotError::Format(name)),
    };
    Ok(crate::fsutil::write_atomic(path, &bytes)?)
}

/// The faces, also registered with plotters (whose own layout of a
/// multi-line text measures with them).
fn faces() -> Result<Faces, String> {
    register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "the embedded font is not a font".to_string())?;
    register_font("sans-serif", FontStyle::Bold, dejavu::sans::bold())
        .map_err(|_| "the embedded bold font is not a font".to_string())?;
    Faces::embedded().map_err(|e| e.to_string())
}

/// The figure as an SVG document whose size is given in inches.
fn svg(figure: &Figure, layout: &Layout) -> Result<String, String> {
    let faces = faces()?;
    let (w, h) = layout.size;
    let mut shapes = String::new();
    let mut letters = String::new();
    {
        let inner = SVGBackend::with_string(&mut shapes, layout.size);
        let root = Lettered::new(inner, &faces, Letters::Svg(&mut letters)).into_drawing_area();
        draw(figure, layout, &root)?;
        root.present().map_err(|e| e.to_string())?;
    }
    let inches = |px: u32| f64::from(px) / f64::from(layout.dpi);
    let header = format!("<svg width=\"{w}\" height=\"{h}\"");
    let sized = format!(
        "<svg width=\"{:.4}in\" height=\"{:.4}in\"",
        inches(w),
        inches(h)
    );
    let end = shapes
        .rfind("</svg>")
        .ok_or_else(|| "the SVG has no end".to_string())?;
    shapes.insert_str(end, &letters);
    Ok(shapes.replacen(&header, &sized, 1))
}

/// The figure as a PNG file that records its resolution.
fn png(figure: &Figure, layout: &Layout) -> Result<Vec<u8>, String> {
    let faces = faces()?;
    let (w, h) = layout.size;
    let mut rgb = vec![0u8; (w as usize) * (h as usize) * 3];
    {
        let inner = BitMapBackend::with_buffer(&mut rgb, layout.size);
        let root = Lettered::new(inner, &faces, Letters::Pixels).into_drawing_area();
        draw(figure, layout, &root)?;
        root.present().map_err(|e| e.to_string())?;
    }
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, w, h);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let per_metre = (f64::from(layout.dpi) / 0.0254).round() as u32;
        encoder.set_pixel_dims(Some(png::PixelDimensions {
            xppu: per_metre,
            yppu: per_metre,
            unit: png::Unit::Meter,
        }));
        let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
        writer.write_image_data(&rgb).map_err(|e| e.to_string())?;
        writer.finish().map_err(|e| e.to_string())?;
    }
    Ok(out)
}

/// The embedded face at `size` pixels at 96 dpi.
fn font(layout: &Layout, size: f64, style: FontStyle) -> TextStyle<'static> {
    let size = size * f64::from(layout.dpi) / 96.0;
    FontDesc::new(FontFamily::SansSerif, size, style).color(&BLACK)
}

/// The colour of each kind, by name.
fn colours(kinds: &[(String, usize)]) -> HashMap<String, RGBColor> {
    kinds
        .iter()
        .zip(PALETTE)
        .map(|((k, _), c)| (k.clone(), c))
        .collect()
}

/// Draws the title, the legend and the panels on any backend.
fn draw<DB: DrawingBackend>(
    figure: &Figure,
    layout: &Layout,
    root: &DrawingArea<DB, Shift>,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let title = font(layout, 24.0, FontStyle::Bold);
    let body = root.titled(&figure.title, title).map_err(e)?;
    let (strip, body) = body.split_vertically(layout.px(40.0));
    let kinds = figure.kinds();
    let colours = colours(&kinds);
    let cols = if figure.panels.len() > 1 { 2 } else { 1 };
    let rows = figure.panels.len().div_ceil(cols).max(1);
    let areas = body.split_evenly((rows, cols));
    let mut charts = Vec::new();
    for (panel, area) in figure.panels.iter().zip(&areas) {
        charts.push(frame(figure, panel, layout, area).map_err(e)?);
    }
    let dense = figure.dense();
    let cell = layout.px(4.0) as i32;
    let mut densities = Vec::new();
    for (p, (panel, chart)) in figure.panels.iter().zip(&charts).enumerate() {
        let columns = Columns::of(&panel.points.iter().map(|p| p.human).collect::<Vec<_>>());
        let xs = columns.positions(
            &panel.points.iter().map(|p| p.human).collect::<Vec<_>>(),
            layout.seed,
            p as u64,
        );
        let density = dense.then(|| {
            let (x0, y0) = chart.plotting_area().get_base_pixel();
            let (w, h) = chart.plotting_area().dim_in_pixel();
            Density::of(
                panel.points.iter().zip(&xs).map(|(pt, &x)| {
                    let (px, py) = chart.backend_coord(&(x, pt.value));
                    (px - x0, py - y0)
                }),
                (w as i32, h as i32),
                cell,
            )
        });
        densities.push((columns, xs, density));
    }
    let most = densities
        .iter()
        .filter_map(|(_, _, d)| d.as_ref().map(Density::max))
        .max()
        .unwrap_or(0);
    for ((panel, chart), (columns, xs, density)) in
        figure.panels.iter().zip(charts.iter_mut()).zip(&densities)
    {
        match density {
            Some(d) => {
                draw_cells(&chart.plotting_area().strip_coord_spec(), d, most).map_err(e)?;
            }
            None => {
                let r = layout.px(3.0);
                let mut order: Vec<usize> = (0..panel.points.len()).collect();
                order.sort_by_key(|&i| kinds.iter().position(|(k, _)| *k == panel.points[i].kind));
                chart
                    .draw_series(order.into_iter().map(|i| {
                        let pt = &panel.points[i];
                        let colour = colours.get(&pt.kind).copied().unwrap_or(PALETTE[6]);
                        Circle::new((xs[i], pt.value), r, colour.mix(0.6).filled())
                    }))
                    .map_err(e)?;
            }
        }
        overlays(panel, columns, layout, chart).map_err(e)?;
    }
    legend(&strip, layout, &kinds, &colours, dense.then_some(most)).map_err(e)
}

/// Density cells drawn on a plotting area in pixels, shaded against the
/// figure's densest cell `most`.
fn draw_cells<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    density: &Density,
    most: u32,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let side = density.cell;
    for ((x, y), count) in density.cells() {
        let (r, g, b) = shade(count, most);
        area.draw(&Rectangle::new(
            [(x, y), (x + side, y + side)],
            RGBColor(r, g, b).filled(),
        ))?;
    }
    Ok(())
}

type Chart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// A panel's caption, axes and grid.
fn frame<'a, DB: DrawingBackend>(
    figure: &Figure,
    panel: &Panel,
    layout: &Layout,
    area: &'a DrawingArea<DB, Shift>,
) -> Result<Chart<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    let humans: Vec<f64> = panel.points.iter().map(|p| p.human).collect();
    let (lo, hi) = human_range(&humans);
    let mut chart = ChartBuilder::on(area)
        .caption(panel.title, font(layout, 20.0, FontStyle::Bold))
        .margin(layout.px(12.0))
        .x_label_area_size(layout.px(44.0))
        .y_label_area_size(layout.px(52.0))
        .build_cartesian_2d(lo..hi, METRIC_AXIS)?;
    let integral = lo >= 0.5 && hi <= 5.5;
    let x_format = move |x: &f64| {
        if integral {
            format!("{x:.0}")
        } else {
            format!("{x:.1}")
        }
    };
    chart
        .configure_mesh()
        .bold_line_style(GRID.stroke_width(layout.px(1.0)))
        .light_line_style(GRID_LIGHT.stroke_width(layout.px(1.0)))
        .max_light_lines(1)
        .axis_style(INK.stroke_width(layout.px(1.0)))
        .x_labels(if integral { 5 } else { 8 })
        .y_labels(6)
        .x_label_formatter(&x_format)
        .y_label_formatter(&|y| format!("{y:.1}"))
        .x_desc(figure.human_axis.as_str())
        .y_desc(panel.title)
        .label_style(font(layout, 14.0, FontStyle::Normal))
        .axis_desc_style(font(layout, 16.0, FontStyle::Normal))
        .draw()?;
    Ok(chart)
}

/// The range of the human axis: the 1-5 scale when the scores lie on it,
/// else the scores' range with a margin.
fn human_range(humans: &[f64]) -> (f64, f64) {
    let (lo, hi) = humans
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &h| {
            (lo.min(h), hi.max(h))
        });
    if !lo.is_finite() || (lo >= 1.0 && hi <= 5.0) {
        return (0.6, 5.4);
    }
    let pad = if hi > lo { (hi - lo) * 0.06 } else { 0.5 };
    (lo - pad, hi + pad)
}

/// The boxes, the least-squares line and the panel's legend.
fn overlays<'a, DB: DrawingBackend + 'a>(
    panel: &Panel,
    columns: &Columns,
    layout: &Layout,
    chart: &mut Chart<'a, DB>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let mut by_column: Vec<Vec<f64>> = vec![Vec::new(); columns.centers.len()];
    for p in &panel.points {
        if let Some(c) = by_column.get_mut(columns.index(p.human)) {
            c.push(p.value);
        }
    }
    let half = columns.width / 2.0;
    let stroke = INK.stroke_width(layout.px(1.5));
    let mut shapes: Vec<PathElement<(f64, f64)>> = Vec::new();
    for (&c, values) in columns.centers.iter().zip(&by_column) {
        if values.len() < 5 {
            continue;
        }
        let Some(b) = BoxStats::of(values) else {
            continue;
        };
        let (l, r) = (c - half, c + half);
        shapes.push(PathElement::new(
            vec![(l, b.q1), (r, b.q1), (r, b.q3), (l, b.q3), (l, b.q1)],
            stroke,
        ));
        shapes.push(PathElement::new(
            vec![(l, b.median), (r, b.median)],
            INK.stroke_width(layout.px(3.0)),
        ));
        for (from, to) in [(b.q3, b.high), (b.q1, b.low)] {
            shapes.push(PathElement::new(vec![(c, from), (c, to)], stroke));
            shapes.push(PathElement::new(
                vec![(c - half / 2.0, to), (c + half / 2.0, to)],
                stroke,
            ));
        }
    }
    let key = layout.px(22.0) as i32;
    chart
        .draw_series(shapes)?
        .label("median, quartiles, 1.5 IQR (5+ items)")
        .legend(move |(x, y)| Rectangle::new([(x, y - key / 4), (x + key, y + key / 4)], stroke));
    let pairs: Vec<(f64, f64)> = panel.points.iter().map(|p| (p.human, p.value)).collect();
    let line = match (
        least_squares(&pairs),
        columns.centers.first(),
        columns.centers.last(),
    ) {
        (Some((a, b)), Some(&lo), Some(&hi)) => vec![(lo, a + b * lo), (hi, a + b * hi)],
        _ => Vec::new(),
    };
    let tau = match panel.tau_b {
        Ok(t) => format!("τb = {t:.3}"),
        Err(e) => format!("τb undefined: {e}"),
    };
    let fit = FIT.stroke_width(layout.px(2.5));
    chart
        .draw_series(std::iter::once(PathElement::new(line, fit)))?
        .label(format!("least squares; {tau}, n = {}", panel.points.len()))
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + key, y)], fit));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(GRID)
        .label_font(font(layout, 13.0, FontStyle::Normal))
        .legend_area_size(layout.px(30.0))
        .margin(layout.px(6.0))
        .draw()
}

/// The strip under the title: the colour of each kind with its count, or
/// with density the scale of the shading.
fn legend<DB: DrawingBackend>(
    strip: &DrawingArea<DB, Shift>,
    layout: &Layout,
    kinds: &[(String, usize)],
    colours: &HashMap<String, RGBColor>,
    density: Option<u32>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let style = font(layout, 15.0, FontStyle::Normal).pos(Pos::new(HPos::Left, VPos::Center));
    let (w, h) = strip.dim_in_pixel();
    let mid = h as i32 / 2;
    let gap = layout.px(24.0) as i32;
    let mark = layout.px(10.0) as i32;
    let entries: Vec<String> = match density {
        Some(most) => vec![
            "items per cell (log scale): 1".to_string(),
            format!("{most}"),
        ],
        None => kinds.iter().map(|(k, n)| format!("{k} ({n})")).collect(),
    };
    let bar = layout.px(200.0) as i32;
    let widths: Vec<i32> = entries
        .iter()
        .map(|t| strip.estimate_text_size(t, &style).map(|(w, _)| w as i32))
        .collect::<Result<_, _>>()?;
    let total: i32 = match density {
        Some(_) => widths.iter().sum::<i32>() + bar + 2 * mark,
        None => widths.iter().map(|w| w + 2 * mark + gap).sum::<i32>() - gap,
    };
    let mut x = (w as i32 - total).max(0) / 2;
    match density {
        Some(most) => {
            strip.draw(&Text::new(entries[0].clone(), (x, mid), style.clone()))?;
            x += widths[0] + mark;
            let steps = 32;
            for s in 0..steps {
                let count = (f64::from(most.max(1)).powf(f64::from(s) / f64::from(steps - 1)))
                    .round() as u32;
                let (r, g, b) = shade(count, most);
                let (x0, x1) = (x + bar * s / steps, x + bar * (s + 1) / steps);
                strip.draw(&Rectangle::new(
                    [(x0, mid - mark), (x1, mid + mark)],
                    RGBColor(r, g, b).filled(),
                ))?;
            }
            x += bar + mark;
            strip.draw(&Text::new(entries[1].clone(), (x, mid), style))?;
        }
        None => {
            for ((kind, _), (text, width)) in kinds.iter().zip(entries.iter().zip(&widths)) {
                let colour = colours.get(kind).copied().unwrap_or(PALETTE[6]);
                strip.draw(&Circle::new(
                    (x + mark / 2, mid),
                    layout.px(5.0),
                    colour.mix(0.8).filled(),
                ))?;
                x += 2 * mark;
                strip.draw(&Text::new(text.clone(), (x, mid), style.clone()))?;
                x += width + gap;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
