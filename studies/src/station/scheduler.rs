//! The station's energy scheduler in rules (issue 38 items 3–4): `station_power.clp` and
//! `eclss_guard.clp`, shipped in `hl-interface/rules/rulebases/`, run in process by the CLIPS
//! engine ([`robosim_rules::embedded::Embedded`]). Every study step the study retracts its
//! `sp-*` facts and asserts them afresh ([`PlanFacts`]: battery, the predicted generation per
//! orbit phase, consumers, experiments, desaturation and docking windows, ECLSS faults), runs
//! the rules, and applies what they call for: `(robosim set-mode|start|stop|move|defer|decide
//! RULE TARGET VALUE REASON)` — each recorded as a [`Decision`] with the rule's name and reason.
//!
//! An injected ECLSS fault ([`super::faults`]) rings its alarms as `alarm` facts;
//! `eclss_guard.clp` diagnoses them through `(robosim diagnose)` (ILM here, in process) and
//! isolates the unit and brings its spare on line through `(robosim transact …)`: the study's
//! plant takes the attach and the consumer's demand follows ([`EclssFault::demand_factor`]).
//!
//! `--scheduler off` loads `eclss_guard.clp` alone (faults are still handled when CLIPS is
//! built) and the loads run at full, each experiment started when asked for. Without CLIPS
//! there is no rule engine at all: `--scheduler on` is refused with what to install, and the
//! default is off, said loudly.
//!
//! Entry points: [`Scheduler::new`], [`Scheduler::step`], [`Scheduling`].

use super::faults::{EclssFault, FaultState};
use super::loads::{Forecast, Loads};
use crate::{Result, StudyError};
use robosim_rules::clips::{Arg, Limits, arg_text as text, float_literal as num, quote};
use robosim_rules::embedded::{Embedded, Pending, shipped};
use robosim_simulator::consumers::Mode;
use std::cell::RefCell;
use std::rc::Rc;

/// A move of a run already moved is recorded again only when it shifts it by more than this, s.
pub const MOVE_RECORDED_S: f64 = 600.0;

/// Whether the rule base schedules the loads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scheduling {
    On,
    Off,
}

impl Scheduling {
    /// On when this build has CLIPS, else off.
    pub fn default_for_build() -> Scheduling {
        if robosim_rules::BUILT_WITH_CLIPS {
            Scheduling::On
        } else {
            Scheduling::Off
        }
    }

    /// `on` or `off`.
    pub fn parse(s: &str) -> Result<Scheduling> {
        match s {
            "on" => Ok(Scheduling::On),
            "off" => Ok(Scheduling::Off),
            other => Err(StudyError::Message(format!(
                "--scheduler {other:?}: on or off"
            ))),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Scheduling::On => "on",
            Scheduling::Off => "off",
        }
    }
}

/// One decision: a rule firing with its reason.
#[derive(Debug, Clone, PartialEq)]
pub struct Decision {
    /// Study time, s.
    pub t: f64,
    /// The rule base and rule (`station_power sp-defer-hygiene`, `eclss_guard isolate`).
    pub rule: String,
    /// What it acts on (a consumer, an experiment, a component).
    pub target: String,
    /// What it did (`off`, `reduced`, `start`, `move`, …).
    pub action: String,
    pub reason: String,
}

/// The facts of one step (module docs).
pub struct PlanFacts<'a> {
    pub t: f64,
    pub step_s: f64,
    pub energy_j: f64,
    pub capacity_j: f64,
    pub charge_eff: f64,
    pub discharge_eff: f64,
    pub reserve_j: f64,
    pub margin_j: f64,
    pub forecast: &'a Forecast,
    /// (kind, start s, end s): predicted desaturations and docking events.
    pub windows: &'a [(&'static str, f64, f64)],
}

/// What the handler leaves for the study (commands of the rules, and the plant's changes).
#[derive(Default)]
struct Shared {
    t: f64,
    commands: Vec<Vec<Arg>>,
    decisions: Vec<Decision>,
    fault: Option<EclssFault>,
    version: i64,
    last_note: Vec<(String, String, String)>,
}

/// The rule engine over a run (module docs).
pub struct Scheduler {
    pub scheduling: Scheduling,
    engine: Option<Embedded>,
    shared: Rc<RefCell<Shared>>,
    /// Alarm facts asserted so far.
    alarms_asserted: usize,
}

/// `(robosim …)` from either rule base (module docs).
fn handle(
    sh: &mut Shared,
    args: &[Arg],
    pending: &mut Vec<Pending>,
) -> std::result::Result<i64, String> {
    let cmd = text(args.first());
    match cmd.as_str() {
        "set-mode" | "start" | "stop" | "move" | "defer" => {
            if args.len() != 5 {
                return Err(format!(
                    "({cmd} RULE TARGET VALUE REASON): {} arguments",
                    args.len() - 1
                ));
            }
            sh.commands.push(args.to_vec());
            Ok(0)
        }
        "decide" => {
            // a note: recorded when it differs from the last one of its rule and target
            let (rule, target, action, reason) = (
                text(args.get(1)),
                text(args.get(2)),
                text(args.get(3)),
                text(args.get(4)),
            );
            let key = (rule.clone(), target.clone(), action.clone());
            if !sh.last_note.contains(&key) {
                sh.last_note
                    .retain(|(r, tg, _)| !(r == &rule && tg == &target));
                sh.last_note.push(key);
                let t = sh.t;
                sh.decisions.push(Decision {
                    t,
                    rule: format!("station_power {rule}"),
                    target,
                    action,
                    reason,
                });
            }
            Ok(0)
        }
        "diagnose" => {
            let t = sh.t;
            let Some(f) = sh.fault.as_mut() else {
                return Err("no fault model runs in this study".into());
            };
            let (fms, comps, n) = f.diagnose(t);
            if n == 0 {
                return Err("no alarm is ringing: nothing to diagnose".into());
            }
            let syms = |v: &[String]| v.iter().map(|s| quote(s)).collect::<Vec<_>>().join(" ");
            pending.push(Pending::Assert(format!(
                "(diagnosis (model eclss) (failure-modes {}) (components {}) (alarms {n}))",
                syms(&fms),
                comps.join(" ")
            )));
            sh.decisions.push(Decision {
                t,
                rule: "eclss_guard diagnose".into(),
                target: comps.join(" "),
                action: "diagnosed".into(),
                reason: format!(
                    "{n} alarm(s) ringing; ILM names {} [components: {}]",
                    fms.join(", "),
                    comps.join(", ")
                ),
            });
            Ok(comps.len() as i64)
        }
        "transact" => {
            let json: serde_json::Value = serde_json::from_str(&text(args.get(1)))
                .map_err(|e| format!("argument 1 is not JSON: {e}"))?;
            let ops = json.as_array().ok_or("a transaction is a list of ops")?;
            let t = sh.t;
            for op in ops {
                let (Some("attach"), Some(obj), Some(parent)) = (
                    op.get(0).and_then(|v| v.as_str()),
                    op.get(1).and_then(|v| v.as_str()),
                    op.get(2).and_then(|v| v.as_str()),
                ) else {
                    return Err(format!(
                        "{op}: only [\"attach\", OBJECT, PARENT] is known to the study's plant"
                    ));
                };
                let f = sh
                    .fault
                    .as_mut()
                    .ok_or("no fault model runs in this study")?;
                let (rule, action) = if parent == "eclss_isolated" {
                    f.isolated_at.get_or_insert(t);
                    ("isolate", "isolated")
                } else if parent == "eclss" && obj.ends_with("_spare") {
                    f.spare_at.get_or_insert(t);
                    ("reconfigure", "spare on line")
                } else {
                    return Err(format!("attach {obj} to {parent}: not a move of the plant"));
                };
                pending.push(Pending::Eval(format!(
                    "(do-for-all-facts ((?i instance)) (eq ?i:name {obj}) (retract ?i))"
                )));
                pending.push(Pending::Assert(format!(
                    "(instance (name {obj}) (kind solid) (parent {parent}))"
                )));
                sh.decisions.push(Decision {
                    t,
                    rule: format!("eclss_guard {rule}"),
                    target: obj.to_owned(),
                    action: action.into(),
                    reason: format!("the diagnosis names it: moved under {parent}"),
                });
            }
            sh.version += 1;
            Ok(sh.version)
        }
        other => Err(format!(
            "unknown command {other:?} (set-mode, start, stop, move, defer, decide, diagnose, transact)"
        )),
    }
}

impl Scheduler {
    /// The engine for `scheduling` with the fault `fault` (if any): `station_power.clp` when
    /// on, `eclss_guard.clp` when there is a fault; none without CLIPS (on is then refused:
    /// [`robosim_rules::RulesError::NotBuilt`]).
    pub fn new(scheduling: Scheduling, fault: Option<EclssFault>) -> Result<Scheduler> {
        let shared: Rc<RefCell<Shared>> = Rc::new(RefCell::new(Shared {
            fault,
            ..Shared::default()
        }));
        let has_fault = shared.borrow().fault.is_some();
        let want = scheduling == Scheduling::On || has_fault;
        let engine = if want && robosim_rules::BUILT_WITH_CLIPS || scheduling == Scheduling::On {
            let s2 = shared.clone();
            let mut e = Embedded::new(
                Box::new(move |args: &[Arg], pending: &mut Vec<Pending>| {
                    let mut sh = s2
                        .try_borrow_mut()
                        .map_err(|_| "the study's state is busy (a nested call)".to_owned())?;
                    handle(&mut sh, args, pending)
                }),
                Limits::default(),
            )
            .map_err(|e| StudyError::at("station scheduler", e))?;
            let load = |e: &mut Embedded, name: &str| -> Result<()> {
                let text = shipped(name).ok_or_else(|| {
                    StudyError::Message(format!("{name}: not a shipped rule base"))
                })?;
                e.load_text(name, text)
                    .map_err(|err| StudyError::at(name, err))
            };
            if scheduling == Scheduling::On {
                load(&mut e, "station_power.clp")?;
            }
            if has_fault {
                load(&mut e, "eclss_guard.clp")?;
                // the plant's units: on line under `eclss`, their spares under `eclss_spares`
                let names: Vec<String> = shared
                    .borrow()
                    .fault
                    .as_ref()
                    .map(|f| f.model.components.iter().map(|c| c.name.clone()).collect())
                    .unwrap_or_default();
                for c in names {
                    for (n, parent) in
                        [(c.clone(), "eclss"), (format!("{c}_spare"), "eclss_spares")]
                    {
                        e.assert_str(&format!(
                            "(instance (name {n}) (kind solid) (parent {parent}))"
                        ))
                        .map_err(|err| StudyError::at("eclss plant", err))?;
                    }
                }
            }
            Some(e)
        } else {
            None
        };
        Ok(Scheduler {
            scheduling,
            engine,
            shared,
            alarms_asserted: 0,
        })
    }

    /// Whether a rule engine runs (the fault is handled, or the loads scheduled).
    pub fn has_engine(&self) -> bool {
        self.engine.is_some()
    }

    /// The fault (its state, diagnoses and the plant's moves so far).
    pub fn fault(&self) -> Option<std::cell::Ref<'_, EclssFault>> {
        std::cell::Ref::filter_map(self.shared.borrow(), |s| s.fault.as_ref()).ok()
    }

    /// The decisions so far.
    pub fn decisions(&self) -> Vec<Decision> {
        self.shared.borrow().decisions.clone()
    }

    /// The decisions and the fault at the end of a run.
    pub fn finish(self) -> (Vec<Decision>, Option<EclssFault>) {
        let mut sh = self.shared.borrow_mut();
        (std::mem::take(&mut sh.decisions), sh.fault.take())
    }

    /// One step at `facts.t`: the fault's alarms and its consumer's demand, the rules run,
    /// their commands applied to `loads` (with the scheduler off: every load at full, each
    /// experiment started when asked for).
    pub fn step(&mut self, facts: &PlanFacts<'_>, loads: &mut Loads) -> Result<()> {
        let t = facts.t;
        self.shared.borrow_mut().t = t;
        self.apply_fault(t, loads);
        let Some(engine) = self.engine.as_mut() else {
            Self::unscheduled(t, loads);
            return Ok(());
        };
        let err = |e: robosim_rules::RulesError| {
            StudyError::at(format!("station scheduler at t = {t} s"), e)
        };
        // new alarms
        let ringing: Vec<(String, String, String, f64)> = {
            let sh = self.shared.borrow();
            match sh.fault.as_ref() {
                Some(f) => f
                    .ringing(t)
                    .into_iter()
                    .skip(self.alarms_asserted)
                    .map(|(a, at)| {
                        let (p, n, g) = f.alarm_text(a);
                        (p.to_owned(), n.to_owned(), g.to_owned(), at)
                    })
                    .collect(),
                None => Vec::new(),
            }
        };
        for (process, name, generator, at) in ringing {
            engine
                .assert_str(&format!(
                    "(alarm (source {process}) (kind {name}) (value {}) (message {}))",
                    num(at),
                    quote(&generator)
                ))
                .map_err(err)?;
            self.alarms_asserted += 1;
        }
        if self.scheduling == Scheduling::On {
            for tpl in [
                "sp-now",
                "sp-battery",
                "sp-phase",
                "sp-consumer",
                "sp-experiment",
                "sp-window",
                "sp-fault",
                "sp-plan",
                "sp-need-plan",
            ] {
                engine
                    .eval(&format!(
                        "(do-for-all-facts ((?f {tpl})) TRUE (retract ?f))"
                    ))
                    .map_err(err)?;
            }
            for f in Self::facts(facts, loads, self.shared.borrow().fault.as_ref()) {
                engine.assert_str(&f).map_err(err)?;
            }
        } else {
            Self::unscheduled(t, loads);
        }
        engine.run().map_err(err)?;
        let commands: Vec<Vec<Arg>> = self.shared.borrow_mut().commands.drain(..).collect();
        for c in commands {
            self.apply(t, &c, loads)?;
        }
        // the fault's consumer follows the plant's moves made in this pass
        self.apply_fault(t, loads);
        Ok(())
    }

    /// Without the scheduler: every consumer at full, every run asked for started.
    fn unscheduled(t: f64, loads: &mut Loads) {
        for m in &mut loads.modes {
            *m = Mode::Full;
        }
        for j in 0..loads.experiments.len() {
            if loads.waiting(j) && loads.exps[j].not_before <= t {
                loads.start(j);
            }
        }
    }

    /// The fault's consumers' demand at `t` ([`EclssFault::demand_factor`]).
    fn apply_fault(&self, t: f64, loads: &mut Loads) {
        let sh = self.shared.borrow();
        let Some(f) = sh.fault.as_ref() else { return };
        let k = f.demand_factor(t);
        for &i in &f.consumers {
            loads.full_w[i] = loads.consumers[i].full_w * k;
            loads.reduced_w[i] = loads.consumers[i].reduced_w * k;
        }
    }

    /// The `sp-*` facts of a step (module docs; station_power.clp's templates).
    fn facts(p: &PlanFacts<'_>, loads: &Loads, fault: Option<&EclssFault>) -> Vec<String> {
        let kwh = |j: f64| num(j / 3.6e6);
        let mut out = vec![
            format!(
                "(sp-now (t {}) (step {}) (reserve-kwh {}) (margin-kwh {}))",
                num(p.t),
                num(p.step_s),
                kwh(p.reserve_j),
                kwh(p.margin_j)
            ),
            format!(
                "(sp-battery (energy-kwh {}) (capacity-kwh {}) (charge-eff {}) (discharge-eff {}))",
                kwh(p.energy_j),
                kwh(p.capacity_j),
                num(p.charge_eff),
                num(p.discharge_eff)
            ),
        ];
        for (kind, a, b, w) in &p.forecast.phases {
            out.push(format!(
                "(sp-phase (kind {kind}) (start {}) (end {}) (power-kw {}))",
                num(*a),
                num(*b),
                num(w / 1e3)
            ));
        }
        for (i, c) in loads.consumers.iter().enumerate() {
            out.push(format!(
                "(sp-consumer (name {}) (priority {}) (mode {}) (full-kw {}) (reduced-kw {}))",
                c.name,
                c.priority.name(),
                loads.modes[i].name(),
                num(loads.full_w[i] / 1e3),
                num(loads.reduced_w[i] / 1e3)
            ));
        }
        for (e, x) in loads.experiments.iter().zip(&loads.exps) {
            if !(x.running || x.remaining_s > 0.0) {
                continue;
            }
            out.push(format!(
                "(sp-experiment (name {}) (power-kw {}) (remaining-s {}) (sensitive {}) (state {}) (not-before {}) (deferred {}))",
                e.name,
                num(e.power_w / 1e3),
                num(x.remaining_s),
                if e.sensitive { "yes" } else { "no" },
                if x.running { "running" } else { "waiting" },
                num(x.not_before),
                if x.deferred { "yes" } else { "no" }
            ));
        }
        for (kind, a, b) in p.windows {
            out.push(format!(
                "(sp-window (kind {kind}) (start {}) (end {}))",
                num(*a),
                num(*b)
            ));
        }
        if let Some(f) = fault {
            let st = f.state(p.t);
            if !matches!(st, FaultState::Healthy | FaultState::Repaired) {
                for &i in &f.consumers {
                    out.push(format!(
                        "(sp-fault (consumer {}) (component {}) (state {}) (demand-kw {}))",
                        loads.consumers[i].name,
                        f.components.join("+"),
                        st.name(),
                        num(loads.full_w[i] / 1e3)
                    ));
                }
            }
        }
        out.push("(sp-need-plan)".into());
        out
    }

    /// One command of station_power.clp applied to `loads`, recorded as a decision.
    fn apply(&mut self, t: f64, c: &[Arg], loads: &mut Loads) -> Result<()> {
        let (cmd, rule, target, value, reason) = (
            text(c.first()),
            text(c.get(1)),
            text(c.get(2)),
            c.get(3),
            text(c.get(4)),
        );
        let bad = |what: &str| {
            StudyError::Message(format!(
                "station_power.clp rule {rule} at t = {t} s: ({cmd} {target} …): {what}"
            ))
        };
        let exp = || loads.experiments.iter().position(|e| e.name == target);
        let at = || match value {
            Some(Arg::Num(x)) if x.is_finite() => Some(*x),
            _ => None,
        };
        let action = match cmd.as_str() {
            "set-mode" => {
                let i = loads
                    .consumers
                    .iter()
                    .position(|x| x.name == target)
                    .ok_or_else(|| bad("no such consumer"))?;
                let m =
                    Mode::parse(&text(value)).ok_or_else(|| bad("mode: full, reduced or off"))?;
                loads.modes[i] = m;
                m.name().to_owned()
            }
            "start" => {
                let j = exp().ok_or_else(|| bad("no such experiment"))?;
                loads.start(j);
                "start".into()
            }
            "stop" => {
                let j = exp().ok_or_else(|| bad("no such experiment"))?;
                let until = at().ok_or_else(|| bad("a time is needed"))?;
                loads.stop(j, until);
                format!("stop until {until:.0} s")
            }
            "move" => {
                let j = exp().ok_or_else(|| bad("no such experiment"))?;
                let until = at().ok_or_else(|| bad("a time is needed"))?;
                let before = loads.exps[j].not_before;
                loads.exps[j].not_before = until;
                // a predicted window moves a little as the prediction firms up, and the run
                // with it: applied every time, recorded when the run was startable or the move
                // shifts it by more than MOVE_RECORDED_S
                if before > t && (until - before).abs() <= MOVE_RECORDED_S {
                    return Ok(());
                }
                loads.exps[j].moved += 1;
                format!("move to {until:.0} s")
            }
            "defer" => {
                let j = exp().ok_or_else(|| bad("no such experiment"))?;
                loads.exps[j].deferred = true;
                "defer".into()
            }
            _ => return Err(bad("not a command of the scheduler")),
        };
        self.shared.borrow_mut().decisions.push(Decision {
            t,
            rule: format!("station_power {rule}"),
            target,
            action,
            reason,
        });
        Ok(())
    }
}
