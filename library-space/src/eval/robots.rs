//! Links and robots: joint kinds, DH rows, limits, dynamics, fixed links folded into base/tool.

use super::*;

impl Evaluator<'_> {
    pub(super) fn link_body(
        &mut self,
        name: &str,
        body: &[Stmt],
        scope: &mut Scope,
        span: Span,
    ) -> RResult<LinkVal> {
        let mut parts = Vec::new();
        let mut counter = PartNames::default();
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

    pub(super) fn robot_body(&mut self, decl: &Decl, scope: &mut Scope) -> RResult<RobotModel> {
        if let Some(src) = &decl.urdf {
            return self.urdf_robot(decl, src, scope);
        }
        let mut base_parts = Vec::new();
        let mut counter = PartNames::default();
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
                            self.push_facets_body(body, &inner)?;
                            let l = self.link_body(name, body, &mut inner, *name_span);
                            self.facets.pop();
                            l?
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
                            ik = Some((
                                self.word(
                                    value,
                                    &[
                                        "spherical_wrist",
                                        "rrp_spherical_wrist",
                                        "offset_wrist",
                                        "three_parallel",
                                        "general",
                                    ],
                                    "IK family",
                                )?,
                                value.span,
                            ))
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
        // The declared IK family must be the one the geometry admits (the kinematics crate's
        // classification); undeclared, the recognised closed form (if any) is recorded.
        let family = robosim_kinematics::ik::family::recognise(&robot);
        let ik = match ik {
            Some((w, span)) if w != family.name() => {
                let why = match &family {
                    robosim_kinematics::ik::family::Family::General(reason) => {
                        format!(" ({reason})")
                    }
                    _ => String::new(),
                };
                return Err(err(
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
                )));
            }
            _ if family.name() == "general" => None,
            _ => Some(family.name().to_string()),
        };
        Ok(RobotModel {
            robot,
            link_names: names,
            frames,
            ik,
        })
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
