//! `robosim automation --session S [--model eclss]`: the automation layer's plant on a session —
//! the seed's Monitoring sub-system (§4.3, figure 6): it runs a Hierarchical Fault Model (the
//! shipped ECLSS model by default), takes injected faults, and publishes the alarms they raise
//! over time, as the model's propagation edges say.
//!
//! **The plant in the Instance Space.** At start the process makes sure the session holds the
//! plant's units, in one transaction (journaled like any other): an item named after the model
//! (`eclss`) holding one solid per component of the model (`co2_sorbent_bed`, …) — the units
//! on line —, an item `<model>_spares` holding one spare per component (`co2_sorbent_bed_spare`),
//! and an empty item `<model>_isolated`. Where a unit hangs is its state, and it is read back
//! from the committed model on every change:
//! * a component's unit moved under `<model>_isolated` is **isolated**: the faults of that
//!   component stop propagating (alarms their propagation would raise later do not ring);
//! * a spare moved under `<model>` is **on line**: once every component of a fault is isolated
//!   and replaced by its spare on line, that fault is **repaired** and its alarms stop ringing.
//!
//! So isolation and reconfiguration are ordinary transactions (a rule base's, a planner's, the
//! editor's), journaled and seen by every reader; this process only follows them.
//!
//! **Commands** on `state/automation/commands` (the simulator's command channel, JSON):
//! `{"cmd": "fault", "fault": NAME}` injects a failure mode (its name or path in the model) now;
//! `{"cmd": "get"}` answers the state:
//!
//! ```json
//! {"model": "eclss", "source": "eclss", "t_s": 12.5, "time_scale": 1.0,
//!  "faults": [{"fault": "ECLSS.AirControl.CO2Processing.CO2Removal.sorbent_bed_failure",
//!              "t_s": 3.0, "components": ["co2_sorbent_bed"], "contained": false, "repaired": false}],
//!  "alarms": [{"alarm": "A_co2_bed", "process": "ECLSS.AirControl.CO2Processing.CO2Removal",
//!              "t_s": 3.0, "message": "bed_temperature(co2_sorbent_bed) > 200 C"}],
//!  "online": ["cabin_fan", …], "isolated": [], "spares_online": []}
//! ```
//!
//! Time is the plant's own clock: seconds since the process started, times `--time-scale`.
//! Propagation is the alarm pattern simulator's (`robosim_automation::sim`) with every edge
//! firing (the seed's "complete alarm sequence") and delays drawn from a fixed seed, so one
//! fault gives the same alarm sequence every run.

use crate::ProtocolError;
use robosim_automation::diag::FaultGraph;
use robosim_automation::model::{Model, load_model};
use robosim_automation::sim::{AlarmEvent, SimOptions, simulate};
use robosim_instance_space::state::CommandReceiver;
use robosim_instance_space::{Client, Id, Kind, Reader, Session, Snapshot, Transaction};
use serde_json::{Value, json};
use std::collections::BTreeSet;
use std::time::{Duration, Instant};

/// The command service name (`state/automation/commands`).
pub const SERVICE: &str = "automation";

/// Seed of the propagation delays.
const SEED: u64 = 1;

#[derive(Debug, thiserror::Error)]
pub enum PlantError {
    #[error("model {model}: {message}")]
    Model { model: String, message: String },
    #[error("session: {0}")]
    Session(String),
    #[error("--time-scale {0} must be a positive number")]
    TimeScale(f64),
}

fn session_err(e: impl std::fmt::Display) -> PlantError {
    PlantError::Session(e.to_string())
}

/// One injected fault.
struct Fault {
    fm: usize,
    t: f64,
    /// Its complete alarm sequence (absolute plant times).
    events: Vec<AlarmEvent>,
    /// When all its components were first seen isolated.
    contained_at: Option<f64>,
    repaired: bool,
}

/// The plant: the fault model, the injected faults and where the units hang.
pub struct Plant {
    name: String,
    /// The model as given (a shipped name or a file path): what `diag_diagnose` loads.
    source: String,
    model: Model,
    graph: FaultGraph,
    faults: Vec<Fault>,
    online: BTreeSet<String>,
    isolated: BTreeSet<String>,
    spares_online: BTreeSet<String>,
}

/// The name of a component's spare.
pub fn spare_name(component: &str) -> String {
    format!("{component}_spare")
}

impl Plant {
    /// The plant of a shipped model name or model file.
    pub fn new(model: &str) -> Result<Plant, PlantError> {
        let m = load_model(model).map_err(|e| PlantError::Model {
            model: model.to_owned(),
            message: e.to_string(),
        })?;
        let name = std::path::Path::new(model)
            .file_stem()
            .map_or(model.to_owned(), |s| s.to_string_lossy().to_lowercase());
        Ok(Plant {
            name,
            source: model.to_owned(),
            graph: FaultGraph::new(&m),
            online: m.components.iter().map(|c| c.name.clone()).collect(),
            model: m,
            faults: Vec::new(),
            isolated: BTreeSet::new(),
            spares_online: BTreeSet::new(),
        })
    }

    /// The item holding the units on line (`eclss`); `_spares` and `_isolated` follow it.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The transaction that creates the plant's units, or `None` when the session holds them.
    pub fn setup(&self, snap: &Snapshot) -> Option<Transaction> {
        if snap.find(&self.name).is_some() {
            return None;
        }
        let mut tx = Transaction::new();
        let online = tx.create(Kind::Item, &self.name, None);
        let spares = tx.create(Kind::Item, &format!("{}_spares", self.name), None);
        tx.create(Kind::Item, &format!("{}_isolated", self.name), None);
        for c in &self.model.components {
            tx.create(Kind::Solid, &c.name, Some(online));
            tx.create(Kind::Solid, &spare_name(&c.name), Some(spares));
        }
        Some(tx)
    }

    /// Reads where the units hang in `snap` and updates containment and repair at time `now`.
    pub fn follow(&mut self, snap: &Snapshot, now: f64) {
        let under = |item: &str| -> BTreeSet<String> {
            let Some(i) = snap.find(item) else {
                return BTreeSet::new();
            };
            let id: Id = snap.rec(i).id;
            snap.children(id).map(|k| snap.name(k).to_owned()).collect()
        };
        let on = under(&self.name);
        self.isolated = under(&format!("{}_isolated", self.name));
        self.online = self
            .model
            .components
            .iter()
            .map(|c| c.name.clone())
            .filter(|c| on.contains(c))
            .collect();
        self.spares_online = self
            .model
            .components
            .iter()
            .map(|c| spare_name(&c.name))
            .filter(|s| on.contains(s))
            .collect();
        for f in &mut self.faults {
            let comps = &self.model.failure_modes[f.fm].components;
            let name = |c: &usize| self.model.components[*c].name.clone();
            let contained =
                !comps.is_empty() && comps.iter().all(|c| self.isolated.contains(&name(c)));
            if contained && f.contained_at.is_none() {
                f.contained_at = Some(now);
            }
            f.repaired = contained
                && comps
                    .iter()
                    .all(|c| self.spares_online.contains(&spare_name(&name(c))));
        }
    }

    /// Injects the failure mode `name` (name or path) at time `now`.
    pub fn inject(&mut self, name: &str, now: f64) -> Result<(), String> {
        let fm = self.model.find_failure_mode(name)?;
        if self.model.failure_modes[fm].derived {
            return Err(format!(
                "{} is a derived failure mode (only ever a consequence): inject an originating one",
                self.model.failure_modes[fm].path
            ));
        }
        let opts = SimOptions {
            seed: SEED,
            ..SimOptions::default()
        };
        let events = simulate(&self.graph, &[(fm, now)], &opts).alarms;
        self.faults.push(Fault {
            fm,
            t: now,
            events,
            contained_at: None,
            repaired: false,
        });
        Ok(())
    }

    /// The alarms ringing at `now`: every alarm of a fault that is not repaired and has rung by
    /// then (for a contained fault, only those that rang before it was contained), once each,
    /// earliest first.
    pub fn ringing(&self, now: f64) -> Vec<(usize, f64)> {
        let mut out: Vec<(usize, f64)> = Vec::new();
        for f in self.faults.iter().filter(|f| !f.repaired) {
            let until = f.contained_at.map_or(now, |c| c.min(now));
            for e in f.events.iter().filter(|e| e.time <= until) {
                match out.iter_mut().find(|(a, _)| *a == e.alarm) {
                    Some(seen) => seen.1 = seen.1.min(e.time),
                    None => out.push((e.alarm, e.time)),
                }
            }
        }
        out.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        out
    }

    /// The `get` answer (module docs).
    pub fn state(&self, now: f64, time_scale: f64) -> Value {
        let m = &self.model;
        json!({
            "model": self.name,
            "source": self.source,
            "t_s": now,
            "time_scale": time_scale,
            "faults": self.faults.iter().map(|f| json!({
                "fault": m.failure_modes[f.fm].path,
                "t_s": f.t,
                "components": m.failure_modes[f.fm].components.iter().map(|&c| m.components[c].name.clone()).collect::<Vec<_>>(),
                "contained": f.contained_at.is_some(),
                "repaired": f.repaired,
            })).collect::<Vec<_>>(),
            "alarms": self.ringing(now).iter().map(|&(a, t)| json!({
                "alarm": m.alarms[a].name,
                "process": m.processes[m.alarms[a].process].path,
                "t_s": t,
                "message": m.alarms[a].generator.clone().unwrap_or_default(),
            })).collect::<Vec<_>>(),
            "online": self.online,
            "isolated": self.isolated,
            "spares_online": self.spares_online,
        })
    }

    /// Answers one command (module docs) at plant time `now`.
    pub fn command(&mut self, cmd: &Value, now: f64, time_scale: f64) -> Result<Value, String> {
        match cmd.get("cmd").and_then(Value::as_str) {
            Some("get") => Ok(self.state(now, time_scale)),
            Some("fault") => {
                let name = cmd
                    .get("fault")
                    .and_then(Value::as_str)
                    .ok_or("`fault` (a failure mode's name) is required")?;
                self.inject(name, now)?;
                Ok(self.state(now, time_scale))
            }
            other => Err(format!("unknown command {other:?} (fault, get)")),
        }
    }
}

/// `robosim automation`: runs until SIGTERM/SIGINT.
pub fn run(session: Option<&str>, model: &str, time_scale: f64) -> Result<(), PlantError> {
    if !(time_scale.is_finite() && time_scale > 0.0) {
        return Err(PlantError::TimeScale(time_scale));
    }
    let mut plant = Plant::new(model)?;
    let session = Session::existing(session).map_err(session_err)?;
    let signals = session
        .node("automation-signals", true)
        .map_err(session_err)?;
    let mut reader = Reader::attach(&session, "automation").map_err(session_err)?;
    let mut commands = CommandReceiver::create(&session, SERVICE).map_err(session_err)?;
    let snap = reader
        .snapshot()
        .ok_or_else(|| PlantError::Session("the keeper has published no model".into()))?;
    if let Some(tx) = plant.setup(&snap) {
        let mut client = Client::connect(&session, "automation").map_err(session_err)?;
        let c = client.transact(&tx).map_err(session_err)?;
        eprintln!(
            "automation: the {} plant's units created at version {}",
            plant.name(),
            c.version
        );
    }
    drop(snap);
    let _reg = session
        .register(
            "automation",
            &[
                "space/objects",
                "space/poses",
                "space/changes",
                "state/automation/commands",
            ],
        )
        .map_err(session_err)?;
    let start = Instant::now();
    let now = || start.elapsed().as_secs_f64() * time_scale;
    reader.refresh().map_err(session_err)?;
    if let Some(s) = reader.snapshot() {
        plant.follow(&s, now());
    }
    eprintln!(
        "automation: model {} on session {} ({} components, {} alarms)",
        plant.name(),
        session.name(),
        plant.model.components.len(),
        plant.model.alarms.len()
    );
    // A reader error does not end the plant: said once, the last version kept, tried again
    // (issue 34 item 4).
    let mut trouble = robosim_instance_space::FollowTrouble::default();
    while signals.wait(Duration::ZERO).is_ok() {
        // Commands are looked at every 2 ms; a commit wakes the wait at once.
        let waited = reader.wait_change(Duration::from_millis(2));
        // SIGTERM/SIGINT interrupt the wait: stop cleanly.
        if waited.is_err() && signals.wait(Duration::ZERO).is_err() {
            break;
        }
        let changed = waited.as_ref().is_ok_and(|c| !c.is_empty());
        if !trouble.note("automation", &reader, waited.map(|_| ())) {
            std::thread::sleep(Duration::from_millis(2));
        }
        if changed && let Some(s) = reader.snapshot() {
            plant.follow(&s, now());
        }
        for cmd in commands.drain().map_err(session_err)? {
            let answer = serde_json::from_slice::<Value>(cmd.bytes())
                .map_err(|e| format!("not JSON: {e}"))
                .and_then(|v| plant.command(&v, now(), time_scale));
            match answer {
                Ok(v) => cmd.reply(v.to_string().as_bytes()),
                Err(e) => cmd.reply(format!("refused: {e}").as_bytes()),
            }
        }
    }
    eprintln!("automation: stopped");
    Ok(())
}

/// Keeps `ProtocolError` conversions close: a plant error as the query protocol's `session`.
impl From<PlantError> for ProtocolError {
    fn from(e: PlantError) -> Self {
        ProtocolError::new(crate::ErrorKind::Session, e.to_string())
    }
}
