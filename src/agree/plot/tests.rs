use super::*;

use std::collections::BTreeSet;

/// A figure of `n` items per panel: human scores the means of three
/// ratings (13 columns), metric values rising with them plus a spread, every
/// seventh item a `drop`, every eleventh a `reorder`.
fn figure(n: usize) -> Figure {
    let panels = ["PG2S", "S_plan", "S_goal", "KAS"]
        .iter()
        .enumerate()
        .map(|(m, &title)| Panel {
            title,
            tau_b: if m == 3 {
                Err(crate::stats::Undefined::TooFewItems)
            } else {
                Ok(0.25 + m as f64 / 10.0)
            },
            points: (0..n)
                .map(|i| {
                    let human = 1.0 + ((i * 7 + m) % 13) as f64 / 3.0;
                    let spread = ((i * 2_654_435_761 + m * 97) % 1000) as f64 / 1000.0;
                    Point {
                        human,
                        value: ((human - 1.0) / 5.0 + spread * 0.3).clamp(0.0, 1.0),
                        kind: match (i % 7, i % 11) {
                            (0, _) => "drop".into(),
                            (_, 0) => "reorder".into(),
                            _ => UNCORRUPTED.into(),
                        },
                    }
                })
                .collect(),
        })
        .collect();
    Figure {
        title: format!("Metrics against the mean human rating ({n} items, 3 annotators)"),
        human_axis: "mean human rating".into(),
        panels,
    }
}

fn layout() -> Layout {
    Layout::new(DEFAULT_SIZE, DEFAULT_DPI, 0).unwrap_or_else(|e| panic!("{e}"))
}

fn decode(png: &[u8]) -> image::RgbImage {
    image::load_from_memory(png)
        .unwrap_or_else(|e| panic!("{e}"))
        .to_rgb8()
}

#[test]
fn the_svg_sets_its_text_as_outlines_named_for_readers() {
    let (fig, layout) = (figure(300), layout());
    let doc = svg(&fig, &layout).unwrap_or_else(|e| panic!("{e}"));
    assert!(!doc.contains("<text"), "no text element needs a font");
    assert!(doc.starts_with("<svg width=\"12.5000in\" height=\"9.3750in\""));
    for label in [
        "PG2S",
        "S_plan",
        "S_goal",
        "KAS",
        "mean human rating",
        "Metrics against the mean human rating (300 items, 3 annotators)",
        "uncorrupted (233)",
        "drop (43)",
        "reorder (24)",
        "least squares; τb = 0.250, n = 300",
        "least squares; τb undefined: fewer than two items, n = 300",
        "median, quartiles, 1.5 IQR (5+ items)",
    ] {
        let named = format!("aria-label=\"{label}\"");
        assert!(doc.contains(&named), "{label:?} is not drawn");
    }
    // The PNG sets the same outlines (compared pixel by pixel with the
    // SVG drawn without fonts in tests/it/cli_agree.rs).
    let picture = decode(&png(&fig, &layout).unwrap_or_else(|e| panic!("{e}")));
    let dark = picture
        .pixels()
        .filter(|p| p.0.iter().all(|&c| c < 60))
        .count();
    assert!(
        dark > 2000,
        "the title and labels are drawn ({dark} dark pixels)"
    );
}

#[test]
fn ten_thousand_items_shade_their_densest_column_in_eight_levels_or_more() {
    let (fig, layout) = (figure(10_000), layout());
    let picture = decode(&png(&fig, &layout).unwrap_or_else(|e| panic!("{e}")));
    // The shading is blue; text, grid and boxes are grey, the line red.
    let shaded = |p: &image::Rgb<u8>| {
        let [r, g, b] = p.0;
        i32::from(b) > i32::from(r) + 30 && b > g
    };
    let (w, h) = picture.dimensions();
    let densest = (0..w)
        .max_by_key(|&x| (0..h).filter(|&y| shaded(picture.get_pixel(x, y))).count())
        .unwrap_or(0);
    let levels: BTreeSet<u8> = (0..h)
        .map(|y| picture.get_pixel(densest, y))
        .filter(|p| shaded(p))
        .map(|p| {
            let [r, g, b] = p.0;
            ((u32::from(r) * 299 + u32::from(g) * 587 + u32::from(b) * 114) / 1000 / 4) as u8
        })
        .collect();
    assert!(
        levels.len() >= 8,
        "column {densest} shows {} levels: {levels:?}",
        levels.len()
    );
    let doc = svg(&fig, &layout).unwrap_or_else(|e| panic!("{e}"));
    assert!(doc.contains("aria-label=\"items per cell (log scale): 1\""));
    assert!(!doc.contains("<circle"), "no points past {DENSITY_FROM}");
}

#[test]
fn size_and_resolution_set_the_pixels_and_the_inches() {
    let fig = figure(50);
    let big = Layout::new((1800, 1200), 192, 0).unwrap_or_else(|e| panic!("{e}"));
    let bytes = png(&fig, &big).unwrap_or_else(|e| panic!("{e}"));
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let reader = decoder.read_info().unwrap_or_else(|e| panic!("{e}"));
    let info = reader.info();
    assert_eq!((info.width, info.height), (1800, 1200));
    let dims = info.pixel_dims.unwrap_or_else(|| panic!("a pHYs chunk"));
    assert_eq!((dims.xppu, dims.unit), (7559, png::Unit::Meter));
    let doc = svg(&fig, &big).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        doc.starts_with("<svg width=\"9.3750in\" height=\"6.2500in\""),
        "{}",
        &doc[..80]
    );
    assert!(doc.contains("viewBox=\"0 0 1800 1200\""));
    for refused in [(100, 900), (1200, 20_000)] {
        assert!(matches!(
            Layout::new(refused, 96, 0),
            Err(PlotError::Size(..))
        ));
    }
    assert!(Layout::new((1200, 900), 5000, 0).is_err());
}

#[test]
fn the_figure_of_an_analysis_names_kinds_and_metrics_for_a_paper() {
    assert_eq!(
        crate::agree::METRICS.map(display_name),
        ["PG2S", "S_plan", "S_goal", "KAS"]
    );
    let many: Vec<Panel> = vec![Panel {
        title: "PG2S",
        tau_b: Ok(0.5),
        points: (0..20)
            .map(|i| Point {
                human: 3.0,
                value: 0.5,
                kind: format!("kind{}", i % 10),
            })
            .collect(),
    }];
    let fig = Figure {
        title: String::new(),
        human_axis: String::new(),
        panels: many,
    };
    let kinds = fig.kinds();
    assert_eq!(kinds.len(), PALETTE.len(), "{kinds:?}");
    assert_eq!(kinds[PALETTE.len() - 1], ("other kinds".to_string(), 8));
}
