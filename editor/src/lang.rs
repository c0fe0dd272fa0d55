//! The ROBOSIM language's syntax (seed §2.3, Table 1): one command a line, a name and then either
//! one word (`STORE B`, `STORE-LINK C.LOC`, `UNITS CM`) or `KEY = NUMBER [UNIT]` arguments
//! separated by commas (`CYLINDER R = 10.000, H = 50.000`, `ROTATE X=-45.000`). Names are not
//! case-sensitive. `!` or `#` starts a comment. Numbers may end in a dot (`-100.`).
//!
//! [`parse`] only checks the shape of each line; [`crate::program`] checks the commands and
//! their arguments. Every error names `file:line:column`, the command and the argument
//! ([`LangError`]; when a working object makes no link, its typed cause is a [`LinkError`]).

use robosim_file_io::linkfile::DhViolation;
use std::fmt;

/// A place in the program, 1-based.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Span {
    pub line: usize,
    pub column: usize,
}

/// A unit written after a number.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Unit {
    /// Metres per unit.
    Length(f64),
    /// Radians per unit.
    Angle(f64),
}

/// The units a UNITS line or a number may name.
pub fn unit(word: &str) -> Option<Unit> {
    Some(match word.to_ascii_uppercase().as_str() {
        "M" => Unit::Length(1.0),
        "CM" => Unit::Length(0.01),
        "MM" => Unit::Length(0.001),
        "IN" => Unit::Length(0.0254),
        "FT" => Unit::Length(0.3048),
        "DEG" => Unit::Angle(std::f64::consts::PI / 180.0),
        "RAD" => Unit::Angle(1.0),
        _ => return None,
    })
}

/// One `KEY = NUMBER [UNIT]` argument.
#[derive(Debug, Clone, PartialEq)]
pub struct Arg {
    pub key: String,
    pub value: f64,
    pub unit: Option<(String, Unit)>,
    pub span: Span,
}

/// One command line.
#[derive(Debug, Clone, PartialEq)]
pub struct Command {
    /// Upper case.
    pub name: String,
    pub span: Span,
    /// The one-word argument (`B`, `C.LOC`, `CM`), as written.
    pub word: Option<(String, Span)>,
    pub args: Vec<Arg>,
}

/// A syntax or meaning error, with where it is.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct LangError {
    pub file: String,
    pub span: Span,
    /// The command it is in ("" when the line has none yet).
    pub command: String,
    /// What is wrong, in words ("" when `source` says it all).
    pub what: String,
    /// The solid's or the link's error when a command's shape makes no solid or its objects no
    /// link (kept typed; the message ends with it).
    #[source]
    pub source: Option<LinkError>,
}

impl fmt::Display for LangError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}: ", self.file, self.span.line, self.span.column)?;
        if !self.command.is_empty() {
            write!(f, "{}: ", self.command)?;
        }
        f.write_str(&self.what)?;
        if let Some(source) = &self.source {
            if !self.what.is_empty() {
                f.write_str(": ")?;
            }
            write!(f, "{source}")?;
        }
        Ok(())
    }
}

/// Why a working object cannot become a link file ([`crate::program::build_link`]; a
/// [`LangError`]'s `source`, so it lives here with it). A variant that wraps the geometry's or the
/// link file's error keeps it (`source()`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LinkError {
    /// The objects do not make a link (two joints of one kind): the message.
    #[error("{0}")]
    Refused(String),
    /// An object's shape makes no solid.
    #[error(transparent)]
    Solid(#[from] robosim_geometry::shapes::ShapeError),
    /// A solid's mass properties cannot be computed.
    #[error(transparent)]
    Mass(#[from] robosim_geometry::MassError),
    /// The link's two joints are not related by a DH transform.
    #[error("the I joint and the I+1 joint are not related by a DH transform: {0}")]
    NotDh(#[source] DhViolation),
}

fn is_name_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || matches!(c, '-' | '+' | '_' | '.')
}

/// Parses a program. `file` names it in errors.
pub fn parse(text: &str, file: &str) -> Result<Vec<Command>, LangError> {
    let mut out = Vec::new();
    for (ln, raw) in text.lines().enumerate() {
        let line = match raw.find(['!', '#']) {
            Some(k) => &raw[..k],
            None => raw,
        };
        if line.trim().is_empty() {
            continue;
        }
        if let Some(c) = parse_line(line, file, ln + 1)? {
            out.push(c);
        }
    }
    Ok(out)
}

struct Cursor<'a> {
    s: &'a str,
    i: usize,
}

impl Cursor<'_> {
    fn skip_ws(&mut self) {
        while self.s[self.i..].starts_with([' ', '\t', '\r']) {
            self.i += 1;
        }
    }
    fn peek(&self) -> Option<char> {
        self.s[self.i..].chars().next()
    }
    fn take_while(&mut self, f: impl Fn(char) -> bool) -> &str {
        let start = self.i;
        while let Some(c) = self.peek() {
            if !f(c) {
                break;
            }
            self.i += c.len_utf8();
        }
        &self.s[start..self.i]
    }
}

/// Where a line is: its text, its file and its number, for spans and errors.
struct At<'a> {
    line: &'a str,
    file: &'a str,
    ln: usize,
}

impl At<'_> {
    /// The span of byte `i` of the line (columns count characters, from 1).
    fn col(&self, i: usize) -> Span {
        Span {
            line: self.ln,
            column: self.line[..i].chars().count() + 1,
        }
    }
    /// An error at byte `i` of the line, in `command`.
    fn err(&self, i: usize, command: &str, what: String) -> LangError {
        LangError {
            file: self.file.to_owned(),
            span: self.col(i),
            command: command.to_owned(),
            what,
            source: None,
        }
    }
}

/// Parses one line: the command name, then nothing, one word, or KEY = VALUE arguments.
fn parse_line(line: &str, file: &str, ln: usize) -> Result<Option<Command>, LangError> {
    let mut c = Cursor { s: line, i: 0 };
    c.skip_ws();
    let at = At { line, file, ln };
    let start = c.i;
    let name = c.take_while(is_name_char).to_ascii_uppercase();
    if name.is_empty() {
        return Err(at.err(
            start,
            "",
            format!(
                "expected a command name, found {:?}",
                c.peek().unwrap_or(' ')
            ),
        ));
    }
    let mut cmd = Command {
        name: name.clone(),
        span: at.col(start),
        word: None,
        args: Vec::new(),
    };
    c.skip_ws();
    if c.peek().is_none() {
        return Ok(Some(cmd));
    }
    // A word or a KEY = value list: look past the first token for '='.
    let tok_start = c.i;
    let tok = c.take_while(is_name_char).to_owned();
    c.skip_ws();
    if c.peek() != Some('=') {
        cmd.word = Some(word_argument(&c, &at, &name, tok, tok_start)?);
        return Ok(Some(cmd));
    }
    key_value_arguments(&mut c, &at, &name, (tok, tok_start), &mut cmd.args)?;
    Ok(Some(cmd))
}

/// The command's one word `tok` (at byte `tok_start`), the cursor past it: an error if there
/// is none, or if anything but '=' follows it.
fn word_argument(
    c: &Cursor,
    at: &At,
    name: &str,
    tok: String,
    tok_start: usize,
) -> Result<(String, Span), LangError> {
    if tok.is_empty() {
        return Err(at.err(
            tok_start,
            name,
            format!("unexpected {:?}", c.peek().unwrap_or(' ')),
        ));
    }
    if let Some(ch) = c.peek() {
        return Err(at.err(
            c.i,
            name,
            format!("unexpected {ch:?} after {tok:?} (one word, or KEY = VALUE arguments)"),
        ));
    }
    Ok((tok, at.col(tok_start)))
}

/// The KEY = VALUE arguments, from the cursor at the first '=' (`first` is the key before it
/// and its byte) to the end of the line, pushed onto `args`.
fn key_value_arguments(
    c: &mut Cursor,
    at: &At,
    name: &str,
    first: (String, usize),
    args: &mut Vec<Arg>,
) -> Result<(), LangError> {
    let mut key = first;
    loop {
        if key.0.is_empty() {
            return Err(at.err(key.1, name, "expected an argument name before '='".into()));
        }
        // at '='
        c.i += 1;
        c.skip_ws();
        let (value, unit_w) = argument_value(c, at, name, &key.0)?;
        args.push(Arg {
            key: key.0.to_ascii_uppercase(),
            value,
            unit: unit_w,
            span: at.col(key.1),
        });
        match next_key(c, at, name, &key.0)? {
            None => break,
            Some(k) => key = k,
        }
    }
    Ok(())
}

/// The value of argument `key`, the cursor past the '=': a finite number and, if a word
/// follows it, its unit; the cursor ends past both and the blanks after them.
fn argument_value(
    c: &mut Cursor,
    at: &At,
    name: &str,
    key: &str,
) -> Result<(f64, Option<(String, Unit)>), LangError> {
    let line = at.line;
    let num_start = c.i;
    let num = c.take_while(|ch| ch.is_ascii_digit() || matches!(ch, '.' | '-' | '+' | 'e' | 'E'));
    let value: f64 = num.parse().map_err(|_| {
        at.err(
            num_start,
            name,
            format!(
                "argument {}: {:?} is not a number",
                key.to_ascii_uppercase(),
                if num.is_empty() {
                    line[num_start..].split([',', ' ']).next().unwrap_or("")
                } else {
                    num
                }
            ),
        )
    })?;
    if !value.is_finite() {
        return Err(at.err(
            num_start,
            name,
            format!("argument {}: {num} is not finite", key.to_ascii_uppercase()),
        ));
    }
    c.skip_ws();
    let mut unit_w = None;
    if c.peek().is_some_and(|ch| ch.is_ascii_alphabetic()) {
        let us = c.i;
        let w = c.take_while(|ch| ch.is_ascii_alphabetic()).to_owned();
        let u = unit(&w).ok_or_else(|| {
            at.err(
                us,
                name,
                format!(
                    "argument {}: unknown unit {w:?} (m, cm, mm, in, ft, deg, rad)",
                    key.to_ascii_uppercase()
                ),
            )
        })?;
        unit_w = Some((w, u));
        c.skip_ws();
    }
    Ok((value, unit_w))
}

/// After argument `key`'s value: the end of the line (`None`), or a comma and the next
/// argument's key and its byte, the cursor at its '='.
fn next_key(
    c: &mut Cursor,
    at: &At,
    name: &str,
    key: &str,
) -> Result<Option<(String, usize)>, LangError> {
    match c.peek() {
        None => Ok(None),
        Some(',') => {
            c.i += 1;
            c.skip_ws();
            let ks = c.i;
            let k = c.take_while(is_name_char).to_owned();
            c.skip_ws();
            if c.peek() != Some('=') {
                return Err(at.err(c.i, name, format!("expected '=' after argument name {k:?}")));
            }
            Ok(Some((k, ks)))
        }
        Some(ch) => Err(at.err(
            c.i,
            name,
            format!(
                "unexpected {ch:?} after argument {} (arguments are separated by commas)",
                key.to_ascii_uppercase()
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_table_1_forms() {
        let p = parse(
            "LOOK-FROM X = -100., Y = 100., Z = 45.\nSTORE B\n  ROTATE X = -45.000\nSTORE-LINK C.LOC\ncylinder r = 1 m, h=2cm ! comment\n",
            "t.rs",
        )
        .expect("parses");
        assert_eq!(p.len(), 5);
        assert_eq!(p[0].args[0].value, -100.0);
        assert_eq!(p[1].word.as_ref().map(|w| w.0.as_str()), Some("B"));
        assert_eq!(p[3].word.as_ref().map(|w| w.0.as_str()), Some("C.LOC"));
        assert_eq!(p[4].name, "CYLINDER");
        assert_eq!(p[4].args[1].unit.as_ref().map(|u| u.0.as_str()), Some("cm"));
        assert_eq!(p[2].span, Span { line: 3, column: 3 });
    }

    #[test]
    fn errors_say_where() {
        let e = parse("BOX X = 1, Y = oops", "p.rsim").expect_err("bad");
        assert_eq!(
            e.to_string(),
            "p.rsim:1:16: BOX: argument Y: \"oops\" is not a number"
        );
        let e = parse("BOX X = 1 furlong", "p").expect_err("unit");
        assert!(
            e.to_string()
                .starts_with("p:1:11: BOX: argument X: unknown unit"),
            "{e}"
        );
    }
}
