//! `robosim rules FILE.clp --session S`: a CLIPS rule base (seed §3.4) on a running session.
//!
//! The real CLIPS 6.30 engine ([`clips`], the one module with `unsafe`) runs the rule file.
//! The session is mirrored into its working memory as facts, brought up to date on every
//! change of the Instance Space (and whenever the simulator's state changes, polled every
//! [`POLL`]), and the rules write back through one function, `(robosim COMMAND ARGS…)`.
//!
//! Facts (templates in [`TEMPLATES`]; names are symbols):
//! * `(space (version V))`
//! * `(robot (name R) (dof N))`, `(joint (robot R) (index I) (name LINK) (q Q) (lo LO) (hi HI))`
//!   — committed joint values, rad / m;
//! * `(instance (name O) (kind K) (parent P|nil))` for every object of the Instance Space
//!   (`object` is a reserved word in CLIPS);
//! * `(sim (state running|stepping|paused|none) (t T) (steps N))`,
//!   `(sim-robot (name R) (contact yes|no) (error nil|"…") (version V))` — the simulator
//!   daemon's state; V is the Instance Space version it had taken at its last step (its
//!   `stepped_version`: `contact` was computed there);
//! * `(alarm (source S) (kind K) (value V) (message M))` — the alarms of the session: a
//!   simulator contact (`kind contact`) or step error (`kind step-error`) per robot, and every
//!   alarm the automation plant (`robosim automation`, `robosim_hl_interface::plant`) rings:
//!   source the fault model's process, kind the alarm's name, value the plant time it rang;
//! * `(sim-power …)`, `(sim-consumer …)`, `(sim-attitude …)`, `(sim-experiment …)`,
//!   `(sim-window …)`, `(sim-fault …)` — the simulator's operations stage (`space.ops` of its
//!   state, when the scene declares `attitude`/`consumers`; [`TEMPLATES`]);
//! * `(diagnosis (model M) (failure-modes …) (components …) (alarms N))` — after
//!   `(robosim diagnose)`.
//!
//! Only facts whose content changed are retracted and asserted again, so a rule fires on a
//! change, not on every mirror pass.
//!
//! Functions the rules call (each returns an integer: a version, 0, or -1 on failure, when
//! `(robosim-error (command C) (message M))` is asserted and the message printed):
//! * `(robosim set-joint R I Q)` — one joint, one transaction; `(robosim set-joints R Q1 … Qn)`;
//! * `(robosim transact "JSON")` — a transaction in the planner's JSON form
//!   (`[["set_pose", obj, T], …]`, docs/python.md);
//! * `(robosim query "JSON")` — any op of the query protocol (MOVEJ, MOVEJI, KINV, CHECK, …);
//!   its answer is asserted as `(robosim-answer (op OP) (json "…"))`; returns the answer's
//!   `version` when it has one, else 0;
//! * `(robosim sim "JSON")` — a simulator command (`{"cmd": "pause"}`, …);
//! * `(robosim diagnose)` — the query op `diag_diagnose` over every alarm the plant rings now;
//!   asserts a `diagnosis` fact, returns the number of components it names.
//!
//! A call whose argument fails to evaluate (`(/ 0.0 0.0)`) or is not a finite number does
//! nothing ([`clips`]). Every run of the rules is bounded by [`clips::Limits`] (time per pass,
//! call depth and stack, memory); past one the process fails naming the rule, and SIGTERM
//! halts a running rule (exit 0). docs/rules.md, "Limits".
//!
//! Rule bases shipped (`hl-interface/rules/rulebases/`): `joint_guard.clp` (soft joint limits
//! enforced by setting the joint back, contact alarms handled by pausing the simulator and
//! backing the robot off to its clear joints) and `eclss_guard.clp` (ECLSS alarms diagnosed,
//! the faulty unit isolated, then its spare brought on line) and `station_power.clp` (the
//! station's energy scheduler, run in process by `robosim study station --scheduler on` through
//! [`embedded::Embedded`]). docs/rules.md.

//!
//! The engine is linked when the build finds the system CLIPS (build.rs sets `cfg(clips)`);
//! without it everything here but [`run`] builds, and [`run`] (so `robosim rules`) fails with
//! [`RulesError::NotBuilt`], saying what to install ([`BUILT_WITH_CLIPS`], [`NOT_BUILT`]).

pub mod cli;
pub mod clips;
pub mod embedded;

#[cfg(clips)]
use clips::Clips;
use clips::{Arg, ClipsError, Limits, Stop, quote};
use robosim_hl_interface::ProtocolError;
use robosim_hl_interface::planner::Planner;
#[cfg(clips)]
use robosim_instance_space::Session;
use serde_json::Value;
#[cfg(clips)]
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::Path;
#[cfg(clips)]
use std::rc::Rc;
use std::time::Duration;

/// Whether this build has the CLIPS engine (build.rs found `libclips.a` and `clips.h`).
pub const BUILT_WITH_CLIPS: bool = cfg!(clips);

/// What a build without CLIPS says when rules are asked for.
pub const NOT_BUILT: &str = "this robosim was built without the CLIPS rule engine: the build did not find the system CLIPS (libclips.a and clips.h, or CLIPS_LIB_DIR / CLIPS_INCLUDE_DIR). Install it with `sudo apt-get install --no-install-recommends libclips-dev`, then rebuild: `cargo clean -p robosim-rules && cargo build --release`";

/// For tests that need the engine: `true` (the test should return, skipped) when this build
/// has no CLIPS, said loudly on stderr with the reason — unless the environment variable `CI`
/// is `true`, where a missing CLIPS fails the test (CI installs it: every test runs there).
#[doc(hidden)]
pub fn skipped_without_clips(test: &str) -> bool {
    if BUILT_WITH_CLIPS {
        return false;
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "{test}: CI=true but {NOT_BUILT}"
    );
    eprintln!("\n*** SKIPPED {test}: {NOT_BUILT} ***\n");
    true
}

/// `Ok` when this build can run rules, else [`RulesError::NotBuilt`] (what to install).
pub fn available() -> Result<(), RulesError> {
    if BUILT_WITH_CLIPS {
        Ok(())
    } else {
        Err(RulesError::NotBuilt)
    }
}

/// How often the simulator's state is looked at when nothing is committed.
pub const POLL: Duration = Duration::from_millis(100);
/// A mirror-and-run pass slower than this is said on stderr.
#[cfg(clips)]
const SLOW_PASS: Duration = Duration::from_secs(2);

/// The bridge's templates, built before the rule file is loaded.
pub const TEMPLATES: &[&str] = &[
    "(deftemplate space (slot version))",
    "(deftemplate robot (slot name) (slot dof))",
    "(deftemplate joint (slot robot) (slot index) (slot name) (slot q) (slot lo) (slot hi))",
    "(deftemplate instance (slot name) (slot kind) (slot parent))",
    "(deftemplate sim (slot state) (slot t) (slot steps))",
    "(deftemplate sim-robot (slot name) (slot contact) (slot error) (slot version))",
    "(deftemplate alarm (slot source) (slot kind) (slot value) (slot message))",
    "(deftemplate diagnosis (slot model) (multislot failure-modes) (multislot components) (slot alarms))",
    "(deftemplate robosim-error (slot command) (slot message))",
    "(deftemplate robosim-answer (slot op) (slot json))",
    "(deftemplate sim-power (slot steps) (slot t) (slot power-kw) (slot battery-kwh) (slot capacity-kwh) (slot charge-eff) (slot discharge-eff) (slot eclipse) (slot to-eclipse-s) (slot eclipse-left-s) (slot eclipse-s) (slot period-s) (slot demand-kw))",
    "(deftemplate sim-consumer (slot name) (slot priority) (slot mode) (slot full-kw) (slot reduced-kw) (slot served-kw))",
    "(deftemplate sim-attitude (slot error-deg) (slot h-fraction) (slot saturation) (slot dumping) (slot desaturations))",
    "(deftemplate sim-experiment (slot name) (slot power-kw) (slot sensitive) (slot state) (slot start-s) (slot end-s))",
    "(deftemplate sim-window (slot kind) (slot from-s) (slot to-s))",
    "(deftemplate sim-fault (slot consumer) (multislot components) (slot state) (slot factor))",
];

/// What `--watch` may trace (CLIPS `watch` items).
pub const WATCH_ITEMS: &[&str] = &["facts", "rules", "activations", "statistics", "all"];

#[derive(Debug, thiserror::Error)]
pub enum RulesError {
    /// The build found no CLIPS to link ([`NOT_BUILT`]).
    #[error("rules: {NOT_BUILT}")]
    NotBuilt,
    #[error("--watch {0:?}: not a watch item (facts, rules, activations, statistics, all)")]
    Watch(String),
    #[error(transparent)]
    Clips(#[from] ClipsError),
    /// A run of the rules went past one of its [`Limits`] (the rule base is at fault: it is
    /// not run again).
    #[error("rules: {0}")]
    Limit(Stop),
    #[error("{0}")]
    Session(#[from] ProtocolError),
    #[error("session: {0}")]
    Registry(#[from] robosim_instance_space::SessionError),
}

/// A name as a CLIPS symbol when it is one, else as a string.
fn sym(name: &str) -> String {
    let ok = name.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.');
    if ok { name.to_owned() } else { quote(name) }
}

fn num(x: f64) -> String {
    // Debug formatting keeps a decimal point (CLIPS reads `1` as an integer, `1.0` as a float).
    format!("{x:?}")
}

/// The mirrored facts: key → (fact text, retraction expression).
#[derive(Default)]
pub struct Mirror {
    #[cfg_attr(not(clips), allow(dead_code))]
    facts: BTreeMap<String, (String, String)>,
}

impl Mirror {
    /// The facts the session holds now.
    pub fn facts_of(
        p: &mut Planner,
        sim: Option<&Value>,
        plant: Option<&Value>,
    ) -> Result<Vec<(String, String, String)>, ProtocolError> {
        let snap = p.snapshot()?;
        let mut out = Vec::new();
        let retract_one = |template: &str, cond: String| {
            format!("(do-for-all-facts ((?f {template})) {cond} (retract ?f))")
        };
        out.push((
            "space".into(),
            format!("(space (version {}))", snap.version()),
            retract_one("space", "TRUE".into()),
        ));
        for i in 0..snap.len() {
            let name = sym(snap.name(i));
            let kind = snap
                .object(i)
                .kind()
                .map_or("unknown".to_owned(), |k| format!("{k:?}").to_lowercase());
            let parent = snap
                .index_of(snap.rec(i).parent)
                .filter(|_| snap.rec(i).parent != 0)
                .map_or("nil".to_owned(), |k| sym(snap.name(k)));
            out.push((
                format!("instance {name}"),
                format!("(instance (name {name}) (kind {kind}) (parent {parent}))"),
                retract_one("instance", format!("(eq ?f:name {name})")),
            ));
        }
        for r in snap.robots() {
            let rn = sym(r.name);
            out.push((
                format!("robot {rn}"),
                format!("(robot (name {rn}) (dof {}))", r.joints.len()),
                retract_one("robot", format!("(eq ?f:name {rn})")),
            ));
            for (k, j) in r.joints.iter().enumerate() {
                out.push((
                    format!("joint {rn} {k}"),
                    format!(
                        "(joint (robot {rn}) (index {k}) (name {}) (q {}) (lo {}) (hi {}))",
                        sym(snap.name(j.index)),
                        num(j.q),
                        num(j.qlim[0]),
                        num(j.qlim[1])
                    ),
                    retract_one(
                        "joint",
                        format!("(and (eq ?f:robot {rn}) (= ?f:index {k}))"),
                    ),
                ));
            }
        }
        let state = sim
            .and_then(|s| s.get("state").and_then(Value::as_str))
            .unwrap_or("none");
        out.push((
            "sim".into(),
            format!(
                "(sim (state {state}) (t {}) (steps {}))",
                num(sim.and_then(|s| s.get("t_s")?.as_f64()).unwrap_or(0.0)),
                sim.and_then(|s| s.get("steps")?.as_u64()).unwrap_or(0)
            ),
            retract_one("sim", "TRUE".into()),
        ));
        // The Instance Space version the simulator had taken at its last step: its robots'
        // `contact` was computed there. (Not `version`, the one it follows: a paused simulator
        // follows commits without stepping, and its `contact` is then older than them.)
        let sim_version = sim
            .and_then(|s| s.get("stepped_version")?.as_u64())
            .unwrap_or(0);
        for r in sim
            .and_then(|s| s.get("robots")?.as_array())
            .into_iter()
            .flatten()
        {
            let rn = sym(r.get("name").and_then(Value::as_str).unwrap_or(""));
            // `contact` is null without a collision stage, else whether the last check touched.
            let contact = r.get("contact") == Some(&Value::Bool(true));
            let error = r.get("error").and_then(Value::as_str);
            out.push((
                format!("sim-robot {rn}"),
                format!(
                    "(sim-robot (name {rn}) (contact {}) (error {}) (version {}))",
                    if contact { "yes" } else { "no" },
                    error.map_or("nil".into(), quote),
                    sim_version
                ),
                retract_one("sim-robot", format!("(eq ?f:name {rn})")),
            ));
            let retract_alarm = |kind: &str| {
                retract_one(
                    "alarm",
                    format!("(and (eq ?f:source {rn}) (eq ?f:kind {kind}))"),
                )
            };
            if contact {
                out.push((
                    format!("alarm {rn} contact"),
                    format!(
                        "(alarm (source {rn}) (kind contact) (message {}))",
                        quote(&r.get("contact").map(Value::to_string).unwrap_or_default())
                    ),
                    retract_alarm("contact"),
                ));
            }
            if let Some(e) = error {
                out.push((
                    format!("alarm {rn} step-error"),
                    format!(
                        "(alarm (source {rn}) (kind step-error) (value 1) (message {}))",
                        quote(e)
                    ),
                    retract_alarm("step-error"),
                ));
            }
        }
        if let Some(ops) = sim
            .and_then(|s| s.pointer("/space/ops"))
            .filter(|o| o.is_object())
        {
            ops_facts(sim.and_then(|s| s.get("space")), ops, &mut out);
        }
        // The automation plant's ringing alarms (`robosim automation`): source the process,
        // kind the alarm's name, value the plant time it rang (s).
        for a in plant
            .and_then(|s| s.get("alarms")?.as_array())
            .into_iter()
            .flatten()
        {
            let source = sym(a.get("process").and_then(Value::as_str).unwrap_or(""));
            let kind = sym(a.get("alarm").and_then(Value::as_str).unwrap_or(""));
            out.push((
                format!("alarm {source} {kind}"),
                format!(
                    "(alarm (source {source}) (kind {kind}) (value {}) (message {}))",
                    num(a.get("t_s").and_then(Value::as_f64).unwrap_or(0.0)),
                    quote(a.get("message").and_then(Value::as_str).unwrap_or(""))
                ),
                retract_one(
                    "alarm",
                    format!("(and (eq ?f:source {source}) (eq ?f:kind {kind}))"),
                ),
            ));
        }
        Ok(out)
    }

    /// Brings working memory to `facts`: retracts what went or changed, asserts what is new
    /// or changed. Returns how many facts were asserted.
    #[cfg(clips)]
    pub fn update(
        &mut self,
        clips: &mut Clips,
        facts: Vec<(String, String, String)>,
    ) -> Result<usize, ClipsError> {
        let mut next = BTreeMap::new();
        for (key, fact, retract) in facts {
            next.insert(key, (fact, retract));
        }
        for (key, (fact, retract)) in &self.facts {
            if next.get(key).is_none_or(|(f, _)| f != fact) {
                clips.eval(retract)?;
            }
        }
        let mut asserted = 0;
        for (key, (fact, _)) in &next {
            if self.facts.get(key).is_none_or(|(f, _)| f != fact) {
                clips.assert_str(fact)?;
                asserted += 1;
            }
        }
        self.facts = next;
        Ok(asserted)
    }
}

/// The simulator's operations stage (`space.ops` of its state, issue 38 item 7) as facts:
/// `(sim-power …)` (the step it was taken at, power, battery, the eclipse ahead, the demand),
/// `(sim-consumer …)` per consumer (kW) and `(sim-attitude …)` when the attitude runs.
fn ops_facts(space: Option<&Value>, ops: &Value, out: &mut Vec<(String, String, String)>) {
    let f = |v: Option<&Value>| num(v.and_then(Value::as_f64).unwrap_or(0.0));
    let kw = |v: Option<&Value>| num(v.and_then(Value::as_f64).unwrap_or(0.0) / 1e3);
    let sp = |p: &str| space.and_then(|s| s.pointer(p));
    let retract_all = |t: &str| format!("(do-for-all-facts ((?f {t})) TRUE (retract ?f))");
    out.push((
        "sim-power".into(),
        format!(
            "(sim-power (steps {}) (t {}) (power-kw {}) (battery-kwh {}) (capacity-kwh {}) (charge-eff {}) (discharge-eff {}) (eclipse {}) (to-eclipse-s {}) (eclipse-left-s {}) (eclipse-s {}) (period-s {}) (demand-kw {}))",
            ops.get("steps").and_then(Value::as_u64).unwrap_or(0),
            f(sp("/t_s")),
            kw(sp("/power/power_w")),
            f(sp("/power/battery_kwh")),
            f(sp("/power/battery_capacity_kwh")),
            f(ops.pointer("/battery/charge_eff")),
            f(ops.pointer("/battery/discharge_eff")),
            if sp("/eclipse") == Some(&Value::Bool(true)) { "yes" } else { "no" },
            f(ops.get("to_eclipse_s")),
            f(ops.get("eclipse_left_s")),
            f(ops.get("eclipse_s")),
            f(sp("/orbit/period_s")),
            kw(ops.get("demand_w")),
        ),
        retract_all("sim-power"),
    ));
    for c in ops
        .get("consumers")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
    {
        let name = sym(c.get("name").and_then(Value::as_str).unwrap_or(""));
        let s = |k: &str| sym(c.get(k).and_then(Value::as_str).unwrap_or("nil"));
        out.push((
            format!("sim-consumer {name}"),
            format!(
                "(sim-consumer (name {name}) (priority {}) (mode {}) (full-kw {}) (reduced-kw {}) (served-kw {}))",
                s("priority"),
                s("mode"),
                kw(c.get("full_w")),
                kw(c.get("reduced_w")),
                kw(c.get("served_w")),
            ),
            format!("(do-for-all-facts ((?f sim-consumer)) (eq ?f:name {name}) (retract ?f))"),
        ));
    }
    let list = |k: &str| ops.get(k).and_then(Value::as_array).into_iter().flatten();
    for e in list("experiments") {
        let name = sym(e.get("name").and_then(Value::as_str).unwrap_or(""));
        out.push((
            format!("sim-experiment {name}"),
            format!(
                "(sim-experiment (name {name}) (power-kw {}) (sensitive {}) (state {}) (start-s {}) (end-s {}))",
                kw(e.get("power_w")),
                if e.get("sensitive") == Some(&Value::Bool(true)) { "yes" } else { "no" },
                sym(e.get("state").and_then(Value::as_str).unwrap_or("nil")),
                f(e.get("start_s")),
                f(e.get("end_s")),
            ),
            format!("(do-for-all-facts ((?f sim-experiment)) (eq ?f:name {name}) (retract ?f))"),
        ));
    }
    for (i, w) in list("windows").enumerate() {
        let kind = sym(w.get("kind").and_then(Value::as_str).unwrap_or("nil"));
        let (from, to) = (f(w.get("from_s")), f(w.get("to_s")));
        out.push((
            format!("sim-window {i}"),
            format!("(sim-window (kind {kind}) (from-s {from}) (to-s {to}))"),
            format!(
                "(do-for-all-facts ((?f sim-window)) (and (eq ?f:kind {kind}) (= ?f:from-s {from}) (= ?f:to-s {to})) (retract ?f))"
            ),
        ));
    }
    for (i, x) in list("faults").enumerate() {
        let consumer = sym(x.get("consumer").and_then(Value::as_str).unwrap_or(""));
        let comps: Vec<String> = x
            .get("components")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
            .filter_map(Value::as_str)
            .map(sym)
            .collect();
        let state = sym(x.get("state").and_then(Value::as_str).unwrap_or("nil"));
        out.push((
            format!("sim-fault {i}"),
            format!(
                "(sim-fault (consumer {consumer}) (components {}) (state {}) (factor {}))",
                comps.join(" "),
                state,
                f(x.get("factor")),
            ),
            format!(
                "(do-for-all-facts ((?f sim-fault)) (and (eq ?f:consumer {consumer}) (eq ?f:state {state})) (retract ?f))"
            ),
        ));
    }
    if let Some(a) = ops.get("attitude").filter(|a| a.is_object()) {
        out.push((
            "sim-attitude".into(),
            format!(
                "(sim-attitude (error-deg {}) (h-fraction {}) (saturation {}) (dumping {}) (desaturations {}))",
                f(a.get("error_deg")),
                f(a.get("h_fraction")),
                f(a.get("saturation")),
                if a.get("dumping") == Some(&Value::Bool(true)) { "yes" } else { "no" },
                a.get("desaturations").and_then(Value::as_u64).unwrap_or(0),
            ),
            retract_all("sim-attitude"),
        ));
    }
}

fn text(args: &[Arg], i: usize, what: &str) -> Result<String, String> {
    match args.get(i) {
        Some(Arg::Text(s)) => Ok(s.clone()),
        Some(Arg::Num(x)) => Ok(x.to_string()),
        None => Err(format!("missing {what} (argument {i})")),
    }
}

fn number(args: &[Arg], i: usize, what: &str) -> Result<f64, String> {
    match args.get(i) {
        Some(Arg::Num(x)) if x.is_finite() => Ok(*x),
        Some(Arg::Num(x)) => Err(format!("{what} (argument {i}) is not a finite number: {x}")),
        Some(Arg::Text(s)) => Err(format!("{what} (argument {i}) must be a number, got {s:?}")),
        None => Err(format!("missing {what} (argument {i})")),
    }
}

/// What `(robosim COMMAND ARGS…)` does (module docs). `answers` collects the facts to assert
/// for `query` and `diagnose` answers (asserted by the caller after the call returns); `plant`
/// is the automation plant's state as last mirrored.
pub fn call(
    p: &mut Planner,
    args: &[Arg],
    answers: &mut Vec<String>,
    plant: Option<&Value>,
) -> Result<i64, String> {
    let command = text(args, 0, "the command")?;
    let e = |e: ProtocolError| e.to_string();
    let json_arg = |i: usize| -> Result<Value, String> {
        let t = text(args, i, "the JSON text")?;
        serde_json::from_str(&t).map_err(|err| format!("argument {i} is not JSON: {err}"))
    };
    match command.as_str() {
        "set-joint" => {
            let robot = text(args, 1, "the robot")?;
            let index = number(args, 2, "the joint index")?;
            let value = number(args, 3, "the joint value")?;
            // One joint of q: read, set and written against the q the keeper holds when it
            // commits (a concurrent write of another joint is read again, not undone).
            p.update_joints(&robot, |q| {
                let k = (index >= 0.0 && index.fract() == 0.0 && (index as usize) < q.len())
                    .then_some(index as usize)
                    .ok_or_else(|| {
                        ProtocolError::new(
                            robosim_hl_interface::ErrorKind::BadRequest,
                            format!("robot {robot} has no joint {index}"),
                        )
                    })?;
                q[k] = value;
                Ok(())
            })
            .map(|v| v as i64)
            .map_err(e)
        }
        "set-joints" => {
            let robot = text(args, 1, "the robot")?;
            let q = (2..args.len())
                .map(|i| number(args, i, "a joint value"))
                .collect::<Result<Vec<_>, _>>()?;
            p.set_joints(&robot, &q).map(|v| v as i64).map_err(e)
        }
        "transact" => p.transact_json(&json_arg(1)?).map(|v| v as i64).map_err(e),
        "query" => {
            let req = json_arg(1)?;
            let answer = p.query(&req).map_err(e)?;
            let op = req.get("op").and_then(Value::as_str).unwrap_or("");
            answers.push(format!(
                "(robosim-answer (op {}) (json {}))",
                sym(op),
                quote(&answer.to_string())
            ));
            Ok(answer.get("version").and_then(Value::as_i64).unwrap_or(0))
        }
        "sim" => p.sim_command(&json_arg(1)?).map(|_| 0).map_err(e),
        "diagnose" => {
            let plant = plant.ok_or("no automation plant runs in the session")?;
            let model = plant
                .get("source")
                .and_then(Value::as_str)
                .ok_or("the plant's state names no model")?;
            let alarms: Vec<Value> = plant
                .get("alarms")
                .and_then(Value::as_array)
                .into_iter()
                .flatten()
                .map(|a| serde_json::json!({"t": a.get("t_s"), "alarm": a.get("alarm")}))
                .collect();
            if alarms.is_empty() {
                return Err("no alarm is ringing: nothing to diagnose".into());
            }
            let req = serde_json::json!({"op": "diag_diagnose", "model": model, "alarms": alarms});
            let answer = p.query(&req).map_err(e)?;
            let list = |v: Option<&Value>| -> Vec<String> {
                v.and_then(Value::as_array)
                    .into_iter()
                    .flatten()
                    .filter_map(Value::as_str)
                    .map(sym)
                    .collect()
            };
            let fms = list(answer.get("ilm").and_then(|i| i.get("failure_modes")));
            let comps = list(answer.get("components"));
            answers.push(format!(
                "(diagnosis (model {}) (failure-modes {}) (components {}) (alarms {}))",
                sym(plant.get("model").and_then(Value::as_str).unwrap_or(model)),
                fms.join(" "),
                comps.join(" "),
                alarms.len()
            ));
            Ok(comps.len() as i64)
        }
        other => Err(format!(
            "unknown command {other:?} (set-joint, set-joints, transact, query, sim, diagnose)"
        )),
    }
}

#[cfg(clips)]
/// `r`'s value; its error is written to stderr when it differs from the last one said in
/// `last` (`None` while the peer answers), so a peer that stops answering is said once.
fn said(last: &mut Option<String>, peer: &str, r: Result<Value, ProtocolError>) -> Option<Value> {
    match r {
        Ok(v) => {
            if last.as_ref().is_some_and(|e| !e.is_empty()) {
                eprintln!("rules: the {peer} answers again");
            }
            *last = None;
            Some(v)
        }
        Err(e) => {
            let m = e.to_string();
            if last.as_deref() != Some(m.as_str()) {
                eprintln!("rules: no state from the {peer}: {m}");
                *last = Some(m);
            }
            None
        }
    }
}

/// `robosim rules FILE --session S`: runs until SIGTERM/SIGINT (exit 0, also when the signal
/// comes while a rule runs: the engine is halted), or until a run of the rules goes past one
/// of `limits` ([`RulesError::Limit`], naming the rule).
#[cfg(clips)]
pub fn run(
    file: &Path,
    session: Option<&str>,
    watch: &[String],
    limits: &Limits,
) -> Result<(), RulesError> {
    let session = Session::existing(session)?;
    let signals = Rc::new(session.node("rules-signals", true)?);
    let planner = Rc::new(RefCell::new(Planner::attach_to(&session)?));
    let answers: Rc<RefCell<Vec<String>>> = Rc::default();
    let plant_state: Rc<RefCell<Option<Value>>> = Rc::default();
    let (p2, a2, s2) = (planner.clone(), answers.clone(), plant_state.clone());
    let mut clips = Clips::with_limits(
        Box::new(move |args: &[Arg]| {
            let mut p = p2
                .try_borrow_mut()
                .map_err(|_| "the planner is busy (a nested call)".to_owned())?;
            call(&mut p, args, &mut a2.borrow_mut(), s2.borrow().as_ref())
        }),
        *limits,
    )?;
    let s3 = signals.clone();
    clips.set_terminate(Box::new(move || s3.wait(Duration::ZERO).is_err()));
    for t in TEMPLATES {
        clips.build(t)?;
    }
    for item in watch {
        if !WATCH_ITEMS.contains(&item.as_str()) {
            return Err(RulesError::Watch(item.clone()));
        }
        clips.eval(&format!("(watch {item})"))?;
    }
    clips.load(file)?;
    // Registered (seen by `robosim ps` and waiting launchers) once the first pass has mirrored
    // the session and run the rules on it: what is committed after that is a change to them.
    let mut registered = None;
    let mut mirror = Mirror::default();
    let mut last_sim: Option<Value> = None;
    let mut first = true;
    let (mut sim_error, mut plant_error) = (Some(String::new()), Some(String::new()));
    while signals.wait(Duration::ZERO).is_ok() {
        let changed = if first {
            true
        } else {
            planner.borrow_mut().wait_change(POLL)?.is_some()
        };
        first = false;
        let pass = std::time::Instant::now();
        // The simulator's state, without the fields that change on every step by themselves.
        // A peer that stops answering (or starts again) is said once, not on every pass.
        let sim = said(
            &mut sim_error,
            "simulator",
            planner.borrow_mut().sim_state(),
        );
        let sim_key = sim.as_ref().map(|s| {
            let mut s = s.clone();
            if let Some(m) = s.as_object_mut() {
                m.remove("recording");
            }
            s
        });
        // The automation plant's state, without its clock.
        let plant = said(
            &mut plant_error,
            "automation plant",
            planner
                .borrow_mut()
                .plant_command(&serde_json::json!({"cmd": "get"})),
        )
        .map(|mut s| {
            if let Some(m) = s.as_object_mut() {
                m.remove("t_s");
            }
            s
        });
        if !changed && sim_key == last_sim && plant == *plant_state.borrow() {
            continue;
        }
        last_sim = sim_key;
        *plant_state.borrow_mut() = plant;
        let facts = Mirror::facts_of(
            &mut planner.borrow_mut(),
            sim.as_ref(),
            plant_state.borrow().as_ref(),
        )?;
        mirror.update(&mut clips, facts)?;
        loop {
            match clips.run(-1) {
                Ok(_) => {}
                Err(stop @ Stop::Terminated { .. }) => {
                    eprintln!("rules: {stop}; stopped");
                    return Ok(());
                }
                Err(stop) => return Err(RulesError::Limit(stop)),
            }
            let pending: Vec<String> = answers.borrow_mut().drain(..).collect();
            if pending.is_empty() {
                break;
            }
            for f in pending {
                clips.assert_str(&f)?;
            }
        }
        if registered.is_none() {
            registered = Some(
                session.register("rules", &["space/objects", "space/poses", "space/changes"])?,
            );
            eprintln!(
                "rules: {} loaded on session {}",
                file.display(),
                session.name()
            );
        }
        if pass.elapsed() > SLOW_PASS {
            eprintln!(
                "rules: a pass took {:.1} s (peers slow to answer?)",
                pass.elapsed().as_secs_f64()
            );
        }
    }
    eprintln!("rules: stopped");
    Ok(())
}

/// This build has no CLIPS: [`RulesError::NotBuilt`], whatever is asked.
#[cfg(not(clips))]
pub fn run(
    _file: &Path,
    _session: Option<&str>,
    _watch: &[String],
    _limits: &Limits,
) -> Result<(), RulesError> {
    Err(RulesError::NotBuilt)
}

/// The engine's own unit tests (src/clips/engine.rs) are compiled out with it: say so.
#[cfg(all(test, not(clips)))]
#[test]
fn the_engine_unit_tests_are_skipped_without_clips() {
    assert!(skipped_without_clips("robosim-rules engine unit tests"));
}
