//! The CLIPS engine itself: the FFI to CLIPS 6.30 and `src/guard.c`, and [`Clips`] over them.
//! Compiled only when build.rs found the system CLIPS (`cfg(clips)`); the types around it
//! (limits, stops, errors) are in the parent module and exist either way.

use super::*;
use std::ffi::{CStr, CString, c_char, c_int, c_long, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::ptr::NonNull;
use std::time::Instant;

#[repr(C)]
struct DataObject {
    supplemental_info: *mut c_void,
    kind: u16,
    value: *mut c_void,
    begin: c_long,
    end: c_long,
    next: *mut DataObject,
}

const FLOAT: c_int = 0;
const INTEGER: c_int = 1;
const SYMBOL: c_int = 2;
const STRING: c_int = 3;
const INSTANCE_NAME: c_int = 8;

type EnterFn = extern "C" fn(*mut c_void, *const c_char, *const c_char, u32) -> c_int;

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
    fn EnvAddPeriodicFunction(
        env: *mut c_void,
        name: *const c_char,
        f: extern "C" fn(*mut c_void),
        priority: c_int,
    ) -> c_int;
    fn EnvSetOutOfMemoryFunction(
        env: *mut c_void,
        f: extern "C" fn(*mut c_void, usize) -> c_int,
    ) -> *mut c_void;
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
    // src/guard.c
    fn robosim_clips_set_budget(bytes: usize);
    fn robosim_clips_grace() -> c_int;
    fn robosim_clips_end_grace();
    fn robosim_clips_in_use() -> usize;
    fn robosim_clips_guard_calls(env: *mut c_void, enter: EnterFn) -> c_int;
    fn robosim_clips_executing_rule(env: *mut c_void) -> *const c_char;
    fn robosim_clips_arg(
        env: *mut c_void,
        i: c_int,
        num: *mut f64,
        text: *mut *const c_char,
    ) -> c_int;
    fn robosim_clips_halt(env: *mut c_void);
    fn robosim_clips_clear_halt(env: *mut c_void);
    fn robosim_clips_stack_left() -> usize;
}

/// What CLIPS holds a pointer to as the environment's context.
struct Ctx {
    handler: Handler,
    limits: Limits,
    terminate: Option<Terminate>,
    /// While a run is under way: when its rule time ends.
    deadline: Option<Instant>,
    /// When the termination predicate was last asked.
    polled: Instant,
    /// Why the engine was halted in this run.
    stop: Option<Stop>,
}

/// A CLIPS environment with the `robosim` function defined.
pub struct Clips {
    env: NonNull<c_void>,
    /// Owned here; CLIPS holds a raw pointer to it as the environment's context.
    ctx: *mut Ctx,
}

fn cstring(what: &str, s: &str) -> Result<CString, ClipsError> {
    CString::new(s).map_err(|_| ClipsError::Nul {
        what: what.to_owned(),
    })
}

/// The context of `env`, when it is one of ours and alive.
///
/// SAFETY (callers): `env` is an environment CLIPS is running now, made by [`Clips::new`],
/// whose context is a live `*mut Ctx` or null; no other `&mut Ctx` is in use (CLIPS runs one
/// callback at a time on its thread, and `Clips`'s methods do not hold one across a call into
/// CLIPS).
unsafe fn ctx<'a>(env: *mut c_void) -> Option<&'a mut Ctx> {
    // SAFETY: see the function's contract.
    unsafe { (GetEnvironmentContext(env) as *mut Ctx).as_mut() }
}

/// The name of the rule firing now in `env`.
///
/// SAFETY (callers): `env` is a live environment.
unsafe fn executing_rule(env: *mut c_void) -> Option<String> {
    // SAFETY: a live environment; the name lives in CLIPS's symbol table while the rule does.
    unsafe {
        let p = robosim_clips_executing_rule(env);
        (!p.is_null()).then(|| CStr::from_ptr(p).to_string_lossy().into_owned())
    }
}

/// Records `stop` (the first reason of a run wins) and halts `env`.
///
/// SAFETY (callers): `env` is a live environment.
unsafe fn halt(env: *mut c_void, c: &mut Ctx, stop: Stop) {
    if c.stop.is_none() {
        c.stop = Some(stop);
    }
    // SAFETY: a live environment.
    unsafe { robosim_clips_halt(env) }
}

/// The time and termination checks; `Some` when the run must stop.
///
/// SAFETY (callers): `env` is a live environment.
unsafe fn check(env: *mut c_void, c: &mut Ctx) -> Option<Stop> {
    let now = Instant::now();
    if c.deadline.is_some_and(|d| now > d) {
        return Some(Stop::Time {
            // SAFETY: a live environment.
            rule: unsafe { executing_rule(env) },
            limit: c.limits.time,
        });
    }
    if now.duration_since(c.polled) >= TERMINATE_POLL {
        c.polled = now;
        // What the rules printed shows while they run (a log read now has it). SAFETY:
        // fflush(NULL) flushes every output stream.
        unsafe { fflush(std::ptr::null_mut()) };
        if c.terminate.as_ref().is_some_and(|t| t()) {
            return Some(Stop::Terminated {
                // SAFETY: a live environment.
                rule: unsafe { executing_rule(env) },
            });
        }
    }
    None
}

/// CLIPS's periodic hook.
extern "C" fn periodic(env: *mut c_void) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: CLIPS calls this while running `env` (the `ctx` contract).
        unsafe {
            let Some(c) = ctx(env) else { return };
            if c.deadline.is_none() || c.stop.is_some() {
                return;
            }
            if let Some(stop) = check(env, c) {
                halt(env, c, stop);
            }
        }
    }));
}

/// Before each deffunction or generic function call (guard.c): 0 to go on.
extern "C" fn enter(
    env: *mut c_void,
    kind: *const c_char,
    name: *const c_char,
    depth: u32,
) -> c_int {
    catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: CLIPS calls this while running `env` (the `ctx` contract); `kind` and `name`
        // are NUL-terminated strings of guard.c and CLIPS's symbol table, or null.
        unsafe {
            let Some(c) = ctx(env) else { return 0 };
            if c.stop.is_some() {
                return 1;
            }
            let text = |p: *const c_char| {
                if p.is_null() {
                    String::new()
                } else {
                    CStr::from_ptr(p).to_string_lossy().into_owned()
                }
            };
            let left = robosim_clips_stack_left();
            let stop = if depth > c.limits.depth {
                Some(Stop::Depth {
                    rule: executing_rule(env),
                    kind: text(kind),
                    function: text(name),
                    depth,
                    limit: c.limits.depth,
                })
            } else if left < STACK_RESERVE {
                Some(Stop::Stack {
                    rule: executing_rule(env),
                    kind: text(kind),
                    function: text(name),
                    depth,
                    left,
                })
            } else {
                check(env, c)
            };
            match stop {
                Some(stop) => {
                    halt(env, c, stop);
                    1
                }
                None => 0,
            }
        }
    }))
    .unwrap_or(1)
}

/// CLIPS's out-of-memory function: a request past the budget (guard.c refused it).
extern "C" fn out_of_memory(env: *mut c_void, size: usize) -> c_int {
    // SAFETY: CLIPS calls this while running `env`; the guard's functions act on this thread.
    unsafe {
        let in_use = robosim_clips_in_use();
        let limit = ctx(env).map_or(0, |c| c.limits.memory);
        let stop = Stop::Memory {
            rule: executing_rule(env),
            requested: size,
            in_use,
            limit,
        };
        if robosim_clips_grace() == 1 {
            if let Some(c) = ctx(env) {
                halt(env, c, stop);
            } else {
                robosim_clips_halt(env);
            }
            // 0: CLIPS asks again, now under the grace.
            return 0;
        }
        // Past twice the budget while unwinding (or no budget and the system refused): CLIPS
        // has no way to go on without the memory (a null would crash it).
        eprintln!("rules: {stop}; past twice the limit while halting: the process ends");
        fflush(std::ptr::null_mut());
        std::process::exit(3)
    }
}

extern "C" fn robosim_call(env: *mut c_void) -> i64 {
    // A panic must not unwind into C: it becomes a failed call.
    catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: CLIPS calls this only while running the environment `env` that `Clips::new`
        // made and whose context it set to the live `*mut Ctx` it owns (cleared before the
        // environment is destroyed); arguments 1..=count exist for this call, and the strings
        // CLIPS returns live in its symbol table at least until the call returns.
        unsafe {
            let n = EnvRtnArgCount(env);
            let mut args = Vec::with_capacity(n.max(0) as usize);
            let mut failed = None;
            for i in 1..=n {
                let (mut x, mut t) = (0.0, std::ptr::null());
                let kind = robosim_clips_arg(env, i, &mut x, &mut t);
                let text = || {
                    if t.is_null() {
                        String::new()
                    } else {
                        CStr::from_ptr(t).to_string_lossy().into_owned()
                    }
                };
                args.push(match kind {
                    -1 => {
                        failed = Some(i);
                        break;
                    }
                    FLOAT | INTEGER => Arg::Num(x),
                    SYMBOL | STRING | INSTANCE_NAME => Arg::Text(text()),
                    other => Arg::Text(format!("<CLIPS type {other}>")),
                });
            }
            let command = match args.first() {
                Some(Arg::Text(c)) => c.clone(),
                _ => String::new(),
            };
            let Some(c) = ctx(env) else { return -1 };
            let result = match failed {
                Some(i) => Err(format!(
                    "argument {i} of (robosim {command} …) did not evaluate (CLIPS said why \
                     above); nothing was done"
                )),
                None => {
                    // Time answering the call is the session's, not the rules': the run's
                    // deadline moves by it.
                    let t0 = Instant::now();
                    let r = (c.handler)(&args);
                    if let Some(d) = &mut c.deadline {
                        *d += t0.elapsed();
                    }
                    r
                }
            };
            match result {
                Ok(v) => v,
                Err(message) => {
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
    /// A new environment whose `(robosim …)` calls go to `handler`, bounded by the default
    /// [`Limits`].
    pub fn new(handler: Handler) -> Result<Clips, ClipsError> {
        Clips::with_limits(handler, Limits::default())
    }

    /// A new environment whose `(robosim …)` calls go to `handler`, its runs bounded by
    /// `limits`. The memory budget is per thread: the newest environment's applies to every
    /// environment of its thread.
    pub fn with_limits(handler: Handler, limits: Limits) -> Result<Clips, ClipsError> {
        let ctx = Box::into_raw(Box::new(Ctx {
            handler,
            limits,
            terminate: None,
            deadline: None,
            polled: Instant::now(),
            stop: None,
        }));
        // SAFETY: plain constructor; a null result is handled.
        let env = NonNull::new(unsafe { CreateEnvironment() }).ok_or_else(|| {
            // SAFETY: `ctx` came from Box::into_raw just above and was not shared.
            drop(unsafe { Box::from_raw(ctx) });
            ClipsError::NoEnvironment
        })?;
        let clips = Clips { env, ctx };
        // CLIPS 6.30 keeps these two pointers as they are (extnfunc.c: `actualFunctionName`,
        // `restrictions`) and reads the restrictions on every call: they must live as long
        // as the environment, hence literals. A dropped CString here once made calls fail at
        // random with "[ARGACCES4] Function robosim expected no more than 0 argument(s)".
        let name: &'static CStr = c"robosim";
        let restrictions: &'static CStr = c"1*";
        let hook: &'static CStr = c"robosim-limits";
        // SAFETY: `env` is a live environment; the context pointer stays valid until Drop
        // clears it; the strings are 'static; the callbacks are `extern "C"` functions that
        // catch panics.
        let guarded = unsafe {
            SetEnvironmentContext(env.as_ptr(), ctx as *mut c_void);
            EnvDefineFunction2(
                env.as_ptr(),
                name.as_ptr(),
                b'g' as c_int,
                robosim_call,
                name.as_ptr(),
                restrictions.as_ptr(),
            );
            EnvAddPeriodicFunction(env.as_ptr(), hook.as_ptr(), periodic, 0);
            EnvSetOutOfMemoryFunction(env.as_ptr(), out_of_memory);
            robosim_clips_set_budget(limits.memory);
            robosim_clips_guard_calls(env.as_ptr(), enter)
        };
        if guarded != 1 {
            return Err(ClipsError::NoGuard);
        }
        Ok(clips)
    }

    /// Asked (at most every [`TERMINATE_POLL`]) while the rules run: `true` halts them with
    /// [`Stop::Terminated`].
    pub fn set_terminate(&mut self, terminate: Terminate) {
        // SAFETY: `ctx` is live while `self` is, and no callback runs now (CLIPS is not
        // running: `&mut self`).
        unsafe { (*self.ctx).terminate = Some(terminate) }
    }

    /// Loads a rule file (constructs only), then resets (deffacts asserted). The file is first
    /// read by [`robosim_input::read_file`]: CLIPS's own open of a FIFO would block and its
    /// reader would take `/dev/zero` until memory runs out.
    pub fn load(&mut self, path: &std::path::Path) -> Result<(), ClipsError> {
        robosim_input::read_file(path, "a rule file", robosim_input::Limit::TEXT)?;
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

    /// Runs the agenda to quiescence (or `limit` firings; negative: no limit) within the
    /// [`Limits`]: the rules fired, or why the engine was halted.
    pub fn run(&mut self, limit: i64) -> Result<i64, Stop> {
        // SAFETY: `ctx` is live while `self` is; no callback runs outside EnvRun below.
        unsafe {
            let c = &mut *self.ctx;
            c.stop = None;
            c.deadline = Some(Instant::now() + c.limits.time);
            robosim_clips_set_budget(c.limits.memory);
        }
        // SAFETY: live environment; callbacks reach the context (no `&mut Ctx` is held here).
        let fired = unsafe { EnvRun(self.env.as_ptr(), limit) };
        // What the rules printed shows now, not when a buffer fills (a log read while the
        // process runs, or after it is killed, has it). SAFETY: fflush(NULL) flushes every
        // output stream.
        unsafe { fflush(std::ptr::null_mut()) };
        // SAFETY: as above; CLIPS is not running.
        let stop = unsafe {
            let c = &mut *self.ctx;
            c.deadline = None;
            robosim_clips_end_grace();
            c.stop.take()
        };
        match stop {
            Some(stop) => {
                // SAFETY: live environment, not running.
                unsafe { robosim_clips_clear_halt(self.env.as_ptr()) };
                Err(stop)
            }
            None => Ok(fired),
        }
    }
}

impl Drop for Clips {
    fn drop(&mut self) {
        // SAFETY: the environment is live until here; the context is cleared before it goes,
        // and freed after, so no callback can see a dangling pointer.
        unsafe {
            SetEnvironmentContext(self.env.as_ptr(), std::ptr::null_mut());
            // Destroying frees everything: no budget may refuse that.
            robosim_clips_set_budget(0);
            DestroyEnvironment(self.env.as_ptr());
            drop(Box::from_raw(self.ctx));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::{Cell, RefCell};
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

    /// A recorder of the handler's calls.
    fn recording() -> (Rc<RefCell<Vec<Vec<Arg>>>>, Handler) {
        let seen: Rc<RefCell<Vec<Vec<Arg>>>> = Rc::default();
        let s2 = seen.clone();
        (
            seen,
            Box::new(move |args: &[Arg]| {
                s2.borrow_mut().push(args.to_vec());
                Ok(7)
            }),
        )
    }

    fn engine(limits: Limits, rules: &[&str]) -> (Rc<RefCell<Vec<Vec<Arg>>>>, Clips) {
        let (seen, handler) = recording();
        let mut clips = Clips::with_limits(handler, limits).expect("environment");
        for r in rules {
            clips.build(r).expect("construct");
        }
        clips.reset();
        (seen, clips)
    }

    /// Issue 34 item 5: `(robosim set-joint positioner 3 (/ 0.0 0.0))` made CLIPS say "divide
    /// by zero" and halt, and the call still went through with a made-up value (a write).
    /// Each argument is evaluated once, and a failed one fails the call before the handler.
    #[test]
    fn a_failed_clips_expression_does_not_reach_the_handler() {
        let (seen, mut clips) = engine(
            Limits::default(),
            &["(defrule bad => (robosim set-joint positioner 3 (/ 0.0 0.0)))"],
        );
        assert_eq!(clips.run(-1), Ok(1), "CLIPS's own halt is not a limit");
        assert_eq!(
            *seen.borrow(),
            Vec::<Vec<Arg>>::new(),
            "the failed call reached the handler"
        );
        // A good call: its argument is evaluated once (it was evaluated again to be read as a
        // number: twice per call), and the engine runs normally after the failed one.
        let (seen, mut clips) = engine(
            Limits::default(),
            &[
                "(defglobal ?*n* = 0)",
                "(defrule once => (robosim set-joint positioner 1 (bind ?*n* (+ ?*n* 1))) (robosim count ?*n*))",
            ],
        );
        assert_eq!(clips.run(-1), Ok(1));
        let calls = seen.borrow().clone();
        assert_eq!(
            calls,
            vec![
                vec![
                    Arg::Text("set-joint".into()),
                    Arg::Text("positioner".into()),
                    Arg::Num(1.0),
                    Arg::Num(1.0)
                ],
                vec![Arg::Text("count".into()), Arg::Num(1.0)],
            ]
        );
    }

    /// Issue 34 item 16: an endless right-hand side hung the process for good.
    #[test]
    fn an_endless_right_hand_side_stops_on_the_time_limit_naming_the_rule() {
        let limits = Limits {
            time: Duration::from_millis(300),
            ..Limits::default()
        };
        let (_, mut clips) = engine(limits, &["(defrule spin => (while TRUE do (+ 1 1)))"]);
        let stop = clips.run(-1).expect_err("the time limit halts the rule");
        assert!(
            matches!(&stop, Stop::Time { rule: Some(r), .. } if r == "spin"),
            "{stop:?}"
        );
        assert!(stop.to_string().contains("rule spin"), "{stop}");
        // The engine is usable after the halt.
        clips
            .build("(defrule fine => (robosim ok))")
            .expect("construct");
        assert_eq!(clips.run(-1), Ok(1));
    }

    /// Issue 34 item 16: rules firing each other forever are stopped by the same limit.
    #[test]
    fn rules_firing_forever_stop_on_the_time_limit() {
        let limits = Limits {
            time: Duration::from_millis(300),
            ..Limits::default()
        };
        let (_, mut clips) = engine(
            limits,
            &[
                "(deftemplate tick (slot n))",
                "(deffacts start (tick (n 0)))",
                "(defrule again ?f <- (tick (n ?n)) => (modify ?f (n (+ ?n 1))))",
            ],
        );
        clips.reset();
        let stop = clips.run(-1).expect_err("the time limit halts the rules");
        assert!(matches!(stop, Stop::Time { .. }), "{stop:?}");
    }

    /// Issue 34 item 16: a deffunction calling itself overflowed the stack (the process died).
    #[test]
    fn deep_recursion_is_an_error_not_a_crash() {
        let (_, mut clips) = engine(
            Limits::default(),
            &[
                "(deffunction down (?n) (+ 1 (down (+ ?n 1))))",
                "(defrule dive => (down 0))",
            ],
        );
        let stop = clips.run(-1).expect_err("the depth guard halts the rule");
        match &stop {
            Stop::Depth {
                rule,
                function,
                depth,
                ..
            }
            | Stop::Stack {
                rule,
                function,
                depth,
                ..
            } => {
                assert_eq!(rule.as_deref(), Some("dive"));
                assert_eq!(function, "down");
                assert!(*depth > 10, "{stop}");
            }
            other => panic!("not a depth error: {other:?}"),
        }
        // A generic function recursing is held by the same guard.
        let (_, mut clips) = engine(
            Limits {
                depth: 100,
                ..Limits::default()
            },
            &[
                "(defgeneric g)",
                "(defmethod g ((?n INTEGER)) (g (+ ?n 1)))",
                "(defrule gen => (g 0))",
            ],
        );
        let stop = clips.run(-1).expect_err("the depth guard halts the rule");
        assert!(
            matches!(&stop, Stop::Depth { function, depth: 101, limit: 100, .. } if function == "g"),
            "{stop:?}"
        );
    }

    /// Issue 34 item 16: a string doubled 40 times (str-cat) segfaulted the process.
    #[test]
    fn a_string_doubled_forty_times_is_a_memory_limit_error_not_a_segfault() {
        let limits = Limits {
            memory: 32 << 20,
            ..Limits::default()
        };
        let (_, mut clips) = engine(
            limits,
            &["(defrule grow => (bind ?s \"ab\") (loop-for-count 40 (bind ?s (str-cat ?s ?s))))"],
        );
        let stop = clips.run(-1).expect_err("the memory budget halts the rule");
        assert!(
            matches!(&stop, Stop::Memory { rule: Some(r), limit, .. } if r == "grow" && *limit == 32 << 20),
            "{stop:?}"
        );
        // The same without a loop: 40 actions on the right-hand side.
        let rhs = "(bind ?s (str-cat ?s ?s)) ".repeat(40);
        let (_, mut clips) = engine(
            limits,
            &[&format!("(defrule grow2 => (bind ?s \"ab\") {rhs})")],
        );
        let stop = clips.run(-1).expect_err("the memory budget halts the rule");
        assert!(
            matches!(&stop, Stop::Memory { rule: Some(r), .. } if r == "grow2"),
            "{stop:?}"
        );
    }

    /// Issue 34 item 16: a termination request halts a rule that would run forever.
    #[test]
    fn a_termination_request_halts_a_running_rule() {
        let limits = Limits {
            time: Duration::from_secs(3600),
            ..Limits::default()
        };
        let (_, mut clips) = engine(limits, &["(defrule spin => (while TRUE do (+ 1 1)))"]);
        let asked = Rc::new(Cell::new(0u32));
        let a2 = asked.clone();
        // The request comes once the rule has been running for a few polls.
        clips.set_terminate(Box::new(move || {
            a2.set(a2.get() + 1);
            a2.get() > 3
        }));
        let stop = clips.run(-1).expect_err("the request halts the rule");
        assert_eq!(
            stop,
            Stop::Terminated {
                rule: Some("spin".into())
            }
        );
        assert!(asked.get() > 3);
    }
}
