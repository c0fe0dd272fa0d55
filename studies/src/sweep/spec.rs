//! What a sweep runs: `--param name=a:b:n` / `name=v1,v2,…` parsed against a study's
//! parameters, and their cartesian product as jobs with stable indices.

use super::SweepError;
use super::study::{Kind, StudyDef};

/// Most jobs one sweep may have (a typo such as `a:b:100000` twice is refused, not run).
pub const MAX_JOBS: usize = 1_000_000;

/// One parameter value: a number (in the parameter's stated unit) or a word (a choice).
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Num(f64),
    Word(String),
}

impl std::fmt::Display for Value {
    /// Numbers in Rust's shortest round-trip form (`0.2`, `12`), so a CSV cell reads back bit
    /// for bit.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Num(v) => write!(f, "{v}"),
            Value::Word(w) => f.write_str(w),
        }
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::study;

    fn axis(s: &str) -> Result<Axis, SweepError> {
        parse_axis(study::find("welding").expect("welding"), s)
    }

    #[test]
    fn a_range_has_n_values_from_a_to_b_exactly() {
        let a = axis("speed=2:7:11").expect("range");
        assert_eq!(a.values.len(), 11);
        assert_eq!(a.values[0], Value::Num(2.0));
        assert_eq!(a.values[10], Value::Num(7.0));
        assert_eq!(a.values[5], Value::Num(4.5));
        let a = axis("arm_x=-1.2:-0.9:4").expect("negative range");
        assert_eq!(a.values[0], Value::Num(-1.2));
        assert_eq!(a.values[3], Value::Num(-0.9));
        assert_eq!(axis("speed=3:3:1").expect("one").values, [Value::Num(3.0)]);
    }

    #[test]
    fn lists_take_numbers_and_a_choice_its_words() {
        let a = axis("mode=bbox, exact").expect("choice");
        assert_eq!(
            a.values,
            [Value::Word("bbox".into()), Value::Word("exact".into())]
        );
        assert_eq!(
            axis("step=0.5,1e-1").expect("numbers").values,
            [Value::Num(0.5), Value::Num(0.1)]
        );
    }

    #[test]
    fn bad_arguments_are_refused_naming_them() {
        for (arg, want) in [
            ("speed", "expected NAME=A:B:N"),
            ("speed=", "no value for speed"),
            ("speeds=1,2", "has no parameter \"speeds\""),
            ("speed=1:2", "expected A:B:N"),
            ("speed=1:2:3:4", "expected A:B:N"),
            ("speed=1:2:0", "at least 1"),
            ("speed=1:2:1", "ambiguous"),
            ("speed=1:2:x", "not a whole number"),
            ("speed=1:inf:3", "not a finite number"),
            ("speed=NaN", "not a finite number"),
            ("speed=1,,2", "empty value"),
            ("speed=fast", "\"fast\" is not a number"),
            ("mode=exact,quick", "expected one of bbox, polygon, exact"),
            ("seam=1:2:2", "is a choice"),
        ] {
            let e = axis(arg).expect_err(arg).to_string();
            assert!(e.contains(arg), "{e:?} does not name {arg:?}");
            assert!(e.contains(want), "{arg}: {e:?} does not say {want:?}");
        }
    }

    #[test]
    fn jobs_are_the_product_first_axis_slowest() {
        let axes = [
            axis("speed=1,2").expect("speed"),
            axis("mode=bbox,polygon,exact").expect("mode"),
        ];
        let jobs = jobs(&axes).expect("jobs");
        assert_eq!(jobs.len(), 6);
        for (i, j) in jobs.iter().enumerate() {
            assert_eq!(j.index, i);
            assert_eq!(j.params[0].1, axes[0].values[i / 3]);
            assert_eq!(j.params[1].1, axes[1].values[i % 3]);
        }
        assert_eq!(super::jobs(&[]).expect("defaults").len(), 1);
        let twice = [axis("speed=1").expect("a"), axis("speed=2").expect("b")];
        assert!(super::jobs(&twice).is_err());
        let huge = [
            axis("speed=1:2:1000").expect("a"),
            axis("step=0.1:1:1000").expect("b"),
            axis("arm_x=-1:1:2").expect("c"),
        ];
        assert!(matches!(
            super::jobs(&huge),
            Err(SweepError::TooMany { .. })
        ));
    }
}
