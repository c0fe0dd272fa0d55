//! The operations stage (issue 38 item 7): the scene-level effects `attitude` and `consumers`
//! in the daemon, run inside the space stage ([`crate::space`]) after the orbit and before the
//! power is shared out. Built only when the scene declares one of them.
//!
//! * **attitude** ([`robosim_simulator::attitude`]): the station's rigid-body attitude held by
//!   its CMG cluster under gravity gradient and drag, with the inertia, centre of mass and drag
//!   geometry of the model *as it stands*: recomputed from the pipelines' joint values after
//!   every step (the arrays turn) and held over the next one, integrated in substeps of
//!   [`SUBSTEP_S`]; a desaturation starts at the declared fraction of the cluster's capacity.
//!   The arrays' power is then taken with the sun in the body frame of the *actual* attitude.
//! * **consumers** ([`robosim_simulator::consumers`]): the station's loads by priority, each in
//!   the mode last commanded (`full` at start), drawing on the battery ([`Battery::supply`]);
//!   a shortfall is shared in proportion ([`share`]: a bus browning out, no one decides — the
//!   rules process decides, by commanding modes).
//!
//! **Commands** (simctl JSON, [`Ops::command`]): `{"cmd": "consumer", "name": N, "mode":
//! "full"|"reduced"|"off", "rule": R, "reason": TEXT}` sets a consumer's mode from the next step
//! and records the decision (with the step and time it was taken at) — answered `ok` only once
//! recorded: an acknowledged decision is in every later `get`; `{"cmd": "demand", "name": N,
//! "full_w": W}` changes a consumer's demand (an operator, a fault); `{"cmd": "ack", "who": W,
//! "steps": N}` records that process W has acted on the state of step N (the operations
//! study waits on it, so a run is the same whatever the processes' speed).
//!
//! **Experiments and windows** ([`consumers::default_experiments`], sheddable, in the
//! experiment modules): each runs on its own timetable (a run starts at its planned time, from
//! the experiment's `first_s` every `every_s`, unless moved); `{"cmd": "experiment", "name": N,
//! "start_s": T, "rule": R, "reason": TEXT}` moves its next run to T (stopping a running one,
//! its time left kept). Docking windows (default [`DOCKING`], `{"cmd": "docking", "from_s": A,
//! "to_s": B}` adds one) and the desaturation window the momentum manager predicts (`set
//! desaturation_in_s`) are published for the rules; a sensitive run under a desaturation or in
//! a docking window is counted as disturbed.
//!
//! **The momentum manager's settings** (`{"cmd": "set", "name": N, "value": X}`, the dataflow
//! process's `sim` sinks): `desaturation_in_s` — the predicted time to saturation, s: when
//! within an orbit, the predicted desaturation window from a tenth of an orbit before it to the
//! last dump's length and the loop's settling time after (`attitude.h_growth_nms_s`, |h|'s
//! growth over the last orbit since the last desaturation, is what the momentum manager
//! divides the headroom by); `desaturate_early` — non-zero: the desaturation starts
//! now (recorded as a decision; ignored while one runs or when |h| is within 5 % of the dump
//! target: nothing to dump).
//!
//! **Faults** (`{"cmd": "fault", "fault": F, "consumer": C, "components": [..]}`, from the fault
//! injector — the operations study, which also injects F into the automation plant): C's
//! demand falls to [`STANDBY`] of itself until every component's spare hangs under the plant's
//! on-line item `eclss` in the Instance Space (the rules' reconfiguration, followed as
//! committed: [`Ops::follow_units`]), stays there [`SPARE_START_S`] while the spare starts,
//! then is [`CATCH_UP`] times itself until the work missed is made up — the in-process station
//! study's model (studies/src/station/faults.rs), with the same constants and catch-up
//! ([`robosim_simulator::consumers`]).
//!
//! `{"cmd": "note", "consumer": C, "rule": R, "reason": TEXT}` records a decision that changes
//! nothing (a reaction the rules want in the record).
//!
//! What `get` reports is [`Ops::status`] under `"space"."ops"`.

use crate::Sim;
use nalgebra::{Matrix3, Matrix4, Vector3};
use robosim_library::{PlacedSolid, SceneModel};
use robosim_model::Options;
use robosim_simulator::attitude::{
    Attitude, CONTROL_BANDWIDTH, CONTROL_DAMPING, Config, Drag, Dump, Facet, MassProps,
};
use robosim_simulator::consumers::{self, Consumer, Experiment, Mode, Priority, Sharing};
use robosim_simulator::orbit::Orbit;
use robosim_simulator::power::{Battery, Flow};
use serde_json::{Value, json};
use std::collections::BTreeMap;

/// The attitude's integration substep, s (the station study's default `attitude_step_s`).
pub const SUBSTEP_S: f64 = 1.0;

/// The decisions `get` lists (the latest; `decisions_total` counts them all).
const DECISIONS_SHOWN: usize = 200;

/// The docking window of a run unless commanded otherwise, s (assumed, as the in-process
/// station study's default: a visiting vehicle's approach and capture, 40 min).
pub const DOCKING: [f64; 2] = [24_000.0, 26_400.0];

/// The fault model's constants, shared with the in-process station study.
pub use robosim_simulator::consumers::{CATCH_UP, SPARE_START_S, STANDBY};

/// A desaturation's length before the first one is seen, s (assumed; replaced by the last
/// dump's measured length).
const DUMP_GUESS_S: f64 = 1200.0;

/// The plant item whose children are the units on line (`robosim_hl_interface::plant`).
const PLANT_ONLINE: &str = "eclss";

/// What the attitude needs from the model, in the frames the parts ride in: taken once from
/// the evaluated scene when the stage is built.
#[derive(Debug, Clone, Default)]
pub(crate) struct Geometry {
    /// Per robot (by name), per link frame (0 = base): its facets in that frame.
    robots: Vec<(String, Vec<Vec<Facet>>)>,
    /// The fixed solids' facets and mass properties (body frame).
    fixed_facets: Vec<Facet>,
    fixed_mass: Option<MassProps>,
    /// The experiment point (the lab module's centre) and the modules' vertices (for the jets'
    /// lever arm), body frame.
    experiment: Option<Vector3<f64>>,
    modules: Vec<Vector3<f64>>,
}

/// The facets of a placed part (`frame` × its transform): Newell's area vector per polygon,
/// turned away from the part's centroid (as the station study's).
fn part_facets(p: &PlacedSolid, frame: &Matrix4<f64>, out: &mut Vec<Facet>) {
    Facet::of_polyhedron(&p.polyhedron, &(frame * p.transform), out);
}

impl Geometry {
    /// The facets and masses of the evaluated scene `sc`.
    pub(crate) fn of(sc: &SceneModel) -> Geometry {
        let robots = sc
            .robots
            .iter()
            .map(|r| {
                let links = r
                    .model
                    .frames
                    .iter()
                    .map(|parts| {
                        let mut f = Vec::new();
                        for p in parts {
                            part_facets(p, &Matrix4::identity(), &mut f);
                        }
                        f
                    })
                    .collect();
                (r.name.clone(), links)
            })
            .collect();
        let mut g = Geometry {
            robots,
            ..Geometry::default()
        };
        let mut fixed = Vec::new();
        for it in &sc.solids {
            for p in &it.solid.parts {
                part_facets(p, &it.placement, &mut g.fixed_facets);
                let leaf = p.name.split('/').next().unwrap_or(&p.name);
                if ["lab", "hab", "node"].iter().any(|m| leaf.starts_with(m)) {
                    let m = it.placement * p.transform;
                    g.modules.extend(
                        p.polyhedron
                            .vertices
                            .iter()
                            .map(|v| (m * v.to_homogeneous()).xyz()),
                    );
                    if p.name == "lab/shell" {
                        g.experiment = Some((m * nalgebra::Vector4::new(0.0, 0.0, 0.0, 1.0)).xyz());
                    }
                }
            }
            if let Some(mp) = &it.solid.mass {
                let r = it.placement.fixed_view::<3, 3>(0, 0).into_owned();
                let c = (it.placement * mp.center_of_mass.to_homogeneous()).xyz();
                fixed.push((mp.mass, c, r * mp.inertia * r.transpose()));
            }
        }
        g.fixed_mass = MassProps::combine(fixed);
        g
    }

    /// The model's configuration with the pipelines where they are now, for the flow along
    /// `v_hat` (body frame).
    fn config(&self, sims: &[Sim], v_hat: &Vector3<f64>) -> Result<Config, String> {
        let mut parts: Vec<(f64, Vector3<f64>, Matrix3<f64>)> = Vec::new();
        if let Some(m) = self.fixed_mass {
            parts.push((m.mass, m.com, m.inertia));
        }
        let mut facets: Vec<Facet> = self.fixed_facets.clone();
        for s in sims {
            let robot = &s.pipeline.model().robot;
            let frames =
                robosim_kinematics::fk::link_frames(robot, s.pipeline.data().state.q.as_slice());
            for (j, joint) in robot.joints.iter().enumerate() {
                let Some(f) = frames.get(j + 1) else { continue };
                let r = f.fixed_view::<3, 3>(0, 0).into_owned();
                let t = f.fixed_view::<3, 1>(0, 3).into_owned();
                parts.push((
                    joint.mass,
                    r * joint.com + t,
                    r * joint.inertia * r.transpose(),
                ));
            }
            let Some((_, links)) = self.robots.iter().find(|(n, _)| *n == s.name) else {
                continue;
            };
            for (link, lf) in links.iter().enumerate() {
                let Some(f) = frames.get(link) else { continue };
                let r = f.fixed_view::<3, 3>(0, 0).into_owned();
                let t = f.fixed_view::<3, 1>(0, 3).into_owned();
                facets.extend(lf.iter().map(|x| Facet {
                    centre: r * x.centre + t,
                    area_normal: r * x.area_normal,
                }));
            }
        }
        let mass = MassProps::combine(parts).ok_or("the model has no mass")?;
        let lever = self
            .modules
            .iter()
            .map(|v| (v - mass.com).norm())
            .fold(0.0, f64::max);
        Ok(Config {
            mass,
            drag: Drag::of(&facets, v_hat),
            lever_m: lever,
            experiment: self.experiment.unwrap_or(mass.com),
        })
    }
}

/// One decision a process took (the rules, the momentum manager), as the simulator
/// acknowledged it: `what` is the consumer, experiment or `cmg`; `action` the mode, `moved to
/// T s`, `stopped until T s`, `desaturate` or `note`.
#[derive(Debug, Clone)]
struct Decision {
    seq: u64,
    steps: u64,
    t_s: f64,
    rule: String,
    what: String,
    action: String,
    reason: String,
}

/// One experiment on its timetable (module docs).
#[derive(Debug, Clone)]
struct Run {
    exp: Experiment,
    running: bool,
    /// Time left of the run under way or stopped, s (0: none).
    remaining_s: f64,
    /// When the next run (or the stopped one) starts, s.
    next_start_s: f64,
    started: usize,
    completed: usize,
    moved: usize,
    stopped: usize,
    run_s: f64,
    disturbed_s: f64,
    served_w: f64,
}

impl Run {
    /// The first timetable slot at or after `t`.
    fn slot_after(&self, t: f64) -> f64 {
        let e = &self.exp;
        if t <= e.first_s {
            return e.first_s;
        }
        e.first_s + ((t - e.first_s) / e.every_s - 1e-9).ceil() * e.every_s
    }

    /// Runs the timetable asked for up to `t`.
    fn asked(&self, t: f64) -> usize {
        let e = &self.exp;
        if t + 1e-9 < e.first_s {
            0
        } else {
            ((t - e.first_s) / e.every_s + 1e-9).floor() as usize + 1
        }
    }

    fn state(&self) -> &'static str {
        if self.running {
            "running"
        } else if self.remaining_s > 0.0 {
            "waiting"
        } else {
            "planned"
        }
    }
}

/// A failed unit's consumer (module docs).
#[derive(Debug, Clone)]
struct UnitFault {
    fault: String,
    consumer: usize,
    components: Vec<String>,
    at_s: f64,
    spare_at: Option<f64>,
}

impl UnitFault {
    fn catch_up_s(&self, spare: f64) -> f64 {
        consumers::catch_up_s(self.at_s, spare)
    }

    fn state(&self, t: f64) -> &'static str {
        match self.spare_at {
            None => "failed",
            Some(s) if t < s + SPARE_START_S => "spare-starting",
            Some(s) if t < s + SPARE_START_S + self.catch_up_s(s) => "catching-up",
            Some(_) => "repaired",
        }
    }

    fn factor(&self, t: f64) -> f64 {
        match self.state(t) {
            "failed" | "spare-starting" => STANDBY,
            "catching-up" => CATCH_UP,
            _ => 1.0,
        }
    }
}

/// The attitude and consumers of a run (module docs).
pub(crate) struct Ops {
    geometry: Geometry,
    attitude: Option<(Attitude, Config)>,
    consumers: Vec<Consumer>,
    modes: Vec<Mode>,
    served_w: Vec<f64>,
    runs: Vec<Run>,
    docking: Vec<[f64; 2]>,
    /// The momentum manager's predicted time to saturation and when it said it, s.
    predicted: Option<(f64, f64)>,
    faults: Vec<UnitFault>,
    /// Energy served and not served per priority (vital, reducible, sheddable), J.
    served_j: [f64; 3],
    unserved_j: [f64; 3],
    /// Time a vital consumer was short while a sheddable one drew, s, and what the sheddable
    /// ones drew meanwhile, J (the issue's "no vital consumer unserved while a sheddable one is
    /// served": both 0 when the schedule holds).
    vital_short_s: f64,
    vital_short_sheddable_j: f64,
    /// The clock: the start of the interval being served, then the step's end.
    t: f64,
    /// Every interval's flows summed: produced = served + shunted + Δstored + losses.
    flow: Flow,
    decisions: Vec<Decision>,
    acks: BTreeMap<String, u64>,
    /// |h| at the last step and its rate over it, N·m·s and N·m·s/s.
    h_nms: f64,
    h_rate: f64,
    /// (t, |h|) at every step over the last orbit since the last desaturation: the secular
    /// growth is taken over it (the in-plane momentum cycles within an orbit).
    h_history: std::collections::VecDeque<(f64, f64)>,
    steps: u64,
}

impl Ops {
    /// The stage the declaration asks for, or `None` (neither `attitude` nor `consumers`).
    pub(crate) fn build(
        effects: &Options,
        orbit: Orbit,
        geometry: Option<Geometry>,
        sims: &[Sim],
    ) -> Result<Option<Ops>, crate::StageError> {
        if effects.attitude.is_none() && !effects.consumers {
            return Ok(None);
        }
        if effects.consumers && effects.power.is_none() {
            return Err(crate::StageError::Refused(
                "consumers need the power effect (they draw on its battery)".into(),
            ));
        }
        let geometry = geometry.unwrap_or_default();
        let attitude = match effects.attitude {
            Some(e) => {
                let cfg = geometry.config(sims, &Vector3::x())?;
                let a = Attitude::new(e, orbit, 0.0, &cfg)?;
                Some((a, cfg))
            }
            None => None,
        };
        let consumers: Vec<Consumer> = if effects.consumers {
            // the servicer draws only while a swap runs: not part of this stage's loads
            consumers::default_consumers(consumers::BASE_LOAD_W)
                .into_iter()
                .filter(|c| c.subsystem != "servicer")
                .collect()
        } else {
            Vec::new()
        };
        let n = consumers.len();
        let runs = if effects.consumers {
            consumers::default_experiments()
                .into_iter()
                .map(|exp| Run {
                    next_start_s: exp.first_s,
                    exp,
                    running: false,
                    remaining_s: 0.0,
                    started: 0,
                    completed: 0,
                    moved: 0,
                    stopped: 0,
                    run_s: 0.0,
                    disturbed_s: 0.0,
                    served_w: 0.0,
                })
                .collect()
        } else {
            Vec::new()
        };
        Ok(Some(Ops {
            geometry,
            attitude,
            modes: vec![Mode::Full; n],
            served_w: vec![0.0; n],
            consumers,
            runs,
            docking: if effects.consumers {
                vec![DOCKING]
            } else {
                Vec::new()
            },
            predicted: None,
            faults: Vec::new(),
            served_j: [0.0; 3],
            unserved_j: [0.0; 3],
            vital_short_s: 0.0,
            vital_short_sheddable_j: 0.0,
            t: 0.0,
            flow: Flow::default(),
            decisions: Vec::new(),
            acks: BTreeMap::new(),
            h_nms: 0.0,
            h_rate: 0.0,
            h_history: std::collections::VecDeque::new(),
            steps: 0,
        }))
    }

    pub(crate) fn describe(&self) -> String {
        let mut parts = Vec::new();
        if let Some((a, cfg)) = &self.attitude {
            parts.push(format!(
                "attitude ({} CMGs, {:.0} N·m·s, desaturation at {:.0} %, {:.1} t)",
                a.effect.cmgs,
                a.capacity(),
                100.0 * a.effect.saturation,
                cfg.mass.mass / 1e3
            ));
        }
        if !self.consumers.is_empty() {
            parts.push(format!(
                "{} consumers, {} experiments, {} docking window(s)",
                self.consumers.len(),
                self.runs.len(),
                self.docking.len()
            ));
        }
        parts.join(", ")
    }

    /// Whether the consumers draw on the battery (else the space stage's constant load does).
    pub(crate) fn has_consumers(&self) -> bool {
        !self.consumers.is_empty()
    }

    /// The attitude over the step ending at `t` (the configuration of the step's start), then
    /// the configuration where the pipelines are now, for the next step. The sun in the body
    /// frame of the actual attitude, when there is one.
    pub(crate) fn advance_attitude(&mut self, sims: &[Sim], t: f64, dt: f64) -> Result<(), String> {
        if dt > 0.0 {
            self.steps += 1;
        }
        self.t = t;
        let Some((a, cfg)) = &mut self.attitude else {
            return Ok(());
        };
        a.advance(cfg, t, SUBSTEP_S.min(dt.max(1e-3)));
        let h = a.state.h.norm();
        if dt > 0.0 {
            self.h_rate = (h - self.h_nms) / dt;
        }
        self.h_nms = h;
        if a.dumping() {
            self.h_history.clear();
        } else {
            self.h_history.push_back((t, h));
            let period = a.orbit.period_s();
            while self
                .h_history
                .front()
                .is_some_and(|(t0, _)| *t0 < t - period)
            {
                self.h_history.pop_front();
            }
        }
        let theta = a.orbit.angle(a.theta0, a.t);
        let v_i = Vector3::z().cross(&a.orbit.position(theta)).normalize();
        *cfg = self.geometry.config(sims, &(a.state.q.inverse() * v_i))?;
        Ok(())
    }

    /// |h|'s secular growth, N·m·s/s: over the last orbit, or since the last desaturation
    /// when that is shorter but at least a quarter orbit; 0 before that (unknown).
    fn h_growth(&self, period: f64) -> f64 {
        match (self.h_history.front(), self.h_history.back()) {
            (Some((t0, h0)), Some((t1, h1))) if t1 - t0 >= 0.25 * period => (h1 - h0) / (t1 - t0),
            _ => 0.0,
        }
    }

    /// The sun in the body frame of the actual attitude (`None` without an attitude).
    pub(crate) fn sun_body(&self) -> Option<Vector3<f64>> {
        self.attitude.as_ref().map(|(a, _)| a.sun_body())
    }

    /// Consumer `k`'s demand factor from its unit faults at the stage's clock.
    fn fault_factor(&self, k: usize) -> f64 {
        self.faults
            .iter()
            .filter(|f| f.consumer == k)
            .map(|f| f.factor(self.t))
            .product()
    }

    /// The consumers' demand in their modes (a unit fault's factor applied), then the
    /// experiments' (their power while running), W.
    fn demands(&self) -> Vec<f64> {
        self.consumers
            .iter()
            .zip(&self.modes)
            .enumerate()
            .map(|(k, (c, m))| c.demand_w(*m) * self.fault_factor(k))
            .chain(
                self.runs
                    .iter()
                    .map(|r| if r.running { r.exp.power_w } else { 0.0 }),
            )
            .collect()
    }

    /// Whether a desaturation runs or a docking window is open at the stage's clock.
    fn disturbed(&self) -> bool {
        self.attitude.as_ref().is_some_and(|(a, _)| a.dumping())
            || self.docking.iter().any(|w| w[0] <= self.t && self.t < w[1])
    }

    /// The arrays' power `power_w` over the interval of `dt` from `t0` against the loads'
    /// demand: the experiments due start, the battery's flows, each load's share, the ledger
    /// per priority, the runs advanced.
    pub(crate) fn supply(&mut self, battery: &mut Battery, power_w: f64, t0: f64, dt: f64) -> Flow {
        self.t = t0;
        for r in &mut self.runs {
            if !r.running && t0 + 1e-9 >= r.next_start_s {
                if r.remaining_s <= 0.0 {
                    r.remaining_s = r.exp.duration_s;
                    r.started += 1;
                }
                r.running = true;
            }
        }
        let disturbed = self.disturbed();
        let demands = self.demands();
        let total: f64 = demands.iter().sum();
        let f = battery.supply(power_w, total, dt);
        let served_w = if dt > 0.0 { f.served_j / dt } else { 0.0 };
        let served = consumers::share(&demands, served_w.min(total), Sharing::Proportional);
        let n = self.consumers.len();
        let (mut vital_short, mut sheddable_w) = (false, 0.0);
        for (k, (d, s)) in demands.iter().zip(&served).enumerate() {
            let p = self
                .consumers
                .get(k)
                .map_or(Priority::Sheddable, |c| c.priority);
            let i = priority_index(p);
            self.served_j[i] += s * dt;
            self.unserved_j[i] += (d - s).max(0.0) * dt;
            match p {
                Priority::Vital => vital_short |= *s < d * (1.0 - 1e-9),
                Priority::Sheddable => sheddable_w += s,
                Priority::Reducible => {}
            }
        }
        if vital_short && sheddable_w > 0.0 {
            self.vital_short_s += dt;
            self.vital_short_sheddable_j += sheddable_w * dt;
        }
        self.served_w = served[..n].to_vec();
        let t1 = t0 + dt;
        for (r, s) in self.runs.iter_mut().zip(&served[n..]) {
            r.served_w = *s;
            if !r.running {
                continue;
            }
            r.run_s += dt;
            if disturbed && r.exp.sensitive {
                r.disturbed_s += dt;
            }
            r.remaining_s -= dt;
            if r.remaining_s <= 1e-9 {
                r.running = false;
                r.remaining_s = 0.0;
                r.completed += 1;
                // a slot that passed while the run ran is not queued behind it
                r.next_start_s = r.slot_after(t1 + 1e-6).max(r.next_start_s);
            }
        }
        self.flow.add(&f);
        f
    }

    /// The plant's units as committed (`robosim_hl_interface::plant`): a fault's spare is on
    /// line once every component's spare hangs under [`PLANT_ONLINE`] — from then its consumer's
    /// spare starts (module docs).
    pub(crate) fn follow_units(&mut self, snap: &robosim_instance_space::Snapshot) {
        let online = |name: &str| -> bool {
            snap.find(name).is_some_and(|i| {
                snap.index_of(snap.rec(i).parent)
                    .is_some_and(|p| snap.name(p) == PLANT_ONLINE)
            })
        };
        for f in self.faults.iter_mut().filter(|f| f.spare_at.is_none()) {
            if !f.components.is_empty()
                && f.components.iter().all(|c| online(&format!("{c}_spare")))
            {
                f.spare_at = Some(self.t);
            }
        }
    }

    /// A `consumer` or `ack` command (module docs); `None` for any other command.
    pub(crate) fn command(&mut self, cmd: &Value, t_s: f64) -> Option<Result<(), String>> {
        match cmd.get("cmd").and_then(Value::as_str)? {
            "consumer" => Some(self.decide(cmd, t_s)),
            "demand" => Some(self.demand(cmd)),
            "experiment" => Some(self.experiment(cmd, t_s)),
            "docking" => Some(self.add_docking(cmd)),
            "set" => Some(self.set(cmd, t_s)),
            "fault" => Some(self.fault(cmd, t_s)),
            "note" => Some((|| {
                let what = text(cmd, "consumer")?;
                self.record(cmd, t_s, what, "note".into());
                Ok(())
            })()),
            "ack" => Some((|| {
                let who = cmd
                    .get("who")
                    .and_then(Value::as_str)
                    .ok_or("`who` must be a string")?;
                let steps = cmd
                    .get("steps")
                    .and_then(Value::as_f64)
                    .filter(|s| *s >= 0.0 && s.fract() == 0.0)
                    .ok_or("`steps` must be a whole number")?;
                self.acks.insert(who.to_owned(), steps as u64);
                Ok(())
            })()),
            _ => None,
        }
    }

    /// `{"cmd": "demand", "name": N, "full_w": W}`: consumer N now draws W at full capacity
    /// (its reduced demand scaled with it) — an operator's or a fault's change of a load.
    fn demand(&mut self, cmd: &Value) -> Result<(), String> {
        let name = cmd
            .get("name")
            .and_then(Value::as_str)
            .ok_or("`name` must be a string")?;
        let w = cmd
            .get("full_w")
            .and_then(Value::as_f64)
            .filter(|w| w.is_finite() && *w >= 0.0)
            .ok_or("`full_w` must be a number of watts, 0 or more")?;
        let c = self
            .consumers
            .iter_mut()
            .find(|c| c.name == name)
            .ok_or_else(|| format!("no consumer {name:?}"))?;
        let ratio = if c.full_w > 0.0 {
            c.reduced_w / c.full_w
        } else {
            1.0
        };
        c.full_w = w;
        c.reduced_w = w * ratio;
        Ok(())
    }

    /// Records a decision of `cmd` (its `rule` and `reason`) on `what`.
    fn record(&mut self, cmd: &Value, t_s: f64, what: String, action: String) {
        self.decisions.push(Decision {
            seq: self.decisions.len() as u64 + 1,
            steps: self.steps,
            t_s,
            rule: text(cmd, "rule").unwrap_or_else(|_| "?".into()),
            what,
            action,
            reason: text(cmd, "reason").unwrap_or_default(),
        });
    }

    /// `{"cmd": "experiment", "name": N, "start_s": T, …}` (module docs).
    fn experiment(&mut self, cmd: &Value, t_s: f64) -> Result<(), String> {
        let name = text(cmd, "name")?;
        let start = cmd
            .get("start_s")
            .and_then(Value::as_f64)
            .filter(|x| x.is_finite() && *x >= t_s)
            .ok_or(format!("`start_s` must be a time from now ({t_s} s) on"))?;
        let names = || {
            self.runs
                .iter()
                .map(|r| r.exp.name)
                .collect::<Vec<_>>()
                .join(", ")
        };
        let k = self
            .runs
            .iter()
            .position(|r| r.exp.name == name)
            .ok_or_else(|| format!("no experiment {name:?} (the experiments: {})", names()))?;
        let r = &mut self.runs[k];
        let action = if r.running {
            r.running = false;
            r.stopped += 1;
            format!("stopped until {start:.0} s")
        } else {
            r.moved += 1;
            format!("moved to {start:.0} s")
        };
        r.next_start_s = start;
        self.record(cmd, t_s, name, action);
        Ok(())
    }

    /// `{"cmd": "docking", "from_s": A, "to_s": B}`: one more docking window.
    fn add_docking(&mut self, cmd: &Value) -> Result<(), String> {
        let a = cmd.get("from_s").and_then(Value::as_f64);
        let b = cmd.get("to_s").and_then(Value::as_f64);
        match (a, b) {
            (Some(a), Some(b)) if a.is_finite() && b.is_finite() && a >= 0.0 && b > a => {
                self.docking.push([a, b]);
                self.docking.sort_by(|x, y| x[0].total_cmp(&y[0]));
                Ok(())
            }
            _ => Err("`from_s` and `to_s` must be times, 0 ≤ from_s < to_s".into()),
        }
    }

    /// The docking window open now or next: (time to its start (0 in it), time to its end), s;
    /// 1e9 each when none is ahead.
    fn docking_ahead(&self) -> (f64, f64) {
        self.docking
            .iter()
            .find(|w| w[1] > self.t)
            .map_or((1e9, 1e9), |w| ((w[0] - self.t).max(0.0), w[1] - self.t))
    }

    /// The desaturation window under way or predicted, s (module docs).
    fn desaturation_window(&self) -> Option<[f64; 2]> {
        let (a, _) = self.attitude.as_ref()?;
        let settle = 4.0 / (CONTROL_DAMPING * CONTROL_BANDWIDTH);
        let length = a
            .dumps
            .iter()
            .rev()
            .find_map(|d| Some(d.end_s? - d.start_s))
            .unwrap_or(DUMP_GUESS_S);
        if let Some(d) = a.dumps.last().filter(|d| d.end_s.is_none()) {
            return Some([d.start_s, (d.start_s + length).max(self.t + 60.0) + settle]);
        }
        let (x, at) = self.predicted?;
        let period = a.orbit.period_s();
        let start = at + x;
        (x.is_finite() && x < period).then(|| [start - 0.1 * period, start + length + settle])
    }

    /// `{"cmd": "set", "name": N, "value": X}` (module docs).
    fn set(&mut self, cmd: &Value, t_s: f64) -> Result<(), String> {
        let name = text(cmd, "name")?;
        let x = cmd
            .get("value")
            .and_then(Value::as_f64)
            .filter(|x| x.is_finite())
            .ok_or("`value` must be a finite number")?;
        match name.as_str() {
            "desaturation_in_s" => {
                self.predicted = Some((x, t_s));
                Ok(())
            }
            "desaturate_early" => {
                if x == 0.0 {
                    return Ok(());
                }
                let (to_dock, dock_left) = self.docking_ahead();
                let predicted = self.predicted.map_or(f64::NAN, |(x, at)| at + x - t_s);
                let Some((a, _)) = &mut self.attitude else {
                    return Err("no attitude effect: nothing to desaturate".into());
                };
                let h = a.state.h.norm();
                let (cap, low) = (a.capacity(), a.effect.dump_to * a.capacity());
                if a.dumping() || h <= low * 1.05 {
                    return Ok(());
                }
                a.dumps.push(Dump {
                    start_s: a.t,
                    end_s: None,
                    h_start: h,
                    h_end: h,
                    pulses: 0,
                    max_error_rad: a.error_rad,
                    max_accel: a.accel,
                });
                let reason = format!(
                    "|h| {:.0} % of capacity; saturation ({:.0} %) predicted in {predicted:.0} s, inside the docking window {:.0}–{:.0} s: desaturation started early, before the window opens",
                    100.0 * h / cap,
                    100.0 * a.effect.saturation,
                    t_s + to_dock,
                    t_s + dock_left
                );
                let mut c = cmd.clone();
                c["rule"] = json!("momentum_manager.flow");
                c["reason"] = json!(reason);
                self.record(&c, t_s, "cmg".into(), "desaturate".into());
                Ok(())
            }
            other => Err(format!(
                "no simulator setting {other:?} (desaturation_in_s, desaturate_early)"
            )),
        }
    }

    /// `{"cmd": "fault", "fault": F, "consumer": C, "components": [..]}` (module docs).
    fn fault(&mut self, cmd: &Value, t_s: f64) -> Result<(), String> {
        let fault = text(cmd, "fault")?;
        let name = text(cmd, "consumer")?;
        let consumer = self
            .consumers
            .iter()
            .position(|c| c.name == name)
            .ok_or_else(|| format!("no consumer {name:?}"))?;
        let components: Vec<String> = cmd
            .get("components")
            .and_then(Value::as_array)
            .ok_or("`components` must be a list of the failed unit's components")?
            .iter()
            .map(|c| {
                c.as_str()
                    .map(str::to_owned)
                    .ok_or("a component must be a name")
            })
            .collect::<Result<_, _>>()?;
        if components.is_empty() {
            return Err("`components`: a fault needs the units a spare replaces".into());
        }
        self.faults.push(UnitFault {
            fault,
            consumer,
            components,
            at_s: t_s,
            spare_at: None,
        });
        Ok(())
    }

    fn decide(&mut self, cmd: &Value, t_s: f64) -> Result<(), String> {
        let field = |f: &str| text(cmd, f);
        let name = field("name")?;
        let mode_name = field("mode")?;
        let mode = Mode::parse(&mode_name)
            .ok_or(format!("mode {mode_name:?}: expected full, reduced or off"))?;
        let k = self
            .consumers
            .iter()
            .position(|c| c.name == name)
            .ok_or_else(|| {
                format!(
                    "no consumer {name:?} (the consumers: {})",
                    self.consumers
                        .iter()
                        .map(|c| c.name)
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })?;
        if self.consumers[k].priority == Priority::Vital && mode != Mode::Full {
            return Err(format!(
                "{name} is vital: it is not reduced or shed (seed §4.2)"
            ));
        }
        self.modes[k] = mode;
        self.record(cmd, t_s, name, mode.name().into());
        Ok(())
    }

    /// The `"ops"` object of `get`.
    pub(crate) fn status(&self, battery: &Battery, orbit: &Orbit, t: f64) -> Value {
        let attitude = self.attitude.as_ref().map(|(a, cfg)| {
            let cap = a.capacity();
            json!({
                "error_deg": a.error_rad.to_degrees(),
                "h_nms": self.h_nms,
                "h_rate_nms_s": self.h_rate,
                "h_growth_nms_s": self.h_growth(a.orbit.period_s()),
                "capacity_nms": cap,
                "h_fraction": self.h_nms / cap,
                "saturation": a.effect.saturation,
                "dumping": a.dumping(),
                "desaturations": a.dumps.len(),
                "dump_starts_s": a.dumps.iter().map(|d| d.start_s).collect::<Vec<_>>(),
                "accel_ug": a.accel / robosim_simulator::attitude::G0 * 1e6,
                "mass_kg": cfg.mass.mass,
            })
        });
        let demands = self.demands();
        let consumers: Vec<Value> = self
            .consumers
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let f = self.fault_factor(k);
                json!({
                    "name": c.name,
                    "priority": c.priority.name(),
                    "mode": self.modes[k].name(),
                    "full_w": c.full_w * f,
                    "reduced_w": c.reduced_w * f,
                    "nominal_full_w": c.full_w,
                    "demand_w": demands[k],
                    "served_w": self.served_w[k],
                    "shed": self.modes[k] != Mode::Full,
                })
            })
            .collect();
        let experiments: Vec<Value> = self
            .runs
            .iter()
            .map(|r| {
                let start = if r.running { t } else { r.next_start_s };
                let left = if r.remaining_s > 0.0 {
                    r.remaining_s
                } else {
                    r.exp.duration_s
                };
                json!({
                    "name": r.exp.name,
                    "power_w": r.exp.power_w,
                    "sensitive": r.exp.sensitive,
                    "state": r.state(),
                    "start_s": start,
                    "end_s": start + left,
                    "served_w": r.served_w,
                    "asked": r.asked(t),
                    "started": r.started,
                    "completed": r.completed,
                    "moved": r.moved,
                    "stopped": r.stopped,
                    "run_s": r.run_s,
                    "disturbed_s": r.disturbed_s,
                })
            })
            .collect();
        let mut windows: Vec<Value> = self
            .docking
            .iter()
            .map(|w| json!({"kind": "docking", "from_s": w[0], "to_s": w[1]}))
            .collect();
        if let Some(w) = self.desaturation_window() {
            windows.push(json!({"kind": "desaturation", "from_s": w[0], "to_s": w[1]}));
        }
        let (to_dock, dock_left) = self.docking_ahead();
        let faults: Vec<Value> = self
            .faults
            .iter()
            .map(|f| {
                json!({
                    "fault": f.fault,
                    "consumer": self.consumers[f.consumer].name,
                    "components": f.components,
                    "at_s": f.at_s,
                    "spare_at_s": f.spare_at,
                    "state": f.state(t),
                    "factor": f.factor(t),
                })
            })
            .collect();
        let per = |v: &[f64; 3]| {
            let mut m = serde_json::Map::new();
            for p in Priority::ALL {
                m.insert(p.name().into(), json!(v[priority_index(p)] / 3.6e6));
            }
            Value::Object(m)
        };
        let from = self.decisions.len().saturating_sub(DECISIONS_SHOWN);
        let decisions: Vec<Value> = self.decisions[from..]
            .iter()
            .map(|d| {
                json!({"seq": d.seq, "steps": d.steps, "t_s": d.t_s, "rule": d.rule,
                       "consumer": d.what, "mode": d.action, "reason": d.reason})
            })
            .collect();
        let (to_eclipse, eclipse_left, eclipse_s) = eclipse_ahead(orbit, t);
        json!({
            "steps": self.steps,
            "attitude": attitude,
            "consumers": consumers,
            "experiments": experiments,
            "windows": windows,
            "docking": {"to_start_s": to_dock, "to_end_s": dock_left},
            "faults": faults,
            "vital_short_while_sheddable": {
                "s": self.vital_short_s,
                "sheddable_kwh": self.vital_short_sheddable_j / 3.6e6,
            },
            "demand_w": demands.iter().sum::<f64>(),
            "served_kwh": per(&self.served_j),
            "unserved_kwh": per(&self.unserved_j),
            "ledger_kwh": {
                "produced": self.flow.produced_j / 3.6e6,
                "served": self.flow.served_j / 3.6e6,
                "shunted": self.flow.shunted_j / 3.6e6,
                "stored": self.flow.stored_j / 3.6e6,
                "losses": self.flow.losses_j / 3.6e6,
                "unserved": self.flow.unserved_j / 3.6e6,
            },
            "battery": {"charge_eff": battery.charge_eff, "discharge_eff": battery.discharge_eff},
            "to_eclipse_s": to_eclipse,
            "eclipse_left_s": eclipse_left,
            "eclipse_s": eclipse_s,
            "decisions_total": self.decisions.len(),
            "decisions": decisions,
            "acks": self.acks,
        })
    }
}

/// A string field of a command.
fn text(cmd: &Value, f: &str) -> Result<String, String> {
    cmd.get(f)
        .and_then(Value::as_str)
        .map(str::to_owned)
        .ok_or(format!("`{f}` must be a string"))
}

fn priority_index(p: Priority) -> usize {
    match p {
        Priority::Vital => 0,
        Priority::Reducible => 1,
        Priority::Sheddable => 2,
    }
}

/// From `t`: the time until the next eclipse starts (0 in one), the time from then (or now)
/// until it ends, and an eclipse's length, s (the crossings from the orbit's shadow sampled at
/// 10 s over one period; the length in closed form).
fn eclipse_ahead(orbit: &Orbit, t: f64) -> (f64, f64, f64) {
    let theta = orbit.angle(0.0, t);
    let length = orbit.eclipse_fraction_closed_form() * orbit.period_s();
    match orbit
        .eclipse_intervals(theta, orbit.period_s() * 1.01, 10.0)
        .first()
    {
        Some([a, b]) => (*a, b - a, length),
        None => (orbit.period_s(), 0.0, length),
    }
}
