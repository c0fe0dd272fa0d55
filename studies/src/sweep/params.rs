//! A study's parameters as a sweep sees them: what values a parameter takes ([`Kind`]), its
//! definition ([`ParamDef`]), a study's definition ([`StudyDef`]) and one value ([`Value`]).
//! Shared by the `--param` parser ([`super::spec`]) and the studies ([`super::study`]), which
//! re-export them under their old paths.

use crate::Result;

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

/// What values a parameter takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A finite number in the parameter's unit.
    Number,
    /// A whole number (encoder bits).
    Whole,
    /// One of these words.
    Choice(&'static [&'static str]),
}

/// One parameter of a study.
#[derive(Debug, Clone, Copy)]
pub struct ParamDef {
    pub name: &'static str,
    pub unit: &'static str,
    pub kind: Kind,
    /// What it is, for `robosim sweep --help` and docs/studies.md.
    pub what: &'static str,
}

/// A study a sweep can run.
pub struct StudyDef {
    pub name: &'static str,
    pub what: &'static str,
    pub params: &'static [ParamDef],
    /// The result columns, each naming its unit.
    pub results: &'static [&'static str],
    /// Refuses a point the study cannot run (a value out of its range), naming it; cheap, so
    /// the coordinator checks every point before any worker starts.
    pub check: fn(&[(String, Value)]) -> Result<()>,
    /// Runs the study at a point: one value per result column.
    pub run: fn(&[(String, Value)]) -> Result<Vec<f64>>,
}

impl StudyDef {
    /// "name (unit), …" for error messages.
    pub fn param_list(&self) -> String {
        self.params
            .iter()
            .map(|p| match p.kind {
                Kind::Choice(w) => format!("{} ({})", p.name, w.join("|")),
                _ => format!("{} ({})", p.name, p.unit),
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
}
