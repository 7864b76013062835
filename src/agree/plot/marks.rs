//! What a panel shows, computed from its points before anything is drawn:
//! the columns of the human score, the jitter that spreads a column's
//! points, the box of each column, the least-squares line and the density
//! of points per cell. Pure arithmetic, so it is tested without a picture.

use crate::stats::rng::{below, stream};

/// More distinct human scores than this and the score is taken as
/// continuous (e.g. z-scores): boxes over [`BINS`] equal bins, no jitter.
const MAX_COLUMNS: usize = 25;
/// The bins of a continuous human score.
const BINS: usize = 10;
/// The share of the gap between two columns that jitter spreads over.
const SPREAD: f64 = 0.6;
/// The stream numbers of the jitter start here (panel `p` uses
/// `JITTER + p`), clear of the bootstrap's and the permutations'.
const JITTER: u64 = 1 << 62;

/// The columns of a panel: where each sits on the human axis, how wide it
/// is, and whether its points are spread sideways.
#[derive(Debug, Clone, PartialEq)]
pub struct Columns {
    /// The centre of each column, ascending.
    pub centers: Vec<f64>,
    /// The width a column's points (and its box) take.
    pub width: f64,
    /// Whether the points are jittered (a discrete score).
    pub jittered: bool,
}

impl Columns {
    /// The columns of these human scores (at least one).
    pub fn of(humans: &[f64]) -> Self {
        let mut distinct: Vec<f64> = humans.iter().copied().filter(|h| h.is_finite()).collect();
        distinct.sort_by(f64::total_cmp);
        distinct.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        if distinct.len() <= MAX_COLUMNS {
            let gap = distinct
                .windows(2)
                .map(|w| w[1] - w[0])
                .fold(1.0f64, f64::min);
            return Self {
                centers: distinct,
                width: gap * SPREAD,
                jittered: true,
            };
        }
        let (lo, hi) = (distinct[0], distinct[distinct.len() - 1]);
        let bin = (hi - lo) / BINS as f64;
        Self {
            centers: (0..BINS).map(|b| lo + bin * (b as f64 + 0.5)).collect(),
            width: bin * SPREAD,
            jittered: false,
        }
    }

    /// The column a human score belongs to (the nearest centre).
    pub fn index(&self, human: f64) -> usize {
        let mut best = 0;
        for (i, c) in self.centers.iter().enumerate() {
            if (human - c).abs() < (human - self.centers[best]).abs() {
                best = i;
            }
        }
        best
    }

    /// The horizontal position of each point: its human score, spread over
    /// the column's width by a uniform draw from ChaCha20 stream
    /// `JITTER + panel` under `seed` when the score is discrete, so the
    /// same seed draws the same figure.
    pub fn positions(&self, humans: &[f64], seed: u64, panel: u64) -> Vec<f64> {
        if !self.jittered {
            return humans.to_vec();
        }
        let mut rng = stream(seed, JITTER + panel);
        humans
            .iter()
            .map(|&h| {
                let u = below(&mut rng, 1 << 53) as f64 / (1u64 << 53) as f64;
                h + (u - 0.5) * self.width
            })
            .collect()
    }
}

/// A box of a box plot: quartiles and Tukey's whiskers (the furthest
/// values within 1.5 interquartile ranges of the box).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxStats {
    /// The lower end of the lower whisker.
    pub low: f64,
    /// The first quartile.
    pub q1: f64,
    /// The median.
    pub median: f64,
    /// The third quartile.
    pub q3: f64,
    /// The upper end of the upper whisker.
    pub high: f64,
}

/// The `q` quantile of sorted values, interpolated linearly between order
/// statistics (numpy's default, R's type 7).
fn quantile(sorted: &[f64], q: f64) -> f64 {
    let at = q * (sorted.len() - 1) as f64;
    let (i, frac) = (at.floor() as usize, at.fract());
    match sorted.get(i + 1) {
        Some(next) => sorted[i] + (next - sorted[i]) * frac,
        None => sorted[i],
    }
}

impl BoxStats {
    /// The box of some values; `None` when there are none.
    pub fn of(values: &[f64]) -> Option<Self> {
        let mut sorted: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        if sorted.is_empty() {
            return None;
        }
        sorted.sort_by(f64::total_cmp);
        let (q1, median, q3) = (
            quantile(&sorted, 0.25),
            quantile(&sorted, 0.5),
            quantile(&sorted, 0.75),
        );
        let reach = 1.5 * (q3 - q1);
        let inside = |v: &&f64| **v >= q1 - reach && **v <= q3 + reach;
        Some(Self {
            low: sorted.iter().find(inside).copied().unwrap_or(q1),
            q1,
            median,
            q3,
            high: sorted.iter().rev().find(inside).copied().unwrap_or(q3),
        })
    }
}

/// The least-squares line `value = intercept + slope * human`, as
/// (intercept, slope); `None` when the human scores do not vary.
pub fn least_squares(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    if points.len() < 2 {
        return None;
    }
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if sxx <= f64::EPSILON * n {
        return None;
    }
    let slope = sxy / sxx;
    Some((my - slope * mx, slope))
}

/// How many points fall in each square cell of a plotting area.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Density {
    /// The cell's side in pixels.
    pub cell: i32,
    /// Cells across.
    pub columns: usize,
    /// The count of every cell, row by row from the top.
    pub counts: Vec<u32>,
}

impl Density {
    /// Counts points given in pixels relative to the area's top left
    /// (`size` wide and high); points outside are not counted.
    pub fn of(pixels: impl IntoIterator<Item = (i32, i32)>, size: (i32, i32), cell: i32) -> Self {
        let cell = cell.max(1);
        let columns = (size.0.max(1) + cell - 1) / cell;
        let rows = (size.1.max(1) + cell - 1) / cell;
        let mut counts = vec![0u32; (columns * rows) as usize];
        for (x, y) in pixels {
            if x < 0 || y < 0 || x >= size.0 || y >= size.1 {
                continue;
            }
            counts[((y / cell) * columns + x / cell) as usize] += 1;
        }
        Self {
            cell,
            columns: columns as usize,
            counts,
        }
    }

    /// The most points in one cell.
    pub fn max(&self) -> u32 {
        self.counts.iter().copied().max().unwrap_or(0)
    }

    /// Every cell with points: (left, top) in pixels and its count.
    pub fn cells(&self) -> impl Iterator<Item = ((i32, i32), u32)> + '_ {
        self.counts
            .iter()
            .enumerate()
            .filter(|(_, &c)| c > 0)
            .map(|(i, &c)| {
                let (col, row) = ((i % self.columns) as i32, (i / self.columns) as i32);
                ((col * self.cell, row * self.cell), c)
            })
    }
}

/// The shade of a cell with `count` points when the densest has `max`:
/// light to dark blue on a log scale, so one point is still visible and a
/// thousand still differ from five hundred.
pub fn shade(count: u32, max: u32) -> (u8, u8, u8) {
    const LIGHT: [f64; 3] = [198.0, 219.0, 239.0];
    const DARK: [f64; 3] = [8.0, 48.0, 107.0];
    let t = if max <= 1 {
        1.0
    } else {
        (f64::from(count.max(1)).ln() / f64::from(max).ln()).clamp(0.0, 1.0)
    };
    let mix = |i: usize| (LIGHT[i] + (DARK[i] - LIGHT[i]) * t).round() as u8;
    (mix(0), mix(1), mix(2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn discrete_scores_make_jittered_columns_and_many_make_bins() {
        let thirds: Vec<f64> = (3..=15).map(|k| f64::from(k) / 3.0).collect();
        let c = Columns::of(&thirds);
        assert_eq!(c.centers.len(), 13);
        assert!(c.jittered);
        assert!((c.width - SPREAD / 3.0).abs() < 1e-12, "{}", c.width);
        assert_eq!(c.index(4.0 / 3.0 + 0.01), 1);
        let xs = c.positions(&thirds, 7, 0);
        assert_eq!(
            xs,
            c.positions(&thirds, 7, 0),
            "the same seed, the same jitter"
        );
        assert_ne!(xs, c.positions(&thirds, 8, 0));
        for (x, h) in xs.iter().zip(&thirds) {
            assert!((x - h).abs() <= c.width / 2.0, "{x} strays from {h}");
        }
        let one = Columns::of(&[3.0, 3.0]);
        assert_eq!((one.centers.clone(), one.width), (vec![3.0], SPREAD));

        let many: Vec<f64> = (0..100).map(|i| f64::from(i) / 10.0).collect();
        let c = Columns::of(&many);
        assert!(!c.jittered);
        assert_eq!(c.centers.len(), BINS);
        assert_eq!(c.positions(&many, 7, 0), many);
        assert_eq!(c.index(9.9), BINS - 1);
    }

    #[test]
    fn a_box_has_numpys_quartiles_and_tukeys_whiskers() {
        // numpy.percentile([1, 2, 3, 4, 100], [25, 50, 75]) = 2, 3, 4;
        // 100 lies beyond 4 + 1.5 * 2, so the whisker stops at 4.
        let b = BoxStats::of(&[100.0, 3.0, 1.0, 4.0, 2.0]).unwrap_or_else(|| panic!("a box"));
        assert_eq!(
            b,
            BoxStats {
                low: 1.0,
                q1: 2.0,
                median: 3.0,
                q3: 4.0,
                high: 4.0
            }
        );
        // numpy.percentile([1, 2, 3, 4], 25) = 1.75.
        let b = BoxStats::of(&[1.0, 2.0, 3.0, 4.0]).unwrap_or_else(|| panic!("a box"));
        assert_eq!((b.q1, b.median, b.q3), (1.75, 2.5, 3.25));
        assert_eq!(BoxStats::of(&[]), None);
    }

    #[test]
    fn the_line_is_least_squares_and_undefined_without_spread() {
        // y = 1 + 2x exactly, then one point off the line by +-1.
        let (a, b) = least_squares(&[(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)])
            .unwrap_or_else(|| panic!("a line"));
        assert!(
            (a - 1.0).abs() < 1e-12 && (b - 2.0).abs() < 1e-12,
            "{a} {b}"
        );
        // Hand-worked: x = 1, 2, 3; y = 1, 3, 2: slope 0.5, intercept 1.
        let (a, b) = least_squares(&[(1.0, 1.0), (2.0, 3.0), (3.0, 2.0)])
            .unwrap_or_else(|| panic!("a line"));
        assert!(
            (a - 1.0).abs() < 1e-12 && (b - 0.5).abs() < 1e-12,
            "{a} {b}"
        );
        assert_eq!(least_squares(&[(2.0, 1.0), (2.0, 3.0)]), None);
        assert_eq!(least_squares(&[(2.0, 1.0)]), None);
    }

    #[test]
    fn density_counts_points_per_cell_and_shades_on_a_log_scale() {
        let d = Density::of(
            [(0, 0), (3, 3), (4, 0), (9, 9), (10, 0), (-1, 0)],
            (10, 10),
            4,
        );
        assert_eq!(d.columns, 3);
        assert_eq!(d.counts, vec![2, 1, 0, 0, 0, 0, 0, 0, 1]);
        assert_eq!(d.max(), 2);
        let cells: Vec<_> = d.cells().collect();
        assert_eq!(cells, vec![((0, 0), 2), ((4, 0), 1), ((8, 8), 1)]);
        assert_eq!(shade(1, 1000), (198, 219, 239));
        assert_eq!(shade(1000, 1000), (8, 48, 107));
        let levels: std::collections::BTreeSet<_> = (1..=1000).map(|c| shade(c, 1000)).collect();
        assert!(levels.len() > 100, "{} shades", levels.len());
    }
}
