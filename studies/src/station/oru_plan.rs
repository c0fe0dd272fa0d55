//! The ORU swap planned by rules (issue 38 item 5): `--fault array_oru@T` fails the
//! power-system ORU of the array that carries the scene's swappable ORU at T s — the array
//! delivers [`ORU_LOSS`] less than the power model expects at its angles until the spare is
//! bolted. `oru_swap.clp` (shipped in `hl-interface/rules/rulebases/`, run in process by the
//! CLIPS engine) watches every array's power against the model's expectation, diagnoses the
//! failure, schedules the swap and asks for its steps one at a time from the state the study
//! observes each step ([`Planner::step`]: servicer pose and motion, where the ORUs are,
//! whether the array is parked). Each step asked for is executed by the geometry: its
//! waypoints ([`SwapStep::waypoints`] of [`Swap::task_with`]) timed at the servicer's speed
//! limits ([`Swap::timed`]) from the next sample, appended to the run's plan — after its
//! motion is checked for collisions with the same clearance functions the study uses
//! (servicer with what it carries against the fixed structure, the ORUs set down, the
//! obstacles, and the parked array), sampled as densely as the between-step check
//! ([`super::between_samples`]). A step closer than [`STEP_CLEARANCE_M`] is refused with the
//! pair and time named; the rules replan (an alternate stowage site, [`ALT_STOW_OFFSET`]),
//! retry, or halt and report.
//!
//! The power scheduler sees the swap coming: once it is scheduled, the forecast of every step
//! ([`Planner::forecast`]) carries the predicted parked window, the parked array's power at its
//! service angle in place of its tracking power over it.
//!
//! Without an `array_oru` fault the swap runs on the scene's declared timetable (a planned
//! maintenance, [`Swap::schedule`]), as before.
//!
//! Entry points: [`Planner::new`], [`Planner::step`], [`Planner::forecast`], [`SwapRun`].

use super::faults::FaultSpec;
use super::loads::Forecast;
use super::scheduler::Decision;
use super::{Held, OruState, Plan, Setup, StationParams, Waypoint, servicer_at};
use crate::common::{self, Posed};
use crate::{Result, StudyError, bail};
use nalgebra::{Isometry3, Vector3};
use robosim_rules::clips::{Arg, Limits, arg_text as text, float_literal as num, quote};
use robosim_rules::embedded::{Embedded, Pending};
use robosim_simulator::swap::{ABOVE, GRAPPLE_M, STOW_OFFSET, SwapStep};
use std::cell::RefCell;
use std::rc::Rc;

/// The fault's name on the command line (`--fault array_oru@T`).
pub const FAULT: &str = "array_oru";
/// The share of its array's generation the failed ORU costs until the spare is bolted
/// (assumed: the ORU regulates one of the array's two strings — on the ISS each power channel
/// runs through a sequential shunt unit, an ORU; its failure takes the channel off the bus).
pub const ORU_LOSS: f64 = 0.5;
/// A step of the swap whose motion comes closer than this to anything is refused, m (the
/// nominal swap's closest approach is 0.05 m: the effector over a grapple fixture).
pub const STEP_CLEARANCE_M: f64 = 0.01;
/// The alternate stowage site for the failed ORU, from the spare (body frame, m): the other
/// side of the spare from [`STOW_OFFSET`].
pub const ALT_STOW_OFFSET: [f64; 3] = [0.0, -1.2, 0.0];
/// How close the effector must be to a site to be "at" it, m.
pub const POSE_TOL_M: f64 = 0.02;
/// The rule base (also in `robosim_rules::embedded::SHIPPED` when it lists it).
pub const RULE_BASE: &str = "oru_swap.clp";

/// An ORU-sized unit (the spare's box) left at `at` (its grapple frame, body frame) from
/// `from_s` until `until_s`: an obstacle the servicer's steps are checked against.
#[derive(Debug, Clone, PartialEq)]
pub struct Obstacle {
    pub at: Isometry3<f64>,
    pub from_s: f64,
    pub until_s: f64,
}

/// Whether `f` is the array ORU fault (else an ECLSS failure mode).
pub fn is_array_fault(f: &FaultSpec) -> bool {
    f.failure_mode == FAULT
}

/// What the planned swap did over a run.
#[derive(Debug, Clone, Default)]
pub struct SwapRun {
    /// The array carrying the ORU (body name), the fault's time, s.
    pub array: String,
    pub fault_s: f64,
    /// When the rules diagnosed the failure, scheduled the swap and its start, s.
    pub diagnosed_s: Option<f64>,
    pub scheduled_s: Option<f64>,
    pub start_s: Option<f64>,
    /// The steps executed: the step, when asked for, its motion's start and end, s.
    pub steps: Vec<(SwapStep, f64, f64, f64)>,
    /// The steps refused: when, which, why.
    pub refused: Vec<(f64, SwapStep, String)>,
    /// When the spare was bolted (the failed ORU's loss ends), s.
    pub bolted_s: Option<f64>,
    /// The swap halted by the rules (a step refused too often), when swapped, s.
    pub halted_s: Option<f64>,
    pub done_s: Option<f64>,
    /// The failed ORU's loss per step (t, W, sunlit steps only non-zero) and in all, J.
    pub loss_w: Vec<(f64, f64)>,
    pub lost_j: f64,
    /// Per step: the parked window the power scheduler's forecast carried (start, end s;
    /// none before the swap is scheduled) and the energy it subtracts inside the horizon, J.
    pub forecast_windows: Vec<(f64, Option<(f64, f64)>, f64)>,
    /// The planner's decisions, in order.
    pub decisions: Vec<Decision>,
}

/// What the handler leaves for the study.
#[derive(Default)]
struct Shared {
    commands: Vec<Vec<Arg>>,
}

/// The planner over a run ([module docs](self)).
pub struct Planner {
    engine: Embedded,
    shared: Rc<RefCell<Shared>>,
    /// The task's waypoints for the current stowage site, and that site (from the spare).
    task: Vec<Waypoint>,
    stow: Vector3<f64>,
    /// Per step: its nominal duration from the previous step's end, s.
    durations: Vec<f64>,
    /// The next step not yet accepted (index in [`SwapStep::ALL`]); when the last accepted
    /// step's motion ends, s; when the array was parked and unparked, s.
    next: usize,
    busy_until: f64,
    parked_s: Option<f64>,
    unparked_s: Option<f64>,
    obstacles: Vec<(common::Part, Obstacle)>,
    step_s: f64,
    pub run: SwapRun,
}

/// `(robosim …)` from oru_swap.clp: decisions are recorded, the rest queued for the study.
fn handle(sh: &mut Shared, args: &[Arg]) -> std::result::Result<i64, String> {
    let cmd = text(args.first());
    match cmd.as_str() {
        "oru-decide" => {
            if args.len() != 5 {
                return Err(format!(
                    "(oru-decide RULE TARGET ACTION REASON): {} arguments",
                    args.len() - 1
                ));
            }
            sh.commands.push(args.to_vec());
            Ok(0)
        }
        "oru-schedule" | "oru-replan" | "oru-do" => {
            // (oru-schedule RULE ARRAY START REASON), (oru-do|oru-replan RULE WHAT REASON)
            let want = if cmd == "oru-schedule" { 5 } else { 4 };
            if args.len() != want {
                return Err(format!("({cmd} …): {} arguments", args.len() - 1));
            }
            sh.commands.push(args.to_vec());
            Ok(0)
        }
        other => Err(format!(
            "unknown command {other:?} (oru-decide, oru-schedule, oru-do, oru-replan)"
        )),
    }
}

impl Planner {
    /// The planner for `p`'s fault when it is [`FAULT`] (None otherwise: the declared
    /// timetable runs); refused without CLIPS, saying what to install.
    pub fn new(s: &Setup, p: &StationParams) -> Result<Option<Planner>> {
        let Some(f) = p.fault.as_ref().filter(|f| is_array_fault(f)) else {
            if !p.oru_obstacles.is_empty() {
                bail!("ORU obstacles are checked by the planned swap: they need --fault {FAULT}@T");
            }
            return Ok(None);
        };
        if !robosim_rules::BUILT_WITH_CLIPS {
            bail!(
                "--fault {FAULT}: the swap is planned by {RULE_BASE} in the CLIPS engine: {}",
                robosim_rules::NOT_BUILT
            );
        }
        let shared: Rc<RefCell<Shared>> = Rc::default();
        let s2 = shared.clone();
        let mut engine = Embedded::new(
            Box::new(move |args: &[Arg], _pending: &mut Vec<Pending>| {
                let mut sh = s2
                    .try_borrow_mut()
                    .map_err(|_| "the study's state is busy (a nested call)".to_owned())?;
                handle(&mut sh, args)
            }),
            Limits::default(),
        )
        .map_err(|e| StudyError::at("ORU planner", e))?;
        let text = robosim_rules::embedded::shipped(RULE_BASE).ok_or_else(|| {
            StudyError::Message(format!("{RULE_BASE} is not among the shipped rule bases"))
        })?;
        engine
            .load_text(RULE_BASE, text)
            .map_err(|e| StudyError::at(RULE_BASE, e))?;
        let swap = &s.oru.swap;
        let array = s.bodies[swap.array].name.clone();
        let fx_spare = s.oru.swap.objects[1].0.clone();
        engine
            .assert_str(&format!(
                "(oru-swap-declared (array {array}) (spare {}))",
                quote(&fx_spare)
            ))
            .map_err(|e| StudyError::at(RULE_BASE, e))?;
        let stow = Vector3::from(STOW_OFFSET);
        let task = swap.task_with(&stow).map_err(StudyError::from)?;
        let obstacles = p
            .oru_obstacles
            .iter()
            .map(|o| {
                let mut part = s.oru.parts[1].clone();
                part.name = "obstacle".into();
                (part, o.clone())
            })
            .collect();
        let mut out = Planner {
            engine,
            shared,
            durations: Vec::new(),
            task,
            stow,
            next: 0,
            busy_until: 0.0,
            parked_s: None,
            unparked_s: None,
            obstacles,
            step_s: p.step_s,
            run: SwapRun {
                array,
                fault_s: f.t_s,
                ..SwapRun::default()
            },
        };
        out.durations = out.step_durations(s);
        Ok(Some(out))
    }

    /// Each step's duration from the end of the one before, s (nominal, at the speed limits).
    fn step_durations(&self, s: &Setup) -> Vec<f64> {
        let swap = &s.oru.swap;
        let mut q = swap.servicer_q0.clone();
        SwapStep::ALL
            .iter()
            .map(|st| {
                let wps = self.waypoints(*st, &q);
                let plan = swap.timed(&wps, 0.0);
                if let Some(last) = wps.last() {
                    q = last.q.clone();
                }
                plan.points.last().map_or(0.0, |x| x.0)
            })
            .collect()
    }

    /// The waypoints of step `st` from the servicer at `q`: a hold there, then the step's
    /// (its park/unpark events stripped: they are steps of their own).
    fn waypoints(&self, st: SwapStep, q: &[f64]) -> Vec<Waypoint> {
        let mut out = vec![Waypoint {
            what: "waiting for the planner's next step",
            q: q.to_vec(),
            dwell_s: 0.0,
            on_arrival: None,
            after_dwell: None,
        }];
        for w in self.task.get(st.waypoints()).unwrap_or(&[]) {
            let mut w = w.clone();
            for e in [&mut w.on_arrival, &mut w.after_dwell] {
                if matches!(e, Some(super::OruEvent::Park | super::OruEvent::Unpark)) {
                    *e = None;
                }
            }
            out.push(w);
        }
        out
    }

    /// The share of array `ai`'s generation it delivers at `t` (the failed ORU's loss).
    pub fn share(&self, s: &Setup, ai: usize, t: f64) -> f64 {
        let failed =
            ai == s.oru.array && t >= self.run.fault_s && self.run.bolted_s.is_none_or(|b| t < b);
        if failed { 1.0 - ORU_LOSS } else { 1.0 }
    }

    /// One study step at `t`: the observations asserted, the rules run, the steps they ask for
    /// executed (or refused) on `plan`. `arrays`: per array, the power it delivers and what the
    /// power model expects at its angles (W), and whether it is parked.
    pub fn step(
        &mut self,
        s: &Setup,
        p: &StationParams,
        t: f64,
        eclipse: bool,
        arrays: &[(f64, f64, bool)],
        plan: &mut Plan,
    ) -> Result<()> {
        // the failed ORU's loss at this step (held over the next interval, as the power)
        let ai = s.oru.array;
        let (got, expected, _) = arrays[ai];
        let loss = if eclipse { 0.0 } else { expected - got };
        if let Some(&(t0, w)) = self.run.loss_w.last() {
            self.run.lost_j += w * (t - t0);
        }
        self.run.loss_w.push((t, loss.max(0.0)));
        let err =
            |e: robosim_rules::RulesError| StudyError::at(format!("{RULE_BASE} at t = {t} s"), e);
        for tpl in ["oru-now", "oru-array", "oru-servicer", "oru-unit"] {
            self.engine
                .eval(&format!(
                    "(do-for-all-facts ((?f {tpl})) TRUE (retract ?f))"
                ))
                .map_err(err)?;
        }
        for f in self.observations(s, t, eclipse, arrays, plan) {
            self.engine.assert_str(&f).map_err(err)?;
        }
        for _ in 0..32 {
            self.engine.run().map_err(err)?;
            let commands: Vec<Vec<Arg>> = self.shared.borrow_mut().commands.drain(..).collect();
            if commands.is_empty() {
                return Ok(());
            }
            for c in commands {
                if let Some(fact) = self.apply(s, p, t, &c, plan)? {
                    self.engine.assert_str(&fact).map_err(err)?;
                }
            }
        }
        bail!("{RULE_BASE} at t = {t} s: the rules ask for steps without end (32 rounds)")
    }

    /// The observation facts of a step (oru_swap.clp's oru-now, oru-array, oru-servicer,
    /// oru-unit), from the model's state.
    fn observations(
        &self,
        s: &Setup,
        t: f64,
        eclipse: bool,
        arrays: &[(f64, f64, bool)],
        plan: &Plan,
    ) -> Vec<String> {
        let swap = &s.oru.swap;
        let mut out = vec![format!(
            "(oru-now (t {}) (step {}))",
            num(t),
            num(self.step_s)
        )];
        for (ai, a) in s.arrays.iter().enumerate() {
            let (got, expected, parked) = arrays[ai];
            let yn = |b: bool| if b { "yes" } else { "no" };
            out.push(format!(
                "(oru-array (name {}) (serviced {}) (parked {}) (sunlit {}) (power-kw {}) (expected-kw {}))",
                s.bodies[a.body].name,
                yn(ai == s.oru.array),
                yn(parked),
                yn(!eclipse),
                num(got / 1e3),
                num(expected / 1e3)
            ));
        }
        let (q, _) = servicer_at(&plan.points, t);
        let busy = plan.points.last().is_some_and(|x| t < x.0 - 1e-9);
        out.push(format!(
            "(oru-servicer (busy {}) (pose {}))",
            if busy { "yes" } else { "no" },
            self.pose(s, &q)
        ));
        let st = swap.state(plan, t);
        let failed = match st.failed {
            Held::OnArray => "on-array",
            Held::Carried(_) => "held",
            Held::Fixed(_) => "set-down",
        };
        let spare = match st.spare {
            Held::OnArray => "bolted",
            Held::Carried(_) => "held",
            Held::Fixed(w) => {
                if (w.translation.vector - swap.spare.translation.vector).norm() < POSE_TOL_M {
                    "on-truss"
                } else {
                    "set-down"
                }
            }
        };
        out.push(format!("(oru-unit (which failed) (where {failed}))"));
        out.push(format!("(oru-unit (which spare) (where {spare}))"));
        out
    }

    /// Where the servicer's effector is at `q`: at or above one of the swap's sites (the
    /// grapple height over it), at rest, at the ORU site along the truss, or between.
    fn pose(&self, s: &Setup, q: &[f64]) -> String {
        let swap = &s.oru.swap;
        let e = swap.effector(q).translation.vector;
        let [oru, spare, stow] = swap.sites_with(&self.stow);
        for (name, site) in [("oru", oru), ("stow", stow), ("spare", spare)] {
            let at = site.coords + Vector3::z() * GRAPPLE_M;
            if (e - at).norm() < POSE_TOL_M {
                return name.into();
            }
            if (e - (at + Vector3::z() * ABOVE)).norm() < POSE_TOL_M {
                return format!("above-{name}");
            }
        }
        let near = |r: &[f64]| q.iter().zip(r).all(|(a, b)| (a - b).abs() < 1e-6);
        if near(&swap.servicer_q0) {
            "rest".into()
        } else if self
            .task
            .get(SwapStep::Travel.waypoints())
            .and_then(|w| w.last())
            .is_some_and(|w| near(&w.q))
        {
            "site".into()
        } else {
            "between".into()
        }
    }

    /// One command of the rules; the fact answering it, if any.
    fn apply(
        &mut self,
        s: &Setup,
        p: &StationParams,
        t: f64,
        c: &[Arg],
        plan: &mut Plan,
    ) -> Result<Option<String>> {
        let (cmd, rule) = (text(c.first()), text(c.get(1)));
        let record = |run: &mut SwapRun, target: &str, action: String, reason: String| {
            run.decisions.push(Decision {
                t,
                rule: format!("oru_swap {rule}"),
                target: target.to_owned(),
                action,
                reason,
            });
        };
        match cmd.as_str() {
            "oru-decide" => {
                let (target, action) = (text(c.get(2)), text(c.get(3)));
                match action.as_str() {
                    "diagnosed" => {
                        self.run.diagnosed_s.get_or_insert(t);
                    }
                    "halted" => {
                        self.run.halted_s.get_or_insert(t);
                    }
                    "swapped" => {
                        self.run.done_s.get_or_insert(t);
                    }
                    _ => {}
                }
                record(&mut self.run, &target, action, text(c.get(4)));
                Ok(None)
            }
            "oru-schedule" => {
                let start = match c.get(3) {
                    Some(Arg::Num(x)) if x.is_finite() => *x,
                    other => bail!("{RULE_BASE} rule {rule}: start {other:?} is not a time"),
                };
                self.run.scheduled_s = Some(t);
                self.run.start_s = Some(start);
                let target = text(c.get(2));
                record(
                    &mut self.run,
                    &target,
                    format!("schedule swap from {start:.0} s"),
                    text(c.get(4)),
                );
                Ok(None)
            }
            "oru-replan" => {
                let site = text(c.get(2));
                let reason = text(c.get(3));
                let offset = Vector3::from(ALT_STOW_OFFSET);
                match s.oru.swap.task_with(&offset) {
                    Ok(task) => {
                        self.task = task;
                        self.stow = offset;
                        self.durations = self.step_durations(s);
                        record(
                            &mut self.run,
                            &site,
                            format!(
                                "stow at ({:+.1}, {:+.1}, {:+.1}) m from the spare",
                                offset.x, offset.y, offset.z
                            ),
                            reason,
                        );
                    }
                    Err(e) => record(
                        &mut self.run,
                        &site,
                        "alternate site unreachable".into(),
                        format!("{reason}; but {}", e.0),
                    ),
                }
                Ok(None)
            }
            "oru-do" => {
                let name = text(c.get(2));
                let reason = text(c.get(3));
                let Some(step) = SwapStep::parse(&name) else {
                    bail!("{RULE_BASE} rule {rule}: no step {name:?} in the swap");
                };
                let start = t + self.step_s;
                match self.execute(s, p, step, start, plan) {
                    Ok(end) => {
                        self.run.steps.push((step, t, start, end));
                        self.busy_until = end;
                        self.next = SwapStep::ALL
                            .iter()
                            .position(|x| *x == step)
                            .map_or(self.next, |i| i + 1);
                        match step {
                            SwapStep::Park => self.parked_s = Some(start),
                            SwapStep::Unpark => self.unparked_s = Some(start),
                            SwapStep::Install => {
                                self.run.bolted_s = plan
                                    .events
                                    .iter()
                                    .rev()
                                    .find(|e| e.1 == super::OruEvent::InstallSpare)
                                    .map(|e| e.0);
                            }
                            _ => {}
                        }
                        record(
                            &mut self.run,
                            &name,
                            format!("do {start:.0}-{end:.0} s"),
                            reason,
                        );
                        Ok(Some(format!("(oru-accepted (step {name}))")))
                    }
                    Err(why) => {
                        self.run.refused.push((t, step, why.clone()));
                        record(
                            &mut self.run,
                            &name,
                            "refused".into(),
                            format!("{reason} — refused by the geometry: {why}"),
                        );
                        Ok(Some(format!(
                            "(oru-refused (step {name}) (reason {}))",
                            quote(&why)
                        )))
                    }
                }
            }
            other => bail!("{RULE_BASE}: unknown command {other:?}"),
        }
    }

    /// Executes `step` from `start` on `plan` when its motion clears: the end of its motion,
    /// or why it was refused.
    fn execute(
        &self,
        s: &Setup,
        p: &StationParams,
        step: SwapStep,
        start: f64,
        plan: &mut Plan,
    ) -> std::result::Result<f64, String> {
        let swap = &s.oru.swap;
        let (q, _) = servicer_at(&plan.points, start);
        let wps = self.waypoints(step, &q);
        let mut seg = swap.timed(&wps, start);
        if let Some(e) = step.event() {
            seg.events.push((start, e));
        }
        let mut tmp = plan.clone();
        tmp.points.extend(seg.points.iter().cloned());
        tmp.events.extend(seg.events.iter().cloned());
        // the motion sampled as densely as the between-step check (and the step's start, for
        // a park: the array turned to its service angle with the servicer there)
        let mut times = vec![start];
        for w in seg.points.windows(2) {
            let n = super::between_samples(s, p, &w[0].1, &w[1].1);
            times.extend(
                (1..=n + 1).map(|k| w[0].0 + (w[1].0 - w[0].0) * k as f64 / (n + 1) as f64),
            );
        }
        let fixed = common::pose_fixed(&s.fixed);
        let mut worst: Option<(f64, f64, String, String)> = None;
        for tu in times {
            let (sq, what) = servicer_at(&tmp.points, tu);
            let ost: OruState = swap.state(&tmp, tu);
            let posed = super::servicer_posed(s, &sq, &ost);
            let mut around: Vec<Posed<'_>> = fixed.clone();
            for (h, part) in [ost.failed, ost.spare].iter().zip(&s.oru.parts) {
                if let Held::Fixed(w) = h {
                    around.push(super::posed_oru(part, w));
                }
            }
            for (part, o) in &self.obstacles {
                if o.from_s <= tu && tu < o.until_s {
                    around.push(super::posed_oru(part, &o.at));
                }
            }
            let mut cands: Vec<common::Clearance> = Vec::new();
            cands.extend(common::clearance(&posed, &around, p.mode));
            if ost.parked {
                cands.extend(super::array_clearance(
                    s,
                    s.oru.array,
                    &swap.service_q,
                    &posed,
                    &ost,
                    p.mode,
                ));
            }
            for c in cands {
                if worst.as_ref().is_none_or(|w| c.distance < w.0) {
                    worst = Some((
                        c.distance,
                        tu,
                        format!("{} × {}", c.a, c.b),
                        what.to_owned(),
                    ));
                }
            }
        }
        if let Some((d, tu, pair, what)) = &worst
            && *d < STEP_CLEARANCE_M
        {
            return Err(format!(
                "{pair} {d:.3} m at t = {tu:.0} s ({what}), below {STEP_CLEARANCE_M} m"
            ));
        }
        let end = seg.points.last().map_or(start, |x| x.0);
        plan.points.extend(seg.points);
        plan.events.extend(seg.events);
        Ok(end)
    }

    /// The parked window predicted at `t` (start, end s): from the swap's state and the
    /// remaining steps' nominal durations (a step asked for one sample after the last ends).
    pub fn predicted_park(&self, t: f64) -> Option<(f64, f64)> {
        let start = self.run.start_s?;
        if self.run.halted_s.is_some() {
            // halted: parked until the operators act (beyond any horizon)
            return self
                .parked_s
                .filter(|_| self.unparked_s.is_none())
                .map(|a| (a, f64::INFINITY));
        }
        if let Some(u) = self.unparked_s {
            return self.parked_s.map(|a| (a, u)).filter(|w| w.1 > t);
        }
        let park = 1; // SwapStep::ALL's index of Park
        let unpark = SwapStep::ALL.len() - 1;
        let lag = self.step_s;
        let mut at = self
            .busy_until
            .max(t)
            .max(if self.next == 0 { start } else { 0.0 });
        let mut park_s = self.parked_s;
        for i in self.next..unpark {
            at += lag;
            if i == park && park_s.is_none() {
                park_s = Some(at);
            }
            at += self.durations.get(i).copied().unwrap_or(0.0);
        }
        park_s.map(|a| (a, at + lag))
    }

    /// `f` with the parked window predicted at `t` in it: inside the window a sunlit phase's
    /// power is less the parked array's loss — its tracking power less its power at the
    /// service angle (the orbit's sun in LVLH), both at the fault's share, averaged over
    /// the piece. The phases are cut at the window's ends (a cut's later pieces are
    /// `sunlit-cont`, so that station_power.clp's next sunrise stays the orbit's). Recorded
    /// with the energy it takes out.
    pub fn forecast(&mut self, s: &Setup, p: &StationParams, t: f64, f: Forecast) -> Forecast {
        let Some((w0, w1)) = self.predicted_park(t) else {
            self.run.forecast_windows.push((t, None, 0.0));
            return f;
        };
        let a = &s.arrays[s.oru.array];
        let robot = &s.bodies[a.body].robot;
        let n_service = a.cells.normal_at(robot, &s.oru.swap.service_q);
        let loss_at = |tu: f64| {
            let sun = s.orbit.sun_body(s.orbit.angle(p.theta0, tu));
            let share = self.share(s, s.oru.array, tu);
            let tracking = a.cells.power_w(s.efficiency, 1.0);
            let parked = a.cells.power_w(s.efficiency, n_service.dot(&sun));
            (tracking - parked) * share
        };
        let (f, taken) = park_in(f, (w0, w1), loss_at);
        self.run.forecast_windows.push((t, Some((w0, w1)), taken));
        f
    }

    /// The run's record.
    pub fn finish(self) -> SwapRun {
        self.run
    }
}

/// `f` with a parked window `w` (start, end s) in it: a sunlit phase's power inside the window
/// is less `loss_at`'s mean over the piece (W, sampled at most every minute; never below 0).
/// The phases are cut at the window's ends; a cut phase's later pieces are `sunlit-cont`, so
/// that station_power.clp's next sunrise stays the orbit's. Also the energy taken out, J.
pub fn park_in(f: Forecast, w: (f64, f64), loss_at: impl Fn(f64) -> f64) -> (Forecast, f64) {
    let (w0, w1) = w;
    let mut phases = Vec::new();
    let mut taken = 0.0;
    for (kind, x, y, w) in f.phases {
        if kind == "eclipse" {
            phases.push((kind, x, y, w));
            continue;
        }
        let mut cuts = vec![x];
        for c in [w0, w1] {
            if c > x && c < y {
                cuts.push(c);
            }
        }
        cuts.push(y);
        for (i, ab) in cuts.windows(2).enumerate() {
            let (a0, b0) = (ab[0], ab[1]);
            let inside = a0 >= w0 && b0 <= w1;
            let k: &'static str = if i == 0 { kind } else { "sunlit-cont" };
            if inside && b0 > a0 {
                let n = (((b0 - a0) / 60.0).ceil() as usize).clamp(1, 60);
                let mean = (0..n)
                    .map(|j| loss_at(a0 + (b0 - a0) * (j as f64 + 0.5) / n as f64))
                    .sum::<f64>()
                    / n as f64;
                let mean = mean.min(w).max(0.0);
                taken += mean * (b0 - a0);
                phases.push((k, a0, b0, w - mean));
            } else {
                phases.push((k, a0, b0, w));
            }
        }
    }
    (Forecast { phases }, taken)
}

/// The summary's notes on the planned swap.
pub fn notes(r: &SwapRun) -> Vec<String> {
    let min = |t: f64| format!("{:.1} min", t / 60.0);
    let mut out = vec![format!(
        "Planned ORU swap ({RULE_BASE}): {}'s power-system ORU failed at {} (costing {:.0} % of its generation); {}.",
        r.array,
        min(r.fault_s),
        100.0 * ORU_LOSS,
        match (r.diagnosed_s, r.scheduled_s, r.start_s) {
            (Some(d), Some(s), Some(st)) => format!(
                "diagnosed by the guard at {}, the swap scheduled at {} to start at {}",
                min(d),
                min(s),
                min(st)
            ),
            (Some(d), _, _) => format!("diagnosed at {} but no swap scheduled", min(d)),
            _ => "not diagnosed within the run".into(),
        }
    )];
    for (st, asked, a, b) in &r.steps {
        out.push(format!(
            "Swap step {} asked for at {}: {}–{}.",
            st.name(),
            min(*asked),
            min(*a),
            min(*b)
        ));
    }
    for (t, st, why) in &r.refused {
        out.push(format!(
            "Swap step {} refused at {}: {why}.",
            st.name(),
            min(*t)
        ));
    }
    out.push(match (r.bolted_s, r.halted_s) {
        (Some(b), _) => format!(
            "The spare bolted at {}: the failed ORU cost {:.1} kWh until then, nothing after.",
            min(b),
            r.lost_j / 3.6e6
        ),
        (None, Some(h)) => format!(
            "The swap was halted at {} (a step refused after its retries): the failed ORU cost {:.1} kWh over the run.",
            min(h),
            r.lost_j / 3.6e6
        ),
        (None, None) => format!(
            "The spare was not bolted within the run: the failed ORU cost {:.1} kWh.",
            r.lost_j / 3.6e6
        ),
    });
    if let Some((t, Some((a, b)), e)) = r.forecast_windows.iter().find(|x| x.1.is_some()) {
        out.push(format!(
            "The power scheduler's forecast carried the parked window from {} (first predicted {}–{}, {:.1} kWh less inside the horizon).",
            min(*t),
            min(*a),
            if b.is_finite() { min(*b) } else { "open".into() },
            e / 3.6e6
        ));
    }
    out
}
