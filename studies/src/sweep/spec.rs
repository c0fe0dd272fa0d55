//! What a sweep runs: `--param name=a:b:n` / `name=v1,v2,…` parsed against a study's
//! parameters, and their cartesian product as jobs with stable indices.

pub use super::params::Value;

use super::SweepError;
use super::params::{Kind, StudyDef};

/// Most jobs one sweep may have (a typo such as `a:b:100000` twice is refused, not run).
pub const MAX_JOBS: usize = 1_000_000;

/// One swept parameter: its name and the values it takes, in order.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    pub name: String,
    pub values: Vec<Value>,
}

/// One point of the sweep: its index (row-major over the axes, the first axis varying
/// slowest) and a value per axis, in axis order.
#[derive(Debug, Clone, PartialEq)]
pub struct Job {
    pub index: usize,
    pub params: Vec<(String, Value)>,
}

/// Parses one `--param` argument for `study`: `name=a:b:n` (n values evenly from a to b, both
/// included) or `name=v1,v2,…` (numbers, or the words a choice parameter takes).
pub fn parse_axis(study: &StudyDef, arg: &str) -> Result<Axis, SweepError> {
    let bad = |why: String| SweepError::Param {
        arg: arg.to_owned(),
        why,
    };
    let (name, spec) = arg
        .split_once('=')
        .ok_or_else(|| bad("expected NAME=A:B:N or NAME=V1,V2,…".into()))?;
    let name = name.trim();
    let def = study
        .params
        .iter()
        .find(|p| p.name == name)
        .ok_or_else(|| {
            bad(format!(
                "study {} has no parameter {name:?}; it has {}",
                study.name,
                study.param_list()
            ))
        })?;
    let spec = spec.trim();
    if spec.is_empty() {
        return Err(bad(format!("no value for {name}")));
    }
    let num = |s: &str| -> Result<f64, SweepError> {
        let v: f64 = s
            .trim()
            .parse()
            .map_err(|_| bad(format!("{s:?} is not a number")))?;
        if !v.is_finite() {
            return Err(bad(format!("{s:?} is not a finite number")));
        }
        Ok(v)
    };
    let values = if spec.contains(':') {
        if let Kind::Choice(words) = def.kind {
            return Err(bad(format!(
                "{name} is a choice ({}): list the values, not a range",
                words.join(", ")
            )));
        }
        let parts: Vec<&str> = spec.split(':').collect();
        let [a, b, n] = parts[..] else {
            return Err(bad(format!(
                "range {spec:?}: expected A:B:N (N values from A to B)"
            )));
        };
        let (a, b) = (num(a)?, num(b)?);
        let n: usize = n.trim().parse().map_err(|_| {
            bad(format!(
                "range {spec:?}: the count {n:?} is not a whole number"
            ))
        })?;
        if n == 0 {
            return Err(bad(format!("range {spec:?}: the count must be at least 1")));
        }
        if n == 1 && a != b {
            return Err(bad(format!(
                "range {spec:?}: one value from {a} to {b} is ambiguous; give N ≥ 2 or one value"
            )));
        }
        if n > MAX_JOBS {
            return Err(bad(format!("range {spec:?}: more than {MAX_JOBS} values")));
        }
        (0..n)
            .map(|i| {
                // a·(1−t) + b·t is exactly a at t = 0 and exactly b at t = 1
                let t = if n == 1 {
                    0.0
                } else {
                    i as f64 / (n - 1) as f64
                };
                Value::Num(a * (1.0 - t) + b * t)
            })
            .collect()
    } else {
        let mut out = Vec::new();
        for s in spec.split(',') {
            let s = s.trim();
            if s.is_empty() {
                return Err(bad(format!("empty value in the list {spec:?}")));
            }
            out.push(match def.kind {
                Kind::Choice(words) => {
                    if !words.contains(&s) {
                        return Err(bad(format!(
                            "{name} {s:?}: expected one of {}",
                            words.join(", ")
                        )));
                    }
                    Value::Word(s.to_owned())
                }
                Kind::Number | Kind::Whole => Value::Num(num(s)?),
            });
        }
        out
    };
    if def.kind == Kind::Whole {
        for v in &values {
            if let Value::Num(x) = v
                && x.fract() != 0.0
            {
                return Err(bad(format!(
                    "{name} = {x}: expected whole numbers ({})",
                    def.unit
                )));
            }
        }
    }
    Ok(Axis {
        name: name.to_owned(),
        values,
    })
}

/// The cartesian product of `axes` (each name once), first axis slowest: job i's value of
/// axis k is `axes[k].values[(i / Π_{l>k} n_l) mod n_k]`.
pub fn jobs(axes: &[Axis]) -> Result<Vec<Job>, SweepError> {
    for (i, a) in axes.iter().enumerate() {
        if axes[..i].iter().any(|b| b.name == a.name) {
            return Err(SweepError::Param {
                arg: a.name.clone(),
                why: "given twice: put every value in one --param".into(),
            });
        }
    }
    let mut total: usize = 1;
    for a in axes {
        total = total
            .checked_mul(a.values.len())
            .filter(|t| *t <= MAX_JOBS)
            .ok_or_else(|| SweepError::TooMany {
                max: MAX_JOBS,
                axes: axes
                    .iter()
                    .map(|a| format!("{} ({})", a.name, a.values.len()))
                    .collect::<Vec<_>>()
                    .join(" × "),
            })?;
    }
    let mut out = Vec::with_capacity(total);
    for index in 0..total {
        let mut rest = index;
        let mut params = vec![(String::new(), Value::Num(0.0)); axes.len()];
        for (k, a) in axes.iter().enumerate().rev() {
            let n = a.values.len();
            params[k] = (a.name.clone(), a.values[rest % n].clone());
            rest /= n;
        }
        out.push(Job { index, params });
    }
    Ok(out)
}
