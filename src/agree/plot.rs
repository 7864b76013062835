//! The figure of `agree --plot`: one scatter plot per metric against the
//! human score, as SVG or PNG, drawn with plotters and an embedded font
//! (DejaVu Sans, shipped by the `dejavu` crate), so no system font library
//! is needed and no font file lives in this repository.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

use super::{HumanAgreement, MetricAgreement};

/// The figure's size in pixels.
const SIZE: (u32, u32) = (1200, 900);

/// Why the figure could not be written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The file name ends neither in `.svg` nor in `.png`.
    #[error("{0}: a figure is written as .svg or .png; name the file so")]
    Format(String),
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

/// Draws every metric's scatter plot into `path` (`.svg` or `.png`),
/// written atomically.
pub fn write_figure(human: &HumanAgreement, path: &Path) -> Result<(), PlotError> {
    let name = path.display().to_string();
    let fail = |message: String| PlotError::Draw {
        path: name.clone(),
        message,
    };
    register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| fail("the embedded font is not a font".into()))?;
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let bytes = match extension.as_deref() {
        Some("svg") => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
                draw(human, &root).map_err(&fail)?;
                root.present().map_err(|e| fail(e.to_string()))?;
            }
            svg.into_bytes()
        }
        Some("png") => {
            let mut rgb = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
            {
                let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
                draw(human, &root).map_err(&fail)?;
                root.present().map_err(|e| fail(e.to_string()))?;
            }
            let image = image::RgbImage::from_raw(SIZE.0, SIZE.1, rgb)
                .ok_or_else(|| fail("the picture has the wrong size".into()))?;
            let mut png = std::io::Cursor::new(Vec::new());
            image
                .write_to(&mut png, image::ImageFormat::Png)
                .map_err(|e| fail(e.to_string()))?;
            png.into_inner()
        }
        _ => return Err(PlotError::Format(name)),
    };
    Ok(crate::fsutil::write_atomic(path, &bytes)?)
}

/// Draws the 2 × 2 grid of scatter plots on any backend.
fn draw<DB: DrawingBackend>(
    human: &HumanAgreement,
    root: &DrawingArea<DB, Shift>,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let title = format!(
        "Metrics against the mean human rating ({} items, {} annotators)",
        human.items,
        human.annotators.len()
    );
    let body = root
        .titled(&title, ("sans-serif", 26))
        .map_err(|e| e.to_string())?;
    for (metric, area) in human.metrics.iter().zip(body.split_evenly((2, 2))) {
        panel(metric, &area).map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// One metric's scatter plot.
fn panel<DB: DrawingBackend>(
    m: &MetricAgreement,
    area: &DrawingArea<DB, Shift>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (h_lo, h_hi) = bounds(m.points.iter().map(|p| p.0), (1.0, 5.0));
    let (v_lo, v_hi) = bounds(m.points.iter().map(|p| p.1), (0.0, 1.0));
    let tau = match m.correlations.kendall_tau_b {
        Ok(t) => format!("τb = {t:.3}"),
        Err(_) => "τb undefined".to_string(),
    };
    let caption = format!("{} ({tau}, n = {})", m.metric, m.points.len());
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(56)
        .build_cartesian_2d(h_lo..h_hi, v_lo..v_hi)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .x_desc("mean human rating")
        .y_desc(m.metric)
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .draw()?;
    chart.draw_series(
        m.points
            .iter()
            .map(|&(h, v)| Circle::new((h, v), 4, BLUE.mix(0.35).filled())),
    )?;
    Ok(())
}

/// The axis range of some values, with a margin; `fallback` when there are none.
fn bounds(values: impl Iterator<Item = f64>, fallback: (f64, f64)) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if !lo.is_finite() {
        return fallback;
    }
    let pad = if hi > lo { (hi - lo) * 0.05 } else { 0.5 };
    (lo - pad, hi + pad)
}
