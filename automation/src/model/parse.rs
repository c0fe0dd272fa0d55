//! The declarative model language: lexer, parser and name resolution.
//!
//! ```text
//! process NAME {
//!   input a, b            output c
//!   component pump_1, filter_bed
//!   process CHILD { ... }
//!   connect a -> CHILD.x            connect CHILD.y -> c
//!   failure NAME [derived] [components c1, c2]
//!   alarm NAME detects fm1, CHILD.fm2 [generator "sensor < limit"]
//!   propagate CHILD.fm -> fm prob 0.9 time 10..60 [assumed]
//! }
//! ```
//! Names are resolved relative to the process that declares the statement (`fm`, `CHILD.fm`,
//! `CHILD.GRANDCHILD.fm`), or absolutely when the first segment is the root's name. Whether a
//! resolved reference is *allowed* there (parent/child/sibling only) is a consistency check
//! ([`super::check`]), so that a model violating it still loads and gets a precise finding.

use super::*;
use std::collections::HashMap;

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Ident(String),
    Num(f64),
    Str(String),
    Sym(&'static str),
    Eof,
}

struct Lexer<'a> {
    chars: std::iter::Peekable<std::str::CharIndices<'a>>,
    line: u32,
    col: u32,
    file: &'a str,
}

type Spanned = (Tok, Span);

fn err(file: &str, span: Span, message: impl Into<String>) -> ModelError {
    ModelError {
        file: file.to_string(),
        line: span.line,
        col: span.col,
        message: message.into(),
    }
}

impl<'a> Lexer<'a> {
    fn bump(&mut self) -> Option<char> {
        let (_, c) = self.chars.next()?;
        if c == '\n' {
            self.line += 1;
            self.col = 1;
        } else {
            self.col += 1;
        }
        Some(c)
    }
    fn peek(&mut self) -> Option<char> {
        self.chars.peek().map(|&(_, c)| c)
    }

    fn tokens(mut self) -> Result<Vec<Spanned>, ModelError> {
        let mut out = Vec::new();
        loop {
            let Some(c) = self.peek() else {
                out.push((
                    Tok::Eof,
                    Span {
                        line: self.line,
                        col: self.col,
                    },
                ));
                return Ok(out);
            };
            let span = Span {
                line: self.line,
                col: self.col,
            };
            if c.is_whitespace() {
                self.bump();
            } else if c == '#' {
                while self.peek().is_some_and(|c| c != '\n') {
                    self.bump();
                }
            } else if c.is_ascii_alphabetic() || c == '_' {
                let mut s = String::new();
                while let Some(c) = self
                    .peek()
                    .filter(|c| c.is_ascii_alphanumeric() || *c == '_')
                {
                    s.push(c);
                    self.bump();
                }
                out.push((Tok::Ident(s), span));
            } else if c.is_ascii_digit() {
                let mut s = String::new();
                while let Some(c) = self.peek().filter(|c| c.is_ascii_digit()) {
                    s.push(c);
                    self.bump();
                }
                // A fraction only when a digit follows the dot: `10..60` is a range.
                let mut look = self.chars.clone();
                look.next();
                if self.peek() == Some('.') && look.peek().is_some_and(|&(_, c)| c.is_ascii_digit())
                {
                    s.push('.');
                    self.bump();
                    while let Some(c) = self.peek().filter(|c| c.is_ascii_digit()) {
                        s.push(c);
                        self.bump();
                    }
                }
                if matches!(self.peek(), Some('e') | Some('E')) {
                    s.push('e');
                    self.bump();
                    if let Some(c) = self.peek().filter(|c| *c == '-' || *c == '+') {
                        s.push(c);
                        self.bump();
                    }
                    while let Some(c) = self.peek().filter(|c| c.is_ascii_digit()) {
                        s.push(c);
                        self.bump();
                    }
                }
                let v: f64 = s
                    .parse()
                    .map_err(|_| err(self.file, span, format!("bad number `{s}`")))?;
                out.push((Tok::Num(v), span));
            } else if c == '"' {
                self.bump();
                let mut s = String::new();
                loop {
                    match self.bump() {
                        Some('"') => break,
                        Some('\n') | None => {
                            return Err(err(self.file, span, "unterminated string"));
                        }
                        Some(c) => s.push(c),
                    }
                }
                out.push((Tok::Str(s), span));
            } else {
                self.bump();
                let sym = match c {
                    '{' => "{",
                    '}' => "}",
                    ',' => ",",
                    '-' if self.peek() == Some('>') => {
                        self.bump();
                        "->"
                    }
                    '.' if self.peek() == Some('.') => {
                        self.bump();
                        ".."
                    }
                    '.' => ".",
                    other => {
                        return Err(err(
                            self.file,
                            span,
                            format!("unexpected character `{other}`"),
                        ));
                    }
                };
                out.push((Tok::Sym(sym), span));
            }
        }
    }
}

/// A dotted reference as written, with its place.
#[derive(Debug, Clone)]
struct RefAst {
    parts: Vec<String>,
    span: Span,
}

/// A failure-mode declaration: name, derived, components, place.
type FailureAst = (String, bool, Vec<(String, Span)>, Span);

#[derive(Debug, Default)]
struct ProcAst {
    name: String,
    span: Span,
    inputs: Vec<String>,
    outputs: Vec<String>,
    components: Vec<(String, Span)>,
    children: Vec<ProcAst>,
    connects: Vec<(RefAst, RefAst, Span)>,
    failures: Vec<FailureAst>,
    alarms: Vec<(String, Vec<RefAst>, Option<String>, Span)>,
    edges: Vec<(RefAst, RefAst, f64, f64, f64, bool, Span)>,
}

struct Parser<'a> {
    toks: Vec<Spanned>,
    pos: usize,
    file: &'a str,
    /// How many `process` blocks enclose the one being read (bounded by
    /// [`MAX_PROCESS_DEPTH`]: the parser and the resolver recurse once per level).
    depth: usize,
}

/// The deepest nesting of `process` blocks a model may have. The seed's ECLSS model is five
/// levels deep; without a bound, 100,000 nested `process a {` overflowed the stack and aborted
/// the process reading the file (e.g. a query server answering `diag_check` with a path).
pub const MAX_PROCESS_DEPTH: usize = 64;

impl Parser<'_> {
    fn peek(&self) -> &Tok {
        &self.toks[self.pos].0
    }
    fn span(&self) -> Span {
        self.toks[self.pos].1
    }
    fn next(&mut self) -> Spanned {
        let t = self.toks[self.pos].clone();
        if self.pos + 1 < self.toks.len() {
            self.pos += 1;
        }
        t
    }
    fn error(&self, msg: impl Into<String>) -> ModelError {
        err(self.file, self.span(), msg)
    }
    fn describe(t: &Tok) -> String {
        match t {
            Tok::Ident(s) => format!("`{s}`"),
            Tok::Num(v) => format!("number {v}"),
            Tok::Str(s) => format!("string \"{s}\""),
            Tok::Sym(s) => format!("`{s}`"),
            Tok::Eof => "end of file".into(),
        }
    }
    fn expect_sym(&mut self, s: &str) -> Result<(), ModelError> {
        if *self.peek()
            == Tok::Sym(match s {
                "{" => "{",
                "}" => "}",
                "->" => "->",
                ".." => "..",
                _ => ",",
            })
        {
            self.next();
            Ok(())
        } else {
            Err(self.error(format!(
                "expected `{s}`, found {}",
                Self::describe(self.peek())
            )))
        }
    }
    fn ident(&mut self, what: &str) -> Result<(String, Span), ModelError> {
        match self.peek().clone() {
            Tok::Ident(s) => {
                let sp = self.span();
                self.next();
                Ok((s, sp))
            }
            t => Err(self.error(format!("expected {what}, found {}", Self::describe(&t)))),
        }
    }
    fn keyword(&mut self, kw: &str) -> bool {
        if matches!(self.peek(), Tok::Ident(s) if s == kw) {
            self.next();
            true
        } else {
            false
        }
    }
    fn number(&mut self, what: &str) -> Result<f64, ModelError> {
        match *self.peek() {
            Tok::Num(v) => {
                self.next();
                Ok(v)
            }
            ref t => Err(self.error(format!(
                "expected {what} (a number), found {}",
                Self::describe(t)
            ))),
        }
    }
    fn ident_list(&mut self, what: &str) -> Result<Vec<(String, Span)>, ModelError> {
        let mut v = vec![self.ident(what)?];
        while *self.peek() == Tok::Sym(",") {
            self.next();
            v.push(self.ident(what)?);
        }
        Ok(v)
    }
    fn reference(&mut self, what: &str) -> Result<RefAst, ModelError> {
        let (first, span) = self.ident(what)?;
        let mut parts = vec![first];
        while *self.peek() == Tok::Sym(".") {
            self.next();
            parts.push(self.ident(what)?.0);
        }
        Ok(RefAst { parts, span })
    }

    /// `alarm NAME detects REF, ... [generator "TEXT"]`, after the keyword.
    fn alarm(&mut self, p: &mut ProcAst, sp: Span) -> Result<(), ModelError> {
        self.next();
        let (name, _) = self.ident("an alarm name")?;
        if !self.keyword("detects") {
            return Err(self.error(format!(
                "expected `detects` after alarm `{name}`, found {}",
                Self::describe(self.peek())
            )));
        }
        let mut refs = vec![self.reference("a failure-mode reference")?];
        while *self.peek() == Tok::Sym(",") {
            self.next();
            refs.push(self.reference("a failure-mode reference")?);
        }
        let generator = if self.keyword("generator") {
            match self.next() {
                (Tok::Str(s), _) => Some(s),
                (t, s) => {
                    return Err(err(
                        self.file,
                        s,
                        format!("expected a quoted generator, found {}", Self::describe(&t)),
                    ));
                }
            }
        } else {
            None
        };
        p.alarms.push((name, refs, generator, sp));
        Ok(())
    }

    /// `propagate REF -> REF prob P time TMIN..TMAX [assumed]`, after the keyword.
    fn propagate(&mut self, p: &mut ProcAst, sp: Span) -> Result<(), ModelError> {
        self.next();
        let a = self.reference("a failure-mode reference")?;
        self.expect_sym("->")?;
        let b = self.reference("a failure-mode reference")?;
        if !self.keyword("prob") {
            return Err(self.error(format!(
                "expected `prob`, found {}",
                Self::describe(self.peek())
            )));
        }
        let pspan = self.span();
        let prob = self.number("a probability")?;
        if !(prob > 0.0 && prob <= 1.0) {
            return Err(err(
                self.file,
                pspan,
                format!("probability {prob} is not in (0, 1]"),
            ));
        }
        if !self.keyword("time") {
            return Err(self.error(format!(
                "expected `time`, found {}",
                Self::describe(self.peek())
            )));
        }
        let tspan = self.span();
        let tmin = self.number("tmin in seconds")?;
        self.expect_sym("..")?;
        let tmax = self.number("tmax in seconds")?;
        if !(tmin >= 0.0 && tmin <= tmax && tmax.is_finite()) {
            return Err(err(
                self.file,
                tspan,
                format!("propagation time {tmin}..{tmax} needs 0 <= tmin <= tmax < inf"),
            ));
        }
        let assumed = self.keyword("assumed");
        p.edges.push((a, b, prob, tmin, tmax, assumed, sp));
        Ok(())
    }

    fn process(&mut self) -> Result<ProcAst, ModelError> {
        let kw_span = self.span();
        if !self.keyword("process") {
            return Err(self.error(format!(
                "expected `process`, found {}",
                Self::describe(self.peek())
            )));
        }
        let (name, _) = self.ident("a process name")?;
        self.expect_sym("{")?;
        let mut p = ProcAst {
            name,
            span: kw_span,
            ..Default::default()
        };
        loop {
            let sp = self.span();
            match self.peek().clone() {
                Tok::Sym("}") => {
                    self.next();
                    return Ok(p);
                }
                Tok::Ident(kw) => match kw.as_str() {
                    "process" => {
                        if self.depth >= MAX_PROCESS_DEPTH {
                            return Err(self.error(format!(
                                "processes nested more than {MAX_PROCESS_DEPTH} deep"
                            )));
                        }
                        self.depth += 1;
                        let child = self.process();
                        self.depth -= 1;
                        p.children.push(child?)
                    }
                    "input" | "output" => {
                        self.next();
                        let names = self
                            .ident_list("a signal name")?
                            .into_iter()
                            .map(|(n, _)| n);
                        if kw == "input" {
                            p.inputs.extend(names)
                        } else {
                            p.outputs.extend(names)
                        }
                    }
                    "component" => {
                        self.next();
                        p.components.extend(self.ident_list("a component name")?);
                    }
                    "connect" => {
                        self.next();
                        let a = self.reference("a signal reference")?;
                        self.expect_sym("->")?;
                        let b = self.reference("a signal reference")?;
                        p.connects.push((a, b, sp));
                    }
                    "failure" => {
                        self.next();
                        let (name, _) = self.ident("a failure-mode name")?;
                        let derived = self.keyword("derived");
                        let comps = if self.keyword("components") {
                            self.ident_list("a component name")?
                        } else {
                            Vec::new()
                        };
                        p.failures.push((name, derived, comps, sp));
                    }
                    "alarm" => self.alarm(&mut p, sp)?,
                    "propagate" => self.propagate(&mut p, sp)?,
                    other => {
                        return Err(self.error(format!(
                            "unknown statement `{other}` in process `{}` (expected process, input, output, component, connect, failure, alarm, propagate or `}}`)",
                            p.name
                        )));
                    }
                },
                t => {
                    return Err(self.error(format!(
                        "expected a statement or `}}`, found {}",
                        Self::describe(&t)
                    )));
                }
            }
        }
    }
}

/// Parses and resolves a model text. `file` names the source in error messages.
///
/// Errors ([`ModelError`], file:line:col): lexical and syntax errors, duplicate names (processes
/// among siblings, signals, failure modes within a process, alarms and components in the model),
/// references to unknown processes, signals, failure modes or components, probabilities outside
/// (0, 1], and time intervals that are not `0 <= tmin <= tmax`.
pub fn parse_model(text: &str, file: &str) -> Result<Model, ModelError> {
    let toks = Lexer {
        chars: text.char_indices().peekable(),
        line: 1,
        col: 1,
        file,
    }
    .tokens()?;
    let mut p = Parser {
        toks,
        pos: 0,
        file,
        depth: 0,
    };
    let root = p.process()?;
    if *p.peek() != Tok::Eof {
        return Err(p.error(format!(
            "expected end of file after the root process, found {}",
            Parser::describe(p.peek())
        )));
    }
    Resolver::new(file).resolve(root)
}

struct Resolver<'a> {
    file: &'a str,
    m: Model,
    asts: Vec<ProcAst>,
}

impl<'a> Resolver<'a> {
    fn new(file: &'a str) -> Self {
        Resolver {
            file,
            m: Model {
                source: file.to_string(),
                processes: Vec::new(),
                connections: Vec::new(),
                failure_modes: Vec::new(),
                alarms: Vec::new(),
                edges: Vec::new(),
                components: Vec::new(),
            },
            asts: Vec::new(),
        }
    }

    fn add_process(
        &mut self,
        mut ast: ProcAst,
        parent: Option<ProcId>,
    ) -> Result<ProcId, ModelError> {
        let id = self.m.processes.len();
        let (path, depth) = match parent {
            Some(q) => (
                format!("{}.{}", self.m.processes[q].path, ast.name),
                self.m.processes[q].depth + 1,
            ),
            None => (ast.name.clone(), 0),
        };
        for (list, what) in [(&ast.inputs, "input"), (&ast.outputs, "output")] {
            for (i, s) in list.iter().enumerate() {
                if list[..i].contains(s) || (what == "output" && ast.inputs.contains(s)) {
                    return Err(err(
                        self.file,
                        ast.span,
                        format!("signal `{s}` declared twice in process `{path}`"),
                    ));
                }
            }
        }
        self.m.processes.push(Process {
            name: ast.name.clone(),
            path,
            parent,
            children: Vec::new(),
            depth,
            inputs: ast.inputs.clone(),
            outputs: ast.outputs.clone(),
            failure_modes: Vec::new(),
            alarms: Vec::new(),
            span: ast.span,
        });
        let children = std::mem::take(&mut ast.children);
        self.asts.push(ast);
        for c in children {
            if self.m.processes[id]
                .children
                .iter()
                .any(|&k| self.m.processes[k].name == c.name)
            {
                return Err(err(
                    self.file,
                    c.span,
                    format!(
                        "process `{}` declared twice in `{}`",
                        c.name, self.m.processes[id].path
                    ),
                ));
            }
            let k = self.add_process(c, Some(id))?;
            self.m.processes[id].children.push(k);
        }
        Ok(id)
    }

    /// Resolves the process part of a reference: all segments but the last.
    fn walk(&self, from: ProcId, r: &RefAst) -> Result<ProcId, ModelError> {
        let segs = &r.parts[..r.parts.len() - 1];
        let child = |p: ProcId, n: &str| {
            self.m.processes[p]
                .children
                .iter()
                .copied()
                .find(|&k| self.m.processes[k].name == n)
        };
        let mut p = from;
        for (i, s) in segs.iter().enumerate() {
            p = match child(p, s) {
                Some(k) => k,
                None if i == 0 && *s == self.m.processes[0].name => 0,
                None => {
                    return Err(err(
                        self.file,
                        r.span,
                        format!(
                            "`{}`: no subprocess `{s}` in `{}`",
                            r.parts.join("."),
                            self.m.processes[p].path
                        ),
                    ));
                }
            };
        }
        Ok(p)
    }

    fn fm_ref(&self, from: ProcId, r: &RefAst) -> Result<FmId, ModelError> {
        let p = self.walk(from, r)?;
        let name = &r.parts[r.parts.len() - 1];
        self.m.processes[p]
            .failure_modes
            .iter()
            .copied()
            .find(|&f| self.m.failure_modes[f].name == *name)
            .ok_or_else(|| {
                err(
                    self.file,
                    r.span,
                    format!(
                        "no failure mode `{name}` in process `{}`",
                        self.m.processes[p].path
                    ),
                )
            })
    }

    fn signal_ref(&self, from: ProcId, r: &RefAst) -> Result<SignalRef, ModelError> {
        let p = self.walk(from, r)?;
        let name = &r.parts[r.parts.len() - 1];
        let proc_ = &self.m.processes[p];
        if !proc_.inputs.contains(name) && !proc_.outputs.contains(name) {
            return Err(err(
                self.file,
                r.span,
                format!("no signal `{name}` in process `{}`", proc_.path),
            ));
        }
        Ok(SignalRef {
            process: p,
            signal: name.clone(),
        })
    }

    fn resolve(mut self, root: ProcAst) -> Result<Model, ModelError> {
        self.add_process(root, None)?;
        let n = self.m.processes.len();
        // Components first (global namespace), then failure modes, so references can resolve.
        let mut comp_index: HashMap<String, CompId> = HashMap::new();
        for p in 0..n {
            for (c, sp) in self.asts[p].components.clone() {
                if comp_index.contains_key(&c) {
                    return Err(err(
                        self.file,
                        sp,
                        format!("component `{c}` declared twice"),
                    ));
                }
                comp_index.insert(c.clone(), self.m.components.len());
                self.m.components.push(Component { name: c, span: sp });
            }
        }
        for p in 0..n {
            for (name, derived, comps, sp) in self.asts[p].failures.clone() {
                if self.m.processes[p]
                    .failure_modes
                    .iter()
                    .any(|&f| self.m.failure_modes[f].name == name)
                {
                    return Err(err(
                        self.file,
                        sp,
                        format!(
                            "failure mode `{name}` declared twice in `{}`",
                            self.m.processes[p].path
                        ),
                    ));
                }
                let mut cs = Vec::new();
                for (c, csp) in comps {
                    let id = *comp_index.get(&c).ok_or_else(|| {
                        err(
                            self.file,
                            csp,
                            format!("unknown component `{c}` (declare it with `component {c}`)"),
                        )
                    })?;
                    cs.push(id);
                }
                let id = self.m.failure_modes.len();
                self.m.failure_modes.push(FailureMode {
                    path: format!("{}.{}", self.m.processes[p].path, name),
                    name,
                    process: p,
                    derived,
                    components: cs,
                    alarms: Vec::new(),
                    span: sp,
                });
                self.m.processes[p].failure_modes.push(id);
            }
        }
        for p in 0..n {
            for (a, b, sp) in self.asts[p].connects.clone() {
                let from = self.signal_ref(p, &a)?;
                let to = self.signal_ref(p, &b)?;
                self.m.connections.push(Connection {
                    owner: p,
                    from,
                    to,
                    span: sp,
                });
            }
            for (name, refs, generator, sp) in self.asts[p].alarms.clone() {
                if self.m.alarms.iter().any(|a| a.name == name) {
                    return Err(err(self.file, sp, format!("alarm `{name}` declared twice")));
                }
                let id = self.m.alarms.len();
                let mut detects = Vec::new();
                for r in &refs {
                    let f = self.fm_ref(p, r)?;
                    if !detects.contains(&f) {
                        detects.push(f);
                        self.m.failure_modes[f].alarms.push(id);
                    }
                }
                self.m.alarms.push(Alarm {
                    name,
                    process: p,
                    detects,
                    generator,
                    span: sp,
                });
                self.m.processes[p].alarms.push(id);
            }
            for (a, b, prob, tmin, tmax, assumed, sp) in self.asts[p].edges.clone() {
                let from = self.fm_ref(p, &a)?;
                let to = self.fm_ref(p, &b)?;
                if from == to {
                    return Err(err(
                        self.file,
                        sp,
                        "a propagation edge from a failure mode to itself",
                    ));
                }
                self.m.edges.push(Edge {
                    from,
                    to,
                    prob,
                    tmin,
                    tmax,
                    assumed,
                    owner: p,
                    span: sp,
                });
            }
        }
        Ok(self.m)
    }
}

#[cfg(test)]
#[expect(
    clippy::unwrap_used,
    reason = "a test unwraps: failing there is the test failing"
)]
mod tests {
    use super::*;

    #[test]
    fn issue_20_deeply_nested_processes_are_refused_not_a_stack_overflow() {
        // 100,000 levels overflowed the stack (one parser frame per level); now a located
        // error at the first `process` past the limit, on a 256 KiB thread to show the
        // recursion is bounded
        std::thread::Builder::new()
            .stack_size(256 << 10)
            .spawn(|| {
                let text = "process a {\n".repeat(100_000);
                let e = parse_model(&text, "deep.hfm").expect_err("too deep");
                assert_eq!(
                    e.to_string(),
                    format!(
                        "deep.hfm:{}:1: processes nested more than 64 deep",
                        MAX_PROCESS_DEPTH + 2
                    )
                );
                let ok = format!(
                    "{}{}",
                    "process a {\n".repeat(MAX_PROCESS_DEPTH + 1),
                    "}\n".repeat(MAX_PROCESS_DEPTH + 1)
                );
                let m = parse_model(&ok, "deep.hfm").expect("64 levels below the root");
                assert_eq!(m.max_depth(), MAX_PROCESS_DEPTH);
            })
            .expect("spawn")
            .join()
            .expect("the small-stack thread panicked");
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let e = parse_model(
            "process A {\n  failure x\n  propagate x -> y prob 0.5 time 1..2\n}\n",
            "m.hfm",
        )
        .unwrap_err();
        assert_eq!((e.line, e.col), (3, 18), "{e}");
        assert!(
            e.to_string().starts_with("m.hfm:3:18: no failure mode `y`"),
            "{e}"
        );
        let e = parse_model("process A {\n  bogus\n}", "m").unwrap_err();
        assert_eq!((e.line, e.col), (2, 3));
        let e = parse_model(
            "process A { failure x failure y propagate x -> y prob 1.5 time 1..2 }",
            "m",
        )
        .unwrap_err();
        assert!(e.message.contains("not in (0, 1]"), "{e}");
        let e = parse_model(
            "process A { failure x failure y propagate x -> y prob 1 time 3..2 }",
            "m",
        )
        .unwrap_err();
        assert!(e.message.contains("tmin <= tmax"), "{e}");
        let e = parse_model("process A { failure x components pump }", "m").unwrap_err();
        assert!(e.message.contains("unknown component `pump`"), "{e}");
    }

    #[test]
    fn ranges_and_decimals_lex_apart() {
        let m = parse_model(
            "process A { failure x failure y propagate x -> y prob 0.25 time 10..60.5 assumed }",
            "m",
        )
        .unwrap();
        let e = &m.edges[0];
        assert_eq!(
            (e.prob, e.tmin, e.tmax, e.assumed),
            (0.25, 10.0, 60.5, true)
        );
    }
}
