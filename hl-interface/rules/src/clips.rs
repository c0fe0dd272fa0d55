//! The real CLIPS 6.30 engine (Debian's `libclips-dev`, linked statically) behind a safe
//! wrapper: the only module of the crate with `unsafe`.
//!
//! One [`Clips`] is one CLIPS environment. Rules call back into Rust through one external
//! function, `(robosim COMMAND ARGS…)`, answered by the [`Handler`] the engine was made with;
//! it returns an integer to CLIPS (a version, 0, or -1 on failure — the failure's message is
//! asserted as `(robosim-error (command C) (message M))`).

use std::ffi::{CStr, CString, c_char, c_int, c_long, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::ptr::NonNull;

/// One argument of a `(robosim …)` call.
#[derive(Debug, Clone, PartialEq)]
pub enum Arg {
    Num(f64),
    Text(String),
}

/// What `(robosim COMMAND ARGS…)` does: the args (COMMAND first) → an integer for CLIPS, or
/// the failure's message.
pub type Handler = Box<dyn FnMut(&[Arg]) -> Result<i64, String>>;

#[derive(Debug, thiserror::Error)]
pub enum ClipsError {
    #[error("CLIPS could not create an environment")]
    NoEnvironment,
    #[error("{what}: text with a NUL byte")]
    Nul { what: String },
    #[error("{path}: CLIPS could not {what} (see its messages above)")]
    Load { path: String, what: &'static str },
    #[error("CLIPS refused {what}: {text}")]
    Refused { what: &'static str, text: String },
}

#[repr(C)]
struct DataObject {
    supplemental_info: *mut c_void,
    kind: u16,
    value: *mut c_void,
    begin: c_long,
    end: c_long,
    next: *mut DataObject,
}

const FLOAT: u16 = 0;
const INTEGER: u16 = 1;
const SYMBOL: u16 = 2;
const STRING: u16 = 3;

unsafe extern "C" {
    fn CreateEnvironment() -> *mut c_void;
    fn DestroyEnvironment(env: *mut c_void) -> c_int;
    fn SetEnvironmentContext(env: *mut c_void, ctx: *mut c_void) -> *mut c_void;
    fn GetEnvironmentContext(env: *mut c_void) -> *mut c_void;
    fn EnvLoad(env: *mut c_void, path: *const c_char) -> c_int;
    fn EnvReset(env: *mut c_void);
    fn EnvRun(env: *mut c_void, limit: i64) -> i64;
    fn EnvBuild(env: *mut c_void, text: *const c_char) -> c_int;
    fn EnvEval(env: *mut c_void, text: *const c_char, out: *mut DataObject) -> c_int;
    fn EnvAssertString(env: *mut c_void, text: *const c_char) -> *mut c_void;
    fn EnvRtnArgCount(env: *mut c_void) -> c_int;
    fn EnvRtnUnknown(env: *mut c_void, i: c_int, out: *mut DataObject) -> *mut DataObject;
    fn EnvRtnLexeme(env: *mut c_void, i: c_int) -> *const c_char;
    fn EnvRtnDouble(env: *mut c_void, i: c_int) -> f64;
    /// C stdio's: CLIPS's `printout t` goes to a buffered `stdout`.
    fn fflush(stream: *mut c_void) -> c_int;
    fn EnvDefineFunction2(
        env: *mut c_void,
        name: *const c_char,
        return_type: c_int,
        f: extern "C" fn(*mut c_void) -> i64,
        actual: *const c_char,
        restrictions: *const c_char,
    ) -> c_int;
}

/// A CLIPS environment with the `robosim` function defined.
pub struct Clips {
    env: NonNull<c_void>,
    /// Owned here; CLIPS holds a raw pointer to it as the environment's context.
    handler: *mut Handler,
}

fn cstring(what: &str, s: &str) -> Result<CString, ClipsError> {
    CString::new(s).map_err(|_| ClipsError::Nul {
        what: what.to_owned(),
    })
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

extern "C" fn robosim_call(env: *mut c_void) -> i64 {
    // A panic must not unwind into C: it becomes a failed call.
    catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: CLIPS calls this only while running the environment `env` that `Clips::new`
        // made and whose context it set to the live `*mut Handler` it owns (cleared before
        // the environment is destroyed); arguments 1..=count exist for this call, and the
        // strings CLIPS returns live in its symbol table at least until the call returns.
        unsafe {
            let handler = GetEnvironmentContext(env) as *mut Handler;
            if handler.is_null() {
                return -1;
            }
            let n = EnvRtnArgCount(env);
            let mut args = Vec::with_capacity(n.max(0) as usize);
            for i in 1..=n {
                let mut d = DataObject {
                    supplemental_info: std::ptr::null_mut(),
                    kind: 0,
                    value: std::ptr::null_mut(),
                    begin: 0,
                    end: 0,
                    next: std::ptr::null_mut(),
                };
                EnvRtnUnknown(env, i, &mut d);
                args.push(match d.kind {
                    FLOAT | INTEGER => Arg::Num(EnvRtnDouble(env, i)),
                    SYMBOL | STRING => {
                        let p = EnvRtnLexeme(env, i);
                        if p.is_null() {
                            Arg::Text(String::new())
                        } else {
                            Arg::Text(CStr::from_ptr(p).to_string_lossy().into_owned())
                        }
                    }
                    other => Arg::Text(format!("<CLIPS type {other}>")),
                });
            }
            match (*handler)(&args) {
                Ok(v) => v,
                Err(message) => {
                    let command = match args.first() {
                        Some(Arg::Text(c)) => c.clone(),
                        _ => String::new(),
                    };
                    eprintln!("rules: (robosim {command} …) failed: {message}");
                    let fact = format!(
                        "(robosim-error (command {}) (message {}))",
                        quote(&command),
                        quote(&message)
                    );
                    if let Ok(c) = CString::new(fact) {
                        EnvAssertString(env, c.as_ptr());
                    }
                    -1
                }
            }
        }
    }))
    .unwrap_or(-1)
}

impl Clips {
    /// A new environment whose `(robosim …)` calls go to `handler`, with the bridge's own
    /// templates ([`crate::TEMPLATES`]) built.
    pub fn new(handler: Handler) -> Result<Clips, ClipsError> {
        let handler = Box::into_raw(Box::new(handler));
        // SAFETY: plain constructor; a null result is handled.
        let env = NonNull::new(unsafe { CreateEnvironment() }).ok_or_else(|| {
            // SAFETY: `handler` came from Box::into_raw just above and was not shared.
            drop(unsafe { Box::from_raw(handler) });
            ClipsError::NoEnvironment
        })?;
        let clips = Clips { env, handler };
        // CLIPS 6.30 keeps these two pointers as they are (extnfunc.c: `actualFunctionName`,
        // `restrictions`) and reads the restrictions on every call: they must live as long
        // as the environment, hence literals. A dropped CString here once made calls fail at
        // random with "[ARGACCES4] Function robosim expected no more than 0 argument(s)".
        let name: &'static CStr = c"robosim";
        let restrictions: &'static CStr = c"1*";
        // SAFETY: `env` is a live environment; the context pointer stays valid until Drop
        // clears it; the strings are 'static.
        unsafe {
            SetEnvironmentContext(env.as_ptr(), handler as *mut c_void);
            EnvDefineFunction2(
                env.as_ptr(),
                name.as_ptr(),
                b'g' as c_int,
                robosim_call,
                name.as_ptr(),
                restrictions.as_ptr(),
            );
        }
        Ok(clips)
    }

    /// Loads a rule file (constructs only), then resets (deffacts asserted).
    pub fn load(&mut self, path: &std::path::Path) -> Result<(), ClipsError> {
        let shown = path.display().to_string();
        let p = cstring(&shown, &shown)?;
        // SAFETY: live environment, NUL-terminated path.
        let rc = unsafe { EnvLoad(self.env.as_ptr(), p.as_ptr()) };
        if rc != 1 {
            return Err(ClipsError::Load {
                path: shown,
                what: if rc == 0 { "open it" } else { "parse it" },
            });
        }
        self.reset();
        Ok(())
    }

    /// (reset): working memory back to the deffacts.
    pub fn reset(&mut self) {
        // SAFETY: live environment.
        unsafe { EnvReset(self.env.as_ptr()) }
    }

    /// Defines one construct (deftemplate, defrule, …).
    pub fn build(&mut self, construct: &str) -> Result<(), ClipsError> {
        let c = cstring("construct", construct)?;
        // SAFETY: live environment, NUL-terminated text.
        if unsafe { EnvBuild(self.env.as_ptr(), c.as_ptr()) } != 1 {
            return Err(ClipsError::Refused {
                what: "the construct",
                text: construct.to_owned(),
            });
        }
        Ok(())
    }

    /// Evaluates one expression for its effect (e.g. a retraction query).
    pub fn eval(&mut self, expr: &str) -> Result<(), ClipsError> {
        let c = cstring("expression", expr)?;
        let mut out = DataObject {
            supplemental_info: std::ptr::null_mut(),
            kind: 0,
            value: std::ptr::null_mut(),
            begin: 0,
            end: 0,
            next: std::ptr::null_mut(),
        };
        // SAFETY: live environment, NUL-terminated text, `out` a writable DATA_OBJECT.
        if unsafe { EnvEval(self.env.as_ptr(), c.as_ptr(), &mut out) } != 1 {
            return Err(ClipsError::Refused {
                what: "the expression",
                text: expr.to_owned(),
            });
        }
        Ok(())
    }

    /// Asserts one fact given as text, e.g. `(joint (robot r) (index 0) (q 0.5))`.
    pub fn assert_str(&mut self, fact: &str) -> Result<(), ClipsError> {
        let c = cstring("fact", fact)?;
        // SAFETY: live environment, NUL-terminated text; the returned fact pointer is not kept.
        if unsafe { EnvAssertString(self.env.as_ptr(), c.as_ptr()) }.is_null() {
            return Err(ClipsError::Refused {
                what: "the fact",
                text: fact.to_owned(),
            });
        }
        Ok(())
    }

    /// Runs the agenda to quiescence (or `limit` firings; negative: no limit); rules fired.
    pub fn run(&mut self, limit: i64) -> i64 {
        // SAFETY: live environment; callbacks reach the handler through the context.
        let fired = unsafe { EnvRun(self.env.as_ptr(), limit) };
        // What the rules printed shows now, not when a buffer fills (a log read while the
        // process runs, or after it is killed, has it). SAFETY: fflush(NULL) flushes every
        // output stream.
        unsafe { fflush(std::ptr::null_mut()) };
        fired
    }
}

impl Drop for Clips {
    fn drop(&mut self) {
        // SAFETY: the environment is live until here; the context is cleared before it goes,
        // and the handler is freed after, so no callback can see a dangling pointer.
        unsafe {
            SetEnvironmentContext(self.env.as_ptr(), std::ptr::null_mut());
            DestroyEnvironment(self.env.as_ptr());
            drop(Box::from_raw(self.handler));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::RefCell;
    use std::rc::Rc;

    /// The `robosim` function keeps its "at least one argument" restriction however the heap
    /// is reused after the environment was made (CLIPS reads the restriction string on every
    /// call and does not copy it).
    #[test]
    fn robosim_calls_take_any_number_of_arguments_after_the_heap_is_reused() {
        let seen: Rc<RefCell<Vec<usize>>> = Rc::default();
        let s2 = seen.clone();
        let mut clips = Clips::new(Box::new(move |args: &[Arg]| {
            s2.borrow_mut().push(args.len());
            Ok(0)
        }))
        .expect("environment");
        // Small blocks full of '0' take the place of anything small freed since: a restriction
        // read from freed memory would say "no arguments".
        let filler: Vec<CString> = (0..20_000)
            .map(|k| CString::new(vec![b'0'; 2 + k % 14]).expect("no NUL"))
            .collect();
        for n in 1..=4 {
            let args: Vec<String> = (0..n).map(|k| format!("a{k}")).collect();
            clips
                .eval(&format!("(robosim {})", args.join(" ")))
                .expect("the call evaluates");
        }
        assert_eq!(*seen.borrow(), vec![1, 2, 3, 4]);
        // At least one argument (the command) is required.
        let _ = clips.eval("(robosim)");
        assert_eq!(
            seen.borrow().len(),
            4,
            "a call without a command is refused by CLIPS"
        );
        drop(filler);
    }
}
