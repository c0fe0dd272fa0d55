//! `robosim plot RUN.mcap|RUN.csv --out DIR`: figures of a user's own run.
//!
//! Input: a recording ([`robosim_record::read::read_run`]: a simulator run's `--record` file
//! or a playback) or the simulator's signal log (`<session>/run/simulator-<robot>.csv`, columns
//! `t_s`, `q1_rad`, `qd1_rad_s`, `tau1_Nm`, …, `contact`; see the simulator's logging stage).
//!
//! Output, in `DIR`:
//! * `<robot>.png` per robot — one panel per signal the run has: joint positions, measured
//!   positions, velocities, accelerations, efforts, and the **actuator work** `W(t) = ∫ Σ τ_j
//!   q̇_j dt` (J; trapezoidal rule over the samples) when both efforts and velocities are
//!   there: the energy the joints put into the robot, the one energy a run's joint states
//!   determine without the robot's model;
//! * `contacts.png` — each robot's contact verdict (1 = the step's check found a contact);
//! * the run's events (contact begins/ends, commands, refusals) as vertical lines on every
//!   panel, coloured by level (info grey, warning orange, error red);
//! * `plot.json` — what each figure holds (panels, series, axis ranges, points drawn) and the
//!   events, for scripts and tests.
//!
//! Series longer than [`MAX_POINTS`] are drawn from their minimum and maximum per bucket
//! (every peak kept), so a 10⁶-sample run draws as fast as a short one. The figure's axis
//! ranges are those of the data, not of the decimated points.
//!
//! Entry points: [`plot_file`], [`PlotSummary`].

use plotters::prelude::*;
use robosim_record::Level;
use robosim_record::read::{Run, read_run};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// Points per series above which a series is drawn from its per-bucket extremes.
pub const MAX_POINTS: usize = 4000;

/// Why a run could not be plotted: the file and what went wrong.
#[derive(Debug, thiserror::Error)]
pub enum RunPlotError {
    #[error(transparent)]
    Record(#[from] robosim_record::RecordError),
    #[error("{path}: {what}")]
    Csv { path: PathBuf, what: String },
    #[error("{path}: nothing to plot ({what})")]
    Empty { path: PathBuf, what: String },
    #[error("cannot write {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot draw {path}: {message}")]
    Draw { path: PathBuf, message: String },
}

/// One line of a panel.
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// One panel of a figure: time on x.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    pub title: String,
    pub y_label: String,
    pub lines: Vec<Line>,
}

/// One event line.
#[derive(Debug, Clone, PartialEq)]
pub struct Mark {
    pub t: f64,
    pub level: Option<Level>,
    pub text: String,
}

/// One PNG: its file name in the output directory and its panels.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    pub file: String,
    pub title: String,
    pub panels: Vec<Panel>,
}

/// What `plot_file` drew (also written as `plot.json`).
#[derive(Debug, Clone, PartialEq)]
pub struct PlotSummary {
    pub source: PathBuf,
    /// The recording ends inside a record (its writer was stopped): read to the cut.
    pub truncated: bool,
    pub figures: Vec<Figure>,
    pub events: Vec<Mark>,
    /// Paths written (PNGs, then plot.json).
    pub written: Vec<PathBuf>,
}

/// Reads `run` (MCAP by its magic, else the simulator's CSV signal log), draws its figures
/// into `out` (created) and returns what was drawn. A bar on standard error follows a long
/// file (see [`crate::progress`]).
pub fn plot_file(run: &Path, out: &Path) -> Result<PlotSummary, RunPlotError> {
    let head = read_head(run)?;
    let (figures, events, truncated) = if head.starts_with(robosim_record::MCAP_MAGIC) {
        let pb = crate::progress::bar(0, "plot");
        let r = read_run(run, &mut |done, total| {
            if total > 0 {
                pb.set_length(total);
            }
            pb.set_position(done);
        });
        pb.finish_and_clear();
        let r = r?;
        let (f, e) = figures_of_run(&r);
        (f, e, r.truncated)
    } else {
        (figures_of_csv(run)?, Vec::new(), false)
    };
    if figures.iter().all(|f| f.panels.is_empty()) {
        return Err(RunPlotError::Empty {
            path: run.to_owned(),
            what: "no joint states, contacts or signal columns".into(),
        });
    }
    std::fs::create_dir_all(out).map_err(|source| RunPlotError::Io {
        path: out.to_owned(),
        source,
    })?;
    let mut written = Vec::new();
    for f in &figures {
        let path = out.join(&f.file);
        draw(&path, f, &events)?;
        written.push(path);
    }
    let summary = PlotSummary {
        source: run.to_owned(),
        truncated,
        figures,
        events,
        written,
    };
    let json_path = out.join("plot.json");
    let text = serde_json::to_string_pretty(&summary_json(&summary)).unwrap_or_default();
    robosim_input::write_file_atomic(&json_path, text.as_bytes()).map_err(|e| {
        RunPlotError::Io {
            path: json_path.clone(),
            source: std::io::Error::other(e.problem),
        }
    })?;
    let mut summary = summary;
    summary.written.push(json_path);
    Ok(summary)
}

/// `robosim plot RUN --out DIR`: [`plot_file`], then one line per figure written and the
/// events marked, on standard output.
pub fn plot_and_say(run: &Path, out: &Path) -> Result<PlotSummary, RunPlotError> {
    let s = plot_file(run, out)?;
    if s.truncated {
        println!(
            "{}: the recording ends inside a record (its writer was stopped); plotted to the cut",
            run.display()
        );
    }
    for f in &s.figures {
        let series: usize = f.panels.iter().map(|p| p.lines.len()).sum();
        println!(
            "wrote {} ({} panels, {series} series)",
            out.join(&f.file).display(),
            f.panels.len()
        );
    }
    println!(
        "wrote {} ({} events marked)",
        out.join("plot.json").display(),
        s.events.len()
    );
    Ok(s)
}

fn read_head(path: &Path) -> Result<Vec<u8>, RunPlotError> {
    use std::io::Read;
    let io = |source| RunPlotError::Io {
        path: path.to_owned(),
        source,
    };
    let mut f = std::fs::File::open(path).map_err(io)?;
    let mut head = vec![0u8; 8];
    let n = f.read(&mut head).map_err(io)?;
    head.truncate(n);
    Ok(head)
}

/// Per-joint series: `rows[k][j]` at `t[k]` as one line per joint j (rows of another length,
/// e.g. empty velocities of a playback, are skipped).
fn joint_lines(joints: &[String], t: &[f64], rows: &[Vec<f64>]) -> Vec<Line> {
    (0..joints.len())
        .map(|j| Line {
            label: joints[j].clone(),
            points: t
                .iter()
                .zip(rows)
                .filter(|(_, r)| r.len() == joints.len())
                .map(|(&t, r)| (t, r[j]))
                .collect(),
        })
        .filter(|l| !l.points.is_empty())
        .collect()
}

/// `W(t) = ∫ Σ τ q̇ dt` by the trapezoidal rule over the samples that have both.
fn actuator_work(t: &[f64], qd: &[Vec<f64>], tau: &[Vec<f64>]) -> Line {
    let mut points = Vec::new();
    let mut w = 0.0;
    let mut prev: Option<(f64, f64)> = None;
    for ((&t, v), f) in t.iter().zip(qd).zip(tau) {
        if v.is_empty() || v.len() != f.len() {
            continue;
        }
        let p: f64 = v.iter().zip(f).map(|(a, b)| a * b).sum();
        if let Some((t0, p0)) = prev {
            w += 0.5 * (p + p0) * (t - t0);
        }
        prev = Some((t, p));
        points.push((t, w));
    }
    Line {
        label: "W = ∫ Σ τ·q̇ dt".into(),
        points,
    }
}

fn panel(title: &str, y_label: &str, lines: Vec<Line>) -> Option<Panel> {
    (!lines.is_empty()).then(|| Panel {
        title: title.into(),
        y_label: y_label.into(),
        lines,
    })
}

/// A file name made of a robot's name: characters other than letters, digits, `-` and `_`
/// become `_`.
fn file_stem(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

fn figures_of_run(run: &Run) -> (Vec<Figure>, Vec<Mark>) {
    let mut figures = Vec::new();
    for r in &run.robots {
        let panels = [
            panel(
                "joint positions",
                "q (rad | m)",
                joint_lines(&r.joints, &r.t, &r.position),
            ),
            panel(
                "joint velocities",
                "q̇ (rad/s | m/s)",
                joint_lines(&r.joints, &r.t, &r.velocity),
            ),
            panel(
                "joint efforts",
                "τ (N·m | N)",
                joint_lines(&r.joints, &r.t, &r.effort),
            ),
            {
                let w = actuator_work(&r.t, &r.velocity, &r.effort);
                panel(
                    "actuator work",
                    "W (J)",
                    if w.points.len() > 1 { vec![w] } else { vec![] },
                )
            },
        ];
        figures.push(Figure {
            file: format!("{}.png", file_stem(&r.name)),
            title: format!("robot {}", r.name),
            panels: panels.into_iter().flatten().collect(),
        });
    }
    if !run.contacts.is_empty() {
        let lines = run
            .contacts
            .iter()
            .map(|c| Line {
                label: c.robot.clone(),
                points: c
                    .t
                    .iter()
                    .zip(&c.contact)
                    .map(|(&t, &b)| (t, if b { 1.0 } else { 0.0 }))
                    .collect(),
            })
            .collect();
        figures.push(Figure {
            file: "contacts.png".into(),
            title: "contacts".into(),
            panels: panel("contact verdict per step", "contact (1 = yes)", lines)
                .into_iter()
                .collect(),
        });
    }
    let events = run
        .events
        .iter()
        .map(|e| Mark {
            t: e.t,
            level: e.level,
            text: if e.name.is_empty() {
                e.message.clone()
            } else {
                format!("{}: {}", e.name, e.message)
            },
        })
        .collect();
    (figures, events)
}

/// The simulator's signal log: `t_s` first, then `<signal><j>_<unit>` columns and `contact`.
fn figures_of_csv(path: &Path) -> Result<Vec<Figure>, RunPlotError> {
    let log = SignalLog::read(path)?;
    let (mut panels, taken) = joint_panels(&log);
    panels.extend(actuator_work_panel(&log));
    panels.extend(other_panels(&log, &taken));
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("run")
        .to_owned();
    let robot = stem.strip_prefix("simulator-").unwrap_or(&stem);
    Ok(vec![Figure {
        file: format!("{}.png", file_stem(robot)),
        title: format!("robot {robot} ({})", path.display()),
        panels,
    }])
}

/// A simulator signal log: its header (`t_s` first) and one column of numbers per header cell.
struct SignalLog {
    header: Vec<String>,
    columns: Vec<Vec<f64>>,
}

impl SignalLog {
    /// Reads and checks the CSV at `path` (every line as many numbers as the header has cells).
    fn read(path: &Path) -> Result<Self, RunPlotError> {
        let bad = |what: String| RunPlotError::Csv {
            path: path.to_owned(),
            what,
        };
        let text = std::fs::read_to_string(path).map_err(|source| RunPlotError::Io {
            path: path.to_owned(),
            source,
        })?;
        let mut lines = text.lines().enumerate();
        let header: Vec<String> = lines
            .next()
            .map(|(_, h)| h.split(',').map(|c| c.trim().to_owned()).collect())
            .ok_or_else(|| bad("empty file".into()))?;
        if header.first().map(String::as_str) != Some("t_s") {
            return Err(bad(format!(
                "the first column is {:?}, not t_s: not a simulator signal log (or an MCAP recording)",
                header.first().map_or("", String::as_str)
            )));
        }
        let mut columns: Vec<Vec<f64>> = vec![Vec::new(); header.len()];
        let pb = crate::progress::bar(text.len() as u64, "plot");
        let mut read = header.iter().map(|h| h.len() + 1).sum::<usize>() as u64;
        for (i, line) in lines {
            read += line.len() as u64 + 1;
            if i % 4096 == 0 {
                pb.set_position(read);
            }
            if line.trim().is_empty() {
                continue;
            }
            let cells: Vec<&str> = line.split(',').collect();
            if cells.len() != header.len() {
                pb.finish_and_clear();
                return Err(bad(format!(
                    "line {}: {} cells, the header has {}",
                    i + 1,
                    cells.len(),
                    header.len()
                )));
            }
            for (c, (cell, col)) in cells.iter().zip(&mut columns).enumerate() {
                let v = cell.trim().parse::<f64>().map_err(|_| {
                    bad(format!(
                        "line {}, column {}: {cell:?} is not a number",
                        i + 1,
                        header[c]
                    ))
                })?;
                col.push(v);
            }
        }
        pb.finish_and_clear();
        Ok(SignalLog { header, columns })
    }
}

/// Signal groups in the logging stage's order of names; `q_measured` before `q`, whose
/// prefix it shares: (prefix, panel title, y label).
const GROUPS: [(&str, &str, &str); 5] = [
    (
        "q_measured",
        "measured joint positions (encoder)",
        "q̃ (rad | m)",
    ),
    ("qdd", "joint accelerations", "q̈ (rad/s² | m/s²)"),
    ("qd", "joint velocities", "q̇ (rad/s | m/s)"),
    ("tau", "joint efforts", "τ (N·m | N)"),
    ("q", "joint positions", "q (rad | m)"),
];

/// One panel per joint signal group present (`<prefix><digits>_<unit>` columns), in the order
/// q, q_measured, qd, qdd, tau; and which columns they took (`t_s` counts as taken).
fn joint_panels(log: &SignalLog) -> (Vec<Panel>, Vec<bool>) {
    let SignalLog { header, columns } = log;
    let t = &columns[0];
    let groups = GROUPS;
    let mut taken = vec![false; header.len()];
    taken[0] = true;
    let mut by_group: Vec<(usize, Vec<Line>)> = Vec::new();
    for (g, (prefix, _, _)) in groups.iter().enumerate() {
        let mut lines = Vec::new();
        for (c, name) in header.iter().enumerate() {
            if taken[c] {
                continue;
            }
            // `<prefix><digits>_<unit>`
            let Some(rest) = name.strip_prefix(prefix) else {
                continue;
            };
            let digits = rest.chars().take_while(char::is_ascii_digit).count();
            if digits == 0 || !rest[digits..].starts_with('_') {
                continue;
            }
            taken[c] = true;
            lines.push(Line {
                label: format!("joint {}", &rest[..digits]),
                points: t.iter().copied().zip(columns[c].iter().copied()).collect(),
            });
        }
        if !lines.is_empty() {
            by_group.push((g, lines));
        }
    }
    let order = [4usize, 0, 2, 1, 3]; // q, q_measured, qd, qdd, tau
    let mut panels: Vec<Panel> = Vec::new();
    for g in order {
        if let Some((_, lines)) = by_group.iter().find(|(k, _)| *k == g) {
            panels.extend(panel(groups[g].1, groups[g].2, lines.clone()));
        }
    }
    (panels, taken)
}

/// The actuator work panel, when the log has both joint velocities and efforts.
fn actuator_work_panel(log: &SignalLog) -> Option<Panel> {
    let SignalLog { header, columns } = log;
    let t = &columns[0];
    let col = |prefix: &str| -> Vec<Vec<f64>> {
        let cs: Vec<usize> = header
            .iter()
            .enumerate()
            .filter(|(_, h)| {
                h.strip_prefix(prefix).is_some_and(|r| {
                    let d = r.chars().take_while(char::is_ascii_digit).count();
                    d > 0 && r[d..].starts_with('_')
                })
            })
            .map(|(c, _)| c)
            .collect();
        (0..t.len())
            .map(|k| cs.iter().map(|&c| columns[c][k]).collect())
            .collect()
    };
    let qd = col("qd");
    let tau = col("tau");
    if qd.first().is_some_and(|r| !r.is_empty()) && tau.first().is_some_and(|r| !r.is_empty()) {
        let w = actuator_work(t, &qd, &tau);
        if w.points.len() > 1 {
            return panel("actuator work", "W (J)", vec![w]);
        }
    }
    None
}

/// The columns no group took: the contact verdict on a panel of its own, the rest together.
fn other_panels(log: &SignalLog, taken: &[bool]) -> Vec<Panel> {
    let SignalLog { header, columns } = log;
    let t = &columns[0];
    let mut panels: Vec<Panel> = Vec::new();
    let mut rest = Vec::new();
    for (c, name) in header.iter().enumerate() {
        if taken[c] {
            continue;
        }
        let line = Line {
            label: name.to_string(),
            points: t.iter().copied().zip(columns[c].iter().copied()).collect(),
        };
        if *name == "contact" {
            panels.extend(panel(
                "contact verdict per step",
                "contact (1 = yes)",
                vec![line],
            ));
        } else {
            rest.push(line);
        }
    }
    panels.extend(panel("other columns", "value", rest));
    panels
}

/// The data range of finite values, padded by 5 % (a flat series by ±1, or ±|v|/10).
fn range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    lo.is_finite().then_some((lo, hi))
}

fn padded((lo, hi): (f64, f64)) -> (f64, f64) {
    if hi - lo <= 1e-12 * lo.abs().max(hi.abs()).max(1e-300) {
        let d = if lo == 0.0 { 1.0 } else { lo.abs() / 10.0 };
        (lo - d, hi + d)
    } else {
        let pad = 0.05 * (hi - lo);
        (lo - pad, hi + pad)
    }
}

/// The points to draw of a series: all of them up to [`MAX_POINTS`], else each bucket's first,
/// minimum and maximum in time order (peaks kept).
fn decimate(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let finite: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    if finite.len() <= MAX_POINTS {
        return finite;
    }
    let buckets = MAX_POINTS / 3;
    let size = finite.len().div_ceil(buckets);
    let mut out = Vec::with_capacity(3 * buckets + 1);
    for chunk in finite.chunks(size) {
        let (mut imin, mut imax) = (0, 0);
        for (i, p) in chunk.iter().enumerate() {
            if p.1 < chunk[imin].1 {
                imin = i;
            }
            if p.1 > chunk[imax].1 {
                imax = i;
            }
        }
        let mut idx = [0, imin, imax];
        idx.sort_unstable();
        let mut last = usize::MAX;
        for i in idx {
            if i != last {
                out.push(chunk[i]);
                last = i;
            }
        }
    }
    if let Some(&p) = finite.last()
        && out.last() != Some(&p)
    {
        out.push(p);
    }
    out
}

const PANEL_W: u32 = 1000;
const PANEL_H: u32 = 330;

fn level_color(level: Option<Level>) -> RGBColor {
    match level {
        Some(Level::Error) => RGBColor(200, 30, 30),
        Some(Level::Warning) => RGBColor(230, 130, 0),
        _ => RGBColor(140, 140, 140),
    }
}

fn draw(path: &Path, figure: &Figure, events: &[Mark]) -> Result<(), RunPlotError> {
    let err = |e: &dyn std::fmt::Display| RunPlotError::Draw {
        path: path.to_owned(),
        message: e.to_string(),
    };
    crate::font::register_for_plots().map_err(|e| err(&e))?;
    let n = figure.panels.len().max(1) as u32;
    let root = BitMapBackend::new(path, (PANEL_W, 40 + PANEL_H * n)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let (title, body) = root.split_vertically(40);
    title
        .titled(&figure.title, (crate::font::PLOT_FAMILY, 24))
        .map_err(|e| err(&e))?;
    // One time axis for every panel of the figure: the panels line up.
    let x = range(
        figure
            .panels
            .iter()
            .flat_map(|p| p.lines.iter().flat_map(|l| l.points.iter().map(|p| p.0)))
            .chain(events.iter().map(|e| e.t)),
    )
    .map(padded)
    .unwrap_or((0.0, 1.0));
    let areas = body.split_evenly((figure.panels.len().max(1), 1));
    for (p, area) in figure.panels.iter().zip(areas.iter()) {
        draw_panel(p, area, x, events).map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

fn draw_panel(
    p: &Panel,
    area: &Area<'_>,
    (x0, x1): (f64, f64),
    events: &[Mark],
) -> Result<(), Box<dyn std::error::Error>> {
    let (y0, y1) = range(p.lines.iter().flat_map(|l| l.points.iter().map(|p| p.1)))
        .map(padded)
        .unwrap_or((0.0, 1.0));
    let mut chart = ChartBuilder::on(area)
        .caption(&p.title, (crate::font::PLOT_FAMILY, 18))
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(80)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc("simulation time (s)")
        .y_desc(p.y_label.as_str())
        .x_label_formatter(&|v| crate::plot::fmt_tick(*v))
        .y_label_formatter(&|v| crate::plot::fmt_tick(*v))
        .draw()?;
    for e in events {
        let c = level_color(e.level);
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(e.t, y0), (e.t, y1)],
            c.stroke_width(1),
        )))?;
    }
    for (i, l) in p.lines.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(decimate(&l.points), color.stroke_width(2)))?
            .label(l.label.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

fn summary_json(s: &PlotSummary) -> Value {
    let figures: Vec<Value> = s
        .figures
        .iter()
        .map(|f| {
            let panels: Vec<Value> = f
                .panels
                .iter()
                .map(|p| {
                    let xs = range(p.lines.iter().flat_map(|l| l.points.iter().map(|p| p.0)));
                    let ys = range(p.lines.iter().flat_map(|l| l.points.iter().map(|p| p.1)));
                    json!({
                        "title": p.title,
                        "y_label": p.y_label,
                        "series": p.lines.iter().map(|l| l.label.clone()).collect::<Vec<_>>(),
                        "points": p.lines.iter().map(|l| l.points.len()).sum::<usize>(),
                        "x_range": xs.map(|(a, b)| vec![a, b]),
                        "y_range": ys.map(|(a, b)| vec![a, b]),
                    })
                })
                .collect();
            json!({"file": f.file, "title": f.title, "panels": panels})
        })
        .collect();
    let events: Vec<Value> = s
        .events
        .iter()
        .map(|e| {
            json!({"t_s": e.t, "level": match e.level {
                Some(Level::Error) => "error",
                Some(Level::Warning) => "warning",
                Some(Level::Info) => "info",
                None => "unknown",
            }, "text": e.text})
        })
        .collect();
    json!({
        "source": s.source.display().to_string(),
        "truncated": s.truncated,
        "figures": figures,
        "events": events,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_every_peak_and_both_ends() {
        let pts: Vec<(f64, f64)> = (0..100_000)
            .map(|k| (k as f64, if k == 54_321 { 9.0 } else { (k as f64).sin() }))
            .collect();
        let d = decimate(&pts);
        assert!(d.len() <= MAX_POINTS + 1, "{}", d.len());
        assert!(d.contains(&(54_321.0, 9.0)), "the spike survives");
        assert_eq!(d.first(), pts.first());
        assert_eq!(d.last(), pts.last());
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0), "in time order");
        let short: Vec<(f64, f64)> = (0..10).map(|k| (k as f64, 1.0)).collect();
        assert_eq!(decimate(&short), short);
    }

    #[test]
    fn work_integrates_power_by_the_trapezoid_rule() {
        // τ q̇ = 2t on [0, 1]: W(1) = 1.
        let t: Vec<f64> = (0..=10).map(|k| k as f64 / 10.0).collect();
        let qd: Vec<Vec<f64>> = t.iter().map(|&t| vec![t, 1.0]).collect();
        let tau: Vec<Vec<f64>> = t.iter().map(|&t| vec![1.0, t]).collect();
        let w = actuator_work(&t, &qd, &tau);
        let last = w.points.last().expect("points").1;
        assert!((last - 1.0).abs() < 1e-12, "{last}");
    }

    #[test]
    fn a_signal_log_becomes_one_panel_per_signal_and_the_bad_lines_are_named() {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("simulator-arm.csv");
        let mut csv = String::from("t_s,q1_rad,q2_m,qd1_rad_s,qd2_m_s,tau1_Nm,tau2_N,contact\n");
        for k in 0..50 {
            let t = k as f64 * 0.01;
            csv.push_str(&format!(
                "{t},{},{},1,0.5,2,4,{}\n",
                t,
                -t,
                u8::from(k > 30)
            ));
        }
        std::fs::write(&path, &csv).expect("write");
        let out = dir.path().join("plots");
        let s = plot_file(&path, &out).expect("plotted");
        assert_eq!(s.figures.len(), 1);
        let f = &s.figures[0];
        assert_eq!(f.file, "arm.png");
        let titles: Vec<&str> = f.panels.iter().map(|p| p.title.as_str()).collect();
        assert_eq!(
            titles,
            [
                "joint positions",
                "joint velocities",
                "joint efforts",
                "actuator work",
                "contact verdict per step"
            ]
        );
        // Power 1·2 + 0.5·4 = 4 W over 0.49 s.
        let w = f.panels[3].lines[0].points.last().expect("work").1;
        assert!((w - 4.0 * 0.49).abs() < 1e-12, "{w}");
        let png = std::fs::read(out.join("arm.png")).expect("png");
        assert_eq!(&png[1..4], b"PNG");
        let json: Value =
            serde_json::from_slice(&std::fs::read(out.join("plot.json")).expect("json"))
                .expect("parse");
        assert_eq!(
            json["figures"][0]["panels"][0]["series"],
            json!(["joint 1", "joint 2"])
        );
        assert_eq!(
            json["figures"][0]["panels"][0]["x_range"],
            json!([0.0, 0.49])
        );

        std::fs::write(&path, "t_s,q1_rad\n0,1\n0.1,x\n").expect("write");
        let e = plot_file(&path, &out).expect_err("refused");
        assert!(
            e.to_string().contains("line 3, column q1_rad: \"x\""),
            "{e}"
        );
        std::fs::write(&path, "time,q1\n0,1\n").expect("write");
        let e = plot_file(&path, &out).expect_err("refused");
        assert!(e.to_string().contains("not t_s"), "{e}");
    }
}
