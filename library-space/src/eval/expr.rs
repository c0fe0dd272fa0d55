//! Expressions: literals, operators with units, names, calls of declarations.

use super::*;

impl Evaluator<'_> {
    /// The value of `e`. Every expression's value passes here, so a number that left f64's
    /// range — a literal such as `1e400`, `1e308 m * 10`, `2 ^ 100000`, a builtin's result —
    /// is refused where it is made (an [`ErrorKind::Overflow`] marking that expression) and
    /// never reaches a declaration, a file or an answer as `inf`, `NaN` or JSON `null`.
    pub(crate) fn eval(&mut self, e: &Expr, scope: &Scope) -> RResult<Value> {
        let v = self.eval_unchecked(e, scope)?;
        let bad = match &v {
            Value::Num(q) => (!q.value.is_finite()).then_some(q.value),
            Value::Transform(m) => m.iter().copied().find(|x| !x.is_finite()),
            _ => None,
        };
        match bad {
            None => Ok(v),
            Some(x) => {
                let what = if matches!(v, Value::Transform(_)) {
                    "this transform has an entry that"
                } else {
                    "the value of this expression"
                };
                let shown = if x.is_nan() {
                    "NaN"
                } else if x > 0.0 {
                    "+inf"
                } else {
                    "-inf"
                };
                Err(err(
                    ErrorKind::Overflow,
                    e.span,
                    format!("{what} is not a finite number ({shown}): it overflows f64's range"),
                )
                .expected("a result within ±1.8e308 (in SI units)"))
            }
        }
    }

    fn eval_unchecked(&mut self, e: &Expr, scope: &Scope) -> RResult<Value> {
        self.steps += 1;
        if self.steps > EVAL_STEP_BUDGET {
            return Err(err(
                ErrorKind::OutOfRange,
                e.span,
                format!(
                    "evaluation too large: more than {EVAL_STEP_BUDGET} expression steps (declarations that use each other many times over?)"
                ),
            )
            .expected("a library whose declarations are not used exponentially many times"));
        }
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
            ExprKind::Chain { first, rest } => {
                // left to right, as `((a op b) op c) …` would: the span of the left operand
                // grows with each step, so errors mark the same text they always did
                let mut acc = self.eval(first, scope)?;
                let mut span = first.span;
                for (op, rhs) in rest {
                    let b = self.eval(rhs, scope)?;
                    let whole = span.to(rhs.span);
                    acc = self.binary(*op, acc, b, span, rhs.span, whole)?;
                    span = whole;
                }
                Ok(acc)
            }
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

    pub(super) fn binary(
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

    pub(super) fn name(&mut self, n: &str, span: Span, scope: &Scope) -> RResult<Value> {
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

    pub(super) fn call_decl(
        &mut self,
        di: usize,
        args: &[Arg],
        span: Span,
        scope: &Scope,
    ) -> RResult<Value> {
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
}
