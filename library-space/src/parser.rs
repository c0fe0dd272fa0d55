//! Recursive-descent parser for the Library Space language (grammar in docs/library.md).
//!
//! Recursion follows nesting only — parentheses, calls, lists, unary minus, `^`, bodies — and
//! that is bounded ([`MAX_DEPTH`]); operator chains (`+ -`, `* /`) are read in a loop into flat
//! [`ExprKind::Chain`] nodes ([`MAX_CHAIN`] operators at most), so no input can overflow the
//! stack here or in any later walk of the tree.
//!
//! ```text
//! file    := item*
//! item    := 'include' STRING | 'let' NAME '=' expr | ('colour'|'color') NAME '=' expr
//!          | ('surface'|'solid'|'link'|'robot'|'scene') NAME params? '{' stmt* '}'
//!          | 'robot' NAME params? ('from_urdf' | 'from_mjcf') STRING ['{' stmt* '}']
//! params  := '(' [NAME '=' expr {',' NAME '=' expr}] ')'
//! stmt    := 'let' NAME '=' expr | NAME ':' expr | NAME '{' stmt* '}'
//!          | 'part' [NAME '='] expr ['at' expr] [('colour'|'color') expr] ['surface' expr]
//!                   ['for' NAME 'in' expr]
//!          | 'link' NAME ('{' stmt* '}' | '=' expr)
//!          | 'place' NAME '=' expr ['at' expr] ['q' expr]
//! expr    := term {('+'|'-') term}       term := unary {('*'|'/') unary}
//! unary   := '-' unary | power           power := primary ['^' unary]
//! primary := NUMBER [unit {('*'|'/') unit} ] | STRING | NAME | NAME '(' args ')'
//!          | '(' expr ')' | '[' [expr {',' expr}] ']'
//! unit    := ('m'|'cm'|'mm'|'kg'|'g'|'deg'|'rad'|'s'|'ms') ['^' ['-'] INT]
//! args    := [arg {',' arg}]             arg := [NAME ':'] expr
//! ```
//! Optional `;` or `,` may separate statements.

use crate::ast::*;
use crate::error::{ErrorKind, RResult, RawError};
use crate::lexer::{Tok, Token};
use crate::source::Span;
use crate::units::{Dim, unit};

const DECL_WORDS: &str =
    "`include`, `let`, `colour`, `surface`, `solid`, `link`, `robot` or `scene`";

pub fn parse(tokens: &[Token]) -> RResult<FileAst> {
    let mut p = Parser {
        t: tokens,
        i: 0,
        depth: 0,
    };
    let mut file = FileAst::default();
    while !p.at_eof() {
        let tok = p.peek().clone();
        let word = match &tok.tok {
            Tok::Ident(w) => w.clone(),
            Tok::Punct(';') => {
                p.i += 1;
                continue;
            }
            other => return Err(p.unexpected(&tok, other, DECL_WORDS)),
        };
        p.i += 1;
        match word.as_str() {
            "include" => {
                let t = p.next().clone();
                match t.tok {
                    Tok::Str(s) => file.includes.push((s, t.span)),
                    ref other => {
                        return Err(p.unexpected(
                            &t,
                            other,
                            "a file name in quotes after `include`",
                        ));
                    }
                }
            }
            "let" | "colour" | "color" => {
                let (name, name_span) = p.name("a name")?;
                p.expect('=', "`=` and the value")?;
                let value = p.expr()?;
                let kind = if word == "let" {
                    DeclKind::Constant
                } else {
                    DeclKind::Colour
                };
                let span = tok.span.to(value.span);
                file.decls.push(Decl {
                    kind,
                    name,
                    name_span,
                    params: vec![],
                    value: Some(value),
                    body: vec![],
                    doc: tok.doc,
                    span,
                    urdf: None,
                });
            }
            "surface" | "solid" | "link" | "robot" | "scene" => {
                let kind = match word.as_str() {
                    "surface" => DeclKind::Surface,
                    "solid" => DeclKind::Solid,
                    "link" => DeclKind::Link,
                    "robot" => DeclKind::Robot,
                    _ => DeclKind::Scene,
                };
                let (name, name_span) = p.name("a name for the declaration")?;
                let params = if p.is_punct('(') { p.params()? } else { vec![] };
                let format = if p.is_word("from_urdf") {
                    Some(RobotFileFormat::Urdf)
                } else if p.is_word("from_mjcf") {
                    Some(RobotFileFormat::Mjcf)
                } else {
                    None
                };
                let urdf = if let Some(format) = format {
                    let w = p.next().clone();
                    let (keyword, what) = (format.keyword(), format.name());
                    if kind != DeclKind::Robot {
                        return Err(RawError::new(
                            ErrorKind::Syntax,
                            w.span,
                            format!("a {} cannot be read `{keyword}`", kind.as_str()),
                        )
                        .expected(match format {
                            RobotFileFormat::Urdf => "`robot NAME from_urdf \"FILE.urdf\" { … }`",
                            RobotFileFormat::Mjcf => "`robot NAME from_mjcf \"FILE.xml\" { … }`",
                        }));
                    }
                    let t = p.next().clone();
                    match t.tok {
                        Tok::Str(s) => Some(UrdfSource {
                            resolved: Ok(std::path::PathBuf::from(&s)),
                            path: s,
                            span: t.span,
                            format,
                        }),
                        ref other => {
                            return Err(p.unexpected(
                                &t,
                                other,
                                &format!("the {what} file name in quotes after `{keyword}`"),
                            ));
                        }
                    }
                } else {
                    None
                };
                // a `from_urdf` robot's body is optional
                let body = if urdf.is_some() && !p.is_punct('{') {
                    vec![]
                } else {
                    p.expect(
                        '{',
                        if urdf.is_some() {
                            "`{` to open the robot's properties (tip, base, …)"
                        } else {
                            "`{` to open the declaration's body (or `(` for its parameters, or `from_urdf \"FILE\"` / `from_mjcf \"FILE\"` for a robot)"
                        },
                    )?;
                    p.body()?
                };
                let end = p.t[p.i - 1].span;
                file.decls.push(Decl {
                    kind,
                    name,
                    name_span,
                    params,
                    value: None,
                    body,
                    doc: tok.doc,
                    span: tok.span.to(end),
                    urdf,
                });
            }
            _ => return Err(p.unexpected(&tok, &tok.tok, DECL_WORDS)),
        }
    }
    Ok(file)
}

struct Parser<'a> {
    t: &'a [Token],
    i: usize,
    /// Nesting depth of expressions and bodies, bounded so malformed input cannot overflow the
    /// stack.
    depth: usize,
}

const MAX_DEPTH: usize = 200;

/// The most operators of one precedence level in a row (`1 + 1 + … + 1`). A chain is parsed
/// and evaluated in a loop whatever its length; the bound keeps one expression's memory and
/// evaluation time in proportion to what a library needs (the standard library's longest chain
/// has a handful) and says so clearly, e.g. for a generated parameter string.
pub(crate) const MAX_CHAIN: usize = 100_000;

impl<'a> Parser<'a> {
    fn peek(&self) -> &'a Token {
        // the token list always ends with Eof and we never advance past it
        &self.t[self.i.min(self.t.len() - 1)]
    }
    fn peek_at(&self, k: usize) -> &'a Tok {
        &self.t[(self.i + k).min(self.t.len() - 1)].tok
    }
    fn next(&mut self) -> &'a Token {
        let t = self.peek();
        if t.tok != Tok::Eof {
            self.i += 1;
        }
        t
    }
    fn at_eof(&self) -> bool {
        self.peek().tok == Tok::Eof
    }
    fn is_punct(&self, c: char) -> bool {
        self.peek().tok == Tok::Punct(c)
    }
    fn is_word(&self, w: &str) -> bool {
        matches!(&self.peek().tok, Tok::Ident(s) if s == w)
    }
    fn unexpected(&self, t: &Token, got: &Tok, expected: &str) -> RawError {
        RawError::new(
            ErrorKind::Syntax,
            t.span,
            format!("unexpected {}", got.describe()),
        )
        .expected(expected.to_string())
    }
    fn expect(&mut self, c: char, expected: &str) -> RResult<Span> {
        let t = self.next();
        if t.tok == Tok::Punct(c) {
            Ok(t.span)
        } else {
            Err(self.unexpected(t, &t.tok, expected))
        }
    }
    fn name(&mut self, what: &str) -> RResult<(String, Span)> {
        let t = self.next();
        match &t.tok {
            Tok::Ident(s) => {
                if unit(s).is_some() {
                    return Err(RawError::new(
                        ErrorKind::Syntax,
                        t.span,
                        format!("`{s}` is a unit and cannot be used as a name"),
                    )
                    .expected(what.to_string()));
                }
                Ok((s.clone(), t.span))
            }
            other => Err(self.unexpected(t, other, what)),
        }
    }

    fn params(&mut self) -> RResult<Vec<Param>> {
        self.expect('(', "`(`")?;
        let mut out = Vec::new();
        while !self.is_punct(')') {
            let (name, span) = self.name("a parameter name")?;
            self.expect(
                '=',
                "`=` and the parameter's default value (every parameter has a default)",
            )?;
            let default = self.expr()?;
            out.push(Param {
                name,
                span,
                default,
            });
            if !self.is_punct(')') {
                self.expect(',', "`,` or `)` after a parameter")?;
            }
        }
        self.i += 1;
        Ok(out)
    }

    /// Statements up to and including the closing `}`.
    fn body(&mut self) -> RResult<Vec<Stmt>> {
        self.depth += 1;
        let r = self.body_inner();
        self.depth -= 1;
        r
    }

    fn body_inner(&mut self) -> RResult<Vec<Stmt>> {
        if self.depth > MAX_DEPTH {
            let t = self.peek();
            return Err(RawError::new(
                ErrorKind::Syntax,
                t.span,
                format!("blocks nested more than {MAX_DEPTH} deep"),
            )
            .expected("a shallower structure"));
        }
        let mut out = Vec::new();
        loop {
            let t = self.peek();
            match &t.tok {
                Tok::Punct('}') => {
                    self.i += 1;
                    return Ok(out);
                }
                Tok::Punct(';') | Tok::Punct(',') => {
                    self.i += 1;
                }
                Tok::Eof => {
                    return Err(self.unexpected(t, &t.tok, "`}` to close the body"));
                }
                Tok::Ident(w) => {
                    let stmt = match w.as_str() {
                        "let" if !matches!(self.peek_at(1), Tok::Punct(':')) => {
                            self.i += 1;
                            let (name, name_span) = self.name("a variable name after `let`")?;
                            self.expect('=', "`=` and the variable's value")?;
                            Stmt::Let {
                                name,
                                name_span,
                                value: self.expr()?,
                            }
                        }
                        "part" if !matches!(self.peek_at(1), Tok::Punct(':')) => self.part()?,
                        "link" if !matches!(self.peek_at(1), Tok::Punct(':')) => {
                            self.i += 1;
                            let (name, name_span) = self.name("a name for the link")?;
                            if self.is_punct('{') {
                                self.i += 1;
                                let body = self.body()?;
                                Stmt::Link {
                                    name,
                                    name_span,
                                    def: LinkDef::Inline(body),
                                    span: t.span.to(self.t[self.i - 1].span),
                                }
                            } else {
                                self.expect(
                                    '=',
                                    "`{` for an inline link or `=` and a declared link",
                                )?;
                                let e = self.expr()?;
                                let span = t.span.to(e.span);
                                Stmt::Link {
                                    name,
                                    name_span,
                                    def: LinkDef::Ref(e),
                                    span,
                                }
                            }
                        }
                        "place" if !matches!(self.peek_at(1), Tok::Punct(':')) => {
                            self.i += 1;
                            let (name, name_span) = self.name("a name for the placed item")?;
                            self.expect('=', "`=` and the robot or solid to place")?;
                            let item = self.expr()?;
                            let mut span = t.span.to(item.span);
                            let mut at = None;
                            let mut q = None;
                            loop {
                                if self.is_word("at") && at.is_none() {
                                    self.i += 1;
                                    let e = self.expr()?;
                                    span = span.to(e.span);
                                    at = Some(e);
                                } else if self.is_word("q")
                                    && q.is_none()
                                    && !matches!(self.peek_at(1), Tok::Punct(':'))
                                {
                                    self.i += 1;
                                    let e = self.expr()?;
                                    span = span.to(e.span);
                                    q = Some(e);
                                } else {
                                    break;
                                }
                            }
                            Stmt::Place {
                                name,
                                name_span,
                                item,
                                at,
                                q,
                                span,
                            }
                        }
                        _ => {
                            let (name, name_span) = self.name("a property name")?;
                            if self.is_punct('{') {
                                self.i += 1;
                                Stmt::Block {
                                    name,
                                    name_span,
                                    body: self.body()?,
                                }
                            } else {
                                self.expect(
                                    ':',
                                    "`:` and a value after the property name (or `{` for a group)",
                                )?;
                                Stmt::Prop {
                                    name,
                                    name_span,
                                    value: self.expr()?,
                                }
                            }
                        }
                    };
                    out.push(stmt);
                }
                other => {
                    return Err(self.unexpected(
                        t,
                        other,
                        "a statement: `let`, `part`, `link`, `place`, `NAME: value` or `}`",
                    ));
                }
            }
        }
    }

    fn part(&mut self) -> RResult<Stmt> {
        let start = self.next().span;
        let name =
            if matches!(self.peek().tok, Tok::Ident(_)) && self.peek_at(1) == &Tok::Punct('=') {
                let n = self.name("a part name")?;
                self.i += 1;
                Some(n)
            } else {
                None
            };
        let shape = self.expr()?;
        let mut span = start.to(shape.span);
        let (mut at, mut colour, mut surface) = (None, None, None);
        let mut repeat = None;
        loop {
            if self.is_word("for") && repeat.is_none() {
                self.i += 1;
                let (var, vspan) = self.name("a loop variable after `for`")?;
                if !self.is_word("in") {
                    let t = self.peek();
                    return Err(self.unexpected(
                        t,
                        &t.tok,
                        "`in` and a list, e.g. `for k in range(4)`",
                    ));
                }
                self.i += 1;
                let e = self.expr()?;
                span = span.to(e.span);
                repeat = Some((var, vspan, e));
                continue;
            }
            let slot = if self.is_word("at") && at.is_none() {
                &mut at
            } else if (self.is_word("colour") || self.is_word("color"))
                && colour.is_none()
                && self.peek_at(1) != &Tok::Punct(':')
            {
                &mut colour
            } else if self.is_word("surface")
                && surface.is_none()
                && self.peek_at(1) != &Tok::Punct(':')
            {
                &mut surface
            } else {
                break;
            };
            self.i += 1;
            let e = self.expr()?;
            span = span.to(e.span);
            *slot = Some(e);
        }
        Ok(Stmt::Part {
            name,
            shape,
            at,
            colour,
            surface,
            repeat,
            span,
        })
    }

    pub fn expr(&mut self) -> RResult<Expr> {
        self.depth += 1;
        let r = self.expr_inner();
        self.depth -= 1;
        r
    }

    fn expr_inner(&mut self) -> RResult<Expr> {
        if self.depth > MAX_DEPTH {
            let t = self.peek();
            return Err(RawError::new(
                ErrorKind::Syntax,
                t.span,
                format!("expressions nested more than {MAX_DEPTH} deep"),
            )
            .expected("a shallower expression"));
        }
        let first = self.term()?;
        self.chain(first, ['+', '-'], Self::term)
    }

    fn term(&mut self) -> RResult<Expr> {
        let first = self.unary()?;
        self.chain(first, ['*', '/'], Self::unary)
    }

    /// `first {op operand}` for the two operators of one precedence level, collected into one
    /// flat [`ExprKind::Chain`] in a loop (a chain of any length costs no stack), at most
    /// [`MAX_CHAIN`] operators long.
    fn chain(
        &mut self,
        first: Expr,
        ops: [char; 2],
        operand: fn(&mut Self) -> RResult<Expr>,
    ) -> RResult<Expr> {
        let mut rest = Vec::new();
        let mut span = first.span;
        while let Tok::Punct(op) = self.peek().tok
            && ops.contains(&op)
        {
            if rest.len() == MAX_CHAIN {
                return Err(RawError::new(
                    ErrorKind::Syntax,
                    self.peek().span,
                    format!("expression too large: more than {MAX_CHAIN} `{}` and `{}` operators in a row", ops[0], ops[1]),
                )
                .expected("a shorter expression (split it with `let` variables)"));
            }
            self.i += 1;
            let rhs = operand(self)?;
            span = span.to(rhs.span);
            rest.push((op, rhs));
        }
        if rest.is_empty() {
            return Ok(first);
        }
        Ok(Expr {
            kind: ExprKind::Chain {
                first: Box::new(first),
                rest,
            },
            span,
        })
    }

    fn unary(&mut self) -> RResult<Expr> {
        if self.is_punct('-') {
            let s = self.next().span;
            self.depth += 1;
            if self.depth > MAX_DEPTH {
                return Err(RawError::new(
                    ErrorKind::Syntax,
                    s,
                    format!("expressions nested more than {MAX_DEPTH} deep"),
                )
                .expected("a shallower expression"));
            }
            let e = self.unary();
            self.depth -= 1;
            let e = e?;
            let span = s.to(e.span);
            return Ok(Expr {
                kind: ExprKind::Neg(Box::new(e)),
                span,
            });
        }
        let base = self.primary()?;
        if self.is_punct('^') {
            // `a ^ b ^ c` nests to the right: one level of depth per `^`
            let s = self.next().span;
            self.depth += 1;
            if self.depth > MAX_DEPTH {
                return Err(RawError::new(
                    ErrorKind::Syntax,
                    s,
                    format!("expressions nested more than {MAX_DEPTH} deep (`^` chains nest to the right)"),
                )
                .expected("a shallower expression"));
            }
            let exp = self.unary();
            self.depth -= 1;
            let exp = exp?;
            let span = base.span.to(exp.span);
            return Ok(Expr {
                kind: ExprKind::Binary {
                    op: '^',
                    lhs: Box::new(base),
                    rhs: Box::new(exp),
                },
                span,
            });
        }
        Ok(base)
    }

    fn primary(&mut self) -> RResult<Expr> {
        let t = self.next();
        match &t.tok {
            Tok::Number(v) => {
                let mut span = t.span;
                let (mut scale, mut dim, mut unitless) = (1.0, Dim::NONE, true);
                if let Tok::Ident(u) = &self.peek().tok
                    && let Some((s, d)) = unit(u)
                {
                    let (s2, d2, sp) = self.unit_power(s, d)?;
                    scale = s2;
                    dim = d2;
                    span = span.to(sp);
                    unitless = false;
                    // compound units: kg*m^2, m/s^2, kg/m^3
                    while (self.is_punct('*') || self.is_punct('/'))
                        && matches!(self.peek_at(1), Tok::Ident(w) if unit(w).is_some())
                    {
                        let div = self.is_punct('/');
                        self.i += 1;
                        let Tok::Ident(w) = self.peek_at(0) else {
                            break;
                        };
                        // checked just above that `w` is a unit
                        let (s, d) = unit(w).unwrap_or((1.0, Dim::NONE));
                        let (s, d, sp) = self.unit_power(s, d)?;
                        span = span.to(sp);
                        if div {
                            scale /= s;
                            dim = dim.div(d);
                        } else {
                            scale *= s;
                            dim = dim.mul(d);
                        }
                    }
                }
                Ok(Expr {
                    kind: ExprKind::Num {
                        value: v * scale,
                        dim,
                        unitless,
                    },
                    span,
                })
            }
            Tok::Str(s) => Ok(Expr {
                kind: ExprKind::Str(s.clone()),
                span: t.span,
            }),
            Tok::Ident(name) => {
                if self.is_punct('(') {
                    self.i += 1;
                    let mut args = Vec::new();
                    while !self.is_punct(')') {
                        let aname = if matches!(self.peek().tok, Tok::Ident(_))
                            && self.peek_at(1) == &Tok::Punct(':')
                        {
                            let n = self.name("an argument name")?;
                            self.i += 1;
                            Some(n)
                        } else {
                            None
                        };
                        let value = self.expr()?;
                        args.push(Arg { name: aname, value });
                        if !self.is_punct(')') {
                            self.expect(',', "`,` or `)` in the argument list")?;
                        }
                    }
                    let end = self.next().span;
                    Ok(Expr {
                        kind: ExprKind::Call {
                            name: name.clone(),
                            name_span: t.span,
                            args,
                        },
                        span: t.span.to(end),
                    })
                } else {
                    Ok(Expr {
                        kind: ExprKind::Name(name.clone()),
                        span: t.span,
                    })
                }
            }
            Tok::Punct('(') => {
                let e = self.expr()?;
                let end = self.expect(')', "`)` to close the parenthesis")?;
                Ok(Expr {
                    span: t.span.to(end),
                    ..e
                })
            }
            Tok::Punct('[') => {
                let mut items = Vec::new();
                while !self.is_punct(']') {
                    items.push(self.expr()?);
                    if !self.is_punct(']') {
                        self.expect(',', "`,` or `]` in the list")?;
                    }
                }
                let end = self.next().span;
                Ok(Expr {
                    kind: ExprKind::List(items),
                    span: t.span.to(end),
                })
            }
            other => Err(self.unexpected(
                t,
                other,
                "a value: a number (with a unit such as mm or deg), a name, a call, `(` or `[`",
            )),
        }
    }

    /// A unit name just peeked, with an optional integer power.
    fn unit_power(&mut self, s: f64, d: Dim) -> RResult<(f64, Dim, Span)> {
        let mut span = self.next().span;
        if self.is_punct('^') {
            self.i += 1;
            let neg = if self.is_punct('-') {
                self.i += 1;
                true
            } else {
                false
            };
            let t = self.next();
            match t.tok {
                Tok::Number(k) if k.fract() == 0.0 && (1.0..=9.0).contains(&k) => {
                    span = span.to(t.span);
                    let k = if neg { -(k as i8) } else { k as i8 };
                    return Ok((s.powi(k as i32), d.pow(k), span));
                }
                ref other => {
                    return Err(self.unexpected(
                        t,
                        other,
                        "a whole power from 1 to 9 after `^` in a unit (m^2, s^-2)",
                    ));
                }
            }
        }
        Ok((s, d, span))
    }
}
