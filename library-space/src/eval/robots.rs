//! Links and robots: joint kinds, DH rows, limits, dynamics, fixed links folded into base/tool.
//!
//! [`Evaluator::link_body`] reads a link's statements, then its joint kind, DH row, limits,
//! inertial properties and joint friction, each in its own step; [`Evaluator::robot_body`]
//! reads a robot's statements, folds its fixed links into the base and tool, validates the
//! chain and checks the declared IK family against the geometry's.

use super::solids::PartNames;
use super::*;

/// The properties a link may declare.
const LINK_PROPS: &[&str] = &[
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

/// The properties a robot may declare.
const ROBOT_PROPS: &[&str] = &[
    "convention",
    "base",
    "tool",
    "gravity",
    "ik",
    "colour",
    "surface",
    "facets",
];

/// The IK families a robot may declare (`ik:`), as the kinematics crate names them.
const IK_FAMILIES: &[&str] = &[
    "spherical_wrist",
    "rrp_spherical_wrist",
    "offset_wrist",
    "three_parallel",
    "general",
];

/// A link's unevaluated numeric properties, by name.
type LinkProps<'b> = HashMap<&'static str, &'b Expr>;

/// What a link's statements declare: its parts (with the link's colour and surface filled in)
/// and its other properties, still unevaluated.
struct LinkStatements<'b> {
    parts: Vec<PlacedSolid>,
    props: LinkProps<'b>,
}

/// A link's DH row in SI units. For a moving joint, `offset` is added to q (θ for a revolute,
/// d for a prismatic joint) and the other of θ/d is constant.
struct DhRow {
    a: f64,
    alpha: f64,
    d: f64,
    theta: f64,
    offset: f64,
}

/// A link's inertial properties as written, each with the span of its expression.
struct InertialInputs {
    density: Option<(f64, Span)>,
    mass: Option<(f64, Span)>,
    com: Option<(Vec<f64>, Span)>,
    inertia: Option<(Matrix3<f64>, Span)>,
}

impl InertialInputs {
    /// The span of `com:`, else of `inertia:`, if either is given.
    fn com_or_inertia_span(&self) -> Option<Span> {
        self.com
            .as_ref()
            .map(|c| c.1)
            .or(self.inertia.as_ref().map(|i| i.1))
    }
}

/// What a robot's statements declare, in source order.
struct RobotStatements {
    /// The robot with its declared convention, base, tool and gravity; no joints yet.
    robot: Robot,
    base_parts: Vec<PlacedSolid>,
    links: Vec<(LinkVal, Span)>,
    colour: Option<Rgb>,
    surface: Option<Surface>,
    /// The declared `ik:` family and where.
    ik: Option<(String, Span)>,
}

impl Evaluator<'_> {
    /// Evaluates a link's body into a [`LinkVal`]: statements, joint kind, DH row, limits,
    /// inertial properties, joint friction.
    pub(super) fn link_body(
        &mut self,
        name: &str,
        body: &[Stmt],
        scope: &mut Scope,
        span: Span,
    ) -> RResult<LinkVal> {
        let LinkStatements { parts, props } = self.link_statements(name, body, scope)?;
        let kind = self.joint_kind(name, &props, span)?;
        let dh = self.dh_row(kind, &props, scope)?;
        let qlim = self.joint_limits(name, kind, &props, scope, span)?;
        let inputs = self.inertial_inputs(&props, scope)?;
        let (mass, com, inertia) = self.link_inertial(inputs, &parts)?;
        let motor_inertia = self.non_negative(&props, "motor_inertia", scope)?;
        let viscous = self.non_negative(&props, "viscous", scope)?;
        let coulomb = self.non_negative(&props, "coulomb", scope)?;
        Ok(LinkVal {
            name: name.to_string(),
            kind,
            a: dh.a,
            alpha: dh.alpha,
            d: dh.d,
            theta: dh.theta,
            offset: dh.offset,
            qlim,
            mass,
            com,
            inertia,
            motor_inertia,
            viscous,
            coulomb,
            parts,
        })
    }

    /// Runs a link's `let`s and `part`s (in order, into `scope`) and collects its properties;
    /// the parts get the link's `colour:` and `surface:` where they have none.
    fn link_statements<'b>(
        &mut self,
        name: &str,
        body: &'b [Stmt],
        scope: &mut Scope,
    ) -> RResult<LinkStatements<'b>> {
        let mut parts = Vec::new();
        let mut counter = PartNames::default();
        let mut seen = Seen::default();
        let mut props: LinkProps<'b> = HashMap::new();
        let mut colour = None;
        let mut surface = None;
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
                        k => match LINK_PROPS.iter().find(|s| **s == k) {
                            Some(key) => {
                                props.insert(key, value);
                            }
                            None => return Err(unknown_prop("link", p, *name_span, LINK_PROPS)),
                        },
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
        Ok(LinkStatements { parts, props })
    }

    /// `joint: revolute | prismatic | fixed`, which every link must declare.
    fn joint_kind(&mut self, name: &str, props: &LinkProps, span: Span) -> RResult<JointKind> {
        let Some(e) = props.get("joint") else {
            return Err(err(
                ErrorKind::Missing,
                span,
                format!("link `{name}` has no `joint:`"),
            )
            .expected("`joint: revolute`, `joint: prismatic` or `joint: fixed`"));
        };
        Ok(
            match self
                .word(e, &["revolute", "prismatic", "fixed"], "joint type")?
                .as_str()
            {
                "revolute" => JointKind::Moving(JointType::Revolute),
                "prismatic" => JointKind::Moving(JointType::Prismatic),
                _ => JointKind::Fixed,
            },
        )
    }

    /// The DH row: `a`, `alpha`, and for a revolute joint `d` and `offset` (θ is the joint
    /// variable), for a prismatic one `theta` and `offset` (d is the joint variable), for a
    /// fixed one `d` and `theta`. Absent values are 0; naming the joint variable is an error.
    fn dh_row(&mut self, kind: JointKind, props: &LinkProps, scope: &Scope) -> RResult<DhRow> {
        let a = self.prop_length(props, "a", scope)?;
        let alpha = self.prop_angle(props, "alpha", scope)?;
        let (d, theta, offset) = match kind {
            JointKind::Moving(JointType::Prismatic) => {
                if let Some(e) = props.get("d") {
                    return Err(err(
                        ErrorKind::UnknownProperty,
                        e.span,
                        "a prismatic joint's `d` is its joint variable",
                    )
                    .expected("`offset:` (added to q to give d) and `theta:` (constant)"));
                }
                let theta = self.prop_angle(props, "theta", scope)?;
                (0.0, theta, self.prop_length(props, "offset", scope)?)
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
                let d = self.prop_length(props, "d", scope)?;
                (d, 0.0, self.prop_angle(props, "offset", scope)?)
            }
            JointKind::Fixed => {
                let d = self.prop_length(props, "d", scope)?;
                (d, self.prop_angle(props, "theta", scope)?, 0.0)
            }
        };
        // + 0.0 turns a written -0 into 0
        Ok(DhRow {
            a,
            alpha,
            d: d + 0.0,
            theta: theta + 0.0,
            offset,
        })
    }

    /// `limits: [lower, upper]` in the joint's unit: required for a prismatic joint, ±π for a
    /// revolute one without it, refused on a fixed one.
    fn joint_limits(
        &mut self,
        name: &str,
        kind: JointKind,
        props: &LinkProps,
        scope: &Scope,
        span: Span,
    ) -> RResult<[f64; 2]> {
        match (kind, props.get("limits")) {
            (JointKind::Fixed, Some(e)) => Err(err(
                ErrorKind::UnknownProperty,
                e.span,
                "a fixed joint has no limits",
            )
            .expected("no `limits:` on a fixed link")),
            (JointKind::Fixed, None) => Ok([0.0, 0.0]),
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
                Ok([v[0], v[1]])
            }
            (JointKind::Moving(JointType::Revolute), None) => {
                Ok([-std::f64::consts::PI, std::f64::consts::PI])
            }
            (JointKind::Moving(JointType::Prismatic), None) => Err(err(
                ErrorKind::Missing,
                span,
                format!("prismatic link `{name}` has no `limits:`"),
            )
            .expected("`limits: [lower, upper]` in metres, e.g. [0, 1.2 m]")),
        }
    }

    /// Evaluates `density`, `mass`, `com` and `inertia`, in that order, each if given.
    fn inertial_inputs(&mut self, props: &LinkProps, scope: &Scope) -> RResult<InertialInputs> {
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
        Ok(InertialInputs {
            density,
            mass,
            com,
            inertia,
        })
    }

    /// Mass (kg), centre of mass (m, link frame) and inertia about it (kg·m²): all from the
    /// parts' geometry with `density`; from `mass` with `com`/`inertia` as given or, missing,
    /// from the parts' geometry; zero for a massless link.
    fn link_inertial(
        &self,
        inputs: InertialInputs,
        parts: &[PlacedSolid],
    ) -> RResult<(f64, Vector3<f64>, Matrix3<f64>)> {
        match (inputs.density, inputs.mass) {
            (Some(_), Some((_, span))) => Err(err(
                ErrorKind::Duplicate,
                span,
                "both `density` and `mass` are given",
            )
            .expected("one of them: the other follows from the volume")),
            (Some((rho, span)), None) => {
                if let Some(s) = inputs.com_or_inertia_span() {
                    return Err(err(
                        ErrorKind::Duplicate,
                        s,
                        "`com`/`inertia` are computed from `density` and cannot be given too",
                    )
                    .expected(
                        "either density (everything from geometry) or mass with com and inertia",
                    ));
                }
                let mp = self.parts_mass(parts, Some(rho), None, span)?;
                Ok((mp.mass, mp.center_of_mass.coords, mp.inertia))
            }
            (None, Some((m, span))) => {
                if m < 0.0 {
                    return Err(
                        err(ErrorKind::OutOfRange, span, "mass must be zero or positive")
                            .expected("a mass ≥ 0 kg"),
                    );
                }
                let geo = if (inputs.com.is_none() || inputs.inertia.is_none()) && !parts.is_empty()
                {
                    Some(self.parts_mass(parts, None, Some(m), span)?)
                } else {
                    None
                };
                let c = inputs
                    .com
                    .map(|c| Vector3::new(c.0[0], c.0[1], c.0[2]))
                    .or(geo.map(|g| g.center_of_mass.coords))
                    .unwrap_or_default();
                let i = inputs
                    .inertia
                    .map(|i| i.0)
                    .or(geo.map(|g| g.inertia))
                    .unwrap_or_default();
                Ok((m, c, i))
            }
            (None, None) => {
                if let Some(s) = inputs.com_or_inertia_span() {
                    return Err(
                        err(ErrorKind::Missing, s, "`com`/`inertia` without a `mass`")
                            .expected("`mass:` (or `density:`) as well"),
                    );
                }
                Ok((0.0, Vector3::zeros(), Matrix3::zeros()))
            }
        }
    }

    /// Property `k` as a length in metres, 0 if absent.
    fn prop_length(&mut self, props: &LinkProps, k: &str, scope: &Scope) -> RResult<f64> {
        props.get(k).map_or(Ok(0.0), |e| {
            self.quantity(e, scope, Dim::LENGTH, "a length such as 431.8 mm")
        })
    }

    /// Property `k` as an angle in radians, 0 if absent.
    fn prop_angle(&mut self, props: &LinkProps, k: &str, scope: &Scope) -> RResult<f64> {
        props.get(k).map_or(Ok(0.0), |e| {
            self.quantity(e, scope, Dim::ANGLE, "an angle such as 90 deg")
        })
    }

    /// Property `k` (a joint friction or motor inertia, SI units) as a finite value ≥ 0, 0 if
    /// absent.
    fn non_negative(&mut self, props: &LinkProps, k: &str, scope: &Scope) -> RResult<f64> {
        let Some(e) = props.get(k) else {
            return Ok(0.0);
        };
        // quantity_any refuses non-finite values
        let v = self.quantity_any(e, scope)?;
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

    /// Evaluates a robot's body (or imports its URDF) into a [`RobotModel`]: statements, fixed
    /// links folded into base and tool, the chain validated, the IK family checked.
    pub(super) fn robot_body(&mut self, decl: &Decl, scope: &mut Scope) -> RResult<RobotModel> {
        if let Some(src) = &decl.urdf {
            return self.urdf_robot(decl, src, scope);
        }
        let RobotStatements {
            mut robot,
            base_parts,
            links,
            colour,
            surface,
            ik,
        } = self.robot_statements(decl, scope)?;
        let (mut frames, link_names) = fold_fixed_links(&mut robot, base_parts, &links)?;
        for f in &mut frames {
            fill_appearance(f, colour, surface.as_ref());
        }
        validated(decl, &robot)?;
        let ik = checked_ik_family(decl, &robot, ik)?;
        Ok(RobotModel {
            robot,
            link_names,
            frames,
            ik,
            mimics: Vec::new(),
        })
    }

    /// Runs a robot's `let`s, `part`s (the base's) and `link`s in order and reads its
    /// properties.
    fn robot_statements(&mut self, decl: &Decl, scope: &mut Scope) -> RResult<RobotStatements> {
        let mut out = RobotStatements {
            robot: Robot {
                name: decl.name.clone(),
                ..Robot::default()
            },
            base_parts: Vec::new(),
            links: Vec::new(),
            colour: None,
            surface: None,
            ik: None,
        };
        let mut counter = PartNames::default();
        let mut seen = Seen::default();
        let mut link_names: HashMap<String, Span> = HashMap::new();
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
                    &mut out.base_parts,
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
                    let mut l = self.robot_link(name, *name_span, def, scope)?;
                    l.name = name.clone();
                    out.links.push((l, *span));
                }
                Stmt::Prop {
                    name,
                    name_span,
                    value,
                } => {
                    seen.check(name, *name_span)?;
                    self.robot_prop(name, *name_span, value, scope, &mut out)?;
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
        Ok(out)
    }

    /// A robot's `link NAME { … }` (evaluated in a copy of the robot's scope) or
    /// `link NAME = declared_link(…)`.
    fn robot_link(
        &mut self,
        name: &str,
        name_span: Span,
        def: &LinkDef,
        scope: &Scope,
    ) -> RResult<LinkVal> {
        match def {
            LinkDef::Inline(body) => {
                let mut inner = scope.clone();
                self.push_facets_body(body, &inner)?;
                let l = self.link_body(name, body, &mut inner, name_span);
                self.facets.pop();
                l
            }
            LinkDef::Ref(e) => match self.eval(e, scope)? {
                Value::Link(l) => Ok((*l).clone()),
                other => Err(err(
                    ErrorKind::Type,
                    e.span,
                    format!(
                        "`link {name} = …` needs a link, but this is {}",
                        other.describe()
                    ),
                )
                .expected("a declared link, called: `link upper = puma_link2()`")),
            },
        }
    }

    /// One robot property (`convention`, `base`, `tool`, `gravity`, `ik`, `colour`, `surface`,
    /// `facets`) into `out`.
    fn robot_prop(
        &mut self,
        name: &str,
        name_span: Span,
        value: &Expr,
        scope: &Scope,
        out: &mut RobotStatements,
    ) -> RResult<()> {
        let robot = &mut out.robot;
        match name {
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
                let g = self.vector(value, scope, Dim::ACCEL, 3, "[gx, gy, gz] in m/s^2")?;
                robot.gravity = Vector3::new(g[0], g[1], g[2]);
            }
            "ik" => out.ik = Some((self.word(value, IK_FAMILIES, "IK family")?, value.span)),
            "colour" | "color" => out.colour = Some(self.colour(value, scope)?),
            "surface" => out.surface = Some(self.surface_ref(value, scope)?),
            "facets" => {}
            _ => return Err(unknown_prop("robot", name, name_span, ROBOT_PROPS)),
        }
        Ok(())
    }
}

/// Folds a robot's fixed links away: leading ones into the base (their parts into frame 0),
/// trailing ones into the tool (their parts into the last moving link's frame); each moving
/// link becomes a joint of `robot` with its own frame. Answers the frames (base first) and the
/// moving links' names. A fixed link between two moving joints is refused: a DH chain has no
/// constant transform there.
fn fold_fixed_links(
    robot: &mut Robot,
    base_parts: Vec<PlacedSolid>,
    links: &[(LinkVal, Span)],
) -> RResult<(Vec<Vec<PlacedSolid>>, Vec<String>)> {
    let first_moving = links.iter().position(|(l, _)| l.kind != JointKind::Fixed);
    let last_moving = links.iter().rposition(|(l, _)| l.kind != JointKind::Fixed);
    let mut frames: Vec<Vec<PlacedSolid>> = vec![base_parts];
    let mut names = Vec::new();
    let mut pre: Matrix4<f64> = Matrix4::identity(); // base-frame transform accumulated by leading fixed links
    let mut post: Matrix4<f64> = Matrix4::identity(); // frame-n transform accumulated by trailing fixed links
    for (k, (l, span)) in links.iter().enumerate() {
        let fixed_a = || fixed_transform(robot.convention, l);
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
                robot.joints.push(moving_joint(l, t));
                names.push(l.name.clone());
                frames.push(l.parts.clone());
            }
        }
    }
    robot.base *= pre;
    robot.tool = post * robot.tool;
    Ok((frames, names))
}

/// The kinematics crate's validation of a robot's chain, refused at the declaration's name.
pub(super) fn validated(decl: &Decl, robot: &Robot) -> RResult<()> {
    robot.validate().map_err(|e| {
        err(
            ErrorKind::OutOfRange,
            decl.name_span,
            format!("robot `{}`: {e}", decl.name),
        )
    })
}

/// The robot's IK family: the declared one must be the one the geometry admits (the kinematics
/// crate's classification); undeclared, the recognised closed form (if any) is recorded.
fn checked_ik_family(
    decl: &Decl,
    robot: &Robot,
    declared: Option<(String, Span)>,
) -> RResult<Option<String>> {
    let family = robosim_kinematics::ik::family::recognise(robot);
    match declared {
        Some((w, span)) if w != family.name() => {
            let why = match &family {
                robosim_kinematics::ik::family::Family::General(reason) => {
                    format!(" ({reason})")
                }
                _ => String::new(),
            };
            Err(err(
                ErrorKind::OutOfRange,
                span,
                format!(
                    "robot `{}` declares `ik: {w}`, but its geometry is `{}`{why}",
                    decl.name,
                    family.name()
                ),
            )
            .expected(format!(
                "`ik: {}` (or no `ik:` to let the geometry decide)",
                family.name()
            )))
        }
        _ if family.name() == "general" => Ok(None),
        _ => Ok(Some(family.name().to_string())),
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
            robot.joints.push(moving_joint(l, t));
            frames.push(l.parts.clone());
            names.push(l.name.clone());
        }
        JointKind::Fixed => {
            robot.base = fixed_transform(robot.convention, l);
            frames[0] = l.parts.clone();
        }
    }
    RobotModel {
        robot,
        link_names: names,
        frames,
        ik: None,
        mimics: Vec::new(),
    }
}

/// The joint of a moving link: its DH row, limits and dynamics.
fn moving_joint(l: &LinkVal, t: JointType) -> Joint {
    Joint {
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
        origin: None,
        spherical: false,
    }
}

/// The constant transform of a fixed link: its DH row with θ as the (fixed) joint angle.
fn fixed_transform(convention: Convention, l: &LinkVal) -> Matrix4<f64> {
    let j = Joint {
        a: l.a,
        d: l.d,
        alpha: l.alpha,
        offset: l.theta,
        ..Joint::default()
    };
    fk::link_transform(convention, &j, 0.0)
}
