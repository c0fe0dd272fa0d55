//! Scenes: placements, initial joint values, the declared effects.

use super::*;

impl Evaluator<'_> {
    pub(super) fn scene_body(&mut self, decl: &Decl, scope: &mut Scope) -> RResult<SceneModel> {
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
                            declaration: callee_name(item),
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
        // The swap names a placed robot and a placed solid of this scene.
        if let Some(sw) = &scene.effects.oru_swap {
            let span = decl.name_span;
            if !scene.robots.iter().any(|r| r.name == sw.servicer) {
                return Err(err(
                    ErrorKind::Type,
                    span,
                    format!(
                        "scene {}: oru_swap's servicer {:?} is not a placed robot",
                        scene.name, sw.servicer
                    ),
                )
                .expected("the place name of a robot of the scene"));
            }
            if !scene.solids.iter().any(|r| r.name == sw.spare) {
                return Err(err(
                    ErrorKind::Type,
                    span,
                    format!(
                        "scene {}: oru_swap's spare {:?} is not a placed solid",
                        scene.name, sw.spare
                    ),
                )
                .expected("the place name of a solid of the scene"));
            }
        }
        // The world's gravity is the scene's: a declared dynamics effect sets it for every robot.
        if let Some(d) = scene.effects.dynamics {
            for r in &mut scene.robots {
                r.model.robot.gravity = d.gravity;
            }
        }
        Ok(scene)
    }

    pub(super) fn joint_vector(
        &mut self,
        e: &Expr,
        scope: &Scope,
        model: &RobotModel,
    ) -> RResult<Vec<f64>> {
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

    pub(super) fn effects(&mut self, body: &[Stmt], scope: &mut Scope) -> RResult<Effects> {
        let mut fx = Effects::default();
        let mut seen = Seen::default();
        // The sun and eclipses come from the orbit: tracking and power without one mean nothing.
        let mut needs_orbit: Option<(Span, &str)> = None;
        const PROPS: &[&str] = &[
            "kinematics",
            "joint_limits",
            "collision",
            "dynamics",
            "encoder_bits",
            "log",
            "orbit",
            "sun_tracking",
            "power",
            "automation",
            "oru_swap",
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
                        "sun_tracking" => {
                            fx.sun_tracking = self.switch(value, scope)?;
                            if fx.sun_tracking {
                                needs_orbit = Some((*name_span, "sun_tracking"));
                            }
                        }
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
                        "automation" => {
                            fx.automation =
                                self.switch(value, scope)?.then(AutomationEffect::default)
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
                    for (name, name_span, value) in group_props(
                        body,
                        "`collision { … }`",
                        "`mode:`, `self:` or `continuous:`",
                    )? {
                        match name {
                            "mode" => {
                                c.mode = match self
                                    .word(value, &["bbox", "polygon", "exact"], "collision mode")?
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
                                    name_span,
                                    &["mode", "self", "continuous"],
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
                    for (name, name_span, value) in group_props(
                        body,
                        "`dynamics { … }`",
                        "`integrator:`, `step:` or `gravity:`",
                    )? {
                        match name {
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
                                    name_span,
                                    &["integrator", "step", "gravity"],
                                ));
                            }
                        }
                    }
                    fx.dynamics = Some(dy);
                }
                Stmt::Block {
                    name,
                    name_span,
                    body,
                } if name == "orbit" => {
                    seen.check(name, *name_span)?;
                    let (mut altitude, mut beta) = (None, 0.0);
                    for (name, name_span, value) in
                        group_props(body, "`orbit { … }`", "`altitude:` or `beta:`")?
                    {
                        match name {
                            "altitude" => {
                                let h = self.quantity(
                                    value,
                                    scope,
                                    Dim::LENGTH,
                                    "an altitude such as 400 km",
                                )?;
                                // Below 100 km there is no orbit (the Kármán line); beyond a
                                // geostationary radius the station model makes no sense.
                                if !(100e3..=36_000e3).contains(&h) {
                                    return Err(err(
                                        ErrorKind::OutOfRange,
                                        value.span,
                                        format!("orbit altitude {h} m is out of range"),
                                    )
                                    .expected("an altitude in [100 km, 36000 km]"));
                                }
                                altitude = Some(h);
                            }
                            "beta" => {
                                let b = self.quantity(
                                    value,
                                    scope,
                                    Dim::ANGLE,
                                    "a beta angle such as 20 deg",
                                )?;
                                if b.abs() > std::f64::consts::FRAC_PI_2 {
                                    return Err(err(
                                        ErrorKind::OutOfRange,
                                        value.span,
                                        format!(
                                            "beta angle {} deg is out of range",
                                            b.to_degrees()
                                        ),
                                    )
                                    .expected("a beta angle in [-90 deg, 90 deg]"));
                                }
                                beta = b;
                            }
                            _ => {
                                return Err(unknown_prop(
                                    "orbit",
                                    name,
                                    name_span,
                                    &["altitude", "beta"],
                                ));
                            }
                        }
                    }
                    let Some(altitude_m) = altitude else {
                        return Err(err(
                            ErrorKind::Type,
                            *name_span,
                            "`orbit { … }` needs an altitude".to_string(),
                        )
                        .expected("`orbit { altitude: 400 km }`"));
                    };
                    fx.orbit = Some(OrbitEffect {
                        altitude_m,
                        beta_rad: beta,
                    });
                }
                Stmt::Block {
                    name,
                    name_span,
                    body,
                } if name == "kinematics" => {
                    seen.check(name, *name_span)?;
                    fx.kinematics = true;
                    for (name, name_span, value) in
                        group_props(body, "`kinematics { … }`", "`step:`")?
                    {
                        match name {
                            "step" => {
                                let s = self.quantity(
                                    value,
                                    scope,
                                    Dim::TIME,
                                    "a time step such as 100 ms",
                                )?;
                                if !(s > 0.0 && s <= 1.0) {
                                    return Err(err(
                                        ErrorKind::OutOfRange,
                                        value.span,
                                        format!("kinematic step {s} s is out of range"),
                                    )
                                    .expected("a step in (0, 1 s]"));
                                }
                                fx.kinematic_step_s = Some(s);
                            }
                            _ => {
                                return Err(unknown_prop("kinematics", name, name_span, &["step"]));
                            }
                        }
                    }
                }
                Stmt::Block {
                    name,
                    name_span,
                    body,
                } if name == "oru_swap" => {
                    seen.check(name, *name_span)?;
                    let (mut servicer, mut spare, mut start) = (None, None, 0.0);
                    for (name, name_span, value) in group_props(
                        body,
                        "`oru_swap { … }`",
                        "`servicer:`, `spare:` or `start:`",
                    )? {
                        match name {
                            "servicer" | "spare" => {
                                let v = match self.eval(value, scope)? {
                                    Value::Str(s) if !s.is_empty() => s,
                                    other => {
                                        return Err(err(
                                            ErrorKind::Type,
                                            value.span,
                                            format!(
                                                "`{name}` must be a place name in quotes, got {}",
                                                other.describe()
                                            ),
                                        )
                                        .expected("a place name such as \"servicer\""));
                                    }
                                };
                                if name == "servicer" {
                                    servicer = Some(v);
                                } else {
                                    spare = Some(v);
                                }
                            }
                            "start" => {
                                let t = self.quantity(
                                    value,
                                    scope,
                                    Dim::TIME,
                                    "a start time such as 300 s",
                                )?;
                                if !(t.is_finite() && t >= 0.0) {
                                    return Err(err(
                                        ErrorKind::OutOfRange,
                                        value.span,
                                        format!("oru_swap start {t} s is out of range"),
                                    )
                                    .expected("a time ≥ 0"));
                                }
                                start = t;
                            }
                            _ => {
                                return Err(unknown_prop(
                                    "oru_swap",
                                    name,
                                    name_span,
                                    &["servicer", "spare", "start"],
                                ));
                            }
                        }
                    }
                    let (Some(servicer), Some(spare)) = (servicer, spare) else {
                        return Err(err(
                            ErrorKind::Type,
                            *name_span,
                            "`oru_swap { … }` needs a servicer and a spare".to_string(),
                        )
                        .expected("`oru_swap { servicer: \"servicer\", spare: \"spare_oru\" }`"));
                    };
                    fx.oru_swap = Some(OruSwapEffect {
                        servicer,
                        spare,
                        start_s: start,
                    });
                }
                Stmt::Block {
                    name,
                    name_span,
                    body,
                } if name == "power" => {
                    seen.check(name, *name_span)?;
                    let mut p = PowerEffect { efficiency: 0.14 };
                    for (name, name_span, value) in
                        group_props(body, "`power { … }`", "`efficiency:`")?
                    {
                        match name {
                            "efficiency" => {
                                let e = self.quantity(
                                    value,
                                    scope,
                                    Dim::NONE,
                                    "a plain fraction such as 0.14",
                                )?;
                                if !(e > 0.0 && e <= 1.0) {
                                    return Err(err(
                                        ErrorKind::OutOfRange,
                                        value.span,
                                        format!("efficiency {e} is out of range"),
                                    )
                                    .expected("an efficiency in (0, 1]"));
                                }
                                p.efficiency = e;
                            }
                            _ => {
                                return Err(unknown_prop(
                                    "power",
                                    name,
                                    name_span,
                                    &["efficiency"],
                                ));
                            }
                        }
                    }
                    fx.power = Some(p);
                    needs_orbit = Some((*name_span, "power"));
                }
                Stmt::Block {
                    name,
                    name_span,
                    body,
                } if name == "automation" => {
                    seen.check(name, *name_span)?;
                    let mut a = AutomationEffect::default();
                    for (name, name_span, value) in
                        group_props(body, "`automation { … }`", "`model:` or `time_scale:`")?
                    {
                        match name {
                            "model" => match self.eval(value, scope)? {
                                Value::Str(m) if !m.trim().is_empty() => a.model = m,
                                other => {
                                    return Err(err(
                                        ErrorKind::Type,
                                        value.span,
                                        format!(
                                            "the automation model must be a name in quotes, got {}",
                                            other.describe()
                                        ),
                                    )
                                    .expected(
                                        "a shipped fault model such as \"eclss\", or a model file's path",
                                    ));
                                }
                            },
                            "time_scale" => {
                                let x = self.quantity(
                                    value,
                                    scope,
                                    Dim::NONE,
                                    "plant seconds per wall-clock second, such as 60",
                                )?;
                                if !(x.is_finite() && x > 0.0) {
                                    return Err(err(
                                        ErrorKind::OutOfRange,
                                        value.span,
                                        format!("time_scale {x} is out of range"),
                                    )
                                    .expected("a positive number of plant seconds per second"));
                                }
                                a.time_scale = x;
                            }
                            _ => {
                                return Err(unknown_prop(
                                    "automation",
                                    name,
                                    name_span,
                                    &["model", "time_scale"],
                                ));
                            }
                        }
                    }
                    fx.automation = Some(a);
                }
                Stmt::Block {
                    name, name_span, ..
                } => {
                    return Err(unknown_prop(
                        "effects",
                        name,
                        *name_span,
                        &[
                            "kinematics",
                            "collision",
                            "dynamics",
                            "orbit",
                            "power",
                            "oru_swap",
                            "automation",
                        ],
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
        if let (Some((span, what)), None) = (needs_orbit, fx.orbit) {
            return Err(err(
                ErrorKind::Type,
                span,
                format!("`{what}` needs an `orbit {{ … }}` effect (the sun comes from the orbit)"),
            )
            .expected("`orbit { altitude: 400 km, beta: 0 deg }` in the same `effects { … }`"));
        }
        Ok(fx)
    }
}

pub(super) fn default_collision() -> CollisionEffect {
    CollisionEffect {
        mode: CollisionMode::Polygon,
        self_collision: false,
        continuous: false,
    }
}

pub(super) fn default_dynamics() -> DynamicsEffect {
    DynamicsEffect {
        integrator: Integrator::Rk4,
        step_s: 1e-3,
        gravity: Vector3::new(0.0, 0.0, -9.81),
    }
}
