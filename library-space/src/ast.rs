//! The syntax tree, every node with its span. Produced by [`crate::parser`], read by
//! [`crate::eval`]. Nothing here is evaluated.

use crate::source::Span;

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum ExprKind {
    /// A number with its unit suffix already applied: SI value and dimension exponents.
    Num {
        value: f64,
        dim: crate::units::Dim,
        unitless: bool,
    },
    Str(String),
    Name(String),
    Call {
        name: String,
        name_span: Span,
        args: Vec<Arg>,
    },
    Neg(Box<Expr>),
    /// `a + b - c …` (ops `+ -`) or `a * b / c …` (ops `* /`): a left-associative chain of one
    /// precedence level, `first` then each `(op, operand)` in order. Kept flat so that a chain
    /// of any length is a `Vec`, not a left-deep tree: the parser, the evaluator, every walk
    /// and `Drop` go through it in a loop, never one stack frame per operand.
    Chain {
        first: Box<Expr>,
        rest: Vec<(char, Expr)>,
    },
    /// `a ^ b` (right-associative: `a ^ b ^ c` is `a ^ (b ^ c)`, its depth bounded by the
    /// parser's nesting limit).
    Binary {
        op: char,
        lhs: Box<Expr>,
        rhs: Box<Expr>,
    },
    List(Vec<Expr>),
}

/// A call argument, positional or `name: value`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Arg {
    pub name: Option<(String, Span)>,
    pub value: Expr,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[expect(
    clippy::large_enum_variant,
    reason = "built once per file; boxing would only add indirection"
)]
pub enum Stmt {
    /// `let NAME = expr`
    Let {
        name: String,
        name_span: Span,
        value: Expr,
    },
    /// `NAME: expr`
    Prop {
        name: String,
        name_span: Span,
        value: Expr,
    },
    /// `NAME { ... }` — a nested group of properties (scene effects).
    Block {
        name: String,
        name_span: Span,
        body: Vec<Stmt>,
    },
    /// `part [NAME =] expr [at expr] [colour expr] [surface expr] [for VAR in expr]` — with
    /// `for`, one part per element of the list (`range(n)`), VAR bound to the element.
    Part {
        name: Option<(String, Span)>,
        shape: Expr,
        at: Option<Expr>,
        colour: Option<Expr>,
        surface: Option<Expr>,
        repeat: Option<(String, Span, Expr)>,
        span: Span,
    },
    /// `link NAME { ... }` (inline) or `link NAME = expr` (a declared link, called).
    Link {
        name: String,
        name_span: Span,
        def: LinkDef,
        span: Span,
    },
    /// `place NAME = expr [at expr] [q expr]` (scenes)
    Place {
        name: String,
        name_span: Span,
        item: Expr,
        at: Option<Expr>,
        q: Option<Expr>,
        span: Span,
    },
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum LinkDef {
    Inline(Vec<Stmt>),
    Ref(Expr),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DeclKind {
    /// `let NAME = expr` at file level: a global constant.
    Constant,
    Colour,
    Surface,
    Solid,
    Link,
    Robot,
    Scene,
}

impl DeclKind {
    pub fn as_str(self) -> &'static str {
        match self {
            DeclKind::Constant => "constant",
            DeclKind::Colour => "colour",
            DeclKind::Surface => "surface",
            DeclKind::Solid => "solid",
            DeclKind::Link => "link",
            DeclKind::Robot => "robot",
            DeclKind::Scene => "scene",
        }
    }
}

/// `name = default` in a declaration's parameter list.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Param {
    pub name: String,
    pub span: Span,
    pub default: Expr,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Decl {
    pub kind: DeclKind,
    pub name: String,
    pub name_span: Span,
    pub params: Vec<Param>,
    /// Constants and colours: their value.
    pub value: Option<Expr>,
    pub body: Vec<Stmt>,
    /// The `//` comment lines directly above the declaration.
    pub doc: Option<String>,
    pub span: Span,
    /// `robot NAME from_urdf "FILE" { … }` (or `from_mjcf`): the robot file the robot is read
    /// from.
    pub urdf: Option<UrdfSource>,
}

/// The format of a robot file: `from_urdf` or `from_mjcf`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum RobotFileFormat {
    #[default]
    Urdf,
    Mjcf,
}

impl RobotFileFormat {
    /// The keyword that declares it: `from_urdf`, `from_mjcf`.
    pub fn keyword(self) -> &'static str {
        match self {
            RobotFileFormat::Urdf => "from_urdf",
            RobotFileFormat::Mjcf => "from_mjcf",
        }
    }

    /// The format's name in messages: `URDF`, `MJCF`.
    pub fn name(self) -> &'static str {
        match self {
            RobotFileFormat::Urdf => "URDF",
            RobotFileFormat::Mjcf => "MJCF",
        }
    }
}

/// The file of a `from_urdf` (or `from_mjcf`) robot: as written, where, and the path it
/// resolves to (relative names against the folder of the `.rsl` file that declares it; set by
/// the loader, which knows that file). `Err`: why it cannot be resolved (a standard-library
/// file is embedded and has no folder).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UrdfSource {
    pub path: String,
    pub span: Span,
    pub resolved: Result<std::path::PathBuf, String>,
    /// URDF or MJCF (the keyword that declared it).
    #[serde(default)]
    pub format: RobotFileFormat,
}

/// One parsed file: its declarations and includes, in order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FileAst {
    pub includes: Vec<(String, Span)>,
    pub decls: Vec<Decl>,
}
