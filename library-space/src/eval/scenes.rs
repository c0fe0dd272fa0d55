//! Scenes: placements, initial joint values; the declared effects are read by [`super::effects`].

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
                    self.place_item(&mut scene, name, item, q.as_ref(), placement, scope)?;
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
        check_oru_swap(&scene, decl.name_span)?;
        // The world's gravity is the scene's: a declared dynamics effect sets it for every robot.
        if let Some(g) = scene.effects.dynamics.and_then(|d| d.gravity) {
            for r in &mut scene.robots {
                r.model.robot.gravity = Vector3::from(g);
            }
        }
        Ok(scene)
    }

    /// Evaluates a placed item and adds it to the scene: a robot (a link as a one-link robot)
    /// at its `q`, or a solid.
    fn place_item(
        &mut self,
        scene: &mut SceneModel,
        name: &str,
        item: &Expr,
        q: Option<&Expr>,
        placement: Matrix4<f64>,
        scope: &mut Scope,
    ) -> RResult<()> {
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
                    name: callee_name(item).unwrap_or_else(|| name.to_owned()),
                    parts: s.parts.clone(),
                    mass: s.mass,
                };
                scene.solids.push(PlacedItem {
                    name: name.to_owned(),
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
            model.robot.name = name.to_owned();
            scene.robots.push(PlacedRobot {
                name: name.to_owned(),
                declaration: callee_name(item),
                model,
                placement,
                q: qv,
            });
        }
        Ok(())
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
}

/// The swap names a placed robot and a placed solid of this scene (`span`: the scene's name).
fn check_oru_swap(scene: &SceneModel, span: Span) -> RResult<()> {
    if let Some(sw) = &scene.effects.oru_swap {
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
    Ok(())
}
