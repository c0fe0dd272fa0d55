//! The real CLIPS 6.30 engine (Debian's `libclips-dev`, linked statically) behind a safe
//! wrapper: the only Rust module of the crate with `unsafe` (`src/guard.c` holds what needs
//! CLIPS's structure layouts, compiled against its own headers by build.rs).
//!
//! One [`Clips`] is one CLIPS environment. Rules call back into Rust through one external
//! function, `(robosim COMMAND ARGS…)`, answered by the [`Handler`] the engine was made with;
//! it returns an integer to CLIPS (a version, 0, or -1 on failure — the failure's message is
//! asserted as `(robosim-error (command C) (message M))`). Each argument is evaluated once; an
//! argument whose evaluation failed (`(/ 0.0 0.0)`: CLIPS says "divide by zero" and halts)
//! fails the call before the handler runs, so nothing is written.
//!
//! A run of the rules ([`Clips::run`]) is bounded by [`Limits`]: rule execution time per run
//! (time spent answering `(robosim …)` calls not counted), deffunction and generic function
//! call depth and the stack left, the memory CLIPS holds, and a termination request
//! ([`Clips::set_terminate`]). Past one, the engine is halted (CLIPS's HaltExecution and
//! HaltRules) and the run returns a [`Stop`] naming the rule. Where it is checked: CLIPS's
//! periodic hook (each iteration of `while`, `loop-for-count`, `progn$`, a fact query, and
//! after each rule firing) and a wrapper around every deffunction and generic call look at
//! time and termination; the call wrapper counts depth and looks at the stack left; CLIPS's
//! `malloc` is renamed (build.rs) to a counting one that refuses past the budget, and CLIPS's
//! out-of-memory function then halts the engine, granting twice the budget while the
//! evaluation unwinds (a request past even that ends the process with the same message: CLIPS
//! cannot go on without the memory it asked for).

use std::time::Duration;

// The engine (FFI and [`Clips`]) is built only when build.rs found the system CLIPS.
#[cfg(clips)]
mod engine;
#[cfg(clips)]
pub use engine::Clips;

/// One argument of a `(robosim …)` call.
#[derive(Debug, Clone, PartialEq)]
pub enum Arg {
    Num(f64),
    Text(String),
}

/// What `(robosim COMMAND ARGS…)` does: the args (COMMAND first) → an integer for CLIPS, or
/// the failure's message.
pub type Handler = Box<dyn FnMut(&[Arg]) -> Result<i64, String>>;

/// Whether a termination was requested (SIGTERM/SIGINT): asked at most every
/// [`TERMINATE_POLL`] while rules run.
pub type Terminate = Box<dyn Fn() -> bool>;

/// How often a running rule base looks for a termination request (and flushes what the rules
/// printed).
pub const TERMINATE_POLL: Duration = Duration::from_millis(10);

#[derive(Debug, thiserror::Error)]
pub enum ClipsError {
    #[error("CLIPS could not create an environment")]
    NoEnvironment,
    #[error("CLIPS 6.30 as linked has no deffunction/generic call primitives to guard")]
    NoGuard,
    #[error("{what}: text with a NUL byte")]
    Nul { what: String },
    #[error("{path}: CLIPS could not {what} (see its messages above)")]
    Load { path: String, what: &'static str },
    #[error("CLIPS refused {what}: {text}")]
    Refused { what: &'static str, text: String },
    /// A rule file that is not a regular file, is larger than [`robosim_input::Limit::TEXT`],
    /// or cannot be read.
    #[error(transparent)]
    Input(#[from] robosim_input::InputError),
}

/// The bounds of one run of the rules ([`Clips::run`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Rule execution time per run (waiting for `(robosim …)` answers not counted).
    pub time: Duration,
    /// Nested deffunction and generic function calls.
    pub depth: u32,
    /// Bytes CLIPS may hold (facts, rules, strings, …); 0: no budget.
    pub memory: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            time: Duration::from_secs(5),
            depth: 2000,
            memory: 256 << 20,
        }
    }
}

/// The stack a call must leave free: below this, a deeper call is refused.
const STACK_RESERVE: usize = 256 << 10;

/// Why a run of the rules was halted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Stop {
    #[error(
        "{}: ran past the time limit of {limit:?} of rule execution in one pass; the rules were halted",
        rule_name(rule)
    )]
    Time {
        rule: Option<String>,
        limit: Duration,
    },
    #[error(
        "{}: {kind} {function} called {depth} deep, past the depth limit of {limit}; the rules were halted",
        rule_name(rule)
    )]
    Depth {
        rule: Option<String>,
        kind: String,
        function: String,
        depth: u32,
        limit: u32,
    },
    #[error(
        "{}: {kind} {function} called {depth} deep with {left} bytes of stack left (at least {STACK_RESERVE} kept); the rules were halted",
        rule_name(rule)
    )]
    Stack {
        rule: Option<String>,
        kind: String,
        function: String,
        depth: u32,
        left: usize,
    },
    #[error(
        "{}: CLIPS asked for {requested} bytes holding {in_use}, past the memory limit of {limit} bytes; the rules were halted",
        rule_name(rule)
    )]
    Memory {
        rule: Option<String>,
        requested: usize,
        in_use: usize,
        limit: usize,
    },
    #[error("a termination request (SIGTERM/SIGINT) halted {}", rule_name(rule))]
    Terminated { rule: Option<String> },
}

fn rule_name(rule: &Option<String>) -> String {
    match rule {
        Some(r) => format!("rule {r}"),
        None => "the rules (between firings)".into(),
    }
}

impl Stop {
    /// The rule that was firing, if one was.
    pub fn rule(&self) -> Option<&str> {
        match self {
            Stop::Time { rule, .. }
            | Stop::Depth { rule, .. }
            | Stop::Stack { rule, .. }
            | Stop::Memory { rule, .. }
            | Stop::Terminated { rule } => rule.as_deref(),
        }
    }
}

/// An argument of a `(robosim …)` call as text (a number in its shortest form); none → "".
pub fn arg_text(a: Option<&Arg>) -> String {
    match a {
        Some(Arg::Text(t)) => t.clone(),
        Some(Arg::Num(x)) => format!("{x}"),
        None => String::new(),
    }
}

/// `x` as a CLIPS float literal: always with a decimal point, since CLIPS reads `1` as an
/// integer and `1.0` as a float.
pub fn float_literal(x: f64) -> String {
    format!("{x:?}")
}

/// Quotes `s` as a CLIPS string literal.
pub fn quote(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        if c == '"' || c == '\\' {
            out.push('\\');
        }
        out.push(c);
    }
    out.push('"');
    out
}
