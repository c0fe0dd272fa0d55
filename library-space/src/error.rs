//! Errors of the Library Space language. Every error names file:line:column, quotes the line,
//! marks the place and says what was expected.

use crate::source::{Location, SourceMap, Span};
use std::fmt;

/// The class of a library error (one test per class asserts location and wording).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// Malformed text: an unexpected character or token.
    Syntax,
    /// A name that is not a parameter, variable, declaration, builtin or unit.
    UnknownName,
    /// A property or parameter name that the declaration does not have.
    UnknownProperty,
    /// A declaration or variable defined twice.
    Duplicate,
    /// A call with too many or too few arguments, or an argument given twice.
    Arity,
    /// A value of the wrong kind (a colour where a length is expected, …).
    Type,
    /// Mismatched or wrong units (adding deg to mm; an angle where a length is expected).
    Unit,
    /// Declarations that refer to each other in a circle.
    Cycle,
    /// A value outside its allowed range (negative radius, colour component above 1, reversed
    /// limits, a concave-and-self-intersecting profile, …).
    OutOfRange,
    /// An included file that cannot be read.
    Include,
    /// A required property is missing.
    Missing,
    /// An expression whose value is not a finite number (`1e308 m * 10`, `2 ^ 100000`).
    Overflow,
}

impl ErrorKind {
    pub fn as_str(self) -> &'static str {
        match self {
            ErrorKind::Syntax => "syntax error",
            ErrorKind::UnknownName => "unknown name",
            ErrorKind::UnknownProperty => "unknown property",
            ErrorKind::Duplicate => "duplicate definition",
            ErrorKind::Arity => "wrong number of arguments",
            ErrorKind::Type => "type error",
            ErrorKind::Unit => "unit error",
            ErrorKind::Cycle => "cycle between declarations",
            ErrorKind::OutOfRange => "value out of range",
            ErrorKind::Include => "include error",
            ErrorKind::Missing => "missing property",
            ErrorKind::Overflow => "overflow",
        }
    }
}

/// A library error located in the source. `Display` prints
///
/// ```text
/// error[unit error]: cannot add a length and an angle
///   --> arm.rsl:3:18
///    |
///  3 |     let x = 5 mm + 3 deg
///    |             ^^^^^^^^^^^^
///    = expected: both sides of `+` in the same unit dimension
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct LibError {
    pub kind: ErrorKind,
    pub message: String,
    pub expected: Option<String>,
    pub location: Location,
    /// Where the offending value came from, when it is elsewhere (a declaration's parameter
    /// default, the first definition of a duplicate).
    pub note: Option<(String, Location)>,
}

impl LibError {
    /// `file:line:col`.
    pub fn position(&self) -> String {
        format!(
            "{}:{}:{}",
            self.location.file, self.location.line, self.location.column
        )
    }
}

impl fmt::Display for LibError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "error[{}]: {}", self.kind.as_str(), self.message)?;
        write_loc(f, &self.location)?;
        let pad = " ".repeat(self.location.line.to_string().len());
        if let Some(e) = &self.expected {
            write!(f, "\n {pad} = expected: {e}")?;
        }
        if let Some((msg, loc)) = &self.note {
            write!(f, "\n {pad} = note: {msg}\n")?;
            write_loc(f, loc)?;
        }
        Ok(())
    }
}

fn write_loc(f: &mut fmt::Formatter<'_>, l: &Location) -> fmt::Result {
    let num = l.line.to_string();
    let pad = " ".repeat(num.len());
    writeln!(f, "  --> {}:{}:{}", l.file, l.line, l.column)?;
    writeln!(f, " {pad} |")?;
    writeln!(f, " {num} | {}", l.line_text)?;
    write!(
        f,
        " {pad} | {}{}",
        " ".repeat(l.column.saturating_sub(1)),
        "^".repeat(l.width)
    )
}

impl std::error::Error for LibError {}

/// An error before it is located: kind, span, message, expectation. Turned into a [`LibError`]
/// with the [`SourceMap`].
#[derive(Debug, Clone)]
pub(crate) struct RawError {
    pub kind: ErrorKind,
    pub span: Span,
    pub message: String,
    pub expected: Option<String>,
    pub note: Option<(String, Span)>,
}

impl RawError {
    pub fn new(kind: ErrorKind, span: Span, message: impl Into<String>) -> Self {
        RawError {
            kind,
            span,
            message: message.into(),
            expected: None,
            note: None,
        }
    }
    pub fn expected(mut self, e: impl Into<String>) -> Self {
        self.expected = Some(e.into());
        self
    }
    pub fn note(mut self, msg: impl Into<String>, span: Span) -> Self {
        self.note = Some((msg.into(), span));
        self
    }
    pub fn locate(self, map: &SourceMap) -> LibError {
        LibError {
            kind: self.kind,
            message: self.message,
            expected: self.expected,
            location: map.locate(self.span),
            note: self.note.map(|(m, s)| (m, map.locate(s))),
        }
    }
}

pub(crate) type RResult<T> = Result<T, RawError>;
