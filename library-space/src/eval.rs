//! The evaluator: declarations with parameter values → plain data ([`crate::model`]).
//!
//! Every check the language promises happens here, before anything is instantiated: names,
//! arity, types, units, ranges (shape parameters through the geometry crate's typed errors),
//! cycles (also found statically by [`crate::library`]), joint limits, rigid transforms.

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

/// The most polygons one evaluation may generate (a guard against `for` loops and facet counts
/// that would exhaust memory).
pub const POLYGON_BUDGET: usize = 5_000_000;

/// Options that apply to a whole evaluation.
#[derive(Debug, Clone, Default)]
pub struct EvalOptions {
    /// Facet count for every round primitive that does not give one explicitly (overrides
    /// declarations' `facets:` and the chord-error default). Used by the facet-count benchmark.
    pub facets: Option<usize>,
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
    /// Polygons generated so far in this evaluation (bounded by [`POLYGON_BUDGET`]).
    polygons: usize,
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

fn rigid_ok(m: &Matrix4<f64>) -> bool {
    let r = m.fixed_view::<3, 3>(0, 0);
    m.iter().all(|v| v.is_finite())
        && (r.transpose() * r - Matrix3::identity()).abs().max() < 1e-9
        && (r.determinant() - 1.0).abs() < 1e-9
        && m[(3, 0)] == 0.0
        && m[(3, 1)] == 0.0
        && m[(3, 2)] == 0.0
        && m[(3, 3)] == 1.0
}

/// The rigid motion of a validated rigid 4×4.
pub(crate) fn isometry(m: &Matrix4<f64>) -> Isometry3<f64> {
    let r = Rotation3::from_matrix_unchecked(m.fixed_view::<3, 3>(0, 0).into_owned());
    Isometry3::from_parts(
        Translation3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

fn translation(x: f64, y: f64, z: f64) -> Matrix4<f64> {
    Matrix4::new_translation(&Vector3::new(x, y, z))
}

fn rot(axis: Vector3<f64>, a: f64) -> Matrix4<f64> {
    Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), a).to_homogeneous()
}

/// What a builtin argument must be.
#[derive(Clone, Copy)]
enum Want {
    Q(Dim),
    Count,
    Points,
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
        let mut f = self.facets.last().copied().flatten();
        for s in &decl.body {
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

    /// Parts of a solid/link/robot body: `part` statements and the `colour:`/`surface:` defaults.
    #[expect(
        clippy::too_many_arguments,
        reason = "the pieces of one `part` statement, passed apart so `for` can rebind the name"
    )]
    fn part(
        &mut self,
        owner: &str,
        counter: &mut usize,
        name: &Option<(String, Span)>,
        shape: &Expr,
        at: &Option<Expr>,
        colour: &Option<Expr>,
        surface: &Option<Expr>,
        repeat: &Option<(String, Span, Expr)>,
        scope: &Scope,
        out: &mut Vec<PlacedSolid>,
    ) -> RResult<()> {
        if let Some((var, vspan, list)) = repeat {
            let items = match self.eval(list, scope)? {
                Value::List(items) => items,
                other => {
                    return Err(err(
                        ErrorKind::Type,
                        list.span,
                        format!("`for` needs a list, found {}", other.describe()),
                    )
                    .expected("a list such as range(4) or [0, 1, 2]"));
                }
            };
            if scope.contains_key(var) {
                return Err(err(
                    ErrorKind::Duplicate,
                    *vspan,
                    format!("`{var}` is already defined"),
                )
                .expected("a new loop variable name"));
            }
            for (k, (item, _)) in items.into_iter().enumerate() {
                let mut inner = scope.clone();
                inner.insert(var.clone(), (item, *vspan));
                let named = name.as_ref().map(|(n, s)| (format!("{n}{k}"), *s));
                self.part(
                    owner, counter, &named, shape, at, colour, surface, &None, &inner, out,
                )?;
            }
            return Ok(());
        }
        let v = self.eval(shape, scope)?;
        let Value::Solid(sv) = v else {
            return Err(err(
                ErrorKind::Type,
                shape.span,
                format!(
                    "a part of `{owner}` must be a solid, but this is {}",
                    v.describe()
                ),
            )
            .expected("a primitive such as box(…), cylinder(…) or a declared solid"));
        };
        let t = match at {
            Some(e) => self.transform(e, scope)?,
            None => Matrix4::identity(),
        };
        let c = colour.as_ref().map(|e| self.colour(e, scope)).transpose()?;
        let s = surface
            .as_ref()
            .map(|e| self.surface_ref(e, scope))
            .transpose()?;
        *counter += 1;
        let pname = match name {
            Some((n, _)) => n.clone(),
            None => {
                let base = match sv.parts.first() {
                    Some(p) if sv.parts.len() == 1 => p.name.clone(),
                    _ => callee_name(shape).unwrap_or_else(|| "part".into()),
                };
                format!("{base}{counter}")
            }
        };
        let single = sv.parts.len() == 1;
        for p in &sv.parts {
            out.push(PlacedSolid {
                name: if single {
                    pname.clone()
                } else {
                    format!("{pname}/{}", p.name)
                },
                primitive: p.primitive.clone(),
                polyhedron: p.polyhedron.clone(),
                transform: t * p.transform,
                colour: c.or(p.colour),
                surface: s.clone().or_else(|| p.surface.clone()),
            });
        }
        Ok(())
    }

    fn solid_body(
        &mut self,
        owner: &str,
        body: &[Stmt],
        scope: &mut Scope,
        _kind: DeclKind,
    ) -> RResult<SolidVal> {
        let mut parts = Vec::new();
        let mut counter = 0;
        let mut seen = Seen::default();
        let (mut colour, mut surface, mut density, mut mass) = (None, None, None, None);
        for st in body {
            match st {
                Stmt::Let {
                    name,
                    name_span,
                    value,
                } => self.let_(name, *name_span, value, scope)?,
                Stmt::Part {
                    name,
                    shape,
                    at,
                    colour: c,
                    surface: s,
                    repeat,
                    ..
                } => self.part(
                    owner,
                    &mut counter,
                    name,
                    shape,
                    at,
                    c,
                    s,
                    repeat,
                    scope,
                    &mut parts,
                )?,
                Stmt::Prop {
                    name,
                    name_span,
                    value,
                } => {
                    seen.check(name, *name_span)?;
                    match name.as_str() {
                        "colour" | "color" => colour = Some(self.colour(value, scope)?),
                        "surface" => surface = Some(self.surface_ref(value, scope)?),
                        "facets" => {}
                        "density" => {
                            density = Some((
                                self.quantity(
                                    value,
                                    scope,
                                    Dim::DENSITY,
                                    "a density such as 2700 kg/m^3",
                                )?,
                                value.span,
                            ))
                        }
                        "mass" => {
                            mass = Some((
                                self.quantity(value, scope, Dim::MASS, "a mass such as 3 kg")?,
                                value.span,
                            ))
                        }
                        _ => {
                            return Err(unknown_prop(
                                "solid",
                                name,
                                *name_span,
                                &["colour", "surface", "facets", "density", "mass"],
                            ));
                        }
                    }
                }
                other => {
                    return Err(misplaced(
                        other,
                        "a solid",
                        "`part`, `let` or a property (colour, surface, facets, density, mass)",
                    ));
                }
            }
        }
        fill_appearance(&mut parts, colour, surface.as_ref());
        let mp = match (density, mass) {
            (Some(_), Some((_, span))) => {
                return Err(err(
                    ErrorKind::Duplicate,
                    span,
                    "both `density` and `mass` are given",
                )
                .expected("one of them: the other follows from the volume"));
            }
            (Some((rho, span)), None) => Some(self.parts_mass(&parts, Some(rho), None, span)?),
            (None, Some((m, span))) => Some(self.parts_mass(&parts, None, Some(m), span)?),
            (None, None) => None,
        };
        Ok(SolidVal { parts, mass: mp })
    }

    /// Mass properties of placed parts (in the owner's frame) for a density or a total mass.
    fn parts_mass(
        &self,
        parts: &[PlacedSolid],
        density: Option<f64>,
        mass: Option<f64>,
        span: Span,
    ) -> RResult<MassProperties> {
        if !density.unwrap_or(0.0).is_finite()
            || density.unwrap_or(0.0) < 0.0
            || !mass.unwrap_or(0.0).is_finite()
            || mass.unwrap_or(0.0) < 0.0
        {
            return Err(err(
                ErrorKind::OutOfRange,
                span,
                "mass and density must be zero or positive",
            )
            .expected("a value ≥ 0"));
        }
        if parts.is_empty() {
            return Err(err(
                ErrorKind::Missing,
                span,
                "mass properties from geometry need at least one `part`",
            )
            .expected("a `part`, or an explicit `com:` and `inertia:` with the mass"));
        }
        let mut each = Vec::with_capacity(parts.len());
        for p in parts {
            let mp = p
                .polyhedron
                .mass_properties(density.unwrap_or(1.0))
                .map_err(|e| {
                    err(
                        ErrorKind::OutOfRange,
                        span,
                        format!("part `{}`: {e}", p.name),
                    )
                })?;
            each.push(mp.transformed(&isometry(&p.transform)));
        }
        // at least one part, so combine returns Some
        let mut total = MassProperties::combine(&each)
            .ok_or_else(|| err(ErrorKind::Missing, span, "no parts"))?;
        if let Some(m) = mass {
            let k = if total.volume > 0.0 {
                m / total.mass
            } else {
                0.0
            };
            total.inertia *= k;
            total.mass = m;
        }
        Ok(total)
    }

    fn link_body(
        &mut self,
        name: &str,
        body: &[Stmt],
        scope: &mut Scope,
        span: Span,
    ) -> RResult<LinkVal> {
        let mut parts = Vec::new();
        let mut counter = 0;
        let mut seen = Seen::default();
        let mut props: HashMap<&str, &Expr> = HashMap::new();
        let mut colour = None;
        let mut surface = None;
        const PROPS: &[&str] = &[
            "joint",
            "a",
            "alpha",
            "d",
            "theta",
            "offset",
            "limits",
            "mass",
            "density",
            "com",
            "inertia",
            "motor_inertia",
            "viscous",
            "coulomb",
            "colour",
            "color",
            "surface",
            "facets",
        ];
        for st in body {
            match st {
                Stmt::Let {
                    name,
                    name_span,
                    value,
                } => self.let_(name, *name_span, value, scope)?,
                Stmt::Part {
                    name: pn,
                    shape,
                    at,
                    colour: c,
                    surface: s,
                    repeat,
                    ..
                } => self.part(
                    name,
                    &mut counter,
                    pn,
                    shape,
                    at,
                    c,
                    s,
                    repeat,
                    scope,
                    &mut parts,
                )?,
                Stmt::Prop {
                    name: p,
                    name_span,
                    value,
                } => {
                    seen.check(p, *name_span)?;
                    match p.as_str() {
                        "colour" | "color" => colour = Some(self.colour(value, scope)?),
                        "surface" => surface = Some(self.surface_ref(value, scope)?),
                        "facets" => {}
                        k if PROPS.contains(&k) => {
                            // PROPS holds 'static strs; find the static one for the map key
                            let key = PROPS.iter().find(|s| **s == k).copied().unwrap_or("joint");
                            props.insert(key, value);
                        }
                        _ => return Err(unknown_prop("link", p, *name_span, PROPS)),
                    }
                }
                other => {
                    return Err(misplaced(
                        other,
                        "a link",
                        "`part`, `let` or a property such as `joint:`, `a:`, `alpha:`, `limits:`, `mass:`",
                    ));
                }
            }
        }
        fill_appearance(&mut parts, colour, surface.as_ref());
        let kind = match props.get("joint") {
            Some(e) => match self
                .word(e, &["revolute", "prismatic", "fixed"], "joint type")?
                .as_str()
            {
                "revolute" => JointKind::Moving(JointType::Revolute),
                "prismatic" => JointKind::Moving(JointType::Prismatic),
                _ => JointKind::Fixed,
            },
            None => {
                return Err(err(
                    ErrorKind::Missing,
                    span,
                    format!("link `{name}` has no `joint:`"),
                )
                .expected("`joint: revolute`, `joint: prismatic` or `joint: fixed`"));
            }
        };
        let len = |s: &mut Self, k: &str| -> RResult<f64> {
            props.get(k).map_or(Ok(0.0), |e| {
                s.quantity(e, scope, Dim::LENGTH, "a length such as 431.8 mm")
            })
        };
        let ang = |s: &mut Self, k: &str| -> RResult<f64> {
            props.get(k).map_or(Ok(0.0), |e| {
                s.quantity(e, scope, Dim::ANGLE, "an angle such as 90 deg")
            })
        };
        let a = len(self, "a")?;
        let alpha = ang(self, "alpha")?;
        let (mut d, mut theta, offset);
        match kind {
            JointKind::Moving(JointType::Prismatic) => {
                if let Some(e) = props.get("d") {
                    return Err(err(
                        ErrorKind::UnknownProperty,
                        e.span,
                        "a prismatic joint's `d` is its joint variable",
                    )
                    .expected("`offset:` (added to q to give d) and `theta:` (constant)"));
                }
                d = 0.0;
                theta = ang(self, "theta")?;
                offset = len(self, "offset")?;
            }
            JointKind::Moving(JointType::Revolute) => {
                if let Some(e) = props.get("theta") {
                    return Err(err(
                        ErrorKind::UnknownProperty,
                        e.span,
                        "a revolute joint's `theta` is its joint variable",
                    )
                    .expected("`offset:` (added to q to give θ) and `d:` (constant)"));
                }
                d = len(self, "d")?;
                theta = 0.0;
                offset = ang(self, "offset")?;
            }
            JointKind::Fixed => {
                d = len(self, "d")?;
                theta = ang(self, "theta")?;
                offset = 0.0;
                if props.contains_key("limits") {
                    let e = props["limits"];
                    return Err(err(
                        ErrorKind::UnknownProperty,
                        e.span,
                        "a fixed joint has no limits",
                    )
                    .expected("no `limits:` on a fixed link"));
                }
            }
        }
        let qlim = match (kind, props.get("limits")) {
            (JointKind::Fixed, _) => [0.0, 0.0],
            (JointKind::Moving(t), Some(e)) => {
                let (dim, what) = match t {
                    JointType::Revolute => (
                        Dim::ANGLE,
                        "[lower, upper] angles, e.g. [-160 deg, 160 deg]",
                    ),
                    JointType::Prismatic => {
                        (Dim::LENGTH, "[lower, upper] lengths, e.g. [0, 1.2 m]")
                    }
                };
                let v = self.vector(e, scope, dim, 2, what)?;
                if v[0] > v[1] {
                    return Err(err(
                        ErrorKind::OutOfRange,
                        e.span,
                        format!(
                            "joint limits are reversed: lower {} > upper {}",
                            show(v[0], dim),
                            show(v[1], dim)
                        ),
                    )
                    .expected("lower ≤ upper"));
                }
                [v[0], v[1]]
            }
            (JointKind::Moving(JointType::Revolute), None) => {
                [-std::f64::consts::PI, std::f64::consts::PI]
            }
            (JointKind::Moving(JointType::Prismatic), None) => {
                return Err(err(
                    ErrorKind::Missing,
                    span,
                    format!("prismatic link `{name}` has no `limits:`"),
                )
                .expected("`limits: [lower, upper]` in metres, e.g. [0, 1.2 m]"));
            }
        };
        // dynamics
        let density = props
            .get("density")
            .map(|e| {
                self.quantity(e, scope, Dim::DENSITY, "a density such as 2700 kg/m^3")
                    .map(|v| (v, e.span))
            })
            .transpose()?;
        let mass = props
            .get("mass")
            .map(|e| {
                self.quantity(e, scope, Dim::MASS, "a mass such as 3 kg")
                    .map(|v| (v, e.span))
            })
            .transpose()?;
        let com = props
            .get("com")
            .map(|e| {
                self.vector(
                    e,
                    scope,
                    Dim::LENGTH,
                    3,
                    "[x, y, z] lengths in the link frame",
                )
                .map(|v| (v, e.span))
            })
            .transpose()?;
        let inertia = props
            .get("inertia")
            .map(|e| self.inertia(e, scope).map(|m| (m, e.span)))
            .transpose()?;
        let (mass_v, com_v, inertia_v) = match (density, mass) {
            (Some(_), Some((_, span))) => {
                return Err(err(
                    ErrorKind::Duplicate,
                    span,
                    "both `density` and `mass` are given",
                )
                .expected("one of them: the other follows from the volume"));
            }
            (Some((rho, span)), None) => {
                if let Some((_, s)) = com
                    .as_ref()
                    .map(|c| ((), c.1))
                    .or(inertia.as_ref().map(|i| ((), i.1)))
                {
                    return Err(err(
                        ErrorKind::Duplicate,
                        s,
                        "`com`/`inertia` are computed from `density` and cannot be given too",
                    )
                    .expected(
                        "either density (everything from geometry) or mass with com and inertia",
                    ));
                }
                let mp = self.parts_mass(&parts, Some(rho), None, span)?;
                (mp.mass, mp.center_of_mass.coords, mp.inertia)
            }
            (None, Some((m, span))) => {
                if m < 0.0 {
                    return Err(
                        err(ErrorKind::OutOfRange, span, "mass must be zero or positive")
                            .expected("a mass ≥ 0 kg"),
                    );
                }
                let geo = if (com.is_none() || inertia.is_none()) && !parts.is_empty() {
                    Some(self.parts_mass(&parts, None, Some(m), span)?)
                } else {
                    None
                };
                let c = com
                    .map(|c| Vector3::new(c.0[0], c.0[1], c.0[2]))
                    .or(geo.map(|g| g.center_of_mass.coords))
                    .unwrap_or_default();
                let i = inertia
                    .map(|i| i.0)
                    .or(geo.map(|g| g.inertia))
                    .unwrap_or_default();
                (m, c, i)
            }
            (None, None) => {
                if let Some((_, s)) = com
                    .as_ref()
                    .map(|c| ((), c.1))
                    .or(inertia.as_ref().map(|i| ((), i.1)))
                {
                    return Err(
                        err(ErrorKind::Missing, s, "`com`/`inertia` without a `mass`")
                            .expected("`mass:` (or `density:`) as well"),
                    );
                }
                (0.0, Vector3::zeros(), Matrix3::zeros())
            }
        };
        let plain = |s: &mut Self, k: &str| -> RResult<f64> {
            match props.get(k) {
                Some(e) => {
                    // quantity_any refuses non-finite values
                    let v = s.quantity_any(e, scope)?;
                    if v < 0.0 {
                        return Err(err(
                            ErrorKind::OutOfRange,
                            e.span,
                            format!("`{k}` must be zero or positive"),
                        )
                        .expected("a value ≥ 0 (SI units)"));
                    }
                    Ok(v)
                }
                None => Ok(0.0),
            }
        };
        let motor_inertia = plain(self, "motor_inertia")?;
        let viscous = plain(self, "viscous")?;
        let coulomb = plain(self, "coulomb")?;
        d += 0.0;
        theta += 0.0;
        Ok(LinkVal {
            name: name.to_string(),
            kind,
            a,
            alpha,
            d,
            theta,
            offset,
            qlim,
            mass: mass_v,
            com: com_v,
            inertia: inertia_v,
            motor_inertia,
            viscous,
            coulomb,
            parts,
        })
    }

    fn robot_body(&mut self, decl: &Decl, scope: &mut Scope) -> RResult<RobotModel> {
        let mut base_parts = Vec::new();
        let mut counter = 0;
        let mut seen = Seen::default();
        let mut links: Vec<(LinkVal, Span)> = Vec::new();
        let mut link_names: HashMap<String, Span> = HashMap::new();
        let mut robot = Robot {
            name: decl.name.clone(),
            ..Robot::default()
        };
        let (mut colour, mut surface, mut ik) = (None, None, None);
        for st in &decl.body {
            match st {
                Stmt::Let {
                    name,
                    name_span,
                    value,
                } => self.let_(name, *name_span, value, scope)?,
                Stmt::Part {
                    name,
                    shape,
                    at,
                    colour: c,
                    surface: s,
                    repeat,
                    ..
                } => self.part(
                    &decl.name,
                    &mut counter,
                    name,
                    shape,
                    at,
                    c,
                    s,
                    repeat,
                    scope,
                    &mut base_parts,
                )?,
                Stmt::Link {
                    name,
                    name_span,
                    def,
                    span,
                } => {
                    if let Some(prev) = link_names.insert(name.clone(), *name_span) {
                        return Err(err(
                            ErrorKind::Duplicate,
                            *name_span,
                            format!("robot `{}` already has a link `{name}`", decl.name),
                        )
                        .expected("a different link name")
                        .note("first defined here", prev));
                    }
                    let mut l = match def {
                        LinkDef::Inline(body) => {
                            let mut inner = scope.clone();
                            self.link_body(name, body, &mut inner, *name_span)?
                        }
                        LinkDef::Ref(e) => match self.eval(e, scope)? {
                            Value::Link(l) => (*l).clone(),
                            other => {
                                return Err(err(
                                    ErrorKind::Type,
                                    e.span,
                                    format!(
                                        "`link {name} = …` needs a link, but this is {}",
                                        other.describe()
                                    ),
                                )
                                .expected("a declared link, called: `link upper = puma_link2()`"));
                            }
                        },
                    };
                    l.name = name.clone();
                    links.push((l, *span));
                }
                Stmt::Prop {
                    name,
                    name_span,
                    value,
                } => {
                    seen.check(name, *name_span)?;
                    match name.as_str() {
                        "convention" => {
                            robot.convention = match self
                                .word(value, &["standard", "modified"], "DH convention")?
                                .as_str()
                            {
                                "standard" => Convention::Standard,
                                _ => Convention::Modified,
                            }
                        }
                        "base" => robot.base = self.transform(value, scope)?,
                        "tool" => robot.tool = self.transform(value, scope)?,
                        "gravity" => {
                            let g =
                                self.vector(value, scope, Dim::ACCEL, 3, "[gx, gy, gz] in m/s^2")?;
                            robot.gravity = Vector3::new(g[0], g[1], g[2]);
                        }
                        "ik" => {
                            ik = Some(self.word(
                                value,
                                &["puma", "stanford", "spherical_wrist", "none"],
                                "analytic IK family",
                            )?)
                        }
                        "colour" | "color" => colour = Some(self.colour(value, scope)?),
                        "surface" => surface = Some(self.surface_ref(value, scope)?),
                        "facets" => {}
                        _ => {
                            return Err(unknown_prop(
                                "robot",
                                name,
                                *name_span,
                                &[
                                    "convention",
                                    "base",
                                    "tool",
                                    "gravity",
                                    "ik",
                                    "colour",
                                    "surface",
                                    "facets",
                                ],
                            ));
                        }
                    }
                }
                other => {
                    return Err(misplaced(
                        other,
                        "a robot",
                        "`link`, `part`, `let` or a property (convention, base, tool, gravity, ik)",
                    ));
                }
            }
        }
        // Fixed links: leading ones fold into the base, trailing ones into the tool.
        let first_moving = links.iter().position(|(l, _)| l.kind != JointKind::Fixed);
        let last_moving = links.iter().rposition(|(l, _)| l.kind != JointKind::Fixed);
        let mut frames: Vec<Vec<PlacedSolid>> = vec![base_parts];
        let mut names = Vec::new();
        let mut pre: Matrix4<f64> = Matrix4::identity(); // base-frame transform accumulated by leading fixed links
        let mut post: Matrix4<f64> = Matrix4::identity(); // frame-n transform accumulated by trailing fixed links
        for (k, (l, span)) in links.iter().enumerate() {
            let fixed_a = || {
                let j = Joint {
                    joint_type: JointType::Revolute,
                    a: l.a,
                    d: l.d,
                    alpha: l.alpha,
                    offset: l.theta,
                    ..Joint::default()
                };
                fk::link_transform(robot.convention, &j, 0.0)
            };
            match l.kind {
                JointKind::Fixed if first_moving.is_none_or(|f| k < f) => {
                    pre *= fixed_a();
                    frames[0].extend(l.parts.iter().map(|p| PlacedSolid {
                        transform: pre * p.transform,
                        ..p.clone()
                    }));
                }
                JointKind::Fixed if last_moving.is_some_and(|lm| k > lm) => {
                    post *= fixed_a();
                    if let Some(f) = frames.last_mut() {
                        f.extend(l.parts.iter().map(|p| PlacedSolid {
                            transform: post * p.transform,
                            ..p.clone()
                        }));
                    }
                }
                JointKind::Fixed => {
                    return Err(err(ErrorKind::Type, *span, format!("fixed link `{}` sits between two moving joints", l.name))
                        .expected("fixed links only before the first or after the last moving joint (DH chains have no constant transforms in between); put its parts in the previous link"));
                }
                JointKind::Moving(t) => {
                    robot.joints.push(Joint {
                        joint_type: t,
                        a: l.a,
                        d: l.d,
                        alpha: l.alpha,
                        theta: l.theta,
                        offset: l.offset,
                        qlim: l.qlim,
                        mass: l.mass,
                        com: l.com,
                        inertia: l.inertia,
                        motor_inertia: l.motor_inertia,
                        viscous: l.viscous,
                        coulomb: l.coulomb,
                    });
                    names.push(l.name.clone());
                    frames.push(l.parts.clone());
                }
            }
        }
        robot.base *= pre;
        robot.tool = post * robot.tool;
        for f in &mut frames {
            fill_appearance(f, colour, surface.as_ref());
        }
        robot.validate().map_err(|e| {
            err(
                ErrorKind::OutOfRange,
                decl.name_span,
                format!("robot `{}`: {e}", decl.name),
            )
        })?;
        Ok(RobotModel {
            robot,
            link_names: names,
            frames,
            ik: ik.filter(|w| w != "none"),
        })
    }

    fn scene_body(&mut self, decl: &Decl, scope: &mut Scope) -> RResult<SceneModel> {
        let mut scene = SceneModel {
            name: decl.name.clone(),
            robots: vec![],
            solids: vec![],
            effects: Effects::default(),
        };
        let mut names: HashMap<String, Span> = HashMap::new();
        let mut seen = Seen::default();
        for st in &decl.body {
            match st {
                Stmt::Let {
                    name,
                    name_span,
                    value,
                } => self.let_(name, *name_span, value, scope)?,
                Stmt::Place {
                    name,
                    name_span,
                    item,
                    at,
                    q,
                    ..
                } => {
                    if let Some(prev) = names.insert(name.clone(), *name_span) {
                        return Err(err(
                            ErrorKind::Duplicate,
                            *name_span,
                            format!("scene `{}` already places `{name}`", decl.name),
                        )
                        .expected("a different name")
                        .note("first placed here", prev));
                    }
                    let placement = match at {
                        Some(e) => self.transform(e, scope)?,
                        None => Matrix4::identity(),
                    };
                    let v = self.eval(item, scope)?;
                    let model = match v {
                        Value::Robot(r) => Some((*r).clone()),
                        Value::Link(l) => Some(single_link_robot(&l)),
                        Value::Solid(s) => {
                            if let Some(e) = q {
                                return Err(err(ErrorKind::Type, e.span, "a solid has no joints")
                                    .expected("`q` only for robots"));
                            }
                            let solid = SolidModel {
                                name: callee_name(item).unwrap_or_else(|| name.clone()),
                                parts: s.parts.clone(),
                                mass: s.mass,
                            };
                            scene.solids.push(PlacedItem {
                                name: name.clone(),
                                solid,
                                placement,
                            });
                            None
                        }
                        other => {
                            return Err(err(
                                ErrorKind::Type,
                                item.span,
                                format!("cannot place {} in a scene", other.describe()),
                            )
                            .expected("a robot or a solid"));
                        }
                    };
                    if let Some(mut model) = model {
                        let dof = model.robot.dof();
                        let qv = match q {
                            Some(e) => self.joint_vector(e, scope, &model)?,
                            None => vec![0.0; dof],
                        };
                        model.robot.base = placement * model.robot.base;
                        model.robot.name = name.clone();
                        scene.robots.push(PlacedRobot {
                            name: name.clone(),
                            model,
                            placement,
                            q: qv,
                        });
                    }
                }
                Stmt::Prop {
                    name,
                    name_span,
                    value,
                } => {
                    seen.check(name, *name_span)?;
                    match name.as_str() {
                        "facets" => {}
                        _ => {
                            return Err(unknown_prop("scene", name, *name_span, &["facets"])
                                .expected_more("or an `effects { … }` group"));
                        }
                    }
                    let _ = value;
                }
                Stmt::Block {
                    name,
                    name_span,
                    body,
                } if name == "effects" => {
                    seen.check(name, *name_span)?;
                    scene.effects = self.effects(body, scope)?;
                }
                Stmt::Block {
                    name, name_span, ..
                } => {
                    return Err(unknown_prop("scene", name, *name_span, &["effects"]));
                }
                other => {
                    return Err(misplaced(
                        other,
                        "a scene",
                        "`place`, `let`, `facets:` or `effects { … }`",
                    ));
                }
            }
        }
        Ok(scene)
    }

    fn joint_vector(&mut self, e: &Expr, scope: &Scope, model: &RobotModel) -> RResult<Vec<f64>> {
        let v = self.eval(e, scope)?;
        let Value::List(items) = v else {
            return Err(err(
                ErrorKind::Type,
                e.span,
                format!("`q` must be a list, got {}", v.describe()),
            )
            .expected("[q1, q2, …] with one value per joint"));
        };
        let dof = model.robot.dof();
        if items.len() != dof {
            return Err(err(
                ErrorKind::Arity,
                e.span,
                format!(
                    "`q` has {} values but the robot has {dof} joints",
                    items.len()
                ),
            )
            .expected(format!("{dof} joint values")));
        }
        let mut out = Vec::with_capacity(dof);
        for (j, ((v, span), joint)) in items.iter().zip(&model.robot.joints).enumerate() {
            let dim = if joint.joint_type == JointType::Revolute {
                Dim::ANGLE
            } else {
                Dim::LENGTH
            };
            let x = self.num_of(
                v,
                *span,
                dim,
                "a joint value (angle for revolute, length for prismatic)",
            )?;
            if x < joint.qlim[0] || x > joint.qlim[1] {
                return Err(err(
                    ErrorKind::OutOfRange,
                    *span,
                    format!(
                        "q[{j}] = {} is outside joint {} ({})'s limits [{}, {}]",
                        show(x, dim),
                        j + 1,
                        model.link_names[j],
                        show(joint.qlim[0], dim),
                        show(joint.qlim[1], dim)
                    ),
                )
                .expected("a value within the joint's limits"));
            }
            out.push(x);
        }
        Ok(out)
    }

    fn effects(&mut self, body: &[Stmt], scope: &mut Scope) -> RResult<Effects> {
        let mut fx = Effects::default();
        let mut seen = Seen::default();
        const PROPS: &[&str] = &[
            "kinematics",
            "joint_limits",
            "collision",
            "dynamics",
            "encoder_bits",
            "log",
        ];
        for st in body {
            match st {
                Stmt::Prop {
                    name,
                    name_span,
                    value,
                } => {
                    seen.check(name, *name_span)?;
                    match name.as_str() {
                        "kinematics" => fx.kinematics = self.switch(value, scope)?,
                        "joint_limits" => fx.joint_limits = self.switch(value, scope)?,
                        "encoder_bits" => {
                            fx.encoder_bits = Some(self.count(value, scope, 1, 32)? as u32)
                        }
                        "log" => {
                            let v = self.eval(value, scope)?;
                            let items = match v {
                                Value::List(items) => items,
                                other => {
                                    return Err(err(
                                        ErrorKind::Type,
                                        value.span,
                                        format!("`log` must be a list, got {}", other.describe()),
                                    )
                                    .expected("[\"q\", \"tau\", …]"));
                                }
                            };
                            for (it, span) in items {
                                match it {
                                    Value::Str(s) if !s.is_empty() => fx.logged.push(s),
                                    other => {
                                        return Err(err(
                                            ErrorKind::Type,
                                            span,
                                            format!(
                                                "a logged signal must be a string, got {}",
                                                other.describe()
                                            ),
                                        )
                                        .expected("a signal name in quotes such as \"q\""));
                                    }
                                }
                            }
                        }
                        "collision" => {
                            fx.collision = if self.switch(value, scope)? {
                                Some(default_collision())
                            } else {
                                None
                            }
                        }
                        "dynamics" => {
                            fx.dynamics = if self.switch(value, scope)? {
                                Some(default_dynamics())
                            } else {
                                None
                            }
                        }
                        _ => return Err(unknown_prop("effects", name, *name_span, PROPS)),
                    }
                }
                Stmt::Block {
                    name,
                    name_span,
                    body,
                } if name == "collision" => {
                    seen.check(name, *name_span)?;
                    let mut c = default_collision();
                    let mut s2 = Seen::default();
                    for st in body {
                        match st {
                            Stmt::Prop {
                                name,
                                name_span,
                                value,
                            } => {
                                s2.check(name, *name_span)?;
                                match name.as_str() {
                                    "mode" => {
                                        c.mode = match self
                                            .word(
                                                value,
                                                &["bbox", "polygon", "exact"],
                                                "collision mode",
                                            )?
                                            .as_str()
                                        {
                                            "bbox" => CollisionMode::Bbox,
                                            "polygon" => CollisionMode::Polygon,
                                            _ => CollisionMode::Exact,
                                        }
                                    }
                                    "self" => c.self_collision = self.switch(value, scope)?,
                                    "continuous" => c.continuous = self.switch(value, scope)?,
                                    _ => {
                                        return Err(unknown_prop(
                                            "collision",
                                            name,
                                            *name_span,
                                            &["mode", "self", "continuous"],
                                        ));
                                    }
                                }
                            }
                            other => {
                                return Err(misplaced(
                                    other,
                                    "`collision { … }`",
                                    "`mode:`, `self:` or `continuous:`",
                                ));
                            }
                        }
                    }
                    fx.collision = Some(c);
                }
                Stmt::Block {
                    name,
                    name_span,
                    body,
                } if name == "dynamics" => {
                    seen.check(name, *name_span)?;
                    let mut dy = default_dynamics();
                    let mut s2 = Seen::default();
                    for st in body {
                        match st {
                            Stmt::Prop {
                                name,
                                name_span,
                                value,
                            } => {
                                s2.check(name, *name_span)?;
                                match name.as_str() {
                                    "integrator" => {
                                        dy.integrator = match self
                                            .word(
                                                value,
                                                &["euler", "semi_implicit_euler", "rk4", "dopri5"],
                                                "integrator",
                                            )?
                                            .as_str()
                                        {
                                            "euler" => Integrator::Euler,
                                            "semi_implicit_euler" => Integrator::SemiImplicitEuler,
                                            "rk4" => Integrator::Rk4,
                                            _ => Integrator::Dopri5,
                                        }
                                    }
                                    "step" => {
                                        let s = self.quantity(
                                            value,
                                            scope,
                                            Dim::TIME,
                                            "a time step such as 1 ms",
                                        )?;
                                        if s <= 0.0 || s > 1.0 {
                                            return Err(err(
                                                ErrorKind::OutOfRange,
                                                value.span,
                                                format!("step {s} s is out of range"),
                                            )
                                            .expected("a step in (0, 1 s]"));
                                        }
                                        dy.step_s = s;
                                    }
                                    "gravity" => {
                                        let g = self.vector(
                                            value,
                                            scope,
                                            Dim::ACCEL,
                                            3,
                                            "[gx, gy, gz] in m/s^2",
                                        )?;
                                        dy.gravity = Vector3::new(g[0], g[1], g[2]);
                                    }
                                    _ => {
                                        return Err(unknown_prop(
                                            "dynamics",
                                            name,
                                            *name_span,
                                            &["integrator", "step", "gravity"],
                                        ));
                                    }
                                }
                            }
                            other => {
                                return Err(misplaced(
                                    other,
                                    "`dynamics { … }`",
                                    "`integrator:`, `step:` or `gravity:`",
                                ));
                            }
                        }
                    }
                    fx.dynamics = Some(dy);
                }
                Stmt::Block {
                    name, name_span, ..
                } => {
                    return Err(unknown_prop(
                        "effects",
                        name,
                        *name_span,
                        &["collision", "dynamics"],
                    ));
                }
                Stmt::Let {
                    name,
                    name_span,
                    value,
                } => self.let_(name, *name_span, value, scope)?,
                other => {
                    return Err(misplaced(
                        other,
                        "`effects { … }`",
                        "effect properties such as `joint_limits: on` or `collision { … }`",
                    ));
                }
            }
        }
        Ok(fx)
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

    // ---------------------------------------------------------------- expressions

    pub fn eval(&mut self, e: &Expr, scope: &Scope) -> RResult<Value> {
        match &e.kind {
            ExprKind::Num {
                value,
                dim,
                unitless,
            } => Ok(Value::Num(Quantity {
                value: *value,
                dim: *dim,
                free: *unitless && *value == 0.0,
            })),
            ExprKind::Str(s) => Ok(Value::Str(s.clone())),
            ExprKind::List(items) => {
                let mut out = Vec::with_capacity(items.len());
                for it in items {
                    out.push((self.eval(it, scope)?, it.span));
                }
                Ok(Value::List(out))
            }
            ExprKind::Neg(inner) => match self.eval(inner, scope)? {
                Value::Num(q) => Ok(Value::Num(Quantity {
                    value: -q.value,
                    ..q
                })),
                other => Err(err(
                    ErrorKind::Type,
                    e.span,
                    format!("cannot negate {}", other.describe()),
                )
                .expected("a number")),
            },
            ExprKind::Binary { op, lhs, rhs } => {
                let a = self.eval(lhs, scope)?;
                let b = self.eval(rhs, scope)?;
                self.binary(*op, a, b, lhs.span, rhs.span, e.span)
            }
            ExprKind::Name(n) => self.name(n, e.span, scope),
            ExprKind::Call {
                name,
                name_span,
                args,
            } => self.call(name, *name_span, args, e.span, scope),
        }
    }

    fn binary(
        &mut self,
        op: char,
        a: Value,
        b: Value,
        sa: Span,
        sb: Span,
        span: Span,
    ) -> RResult<Value> {
        match (op, &a, &b) {
            ('*', Value::Transform(x), Value::Transform(y)) => Ok(Value::Transform(x * y)),
            (_, Value::Num(x), Value::Num(y)) => {
                let (x, y) = (*x, *y);
                let q = match op {
                    '+' | '-' => {
                        let dim = if x.free && x.value == 0.0 {
                            y.dim
                        } else if y.free && y.value == 0.0 || x.dim == y.dim {
                            x.dim
                        } else {
                            let verb = if op == '+' { "add" } else { "subtract" };
                            return Err(err(
                                ErrorKind::Unit,
                                span,
                                format!(
                                    "cannot {verb} {} and {}",
                                    x.dim.describe(),
                                    y.dim.describe()
                                ),
                            )
                            .expected(format!("both sides of `{op}` in the same unit dimension")));
                        };
                        let v = if op == '+' {
                            x.value + y.value
                        } else {
                            x.value - y.value
                        };
                        Quantity {
                            value: v,
                            dim,
                            free: x.free && y.free,
                        }
                    }
                    '*' => Quantity {
                        value: x.value * y.value,
                        dim: x.dim.mul(y.dim),
                        free: (x.free || y.free) && x.value * y.value == 0.0,
                    },
                    '/' => {
                        if y.value == 0.0 {
                            return Err(err(ErrorKind::OutOfRange, sb, "division by zero")
                                .expected("a non-zero divisor"));
                        }
                        Quantity {
                            value: x.value / y.value,
                            dim: x.dim.div(y.dim),
                            free: x.free && x.value == 0.0,
                        }
                    }
                    _ => {
                        // '^': exponent must be a plain number; a dimensioned base needs a whole one
                        if y.dim != Dim::NONE {
                            return Err(err(
                                ErrorKind::Unit,
                                sb,
                                format!(
                                    "an exponent must be a plain number, found {}",
                                    y.dim.describe()
                                ),
                            )
                            .expected("a plain number"));
                        }
                        if x.dim == Dim::NONE {
                            Quantity::new(x.value.powf(y.value), Dim::NONE)
                        } else if y.value.fract() == 0.0 && y.value.abs() <= 9.0 {
                            Quantity::new(x.value.powi(y.value as i32), x.dim.pow(y.value as i8))
                        } else {
                            return Err(err(
                                ErrorKind::Unit,
                                sb,
                                format!("{} can only be raised to a whole power", x.dim.describe()),
                            )
                            .expected("a whole exponent from -9 to 9"));
                        }
                    }
                };
                Ok(Value::Num(q))
            }
            _ => {
                let bad = if matches!(a, Value::Num(_) | Value::Transform(_)) {
                    (&b, sb)
                } else {
                    (&a, sa)
                };
                Err(err(
                    ErrorKind::Type,
                    bad.1,
                    format!(
                        "`{op}` cannot combine {} and {}",
                        a.describe(),
                        b.describe()
                    ),
                )
                .expected(if op == '*' {
                    "two numbers, or two transforms"
                } else {
                    "two numbers"
                }))
            }
        }
    }

    fn name(&mut self, n: &str, span: Span, scope: &Scope) -> RResult<Value> {
        if let Some((v, _)) = scope.get(n) {
            return Ok(v.clone());
        }
        if let Some(&di) = self.index.get(n) {
            return self.call_decl(di, &[], span, scope);
        }
        match n {
            "pi" => return Ok(Value::Num(Quantity::new(std::f64::consts::PI, Dim::NONE))),
            "on" | "true" => return Ok(Value::Bool(true)),
            "off" | "false" => return Ok(Value::Bool(false)),
            "identity" => return Ok(Value::Transform(Matrix4::identity())),
            _ => {}
        }
        if let Some((s, d)) = crate::units::unit(n) {
            return Ok(Value::Num(Quantity::new(s, d)));
        }
        let mut msg = format!("unknown name `{n}`");
        let cands = scope
            .keys()
            .map(String::as_str)
            .chain(self.index.keys().map(String::as_str))
            .chain(BUILTIN_CONSTANTS.iter().copied());
        if let Some(s) = suggest(n, cands) {
            msg.push_str(&format!("; did you mean `{s}`?"));
        }
        let hint = if BUILTIN_FUNCTIONS.contains(&n) {
            format!("`{n}` is a function: call it as {n}(…)")
        } else {
            "a parameter, a `let` variable, a declaration, or a builtin (pi, on, off, identity)"
                .into()
        };
        Err(err(ErrorKind::UnknownName, span, msg).expected(hint))
    }

    fn call_decl(&mut self, di: usize, args: &[Arg], span: Span, scope: &Scope) -> RResult<Value> {
        let mut vals = Vec::with_capacity(args.len());
        for a in args {
            vals.push((a.name.clone(), self.eval(&a.value, scope)?, a.value.span));
        }
        if self.decls[di].kind == DeclKind::Scene {
            return Err(err(
                ErrorKind::Type,
                span,
                format!(
                    "`{}` is a scene and cannot be used inside another declaration",
                    self.decls[di].name
                ),
            )
            .expected("a solid, link, robot, colour, surface or constant"));
        }
        if !args.is_empty() && matches!(self.decls[di].kind, DeclKind::Constant | DeclKind::Colour)
        {
            return Err(err(
                ErrorKind::Arity,
                span,
                format!(
                    "`{}` is a {} and takes no arguments",
                    self.decls[di].name,
                    self.decls[di].kind.as_str()
                ),
            )
            .expected("the name alone"));
        }
        self.eval_decl(di, vals, span)
    }

    fn call(
        &mut self,
        name: &str,
        name_span: Span,
        args: &[Arg],
        span: Span,
        scope: &Scope,
    ) -> RResult<Value> {
        if let Some(&di) = self.index.get(name) {
            return self.call_decl(di, args, span, scope);
        }
        let spec: &[(&str, Want, bool)] = match name {
            "sin" | "cos" | "tan" => &[("angle", Want::Q(Dim::ANGLE), true)],
            "translate" => &[
                ("x", Want::Q(Dim::LENGTH), true),
                ("y", Want::Q(Dim::LENGTH), true),
                ("z", Want::Q(Dim::LENGTH), true),
            ],
            "rotate_x" | "rotate_y" | "rotate_z" => &[("angle", Want::Q(Dim::ANGLE), true)],
            "ypr" => &[
                ("yaw", Want::Q(Dim::ANGLE), true),
                ("pitch", Want::Q(Dim::ANGLE), true),
                ("roll", Want::Q(Dim::ANGLE), true),
            ],
            "rgb" => &[
                ("red", Want::Q(Dim::NONE), true),
                ("green", Want::Q(Dim::NONE), true),
                ("blue", Want::Q(Dim::NONE), true),
            ],
            "identity" => &[],
            "box" => &[
                ("x", Want::Q(Dim::LENGTH), true),
                ("y", Want::Q(Dim::LENGTH), true),
                ("z", Want::Q(Dim::LENGTH), true),
            ],
            "cylinder" | "cone" => &[
                ("radius", Want::Q(Dim::LENGTH), true),
                ("height", Want::Q(Dim::LENGTH), true),
                ("facets", Want::Count, false),
            ],
            "truncated_cone" => &[
                ("bottom", Want::Q(Dim::LENGTH), true),
                ("top", Want::Q(Dim::LENGTH), true),
                ("height", Want::Q(Dim::LENGTH), true),
                ("facets", Want::Count, false),
            ],
            "sphere" => &[
                ("radius", Want::Q(Dim::LENGTH), true),
                ("facets", Want::Count, false),
            ],
            "extrude" => &[
                ("points", Want::Points, true),
                ("height", Want::Q(Dim::LENGTH), true),
            ],
            "revolve" => &[
                ("points", Want::Points, true),
                ("angle", Want::Q(Dim::ANGLE), false),
                ("facets", Want::Count, false),
            ],
            // same-dimension arguments, checked below
            "atan2" | "sqrt" | "abs" | "min" | "max" | "matrix" | "range" => &[],
            _ => {
                let mut msg = format!("unknown function `{name}`");
                let cands = self
                    .index
                    .keys()
                    .map(String::as_str)
                    .chain(BUILTIN_FUNCTIONS.iter().copied());
                if let Some(s) = suggest(name, cands) {
                    msg.push_str(&format!("; did you mean `{s}`?"));
                }
                return Err(
                    err(ErrorKind::UnknownName, name_span, msg).expected(format!(
                        "a declared solid, link or robot, or a builtin: {}",
                        BUILTIN_FUNCTIONS.join(", ")
                    )),
                );
            }
        };
        let mut vals: Vec<(Value, Span)> = Vec::with_capacity(args.len());
        for a in args {
            vals.push((self.eval(&a.value, scope)?, a.value.span));
        }
        match name {
            "atan2" | "min" | "max" => {
                let [(a, sa), (b, sb)] =
                    self.exactly::<2>(name, "two numbers of the same unit", args, vals, span)?;
                let (Value::Num(x), Value::Num(y)) = (&a, &b) else {
                    let bad = if matches!(a, Value::Num(_)) { sb } else { sa };
                    return Err(err(ErrorKind::Type, bad, format!("`{name}` needs numbers"))
                        .expected("two numbers of the same unit"));
                };
                if !(x.dim == y.dim || x.free || y.free) {
                    return Err(err(
                        ErrorKind::Unit,
                        span,
                        format!("`{name}` got {} and {}", x.dim.describe(), y.dim.describe()),
                    )
                    .expected("two numbers of the same unit"));
                }
                let dim = if x.free { y.dim } else { x.dim };
                return Ok(Value::Num(match name {
                    "atan2" => Quantity::new(x.value.atan2(y.value), Dim::ANGLE),
                    "min" => Quantity::new(x.value.min(y.value), dim),
                    _ => Quantity::new(x.value.max(y.value), dim),
                }));
            }
            "sqrt" | "abs" => {
                let [(a, sa)] = self.exactly::<1>(name, "one number", args, vals, span)?;
                let Value::Num(x) = a else {
                    return Err(err(
                        ErrorKind::Type,
                        sa,
                        format!("`{name}` needs a number, found {}", a.describe()),
                    )
                    .expected("a number"));
                };
                if name == "abs" {
                    return Ok(Value::Num(Quantity {
                        value: x.value.abs(),
                        ..x
                    }));
                }
                if x.value < 0.0 {
                    return Err(err(
                        ErrorKind::OutOfRange,
                        sa,
                        format!("square root of a negative number ({})", x.show()),
                    )
                    .expected("a value ≥ 0"));
                }
                let Some(d) = x.dim.half() else {
                    return Err(err(
                        ErrorKind::Unit,
                        sa,
                        format!("the square root of {} has no unit", x.dim.describe()),
                    )
                    .expected("a quantity whose unit is a square, such as m^2"));
                };
                return Ok(Value::Num(Quantity::new(x.value.sqrt(), d)));
            }
            "range" => {
                let n = vals.len();
                let bounds: Vec<f64> = vals
                    .iter()
                    .map(|(v, s)| {
                        self.num_of(
                            v,
                            *s,
                            Dim::NONE,
                            "whole numbers: range(n) or range(from, to)",
                        )
                    })
                    .collect::<RResult<_>>()?;
                let (lo, hi) = match n {
                    1 => (0.0, bounds[0]),
                    2 => (bounds[0], bounds[1]),
                    _ => {
                        return Err(err(
                            ErrorKind::Arity,
                            span,
                            format!("`range` takes 1 or 2 arguments, got {n}"),
                        )
                        .expected("range(n) or range(from, to)"));
                    }
                };
                if lo.fract() != 0.0 || hi.fract() != 0.0 || hi - lo > 100_000.0 {
                    return Err(err(
                        ErrorKind::OutOfRange,
                        span,
                        "range bounds must be whole numbers at most 100000 apart",
                    )
                    .expected("range(n) or range(from, to) with whole numbers"));
                }
                let items = ((lo as i64)..(hi as i64))
                    .map(|k| (Value::Num(Quantity::new(k as f64, Dim::NONE)), span))
                    .collect();
                return Ok(Value::List(items));
            }
            "matrix" => {
                let [(a, sa)] =
                    self.exactly::<1>(name, "one 4×4 list of rows", args, vals, span)?;
                return self.matrix(a, sa).map(Value::Transform);
            }
            _ => {}
        }
        let bound = self.bind_builtin(name, spec, args, vals, span)?;
        let q = |k: usize| match &bound[k] {
            Some((Value::Num(q), _)) => q.value,
            _ => 0.0,
        };
        let present = |k: usize| bound[k].is_some();
        let solid = |s: &mut Self,
                     prim: Primitive,
                     r: Result<Polyhedron, shapes::ShapeError>|
         -> RResult<Value> {
            let poly = r.map_err(|e| {
                err(ErrorKind::OutOfRange, span, e.to_string()).expected(
                    "parameters a solid can be built from (positive sizes, a simple polygon)",
                )
            })?;
            s.polygons += poly.polygons.len();
            if s.polygons > POLYGON_BUDGET {
                return Err(err(
                    ErrorKind::OutOfRange,
                    span,
                    format!("the model has more than {POLYGON_BUDGET} polygons"),
                )
                .expected("fewer facets or fewer repeated parts"));
            }
            Ok(Value::Solid(Rc::new(SolidVal {
                parts: vec![PlacedSolid {
                    name: name.to_string(),
                    primitive: prim,
                    polyhedron: poly,
                    transform: Matrix4::identity(),
                    colour: None,
                    surface: None,
                }],
                mass: None,
            })))
        };
        let facets = |s: &Self, k: usize| -> Option<usize> {
            match &bound[k] {
                Some((Value::Num(q), _)) => Some(q.value as usize),
                _ => s.opts.facets.or(s.facets.last().copied().flatten()),
            }
        };
        let round_facets = |s: &Self, k: usize, r: f64| {
            facets(s, k).unwrap_or_else(|| shapes::default_facets(r, shapes::DEFAULT_CHORD_TOL))
        };
        match name {
            "sin" => Ok(Value::Num(Quantity::new(q(0).sin(), Dim::NONE))),
            "cos" => Ok(Value::Num(Quantity::new(q(0).cos(), Dim::NONE))),
            "tan" => Ok(Value::Num(Quantity::new(q(0).tan(), Dim::NONE))),
            "translate" => Ok(Value::Transform(translation(q(0), q(1), q(2)))),
            "rotate_x" => Ok(Value::Transform(rot(Vector3::x(), q(0)))),
            "rotate_y" => Ok(Value::Transform(rot(Vector3::y(), q(0)))),
            "rotate_z" => Ok(Value::Transform(rot(Vector3::z(), q(0)))),
            "ypr" => Ok(Value::Transform(
                rot(Vector3::z(), q(0)) * rot(Vector3::y(), q(1)) * rot(Vector3::x(), q(2)),
            )),
            "identity" => Ok(Value::Transform(Matrix4::identity())),
            "rgb" => {
                for (k, b) in bound.iter().enumerate().take(3) {
                    if !(0.0..=1.0).contains(&q(k)) {
                        let s = b.as_ref().map_or(span, |b| b.1);
                        return Err(err(
                            ErrorKind::OutOfRange,
                            s,
                            format!("colour component {} is outside [0, 1]", q(k)),
                        )
                        .expected("red, green and blue from 0 to 1"));
                    }
                }
                Ok(Value::Colour([q(0), q(1), q(2)]))
            }
            "box" => solid(
                self,
                Primitive::Box {
                    size: [q(0), q(1), q(2)],
                },
                shapes::cuboid(q(0), q(1), q(2)),
            ),
            "cylinder" => {
                let n = round_facets(self, 2, q(0));
                solid(
                    self,
                    Primitive::Cylinder {
                        radius: q(0),
                        height: q(1),
                        facets: n,
                    },
                    shapes::cylinder(q(0), q(1), Some(n)),
                )
            }
            "cone" => {
                let n = round_facets(self, 2, q(0));
                solid(
                    self,
                    Primitive::Cone {
                        radius: q(0),
                        height: q(1),
                        facets: n,
                    },
                    shapes::cone(q(0), q(1), Some(n)),
                )
            }
            "truncated_cone" => {
                let n = round_facets(self, 3, q(0).max(q(1)));
                solid(
                    self,
                    Primitive::TruncatedCone {
                        bottom: q(0),
                        top: q(1),
                        height: q(2),
                        facets: n,
                    },
                    shapes::truncated_cone(q(0), q(1), q(2), Some(n)),
                )
            }
            "sphere" => {
                let n = round_facets(self, 1, q(0)).max(4);
                solid(
                    self,
                    Primitive::Sphere {
                        radius: q(0),
                        facets: n,
                    },
                    shapes::sphere(q(0), Some(n)),
                )
            }
            "extrude" | "revolve" => {
                let Some((Value::List(items), _)) = &bound[0] else {
                    unreachable!("points checked by bind_builtin")
                };
                let pts: Vec<nalgebra::Point2<f64>> = items
                    .iter()
                    .map(|(v, _)| match v {
                        Value::List(xy) => nalgebra::Point2::new(num(&xy[0].0), num(&xy[1].0)),
                        _ => nalgebra::Point2::origin(),
                    })
                    .collect();
                let arr: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
                if name == "extrude" {
                    solid(
                        self,
                        Primitive::Extrusion {
                            points: arr,
                            height: q(1),
                        },
                        shapes::extrude(&pts, q(1)),
                    )
                } else {
                    let angle = if present(1) {
                        q(1)
                    } else {
                        std::f64::consts::TAU
                    };
                    let f = facets(self, 2).map(|n| {
                        // a facets override means "n around a full turn": scale for a partial revolution
                        if present(2) {
                            n
                        } else {
                            ((n as f64 * angle / std::f64::consts::TAU).ceil() as usize).max(1)
                        }
                    });
                    solid(
                        self,
                        Primitive::Revolution {
                            points: arr,
                            angle,
                            facets: f,
                        },
                        shapes::revolve(&pts, angle, f),
                    )
                }
            }
            _ => unreachable!("every name in the spec table is handled above"),
        }
    }

    fn exactly<const N: usize>(
        &self,
        name: &str,
        what: &str,
        args: &[Arg],
        vals: Vec<(Value, Span)>,
        span: Span,
    ) -> RResult<[(Value, Span); N]> {
        if let Some(a) = args.iter().find(|a| a.name.is_some()) {
            let (n, s) = a.name.clone().unwrap_or_default();
            return Err(err(
                ErrorKind::Arity,
                s,
                format!("`{name}` takes no named argument `{n}`"),
            )
            .expected(what.to_string()));
        }
        let got = vals.len();
        vals.try_into().map_err(|_| {
            err(
                ErrorKind::Arity,
                span,
                format!("`{name}` takes {N} argument(s), got {got}"),
            )
            .expected(what.to_string())
        })
    }

    fn bind_builtin(
        &self,
        name: &str,
        spec: &[(&str, Want, bool)],
        args: &[Arg],
        vals: Vec<(Value, Span)>,
        span: Span,
    ) -> RResult<Vec<Option<(Value, Span)>>> {
        let sig = || {
            let ps: Vec<String> = spec
                .iter()
                .map(|(n, _, req)| if *req { n.to_string() } else { format!("{n}?") })
                .collect();
            format!("{name}({})", ps.join(", "))
        };
        let mut bound: Vec<Option<(Value, Span)>> = vec![None; spec.len()];
        let mut pos = 0;
        for (a, (v, s)) in args.iter().zip(vals) {
            let k = match &a.name {
                None => {
                    if pos >= spec.len() {
                        return Err(err(
                            ErrorKind::Arity,
                            s,
                            format!(
                                "too many arguments to `{name}`: it takes at most {}",
                                spec.len()
                            ),
                        )
                        .expected(sig()));
                    }
                    pos += 1;
                    pos - 1
                }
                Some((n, ns)) => match spec.iter().position(|(p, _, _)| p == n) {
                    Some(k) => k,
                    None => {
                        return Err(err(
                            ErrorKind::UnknownProperty,
                            *ns,
                            format!("`{name}` has no parameter `{n}`"),
                        )
                        .expected(sig()));
                    }
                },
            };
            if bound[k].is_some() {
                return Err(err(
                    ErrorKind::Arity,
                    s,
                    format!("`{}` is given twice", spec[k].0),
                )
                .expected(sig()));
            }
            match spec[k].1 {
                Want::Q(d) => {
                    self.num_of(&v, s, d, &format!("`{}` of {}", spec[k].0, sig()))?;
                }
                Want::Count => {
                    let n = self.num_of(&v, s, Dim::NONE, "a whole number of facets")?;
                    if n.fract() != 0.0 || !(3.0..=shapes::FACET_LIMIT as f64).contains(&n) {
                        return Err(err(
                            ErrorKind::OutOfRange,
                            s,
                            format!(
                                "facet count {n} is not a whole number in [3, {}]",
                                shapes::FACET_LIMIT
                            ),
                        )
                        .expected("a whole number of facets"));
                    }
                }
                Want::Points => {
                    let ok = matches!(&v, Value::List(items) if items.iter().all(|(p, _)| matches!(p, Value::List(xy) if xy.len() == 2)));
                    if !ok {
                        return Err(err(
                            ErrorKind::Type,
                            s,
                            format!(
                                "`points` must be a list of [x, y] pairs, found {}",
                                v.describe()
                            ),
                        )
                        .expected("[[x1, y1], [x2, y2], …] in lengths"));
                    }
                    if let Value::List(items) = &v {
                        for (p, _) in items {
                            if let Value::List(xy) = p {
                                for (c, cs) in xy {
                                    self.num_of(c, *cs, Dim::LENGTH, "a length such as 10 mm")?;
                                }
                            }
                        }
                    }
                }
            }
            bound[k] = Some((v, s));
        }
        for (k, (p, _, req)) in spec.iter().enumerate() {
            if *req && bound[k].is_none() {
                return Err(err(
                    ErrorKind::Arity,
                    span,
                    format!("`{name}` is missing its `{p}` argument"),
                )
                .expected(sig()));
            }
        }
        Ok(bound)
    }

    fn matrix(&self, v: Value, span: Span) -> RResult<Matrix4<f64>> {
        const WHAT: &str = "4 rows of 4: a rotation (plain numbers) and a translation column (lengths), last row [0, 0, 0, 1]";
        let rows = match v {
            Value::List(rows) if rows.len() == 4 => rows,
            other => {
                return Err(err(
                    ErrorKind::Type,
                    span,
                    format!("`matrix` needs 4 rows, found {}", other.describe()),
                )
                .expected(WHAT));
            }
        };
        let mut m = Matrix4::zeros();
        for (r, (row, rs)) in rows.iter().enumerate() {
            let Value::List(cols) = row else {
                return Err(err(ErrorKind::Type, *rs, "a matrix row must be a list").expected(WHAT));
            };
            if cols.len() != 4 {
                return Err(err(
                    ErrorKind::Arity,
                    *rs,
                    format!("matrix row {} has {} values", r + 1, cols.len()),
                )
                .expected(WHAT));
            }
            for (c, (x, xs)) in cols.iter().enumerate() {
                let dim = if c == 3 && r < 3 {
                    Dim::LENGTH
                } else {
                    Dim::NONE
                };
                m[(r, c)] = self.num_of(x, *xs, dim, WHAT)?;
            }
        }
        if !rigid_ok(&m) {
            return Err(err(
                ErrorKind::OutOfRange,
                span,
                "the matrix is not a rigid transform",
            )
            .expected("an orthonormal rotation with determinant 1 and last row [0, 0, 0, 1]"));
        }
        Ok(m)
    }
}

fn param_list(decl: &Decl) -> String {
    if decl.params.is_empty() {
        return format!("no arguments: `{}` has no parameters", decl.name);
    }
    let ps: Vec<&str> = decl.params.iter().map(|p| p.name.as_str()).collect();
    format!("{}({})", decl.name, ps.join(", "))
}

fn num(v: &Value) -> f64 {
    match v {
        Value::Num(q) => q.value,
        _ => 0.0,
    }
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

fn default_collision() -> CollisionEffect {
    CollisionEffect {
        mode: CollisionMode::Polygon,
        self_collision: false,
        continuous: false,
    }
}

fn default_dynamics() -> DynamicsEffect {
    DynamicsEffect {
        integrator: Integrator::Rk4,
        step_s: 1e-3,
        gravity: Vector3::new(0.0, 0.0, -9.81),
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

/// A link evaluated on its own: a one-joint robot (fixed links: a zero-joint robot).
pub(crate) fn single_link_robot(l: &LinkVal) -> RobotModel {
    let mut robot = Robot {
        name: l.name.clone(),
        ..Robot::default()
    };
    let mut frames = vec![vec![]];
    let mut names = vec![];
    match l.kind {
        JointKind::Moving(t) => {
            robot.joints.push(Joint {
                joint_type: t,
                a: l.a,
                d: l.d,
                alpha: l.alpha,
                theta: l.theta,
                offset: l.offset,
                qlim: l.qlim,
                mass: l.mass,
                com: l.com,
                inertia: l.inertia,
                motor_inertia: l.motor_inertia,
                viscous: l.viscous,
                coulomb: l.coulomb,
            });
            frames.push(l.parts.clone());
            names.push(l.name.clone());
        }
        JointKind::Fixed => {
            let j = Joint {
                a: l.a,
                d: l.d,
                alpha: l.alpha,
                offset: l.theta,
                ..Joint::default()
            };
            robot.base = fk::link_transform(robot.convention, &j, 0.0);
            frames[0] = l.parts.clone();
        }
    }
    RobotModel {
        robot,
        link_names: names,
        frames,
        ik: None,
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
