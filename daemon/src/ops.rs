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
//! What `get` reports is [`Ops::status`] under `"space"."ops"`.

use crate::Sim;
use nalgebra::{Matrix3, Matrix4, Vector3};
use robosim_library::{PlacedSolid, SceneModel};
use robosim_model::Options;
use robosim_simulator::attitude::{Attitude, Config, Drag, Facet, MassProps};
use robosim_simulator::consumers::{self, Consumer, Mode, Priority, Sharing};
use robosim_simulator::orbit::Orbit;
use robosim_simulator::power::{Battery, Flow};
use serde_json::{Value, json};
use std::collections::BTreeMap;

/// The attitude's integration substep, s (the station study's default `attitude_step_s`).
pub const SUBSTEP_S: f64 = 1.0;

/// The decisions `get` lists (the latest; `decisions_total` counts them all).
const DECISIONS_SHOWN: usize = 200;

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

/// One decision the rules process took, as the simulator acknowledged it.
#[derive(Debug, Clone)]
struct Decision {
    seq: u64,
    steps: u64,
    t_s: f64,
    rule: String,
    consumer: String,
    mode: Mode,
    reason: String,
}

/// The attitude and consumers of a run (module docs).
pub(crate) struct Ops {
    geometry: Geometry,
    attitude: Option<(Attitude, Config)>,
    consumers: Vec<Consumer>,
    modes: Vec<Mode>,
    served_w: Vec<f64>,
    /// Energy served and not served per priority (vital, reducible, sheddable), J.
    served_j: [f64; 3],
    unserved_j: [f64; 3],
    /// Every interval's flows summed: produced = served + shunted + Δstored + losses.
    flow: Flow,
    decisions: Vec<Decision>,
    acks: BTreeMap<String, u64>,
    /// |h| at the last step and its rate over it, N·m·s and N·m·s/s.
    h_nms: f64,
    h_rate: f64,
    steps: u64,
}

impl Ops {
    /// The stage the declaration asks for, or `None` (neither `attitude` nor `consumers`).
    pub(crate) fn build(
        effects: &Options,
        orbit: Orbit,
        geometry: Option<Geometry>,
        sims: &[Sim],
    ) -> Result<Option<Ops>, String> {
        if effects.attitude.is_none() && !effects.consumers {
            return Ok(None);
        }
        if effects.consumers && effects.power.is_none() {
            return Err("consumers need the power effect (they draw on its battery)".into());
        }
        let geometry = geometry.unwrap_or_default();
        let attitude = match effects.attitude {
            Some(e) => {
                let cfg = geometry.config(sims, &Vector3::x())?;
                let a = Attitude::new(e, orbit, 0.0, &cfg).map_err(|e| e.to_string())?;
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
        Ok(Some(Ops {
            geometry,
            attitude,
            modes: vec![Mode::Full; n],
            served_w: vec![0.0; n],
            consumers,
            served_j: [0.0; 3],
            unserved_j: [0.0; 3],
            flow: Flow::default(),
            decisions: Vec::new(),
            acks: BTreeMap::new(),
            h_nms: 0.0,
            h_rate: 0.0,
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
            parts.push(format!("{} consumers", self.consumers.len()));
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
        let Some((a, cfg)) = &mut self.attitude else {
            return Ok(());
        };
        a.advance(cfg, t, SUBSTEP_S.min(dt.max(1e-3)));
        let h = a.state.h.norm();
        if dt > 0.0 {
            self.h_rate = (h - self.h_nms) / dt;
        }
        self.h_nms = h;
        let theta = a.orbit.angle(a.theta0, a.t);
        let v_i = Vector3::z().cross(&a.orbit.position(theta)).normalize();
        *cfg = self.geometry.config(sims, &(a.state.q.inverse() * v_i))?;
        Ok(())
    }

    /// The sun in the body frame of the actual attitude (`None` without an attitude).
    pub(crate) fn sun_body(&self) -> Option<Vector3<f64>> {
        self.attitude.as_ref().map(|(a, _)| a.sun_body())
    }

    /// The consumers' demand in their modes, W.
    fn demands(&self) -> Vec<f64> {
        self.consumers
            .iter()
            .zip(&self.modes)
            .map(|(c, m)| c.demand_w(*m))
            .collect()
    }

    /// The arrays' power `power_w` over `dt` against the consumers' demand: the battery's flows,
    /// each consumer's share, the ledger per priority.
    pub(crate) fn supply(&mut self, battery: &mut Battery, power_w: f64, dt: f64) -> Flow {
        let demands = self.demands();
        let total: f64 = demands.iter().sum();
        let f = battery.supply(power_w, total, dt);
        let served_w = if dt > 0.0 { f.served_j / dt } else { 0.0 };
        self.served_w = consumers::share(&demands, served_w.min(total), Sharing::Proportional);
        for ((c, d), s) in self.consumers.iter().zip(&demands).zip(&self.served_w) {
            let k = priority_index(c.priority);
            self.served_j[k] += s * dt;
            self.unserved_j[k] += (d - s).max(0.0) * dt;
        }
        self.flow.add(&f);
        f
    }

    /// A `consumer` or `ack` command (module docs); `None` for any other command.
    pub(crate) fn command(&mut self, cmd: &Value, t_s: f64) -> Option<Result<(), String>> {
        match cmd.get("cmd").and_then(Value::as_str)? {
            "consumer" => Some(self.decide(cmd, t_s)),
            "demand" => Some(self.demand(cmd)),
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

    fn decide(&mut self, cmd: &Value, t_s: f64) -> Result<(), String> {
        let field = |f: &str| -> Result<String, String> {
            cmd.get(f)
                .and_then(Value::as_str)
                .map(str::to_owned)
                .ok_or(format!("`{f}` must be a string"))
        };
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
        self.decisions.push(Decision {
            seq: self.decisions.len() as u64 + 1,
            steps: self.steps,
            t_s,
            rule: field("rule").unwrap_or_else(|_| "?".into()),
            consumer: name,
            mode,
            reason: field("reason").unwrap_or_default(),
        });
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
                json!({
                    "name": c.name,
                    "priority": c.priority.name(),
                    "mode": self.modes[k].name(),
                    "full_w": c.full_w,
                    "reduced_w": c.reduced_w,
                    "demand_w": demands[k],
                    "served_w": self.served_w[k],
                    "shed": self.modes[k] != Mode::Full,
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
                       "consumer": d.consumer, "mode": d.mode.name(), "reason": d.reason})
            })
            .collect();
        let (to_eclipse, eclipse_left, eclipse_s) = eclipse_ahead(orbit, t);
        json!({
            "steps": self.steps,
            "attitude": attitude,
            "consumers": consumers,
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
