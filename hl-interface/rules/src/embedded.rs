//! A rule base run inside another program's loop (no session): the caller asserts its own
//! facts, runs the rules, and the rules answer through `(robosim COMMAND ARGS…)` calls its
//! [`EmbeddedHandler`] takes. `robosim study station --scheduler on` runs `station_power.clp`
//! (with `eclss_guard.clp`) this way.
//!
//! It exists in every build; without CLIPS [`Embedded::new`] fails with
//! [`RulesError::NotBuilt`] (what to install) and nothing else can be reached.
//!
//! What a handler returns to CLIPS is an integer (the calls' convention, [`crate::clips`]);
//! facts it wants asserted in answer (a diagnosis, a changed instance) and expressions it wants
//! evaluated (a retraction) go into the [`Pending`] list it is given, applied once the run
//! returns, and the rules run again until nothing is pending — as `robosim rules` does for its
//! `query` and `diagnose` answers.
//!
//! Entry points: [`Embedded::new`], [`Embedded::load_text`], [`Embedded::assert_str`],
//! [`Embedded::eval`], [`Embedded::run`], [`shipped`].

use crate::RulesError;
use crate::clips::{Arg, Limits};

/// What a handler asks to be done once the rules stop: facts asserted, expressions evaluated
/// (in that order of arrival).
#[derive(Debug, Clone, PartialEq)]
pub enum Pending {
    Assert(String),
    Eval(String),
}

/// `(robosim COMMAND ARGS…)` in an embedded rule base: the args (COMMAND first), the list of
/// things to do after the run → an integer for CLIPS, or the failure's message (asserted as a
/// `robosim-error` fact, as in a session).
pub type EmbeddedHandler = Box<dyn FnMut(&[Arg], &mut Vec<Pending>) -> Result<i64, String>>;

/// The rule bases shipped in `hl-interface/rules/rulebases/`, by file name, with their text
/// (compiled in: a binary run away from the sources has them).
pub const SHIPPED: &[(&str, &str)] = &[
    (
        "joint_guard.clp",
        include_str!("../rulebases/joint_guard.clp"),
    ),
    (
        "eclss_guard.clp",
        include_str!("../rulebases/eclss_guard.clp"),
    ),
    (
        "station_power.clp",
        include_str!("../rulebases/station_power.clp"),
    ),
    // The scheduler handles faults with eclss_guard.clp's rules: the two loaded as one text
    // (station_ops.clp's header).
    (
        "station_ops.clp",
        concat!(
            include_str!("../rulebases/eclss_guard.clp"),
            "\n",
            include_str!("../rulebases/station_ops.clp")
        ),
    ),
    ("oru_swap.clp", include_str!("../rulebases/oru_swap.clp")),
];

/// The text of the shipped rule base `name` (`station_power.clp`, …).
pub fn shipped(name: &str) -> Option<&'static str> {
    SHIPPED.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

/// One CLIPS environment run by its caller ([module docs](self)).
pub struct Embedded {
    #[cfg(clips)]
    clips: crate::clips::Clips,
    #[cfg(clips)]
    pending: std::rc::Rc<std::cell::RefCell<Vec<Pending>>>,
    #[cfg(not(clips))]
    never: std::convert::Infallible,
}

#[cfg(clips)]
impl Embedded {
    /// A new environment with the session bridge's templates ([`crate::TEMPLATES`]: `alarm`,
    /// `diagnosis`, `instance`, `robosim-error`, …), its `(robosim …)` calls going to
    /// `handler`, each run bounded by `limits`.
    pub fn new(mut handler: EmbeddedHandler, limits: Limits) -> Result<Embedded, RulesError> {
        let pending: std::rc::Rc<std::cell::RefCell<Vec<Pending>>> = Default::default();
        let p2 = pending.clone();
        let mut clips = crate::clips::Clips::with_limits(
            Box::new(move |args: &[Arg]| {
                let mut p = p2
                    .try_borrow_mut()
                    .map_err(|_| "a nested (robosim …) call".to_owned())?;
                handler(args, &mut p)
            }),
            limits,
        )?;
        for t in crate::TEMPLATES {
            clips.build(t)?;
        }
        Ok(Embedded { clips, pending })
    }

    /// Loads a rule base given as text (`name` says which in errors): written to a private
    /// temporary file that CLIPS loads, then removed; deffacts asserted.
    pub fn load_text(&mut self, name: &str, text: &str) -> Result<(), RulesError> {
        let dir = std::env::temp_dir().join(format!(
            "robosim-rules-{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
        ));
        let io = |e: std::io::Error| {
            RulesError::Clips(crate::clips::ClipsError::Load {
                path: format!("{} ({name}): {e}", dir.display()),
                what: "write a copy of it",
            })
        };
        std::fs::create_dir_all(&dir).map_err(io)?;
        let path = dir.join(name);
        let r = std::fs::write(&path, text)
            .map_err(io)
            .and_then(|()| self.clips.load(&path).map_err(RulesError::from));
        let _ = std::fs::remove_dir_all(&dir);
        r
    }

    /// Asserts one fact given as text.
    pub fn assert_str(&mut self, fact: &str) -> Result<(), RulesError> {
        Ok(self.clips.assert_str(fact)?)
    }

    /// Evaluates one expression for its effect (a retraction, a `modify`).
    pub fn eval(&mut self, expr: &str) -> Result<(), RulesError> {
        Ok(self.clips.eval(expr)?)
    }

    /// Runs the rules to quiescence, applying what the handler left pending after each run
    /// and running again until nothing is; the rules fired.
    pub fn run(&mut self) -> Result<i64, RulesError> {
        let mut fired = 0;
        loop {
            fired += self.clips.run(-1).map_err(RulesError::Limit)?;
            let todo: Vec<Pending> = self.pending.borrow_mut().drain(..).collect();
            if todo.is_empty() {
                return Ok(fired);
            }
            for p in todo {
                match p {
                    Pending::Assert(f) => self.clips.assert_str(&f)?,
                    Pending::Eval(e) => self.clips.eval(&e)?,
                }
            }
        }
    }
}

#[cfg(clips)]
static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

#[cfg(not(clips))]
impl Embedded {
    /// This build has no CLIPS: [`RulesError::NotBuilt`].
    pub fn new(handler: EmbeddedHandler, limits: Limits) -> Result<Embedded, RulesError> {
        let _ = (handler, limits);
        Err(RulesError::NotBuilt)
    }

    pub fn load_text(&mut self, _name: &str, _text: &str) -> Result<(), RulesError> {
        match self.never {}
    }

    pub fn assert_str(&mut self, _fact: &str) -> Result<(), RulesError> {
        match self.never {}
    }

    pub fn eval(&mut self, _expr: &str) -> Result<(), RulesError> {
        match self.never {}
    }

    pub fn run(&mut self) -> Result<i64, RulesError> {
        match self.never {}
    }
}

#[cfg(all(test, clips))]
mod tests {
    use super::*;
    use std::cell::RefCell;
    use std::rc::Rc;

    type Calls = Rc<RefCell<Vec<Vec<String>>>>;

    /// station_power.clp in an embedded engine; every `(robosim …)` call recorded as text.
    fn engine() -> (Embedded, Calls) {
        let calls: Calls = Rc::default();
        let c2 = calls.clone();
        let mut e = Embedded::new(
            Box::new(move |args: &[Arg], _p: &mut Vec<Pending>| {
                c2.borrow_mut().push(
                    args.iter()
                        .map(|a| match a {
                            Arg::Num(x) => format!("{x}"),
                            Arg::Text(t) => t.clone(),
                        })
                        .collect(),
                );
                Ok(0)
            }),
            Limits::default(),
        )
        .expect("an environment");
        e.load_text(
            "station_power.clp",
            shipped("station_power.clp").expect("shipped"),
        )
        .expect("station_power.clp loads");
        (e, calls)
    }

    /// A station at `energy` kWh of 150 with one orbit ahead (60 min sunlit at `sun` kW, 35 min
    /// eclipse), the §4.3 consumers at full and one experiment.
    fn facts(e: &mut Embedded, energy: f64, sun: f64, sensitive: &str, window: Option<(f64, f64)>) {
        for f in [
            "(sp-now (t 0.0) (step 10.0) (reserve-kwh 37.5) (margin-kwh 7.5))".to_owned(),
            format!(
                "(sp-battery (energy-kwh {energy:?}) (capacity-kwh 150.0) (charge-eff 0.9) (discharge-eff 0.9))"
            ),
            format!("(sp-phase (kind sunlit) (start 0.0) (end 3600.0) (power-kw {sun:?}))"),
            "(sp-phase (kind eclipse) (start 3600.0) (end 5700.0) (power-kw 0.0))".to_owned(),
            "(sp-consumer (name station_base) (priority vital) (mode full) (full-kw 100.0) (reduced-kw 100.0))".to_owned(),
            "(sp-consumer (name air_crew) (priority vital) (mode full) (full-kw 18.0) (reduced-kw 18.0))".to_owned(),
            "(sp-consumer (name air_experiment) (priority reducible) (mode full) (full-kw 18.0) (reduced-kw 7.0))".to_owned(),
            "(sp-consumer (name hygiene) (priority sheddable) (mode full) (full-kw 6.0) (reduced-kw 6.0))".to_owned(),
            format!(
                "(sp-experiment (name furnace) (power-kw 30.0) (remaining-s 3600.0) (sensitive {sensitive}) (state waiting) (not-before 0.0))"
            ),
        ] {
            e.assert_str(&f).expect("a fact");
        }
        // the window after the experiment: the rules must not depend on the facts' order
        if let Some((a, b)) = window {
            e.assert_str(&format!(
                "(sp-window (kind desaturation) (start {a:?}) (end {b:?}))"
            ))
            .expect("a window");
        }
        e.assert_str("(sp-need-plan)").expect("a fact");
    }

    fn verbs(calls: &Calls) -> Vec<(String, String)> {
        calls
            .borrow()
            .iter()
            .map(|c| (c[1].clone(), c[2].clone()))
            .collect()
    }

    /// Short of energy: hygiene is deferred first, then the experiment modules' air control
    /// reduced; the crew modules' never; the experiment not started; each with its reason.
    #[test]
    fn short_of_energy_the_rules_shed_hygiene_then_experiment_air_never_crew_air() {
        let (mut e, calls) = engine();
        // 200 kW for an hour, 0 for 35 min against ~142 kW: the eclipse takes ~55 kWh from 60
        facts(&mut e, 60.0, 200.0, "no", None);
        e.run().expect("the rules run");
        let v = verbs(&calls);
        let pos = |rule: &str| v.iter().position(|(r, _)| r == rule);
        let hyg = pos("sp-defer-hygiene").expect("hygiene deferred");
        let air = pos("sp-reduce-experiment-air").expect("experiment air reduced");
        assert!(hyg < air, "{v:?}");
        assert!(!v.iter().any(|(_, t)| t == "air_crew"), "{v:?}");
        assert!(pos("sp-start-experiment").is_none(), "{v:?}");
        assert!(
            calls
                .borrow()
                .iter()
                .all(|c| c.last().is_some_and(|r| r.contains("kWh"))),
            "every decision says why: {:?}",
            calls.borrow()
        );
    }

    /// Regression: the plan once counted a running experiment's load over the whole orbit while
    /// the start rule counted it only until the run ends, so a run ending before the eclipse
    /// was started, then hygiene shed and the run stopped for the energy, then both restored
    /// and started again — until the 5 s limit halted the rules. Now started once, nothing shed.
    #[test]
    fn a_run_ending_before_the_eclipse_is_started_once_and_nothing_cycles() {
        let (mut e, calls) = engine();
        // with the furnace until t = 3600 s: 115 + 25.2 − 92.0 = 48.2 kWh ≥ 45 at the eclipse's end
        facts(&mut e, 115.0, 200.0, "no", None);
        e.run().expect("the rules come to rest");
        let v = verbs(&calls);
        assert_eq!(
            v,
            vec![("sp-start-experiment".into(), "furnace".into())],
            "{v:?}"
        );
    }

    /// With room: a non-sensitive experiment starts; a sensitive one whose run would meet a
    /// desaturation window is moved after it and not started.
    #[test]
    fn with_room_an_experiment_starts_unless_a_desaturation_window_is_in_its_way() {
        let (mut e, calls) = engine();
        facts(&mut e, 140.0, 300.0, "no", Some((1800.0, 2400.0)));
        e.run().expect("the rules run");
        let v = verbs(&calls);
        assert!(
            v.contains(&("sp-start-experiment".into(), "furnace".into())),
            "{v:?}"
        );
        let (mut e, calls) = engine();
        facts(&mut e, 140.0, 300.0, "yes", Some((1800.0, 2400.0)));
        e.run().expect("the rules run");
        let c = calls.borrow();
        let moved = c
            .iter()
            .find(|c| c[1] == "sp-move-experiment")
            .expect("moved");
        assert_eq!(moved[3], "2400", "{c:?}");
        // moved first, not after some other rule happened to touch the experiment's fact
        assert_eq!(c[0][1], "sp-move-experiment", "{c:?}");
        assert!(!c.iter().any(|c| c[1] == "sp-start-experiment"), "{c:?}");
    }
}

#[cfg(all(test, not(clips)))]
#[test]
fn the_embedded_engine_says_it_is_not_built() {
    assert!(crate::skipped_without_clips(
        "robosim-rules embedded engine tests"
    ));
    assert!(matches!(
        Embedded::new(Box::new(|_, _| Ok(0)), Limits::default()),
        Err(RulesError::NotBuilt)
    ));
}
