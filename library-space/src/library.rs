//! A loaded library: files parsed, names resolved, cycles refused, every declaration evaluated
//! once at its defaults (so every error the language can catch is caught at load time), and the
//! API to list, inspect and evaluate declarations.

use crate::ast::{Decl, DeclKind, Expr, ExprKind, LinkDef, Stmt};
use crate::error::{ErrorKind, LibError, RawError};
use crate::eval::{BUILTIN_CONSTANTS, BUILTIN_FUNCTIONS, EvalOptions, Evaluator, suggest};
use crate::model::Evaluated;
use crate::source::{Location, SourceFile, SourceMap, Span};
use crate::units::{Dim, unit};
use crate::value::Value;
use crate::{lexer, parser, stdlib};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// A parsed, checked library (the Library Space's content).
#[derive(Debug, Clone)]
pub struct Library {
    pub(crate) map: SourceMap,
    pub(crate) decls: Vec<Decl>,
    pub(crate) index: HashMap<String, usize>,
}

/// One declaration as listed by [`Library::declarations`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DeclInfo {
    pub name: String,
    pub kind: DeclKind,
    /// The `//` comment above the declaration.
    pub doc: Option<String>,
    /// file:line:col of its name.
    pub location: String,
}

/// One parameter as listed by [`Library::params`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ParamInfo {
    pub name: String,
    /// The default as written in the source (`431.8 mm`).
    pub default_source: String,
    /// The default's value in SI units, when it is a number.
    pub default_si: Option<f64>,
    /// The unit dimension in SI (`m`, `rad`, `kg`, `1`), or the value kind (`colour`, …).
    pub unit: String,
    /// Human description: "a length (m, cm, mm)".
    pub kind: String,
}

/// A parameter value for [`Library::evaluate`].
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    /// A number in SI units (m, rad, kg, s); its dimension is the default's.
    Si(f64),
    /// An expression in the language, e.g. `"45 deg"`, `"0.5 m + 2 cm"`, `"rgb(1, 0, 0)"`.
    Expr(String),
}

/// Parameter values by name.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Params(pub Vec<(String, ParamValue)>);

impl Params {
    pub fn new() -> Self {
        Params::default()
    }
    /// Sets `name` to an SI number.
    pub fn si(mut self, name: &str, v: f64) -> Self {
        self.0.push((name.to_string(), ParamValue::Si(v)));
        self
    }
    /// Sets `name` to an expression in the language.
    pub fn expr(mut self, name: &str, e: &str) -> Self {
        self.0
            .push((name.to_string(), ParamValue::Expr(e.to_string())));
        self
    }
}

/// Why a request to the library failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// An error in library source (or in a parameter expression), located.
    #[error("{0}")]
    Source(LibError),
    /// No declaration has this name.
    #[error("no declaration named `{name}`{}", suggestion.as_ref().map(|s| format!("; did you mean `{s}`?")).unwrap_or_default())]
    NoSuchDeclaration {
        name: String,
        suggestion: Option<String>,
    },
    /// The declaration has no parameter of this name.
    #[error("`{decl}` has no parameter `{name}`; its parameters are: {}", known.join(", "))]
    NoSuchParameter {
        decl: String,
        name: String,
        known: Vec<String>,
    },
    /// A parameter value of the wrong kind or unit. `message` continues the sentence that
    /// names the parameter ("is a length, but this is a number").
    #[error("parameter `{name}` of `{decl}` {message}")]
    BadParameter {
        decl: String,
        name: String,
        message: String,
    },
    /// A file could not be read.
    #[error("cannot read {path}: {message}")]
    Io { path: String, message: String },
}

impl From<LibError> for Error {
    fn from(e: LibError) -> Self {
        Error::Source(e)
    }
}

impl std::str::FromStr for Library {
    type Err = LibError;
    /// `text.parse::<Library>()`: [`Library::from_source`] with the file name `<string>`.
    fn from_str(text: &str) -> Result<Library, LibError> {
        Library::from_source("<string>", text)
    }
}

/// Builds a library from files; follows includes once each.
struct Loader {
    map: SourceMap,
    decls: Vec<Decl>,
    seen: HashSet<String>,
}

impl Loader {
    fn add(
        &mut self,
        key: String,
        display: String,
        text: String,
        dir: Option<PathBuf>,
    ) -> Result<(), LibError> {
        let embedded = stdlib::FILES.iter().any(|(n, _)| *n == key);
        if !self.seen.insert(key) {
            return Ok(());
        }
        let id = self.map.add(display, text);
        let text = &self.map.files[id as usize].text;
        let toks = lexer::lex(id, text).map_err(|e| e.locate(&self.map))?;
        let mut ast = parser::parse(&toks).map_err(|e| e.locate(&self.map))?;
        for (inc, span) in &ast.includes {
            self.include(inc, *span, dir.as_deref())?;
        }
        resolve_urdf(&mut ast.decls, embedded, dir.as_deref());
        self.decls.extend(ast.decls);
        Ok(())
    }

    fn include(&mut self, inc: &str, span: Span, dir: Option<&Path>) -> Result<(), LibError> {
        if inc == "std" {
            for (name, text) in stdlib::FILES {
                self.add(name.to_string(), name.to_string(), text.to_string(), None)?;
            }
            return Ok(());
        }
        if let Some(rest) = inc.strip_prefix("std/") {
            return match stdlib::FILES
                .iter()
                .find(|(n, _)| n.strip_prefix("std/") == Some(rest))
            {
                Some((name, text)) => {
                    self.add(name.to_string(), name.to_string(), text.to_string(), None)
                }
                None => {
                    let names: Vec<&str> = stdlib::FILES.iter().map(|(n, _)| *n).collect();
                    Err(RawError::new(
                        ErrorKind::Include,
                        span,
                        format!("the standard library has no file `{inc}`"),
                    )
                    .expected(format!("one of: std, {}", names.join(", ")))
                    .locate(&self.map))
                }
            };
        }
        let path = match dir {
            Some(d) => d.join(inc),
            None => PathBuf::from(inc),
        };
        let text = crate::source::read_source_file(&path).map_err(|e| {
            RawError::new(
                ErrorKind::Include,
                span,
                format!("cannot read included file `{}`: {e}", path.display()),
            )
            .expected("a readable file, relative to the including file's folder, or `std/NAME.rsl`")
            .locate(&self.map)
        })?;
        let key = std::fs::canonicalize(&path)
            .unwrap_or(path.clone())
            .display()
            .to_string();
        self.add(
            key,
            path.display().to_string(),
            text,
            path.parent().map(Path::to_path_buf),
        )
    }

    fn finish(self) -> Result<Library, LibError> {
        let Loader { map, decls, .. } = self;
        let mut index = HashMap::new();
        for (k, d) in decls.iter().enumerate() {
            if BUILTIN_FUNCTIONS.contains(&d.name.as_str())
                || BUILTIN_CONSTANTS.contains(&d.name.as_str())
                || unit(&d.name).is_some()
            {
                return Err(RawError::new(
                    ErrorKind::Duplicate,
                    d.name_span,
                    format!("`{}` is a builtin name", d.name),
                )
                .expected("a name that is not a builtin function, constant or unit")
                .locate(&map));
            }
            if let Some(&prev) = index.get(&d.name) {
                let p: &Decl = &decls[prev];
                return Err(RawError::new(
                    ErrorKind::Duplicate,
                    d.name_span,
                    format!("`{}` is declared twice", d.name),
                )
                .expected("a unique name for every declaration")
                .note(
                    format!("first declared here as a {}", p.kind.as_str()),
                    p.name_span,
                )
                .locate(&map));
            }
            index.insert(d.name.clone(), k);
        }
        let lib = Library { map, decls, index };
        lib.find_cycles()?;
        lib.check_all()?;
        Ok(lib)
    }
}

impl Library {
    /// Loads a file (and what it includes), checks it, and returns the library. Errors carry
    /// file:line:col. Every file read is a regular file of at most
    /// [`MAX_SOURCE_BYTES`](crate::MAX_SOURCE_BYTES) bytes ([`Error::Io`] otherwise, naming the
    /// path and why; an `include` of such a file is an [`ErrorKind::Include`] error).
    pub fn load(path: impl AsRef<Path>) -> Result<Library, Error> {
        let path = path.as_ref();
        let text = crate::source::read_source_file(path).map_err(|message| Error::Io {
            path: path.display().to_string(),
            message,
        })?;
        let mut l = Loader {
            map: SourceMap::default(),
            decls: vec![],
            seen: HashSet::new(),
        };
        let key = std::fs::canonicalize(path)
            .unwrap_or(path.to_path_buf())
            .display()
            .to_string();
        l.add(
            key,
            path.display().to_string(),
            text,
            path.parent().map(Path::to_path_buf),
        )?;
        Ok(l.finish()?)
    }

    /// [`Library::load`] of a user's file with the standard library visible to it: a scene of
    /// the file can place `puma560()` or use `steel` without `include "std"` (an explicit
    /// `include "std"` is followed once, as before). The library holds both; a declaration of
    /// the file named like a standard one is a duplicate, as with `include "std"`.
    /// [`Library::own_declarations`] lists the file's own.
    pub fn load_with_standard(path: impl AsRef<Path>) -> Result<Library, Error> {
        let path = path.as_ref();
        let text = crate::source::read_source_file(path).map_err(|message| Error::Io {
            path: path.display().to_string(),
            message,
        })?;
        let mut l = Loader {
            map: SourceMap::default(),
            decls: vec![],
            seen: HashSet::new(),
        };
        for (name, text) in stdlib::FILES {
            l.add(name.to_string(), name.to_string(), text.to_string(), None)?;
        }
        let key = std::fs::canonicalize(path)
            .unwrap_or(path.to_path_buf())
            .display()
            .to_string();
        l.add(
            key,
            path.display().to_string(),
            text,
            path.parent().map(Path::to_path_buf),
        )?;
        Ok(l.finish()?)
    }

    /// The declarations not from the standard library's embedded files, in source order.
    pub fn own_declarations(&self) -> Vec<DeclInfo> {
        let std_files: Vec<&str> = stdlib::FILES.iter().map(|(n, _)| *n).collect();
        self.declarations()
            .into_iter()
            .filter(|d| {
                !std_files
                    .iter()
                    .any(|f| d.location.starts_with(&format!("{f}:")))
            })
            .collect()
    }

    /// Parses and checks `text` as if it were the file `name`. Includes are resolved relative
    /// to the current directory (`std/…` from the embedded standard library).
    pub fn from_source(name: &str, text: &str) -> Result<Library, LibError> {
        let mut l = Loader {
            map: SourceMap::default(),
            decls: vec![],
            seen: HashSet::new(),
        };
        l.add(
            format!("<source>{name}"),
            name.to_string(),
            text.to_string(),
            None,
        )?;
        l.finish()
    }

    /// The standard library shipped inside the crate (`library-space/stdlib/*.rsl`).
    pub fn standard() -> Result<Library, LibError> {
        Library::from_source("<standard library>", "include \"std\"\n")
    }

    /// The text of every file this library was built from, as (name, text), in load order —
    /// what a process needs to rebuild the library with [`Library::from_sources`] (e.g. from
    /// shared memory) without reading any file.
    pub fn sources(&self) -> Vec<(String, String)> {
        self.map
            .files
            .iter()
            .map(|f| (f.path.clone(), f.text.clone()))
            .collect()
    }

    /// Rebuilds a library from the complete file list of [`Library::sources`]. `include`
    /// statements are not followed (every included file is in the list already); the result
    /// is checked exactly as [`Library::load`] checks.
    pub fn from_sources(files: &[(String, String)]) -> Result<Library, LibError> {
        let mut l = Loader {
            map: SourceMap::default(),
            decls: vec![],
            seen: HashSet::new(),
        };
        for (name, text) in files {
            let id = l.map.add(name.clone(), text.clone());
            let text = &l.map.files[id as usize].text;
            let toks = lexer::lex(id, text).map_err(|e| e.locate(&l.map))?;
            let mut ast = parser::parse(&toks).map_err(|e| e.locate(&l.map))?;
            let embedded = stdlib::FILES.iter().any(|(n, t)| n == name && t == text);
            resolve_urdf(&mut ast.decls, embedded, Path::new(name.as_str()).parent());
            l.decls.extend(ast.decls);
        }
        l.finish()
    }

    /// Every declaration with its kind, in source order.
    pub fn declarations(&self) -> Vec<DeclInfo> {
        self.decls
            .iter()
            .map(|d| {
                let l = self.map.locate(d.name_span);
                DeclInfo {
                    name: d.name.clone(),
                    kind: d.kind,
                    doc: d.doc.clone(),
                    location: format!("{}:{}:{}", l.file, l.line, l.column),
                }
            })
            .collect()
    }

    /// The robot file a `robot NAME from_urdf "FILE"` declaration reads, as resolved; `None`
    /// for any other declaration (or a file name that did not resolve). The URDF export reads
    /// the file's own visual and collision geometry from it.
    pub fn robot_file(&self, name: &str) -> Option<std::path::PathBuf> {
        let d = &self.decls[*self.index.get(name)?];
        d.urdf.as_ref()?.resolved.clone().ok()
    }

    /// The kind of declaration `name`, if there is one.
    pub fn kind(&self, name: &str) -> Option<DeclKind> {
        self.index.get(name).map(|&i| self.decls[i].kind)
    }

    fn find(&self, name: &str) -> Result<usize, Error> {
        self.index
            .get(name)
            .copied()
            .ok_or_else(|| Error::NoSuchDeclaration {
                name: name.to_string(),
                suggestion: suggest(name, self.index.keys().map(String::as_str))
                    .map(str::to_string),
            })
    }

    /// The parameters of declaration `name`: names, defaults (source and SI) and units.
    pub fn params(&self, name: &str) -> Result<Vec<ParamInfo>, Error> {
        let di = self.find(name)?;
        let opts = EvalOptions::default();
        let mut ev = Evaluator::new(&self.decls, &self.index, &opts);
        let mut scope = HashMap::new();
        let mut out = Vec::new();
        for p in &self.decls[di].params {
            let v = ev
                .eval(&p.default, &scope)
                .map_err(|e| e.locate(&self.map))?;
            let (si, unit, kind) = match &v {
                Value::Num(q) => (Some(q.value), q.dim.to_string(), q.dim.describe()),
                other => (
                    None,
                    other
                        .describe()
                        .trim_start_matches("a ")
                        .trim_start_matches("an ")
                        .to_string(),
                    other.describe(),
                ),
            };
            let f = &self.map.files[p.default.span.file as usize];
            out.push(ParamInfo {
                name: p.name.clone(),
                default_source: f.text[p.default.span.start as usize..p.default.span.end as usize]
                    .to_string(),
                default_si: si,
                unit,
                kind,
            });
            scope.insert(p.name.clone(), (v, p.span));
        }
        Ok(out)
    }

    /// Evaluates declaration `name` with `params` (the rest at their defaults) to plain data.
    pub fn evaluate(&self, name: &str, params: &Params) -> Result<Evaluated, Error> {
        self.evaluate_with(name, params, &EvalOptions::default())
    }

    /// [`Library::evaluate`] with options (e.g. a facet count for every round primitive).
    pub fn evaluate_with(
        &self,
        name: &str,
        params: &Params,
        opts: &EvalOptions,
    ) -> Result<Evaluated, Error> {
        let di = self.find(name)?;
        let decl = &self.decls[di];
        let mut ev = Evaluator::new(&self.decls, &self.index, opts);
        // parameter values → evaluator values, checked against the defaults' kinds
        let mut args = Vec::new();
        let mut extra: Vec<SourceFile> = Vec::new();
        let info = self.params(name)?;
        for (pname, pv) in &params.0 {
            let Some(pi) = info.iter().find(|i| &i.name == pname) else {
                return Err(Error::NoSuchParameter {
                    decl: name.into(),
                    name: pname.clone(),
                    known: info.iter().map(|i| i.name.clone()).collect(),
                });
            };
            let bad = |message: String| Error::BadParameter {
                decl: name.into(),
                name: pname.clone(),
                message,
            };
            let value = match pv {
                ParamValue::Si(x) => {
                    let Some(_) = pi.default_si else {
                        return Err(bad(format!("is {}; give it as an expression", pi.kind)));
                    };
                    let dim = self.param_dim(di, pname, &mut ev)?;
                    if !x.is_finite() {
                        return Err(bad(format!("is {x}, which is not finite")));
                    }
                    Value::Num(crate::units::Quantity::new(*x, dim))
                }
                ParamValue::Expr(text) => {
                    let id = (self.map.files.len() + extra.len()) as u32;
                    extra.push(SourceFile::new(
                        format!("<parameter {pname}>"),
                        text.clone(),
                    ));
                    let locate = |e: RawError| {
                        let mut m = self.map.clone();
                        m.files.extend(extra.iter().cloned());
                        Error::Source(e.locate(&m))
                    };
                    let toks = lexer::lex(id, text).map_err(locate)?;
                    let expr = parse_single_expr(&toks).map_err(locate)?;
                    ev.eval(&expr, &HashMap::new()).map_err(locate)?
                }
            };
            // a sentinel span (no such file) naming the argument's index, mapped back below
            let k = args.len();
            let sentinel = Span::new(u32::MAX, k, k);
            args.push((Some((pname.clone(), sentinel)), value, sentinel));
        }
        let locate = |e: RawError| -> Error {
            // argument errors carry a sentinel span; report them as parameter errors
            if e.span.file == u32::MAX {
                let pname = params
                    .0
                    .get(e.span.start as usize)
                    .map(|p| p.0.clone())
                    .unwrap_or_default();
                // The evaluator's message names the parameter already: say it once.
                let prefix = format!("parameter `{pname}` of `{name}` ");
                let message = match e.message.strip_prefix(&prefix) {
                    Some(rest) => rest.to_owned(),
                    None => format!("is refused: {}", e.message),
                };
                return Error::BadParameter {
                    decl: name.into(),
                    name: pname,
                    message,
                };
            }
            Error::Source(e.locate(&self.map))
        };
        Ok(match decl.kind {
            DeclKind::Scene => Evaluated::Scene(ev.eval_scene(di, args).map_err(locate)?),
            _ => match ev.eval_decl(di, args, decl.name_span).map_err(locate)? {
                Value::Num(q) => Evaluated::Constant {
                    value: q.value,
                    unit: q.dim.to_string(),
                },
                Value::Colour(c) => Evaluated::Colour { rgb: c },
                Value::Surface(s) => Evaluated::Surface((*s).clone()),
                Value::Solid(s) => Evaluated::Solid(crate::model::SolidModel {
                    name: name.into(),
                    parts: s.parts.clone(),
                    mass: s.mass,
                }),
                Value::Link(l) => Evaluated::Link(crate::eval::single_link_robot(&l)),
                Value::Robot(r) => Evaluated::Robot((*r).clone()),
                other => {
                    return Err(Error::Source(
                        RawError::new(
                            ErrorKind::Type,
                            decl.name_span,
                            format!("constant `{name}` is {}", other.describe()),
                        )
                        .expected("a number, colour, surface, solid, link, robot or scene")
                        .locate(&self.map),
                    ));
                }
            },
        })
    }

    fn param_dim(&self, di: usize, pname: &str, ev: &mut Evaluator) -> Result<Dim, Error> {
        let mut scope = HashMap::new();
        for p in &self.decls[di].params {
            let v = ev
                .eval(&p.default, &scope)
                .map_err(|e| Error::Source(e.locate(&self.map)))?;
            if p.name == pname {
                return Ok(v.dim().unwrap_or(Dim::NONE));
            }
            scope.insert(p.name.clone(), (v, p.span));
        }
        Ok(Dim::NONE)
    }

    /// Locates a span of this library (file:line:col and the line's text).
    pub fn locate(&self, span: Span) -> Location {
        self.map.locate(span)
    }

    /// Static check for declarations that refer to each other in a circle.
    fn find_cycles(&self) -> Result<(), LibError> {
        let refs: Vec<Vec<(usize, Span)>> = self.decls.iter().map(|d| self.references(d)).collect();
        // 0 = unvisited, 1 = on the stack, 2 = done
        let mut state = vec![0u8; self.decls.len()];
        let mut path: Vec<(usize, Span)> = Vec::new();
        fn dfs(
            u: usize,
            refs: &[Vec<(usize, Span)>],
            state: &mut [u8],
            path: &mut Vec<(usize, Span)>,
        ) -> Option<(Vec<usize>, Span)> {
            state[u] = 1;
            for &(v, span) in &refs[u] {
                if state[v] == 1 {
                    let start = path.iter().position(|&(p, _)| p == v).unwrap_or(0);
                    let mut cyc: Vec<usize> = path[start..].iter().map(|&(p, _)| p).collect();
                    cyc.push(u);
                    cyc.push(v);
                    cyc.dedup();
                    return Some((cyc, span));
                }
                if state[v] == 0 {
                    path.push((u, span));
                    if let Some(c) = dfs(v, refs, state, path) {
                        return Some(c);
                    }
                    path.pop();
                }
            }
            state[u] = 2;
            None
        }
        for u in 0..self.decls.len() {
            if state[u] == 0 {
                path.clear();
                if let Some((cyc, span)) = dfs(u, &refs, &mut state, &mut path) {
                    let names: Vec<&str> =
                        cyc.iter().map(|&k| self.decls[k].name.as_str()).collect();
                    let first = &self.decls[cyc[0]];
                    return Err(RawError::new(
                        ErrorKind::Cycle,
                        span,
                        format!(
                            "declarations refer to each other in a circle: {}",
                            names.join(" → ")
                        ),
                    )
                    .expected(
                        "a part hierarchy without cycles (a declaration cannot contain itself)",
                    )
                    .note(
                        format!("`{}` is declared here", first.name),
                        first.name_span,
                    )
                    .locate(&self.map));
                }
            }
        }
        Ok(())
    }

    /// Declarations referenced by `d`'s parameter defaults and body (names not shadowed by its
    /// parameters or variables).
    fn references(&self, d: &Decl) -> Vec<(usize, Span)> {
        let mut local: HashSet<&str> = d.params.iter().map(|p| p.name.as_str()).collect();
        fn lets<'a>(body: &'a [Stmt], out: &mut HashSet<&'a str>) {
            for s in body {
                match s {
                    Stmt::Let { name, .. }
                    | Stmt::Part {
                        repeat: Some((name, _, _)),
                        ..
                    } => {
                        out.insert(name);
                    }
                    Stmt::Block { body, .. }
                    | Stmt::Link {
                        def: LinkDef::Inline(body),
                        ..
                    } => lets(body, out),
                    _ => {}
                }
            }
        }
        lets(&d.body, &mut local);
        let mut out = Vec::new();
        let mut visit = |e: &Expr| self.expr_refs(e, &local, &mut out);
        for p in &d.params {
            visit(&p.default);
        }
        if let Some(v) = &d.value {
            visit(v);
        }
        fn stmts(body: &[Stmt], f: &mut dyn FnMut(&Expr)) {
            for s in body {
                match s {
                    Stmt::Let { value, .. } | Stmt::Prop { value, .. } => f(value),
                    Stmt::Block { body, .. }
                    | Stmt::Link {
                        def: LinkDef::Inline(body),
                        ..
                    } => stmts(body, f),
                    Stmt::Link {
                        def: LinkDef::Ref(e),
                        ..
                    } => f(e),
                    Stmt::Part {
                        shape,
                        at,
                        colour,
                        surface,
                        repeat,
                        ..
                    } => {
                        f(shape);
                        if let Some((_, _, e)) = repeat {
                            f(e);
                        }
                        for e in [at, colour, surface].into_iter().flatten() {
                            f(e);
                        }
                    }
                    Stmt::Place { item, at, q, .. } => {
                        f(item);
                        for e in [at, q].into_iter().flatten() {
                            f(e);
                        }
                    }
                }
            }
        }
        stmts(&d.body, &mut visit);
        out
    }

    fn expr_refs(&self, e: &Expr, local: &HashSet<&str>, out: &mut Vec<(usize, Span)>) {
        match &e.kind {
            ExprKind::Name(n) => {
                if !local.contains(n.as_str())
                    && let Some(&k) = self.index.get(n)
                {
                    out.push((k, e.span));
                }
            }
            ExprKind::Call {
                name,
                name_span,
                args,
            } => {
                if let Some(&k) = self.index.get(name) {
                    out.push((k, *name_span));
                }
                for a in args {
                    self.expr_refs(&a.value, local, out);
                }
            }
            ExprKind::Neg(x) => self.expr_refs(x, local, out),
            ExprKind::Chain { first, rest } => {
                self.expr_refs(first, local, out);
                for (_, e) in rest {
                    self.expr_refs(e, local, out);
                }
            }
            ExprKind::Binary { lhs, rhs, .. } => {
                self.expr_refs(lhs, local, out);
                self.expr_refs(rhs, local, out);
            }
            ExprKind::List(items) => {
                for i in items {
                    self.expr_refs(i, local, out);
                }
            }
            ExprKind::Num { .. } | ExprKind::Str(_) => {}
        }
    }

    /// Evaluates every declaration at its defaults: the load-time check.
    fn check_all(&self) -> Result<(), LibError> {
        let opts = EvalOptions::default();
        for (k, d) in self.decls.iter().enumerate() {
            let mut ev = Evaluator::new(&self.decls, &self.index, &opts);
            let r = if d.kind == DeclKind::Scene {
                ev.eval_scene(k, vec![]).map(|_| ())
            } else {
                ev.eval_decl(k, vec![], d.name_span).map(|_| ())
            };
            r.map_err(|e| e.locate(&self.map))?;
        }
        Ok(())
    }
}

/// Resolves the `from_urdf` file names of `decls` (declared in one file): absolute names as
/// they are; relative ones against `dir`, the declaring file's folder (`None`: a text without
/// a file, resolved against the current directory as its includes are), made absolute so the
/// result does not depend on a later change of directory. A standard-library file is
/// embedded and has no folder: its relative names are refused when the robot is evaluated.
fn resolve_urdf(decls: &mut [Decl], embedded: bool, dir: Option<&Path>) {
    for d in decls {
        let Some(u) = &mut d.urdf else { continue };
        let p = Path::new(&u.path);
        u.resolved = if p.is_absolute() {
            Ok(p.to_path_buf())
        } else if embedded {
            Err(format!(
                "`{}` is relative, and the standard library's files are embedded in the program, with no folder to resolve it against",
                u.path
            ))
        } else {
            let joined = dir.map_or_else(|| p.to_path_buf(), |d| d.join(p));
            std::path::absolute(&joined)
                .map_err(|e| format!("cannot make `{}` an absolute path: {e}", joined.display()))
        };
    }
}

/// A parameter expression: exactly one expression and nothing after it.
fn parse_single_expr(toks: &[lexer::Token]) -> Result<Expr, RawError> {
    // Reuse the declaration parser on `let _ = EXPR`
    let mut wrapped = Vec::with_capacity(toks.len() + 3);
    let s = toks.first().map(|t| t.span).unwrap_or_default();
    let at = |tok| lexer::Token {
        tok,
        span: Span { end: s.start, ..s },
        doc: None,
    };
    wrapped.push(at(lexer::Tok::Ident("let".into())));
    wrapped.push(at(lexer::Tok::Ident("__param".into())));
    wrapped.push(at(lexer::Tok::Punct('=')));
    wrapped.extend_from_slice(toks);
    let ast = parser::parse(&wrapped)?;
    match (
        ast.decls.len(),
        ast.decls.into_iter().next().and_then(|d| d.value),
    ) {
        (1, Some(e)) => Ok(e),
        _ => Err(RawError::new(
            ErrorKind::Syntax,
            s,
            "a parameter value must be a single expression",
        )
        .expected("one expression such as `45 deg`")),
    }
}
