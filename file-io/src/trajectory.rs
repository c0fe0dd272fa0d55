//! The joint trajectory a simulator run logged, as CSV with units in the header.
//!
//! Source: the daemon's signal log of one robot, `<session>/run/simulator-<robot>.csv` (written
//! when the scene declares logging), or any log given with `--log`. Both header styles are
//! read: today's `t,q1,q2,…` and a header with units (`t_s,q1_rad,…`): a column is known by
//! its name before the first `_` (`t`, `q<j>`); other signals (qd, tau, …) are left out. A
//! log without a time column gets its times from `--dt` (row k at (k + 1)·dt).
//!
//! Output: `t_s,<joint>_<unit>,…` — one column per joint named after its link, unit `rad` for a
//! revolute joint and `m` for a prismatic one (from the session's robot), rows as logged.

use crate::error::FileError;
use robosim_instance_space::{JointKind, Snapshot};
use std::fmt::Write as _;
use std::path::Path;

/// The joint names and units of `robot` in `snap`, in chain order.
pub fn joint_columns(snap: &Snapshot, robot: &str) -> Result<Vec<String>, FileError> {
    let r = snap.robot(robot).ok_or_else(|| {
        let names: Vec<String> = snap.robots().iter().map(|r| r.name.to_owned()).collect();
        FileError::Usage(format!(
            "no robot {robot:?} in the session (robots: {})",
            names.join(", ")
        ))
    })?;
    Ok(r.joints
        .iter()
        .map(|j| {
            let unit = if j.kind == JointKind::Prismatic {
                "m"
            } else {
                "rad"
            };
            format!("{}_{unit}", snap.name(j.index))
        })
        .collect())
}

/// Rewrites the log `log` (CSV text) with the header `t_s` + `columns`. A log without a time
/// column (today's daemon logs only what the scene declares, e.g. `q`) needs `dt_s`, the time
/// between two rows (s): row k is at (k + 1)·dt_s. `path` names the log in errors.
pub fn convert(
    log: &str,
    columns: &[String],
    dt_s: Option<f64>,
    path: &Path,
) -> Result<String, FileError> {
    let err = |line: usize, reason: String| FileError::Mesh {
        path: path.to_owned(),
        line,
        reason,
    };
    let mut lines = log.lines();
    let header = lines
        .next()
        .ok_or_else(|| err(1, "the log is empty".into()))?;
    let base = |h: &str| h.trim().split('_').next().unwrap_or("").to_owned();
    let names: Vec<String> = header.split(',').map(base).collect();
    let t = names.iter().position(|n| n == "t");
    if t.is_none() && !dt_s.is_some_and(|d| d.is_finite() && d > 0.0) {
        return Err(err(
            1,
            format!(
                "no time column (t or t_s) in {header:?}: give --dt, the seconds between two rows (the simulator's step times the logging interval)"
            ),
        ));
    }
    let mut q = Vec::with_capacity(columns.len());
    for (j, column) in columns.iter().enumerate() {
        let want = format!("q{}", j + 1);
        q.push(names.iter().position(|n| *n == want).ok_or_else(|| {
            err(
                1,
                format!(
                    "no column {want} for joint {column} in {header:?} (does the scene log q?)"
                ),
            )
        })?);
    }
    let mut out = String::with_capacity(log.len());
    out.push_str("t_s");
    for c in columns {
        out.push(',');
        out.push_str(c);
    }
    out.push('\n');
    for (k, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').collect();
        let cell = |i: usize| -> Result<&str, FileError> {
            let c = cells
                .get(i)
                .ok_or_else(|| {
                    err(
                        k + 2,
                        format!("{} cells, expected {}", cells.len(), names.len()),
                    )
                })?
                .trim();
            c.parse::<f64>()
                .map_err(|_| err(k + 2, format!("{c:?} is not a number")))?;
            Ok(c)
        };
        match (t, dt_s) {
            (Some(t), _) => out.push_str(cell(t)?),
            (None, Some(dt)) => {
                let _ = write!(out, "{}", (k + 1) as f64 * dt);
            }
            (None, None) => {}
        }
        for &i in &q {
            out.push(',');
            out.push_str(cell(i)?);
        }
        out.push('\n');
    }
    Ok(out)
}

/// Reads `log` and writes the converted trajectory to `out`.
pub fn export(
    log: &Path,
    columns: &[String],
    dt_s: Option<f64>,
    out: &Path,
) -> Result<usize, FileError> {
    let text = robosim_input::read_to_string(log, "a simulator log", robosim_input::Limit::MODEL)?;
    let csv = convert(&text, columns, dt_s, log)?;
    crate::format::write_atomic(out, csv.as_bytes())?;
    Ok(csv.lines().count().saturating_sub(1))
}
