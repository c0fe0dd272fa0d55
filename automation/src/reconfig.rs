//! The reconfigurable controller of the seed's pictures 6–7 (§3.4), on the dataflow kernel.
//!
//! A one-link arm (a point mass `m` at the end of a massless rod of length `l`, hinged at a
//! horizontal axis, viscous damping `b`, gravity `g`; `q` measured from the downward vertical):
//!
//! ```text
//!   m l² q̈ = τ − m g l sin q − b q̇
//! ```
//!
//! integrated with semi-implicit Euler at step `dt` (velocity first, then position with the new
//! velocity), is held at a set-point `q_ref` by a proportional controller `τ = Kp e`,
//! `e = q_ref − q`. Against gravity a P controller leaves a steady-state error
//! `e ≈ m g l sin q / Kp`. A **Checker** actor watches the tracking error, in lockstep with the
//! loop (the arm steps only after the Checker has judged the previous sample, so a supervisor
//! starved of CPU cannot fall behind a simulation that runs as fast as it can); when the RMS
//! error over a window exceeds a threshold after a settling time, it rewires the *running*
//! graph: it adds a PID actor, moves the error stream's reader from P to PID (no error sample
//! is lost or read twice), connects PID to the torque node and removes P — while the arm keeps
//! being simulated.
//!
//! ```text
//!   torque ──► [arm] ──► state ──► [error] ──► error ──► [P]  ──► torque   (before)
//!      ▲                                          └────► [Checker] ──► checked ──┐
//!      └───────────────────────── (the arm waits for the Checker) ──────────────┘
//!                                               error ──► [PID] ──► torque  (after)
//! ```
//!
//! Entry point: [`run_reconfig_demo`] → [`ReconfigOutcome`] (errors before and after).

use crate::kernel::{ActorSpec, DataId, Graph, KernelError, Retention, TraceRecord, Value};
use std::sync::{Arc, Mutex};

/// Parameters of the demo (SI units: kg, m, s, rad, N·m).
#[derive(Debug, Clone, Copy)]
pub struct ReconfigOptions {
    pub mass: f64,
    pub length: f64,
    pub damping: f64,
    pub gravity: f64,
    /// Integration step, s.
    pub dt: f64,
    /// Simulated time, s.
    pub duration: f64,
    /// Set-point, rad from the downward vertical.
    pub setpoint: f64,
    /// Proportional gain of the initial controller, N·m/rad.
    pub kp: f64,
    /// PID gains (N·m/rad, N·m/(rad·s), N·m·s/rad).
    pub pid: (f64, f64, f64),
    /// RMS tracking error above which the Checker reconfigures, rad.
    pub threshold: f64,
    /// Length of the Checker's RMS window, s.
    pub window: f64,
    /// Time before the Checker judges, s.
    pub settle: f64,
    /// Whether the Checker may reconfigure (false: P all along, for comparison).
    pub allow_switch: bool,
    /// Worker threads of the kernel.
    pub workers: usize,
}

impl Default for ReconfigOptions {
    fn default() -> Self {
        ReconfigOptions {
            mass: 1.0,
            length: 0.5,
            damping: 0.1,
            gravity: 9.81,
            dt: 1e-3,
            duration: 6.0,
            setpoint: 1.0,
            kp: 20.0,
            pid: (20.0, 40.0, 2.0),
            threshold: 0.05,
            window: 0.5,
            settle: 1.5,
            allow_switch: true,
            workers: 2,
        }
    }
}

/// What happened.
#[derive(Debug, Clone)]
pub struct ReconfigOutcome {
    /// Simulated time at which the Checker switched to PID (None: it never did).
    pub switched_at: Option<f64>,
    /// RMS tracking error over the window that made the Checker switch (or over the window
    /// ending at `settle + window` when it did not), rad.
    pub rms_error_before: f64,
    /// RMS tracking error over the last window of the run, rad.
    pub rms_error_after: f64,
    /// Tracking error at the end, rad.
    pub final_error: f64,
    /// Integration steps simulated.
    pub steps: usize,
    /// Firings recorded by the tracer.
    pub firings: usize,
    /// Firings per actor, from the tracer, in order of first firing.
    pub firings_by_actor: Vec<(String, usize)>,
    /// The tracking error `(t, e)` at every step, s and rad (`q = setpoint − e`).
    pub tracking: Vec<(f64, f64)>,
    /// DOT of the graph before the run and after it.
    pub dot_before: String,
    pub dot_after: String,
}

impl ReconfigOutcome {
    /// A few lines for a command line: the switch and the errors before and after.
    pub fn summary(&self) -> String {
        let switch = match self.switched_at {
            Some(t) => format!("Checker switched P -> PID at t = {t:.3} s"),
            None => "Checker kept the P controller".to_string(),
        };
        format!(
            "{switch}\nRMS tracking error before: {:.4} rad\nRMS tracking error at the end (last window): {:.4} rad\nfinal error: {:.5} rad; {} steps, {} firings traced ({})\n",
            self.rms_error_before,
            self.rms_error_after,
            self.final_error,
            self.steps,
            self.firings,
            self.firings_by_actor
                .iter()
                .map(|(n, k)| format!("{n} {k}"))
                .collect::<Vec<_>>()
                .join(", ")
        )
    }
}

struct Arm {
    q: f64,
    qd: f64,
    t: f64,
    steps: usize,
    max_steps: usize,
}

#[derive(Default)]
struct Log {
    errors: Vec<(f64, f64)>,
    switched_at: Option<f64>,
    checker_window: Option<f64>,
}

/// A (time, value) pair from a `Value::Vec` of at least two numbers.
fn pair(v: &Value) -> Option<(f64, f64)> {
    match v.as_vec()? {
        [t, x, ..] => Some((*t, *x)),
        _ => None,
    }
}

fn rms(samples: &[(f64, f64)], from: f64, to: f64) -> f64 {
    let v: Vec<f64> = samples
        .iter()
        .filter(|(t, _)| *t > from && *t <= to)
        .map(|(_, e)| e * e)
        .collect();
    if v.is_empty() {
        f64::NAN
    } else {
        (v.iter().sum::<f64>() / v.len() as f64).sqrt()
    }
}

fn pid_actor(name: &str, (kp, ki, kd): (f64, f64, f64), dt: f64) -> ActorSpec {
    // Context: (integral, previous error).
    ActorSpec::new(name, move |ctx: &mut crate::kernel::Ctx<'_>| {
        let e = ctx
            .input("e")
            .and_then(pair)
            .map(|p| p.1)
            .ok_or("PID: no error sample")?;
        let (integral, prev) = ctx.context::<(f64, Option<f64>)>().ok_or("PID: context")?;
        *integral += e * dt;
        let de = prev.map_or(0.0, |p| (e - p) / dt);
        *prev = Some(e);
        let u = kp * e + ki * *integral + kd * de;
        ctx.emit("u", Value::F64(u))
    })
    .inputs(&["e"])
    .outputs(&["u"])
    .context((0.0f64, None::<f64>))
}

/// Why the reconfiguration demo did not run to its end.
#[derive(Debug, thiserror::Error)]
pub enum ReconfigError {
    /// A non-positive step, duration, window, mass or length (the options as given).
    #[error("invalid reconfiguration demo options: {0}")]
    InvalidOptions(String),
    /// The kernel refused building or feeding the graph.
    #[error(transparent)]
    Kernel(#[from] KernelError),
    /// A script of the demo's graph failed while it ran (the script's message, text by the
    /// kernel's `Script` contract).
    #[error("script error during the demo: {0}")]
    Script(String),
    /// A script panicked while holding the demo's log.
    #[error("demo log poisoned")]
    LogPoisoned,
}

/// The arm: one integration step of the pendulum per torque sample, once the Checker has
/// acknowledged the previous state.
fn arm_actor(o: ReconfigOptions) -> ActorSpec {
    let inertia = o.mass * o.length * o.length;
    ActorSpec::new("arm", move |ctx: &mut crate::kernel::Ctx<'_>| {
        let tau = ctx.input_f64("tau").ok_or("arm: no torque")?;
        ctx.input("ok").ok_or("arm: no Checker acknowledgement")?;
        let s = ctx.context::<Arm>().ok_or("arm: context")?;
        if s.steps >= s.max_steps {
            return Ok(()); // the run is over: no new state, the loop drains
        }
        let qdd = (tau - o.mass * o.gravity * o.length * s.q.sin() - o.damping * s.qd) / inertia;
        s.qd += qdd * o.dt;
        s.q += s.qd * o.dt;
        s.t += o.dt;
        s.steps += 1;
        let out = Value::Vec(vec![s.t, s.q, s.qd]);
        ctx.emit("state", out)
    })
    .inputs(&["tau", "ok"])
    .outputs(&["state"])
    .context(Arm {
        q: 0.0,
        qd: 0.0,
        t: 0.0,
        steps: 0,
        max_steps: (o.duration / o.dt).round() as usize,
    })
}

/// The tracking error `[t, setpoint − q]` of each state, logged.
fn error_actor(o: ReconfigOptions, log: Arc<Mutex<Log>>) -> ActorSpec {
    ActorSpec::new("error", move |ctx: &mut crate::kernel::Ctx<'_>| {
        let (t, q) = ctx
            .input("x")
            .and_then(pair)
            .ok_or("error: no state [t, q, qd]")?;
        let e = o.setpoint - q;
        if let Ok(mut l) = log.lock() {
            l.errors.push((t, e));
        }
        ctx.emit("e", Value::Vec(vec![t, e]))
    })
    .inputs(&["x"])
    .outputs(&["e"])
}

/// The P controller the run starts with.
fn p_actor(o: ReconfigOptions) -> ActorSpec {
    ActorSpec::new("P", move |ctx: &mut crate::kernel::Ctx<'_>| {
        let e = ctx
            .input("e")
            .and_then(pair)
            .map(|p| p.1)
            .ok_or("P: no error sample")?;
        ctx.emit("u", Value::F64(o.kp * e))
    })
    .inputs(&["e"])
    .outputs(&["u"])
}

/// The Checker: judges the RMS error over the last window and, once it is unacceptable,
/// replaces P by PID in the running graph; acknowledges every sample.
fn checker_actor(o: ReconfigOptions, log: Arc<Mutex<Log>>) -> ActorSpec {
    ActorSpec::new("Checker", move |ctx: &mut crate::kernel::Ctx<'_>| {
        let s = ctx
            .input("e")
            .and_then(pair)
            .ok_or("Checker: no error sample")?;
        let (window, switched) = ctx
            .context::<(Vec<(f64, f64)>, bool)>()
            .ok_or("Checker: context")?;
        window.push(s);
        window.retain(|(t, _)| *t > s.0 - o.window);
        let r = rms(window, s.0 - o.window, s.0);
        if o.allow_switch && !*switched && s.0 >= o.settle && r > o.threshold {
            *switched = true;
            // Unacceptable: reconfigure the running graph to PID.
            ctx.control()
                .edit(|e| -> Result<(), KernelError> {
                    let Some(p) = e.actor("P") else { return Ok(()) };
                    let Some(torque) = e.data("torque") else {
                        return Ok(());
                    };
                    let pid = e.add_actor(pid_actor("PID", o.pid, o.dt))?;
                    e.connect_out(pid, "u", torque)?;
                    e.move_input(p, "e", pid, "e")?;
                    e.remove_actor(p)
                })
                .map_err(|e| format!("switching to PID: {e}"))?;
            if let Ok(mut l) = log.lock() {
                l.switched_at = Some(s.0);
                l.checker_window = Some(r);
            }
        }
        ctx.emit("ok", Value::Unit)
    })
    .inputs(&["e"])
    .outputs(&["ok"])
    .context((Vec::<(f64, f64)>::new(), false))
}

/// Builds the loop arm → error → P → arm with the Checker beside P; returns the torque and
/// the acknowledgement data, which the run is started by writing.
fn build_loop(
    graph: &Graph,
    o: ReconfigOptions,
    log: &Arc<Mutex<Log>>,
) -> Result<(DataId, DataId), KernelError> {
    graph.edit(|e| -> Result<_, KernelError> {
        let torque = e.add_data("torque", Retention::Stream)?;
        let state = e.add_data("state", Retention::Stream)?;
        let error = e.add_data("error", Retention::Stream)?;
        // The Checker runs in lockstep with the loop: the arm steps only once the Checker
        // has judged the previous sample. A free-running supervisor could fall thousands of
        // steps behind a simulation that runs as fast as it can, and switch far too late.
        let ack = e.add_data("checked", Retention::Stream)?;
        let arm = e.add_actor(arm_actor(o))?;
        let err = e.add_actor(error_actor(o, log.clone()))?;
        let p = e.add_actor(p_actor(o))?;
        let checker = e.add_actor(checker_actor(o, log.clone()))?;
        e.connect_in(torque, arm, "tau")?;
        e.connect_out(arm, "state", state)?;
        e.connect_in(state, err, "x")?;
        e.connect_out(err, "e", error)?;
        e.connect_in(error, p, "e")?;
        e.connect_in(error, checker, "e")?;
        e.connect_out(checker, "ok", ack)?;
        e.connect_in(ack, arm, "ok")?;
        e.connect_out(p, "u", torque)?;
        Ok((torque, ack))
    })
}

/// Firings per actor, in order of first firing.
fn firings_by_actor(trace: &[TraceRecord]) -> Vec<(String, usize)> {
    let mut firings_by_actor: Vec<(String, usize)> = Vec::new();
    for r in trace {
        match firings_by_actor.iter_mut().find(|(n, _)| *n == r.actor) {
            Some(e) => e.1 += 1,
            None => firings_by_actor.push((r.actor.clone(), 1)),
        }
    }
    firings_by_actor
}

/// Runs the reconfigurable-controller example and reports the tracking error before and after
/// the Checker's reconfiguration. Side effects: spawns `opts.workers` threads for the run.
///
/// Errors: invalid options (non-positive step, duration or window), or a kernel error while
/// building the graph.
pub fn run_reconfig_demo(opts: &ReconfigOptions) -> Result<ReconfigOutcome, ReconfigError> {
    if !(opts.dt > 0.0
        && opts.duration > opts.dt
        && opts.window > 0.0
        && opts.mass > 0.0
        && opts.length > 0.0)
    {
        return Err(ReconfigError::InvalidOptions(format!("{opts:?}")));
    }
    let o = *opts;
    let log = Arc::new(Mutex::new(Log::default()));
    let graph = Graph::new(o.workers);
    graph.set_tracing(true);
    let (torque, ack) = build_loop(&graph, o, &log)?;
    let dot_before = graph.to_dot();
    graph.write(torque, Value::F64(0.0))?;
    graph.write(ack, Value::Unit)?;
    graph.wait_idle();
    let dot_after = graph.to_dot();
    let trace = graph.trace();
    let firings = trace.len();
    let firings_by_actor = firings_by_actor(&trace);
    let errors = graph.errors();
    if let Some(e) = errors.first() {
        return Err(ReconfigError::Script(e.clone()));
    }
    let l = log.lock().map_err(|_| ReconfigError::LogPoisoned)?;
    let mut samples = l.errors.clone();
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    let end = samples.last().map_or(0.0, |s| s.0);
    let before = match l.switched_at {
        Some(ts) => rms(&samples, ts - o.window, ts),
        None => rms(&samples, o.settle, o.settle + o.window),
    };
    Ok(ReconfigOutcome {
        switched_at: l.switched_at,
        rms_error_before: before,
        rms_error_after: rms(&samples, end - o.window, end),
        final_error: samples.last().map_or(f64::NAN, |s| s.1),
        steps: samples.len(),
        firings,
        firings_by_actor,
        tracking: samples,
        dot_before,
        dot_after,
    })
}
