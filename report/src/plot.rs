//! The writer every report shares: one table written as CSV and as markdown, and one PNG with a
//! panel per plot. Every `robosim report …` command goes through
//! [`write_report`], so all reports look alike and regenerate the same way.
//!
//! Entry points: [`write_report`], [`write_report_with_x_names`] (a plot whose x axis is a list
//! of named categories, its ticks the names), [`percentile`].

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
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

/// Why a report did not run to its end: the lower error kept whole (`#[source]`), its message
/// naming what was being built. [`run`] prefixes the report's name.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The report's files could not be written.
    #[error(transparent)]
    Write(#[from] ReportError),
    /// A solid of the measured scene was refused (`what`: which one).
    #[error("{what}: {source}")]
    Solid {
        what: &'static str,
        #[source]
        source: robosim_collision::ShapeError,
    },
    /// A robot's link solids could not be built (`what`: which robot).
    #[error("{what}'s link solids: {source}")]
    LinkSolids {
        what: &'static str,
        #[source]
        source: robosim_collision::robot::CheckError,
    },
    /// The dynamics refused a model or a simulation (`what`: which).
    #[error("{what}: {source}")]
    Dynamics {
        what: &'static str,
        #[source]
        source: robosim_dynamics::DynamicsError,
    },
    /// One integrator run of a measured fall failed (`run`: its label and setting).
    #[error("{run}: {source}")]
    DynamicsRun {
        run: String,
        #[source]
        source: robosim_dynamics::DynamicsError,
    },
    /// A simulator pipeline could not be built (`what`: the effect set's name).
    #[error("{what}: {source}")]
    Pipeline {
        what: String,
        #[source]
        source: robosim_simulator::EffectsError,
    },
    /// A simulator pipeline refused a command or a step.
    #[error(transparent)]
    Step(#[from] robosim_simulator::StepError),
    /// The library refused a source (`what`: which).
    #[error("{what}: {source}")]
    Library {
        what: &'static str,
        #[source]
        source: robosim_library::LibError,
    },
    /// The library could not evaluate a declaration (`what`: which).
    #[error("{what}: {source}")]
    Evaluate {
        what: &'static str,
        #[source]
        source: robosim_library::Error,
    },
    /// A built-in fault model does not load.
    #[error(transparent)]
    FaultModel(#[from] robosim_automation::model::ModelError),
    /// A condition the report checks did not hold (the message says which).
    #[error("{0}")]
    Condition(String),
}

impl From<String> for RunError {
    fn from(message: String) -> Self {
        RunError::Condition(message)
    }
}

impl From<&str> for RunError {
    fn from(message: &str) -> Self {
        RunError::Condition(message.to_string())
    }
}

/// Writes `<dir>/<name>.csv`, `<dir>/<name>.md` (title, notes, markdown table, image link) and,
/// when there are plots, `<dir>/<name>.png` (one panel per plot). Creates `dir`. Returns the
/// paths written.
pub fn write_report(dir: &Path, report: &Report) -> Result<Vec<PathBuf>, ReportError> {
    write_report_with_x_names(dir, report, &[])
}

/// [`write_report`] with named categories on x axes: plot `i`'s x values are the positions 1, 2,
/// … n of the n names `x_names[i]` (the effects report's configurations, say), and its x ticks
/// read those names — drawn upright, shortened in the middle when longer than
/// [`X_NAME_CHARS`] characters ([`short_x_name`]) — instead of numbers. A plot with no entry in
/// `x_names`, or an empty one, keeps its numeric x axis. (Beside [`Plot`] rather than in it, so
/// that the reports' many `Plot { … }` literals stay as they are.)
pub fn write_report_with_x_names(
    dir: &Path,
    report: &Report,
    x_names: &[Vec<String>],
) -> Result<Vec<PathBuf>, ReportError> {
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
        draw(&png_path, &report.plots, x_names)?;
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

/// Draws the panels one above the other; a panel with x names is taller by the height of its
/// upright names. Returns each panel's x tick labels as drawn, left to right.
pub(crate) fn draw(
    path: &Path,
    plots: &[Plot],
    x_names: &[Vec<String>],
) -> Result<Vec<Vec<String>>, ReportError> {
    let err = |e: &dyn std::fmt::Display| ReportError::Draw {
        path: path.to_owned(),
        message: e.to_string(),
    };
    crate::font::register_for_plots().map_err(|e| err(&e))?;
    let names: Vec<Option<Vec<String>>> = (0..plots.len())
        .map(|i| {
            let n = x_names.get(i).filter(|n| !n.is_empty())?;
            Some(n.iter().map(|s| short_x_name(s)).collect())
        })
        .collect();
    let heights: Vec<u32> = names
        .iter()
        .map(|n| PANEL_H + n.as_deref().map_or(0, |n| names_area(n) - X_LABEL_AREA))
        .collect();
    let root = BitMapBackend::new(path, (PANEL_W, heights.iter().sum())).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let breaks: Vec<i32> = heights
        .iter()
        .scan(0u32, |y, h| {
            *y += h;
            Some(*y as i32)
        })
        .take(plots.len().saturating_sub(1))
        .collect();
    let panels = root.split_by_breakpoints(Vec::<i32>::new(), breaks);
    let mut ticks = Vec::new();
    for ((plot, area), names) in plots.iter().zip(panels.iter()).zip(&names) {
        ticks.push(draw_panel(plot, names.as_deref(), area).map_err(|e| err(&e))?);
    }
    root.present().map_err(|e| err(&e))?;
    Ok(ticks)
}

/// The longest x name drawn whole; longer ones keep their start and end ([`short_x_name`]).
pub const X_NAME_CHARS: usize = 42;
/// Size of an x tick name, in pixels.
const X_NAME_FONT: u32 = 13;
/// The x label area (tick labels and the axis description) of a numeric axis.
const X_LABEL_AREA: u32 = 45;

/// An x tick name as drawn: `name` when at most [`X_NAME_CHARS`] characters long, else its
/// first and last whole words around "…" (the two ends tell similar long names apart better
/// than either), cut inside a word only when a word alone is too long.
pub fn short_x_name(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    if chars.len() <= X_NAME_CHARS {
        return name.to_owned();
    }
    // (the budget leaves room for "…" and the space each side of it)
    let budget = X_NAME_CHARS - 3;
    let word = |c: &char| c.is_alphanumeric();
    let mut head = budget / 2;
    if word(&chars[head - 1])
        && word(&chars[head])
        && let Some(gap) = chars[..head].iter().rposition(|c| !word(c))
    {
        head = gap;
    }
    let start: String = chars[..head].iter().collect();
    let start = start.trim_end_matches([' ', ',', ';']);
    let room = budget - start.chars().count();
    let mut tail = chars.len() - room;
    if word(&chars[tail - 1])
        && word(&chars[tail])
        && let Some(gap) = chars[tail..].iter().position(|c| !word(c))
    {
        tail += gap;
    }
    let end: String = chars[tail..].iter().collect();
    let end = end.trim_start_matches([' ', ',', ';']);
    format!("{start} … {end}")
}

/// Height of the x label area for upright `names`: the longest name, the axis description and
/// a margin.
fn names_area(names: &[String]) -> u32 {
    let longest = names.iter().map(|n| n.chars().count()).max().unwrap_or(0) as u32;
    // ~0.5 em per character of the bundled sans-serif font
    longest * X_NAME_FONT / 2 + 50
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

/// One panel; returns its x tick labels as drawn. With `names` (already shortened), the x axis
/// runs from 0.5 to n + 0.5, linear whatever `plot.log_x` says, and the tick at k reads the
/// k-th name.
fn draw_panel(
    plot: &Plot,
    names: Option<&[String]>,
    area: &Area<'_>,
) -> Result<Vec<String>, Box<dyn std::error::Error>> {
    let xs = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0));
    let ys = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1));
    let log_x = plot.log_x && names.is_none();
    let (x0, x1) = match names {
        Some(n) => (0.5, n.len() as f64 + 0.5),
        None => range(xs, log_x),
    };
    let (y0, y1) = range(ys, plot.log_y);
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(&plot.title, (crate::font::PLOT_FAMILY, 22))
        .margin(12)
        .x_label_area_size(names.map_or(X_LABEL_AREA, names_area))
        .y_label_area_size(80);
    // Numeric x tick labels as plotters asks for them while drawing; with names, the positions
    // plotters puts its ticks at (their labels left empty: the names are drawn below).
    let drawn = std::cell::RefCell::new(Vec::new());
    let tick_at = std::cell::RefCell::new(Vec::new());
    let x_tick = |v: &f64| -> String {
        match names {
            Some(n) => {
                let k = v.round();
                if (v - k).abs() < 1e-6 && k >= 1.0 && k <= n.len() as f64 {
                    tick_at.borrow_mut().push(k as usize);
                }
                String::new()
            }
            None => {
                let label = fmt_tick(*v);
                drawn.borrow_mut().push(label.clone());
                label
            }
        }
    };
    // Upright, reading downwards from just below the tick (plotters centres its own x labels
    // on the tick, which for upright text is across the axis).
    let names_style = TextStyle::from((crate::font::PLOT_FAMILY, X_NAME_FONT))
        .transform(FontTransform::Rotate90)
        .pos(Pos::new(HPos::Left, VPos::Center));
    // With names, every position gets its tick (plotters picks steps of 1, 2 or 5 of at most
    // this many ticks); else plotters' default.
    let x_ticks = names.map_or(11, |n| n.len() + 1);
    // The four axis combinations have different coordinate types, hence the macro.
    macro_rules! body {
        ($chart:expr) => {{
            let mut chart = $chart;
            let mut mesh = chart.configure_mesh();
            mesh.x_desc(plot.x_label.as_str())
                .y_desc(plot.y_label.as_str())
                .x_labels(x_ticks)
                .x_label_formatter(&x_tick)
                .y_label_formatter(&|v| fmt_tick(*v));
            if names.is_some() {
                mesh.axis_desc_style((crate::font::PLOT_FAMILY, 14));
            }
            mesh.draw()?;
            if let Some(n) = names {
                let (bx, by) = area.get_base_pixel();
                for k in tick_at.borrow().iter() {
                    let (px, py) = chart.backend_coord(&(*k as f64, y0));
                    let name = &n[k - 1];
                    area.draw_text(name, &names_style, (px - bx, py - by + 8))?;
                    drawn.borrow_mut().push(name.clone());
                }
            }
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
    match (log_x, plot.log_y) {
        (false, false) => body!(builder.build_cartesian_2d(x0..x1, y0..y1)?),
        (true, false) => body!(builder.build_cartesian_2d((x0..x1).log_scale(), y0..y1)?),
        (false, true) => body!(builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale())?),
        (true, true) => {
            body!(builder.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?)
        }
    }
    Ok(drawn.into_inner())
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

    /// Issue 39: the effects plot's x axis numbered its configurations ("1 = kinematics only");
    /// with x names, the ticks drawn are the names, in order, one per position (a long one
    /// shortened in the middle), and a panel without names keeps its numbers.
    #[test]
    fn named_x_ticks_are_the_names_in_order() {
        let names: Vec<String> = [
            "kinematics only",
            "kinematics, collision declared off",
            "+ joint limits",
            "+ collision bbox (self on)",
            "+ collision polygon (self on)",
            "+ collision exact (self on)",
            "+ collision exact, continuous",
            "+ dynamics rk4 1 ms (no collision)",
            "+ dynamics semi_implicit_euler 1 ms",
            "all: rk4 + limits + bbox + encoder + logging",
            "+ dynamics rk4 1 ms, robot with friction data, joint friction undeclared",
            "+ dynamics rk4 1 ms + joint friction (viscous, Coulomb stick-slip)",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let plot = Plot {
            title: "time per step by configuration".into(),
            x_label: "configuration".into(),
            y_label: "µs per step".into(),
            log_x: true,
            log_y: true,
            series: vec![Series {
                label: "median".into(),
                points: (1..=names.len())
                    .map(|k| (k as f64, 0.1 * (k * k) as f64))
                    .collect(),
            }],
        };
        let dir = tempfile::tempdir().expect("temp dir");
        let png = dir.path().join("named.png");
        let ticks = draw(&png, &[plot.clone(), plot], std::slice::from_ref(&names)).expect("drawn");
        let want: Vec<String> = names.iter().map(|n| short_x_name(n)).collect();
        assert_eq!(ticks[0], want);
        assert_eq!(ticks[0][0], "kinematics only");
        assert_eq!(ticks[0][3], "+ collision bbox (self on)");
        let long = &ticks[0][10];
        assert!(long.chars().count() <= X_NAME_CHARS, "{long}");
        assert_eq!(long, "+ dynamics rk4 1 ms … friction undeclared");
        assert_eq!(ticks[0][11], "+ dynamics rk4 1 ms … Coulomb stick-slip)");
        assert_eq!(ticks[0][9], "all: rk4 + limits + … + encoder + logging");
        assert_eq!(ticks[0][8], "+ dynamics semi_implicit_euler 1 ms");
        // the second panel (no names) is numeric, on its log axis
        assert!(!ticks[1].is_empty());
        assert!(
            ticks[1].iter().all(|t| t.parse::<f64>().is_ok()),
            "{:?}",
            ticks[1]
        );
        // the named panel is taller by its upright names
        let bytes = std::fs::read(&png).expect("png");
        let height = u32::from_be_bytes([bytes[20], bytes[21], bytes[22], bytes[23]]);
        assert_eq!(height, 2 * PANEL_H + names_area(&want) - X_LABEL_AREA);
    }

    /// A name without spaces is cut inside its one word; one of exactly the limit is whole.
    #[test]
    fn a_long_name_is_shortened_in_the_middle() {
        let whole = "x".repeat(X_NAME_CHARS);
        assert_eq!(short_x_name(&whole), whole);
        let word: String = ('a'..='z').cycle().take(60).collect();
        let short = short_x_name(&word);
        assert!(short.chars().count() <= X_NAME_CHARS, "{short}");
        let (start, end) = short.split_once(" … ").expect("elided");
        assert!(word.starts_with(start) && word.ends_with(end), "{short}");
        assert!(!start.is_empty() && !end.is_empty(), "{short}");
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
