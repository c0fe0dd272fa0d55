//! The writer every report shares: one table written as CSV and as markdown, and one PNG with a
//! panel per plot. Every `robosim report …` command goes through
//! [`write_report`], so all reports look alike and regenerate the same way.
//!
//! Entry points: [`write_report`], [`percentile`].

use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A table: `rows[i][j]` is the cell of column `j`.
#[derive(Debug, Clone, Default)]
pub struct Table {
    pub columns: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

/// One line of a plot.
#[derive(Debug, Clone, Default)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// One panel.
#[derive(Debug, Clone, Default)]
pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
    pub series: Vec<Series>,
}

/// A whole report: `name` is the file stem.
#[derive(Debug, Clone, Default)]
pub struct Report {
    pub name: String,
    pub title: String,
    pub notes: Vec<String>,
    pub table: Table,
    pub plots: Vec<Plot>,
}

#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("cannot write {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("table row {row} has {got} cells, but there are {expected} columns")]
    RaggedRow {
        row: usize,
        got: usize,
        expected: usize,
    },
    #[error("cannot draw {path}: {message}")]
    Draw { path: PathBuf, message: String },
}

/// Writes `<dir>/<name>.csv`, `<dir>/<name>.md` (title, notes, markdown table, image link) and,
/// when there are plots, `<dir>/<name>.png` (one panel per plot). Creates `dir`. Returns the
/// paths written.
pub fn write_report(dir: &Path, report: &Report) -> Result<Vec<PathBuf>, ReportError> {
    let ncol = report.table.columns.len();
    for (row, cells) in report.table.rows.iter().enumerate() {
        if cells.len() != ncol {
            return Err(ReportError::RaggedRow {
                row,
                got: cells.len(),
                expected: ncol,
            });
        }
    }
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Io {
        path: dir.to_owned(),
        source,
    })?;
    let mut written = Vec::new();

    let csv_path = dir.join(format!("{}.csv", report.name));
    let mut csv = String::new();
    for line in std::iter::once(&report.table.columns).chain(&report.table.rows) {
        let cells: Vec<String> = line.iter().map(|c| csv_cell(c)).collect();
        csv.push_str(&cells.join(","));
        csv.push('\n');
    }
    write_file(&csv_path, csv.as_bytes())?;
    written.push(csv_path);

    let png_name = format!("{}.png", report.name);
    if !report.plots.is_empty() {
        let png_path = dir.join(&png_name);
        draw(&png_path, &report.plots)?;
        written.push(png_path);
    }

    let md_path = dir.join(format!("{}.md", report.name));
    let mut md = format!("# {}\n\n", report.title);
    for note in &report.notes {
        let _ = writeln!(md, "{note}\n");
    }
    let _ = writeln!(md, "| {} |", report.table.columns.join(" | "));
    let _ = writeln!(md, "|{}", "---|".repeat(ncol));
    for row in &report.table.rows {
        let cells: Vec<String> = row.iter().map(|c| c.replace('|', "\\|")).collect();
        let _ = writeln!(md, "| {} |", cells.join(" | "));
    }
    if !report.plots.is_empty() {
        let _ = writeln!(md, "\n![{}]({png_name})", report.title);
    }
    let _ = writeln!(md, "\nData: [{}.csv]({}.csv)", report.name, report.name);
    write_file(&md_path, md.as_bytes())?;
    written.push(md_path);
    Ok(written)
}

/// The `p`-th percentile (0–100, nearest rank) of `samples`; sorts them in place. NaN sorts last.
/// Returns NaN for an empty slice.
pub fn percentile(samples: &mut [f64], p: f64) -> f64 {
    if samples.is_empty() {
        return f64::NAN;
    }
    samples.sort_by(|a, b| a.total_cmp(b));
    let rank = ((p.clamp(0.0, 100.0) / 100.0) * samples.len() as f64).ceil() as usize;
    samples[rank.saturating_sub(1).min(samples.len() - 1)]
}

/// Every report output (PNG, CSV, markdown) by [`robosim_input::write_file_atomic`]: a link, a
/// FIFO or a device at `path` is refused, a crash leaves no half file.
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), ReportError> {
    robosim_input::write_file_atomic(path, bytes).map_err(|e| ReportError::Io {
        path: path.to_owned(),
        source: std::io::Error::other(e.problem),
    })
}

fn csv_cell(c: &str) -> String {
    if c.contains([',', '"', '\n']) {
        format!("\"{}\"", c.replace('"', "\"\""))
    } else {
        c.to_owned()
    }
}

const PANEL_W: u32 = 900;
const PANEL_H: u32 = 560;

fn draw(path: &Path, plots: &[Plot]) -> Result<(), ReportError> {
    let err = |e: &dyn std::fmt::Display| ReportError::Draw {
        path: path.to_owned(),
        message: e.to_string(),
    };
    crate::font::register_for_plots().map_err(|e| err(&e))?;
    let root =
        BitMapBackend::new(path, (PANEL_W, PANEL_H * plots.len() as u32)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let panels = root.split_evenly((plots.len(), 1));
    for (plot, area) in plots.iter().zip(panels.iter()) {
        draw_panel(plot, area).map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// Data range of the finite (and, on log axes, positive) points, padded.
fn range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return if log { (0.1, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        // From the decade at or below the padded minimum: the axis's labelled ticks are the
        // powers of ten in range, so data between 0.1 and 1 on an axis starting at 0.2 had no
        // tick below 1 (issue 39 item 8: "no y ticks below 1 µs").
        // (A hair below it: plotters finds the first tick as the ceiling of a logarithm, which
        // rounding can put a decade too high.)
        (
            10f64.powf((lo / 1.5).log10().floor()) * (1.0 - 1e-9),
            hi * 1.5,
        )
    } else if hi - lo < 1e-300 {
        (lo - 1.0, hi + 1.0)
    } else {
        let pad = 0.05 * (hi - lo);
        (lo - pad, hi + pad)
    }
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

fn draw_panel(plot: &Plot, area: &Area<'_>) -> Result<(), Box<dyn std::error::Error>> {
    let xs = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0));
    let ys = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1));
    let (x0, x1) = range(xs, plot.log_x);
    let (y0, y1) = range(ys, plot.log_y);
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(&plot.title, (crate::font::PLOT_FAMILY, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(80);
    // The four axis combinations have different coordinate types, hence the macro.
    macro_rules! body {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(plot.x_label.as_str())
                .y_desc(plot.y_label.as_str())
                .x_label_formatter(&|v| fmt_tick(*v))
                .y_label_formatter(&|v| fmt_tick(*v))
                .draw()?;
            for (i, s) in plot.series.iter().enumerate() {
                let color = Palette99::pick(i).to_rgba();
                let pts: Vec<(f64, f64)> = s
                    .points
                    .iter()
                    .copied()
                    .filter(|(x, y)| {
                        x.is_finite()
                            && y.is_finite()
                            && (!plot.log_x || *x > 0.0)
                            && (!plot.log_y || *y > 0.0)
                    })
                    .collect();
                chart
                    .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?
                    .label(s.label.as_str())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                    });
                chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 3, color.filled())))?;
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()?;
        }};
    }
    match (plot.log_x, plot.log_y) {
        (false, false) => body!(builder.build_cartesian_2d(x0..x1, y0..y1)?),
        (true, false) => body!(builder.build_cartesian_2d((x0..x1).log_scale(), y0..y1)?),
        (false, true) => body!(builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale())?),
        (true, true) => {
            body!(builder.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?)
        }
    }
    Ok(())
}

/// Angles in degrees over time, unwrapped: each point is moved by whole turns to within 180°
/// of the one before, so an angle that passes ±180° is drawn as the continuous curve it is,
/// not as a vertical line across the plot (issue 39 item 8, the station's gimbal angles).
/// Non-finite values are kept as they are and do not move the reference.
pub fn unwrap_degrees(points: &mut [(f64, f64)]) {
    let mut prev: Option<f64> = None;
    for p in points.iter_mut() {
        if !p.1.is_finite() {
            continue;
        }
        if let Some(q) = prev {
            p.1 -= 360.0 * ((p.1 - q) / 360.0).round();
        }
        prev = Some(p.1);
    }
}

/// A tick label: plain with up to 3 decimals in [0.01, 10⁴), else in exponent form with up to 3
/// significant digits (ticks 1.2e-5 apart must not all read "1e-5").
pub(crate) fn fmt_tick(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-2..1e4).contains(&a) {
        let s = format!("{v:.2e}");
        match s.split_once('e') {
            Some((m, e)) => {
                let m = m.trim_end_matches('0').trim_end_matches('.');
                format!("{m}e{e}")
            }
            None => s,
        }
    } else {
        format!("{v:.3}")
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 39 item 8: the station's gimbal angle crossing ±180° was drawn as a vertical line.
    #[test]
    fn unwrapped_angles_have_no_jump_of_half_a_turn() {
        let mut pts: Vec<(f64, f64)> = [170.0, 179.0, -178.0, -170.0, 175.0, f64::NAN, -175.0]
            .iter()
            .enumerate()
            .map(|(i, a)| (i as f64, *a))
            .collect();
        unwrap_degrees(&mut pts);
        let ys: Vec<f64> = pts.iter().map(|p| p.1).collect();
        assert_eq!(&ys[..5], &[170.0, 179.0, 182.0, 190.0, 175.0]);
        assert!(ys[5].is_nan());
        assert_eq!(ys[6], 185.0);
        // The same angles, modulo whole turns.
        for (a, b) in ys
            .iter()
            .zip([170.0, 179.0, -178.0, -170.0, 175.0, 0.0, -175.0])
        {
            if a.is_finite() {
                assert_eq!((a - b).rem_euclid(360.0), 0.0);
            }
        }
    }

    /// Issue 39 item 8: a log axis over 0.3 … 50 µs has a labelled tick below 1 µs.
    #[test]
    fn a_log_axis_has_a_tick_below_its_first_decade_of_data() {
        use plotters::coord::combinators::LogCoord;
        use plotters::coord::ranged1d::Ranged;
        let (lo, hi) = range([0.3, 2.0, 50.0].into_iter(), true);
        assert!(lo <= 0.1 && hi >= 50.0, "{lo} {hi}");
        let axis: LogCoord<f64> = (lo..hi).log_scale().into();
        let ticks = axis.key_points(12);
        assert!(ticks.iter().any(|t| *t < 1.0 && *t >= lo), "{ticks:?}");
        let (lo, _) = range([2.0, 3.0].into_iter(), true);
        assert!((lo - 1.0).abs() < 1e-8, "{lo}");
    }

    /// Issue 17 audit: the welding summary's error axis read "1e-5" at 1.0, 1.2 and 1.4 × 10⁻⁵.
    #[test]
    fn tick_labels_in_exponent_form_keep_the_digits_that_tell_them_apart() {
        let labels: Vec<String> = [1.0e-5, 1.2e-5, 1.4e-5, 8e-6, 2.5e6]
            .iter()
            .map(|v| fmt_tick(*v))
            .collect();
        assert_eq!(labels, ["1e-5", "1.2e-5", "1.4e-5", "8e-6", "2.5e6"]);
        assert_eq!(fmt_tick(0.0), "0");
        assert_eq!(fmt_tick(12.5), "12.5");
        assert_eq!(fmt_tick(-1.25e-3), "-1.25e-3");
    }

    #[test]
    fn writes_csv_markdown_and_png_that_say_what_was_given() {
        let dir = tempfile::tempdir().expect("temp dir");
        let report = Report {
            name: "t".into(),
            title: "Test".into(),
            notes: vec!["a note".into()],
            table: Table {
                columns: vec!["x".into(), "y, quoted".into()],
                rows: vec![vec!["1".into(), "2".into()]],
            },
            plots: vec![Plot {
                title: "p".into(),
                x_label: "x".into(),
                y_label: "y".into(),
                log_x: true,
                log_y: true,
                series: vec![Series {
                    label: "s".into(),
                    points: vec![(1.0, 1e-3), (10.0, 1e-6), (f64::NAN, 1.0)],
                }],
            }],
        };
        let paths = write_report(dir.path(), &report).expect("written");
        assert_eq!(paths.len(), 3);
        let csv = std::fs::read_to_string(dir.path().join("t.csv")).expect("csv");
        assert_eq!(csv, "x,\"y, quoted\"\n1,2\n");
        let md = std::fs::read_to_string(dir.path().join("t.md")).expect("md");
        assert!(md.contains("| 1 | 2 |") && md.contains("![Test](t.png)") && md.contains("a note"));
        let png = std::fs::read(dir.path().join("t.png")).expect("png");
        assert_eq!(&png[1..4], b"PNG");
    }

    /// Text is drawn with the bundled font (no system fonts): the same plot with another
    /// title and axis labels is another picture.
    #[test]
    fn plot_text_is_drawn_with_the_bundled_font() {
        let dir = tempfile::tempdir().expect("temp dir");
        let png = |name: &str, title: &str, label: &str| {
            let report = Report {
                name: name.into(),
                table: Table::default(),
                plots: vec![Plot {
                    title: title.into(),
                    x_label: label.into(),
                    y_label: label.into(),
                    series: vec![Series {
                        label: label.into(),
                        points: vec![(0.0, 0.0), (1.0, 1.0)],
                    }],
                    ..Plot::default()
                }],
                ..Report::default()
            };
            write_report(dir.path(), &report).expect("drawn");
            std::fs::read(dir.path().join(format!("{name}.png"))).expect("png")
        };
        let a = png("a", "Accuracy against time", "µs per step");
        assert_eq!(a, png("a2", "Accuracy against time", "µs per step"));
        assert_ne!(a, png("b", "", ""));
    }

    #[test]
    fn ragged_rows_are_refused_with_their_index() {
        let report = Report {
            name: "r".into(),
            table: Table {
                columns: vec!["a".into()],
                rows: vec![vec!["1".into()], vec![]],
            },
            ..Report::default()
        };
        let dir = tempfile::tempdir().expect("temp dir");
        assert!(matches!(
            write_report(dir.path(), &report),
            Err(ReportError::RaggedRow {
                row: 1,
                got: 0,
                expected: 1
            })
        ));
    }

    #[test]
    fn percentile_is_nearest_rank() {
        let mut v: Vec<f64> = (1..=100).rev().map(f64::from).collect();
        assert_eq!(percentile(&mut v, 50.0), 50.0);
        assert_eq!(percentile(&mut v, 99.0), 99.0);
        assert_eq!(percentile(&mut v, 100.0), 100.0);
        assert_eq!(percentile(&mut v, 0.0), 1.0);
    }
}
