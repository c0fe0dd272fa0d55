//! The graph file's parser: one declaration per line (module docs of [`super`]); every error
//! names the file, the line and what is wrong there.

use super::actors::kind;
use super::{ActorDecl, Axis, DataDecl, GraphSpec, SinkAddr, SinkDecl, SourceAddr, SourceDecl};
use crate::kernel::{Drive, Firing, Retention};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A graph file that could not be read or is wrong at `line` (0: the file as a whole).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}:{line}: {message}")]
pub struct GraphFileError {
    pub file: String,
    pub line: usize,
    pub message: String,
}

/// Reads and parses the graph file at `path` ([`parse_graph`]).
///
/// Errors: the file cannot be read (missing, not a regular file, larger than
/// [`robosim_input::Limit::TEXT`], not UTF-8) — at line 0 —, or any error of [`parse_graph`].
pub fn load_graph(path: &Path) -> Result<GraphSpec, GraphFileError> {
    let file = path.display().to_string();
    let text = robosim_input::read_to_string(path, "a dataflow graph", robosim_input::Limit::TEXT)
        .map_err(|e| GraphFileError {
            file: file.clone(),
            line: 0,
            message: format!("cannot read the graph: {}", e.reason()),
        })?;
    parse_graph(&text, &file)
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Word(String),
    Eq,
    Open,
    Close,
    Comma,
    Arrow,
}

impl std::fmt::Display for Tok {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Tok::Word(w) => write!(f, "`{w}`"),
            Tok::Eq => write!(f, "`=`"),
            Tok::Open => write!(f, "`(`"),
            Tok::Close => write!(f, "`)`"),
            Tok::Comma => write!(f, "`,`"),
            Tok::Arrow => write!(f, "`->`"),
        }
    }
}

fn word_char(c: char) -> bool {
    c.is_alphanumeric() || matches!(c, '_' | '.' | '-' | '+' | ':' | '/')
}

fn tokens(line: &str) -> Result<Vec<Tok>, String> {
    let mut out = Vec::new();
    let chars: Vec<char> = line.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c == '#' {
            break;
        }
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        if c == '-' && chars.get(i + 1) == Some(&'>') {
            out.push(Tok::Arrow);
            i += 2;
            continue;
        }
        let single = match c {
            '=' => Some(Tok::Eq),
            '(' => Some(Tok::Open),
            ')' => Some(Tok::Close),
            ',' => Some(Tok::Comma),
            _ => None,
        };
        if let Some(t) = single {
            out.push(t);
            i += 1;
            continue;
        }
        if !word_char(c) {
            return Err(format!("unexpected character {c:?} at column {}", i + 1));
        }
        let start = i;
        while i < chars.len()
            && word_char(chars[i])
            && !(chars[i] == '-' && chars.get(i + 1) == Some(&'>'))
        {
            i += 1;
        }
        out.push(Tok::Word(chars[start..i].iter().collect()));
    }
    Ok(out)
}

/// A cursor over one line's tokens.
struct Line<'a> {
    toks: &'a [Tok],
    at: usize,
}

impl Line<'_> {
    fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.at)
    }
    fn next(&mut self) -> Option<&Tok> {
        let t = self.toks.get(self.at);
        self.at += 1;
        t
    }
    fn word(&mut self, what: &str) -> Result<String, String> {
        match self.next() {
            Some(Tok::Word(w)) => Ok(w.clone()),
            Some(t) => Err(format!("expected {what}, found {t}")),
            None => Err(format!("expected {what} at the end of the line")),
        }
    }
    fn name(&mut self, what: &str) -> Result<String, String> {
        let w = self.word(what)?;
        let ok = w
            .chars()
            .next()
            .is_some_and(|c| c.is_alphabetic() || c == '_')
            && w.chars().all(|c| c.is_alphanumeric() || c == '_');
        if ok {
            Ok(w)
        } else {
            Err(format!(
                "{what} `{w}` is not a name (letters, digits and _, not starting with a digit)"
            ))
        }
    }
    fn number(&mut self, what: &str) -> Result<f64, String> {
        let w = self.word(what)?;
        match w.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(format!("{what} must be a finite number, found `{w}`")),
        }
    }
    fn index(&mut self, what: &str) -> Result<usize, String> {
        let w = self.word(what)?;
        w.parse::<usize>()
            .map_err(|_| format!("{what} must be a joint index 0, 1, 2, …, found `{w}`"))
    }
    fn expect(&mut self, t: Tok) -> Result<(), String> {
        match self.next() {
            Some(x) if *x == t => Ok(()),
            Some(x) => Err(format!("expected {t}, found {x}")),
            None => Err(format!("expected {t} at the end of the line")),
        }
    }
    fn end(&mut self) -> Result<(), String> {
        match self.peek() {
            None => Ok(()),
            Some(t) => Err(format!("unexpected {t} after the declaration")),
        }
    }
}

fn axis(w: &str) -> Result<Axis, String> {
    match w {
        "x" => Ok(Axis::X),
        "y" => Ok(Axis::Y),
        "z" => Ok(Axis::Z),
        other => Err(format!("pose component `{other}`: expected x, y or z")),
    }
}

fn source_addr(l: &mut Line<'_>) -> Result<SourceAddr, String> {
    let what = l.word("a source (joint, pose, sim, alarm, const or clock)")?;
    let a = match what.as_str() {
        "joint" => SourceAddr::Joint {
            robot: l.word("the robot's name")?,
            index: l.index("the joint index")?,
        },
        "pose" => SourceAddr::Pose {
            object: l.word("the object's name")?,
            axis: axis(&l.word("the pose component (x, y or z)")?)?,
        },
        "sim" => SourceAddr::Sim {
            path: l.word("a path in the simulator's state, e.g. t_s or space.power.battery_kwh")?,
        },
        "alarm" => SourceAddr::Alarm {
            name: l.word("the alarm's name")?,
        },
        "const" => SourceAddr::Const(l.number("the constant")?),
        "clock" => SourceAddr::Clock,
        other => {
            return Err(format!(
                "unknown source `{other}` (joint ROBOT I, pose OBJECT x|y|z, sim PATH, alarm NAME, const VALUE, clock)"
            ));
        }
    };
    l.end()?;
    Ok(a)
}

fn sink_addr(l: &mut Line<'_>) -> Result<SinkAddr, String> {
    let what = l.word("a sink (joint, pose, alarm or sim)")?;
    let a = match what.as_str() {
        "joint" => SinkAddr::Joint {
            robot: l.word("the robot's name")?,
            index: l.index("the joint index")?,
        },
        "pose" => SinkAddr::Pose {
            object: l.word("the object's name")?,
            axis: axis(&l.word("the pose component (x, y or z)")?)?,
        },
        "alarm" => SinkAddr::Alarm {
            name: l.name("the alarm's name")?,
        },
        "sim" => SinkAddr::Sim {
            name: l.name("the simulator setting's name")?,
        },
        other => {
            return Err(format!(
                "unknown sink `{other}` (joint ROBOT I, pose OBJECT x|y|z, alarm NAME, sim NAME)"
            ));
        }
    };
    l.end()?;
    Ok(a)
}

fn name_list(l: &mut Line<'_>, what: &str, close: Option<Tok>) -> Result<Vec<String>, String> {
    let mut out = Vec::new();
    if close.is_some() && l.peek() == close.as_ref() {
        l.next();
        return Ok(out);
    }
    loop {
        out.push(l.name(what)?);
        match l.peek() {
            Some(Tok::Comma) => {
                l.next();
            }
            Some(t) if Some(t) == close.as_ref() => {
                l.next();
                return Ok(out);
            }
            _ if close.is_none() => return Ok(out),
            Some(t) => return Err(format!("expected `,` or `)` in the input list, found {t}")),
            None => return Err("the input list is not closed with `)`".into()),
        }
    }
}

/// `NAME = KIND(IN, …) -> OUT, … [key=value …] [flags]` after `actor`.
fn actor(l: &mut Line<'_>, rate: Option<f64>, line: usize) -> Result<ActorDecl, String> {
    let name = l.name("the actor's name")?;
    l.expect(Tok::Eq)?;
    let kind_name = l.word("the actor's kind")?;
    let info = kind(&kind_name).ok_or_else(|| {
        format!(
            "unknown actor kind `{kind_name}` (built-in kinds: {})",
            super::kinds()
                .iter()
                .map(|k| k.name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    })?;
    l.expect(Tok::Open)?;
    let inputs = name_list(l, "an input data node", Some(Tok::Close))?;
    l.expect(Tok::Arrow)?;
    let outputs = name_list(l, "an output data node", None)?;
    if inputs.len() != info.inputs.len() {
        return Err(format!(
            "{kind_name} takes {} input(s) ({}), the line gives {}",
            info.inputs.len(),
            info.inputs.join(", "),
            inputs.len()
        ));
    }
    if outputs.len() != info.outputs.len() {
        return Err(format!(
            "{kind_name} has {} output(s) ({}), the line gives {}",
            info.outputs.len(),
            info.outputs.join(", "),
            outputs.len()
        ));
    }
    let mut given: BTreeMap<String, f64> = BTreeMap::new();
    let (mut firing, mut drive) = (None, None);
    while l.peek().is_some() {
        let w = l.word("a parameter (key=value) or a flag (ifall, ifany, data, demand)")?;
        match w.as_str() {
            "ifall" | "ifany" if firing.is_some() => {
                return Err(format!("`{w}`: the firing mode is given twice"));
            }
            "data" | "demand" if drive.is_some() => {
                return Err(format!("`{w}`: the drive mode is given twice"));
            }
            "ifall" => firing = Some(Firing::IfAll),
            "ifany" => firing = Some(Firing::IfAny),
            "data" => drive = Some(Drive::Data),
            "demand" => drive = Some(Drive::Demand),
            key => {
                if l.peek() != Some(&Tok::Eq) {
                    return Err(format!(
                        "`{key}` is neither a flag (ifall, ifany, data, demand) nor key=value"
                    ));
                }
                l.next();
                if !info.params.iter().any(|(p, _)| *p == key) {
                    return Err(format!(
                        "{kind_name} has no parameter `{key}` (its parameters: {})",
                        if info.params.is_empty() {
                            "none".to_owned()
                        } else {
                            info.params
                                .iter()
                                .map(|p| p.0)
                                .collect::<Vec<_>>()
                                .join(", ")
                        }
                    ));
                }
                let v = l.number(&format!("parameter `{key}`"))?;
                if given.insert(key.to_owned(), v).is_some() {
                    return Err(format!("parameter `{key}` is given twice"));
                }
            }
        }
    }
    let mut params = BTreeMap::new();
    for (p, default) in info.params {
        let v = match (given.get(*p), default, *p) {
            (Some(v), _, _) => *v,
            (None, _, "dt") if rate.is_some() => 1.0 / rate.unwrap_or(1.0),
            (None, Some(d), _) => *d,
            (None, None, "dt") => {
                return Err(format!(
                    "{kind_name} needs dt= (its sample time, s), or a `rate` line before it"
                ));
            }
            (None, None, p) => return Err(format!("{kind_name} needs the parameter {p}=")),
        };
        if *p == "dt" && v <= 0.0 {
            return Err(format!("dt must be positive, got {v}"));
        }
        params.insert((*p).to_owned(), v);
    }
    check_params(&kind_name, &params)?;
    Ok(ActorDecl {
        name,
        kind: kind_name,
        params,
        inputs,
        outputs,
        firing: firing.unwrap_or(Firing::IfAll),
        drive: drive.unwrap_or(Drive::Data),
        line,
    })
}

/// What a kind's parameters must satisfy beyond being numbers.
fn check_params(kind: &str, p: &BTreeMap<String, f64>) -> Result<(), String> {
    let get = |k: &str| p.get(k).copied().unwrap_or(f64::NAN);
    match kind {
        "clamp" | "pid" if get("lo") > get("hi") => Err(format!(
            "{kind}: lo = {} is above hi = {}",
            get("lo"),
            get("hi")
        )),
        "lowpass" if get("tau") < 0.0 => Err(format!(
            "lowpass: tau must be zero or positive, got {}",
            get("tau")
        )),
        "ratelimit" if get("rate") <= 0.0 => Err(format!(
            "ratelimit: rate must be positive, got {}",
            get("rate")
        )),
        "threshold" if get("above").is_nan() && get("below").is_nan() => {
            Err("threshold needs above= or below= (or both)".into())
        }
        "threshold" if get("hysteresis") < 0.0 => Err(format!(
            "threshold: hysteresis must be zero or positive, got {}",
            get("hysteresis")
        )),
        _ => Ok(()),
    }
}

/// Parses a graph file's text. `file` names it in errors.
///
/// Errors ([`GraphFileError`], file:line): an unknown declaration, source, sink or actor kind;
/// a malformed line; a name declared twice; a wrong number of inputs or outputs for the kind;
/// an unknown, repeated or missing parameter; a data node read or written that no `source` or
/// `data` line declares; a node written by two actors, or written by an actor while a source
/// feeds it; a sink on a node nothing writes; two sinks on one address; a `rate` that is not a
/// positive number or comes after an actor that took its `dt`.
pub fn parse_graph(text: &str, file: &str) -> Result<GraphSpec, GraphFileError> {
    let err = |line: usize, message: String| GraphFileError {
        file: file.to_owned(),
        line,
        message,
    };
    let mut spec = GraphSpec {
        file: file.to_owned(),
        rate_hz: None,
        sources: Vec::new(),
        data: Vec::new(),
        actors: Vec::new(),
        sinks: Vec::new(),
    };
    let mut names: BTreeMap<String, (usize, &'static str)> = BTreeMap::new();
    let mut declare = |name: &str, what: &'static str, line: usize| -> Result<(), String> {
        match names.get(name) {
            Some((l, w)) => Err(format!("`{name}` is already declared as {w} at line {l}")),
            None => {
                names.insert(name.to_owned(), (line, what));
                Ok(())
            }
        }
    };
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let toks = tokens(raw).map_err(|m| err(line, m))?;
        if toks.is_empty() {
            continue;
        }
        let mut l = Line { toks: &toks, at: 0 };
        let r: Result<(), String> = (|| {
            let head = l.word("a declaration (rate, source, data, actor, sink)")?;
            match head.as_str() {
                "rate" => {
                    if spec.rate_hz.is_some() {
                        return Err("the rate is given twice".into());
                    }
                    if !spec.actors.is_empty() {
                        return Err(
                            "`rate` must come before the actors (their dt follows it)".into()
                        );
                    }
                    let hz = l.number("the rate, Hz")?;
                    if hz <= 0.0 {
                        return Err(format!("the rate must be positive, got {hz}"));
                    }
                    let unit = l.peek().cloned();
                    if let Some(Tok::Word(u)) = unit {
                        if u != "Hz" && u != "hz" {
                            return Err(format!("the rate's unit is Hz, found `{u}`"));
                        }
                        l.next();
                    }
                    l.end()?;
                    spec.rate_hz = Some(hz);
                }
                "source" => {
                    let name = l.name("the source's name")?;
                    l.expect(Tok::Eq)?;
                    let addr = source_addr(&mut l)?;
                    declare(&name, "a source", line)?;
                    spec.sources.push(SourceDecl { name, addr, line });
                }
                "data" => {
                    let name = l.name("the data node's name")?;
                    let retention = match l.peek() {
                        None => Retention::LastValue,
                        Some(Tok::Word(w)) if w == "last" => Retention::LastValue,
                        Some(Tok::Word(w)) if w == "stream" => Retention::Stream,
                        Some(t) => {
                            return Err(format!(
                                "expected `last` or `stream` after the name, found {t}"
                            ));
                        }
                    };
                    if l.peek().is_some() {
                        l.next();
                    }
                    l.end()?;
                    declare(&name, "a data node", line)?;
                    spec.data.push(DataDecl {
                        name,
                        retention,
                        line,
                    });
                }
                "actor" => {
                    let a = actor(&mut l, spec.rate_hz, line)?;
                    declare(&a.name, "an actor", line)?;
                    spec.actors.push(a);
                }
                "sink" => {
                    let node = l.name("the data node the sink reads")?;
                    l.expect(Tok::Arrow)?;
                    let addr = sink_addr(&mut l)?;
                    spec.sinks.push(SinkDecl { node, addr, line });
                }
                other => {
                    return Err(format!(
                        "unknown declaration `{other}` (rate, source, data, actor, sink)"
                    ));
                }
            }
            Ok(())
        })();
        r.map_err(|m| err(line, m))?;
    }
    check_wiring(&spec).map_err(|(line, m)| err(line, m))?;
    Ok(spec)
}

/// Every node an actor or sink names is declared; each node has one writer.
fn check_wiring(spec: &GraphSpec) -> Result<(), (usize, String)> {
    let nodes: BTreeSet<&str> = spec
        .sources
        .iter()
        .map(|s| s.name.as_str())
        .chain(spec.data.iter().map(|d| d.name.as_str()))
        .collect();
    let mut writer: BTreeMap<&str, String> = spec
        .sources
        .iter()
        .map(|s| {
            (
                s.name.as_str(),
                format!("source `{}` (line {})", s.name, s.line),
            )
        })
        .collect();
    for a in &spec.actors {
        for n in &a.inputs {
            if !nodes.contains(n.as_str()) {
                return Err((
                    a.line,
                    format!(
                        "actor `{}` reads `{n}`, which no `source` or `data` line declares",
                        a.name
                    ),
                ));
            }
        }
        for n in &a.outputs {
            if !nodes.contains(n.as_str()) {
                return Err((
                    a.line,
                    format!(
                        "actor `{}` writes `{n}`, which no `data` line declares",
                        a.name
                    ),
                ));
            }
            if let Some(w) = writer.get(n.as_str()) {
                return Err((
                    a.line,
                    format!("actor `{}` writes `{n}`, which {w} already writes", a.name),
                ));
            }
            writer.insert(n, format!("actor `{}` (line {})", a.name, a.line));
        }
    }
    let mut addrs: Vec<(&SinkAddr, usize)> = Vec::new();
    for s in &spec.sinks {
        if !nodes.contains(s.node.as_str()) {
            return Err((
                s.line,
                format!(
                    "the sink reads `{}`, which no `source` or `data` line declares",
                    s.node
                ),
            ));
        }
        if !writer.contains_key(s.node.as_str()) {
            return Err((
                s.line,
                format!("the sink reads `{}`, which no actor writes", s.node),
            ));
        }
        if let Some((_, l)) = addrs.iter().find(|(a, _)| **a == s.addr) {
            return Err((s.line, format!("{} is already a sink at line {l}", s.addr)));
        }
        addrs.push((&s.addr, s.line));
    }
    Ok(())
}
