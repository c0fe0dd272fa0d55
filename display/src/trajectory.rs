//! MD's file mode (seed §2.2): joint angles read from a file and cycled through — the downhand
//! welding cell's robot and positioner each played from its own file.
//!
//! Format: one sample per line, one column per joint of the robot, separated by spaces, tabs
//! or commas; degrees for revolute joints and metres for prismatic ones (ROBOSIM's units).
//! `#` starts a comment. Two directives may appear in comments: `# units: rad` (revolute
//! columns are radians) and `# dt: 0.02` (seconds between samples; default 1/30 s).

use crate::{DisplayError, Result};
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    pub path: PathBuf,
    /// As written in the file (degrees unless `radians`).
    pub samples: Vec<Vec<f64>>,
    pub radians: bool,
    /// Seconds between samples.
    pub dt: f64,
}

impl Trajectory {
    pub fn load(path: &Path) -> Result<Trajectory> {
        // A regular file of at most Limit::MODEL bytes (a FIFO or a device is refused).
        let text = robosim_input::read_to_string(path, "a trajectory", robosim_input::Limit::MODEL)
            .map_err(|e| DisplayError::Io {
                path: path.to_path_buf(),
                source: std::io::Error::new(std::io::ErrorKind::InvalidInput, e.reason()),
            })?;
        Self::parse(&text, path)
    }

    pub fn parse(text: &str, path: &Path) -> Result<Trajectory> {
        let bad = |line: usize, what: String| DisplayError::Trajectory {
            path: path.to_path_buf(),
            line,
            what,
        };
        let mut t = Trajectory {
            path: path.to_path_buf(),
            samples: Vec::new(),
            radians: false,
            dt: 1.0 / 30.0,
        };
        for (n, raw) in text.lines().enumerate() {
            let line = n + 1;
            let (data, comment) = raw.split_once('#').unwrap_or((raw, ""));
            if let Some((key, value)) = comment.split_once(':') {
                match key.trim() {
                    "units" => match value.trim() {
                        "rad" => t.radians = true,
                        "deg" => t.radians = false,
                        other => return Err(bad(line, format!("units {other:?}: rad or deg"))),
                    },
                    "dt" => {
                        t.dt = value
                            .trim()
                            .parse::<f64>()
                            .ok()
                            .filter(|v| v.is_finite() && *v > 0.0)
                            .ok_or_else(|| {
                                bad(
                                    line,
                                    format!("dt {:?} is not a positive number", value.trim()),
                                )
                            })?;
                    }
                    _ => {}
                }
            }
            let fields: Vec<&str> = data
                .split(|c: char| c.is_whitespace() || c == ',')
                .filter(|f| !f.is_empty())
                .collect();
            if fields.is_empty() {
                continue;
            }
            let mut row = Vec::with_capacity(fields.len());
            for (col, f) in fields.iter().enumerate() {
                let v: f64 = f
                    .parse()
                    .map_err(|_| bad(line, format!("column {}: {f:?} is not a number", col + 1)))?;
                if !v.is_finite() {
                    return Err(bad(line, format!("column {}: {f} is not finite", col + 1)));
                }
                row.push(v);
            }
            if let Some(first) = t.samples.first()
                && first.len() != row.len()
            {
                return Err(bad(
                    line,
                    format!(
                        "{} columns; the first sample has {}",
                        row.len(),
                        first.len()
                    ),
                ));
            }
            t.samples.push(row);
        }
        if t.samples.is_empty() {
            return Err(bad(0, "no samples".into()));
        }
        Ok(t)
    }

    pub fn columns(&self) -> usize {
        self.samples.first().map_or(0, Vec::len)
    }

    /// Sample `k` (the last one once the file is exhausted) in SI units: revolute columns
    /// (`prismatic[j] == false`) converted to radians.
    pub fn sample_si(&self, k: usize, prismatic: &[bool]) -> Vec<f64> {
        to_si(
            &self.samples[k.min(self.samples.len() - 1)],
            prismatic,
            self.radians,
        )
    }
}

/// Joint values in ROBOSIM units to SI: revolute columns (`prismatic[j] == false`) from
/// degrees to radians unless `radians`; prismatic columns are metres either way.
pub fn to_si(values: &[f64], prismatic: &[bool], radians: bool) -> Vec<f64> {
    values
        .iter()
        .enumerate()
        .map(|(j, v)| {
            if prismatic.get(j).copied().unwrap_or(false) || radians {
                *v
            } else {
                v.to_radians()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_units_dt_and_separators_and_names_bad_lines() {
        let p = Path::new("arm.traj");
        let t = Trajectory::parse(
            "# welding arm\n# dt: 0.05\n0 90, 0\n\n10\t-90 0.5 # last\n",
            p,
        )
        .expect("valid");
        assert_eq!(t.samples.len(), 2);
        assert_eq!(t.dt, 0.05);
        let q = t.sample_si(1, &[false, false, true]);
        assert!((q[0] - 10f64.to_radians()).abs() < 1e-15 && q[2] == 0.5);
        assert_eq!(
            t.sample_si(99, &[]),
            t.sample_si(1, &[]),
            "holds the last sample"
        );
        let r = Trajectory::parse("# units: rad\n1 2\n", p).expect("valid");
        assert_eq!(r.sample_si(0, &[]), vec![1.0, 2.0]);
        let e = Trajectory::parse("0 0\n0 x\n", p)
            .expect_err("refused")
            .to_string();
        assert!(e.starts_with("arm.traj:2:") && e.contains("\"x\""), "{e}");
        let e = Trajectory::parse("0 0\n0 0 0\n", p)
            .expect_err("refused")
            .to_string();
        assert!(e.contains("arm.traj:2: 3 columns"), "{e}");
        let e = Trajectory::parse("0 NaN\n", p)
            .expect_err("refused")
            .to_string();
        assert!(e.contains("not finite"), "{e}");
        assert!(Trajectory::parse("# nothing\n", p).is_err());
        assert!(Trajectory::parse("# dt: -1\n0\n", p).is_err());
    }
}
