//! The space stage: the scene-level effects `orbit`, `sun_tracking` and `power` in the daemon.
//! Built only when the scene declares `orbit` (a scene that does not pays nothing: no stage,
//! no field in `get`). After every step of the robots' pipelines, with t the pipelines' clock:
//!
//! * **orbit**: the orbit angle θ = ω t (the run starts at orbit noon), the sun in the body
//!   frame under LVLH hold and the eclipse flag from the geometry ([`robosim_simulator::orbit`]);
//! * **sun_tracking**: each array's gimbals are given the joint values facing the sun as it
//!   will be after the next step as their target ([`robosim_simulator::power::track`]), so
//!   they turn there through their own pipeline
//!   — kinematic motion at the scene's speed limit, joint limits, collision — and their joint
//!   values are published on `state/simulator` like any simulated joint motion. The solve is
//!   repeated when the sun has moved 10⁻⁴ rad in the body frame since the last one (every
//!   ~0.09 s of simulated time at 400 km: every step at the station scene's 1 s step);
//! * **power**: Σ arrays area × efficiency × flux × cos⁺ incidence at the arrays' *current*
//!   joint values (an array still turning delivers less), zero in eclipse; the battery
//!   ([`robosim_simulator::power::Battery`], its stated defaults) integrates it over each step.
//!
//! * **attitude** and **consumers** ([`crate::ops`], when declared): the attitude integrated
//!   over the step (the arrays' power then taken with the sun in the actual attitude's body
//!   frame) and the consumers' demand in their commanded modes drawn from the battery in place
//!   of its constant load.
//!
//! What `get` reports is [`SpaceStage::status`] under the key `"space"`.

use crate::Sim;
use crate::ops::{Geometry, Ops};
use nalgebra::Vector3;
use robosim_model::Options;
use robosim_model::parts::SceneParts;
use robosim_simulator::Command;
use robosim_simulator::orbit::Orbit;
use robosim_simulator::power::{self, Battery, SolarArray};
use serde_json::{Value, json};
use std::f64::consts::TAU;

/// Tracking tolerance of the 2-axis search, rad (the station study's default).
const TRACKING_TOL: f64 = 1e-4;
/// Re-solve the tracking when the sun has moved this far in the body frame, rad.
const RETRACK_RAD: f64 = 1e-4;

/// One array: which pipeline, its cells, what it delivers now.
struct ArrayState {
    sim: usize,
    /// Its robot is held ([`Sim::held`]): never stepped, so it is not commanded to track; its
    /// power is computed where it is held.
    held: bool,
    cells: SolarArray,
    cos_incidence: f64,
    power_w: f64,
}

/// The scene's orbit, its arrays and the battery (module docs).
pub(crate) struct SpaceStage {
    orbit: Orbit,
    tracking: bool,
    efficiency: Option<f64>,
    arrays: Vec<ArrayState>,
    battery: Battery,
    /// The sun at the last tracking solve.
    tracked_sun: Option<Vector3<f64>>,
    t: f64,
    theta: f64,
    sun: Vector3<f64>,
    eclipse: bool,
    power_w: f64,
    energy_j: f64,
    unserved_j: f64,
    /// The attitude and the consumers, when declared ([`crate::ops`]).
    ops: Option<Ops>,
}

impl SpaceStage {
    /// The stage the scene's declaration asks for, or `None` (no `orbit` declared). `notes`
    /// receives what is said on stderr: declared effects that find nothing to act on.
    pub(crate) fn build(
        effects: &Options,
        scene: &SceneParts,
        geometry: Option<Geometry>,
        sims: &mut [Sim],
        notes: &mut Vec<String>,
    ) -> Result<Option<SpaceStage>, crate::StageError> {
        let Some(o) = effects.orbit else {
            if effects.sun_tracking
                || effects.power.is_some()
                || effects.attitude.is_some()
                || effects.consumers
            {
                // the library refuses this; a hand-written declaration could still say it
                return Err(crate::StageError::Refused(
                    "sun_tracking, power, attitude and consumers need an orbit effect".into(),
                ));
            }
            return Ok(None);
        };
        let orbit = Orbit::new(o.altitude_m, o.beta_rad)?;
        let mut arrays = Vec::new();
        for placed in &scene.robots {
            let Some(cells) = power::solar_array(&placed.frames) else {
                continue;
            };
            match sims.iter().position(|s| s.name == placed.name) {
                Some(sim) => arrays.push(ArrayState {
                    sim,
                    held: match &sims[sim].held {
                        Some(why) => {
                            notes.push(format!(
                                "solar array {} is held ({why}): it does not track the sun; its power is computed where it is held",
                                placed.name
                            ));
                            true
                        }
                        None => false,
                    },
                    cells,
                    cos_incidence: 0.0,
                    power_w: 0.0,
                }),
                None => notes.push(format!(
                    "solar array {} is not simulated (no pipeline of that name): its tracking and power are left out",
                    placed.name
                )),
            }
        }
        if arrays.is_empty() && (effects.sun_tracking || effects.power.is_some()) {
            notes.push(
                "sun_tracking/power declared but the scene has no solar arrays (box parts named panel… or blanket…): nothing tracks, power is 0".into(),
            );
        }
        let mut stage = SpaceStage {
            orbit,
            tracking: effects.sun_tracking,
            efficiency: effects.power.map(|p| p.efficiency),
            arrays,
            battery: Battery::default(),
            tracked_sun: None,
            t: 0.0,
            theta: 0.0,
            sun: orbit.sun_body(0.0),
            eclipse: false,
            power_w: 0.0,
            energy_j: 0.0,
            unserved_j: 0.0,
            ops: Ops::build(effects, orbit, geometry, sims)?,
        };
        stage.update(sims, 0.0, 0.0)?;
        Ok(Some(stage))
    }

    /// Names of what the stage does, for the daemon's start-up line.
    pub(crate) fn describe(&self) -> String {
        let mut parts = vec![format!(
            "orbit {:.0} km, beta {:.1}°, period {:.1} min",
            self.orbit.altitude_m / 1e3,
            self.orbit.beta_rad.to_degrees(),
            self.orbit.period_s() / 60.0
        )];
        if self.tracking {
            parts.push(format!("sun_tracking of {} array(s)", self.arrays.len()));
        }
        if let Some(e) = self.efficiency {
            parts.push(format!(
                "power (efficiency {e}, battery {:.0} kWh, load {:.0} kW)",
                self.battery.capacity_j / 3.6e6,
                self.battery.load_w / 1e3
            ));
        }
        if let Some(ops) = &self.ops {
            parts.push(ops.describe());
        }
        parts.join(" → ")
    }

    /// A command for the operations stage (`consumer`, `ack`; [`Ops::command`]), `None` for
    /// any other.
    pub(crate) fn command(&mut self, cmd: &Value) -> Option<Result<(), String>> {
        let t = self.t;
        self.ops.as_mut()?.command(cmd, t)
    }

    /// The committed model's plant units, for the operations stage's faults
    /// ([`Ops::follow_units`]).
    pub(crate) fn follow_units(&mut self, snap: &robosim_instance_space::Snapshot) {
        if let Some(ops) = &mut self.ops {
            ops.follow_units(snap);
        }
    }

    /// After a step of every pipeline: the orbit at the pipelines' clock `t` (s), new tracking
    /// targets when the sun has moved, the power delivered by the arrays where they are, the
    /// battery over the step `dt` (s) just taken.
    pub(crate) fn update(&mut self, sims: &mut [Sim], t: f64, dt: f64) -> Result<(), String> {
        // the power of the step just ended, held over it (as in the study)
        if dt > 0.0 && self.efficiency.is_some() {
            self.energy_j += self.power_w * dt;
            self.unserved_j += match &mut self.ops {
                Some(ops) if ops.has_consumers() => {
                    ops.supply(&mut self.battery, self.power_w, self.t, dt)
                        .unserved_j
                }
                _ => self.battery.step(self.power_w, dt),
            };
        }
        if let Some(ops) = &mut self.ops {
            ops.advance_attitude(sims, t, dt)?;
        }
        self.t = t;
        self.theta = self.orbit.angle(0.0, t);
        self.sun = self.orbit.sun_body(self.theta);
        self.eclipse = self.orbit.eclipse_at(self.theta);
        // the arrays see the sun in the actual attitude's body frame (they are aimed at where it
        // will be under the commanded one)
        let sun_actual = self
            .ops
            .as_ref()
            .and_then(Ops::sun_body)
            .unwrap_or(self.sun);
        // the targets are for the next step: the sun where it will be then
        let sun_next = self
            .orbit
            .sun_body(self.orbit.angle(0.0, t + dt_next(sims)));
        if self.tracking
            && self
                .tracked_sun
                .is_none_or(|s| s.angle(&sun_next) >= RETRACK_RAD)
        {
            for a in self.arrays.iter().filter(|a| !a.held) {
                let s = &mut sims[a.sim];
                let robot = &s.pipeline.model().robot;
                let q_now = s.pipeline.data().state.q.as_slice().to_vec();
                let (q, _) = power::track(robot, &a.cells, &q_now, &sun_next, TRACKING_TOL);
                let q = nearest_within_limits(robot, &q, &q_now);
                s.pipeline
                    .set_command(Command::Target(nalgebra::DVector::from_vec(q)))
                    .map_err(|e| format!("sun tracking of {}: {e}", s.name))?;
            }
            self.tracked_sun = Some(sun_next);
        }
        self.power_w = 0.0;
        for a in &mut self.arrays {
            let s = &sims[a.sim];
            let robot = &s.pipeline.model().robot;
            a.cos_incidence = a
                .cells
                .normal_at(robot, s.pipeline.data().state.q.as_slice())
                .dot(&sun_actual);
            a.power_w = match self.efficiency {
                Some(e) if !self.eclipse => a.cells.power_w(e, a.cos_incidence),
                _ => 0.0,
            };
            self.power_w += a.power_w;
        }
        Ok(())
    }

    /// The `"space"` object of `get`: orbit, sun, eclipse, each array's joints, target,
    /// incidence and power, total power and the battery. Units in the key names.
    pub(crate) fn status(&self, sims: &[Sim]) -> Value {
        let arrays: Vec<Value> = self
            .arrays
            .iter()
            .map(|a| {
                let d = sims[a.sim].pipeline.data();
                json!({
                    "robot": sims[a.sim].name,
                    "q": d.state.q.as_slice(),
                    "incidence_deg": a.cos_incidence.clamp(-1.0, 1.0).acos().to_degrees(),
                    "area_m2": a.cells.area_m2,
                    "power_w": a.power_w,
                })
            })
            .collect();
        let power = self.efficiency.map(|e| {
            json!({
                "efficiency": e,
                "power_w": self.power_w,
                "energy_kwh": self.energy_j / 3.6e6,
                "battery_soc": self.battery.soc,
                "battery_kwh": self.battery.energy_j() / 3.6e6,
                "battery_capacity_kwh": self.battery.capacity_j / 3.6e6,
                "load_w": self.battery.load_w,
                "unserved_kwh": self.unserved_j / 3.6e6,
            })
        });
        json!({
            "t_s": self.t,
            "orbit": {
                "altitude_m": self.orbit.altitude_m,
                "beta_deg": self.orbit.beta_rad.to_degrees(),
                "period_s": self.orbit.period_s(),
                "angle_deg": self.theta.to_degrees(),
            },
            "sun_body": [self.sun.x, self.sun.y, self.sun.z],
            "eclipse": self.eclipse,
            "sun_tracking": self.tracking,
            "arrays": arrays,
            "power": power,
            "ops": self.ops.as_ref().map(|o| o.status(&self.battery, &self.orbit, self.t)),
        })
    }
}

/// The pipelines' step (s): what the next step will take.
fn dt_next(sims: &[Sim]) -> f64 {
    sims.first().map_or(0.0, |s| s.pipeline.model().dt)
}

/// `q` with each revolute joint moved by whole turns to the value nearest `now` that stays
/// within its limits (a gimbal need not turn the long way round).
fn nearest_within_limits(robot: &robosim_kinematics::Robot, q: &[f64], now: &[f64]) -> Vec<f64> {
    q.iter()
        .zip(now)
        .zip(&robot.joints)
        .map(|((&v, &n), j)| {
            if j.joint_type != robosim_kinematics::JointType::Revolute {
                return v;
            }
            let k = ((n - v) / TAU).round();
            [k - 1.0, k, k + 1.0]
                .iter()
                .map(|k| v + k * TAU)
                .filter(|c| *c >= j.qlim[0] && *c <= j.qlim[1])
                .min_by(|a, b| (a - n).abs().total_cmp(&(b - n).abs()))
                .unwrap_or(v)
        })
        .collect()
}
