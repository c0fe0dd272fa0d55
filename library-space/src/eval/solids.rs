//! Solid bodies: `part` statements, solid declarations, mass properties from parts.

use super::*;

/// Part names of one body: a counter for unnamed parts and the names given so far.
#[derive(Default)]
pub(super) struct PartNames {
    count: usize,
    seen: HashMap<String, Span>,
}

impl Evaluator<'_> {
    /// Parts of a solid/link/robot body: `part` statements and the `colour:`/`surface:` defaults.
    #[expect(
        clippy::too_many_arguments,
        reason = "the pieces of one `part` statement, passed apart so `for` can rebind the name"
    )]
    pub(super) fn part(
        &mut self,
        owner: &str,
        counter: &mut PartNames,
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
        counter.count += 1;
        let (pname, pspan) = match name {
            Some((n, span)) => (n.clone(), *span),
            None => {
                let base = match sv.parts.first() {
                    Some(p) if sv.parts.len() == 1 => p.name.clone(),
                    _ => callee_name(shape).unwrap_or_else(|| "part".into()),
                };
                (format!("{base}{}", counter.count), shape.span)
            }
        };
        if let Some(prev) = counter.seen.insert(pname.clone(), pspan) {
            return Err(err(
                ErrorKind::Duplicate,
                pspan,
                format!("`{owner}` already has a part named `{pname}`"),
            )
            .expected("a unique name for every part (names make the part paths of the model)")
            .note("first named here", prev));
        }
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

    pub(super) fn solid_body(
        &mut self,
        owner: &str,
        body: &[Stmt],
        scope: &mut Scope,
        _kind: DeclKind,
    ) -> RResult<SolidVal> {
        let mut parts = Vec::new();
        let mut counter = PartNames::default();
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
    pub(super) fn parts_mass(
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
}
