//! An ECLSS fault in the station study (issue 38 item 4): a failure mode of the shipped ECLSS
//! fault model (`robosim_automation`, seed §4.3) injected at a time; its alarms ring as the
//! alarm pattern simulator propagates it (every edge firing, delays from a fixed seed — as the
//! session's automation plant does); the diagnosis (ILM over the alarms rung so far, the query
//! protocol's `diag_diagnose`) names the components; `eclss_guard.clp` isolates the unit and
//! brings its spare on line ([`super::scheduler`]); the consumer whose process failed changes
//! its demand meanwhile ([`EclssFault::demand_factor`]):
//!
//! * failed, isolated, spare starting: the process stands still — its consumer draws
//!   [`STANDBY`] of its demand (controller, heaters) and the work it does not do piles up;
//! * the spare on line, after [`SPARE_START_S`]: the process catches up at [`CATCH_UP`] times
//!   its demand until the work missed is made up, then runs as before.
//!
//! Entry points: [`FaultSpec::parse`], [`EclssFault::new`].

use crate::{Result, StudyError, bail};
use robosim_automation::diag::{FaultGraph, Ilm};
use robosim_automation::model::{AlarmId, FmId, Model, load_model};
use robosim_automation::sim::{AlarmEvent, SimOptions, simulate};
use robosim_simulator::consumers::Consumer;

/// The fault model's constants (the simulator's, shared with the daemon's ops stage).
pub use robosim_simulator::consumers::{CATCH_UP, SPARE_START_S, STANDBY};

/// `FAILURE_MODE@T`: a failure mode of the ECLSS model (a unique dotted tail of its path,
/// `pump_failure`) injected at T seconds into the run.
#[derive(Debug, Clone, PartialEq)]
pub struct FaultSpec {
    pub failure_mode: String,
    pub t_s: f64,
}

impl FaultSpec {
    /// Reads `FAILURE_MODE@T` (T in seconds ≥ 0).
    pub fn parse(s: &str) -> Result<FaultSpec> {
        let Some((fm, t)) = s.rsplit_once('@') else {
            bail!("--fault {s:?}: expected FAILURE_MODE@SECONDS, e.g. pump_failure@3000");
        };
        let t_s: f64 = t
            .trim()
            .parse()
            .map_err(|e| StudyError::at(format!("--fault {s:?}: time {t:?}"), e))?;
        if !(t_s.is_finite() && t_s >= 0.0) {
            bail!("--fault {s:?}: time {t_s}: expected seconds ≥ 0");
        }
        Ok(FaultSpec {
            failure_mode: fm.trim().to_owned(),
            t_s,
        })
    }
}

/// Where the fault stands at a time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FaultState {
    Healthy,
    Failed,
    Isolated,
    SpareStarting,
    CatchingUp,
    Repaired,
}

impl FaultState {
    /// The rule base's name for it (`sp-fault` facts).
    pub fn name(self) -> &'static str {
        match self {
            FaultState::Healthy => "healthy",
            FaultState::Failed => "failed",
            FaultState::Isolated => "isolated",
            FaultState::SpareStarting => "spare-starting",
            FaultState::CatchingUp => "catching-up",
            FaultState::Repaired => "repaired",
        }
    }
}

/// One injected fault over the run.
#[derive(Debug, Clone)]
pub struct EclssFault {
    pub model: Model,
    pub graph: FaultGraph,
    pub spec: FaultSpec,
    pub fm: FmId,
    /// Its complete alarm sequence (absolute times, s).
    pub alarms: Vec<AlarmEvent>,
    /// The failure mode's components (the units the rules isolate and replace).
    pub components: Vec<String>,
    /// The consumers (indices) whose subsystem holds the failed process.
    pub consumers: Vec<usize>,
    /// When the rules isolated the unit and brought its spare on line, s.
    pub isolated_at: Option<f64>,
    pub spare_at: Option<f64>,
    /// The diagnoses made: time, failure modes, components, alarms used.
    pub diagnoses: Vec<(f64, Vec<String>, Vec<String>, usize)>,
}

impl EclssFault {
    /// The fault of `spec` on the shipped ECLSS model, its alarms simulated; the consumers
    /// (of `consumers`) whose subsystem is a prefix of the failed process's path.
    pub fn new(spec: &FaultSpec, consumers: &[Consumer]) -> Result<EclssFault> {
        let model = load_model("eclss").map_err(StudyError::from)?;
        let fm = model
            .find_failure_mode(&spec.failure_mode)
            .map_err(|e| StudyError::Message(format!("--fault: {e}")))?;
        let f = &model.failure_modes[fm];
        if f.derived {
            bail!(
                "--fault {}: a derived failure mode (a consequence, not a fault to inject); the model's faults are those with components",
                f.path
            );
        }
        let process = &model.processes[f.process].path;
        let hit: Vec<usize> = consumers
            .iter()
            .enumerate()
            .filter(|(_, c)| {
                process == c.subsystem || process.starts_with(&format!("{}.", c.subsystem))
            })
            .map(|(i, _)| i)
            .collect();
        if hit.is_empty() {
            bail!(
                "--fault {}: its process {process} is no consumer's subsystem ({})",
                f.path,
                consumers
                    .iter()
                    .map(|c| c.subsystem)
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        let components = f
            .components
            .iter()
            .map(|&c| model.components[c].name.clone())
            .collect();
        let graph = FaultGraph::new(&model);
        let alarms = simulate(&graph, &[(fm, spec.t_s)], &SimOptions::default()).alarms;
        Ok(EclssFault {
            spec: spec.clone(),
            fm,
            alarms,
            components,
            consumers: hit,
            isolated_at: None,
            spare_at: None,
            diagnoses: Vec::new(),
            model,
            graph,
        })
    }

    /// The alarms rung by `t` while the fault is not repaired (a spare on line stops them, as
    /// in the session's plant).
    pub fn ringing(&self, t: f64) -> Vec<(AlarmId, f64)> {
        if self.spare_at.is_some_and(|s| s <= t) {
            return Vec::new();
        }
        self.alarms
            .iter()
            .filter(|a| a.time <= t)
            .map(|a| (a.alarm, a.time))
            .collect()
    }

    /// ILM over the alarms ringing at `t` (the query protocol's `diag_diagnose`): the failure
    /// modes and components it names, and how many alarms it used; recorded.
    pub fn diagnose(&mut self, t: f64) -> (Vec<String>, Vec<String>, usize) {
        let ringing = self.ringing(t);
        let mut ilm = Ilm::new(&self.model, &self.graph, None);
        for batch in ringing.chunk_by(|x, y| x.1 == y.1) {
            // alarms of the model itself, in time order: refused only on a bug here
            if ilm.on_alarms(batch).is_err() {
                return (Vec::new(), Vec::new(), ringing.len());
            }
        }
        ilm.run_to_completion();
        let (fms, comps) = match ilm.best_guess() {
            Some(g) => (
                g.failure_modes
                    .iter()
                    .map(|&f| self.model.failure_modes[f].path.clone())
                    .collect(),
                g.components
                    .iter()
                    .map(|&c| self.model.components[c].name.clone())
                    .collect(),
            ),
            None => (Vec::new(), Vec::new()),
        };
        self.diagnoses
            .push((t, fms.clone(), comps.clone(), ringing.len()));
        (fms, comps, ringing.len())
    }

    /// The fault's state at `t`.
    pub fn state(&self, t: f64) -> FaultState {
        if t < self.spec.t_s {
            return FaultState::Healthy;
        }
        match (self.isolated_at, self.spare_at) {
            (_, Some(s)) if t < s + SPARE_START_S => FaultState::SpareStarting,
            (_, Some(s)) => {
                if t < s + SPARE_START_S + self.catch_up_s(s) {
                    FaultState::CatchingUp
                } else {
                    FaultState::Repaired
                }
            }
            (Some(_), None) => FaultState::Isolated,
            (None, None) => FaultState::Failed,
        }
    }

    /// How long the catch-up takes when the spare came on line at `spare`: the work missed
    /// from the fault to the spare running, made up at (CATCH_UP − 1) × the demand.
    fn catch_up_s(&self, spare: f64) -> f64 {
        robosim_simulator::consumers::catch_up_s(self.spec.t_s, spare)
    }

    /// The share of its demand the failed process's consumer draws at `t`.
    pub fn demand_factor(&self, t: f64) -> f64 {
        match self.state(t) {
            FaultState::Healthy | FaultState::Repaired => 1.0,
            FaultState::Failed | FaultState::Isolated | FaultState::SpareStarting => STANDBY,
            FaultState::CatchingUp => CATCH_UP,
        }
    }

    /// The alarm's process path and generator text (the `alarm` fact's source and message).
    pub fn alarm_text(&self, a: AlarmId) -> (&str, &str, &str) {
        let al = &self.model.alarms[a];
        (
            &self.model.processes[al.process].path,
            &al.name,
            al.generator.as_deref().unwrap_or(""),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use robosim_simulator::consumers::default_consumers;

    #[test]
    fn a_failed_pump_rings_its_alarms_is_diagnosed_and_its_consumer_stands_still_then_catches_up() {
        let spec = FaultSpec::parse("pump_failure@1000").expect("a spec");
        let c = default_consumers(100e3);
        let mut f = EclssFault::new(&spec, &c).expect("the fault");
        assert_eq!(f.components, vec!["water_pump".to_owned()]);
        assert_eq!(
            f.consumers.iter().map(|&i| c[i].name).collect::<Vec<_>>(),
            vec!["potable_water"]
        );
        assert!(f.ringing(999.0).is_empty());
        assert!(f.alarms.iter().all(|a| a.time >= 1000.0));
        let (_, comps, n) = f.diagnose(2000.0);
        assert!(
            n >= 1 && comps.contains(&"water_pump".to_owned()),
            "{comps:?}"
        );
        assert_eq!(f.state(500.0), FaultState::Healthy);
        assert_eq!(f.demand_factor(1500.0), STANDBY);
        f.isolated_at = Some(1600.0);
        f.spare_at = Some(1700.0);
        assert_eq!(f.state(1800.0), FaultState::SpareStarting);
        // missed 1000 s of work; made up at twice the demand over the next 1000 s
        assert_eq!(f.state(2100.0), FaultState::CatchingUp);
        assert_eq!(f.state(2999.0), FaultState::CatchingUp);
        assert_eq!(f.state(3001.0), FaultState::Repaired);
        assert!(f.ringing(1800.0).is_empty());
    }

    #[test]
    fn bad_faults_are_refused_by_name() {
        let c = default_consumers(100e3);
        for (s, why) in [
            ("pump_failure", "FAILURE_MODE@SECONDS"),
            ("pump_failure@-3", "≥ 0"),
            ("no_such_thing@10", "no_such_thing"),
            ("no_flow@10", "derived"),
        ] {
            let e = FaultSpec::parse(s)
                .and_then(|f| EclssFault::new(&f, &c))
                .err()
                .unwrap_or_else(|| panic!("{s} accepted"));
            assert!(e.to_string().contains(why), "{s}: {e}");
        }
    }
}
