//! A scene's `effects { … }` block, read into the one typed set of effects
//! ([`Effects`] = `robosim_model::Options`): one named step per effect. Properties
//! (`kinematics: on`, `encoder_bits: 12`, `log: ["q"]`, …) go through [`Evaluator::effect_prop`];
//! groups (`collision { … }`, `dynamics { … }`, `orbit { … }`, `kinematics { … }`,
//! `oru_swap { … }`, `power { … }`, `automation { … }`, `attitude { … }`, `joint_friction { … }`)
//! through one
//! `*_group` step each.

use super::*;

/// Every property an `effects { … }` block takes.
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
    "attitude",
    "joint_friction",
    "consumers",
];

/// Every group an `effects { … }` block takes.
const GROUPS: &[&str] = &[
    "kinematics",
    "collision",
    "dynamics",
    "orbit",
    "power",
    "oru_swap",
    "automation",
    "attitude",
    "joint_friction",
];

/// `collision: on`: polygon mode, no self-collision, discrete.
pub(super) fn default_collision() -> CollisionEffect {
    CollisionEffect {
        mode: CollisionMode::Polygon,
        self_collision: false,
        continuous: false,
        ..CollisionEffect::default()
    }
}

/// `dynamics: on`: RK4 at 1 ms under standard gravity along −z.
pub(super) fn default_dynamics() -> DynamicsEffect {
    DynamicsEffect {
        integrator: Integrator::Rk4,
        dt: 1e-3,
        gravity: Some([0.0, 0.0, -9.81]),
        ..DynamicsEffect::default()
    }
}

/// What an effect said that another must check (the sun comes from the orbit: tracking and
/// power without one mean nothing).
type NeedsOrbit = Option<(Span, &'static str)>;

impl Evaluator<'_> {
    /// The effects a scene's `effects { … }` block declares; kinematics is on unless it says
    /// `kinematics: off`.
    pub(super) fn effects(&mut self, body: &[Stmt], scope: &mut Scope) -> RResult<Effects> {
        let mut fx = Effects {
            kinematics: true,
            ..Effects::default()
        };
        let mut seen = Seen::default();
        let mut needs_orbit: NeedsOrbit = None;
        for st in body {
            match st {
                Stmt::Prop {
                    name,
                    name_span,
                    value,
                } => {
                    seen.check(name, *name_span)?;
                    self.effect_prop(&mut fx, &mut needs_orbit, name, *name_span, value, scope)?;
                }
                Stmt::Block {
                    name,
                    name_span,
                    body,
                } => {
                    if !GROUPS.contains(&name.as_str()) {
                        return Err(unknown_prop("effects", name, *name_span, GROUPS));
                    }
                    seen.check(name, *name_span)?;
                    self.effect_group(&mut fx, &mut needs_orbit, name, *name_span, body, scope)?;
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

    /// One `name: value` property of the block.
    fn effect_prop(
        &mut self,
        fx: &mut Effects,
        needs_orbit: &mut NeedsOrbit,
        name: &str,
        name_span: Span,
        value: &Expr,
        scope: &mut Scope,
    ) -> RResult<()> {
        match name {
            "kinematics" => fx.kinematics = self.switch(value, scope)?,
            "sun_tracking" => {
                fx.sun_tracking = self.switch(value, scope)?;
                if fx.sun_tracking {
                    *needs_orbit = Some((name_span, "sun_tracking"));
                }
            }
            "joint_limits" => fx.joint_limits = self.switch(value, scope)?,
            "consumers" => {
                fx.consumers = self.switch(value, scope)?;
                if fx.consumers {
                    *needs_orbit = Some((name_span, "consumers"));
                }
            }
            "encoder_bits" => {
                fx.encoder = Some(EncoderEffect {
                    bits: self.count(value, scope, 1, 32)? as u32,
                })
            }
            "log" => fx.logging = self.log_prop(value, scope)?,
            "collision" => fx.collision = self.switch(value, scope)?.then(default_collision),
            "automation" => {
                fx.automation = self.switch(value, scope)?.then(AutomationEffect::default)
            }
            "dynamics" => fx.dynamics = self.switch(value, scope)?.then(default_dynamics),
            "attitude" => {
                fx.attitude = self.switch(value, scope)?.then(AttitudeEffect::default);
                if fx.attitude.is_some() {
                    *needs_orbit = Some((name_span, "attitude"));
                }
            }
            "joint_friction" => {
                fx.joint_friction = self
                    .switch(value, scope)?
                    .then(robosim_model::JointFrictionEffect::default)
            }
            _ => return Err(unknown_prop("effects", name, name_span, PROPS)),
        }
        Ok(())
    }

    /// One `name { … }` group of the block (`name` is one of [`GROUPS`]).
    fn effect_group(
        &mut self,
        fx: &mut Effects,
        needs_orbit: &mut NeedsOrbit,
        name: &str,
        name_span: Span,
        body: &[Stmt],
        scope: &mut Scope,
    ) -> RResult<()> {
        match name {
            "collision" => fx.collision = Some(self.collision_group(body, scope)?),
            "dynamics" => fx.dynamics = Some(self.dynamics_group(body, scope)?),
            "orbit" => fx.orbit = Some(self.orbit_group(name_span, body, scope)?),
            "kinematics" => {
                fx.kinematics = true;
                if let Some(step) = self.kinematics_group(body, scope)? {
                    fx.dt = step;
                }
            }
            "oru_swap" => fx.oru_swap = Some(self.oru_swap_group(name_span, body, scope)?),
            "power" => {
                fx.power = Some(self.power_group(body, scope)?);
                *needs_orbit = Some((name_span, "power"));
            }
            "automation" => fx.automation = Some(self.automation_group(body, scope)?),
            "attitude" => {
                fx.attitude = Some(self.attitude_group(name_span, body, scope)?);
                *needs_orbit = Some((name_span, "attitude"));
            }
            "joint_friction" => fx.joint_friction = Some(self.joint_friction_group(body, scope)?),
            _ => return Err(unknown_prop("effects", name, name_span, GROUPS)),
        }
        Ok(())
    }

    /// `log: ["q", "tau", …]`: the signals the simulator logs, typed; any other name is kept
    /// as `unsupported` (the simulator says it does not log it). `None` for an empty list.
    fn log_prop(&mut self, value: &Expr, scope: &mut Scope) -> RResult<Option<LoggingEffect>> {
        let items = match self.eval(value, scope)? {
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
        let mut log = LoggingEffect {
            signals: Vec::new(),
            ..LoggingEffect::default()
        };
        for (it, span) in items {
            match it {
                Value::Str(s) if !s.is_empty() => match Signal::from_name(&s) {
                    Some(signal) => log.signals.push(signal),
                    None => log.unsupported.push(s),
                },
                other => {
                    return Err(err(
                        ErrorKind::Type,
                        span,
                        format!("a logged signal must be a string, got {}", other.describe()),
                    )
                    .expected("a signal name in quotes such as \"q\""));
                }
            }
        }
        Ok((!log.signals.is_empty() || !log.unsupported.is_empty()).then_some(log))
    }

    /// `collision { mode: bbox | polygon | exact, self: on, continuous: on,
    /// tolerance: certified | 1e-6 m }`.
    fn collision_group(&mut self, body: &[Stmt], scope: &mut Scope) -> RResult<CollisionEffect> {
        const NAMES: &[&str] = &["mode", "self", "continuous", "tolerance"];
        let mut c = default_collision();
        for (name, name_span, value) in group_props(
            body,
            "`collision { … }`",
            "`mode:`, `self:`, `continuous:` or `tolerance:`",
        )? {
            match name {
                "mode" => {
                    c.mode = match self
                        .word(value, &["bbox", "polygon", "exact"], "collision mode")?
                        .as_str()
                    {
                        "bbox" => CollisionMode::BBox,
                        "polygon" => CollisionMode::Polygon,
                        _ => CollisionMode::Exact,
                    }
                }
                "self" => c.self_collision = self.switch(value, scope)?,
                "continuous" => c.continuous = self.switch(value, scope)?,
                // `certified` (the default) or a GJK tolerance, a length > 0
                "tolerance" => {
                    c.tolerance = if matches!(&value.kind, ExprKind::Name(w) if w == "certified") {
                        robosim_model::CollisionTolerance::Certified
                    } else {
                        let t = self.quantity(
                            value,
                            scope,
                            Dim::LENGTH,
                            "`certified` or a GJK tolerance such as 1e-6 m",
                        )?;
                        robosim_model::CollisionTolerance::gjk(t).map_err(|_| {
                            err(
                                ErrorKind::OutOfRange,
                                value.span,
                                format!("collision tolerance {t} m is out of range"),
                            )
                            .expected("`certified` or a finite length > 0 such as 1e-6 m")
                        })?
                    }
                }
                _ => return Err(unknown_prop("collision", name, name_span, NAMES)),
            }
        }
        Ok(c)
    }

    /// `dynamics { integrator: rk4, step: 1 ms, gravity: [0, 0, -9.81] m/s^2 }`.
    fn dynamics_group(&mut self, body: &[Stmt], scope: &mut Scope) -> RResult<DynamicsEffect> {
        let mut dy = default_dynamics();
        for (name, name_span, value) in group_props(
            body,
            "`dynamics { … }`",
            "`integrator:`, `step:` or `gravity:`",
        )? {
            match name {
                "integrator" => {
                    let names = Integrator::ALL.map(Integrator::name);
                    let word = self.word(value, &names, "integrator")?;
                    // `word` admits only the names of `Integrator::ALL`
                    dy.integrator = Integrator::from_name(&word).unwrap_or(Integrator::Dopri5);
                }
                "step" => {
                    let s = self.quantity(value, scope, Dim::TIME, "a time step such as 1 ms")?;
                    if s <= 0.0 || s > 1.0 {
                        return Err(err(
                            ErrorKind::OutOfRange,
                            value.span,
                            format!("step {s} s is out of range"),
                        )
                        .expected("a step in (0, 1 s]"));
                    }
                    dy.dt = s;
                }
                "gravity" => {
                    let g = self.vector(value, scope, Dim::ACCEL, 3, "[gx, gy, gz] in m/s^2")?;
                    dy.gravity = Some([g[0], g[1], g[2]]);
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
        Ok(dy)
    }

    /// `orbit { altitude: 400 km, beta: 0 deg }` (the altitude is required).
    fn orbit_group(
        &mut self,
        group_span: Span,
        body: &[Stmt],
        scope: &mut Scope,
    ) -> RResult<OrbitEffect> {
        let (mut altitude, mut beta) = (None, 0.0);
        for (name, name_span, value) in
            group_props(body, "`orbit { … }`", "`altitude:` or `beta:`")?
        {
            match name {
                "altitude" => {
                    let h =
                        self.quantity(value, scope, Dim::LENGTH, "an altitude such as 400 km")?;
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
                    let b =
                        self.quantity(value, scope, Dim::ANGLE, "a beta angle such as 20 deg")?;
                    if b.abs() > std::f64::consts::FRAC_PI_2 {
                        return Err(err(
                            ErrorKind::OutOfRange,
                            value.span,
                            format!("beta angle {} deg is out of range", b.to_degrees()),
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
                group_span,
                "`orbit { … }` needs an altitude".to_string(),
            )
            .expected("`orbit { altitude: 400 km }`"));
        };
        Ok(OrbitEffect {
            altitude_m,
            beta_rad: beta,
        })
    }

    /// `kinematics { step: 100 ms }`: the kinematic step, if given.
    fn kinematics_group(&mut self, body: &[Stmt], scope: &mut Scope) -> RResult<Option<f64>> {
        let mut step = None;
        for (name, name_span, value) in group_props(body, "`kinematics { … }`", "`step:`")? {
            match name {
                "step" => {
                    let s = self.quantity(value, scope, Dim::TIME, "a time step such as 100 ms")?;
                    if !(s > 0.0 && s <= 1.0) {
                        return Err(err(
                            ErrorKind::OutOfRange,
                            value.span,
                            format!("kinematic step {s} s is out of range"),
                        )
                        .expected("a step in (0, 1 s]"));
                    }
                    step = Some(s);
                }
                _ => {
                    return Err(unknown_prop("kinematics", name, name_span, &["step"]));
                }
            }
        }
        Ok(step)
    }

    /// `oru_swap { servicer: "servicer", spare: "spare_oru", start: 300 s }` (servicer and
    /// spare required).
    fn oru_swap_group(
        &mut self,
        group_span: Span,
        body: &[Stmt],
        scope: &mut Scope,
    ) -> RResult<OruSwapEffect> {
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
                    let t = self.quantity(value, scope, Dim::TIME, "a start time such as 300 s")?;
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
                group_span,
                "`oru_swap { … }` needs a servicer and a spare".to_string(),
            )
            .expected("`oru_swap { servicer: \"servicer\", spare: \"spare_oru\" }`"));
        };
        Ok(OruSwapEffect {
            servicer,
            spare,
            start_s: start,
        })
    }

    /// `power { efficiency: 0.14 }`.
    fn power_group(&mut self, body: &[Stmt], scope: &mut Scope) -> RResult<PowerEffect> {
        let mut p = PowerEffect { efficiency: 0.14 };
        for (name, name_span, value) in group_props(body, "`power { … }`", "`efficiency:`")? {
            match name {
                "efficiency" => {
                    let e =
                        self.quantity(value, scope, Dim::NONE, "a plain fraction such as 0.14")?;
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
                    return Err(unknown_prop("power", name, name_span, &["efficiency"]));
                }
            }
        }
        Ok(p)
    }

    /// `automation { model: "eclss", time_scale: 60 }`.
    fn automation_group(&mut self, body: &[Stmt], scope: &mut Scope) -> RResult<AutomationEffect> {
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
        Ok(a)
    }
    /// `joint_friction { viscous: on, coulomb: stick_slip | regularised | off, velocity: 1e-6
    /// rad/s }` (issue 36; every property optional: `JointFrictionEffect::default`): the robot's
    /// per-joint viscous and Coulomb friction act in the dynamics stage.
    fn joint_friction_group(
        &mut self,
        body: &[Stmt],
        scope: &mut Scope,
    ) -> RResult<robosim_model::JointFrictionEffect> {
        use robosim_model::CoulombModel;
        const NAMES: &[&str] = &["viscous", "coulomb", "velocity"];
        let mut f = robosim_model::JointFrictionEffect::default();
        for (name, name_span, value) in group_props(
            body,
            "`joint_friction { … }`",
            "`viscous:`, `coulomb:` or `velocity:`",
        )? {
            match name {
                "viscous" => f.viscous = self.switch(value, scope)?,
                "coulomb" => {
                    f.coulomb = match self
                        .word(
                            value,
                            &["stick_slip", "regularised", "off"],
                            "Coulomb model",
                        )?
                        .as_str()
                    {
                        "regularised" => CoulombModel::Regularised,
                        "off" => CoulombModel::Off,
                        _ => CoulombModel::StickSlip,
                    }
                }
                "velocity" => {
                    let v = self.quantity(
                        value,
                        scope,
                        Dim([0, 0, 1, -1]),
                        "a joint velocity such as 1e-6 rad/s",
                    )?;
                    if !(v.is_finite() && v >= 0.0) {
                        return Err(err(
                            ErrorKind::OutOfRange,
                            value.span,
                            format!("velocity {v} is out of range"),
                        )
                        .expected("a finite velocity ≥ 0 (> 0 for the regularised model)"));
                    }
                    f.velocity = v;
                }
                _ => return Err(unknown_prop("joint_friction", name, name_span, NAMES)),
            }
        }
        Ok(f)
    }

    /// `attitude { cmgs: 4, cmg_momentum: 4760 kg*m^2/s, cmg_torque: 258 kg*m^2/s^2,
    /// saturation: 0.8, dump_to: 0.2, hold: lvlh | tea, drag_coefficient: 2.2 }` (every
    /// property optional: `AttitudeEffect::default`, the ISS's CMGs).
    fn attitude_group(
        &mut self,
        group_span: Span,
        body: &[Stmt],
        scope: &mut Scope,
    ) -> RResult<AttitudeEffect> {
        const NAMES: &[&str] = &[
            "cmgs",
            "cmg_momentum",
            "cmg_torque",
            "saturation",
            "dump_to",
            "hold",
            "drag_coefficient",
        ];
        let mut a = AttitudeEffect::default();
        let positive = |x: f64, span: Span, what: &str, expected: &str| {
            if x.is_finite() && x > 0.0 {
                Ok(x)
            } else {
                Err(err(
                    ErrorKind::OutOfRange,
                    span,
                    format!("{what} {x} is out of range"),
                )
                .expected(expected))
            }
        };
        let mut dump_span = None;
        for (name, name_span, value) in group_props(
            body,
            "`attitude { … }`",
            "`cmgs:`, `cmg_momentum:`, `saturation:`, `hold:` or `drag_coefficient:`",
        )? {
            match name {
                "cmgs" => a.cmgs = self.count(value, scope, 1, 64)? as u32,
                "cmg_momentum" => {
                    let h = self.quantity(
                        value,
                        scope,
                        Dim([2, 1, 0, -1]),
                        "an angular momentum such as 4760 kg*m^2/s",
                    )?;
                    a.cmg_momentum_nms =
                        positive(h, value.span, "cmg_momentum", "a positive momentum")?;
                }
                "cmg_torque" => {
                    let t = self.quantity(
                        value,
                        scope,
                        Dim([2, 1, 0, -2]),
                        "a torque such as 258 kg*m^2/s^2",
                    )?;
                    a.cmg_torque_nm = positive(t, value.span, "cmg_torque", "a positive torque")?;
                }
                "saturation" | "dump_to" => {
                    let f = self.quantity(value, scope, Dim::NONE, "a fraction such as 0.8")?;
                    if !(f.is_finite() && (0.0..1.0).contains(&f)) {
                        return Err(err(
                            ErrorKind::OutOfRange,
                            value.span,
                            format!("{name} {f} is out of range"),
                        )
                        .expected("a fraction of the CMG capacity in [0, 1)"));
                    }
                    if name == "saturation" {
                        a.saturation = f;
                    } else {
                        a.dump_to = f;
                        dump_span = Some(value.span);
                    }
                }
                "hold" => {
                    a.hold = match self
                        .word(value, &["lvlh", "tea"], "attitude hold")?
                        .as_str()
                    {
                        "tea" => AttitudeHold::Tea,
                        _ => AttitudeHold::Lvlh,
                    }
                }
                "drag_coefficient" => {
                    let c = self.quantity(value, scope, Dim::NONE, "a coefficient such as 2.2")?;
                    a.drag_coefficient =
                        positive(c, value.span, "drag_coefficient", "a positive coefficient")?;
                }
                _ => return Err(unknown_prop("attitude", name, name_span, NAMES)),
            }
        }
        if a.saturation <= 0.0 || a.dump_to >= a.saturation {
            let span = dump_span.unwrap_or(group_span);
            return Err(err(
                ErrorKind::OutOfRange,
                span,
                format!(
                    "the dump target {} is not below the saturation {}",
                    a.dump_to, a.saturation
                ),
            )
            .expected("0 ≤ dump_to < saturation < 1"));
        }
        Ok(a)
    }
}
