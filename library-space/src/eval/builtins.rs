//! Builtin functions: maths, transforms, colours and the shape generators.

use super::*;

impl Evaluator<'_> {
    /// Calls `name`: a declared solid, link or robot first, else a builtin.
    ///
    /// A builtin's arguments are evaluated left to right once its name is known; the
    /// same-unit builtins (`atan2`, `min`, `max`, `sqrt`, `abs`, `range`, `matrix`) take them
    /// positionally, every other builtin binds them to its signature ([`builtin_signature`]).
    pub(super) fn call(
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
        let Some(spec) = builtin_signature(name) else {
            return Err(self.unknown_function(name, name_span));
        };
        let vals = self.eval_args(args, scope)?;
        match name {
            "atan2" | "min" | "max" => self.same_unit_pair(name, args, vals, span),
            "sqrt" | "abs" => self.sqrt_or_abs(name, args, vals, span),
            "range" => self.range(vals, span),
            "matrix" => {
                let [(a, sa)] =
                    self.exactly::<1>(name, "one 4×4 list of rows", args, vals, span)?;
                self.matrix(a, sa).map(Value::Transform)
            }
            _ => {
                let bound = Bound(self.bind_builtin(name, spec, args, vals, span)?);
                match name {
                    "rgb" => rgb(&bound, span),
                    "box" | "cylinder" | "cone" | "truncated_cone" | "sphere" => {
                        self.round_solid(name, &bound, span)
                    }
                    "extrude" | "revolve" => self.profile_solid(name, &bound, span),
                    _ => math_or_transform(name, &bound),
                }
            }
        }
    }

    /// The error for a name that is neither declared nor a builtin, with the nearest name.
    fn unknown_function(&self, name: &str, name_span: Span) -> RawError {
        let mut msg = format!("unknown function `{name}`");
        let cands = self
            .index
            .keys()
            .map(String::as_str)
            .chain(BUILTIN_FUNCTIONS.iter().copied());
        if let Some(s) = suggest(name, cands) {
            msg.push_str(&format!("; did you mean `{s}`?"));
        }
        err(ErrorKind::UnknownName, name_span, msg).expected(format!(
            "a declared solid, link or robot, or a builtin: {}",
            BUILTIN_FUNCTIONS.join(", ")
        ))
    }

    /// Each argument's value with the span of its expression, left to right.
    fn eval_args(&mut self, args: &[Arg], scope: &Scope) -> RResult<Vec<(Value, Span)>> {
        let mut vals: Vec<(Value, Span)> = Vec::with_capacity(args.len());
        for a in args {
            vals.push((self.eval(&a.value, scope)?, a.value.span));
        }
        Ok(vals)
    }

    /// `atan2(y, x)` (an angle), `min(a, b)`, `max(a, b)`: two numbers of one unit (a plain
    /// number fits any unit).
    fn same_unit_pair(
        &self,
        name: &str,
        args: &[Arg],
        vals: Vec<(Value, Span)>,
        span: Span,
    ) -> RResult<Value> {
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
        Ok(Value::Num(match name {
            "atan2" => Quantity::new(x.value.atan2(y.value), Dim::ANGLE),
            "min" => Quantity::new(x.value.min(y.value), dim),
            _ => Quantity::new(x.value.max(y.value), dim),
        }))
    }

    /// `abs(x)` in x's unit; `sqrt(x)` of x ≥ 0 whose unit is a square (m^2 → m).
    fn sqrt_or_abs(
        &self,
        name: &str,
        args: &[Arg],
        vals: Vec<(Value, Span)>,
        span: Span,
    ) -> RResult<Value> {
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
        Ok(Value::Num(Quantity::new(x.value.sqrt(), d)))
    }

    /// `range(n)` or `range(from, to)`: the whole numbers from..to (to excluded), at most
    /// 100 000 of them.
    fn range(&self, vals: Vec<(Value, Span)>, span: Span) -> RResult<Value> {
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
        Ok(Value::List(items))
    }

    /// `box`, `cylinder`, `cone`, `truncated_cone`, `sphere`: a primitive and its polyhedron,
    /// with the facet count from the argument, the `facets` setting or the chord tolerance.
    fn round_solid(&mut self, name: &str, bound: &Bound, span: Span) -> RResult<Value> {
        let q = |k| bound.q(k);
        let (prim, poly) = match name {
            "box" => (
                Primitive::Box {
                    size: [q(0), q(1), q(2)],
                },
                shapes::cuboid(q(0), q(1), q(2)),
            ),
            "cylinder" => {
                let n = self.round_facets(bound, 2, q(0));
                (
                    Primitive::Cylinder {
                        radius: q(0),
                        height: q(1),
                        facets: n,
                    },
                    shapes::cylinder(q(0), q(1), Some(n)),
                )
            }
            "cone" => {
                let n = self.round_facets(bound, 2, q(0));
                (
                    Primitive::Cone {
                        radius: q(0),
                        height: q(1),
                        facets: n,
                    },
                    shapes::cone(q(0), q(1), Some(n)),
                )
            }
            "truncated_cone" => {
                let n = self.round_facets(bound, 3, q(0).max(q(1)));
                (
                    Primitive::TruncatedCone {
                        bottom: q(0),
                        top: q(1),
                        height: q(2),
                        facets: n,
                    },
                    shapes::truncated_cone(q(0), q(1), q(2), Some(n)),
                )
            }
            _ => {
                let n = self.round_facets(bound, 1, q(0)).max(4);
                (
                    Primitive::Sphere {
                        radius: q(0),
                        facets: n,
                    },
                    shapes::sphere(q(0), Some(n)),
                )
            }
        };
        self.new_solid(name, prim, poly, span)
    }

    /// `extrude(points, height)` and `revolve(points, angle?, facets?)` of a 2-D profile.
    fn profile_solid(&mut self, name: &str, bound: &Bound, span: Span) -> RResult<Value> {
        let pts = bound.points(0);
        let arr: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
        if name == "extrude" {
            let height = bound.q(1);
            return self.new_solid(
                name,
                Primitive::Extrusion {
                    points: arr,
                    height,
                },
                shapes::extrude(&pts, height),
                span,
            );
        }
        let angle = if bound.present(1) {
            bound.q(1)
        } else {
            std::f64::consts::TAU
        };
        let f = self.facets(bound, 2).map(|n| {
            // a facets override means "n around a full turn": scale for a partial revolution
            if bound.present(2) {
                n
            } else {
                ((n as f64 * angle / std::f64::consts::TAU).ceil() as usize).max(1)
            }
        });
        self.new_solid(
            name,
            Primitive::Revolution {
                points: arr,
                angle,
                facets: f,
            },
            shapes::revolve(&pts, angle, f),
            span,
        )
    }

    /// The facet count: argument `k` if given, else the `facets` option or the innermost
    /// `facets` block, else none (the shape's own default).
    fn facets(&self, bound: &Bound, k: usize) -> Option<usize> {
        match bound.get(k) {
            Some((Value::Num(q), _)) => Some(q.value as usize),
            _ => self.opts.facets.or(self.facets.last().copied().flatten()),
        }
    }

    /// [`Self::facets`], or the count that keeps a circle of radius `r` within the chord
    /// tolerance.
    fn round_facets(&self, bound: &Bound, k: usize, r: f64) -> usize {
        self.facets(bound, k)
            .unwrap_or_else(|| shapes::default_facets(r, shapes::DEFAULT_CHORD_TOL))
    }

    /// One placed part named after its builtin, counted against the polygon budget.
    fn new_solid(
        &mut self,
        name: &str,
        prim: Primitive,
        r: Result<Polyhedron, shapes::ShapeError>,
        span: Span,
    ) -> RResult<Value> {
        let poly = r.map_err(|e| {
            err(ErrorKind::OutOfRange, span, e.to_string())
                .expected("parameters a solid can be built from (positive sizes, a simple polygon)")
        })?;
        self.count_polygons(
            poly.polygons.len(),
            span,
            "fewer facets or fewer repeated parts",
        )?;
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
    }

    pub(super) fn exactly<const N: usize>(
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

    pub(super) fn bind_builtin(
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

    pub(super) fn matrix(&self, v: Value, span: Span) -> RResult<Matrix4<f64>> {
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

/// A builtin's parameters: (name, what it must be, required), in call order; `None` for a
/// name that is no builtin. The same-unit builtins take their arguments positionally and have
/// an empty list.
fn builtin_signature(name: &str) -> Option<&'static [(&'static str, Want, bool)]> {
    Some(match name {
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
        // same-unit arguments, checked by their own functions
        "atan2" | "sqrt" | "abs" | "min" | "max" | "matrix" | "range" => &[],
        _ => return None,
    })
}

/// A builtin's arguments bound to its signature by [`Evaluator::bind_builtin`]: slot `k` is
/// parameter `k`, checked against its [`Want`], or `None` when an optional one is absent.
struct Bound(Vec<Option<(Value, Span)>>);

impl Bound {
    fn get(&self, k: usize) -> Option<&(Value, Span)> {
        self.0.get(k).and_then(Option::as_ref)
    }

    fn present(&self, k: usize) -> bool {
        self.get(k).is_some()
    }

    /// Parameter `k`'s number in SI units (0 when absent: only optional ones can be).
    fn q(&self, k: usize) -> f64 {
        match self.get(k) {
            Some((Value::Num(q), _)) => q.value,
            _ => 0.0,
        }
    }

    /// Parameter `k`'s `[x, y]` points (checked by `bind_builtin` as a list of pairs of lengths).
    fn points(&self, k: usize) -> Vec<nalgebra::Point2<f64>> {
        let Some((Value::List(items), _)) = self.get(k) else {
            return Vec::new();
        };
        items
            .iter()
            .map(|(v, _)| match v {
                Value::List(xy) => nalgebra::Point2::new(num(&xy[0].0), num(&xy[1].0)),
                _ => nalgebra::Point2::origin(),
            })
            .collect()
    }
}

/// `sin`, `cos`, `tan` of an angle; the transforms `translate`, `rotate_x|y|z`, `ypr`,
/// `identity`.
fn math_or_transform(name: &str, bound: &Bound) -> RResult<Value> {
    let q = |k| bound.q(k);
    Ok(match name {
        "sin" => Value::Num(Quantity::new(q(0).sin(), Dim::NONE)),
        "cos" => Value::Num(Quantity::new(q(0).cos(), Dim::NONE)),
        "tan" => Value::Num(Quantity::new(q(0).tan(), Dim::NONE)),
        "translate" => Value::Transform(translation(q(0), q(1), q(2))),
        "rotate_x" => Value::Transform(rot(Vector3::x(), q(0))),
        "rotate_y" => Value::Transform(rot(Vector3::y(), q(0))),
        "rotate_z" => Value::Transform(rot(Vector3::z(), q(0))),
        "ypr" => Value::Transform(
            rot(Vector3::z(), q(0)) * rot(Vector3::y(), q(1)) * rot(Vector3::x(), q(2)),
        ),
        _ => Value::Transform(Matrix4::identity()),
    })
}

/// `rgb(red, green, blue)`, each from 0 to 1.
fn rgb(bound: &Bound, span: Span) -> RResult<Value> {
    for k in 0..3 {
        let c = bound.q(k);
        if !(0.0..=1.0).contains(&c) {
            let s = bound.get(k).map_or(span, |b| b.1);
            return Err(err(
                ErrorKind::OutOfRange,
                s,
                format!("colour component {c} is outside [0, 1]"),
            )
            .expected("red, green and blue from 0 to 1"));
        }
    }
    Ok(Value::Colour([bound.q(0), bound.q(1), bound.q(2)]))
}

/// What a builtin argument must be.
#[derive(Clone, Copy)]
pub(super) enum Want {
    Q(Dim),
    Count,
    Points,
}

pub(super) fn rigid_ok(m: &Matrix4<f64>) -> bool {
    let r = m.fixed_view::<3, 3>(0, 0);
    m.iter().all(|v| v.is_finite())
        && (r.transpose() * r - Matrix3::identity()).abs().max() < 1e-9
        && (r.determinant() - 1.0).abs() < 1e-9
        && m[(3, 0)] == 0.0
        && m[(3, 1)] == 0.0
        && m[(3, 2)] == 0.0
        && m[(3, 3)] == 1.0
}

pub(super) fn translation(x: f64, y: f64, z: f64) -> Matrix4<f64> {
    Matrix4::new_translation(&Vector3::new(x, y, z))
}

pub(super) fn rot(axis: Vector3<f64>, a: f64) -> Matrix4<f64> {
    Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), a).to_homogeneous()
}

pub(super) fn num(v: &Value) -> f64 {
    match v {
        Value::Num(q) => q.value,
        _ => 0.0,
    }
}
