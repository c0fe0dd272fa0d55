//! The evaluator: declarations with parameter values → plain data ([`crate::model`]).
//!
//! Every check the language promises happens here, before anything is instantiated: names,
//! arity, types, units, ranges (shape parameters through the geometry crate's typed errors),
//! cycles (also found statically by [`crate::library`]), joint limits, rigid transforms.
//!
//! Layout: this file holds the evaluator, declaration binding and typed helpers; `expr.rs`
//! expressions; `builtins.rs` builtin functions and shape generators; `solids.rs`, `robots.rs`
//! and `scenes.rs` the bodies of those declarations.

use crate::ast::{Arg, Decl, DeclKind, Expr, ExprKind, LinkDef, Stmt};
use crate::error::{ErrorKind, RResult, RawError};
use crate::model::*;
use crate::source::Span;
use crate::units::{Dim, Quantity};
use crate::value::{JointKind, LinkVal, SolidVal, Value};
use nalgebra::{Isometry3, Matrix3, Matrix4, Rotation3, Translation3, UnitQuaternion, Vector3};
use robosim_geometry::{MassProperties, Polyhedron, shapes};
use robosim_kinematics::{Convention, Joint, JointType, Robot, fk};
use std::collections::HashMap;
use std::rc::Rc;

mod builtins;
mod effects;
mod expr;
mod robots;
mod scenes;
mod solids;
mod urdf;

pub(crate) use robots::single_link_robot;

/// The most polygons one evaluation may generate (a guard against `for` loops and facet counts
/// that would exhaust memory).
pub const POLYGON_BUDGET: usize = 5_000_000;

/// The most expression nodes one evaluation may evaluate. Declarations are evaluated where
/// they are used, so `let a1 = a0 + a0`, `let a2 = a1 + a1`, … doubles the work per line: 40
/// lines would take hours. Real libraries stay far below it (every standard-library
/// declaration evaluates within it: `tests/limits.rs`); a hostile one is stopped after seconds.
pub const EVAL_STEP_BUDGET: u64 = 20_000_000;

/// Options that apply to a whole evaluation.
#[derive(Debug, Clone, Default)]
pub struct EvalOptions {
    /// Facet count for every round primitive that does not give one explicitly (overrides
    /// declarations' `facets:` and the chord-error default). Used by the facet-count benchmark.
    pub facets: Option<usize>,
    /// The most polygons the evaluation may generate (default [`POLYGON_BUDGET`]).
    pub max_polygons: Option<usize>,
}

/// Names the evaluator knows without declarations.
pub const BUILTIN_FUNCTIONS: &[&str] = &[
    "sin",
    "cos",
    "tan",
    "atan2",
    "sqrt",
    "abs",
    "min",
    "max",
    "rgb",
    "translate",
    "rotate_x",
    "rotate_y",
    "rotate_z",
    "ypr",
    "matrix",
    "identity",
    "range",
    "box",
    "cylinder",
    "cone",
    "truncated_cone",
    "sphere",
    "extrude",
    "revolve",
];
pub const BUILTIN_CONSTANTS: &[&str] = &["pi", "on", "off", "true", "false", "identity"];

pub(crate) struct Evaluator<'l> {
    pub decls: &'l [Decl],
    pub index: &'l HashMap<String, usize>,
    pub opts: &'l EvalOptions,
    stack: Vec<usize>,
    facets: Vec<Option<usize>>,
    /// Polygons generated so far in this evaluation (bounded by [`EvalOptions::max_polygons`]).
    polygons: usize,
    /// Expression nodes evaluated so far (bounded by [`EVAL_STEP_BUDGET`]).
    pub(crate) steps: u64,
}

type Scope = HashMap<String, (Value, Span)>;
/// Call arguments: optional name (with its span), value, value span.
pub(crate) type Args = Vec<(Option<(String, Span)>, Value, Span)>;

fn err(kind: ErrorKind, span: Span, msg: impl Into<String>) -> RawError {
    RawError::new(kind, span, msg)
}

/// Edit distance for "did you mean".
fn levenshtein(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, &cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != cb))
                .min(prev[j + 1] + 1)
                .min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

pub(crate) fn suggest<'a>(
    name: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| (levenshtein(name, c), c))
        .filter(|(d, c)| *d <= 2.max(name.len() / 3) && *d < c.len())
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// The rigid motion of a validated rigid 4×4.
pub(crate) fn isometry(m: &Matrix4<f64>) -> Isometry3<f64> {
    let r = Rotation3::from_matrix_unchecked(m.fixed_view::<3, 3>(0, 0).into_owned());
    Isometry3::from_parts(
        Translation3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

impl<'l> Evaluator<'l> {
    pub fn new(
        decls: &'l [Decl],
        index: &'l HashMap<String, usize>,
        opts: &'l EvalOptions,
    ) -> Self {
        Evaluator {
            decls,
            index,
            opts,
            stack: Vec::new(),
            facets: Vec::new(),
            polygons: 0,
            steps: 0,
        }
    }

    // ---------------------------------------------------------------- declarations

    /// Evaluates declaration `di` with `args` (already evaluated, with the spans to blame),
    /// `call_span` being where it was called from (the declaration itself at top level).
    pub fn eval_decl(&mut self, di: usize, args: Args, call_span: Span) -> RResult<Value> {
        let decl = &self.decls[di];
        if let Some(pos) = self.stack.iter().position(|&d| d == di) {
            let chain: Vec<&str> = self.stack[pos..]
                .iter()
                .map(|&d| self.decls[d].name.as_str())
                .chain([decl.name.as_str()])
                .collect();
            return Err(err(
                ErrorKind::Cycle,
                call_span,
                format!("`{}` refers to itself: {}", decl.name, chain.join(" → ")),
            )
            .expected("declarations that refer to each other without a circle"));
        }
        if self.stack.len() > 64 {
            return Err(err(
                ErrorKind::Cycle,
                call_span,
                "declarations nest more than 64 deep",
            )
            .expected("a shallower part hierarchy"));
        }
        let mut scope = self.bind_params(decl, args, call_span)?;
        self.stack.push(di);
        let r = self.eval_decl_body(decl, &mut scope);
        self.stack.pop();
        r
    }

    fn bind_params(&mut self, decl: &Decl, args: Args, call_span: Span) -> RResult<Scope> {
        let mut given: Vec<Option<(Value, Span)>> = vec![None; decl.params.len()];
        let mut positional = 0;
        for (name, value, span) in args {
            let slot = match name {
                None => {
                    if positional >= decl.params.len() {
                        return Err(err(
                            ErrorKind::Arity,
                            span,
                            format!(
                                "too many arguments: {} `{}` takes {} parameter(s)",
                                decl.kind.as_str(),
                                decl.name,
                                decl.params.len()
                            ),
                        )
                        .expected(param_list(decl))
                        .note("declared here", decl.name_span));
                    }
                    positional += 1;
                    positional - 1
                }
                Some((n, nspan)) => match decl.params.iter().position(|p| p.name == n) {
                    Some(k) => k,
                    None => {
                        let mut e = err(
                            ErrorKind::UnknownProperty,
                            nspan,
                            format!(
                                "{} `{}` has no parameter `{n}`",
                                decl.kind.as_str(),
                                decl.name
                            ),
                        )
                        .expected(param_list(decl));
                        if let Some(s) = suggest(&n, decl.params.iter().map(|p| p.name.as_str())) {
                            e.message.push_str(&format!("; did you mean `{s}`?"));
                        }
                        return Err(e.note("declared here", decl.name_span));
                    }
                },
            };
            if given[slot].is_some() {
                return Err(err(
                    ErrorKind::Arity,
                    span,
                    format!("parameter `{}` is given twice", decl.params[slot].name),
                )
                .expected("each parameter at most once"));
            }
            given[slot] = Some((value, span));
        }
        let mut scope = Scope::new();
        for (k, p) in decl.params.iter().enumerate() {
            // defaults see the parameters before them
            let default = self.eval(&p.default, &scope)?;
            let (value, span) = match given[k].take() {
                Some((v, span)) => {
                    if !v.same_kind(&default) {
                        let kind = if matches!((&v, &default), (Value::Num(_), Value::Num(_))) {
                            ErrorKind::Unit
                        } else {
                            ErrorKind::Type
                        };
                        return Err(err(
                            kind,
                            span,
                            format!(
                                "parameter `{}` of `{}` is {}, but this is {}",
                                p.name,
                                decl.name,
                                default.describe(),
                                v.describe()
                            ),
                        )
                        .expected(default.describe())
                        .note("the parameter's default sets its unit", p.default.span));
                    }
                    (v, span)
                }
                None => (default, p.span),
            };
            scope.insert(p.name.clone(), (value, span));
        }
        let _ = call_span;
        Ok(scope)
    }

    fn eval_decl_body(&mut self, decl: &Decl, scope: &mut Scope) -> RResult<Value> {
        match decl.kind {
            DeclKind::Constant | DeclKind::Colour => {
                let Some(e) = &decl.value else {
                    return Err(err(
                        ErrorKind::Syntax,
                        decl.span,
                        "declaration without a value",
                    ));
                };
                let v = self.eval(e, scope)?;
                if decl.kind == DeclKind::Colour && !matches!(v, Value::Colour(_)) {
                    return Err(err(ErrorKind::Type, e.span, format!("colour `{}` is {}", decl.name, v.describe()))
                        .expected("a colour: rgb(red, green, blue) with components in [0, 1], or another colour's name"));
                }
                Ok(v)
            }
            DeclKind::Surface => self.surface(decl, scope),
            DeclKind::Solid => {
                self.push_facets(decl, scope)?;
                let r = self.solid_body(&decl.name, &decl.body, scope, decl.kind);
                self.facets.pop();
                Ok(Value::Solid(Rc::new(r?)))
            }
            DeclKind::Link => {
                self.push_facets(decl, scope)?;
                let r = self.link_body(&decl.name, &decl.body, scope, decl.name_span);
                self.facets.pop();
                Ok(Value::Link(Rc::new(r?)))
            }
            DeclKind::Robot => {
                self.push_facets(decl, scope)?;
                let r = self.robot_body(decl, scope);
                self.facets.pop();
                Ok(Value::Robot(Rc::new(r?)))
            }
            DeclKind::Scene => Err(err(
                ErrorKind::Type,
                decl.name_span,
                "a scene cannot be used as a value",
            )),
        }
    }

    /// A declaration's `facets:` property applies to the primitives of its whole body.
    fn push_facets(&mut self, decl: &Decl, scope: &Scope) -> RResult<()> {
        self.push_facets_body(&decl.body, scope)
    }

    /// The same for an inline body (an inline link); pop with `self.facets.pop()`.
    pub(super) fn push_facets_body(&mut self, body: &[Stmt], scope: &Scope) -> RResult<()> {
        let mut f = self.facets.last().copied().flatten();
        for s in body {
            if let Stmt::Prop { name, value, .. } = s
                && name == "facets"
            {
                f = Some(self.count(value, scope, 3, shapes::FACET_LIMIT)?);
            }
        }
        self.facets.push(f);
        Ok(())
    }

    pub fn eval_scene(&mut self, di: usize, args: Args) -> RResult<SceneModel> {
        let decl = &self.decls[di];
        let mut scope = self.bind_params(decl, args, decl.name_span)?;
        self.stack.push(di);
        self.push_facets(decl, &scope)?;
        let r = self.scene_body(decl, &mut scope);
        self.facets.pop();
        self.stack.pop();
        r
    }

    fn surface(&mut self, decl: &Decl, scope: &mut Scope) -> RResult<Value> {
        let mut s = Surface {
            name: decl.name.clone(),
            colour: [0.7, 0.7, 0.7],
            specular: 0.3,
            shininess: 20.0,
            opacity: 1.0,
        };
        let mut seen = Seen::default();
        for st in &decl.body {
            match st {
                Stmt::Let {
                    name,
                    name_span,
                    value,
                } => self.let_(name, *name_span, value, scope)?,
                Stmt::Prop {
                    name,
                    name_span,
                    value,
                } => {
                    seen.check(name, *name_span)?;
                    match name.as_str() {
                        "colour" | "color" => s.colour = self.colour(value, scope)?,
                        "specular" => s.specular = self.unit_range(value, scope, 0.0, 1.0)?,
                        "shininess" => s.shininess = self.unit_range(value, scope, 0.0, 1000.0)?,
                        "opacity" => s.opacity = self.unit_range(value, scope, 0.0, 1.0)?,
                        _ => {
                            return Err(unknown_prop(
                                "surface",
                                name,
                                *name_span,
                                &["colour", "specular", "shininess", "opacity"],
                            ));
                        }
                    }
                }
                other => {
                    return Err(misplaced(
                        other,
                        "a surface",
                        "`colour:`, `specular:`, `shininess:`, `opacity:` or `let`",
                    ));
                }
            }
        }
        Ok(Value::Surface(Rc::new(s)))
    }

    fn let_(&mut self, name: &str, span: Span, value: &Expr, scope: &mut Scope) -> RResult<()> {
        if let Some((_, prev)) = scope.get(name) {
            return Err(err(
                ErrorKind::Duplicate,
                span,
                format!("`{name}` is already defined in this declaration"),
            )
            .expected("a new name")
            .note("first defined here", *prev));
        }
        let v = self.eval(value, scope)?;
        scope.insert(name.to_string(), (v, span));
        Ok(())
    }

    // ---------------------------------------------------------------- typed helpers

    fn quantity(&mut self, e: &Expr, scope: &Scope, dim: Dim, example: &str) -> RResult<f64> {
        let v = self.eval(e, scope)?;
        self.num_of(&v, e.span, dim, example)
    }

    fn num_of(&self, v: &Value, span: Span, dim: Dim, example: &str) -> RResult<f64> {
        match v {
            Value::Num(q) if q.fits(dim) => {
                if q.value.is_finite() {
                    Ok(q.value)
                } else {
                    Err(err(
                        ErrorKind::OutOfRange,
                        span,
                        format!("value is not finite ({})", q.value),
                    )
                    .expected("a finite number"))
                }
            }
            Value::Num(q) => Err(err(
                ErrorKind::Unit,
                span,
                format!(
                    "expected {}, found {} ({})",
                    dim.describe(),
                    q.dim.noun(),
                    q.show()
                ),
            )
            .expected(example.to_string())),
            other => Err(err(
                ErrorKind::Type,
                span,
                format!("expected {}, found {}", dim.describe(), other.describe()),
            )
            .expected(example.to_string())),
        }
    }

    /// Any number (SI, whatever its dimension): friction and motor inertia.
    fn quantity_any(&mut self, e: &Expr, scope: &Scope) -> RResult<f64> {
        match self.eval(e, scope)? {
            Value::Num(q) if q.value.is_finite() => Ok(q.value),
            other => Err(err(
                ErrorKind::Type,
                e.span,
                format!("expected a number, found {}", other.describe()),
            )
            .expected("a number in SI units")),
        }
    }

    fn unit_range(&mut self, e: &Expr, scope: &Scope, lo: f64, hi: f64) -> RResult<f64> {
        let v = self.quantity(e, scope, Dim::NONE, "a plain number")?;
        if !(lo..=hi).contains(&v) {
            return Err(err(
                ErrorKind::OutOfRange,
                e.span,
                format!("{v} is out of range [{lo}, {hi}]"),
            )
            .expected(format!("a number from {lo} to {hi}")));
        }
        Ok(v)
    }

    fn count(&mut self, e: &Expr, scope: &Scope, lo: usize, hi: usize) -> RResult<usize> {
        let v = self.quantity(e, scope, Dim::NONE, "a whole number")?;
        if v.fract() != 0.0 || v < lo as f64 || v > hi as f64 {
            return Err(err(
                ErrorKind::OutOfRange,
                e.span,
                format!("{v} is not a whole number in [{lo}, {hi}]"),
            )
            .expected(format!("a whole number from {lo} to {hi}")));
        }
        Ok(v as usize)
    }

    /// Adds `n` generated polygons to this evaluation's count, refused at `span` past the budget
    /// ([`EvalOptions::max_polygons`], else [`POLYGON_BUDGET`]); `advice` is how to stay within it.
    fn count_polygons(&mut self, n: usize, span: Span, advice: &str) -> RResult<()> {
        self.polygons += n;
        let budget = self.opts.max_polygons.unwrap_or(POLYGON_BUDGET);
        if self.polygons > budget {
            return Err(err(
                ErrorKind::OutOfRange,
                span,
                format!("the model has more than {budget} polygons"),
            )
            .expected(advice));
        }
        Ok(())
    }

    fn vector(
        &mut self,
        e: &Expr,
        scope: &Scope,
        dim: Dim,
        n: usize,
        what: &str,
    ) -> RResult<Vec<f64>> {
        let v = self.eval(e, scope)?;
        let Value::List(items) = v else {
            return Err(err(
                ErrorKind::Type,
                e.span,
                format!("expected a list of {n}, found {}", v.describe()),
            )
            .expected(what.to_string()));
        };
        if items.len() != n {
            return Err(err(
                ErrorKind::Arity,
                e.span,
                format!("expected {n} values, found {}", items.len()),
            )
            .expected(what.to_string()));
        }
        items
            .iter()
            .map(|(v, s)| self.num_of(v, *s, dim, what))
            .collect()
    }

    fn inertia(&mut self, e: &Expr, scope: &Scope) -> RResult<Matrix3<f64>> {
        const WHAT: &str =
            "[Ixx, Iyy, Izz], [Ixx, Iyy, Izz, Ixy, Iyz, Ixz] or a 3×3 list, in kg*m^2";
        let v = self.eval(e, scope)?;
        let Value::List(items) = v else {
            return Err(err(
                ErrorKind::Type,
                e.span,
                format!("expected an inertia, found {}", v.describe()),
            )
            .expected(WHAT));
        };
        let m = if items.len() == 3 && items.iter().all(|(v, _)| matches!(v, Value::List(_))) {
            let mut m = Matrix3::zeros();
            for (r, (row, rs)) in items.iter().enumerate() {
                let Value::List(cols) = row else {
                    unreachable!("checked to be lists above")
                };
                if cols.len() != 3 {
                    return Err(err(
                        ErrorKind::Arity,
                        *rs,
                        format!("inertia row has {} values", cols.len()),
                    )
                    .expected(WHAT));
                }
                for (c, (v, s)) in cols.iter().enumerate() {
                    m[(r, c)] = self.num_of(v, *s, Dim::INERTIA, WHAT)?;
                }
            }
            if (m - m.transpose()).abs().max() > 1e-12 * m.abs().max().max(1e-300) {
                return Err(err(
                    ErrorKind::OutOfRange,
                    e.span,
                    "the inertia matrix is not symmetric",
                )
                .expected("a symmetric 3×3 matrix"));
            }
            m
        } else {
            let v: Vec<f64> = items
                .iter()
                .map(|(v, s)| self.num_of(v, *s, Dim::INERTIA, WHAT))
                .collect::<RResult<_>>()?;
            match v.len() {
                3 => Matrix3::from_diagonal(&Vector3::new(v[0], v[1], v[2])),
                6 => Matrix3::new(v[0], v[3], v[5], v[3], v[1], v[4], v[5], v[4], v[2]),
                n => {
                    return Err(err(
                        ErrorKind::Arity,
                        e.span,
                        format!("an inertia needs 3, 6 or 3×3 values, found {n}"),
                    )
                    .expected(WHAT));
                }
            }
        };
        // Positive semi-definite. (The triangle inequality is not enforced: published lumped
        // models such as the PUMA 560's link 1, [0, 0.35, 0] kg·m², give only the moment about
        // the joint axis.)
        let ev = m.symmetric_eigenvalues();
        let tol = 1e-9 * ev.abs().max().max(1e-300);
        if ev.iter().any(|&x| x < -tol) {
            return Err(err(
                ErrorKind::OutOfRange,
                e.span,
                "this inertia has a negative principal moment",
            )
            .expected("a positive semi-definite inertia (kg*m^2)"));
        }
        Ok(m)
    }

    fn colour(&mut self, e: &Expr, scope: &Scope) -> RResult<Rgb> {
        match self.eval(e, scope)? {
            Value::Colour(c) => Ok(c),
            other => Err(err(
                ErrorKind::Type,
                e.span,
                format!("expected a colour, found {}", other.describe()),
            )
            .expected("rgb(r, g, b) or a declared colour's name")),
        }
    }

    fn surface_ref(&mut self, e: &Expr, scope: &Scope) -> RResult<Surface> {
        match self.eval(e, scope)? {
            Value::Surface(s) => Ok((*s).clone()),
            other => Err(err(
                ErrorKind::Type,
                e.span,
                format!("expected a surface, found {}", other.describe()),
            )
            .expected("a declared surface's name")),
        }
    }

    fn transform(&mut self, e: &Expr, scope: &Scope) -> RResult<Matrix4<f64>> {
        match self.eval(e, scope)? {
            Value::Transform(m) => Ok(m),
            other => Err(err(ErrorKind::Type, e.span, format!("expected a transform, found {}", other.describe()))
                .expected("translate(x, y, z), rotate_x/y/z(angle), ypr(yaw, pitch, roll), matrix(…) or a product of them with `*`")),
        }
    }

    fn switch(&mut self, e: &Expr, scope: &Scope) -> RResult<bool> {
        match self.eval(e, scope)? {
            Value::Bool(b) => Ok(b),
            other => Err(err(
                ErrorKind::Type,
                e.span,
                format!("expected on or off, found {}", other.describe()),
            )
            .expected("`on` or `off`")),
        }
    }

    /// A bare word from a fixed set (joint types, conventions, modes).
    fn word(&mut self, e: &Expr, allowed: &[&str], what: &str) -> RResult<String> {
        let list = allowed.join(", ");
        match &e.kind {
            ExprKind::Name(w) if allowed.contains(&w.as_str()) => Ok(w.clone()),
            ExprKind::Name(w) => {
                let mut m = format!("`{w}` is not a {what}");
                if let Some(s) = suggest(w, allowed.iter().copied()) {
                    m.push_str(&format!("; did you mean `{s}`?"));
                }
                Err(err(ErrorKind::UnknownName, e.span, m).expected(format!("one of: {list}")))
            }
            _ => Err(err(ErrorKind::Type, e.span, format!("expected a {what}"))
                .expected(format!("one of the words: {list}"))),
        }
    }

    // expressions: see expr.rs (eval, operators, names) and builtins.rs (builtin calls)
}

fn param_list(decl: &Decl) -> String {
    if decl.params.is_empty() {
        return format!("no arguments: `{}` has no parameters", decl.name);
    }
    let ps: Vec<&str> = decl.params.iter().map(|p| p.name.as_str()).collect();
    format!("{}({})", decl.name, ps.join(", "))
}

fn show(v: f64, dim: Dim) -> String {
    Quantity::new(v, dim).show()
}

fn callee_name(e: &Expr) -> Option<String> {
    match &e.kind {
        ExprKind::Call { name, .. } | ExprKind::Name(name) => Some(name.clone()),
        _ => None,
    }
}

/// Fills unset colours and surfaces with a declaration's defaults.
fn fill_appearance(parts: &mut [PlacedSolid], colour: Option<Rgb>, surface: Option<&Surface>) {
    for p in parts {
        if p.colour.is_none() {
            p.colour = colour;
        }
        if p.surface.is_none() {
            p.surface = surface.cloned();
        }
    }
}

#[derive(Default)]
struct Seen(HashMap<String, Span>);

impl Seen {
    fn check(&mut self, name: &str, span: Span) -> RResult<()> {
        let key = if name == "color" { "colour" } else { name };
        if let Some(prev) = self.0.insert(key.to_string(), span) {
            return Err(err(
                ErrorKind::Duplicate,
                span,
                format!("`{name}` is given twice"),
            )
            .expected("each property once")
            .note("first given here", prev));
        }
        Ok(())
    }
}

/// The properties of a `{ … }` group that holds nothing else (a scene's `collision { … }`,
/// `dynamics { … }`): each as (name, span, value) in order, every name at most once; any other
/// statement in it is refused as misplaced in `inside`, `expected` saying what may be there.
fn group_props<'b>(
    body: &'b [Stmt],
    inside: &str,
    expected: &str,
) -> RResult<Vec<(&'b str, Span, &'b Expr)>> {
    let mut seen = Seen::default();
    let mut out = Vec::with_capacity(body.len());
    for st in body {
        match st {
            Stmt::Prop {
                name,
                name_span,
                value,
            } => {
                seen.check(name, *name_span)?;
                out.push((name.as_str(), *name_span, value));
            }
            other => return Err(misplaced(other, inside, expected)),
        }
    }
    Ok(out)
}

fn unknown_prop(what: &str, name: &str, span: Span, allowed: &[&str]) -> RawError {
    let mut msg = format!("a {what} has no property `{name}`");
    if let Some(s) = suggest(name, allowed.iter().copied()) {
        msg.push_str(&format!("; did you mean `{s}`?"));
    }
    err(ErrorKind::UnknownProperty, span, msg).expected(format!("one of: {}", allowed.join(", ")))
}

trait ExpectedMore {
    fn expected_more(self, more: &str) -> Self;
}
impl ExpectedMore for RawError {
    fn expected_more(mut self, more: &str) -> Self {
        if let Some(e) = &mut self.expected {
            e.push(' ');
            e.push_str(more);
        }
        self
    }
}

fn misplaced(st: &Stmt, inside: &str, expected: &str) -> RawError {
    let (what, span) = match st {
        Stmt::Let { name_span, .. } => ("`let`", *name_span),
        Stmt::Prop { name_span, .. } => ("a property", *name_span),
        Stmt::Block { name_span, .. } => ("a `{ … }` group", *name_span),
        Stmt::Part { span, .. } => ("`part`", *span),
        Stmt::Link { span, .. } => ("`link`", *span),
        Stmt::Place { span, .. } => ("`place`", *span),
    };
    err(
        ErrorKind::Syntax,
        span,
        format!("{what} is not allowed in {inside}"),
    )
    .expected(expected.to_string())
}
