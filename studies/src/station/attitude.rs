//! The station study's attitude (`robosim study station --attitude`, the scene's declared
//! `attitude { … }` effect, [`robosim_simulator::attitude`]): the model's mass properties and
//! its facets as the flow sees them, recomputed from the bodies' joint values at every step of
//! the study (the arrays turn, the servicer moves) and held over the step while the attitude is
//! integrated in substeps; the desaturations; the energy the attitude costs the arrays; the
//! summary's rows, notes and plots; the accuracy of the attitude integration against a fine
//! reference.

use super::{Run, Setup, StationParams};
use crate::{Result, StudyError, bail};
use nalgebra::{Matrix3, Matrix4, Vector3};
use robosim_library::PlacedSolid;
use robosim_simulator::attitude::{
    self as att, Attitude, Config, Drag, Facet, MassProps, RCS_JETS, RCS_THRUST_N,
};
use robosim_simulator::orbit::Orbit;
use std::path::Path;

/// Largest gimbal rate of the arrays' joints, rad/s: 0.25°/s, four times the orbit rate the
/// tracking needs (assumed; the ISS's SARJ tracks at ~4°/min and slews faster).
pub const GIMBAL_RATE: f64 = 0.25 * std::f64::consts::PI / 180.0;

/// What the attitude needs from the model, in the frames the parts ride in.
pub struct AttitudeSetup {
    pub effect: robosim_library::AttitudeEffect,
    /// Per body, per link frame (0 = base): the facets in that frame.
    pub facets: Vec<Vec<Vec<Facet>>>,
    /// The fixed solids' facets (world = body frame).
    pub fixed_facets: Vec<Facet>,
    /// The fixed solids' mass properties (body frame).
    pub fixed_mass: Option<MassProps>,
    /// The experiment point (body frame, m): the lab module's centre.
    pub experiment: Vector3<f64>,
    /// The pressurised modules' vertices (body frame), for the jets' lever arm.
    pub modules: Vec<Vector3<f64>>,
}

/// The facets of a placed part (`frame` × its transform): Newell's area vector per polygon,
/// turned away from the part's centroid (the library's parts are convex but for a dish).
fn part_facets(p: &PlacedSolid, frame: &Matrix4<f64>, out: &mut Vec<Facet>) {
    Facet::of_polyhedron(&p.polyhedron, &(frame * p.transform), out);
}

/// The scene's attitude effect and the model's facets and masses (`Setup::scene`).
pub fn setup(s: &Setup) -> Result<AttitudeSetup> {
    let Some(effect) = s.scene.effects.attitude else {
        bail!("{} declares no attitude effect", super::SCENE);
    };
    let facets = s
        .scene
        .robots
        .iter()
        .map(|r| {
            r.model
                .frames
                .iter()
                .map(|parts| {
                    let mut f = Vec::new();
                    for p in parts {
                        part_facets(p, &Matrix4::identity(), &mut f);
                    }
                    f
                })
                .collect()
        })
        .collect();
    let mut fixed_facets = Vec::new();
    let mut fixed = Vec::new();
    let mut experiment = None;
    let mut modules = Vec::new();
    for it in &s.scene.solids {
        for p in &it.solid.parts {
            part_facets(p, &it.placement, &mut fixed_facets);
            let leaf = p.name.split('/').next().unwrap_or(&p.name);
            if ["lab", "hab", "node"].iter().any(|m| leaf.starts_with(m)) {
                let m = it.placement * p.transform;
                modules.extend(
                    p.polyhedron
                        .vertices
                        .iter()
                        .map(|v| (m * v.to_homogeneous()).xyz()),
                );
                if p.name == "lab/shell" {
                    experiment = Some((m * nalgebra::Vector4::new(0.0, 0.0, 0.0, 1.0)).xyz());
                }
            }
        }
        if let Some(mp) = &it.solid.mass {
            let r = it.placement.fixed_view::<3, 3>(0, 0).into_owned();
            let c = (it.placement * mp.center_of_mass.to_homogeneous()).xyz();
            fixed.push((mp.mass, c, r * mp.inertia * r.transpose()));
        }
    }
    let Some(experiment) = experiment else {
        bail!(
            "{}: no part lab/shell (the experiment module) among the fixed solids",
            super::SCENE
        );
    };
    Ok(AttitudeSetup {
        effect,
        facets,
        fixed_facets,
        fixed_mass: MassProps::combine(fixed),
        experiment,
        modules,
    })
}

/// The model's configuration at joint values `qs` (one per body): mass properties about the
/// centre of mass, the drag geometry for the flow along `v_hat` (body frame), the jets' lever
/// arm (the farthest module vertex from the centre of mass) and the experiment point.
pub fn config(
    s: &Setup,
    a: &AttitudeSetup,
    qs: &[Vec<f64>],
    v_hat: &Vector3<f64>,
) -> Result<Config> {
    let mut parts: Vec<(f64, Vector3<f64>, Matrix3<f64>)> = Vec::new();
    if let Some(m) = a.fixed_mass {
        parts.push((m.mass, m.com, m.inertia));
    }
    let mut facets: Vec<Facet> = a.fixed_facets.clone();
    for ((b, q), fs) in s.bodies.iter().zip(qs).zip(&a.facets) {
        let frames = b.frames(q);
        for (j, joint) in b.robot.joints.iter().enumerate() {
            let f = &frames[j + 1];
            let r = f.fixed_view::<3, 3>(0, 0).into_owned();
            let t = f.fixed_view::<3, 1>(0, 3).into_owned();
            parts.push((
                joint.mass,
                r * joint.com + t,
                r * joint.inertia * r.transpose(),
            ));
        }
        for (link, lf) in fs.iter().enumerate() {
            let f = &frames[link];
            let r = f.fixed_view::<3, 3>(0, 0).into_owned();
            let t = f.fixed_view::<3, 1>(0, 3).into_owned();
            facets.extend(lf.iter().map(|x| Facet {
                centre: r * x.centre + t,
                area_normal: r * x.area_normal,
            }));
        }
    }
    let Some(mass) = MassProps::combine(parts) else {
        return Err(StudyError::Message(format!(
            "{}: the model has no mass",
            super::SCENE
        )));
    };
    let lever = a
        .modules
        .iter()
        .map(|v| (v - mass.com).norm())
        .fold(0.0, f64::max);
    Ok(Config {
        mass,
        drag: Drag::of(&facets, v_hat),
        lever_m: lever,
        experiment: a.experiment,
    })
}

/// One step's attitude record.
#[derive(Debug, Clone, Copy)]
pub struct AttStep {
    /// Attitude error against the commanded attitude, deg.
    pub error_deg: f64,
    /// CMG momentum, N·m·s, and as a fraction of the cluster's capacity.
    pub h_nms: f64,
    pub h_fraction: f64,
    pub dumping: bool,
    /// Disturbance acceleration at the experiment module, µg (the last substep's).
    pub accel_ug: f64,
    /// Principal moments of inertia, kg·m² (sorted), and the drag area, m².
    pub inertia: [f64; 3],
    pub drag_area_m2: f64,
    /// Power the tracking arrays lose to the attitude, W: their ideal at the commanded attitude
    /// less what they make at the actual one with rate-limited gimbals (0 in eclipse; feathered
    /// and parked arrays count with the feathering losses).
    pub attitude_loss_w: f64,
    /// The part of it the gimbals' rate costs: the ideal at the actual attitude less what the
    /// rate-limited gimbals reach, W (≥ 0).
    pub gimbal_loss_w: f64,
}

/// The attitude over a run.
#[derive(Debug, Clone)]
pub struct AttRun {
    pub dumps: Vec<att::Dump>,
    pub capacity_nms: f64,
    pub torque_limit_nm: f64,
    /// Largest attitude error outside and during the desaturations, deg.
    pub max_error_quiet_deg: f64,
    pub max_error_dump_deg: f64,
    /// Largest disturbance acceleration at the experiment module outside and during, µg.
    pub max_accel_quiet_ug: f64,
    pub max_accel_dump_ug: f64,
    /// Configurations computed (one per step) and their total wall time, s.
    pub recomputes: usize,
    pub recompute_s: f64,
    /// Wall time of the attitude integration, s, and its substeps.
    pub integrate_s: f64,
    pub substeps: usize,
    /// Energy the attitude cost the tracking arrays (the commanded attitude's ideal against
    /// the actual attitude with rate-limited gimbals), J.
    pub lost_j: f64,
    /// The part of it the gimbals' rate limit costs, J.
    pub gimbal_lost_j: f64,
    /// The held pitch from LVLH, rad (TEA; 0 for LVLH).
    pub pitch_rad: f64,
    /// The configurations per step (for the accuracy section).
    pub configs: Vec<Config>,
    pub mass: MassProps,
    pub lever_m: f64,
    pub rho: f64,
    pub substep_s: f64,
    /// The saturation fraction a desaturation starts at.
    pub saturation: f64,
}

/// The running attitude inside the study's loop.
pub struct Running {
    pub model: Attitude,
    pub cfg: Config,
    pub run: AttRun,
}

impl Running {
    /// Starts at the held attitude with the configuration at t = 0.
    pub fn start(
        s: &Setup,
        a: &AttitudeSetup,
        p: &StationParams,
        qs: &[Vec<f64>],
    ) -> Result<Running> {
        let t0 = std::time::Instant::now();
        let cfg = config(s, a, qs, &Vector3::x())?;
        let recompute_s = t0.elapsed().as_secs_f64();
        let model = Attitude::new(a.effect, s.orbit, p.theta0, &cfg).map_err(StudyError::from)?;
        let pitch = 2.0 * model.offset.imag().y.atan2(model.offset.w);
        Ok(Running {
            run: AttRun {
                dumps: Vec::new(),
                capacity_nms: model.capacity(),
                torque_limit_nm: model.torque_limit(),
                max_error_quiet_deg: 0.0,
                max_error_dump_deg: 0.0,
                max_accel_quiet_ug: 0.0,
                max_accel_dump_ug: 0.0,
                recomputes: 1,
                recompute_s,
                integrate_s: 0.0,
                substeps: 0,
                lost_j: 0.0,
                gimbal_lost_j: 0.0,
                pitch_rad: pitch,
                configs: vec![cfg],
                mass: cfg.mass,
                lever_m: cfg.lever_m,
                rho: model.rho,
                substep_s: p.attitude_step_s,
                saturation: a.effect.saturation,
            },
            model,
            cfg,
        })
    }

    /// Integrates to `t` with the configuration of the last step.
    pub fn advance(&mut self, t: f64, substep: f64) {
        let t0 = std::time::Instant::now();
        self.model.advance(&self.cfg, t, substep);
        self.run.integrate_s += t0.elapsed().as_secs_f64();
    }

    /// The configuration at this step's joint values (timed), for the next interval.
    pub fn reconfigure(&mut self, s: &Setup, a: &AttitudeSetup, qs: &[Vec<f64>]) -> Result<()> {
        let t0 = std::time::Instant::now();
        // the flow in the body frame of the actual attitude
        let theta = self.model.orbit.angle(self.model.theta0, self.model.t);
        let v_i = Vector3::z()
            .cross(&self.model.orbit.position(theta))
            .normalize();
        let v_hat = self.model.state.q.inverse() * v_i;
        self.cfg = config(s, a, qs, &v_hat)?;
        self.run.recompute_s += t0.elapsed().as_secs_f64();
        self.run.recomputes += 1;
        self.run.configs.push(self.cfg);
        Ok(())
    }

    /// This step's record.
    pub fn record(&self, attitude_loss_w: f64, gimbal_loss_w: f64) -> AttStep {
        let m = &self.model;
        let mut e = self.cfg.mass.inertia.symmetric_eigenvalues();
        e.as_mut_slice().sort_by(f64::total_cmp);
        AttStep {
            error_deg: m.error_rad.to_degrees(),
            h_nms: m.state.h.norm(),
            h_fraction: m.state.h.norm() / m.capacity(),
            dumping: m.dumping(),
            accel_ug: m.accel / att::G0 * 1e6,
            inertia: [e[0], e[1], e[2]],
            drag_area_m2: self.cfg.drag.area_m2,
            attitude_loss_w,
            gimbal_loss_w,
        }
    }

    /// The run's attitude summary.
    pub fn finish(mut self) -> AttRun {
        let m = &self.model;
        self.run.dumps = m.dumps.clone();
        self.run.max_error_quiet_deg = m.max_error_quiet.to_degrees();
        self.run.max_accel_quiet_ug = m.max_accel_quiet / att::G0 * 1e6;
        self.run.max_error_dump_deg = m
            .dumps
            .iter()
            .map(|d| d.max_error_rad.to_degrees())
            .fold(0.0, f64::max);
        self.run.max_accel_dump_ug = m
            .dumps
            .iter()
            .map(|d| d.max_accel / att::G0 * 1e6)
            .fold(0.0, f64::max);
        self.run.substeps = m.substeps;
        self.run
    }
}

/// The gimbal angles an array reaches from `prev` towards `want` in `dt` at [`GIMBAL_RATE`]
/// (the short way round).
pub fn rate_limited(prev: &[f64], want: &[f64], dt: f64) -> Vec<f64> {
    let step = GIMBAL_RATE * dt;
    prev.iter()
        .zip(want)
        .map(|(p, w)| super::wrap(p + super::wrap(w - p).clamp(-step, step)))
        .collect()
}

/// A desaturation's length when none has finished yet, s (assumed; the 20-orbit run's dumps
/// took ~40 s of pulses plus the loop's settling).
pub const DUMP_GUESS_S: f64 = 300.0;

/// The next desaturation window the momentum manager predicts at `t` (the attitude plan the
/// scheduler is given, seed §4.2 constraint 1), [start, end] s: under way — from its start to
/// its expected end; else when |h| reaches the saturation fraction at the secular growth rate
/// measured over the last orbit (or since the last desaturation, once a quarter orbit has
/// passed), opened a tenth of an orbit early for the rate's error. Its length: the last
/// finished desaturation's plus the loop's settling time 4/(ζ ω_n), else [`DUMP_GUESS_S`].
/// `None` when |h| does not grow.
pub fn predict_desaturation(
    steps: &[super::Step],
    now: &AttStep,
    r: &Running,
    t: f64,
    period: f64,
) -> Option<(f64, f64)> {
    let settle = 4.0 / (att::CONTROL_DAMPING * att::CONTROL_BANDWIDTH);
    let dumps = &r.model.dumps;
    let length = dumps
        .iter()
        .rev()
        .find_map(|d| d.end_s.map(|e| e - d.start_s + settle))
        .unwrap_or(DUMP_GUESS_S);
    if let Some(d) = dumps.last().filter(|d| d.end_s.is_none()) {
        return Some((d.start_s, (d.start_s + length).max(t)));
    }
    let since = dumps
        .last()
        .and_then(|d| d.end_s)
        .map_or(0.0, |e| e + settle)
        .max(t - period);
    if t - since < 0.25 * period {
        return None;
    }
    let h0 = steps
        .iter()
        .find(|st| st.t >= since)
        .and_then(|st| st.attitude)
        .map(|a| (st_t(steps, since), a.h_fraction))?;
    let rate = (now.h_fraction - h0.1) / (t - h0.0);
    // NaN (no time between the samples) or not growing: no prediction
    if rate.is_nan() || rate <= 0.0 {
        return None;
    }
    let at = t + ((r.run.saturation - now.h_fraction) / rate).max(0.0);
    Some(((at - 0.1 * period).max(t), at + length))
}

/// The time of the first step at or after `t`.
fn st_t(steps: &[super::Step], t: f64) -> f64 {
    steps.iter().find(|st| st.t >= t).map_or(t, |st| st.t)
}

/// The mean interval between desaturations, orbits: between the starts of consecutive ones,
/// and (when there is one) the first's start from t = 0 (momentum starts at zero).
pub fn mean_interval_orbits(dumps: &[att::Dump], period_s: f64) -> Option<f64> {
    let first = dumps.first()?;
    let span = dumps.last().map_or(0.0, |d| d.start_s);
    Some(if dumps.len() > 1 {
        (span - first.start_s) / (dumps.len() - 1) as f64 / period_s
    } else {
        first.start_s / period_s
    })
}

/// The summary table's attitude rows.
pub fn rows(run: &Run, a: &AttRun) -> Vec<(&'static str, String, &'static str)> {
    let orbits = run.steps.last().map_or(0.0, |s| s.t) / run.period_s;
    let interval = mean_interval_orbits(&a.dumps, run.period_s);
    let e0 = a.mass.inertia.symmetric_eigenvalues();
    vec![
        (
            "station mass (the model's)",
            format!("{:.1}", a.mass.mass / 1e3),
            "t",
        ),
        (
            "principal moments of inertia at the start",
            format!("{:.3e} / {:.3e} / {:.3e}", e0[0], e0[1], e0[2]),
            "kg·m²",
        ),
        (
            "CMG capacity (4 × 4760 N·m·s by default)",
            format!("{:.0}", a.capacity_nms),
            "N·m·s",
        ),
        (
            "held pitch from LVLH",
            format!("{:.3}", a.pitch_rad.to_degrees()),
            "deg",
        ),
        (
            "atmospheric density (Vallado table 8-4, USSA 1976)",
            format!("{:.3e}", a.rho),
            "kg/m³",
        ),
        (
            "desaturations",
            format!("{} in {orbits:.1} orbits", a.dumps.len()),
            "1",
        ),
        (
            "mean interval between desaturations (seed: about every tenth orbit)",
            interval.map_or("none".into(), |i| format!("{i:.2}")),
            "orbits",
        ),
        (
            "attitude error, largest between desaturations",
            format!("{:.4}", a.max_error_quiet_deg),
            "deg",
        ),
        (
            "attitude error, largest during a desaturation",
            format!("{:.4}", a.max_error_dump_deg),
            "deg",
        ),
        (
            "disturbance at the lab module, largest between desaturations",
            format!("{:.2}", a.max_accel_quiet_ug),
            "µg",
        ),
        (
            "disturbance at the lab module, largest during a desaturation",
            format!("{:.1}", a.max_accel_dump_ug),
            "µg",
        ),
        (
            "energy the attitude cost the tracking arrays (commanded attitude's ideal − reached; signed: the one-axis arrays cannot track, an attitude error may help them)",
            format!("{:.3}", a.lost_j / 3.6e6),
            "kWh",
        ),
        (
            "of which the gimbals' rate limit (could not follow)",
            format!("{:.3}", a.gimbal_lost_j / 3.6e6),
            "kWh",
        ),
        (
            "mass properties and drag geometry recomputed",
            format!(
                "{} times, {:.1} µs each",
                a.recomputes,
                a.recompute_s / a.recomputes.max(1) as f64 * 1e6
            ),
            "1",
        ),
        (
            "attitude integration",
            format!(
                "{} substeps of ≤ {} s, {:.3} s wall",
                a.substeps, a.substep_s, a.integrate_s
            ),
            "1",
        ),
    ]
}

/// The summary's attitude notes.
pub fn notes(run: &Run, a: &AttRun) -> Vec<String> {
    let mut out = vec![format!(
        "Attitude (effect `attitude`, simulator/src/attitude.rs): rigid body with the model's own mass properties ({:.1} t; recomputed from the joint values at every {} s step and held over it), gravity gradient 3μ/r³ r̂ × I r̂, drag ½ρv²C_D on the windward facets at ρ = {:.3e} kg/m³, a CMG cluster of {:.0} N·m·s and {:.0} N·m holding {} with a PD law (ω_n = {} rad/s, ζ = {}), desaturation from {:.0} % of capacity by pulses of {} × {RCS_THRUST_N} N jets on a {:.1} m lever (the modules' farthest point from the centre of mass), {} s long, mean torque {} of the cluster's. Gimbals follow the sun in the actual attitude at up to {:.2}°/s.",
        a.mass.mass / 1e3,
        run.steps.get(1).map_or(0.0, |s| s.t),
        a.rho,
        a.capacity_nms,
        a.torque_limit_nm,
        if a.pitch_rad == 0.0 {
            "LVLH".to_owned()
        } else {
            format!(
                "a torque-equilibrium attitude (LVLH pitched {:.3}°)",
                a.pitch_rad.to_degrees()
            )
        },
        att::CONTROL_BANDWIDTH,
        att::CONTROL_DAMPING,
        100.0 * a.saturation,
        RCS_JETS,
        a.lever_m,
        att::RCS_PULSE_S,
        att::DUMP_SHARE,
        GIMBAL_RATE.to_degrees(),
    )];
    for (k, d) in a.dumps.iter().enumerate() {
        out.push(format!(
            "Desaturation {}: orbit {:.2} ({:.1} min), {:.0} → {:.0} N·m·s in {} pulses over {}; attitude error up to {:.4}°, disturbance at the lab module up to {:.1} µg.",
            k + 1,
            d.start_s / run.period_s,
            d.start_s / 60.0,
            d.h_start,
            d.h_end,
            d.pulses,
            d.end_s.map_or("the rest of the run".to_owned(), |e| format!("{:.0} s", e - d.start_s)),
            d.max_error_rad.to_degrees(),
            d.max_accel / att::G0 * 1e6,
        ));
    }
    match mean_interval_orbits(&a.dumps, run.period_s) {
        Some(i) => out.push(format!(
            "Desaturations every {i:.2} orbits on average (the seed expected about every tenth orbit): the interval comes out of the model's inertia, drag and attitude, not from a setting."
        )),
        None => out.push(
            "No desaturation in the run: the momentum never reached the saturation margin (the seed expected one about every tenth orbit).".into(),
        ),
    }
    out
}

/// CMG momentum and attitude error against time.
pub fn plots(run: &Run) -> Vec<robosim_report::Plot> {
    use robosim_report::{Plot, Series};
    let series = |label: &str, f: &dyn Fn(&AttStep) -> f64| Series {
        label: label.into(),
        points: run
            .steps
            .iter()
            .filter_map(|st| st.attitude.map(|a| (st.t / run.period_s, f(&a))))
            .collect(),
    };
    vec![
        Plot {
            title: "CMG momentum".into(),
            x_label: "orbits".into(),
            y_label: "fraction of capacity / desaturating (1)".into(),
            series: vec![
                series("|h| / capacity", &|a| a.h_fraction),
                series("desaturating", &|a| a.dumping as u8 as f64),
            ],
            ..Plot::default()
        },
        Plot {
            title: "Attitude error".into(),
            x_label: "orbits".into(),
            y_label: "error (deg)".into(),
            series: vec![series("attitude error", &|a| a.error_deg)],
            ..Plot::default()
        },
    ]
}

/// "What accuracy costs in time" for the attitude: the run's configurations (one per study
/// step) integrated again at each substep in `steps` against the finest one over the same
/// configurations; written as `station_attitude_accuracy.{md,csv,png}`.
pub fn accuracy(
    a: &AttitudeSetup,
    run: &Run,
    dir: &Path,
    steps: &[f64],
    orbit: Orbit,
    theta0: f64,
) -> Result<robosim_report::Report> {
    use robosim_report::{Plot, Report, Series, Table};
    let Some(ar) = &run.attitude else {
        bail!("the run has no attitude");
    };
    let times: Vec<f64> = run.steps.iter().map(|st| st.t).collect();
    let integrate = |dt: f64| -> Result<(Attitude, Vec<(f64, att::State)>, f64)> {
        let t0 = std::time::Instant::now();
        let mut m =
            Attitude::new(a.effect, orbit, theta0, &ar.configs[0]).map_err(StudyError::from)?;
        let mut trace = Vec::with_capacity(times.len());
        for (k, &t) in times.iter().enumerate() {
            if k > 0 {
                m.advance(&ar.configs[k - 1], t, dt);
            }
            trace.push((t, m.state));
        }
        Ok((m, trace, t0.elapsed().as_secs_f64()))
    };
    let fine = steps.iter().copied().fold(f64::INFINITY, f64::min) / 4.0;
    let (rm, reference, _) = integrate(fine)?;
    let mut rows = Vec::new();
    let (mut err_pts, mut time_pts, mut calm_pts) = (Vec::new(), Vec::new(), Vec::new());
    for &h in steps {
        let (m, trace, wall) = integrate(h)?;
        let att_err = trace
            .iter()
            .zip(&reference)
            .map(|((_, x), (_, r))| x.q.angle_to(&r.q))
            .fold(0.0, f64::max);
        let h_err = trace
            .iter()
            .zip(&reference)
            .map(|((_, x), (_, r))| (x.h - r.h).norm())
            .fold(0.0, f64::max);
        // before the first desaturation of either: the integration alone (a desaturation
        // starts at the end of the substep that crosses the threshold, which shifts its pulses)
        let calm = m
            .dumps
            .first()
            .map(|d| d.start_s)
            .into_iter()
            .chain(rm.dumps.first().map(|d| d.start_s))
            .fold(f64::INFINITY, f64::min);
        let calm_err = trace
            .iter()
            .zip(&reference)
            .filter(|((t, _), _)| *t < calm)
            .map(|((_, x), (_, r))| x.q.angle_to(&r.q))
            .fold(0.0, f64::max);
        calm_pts.push((h, calm_err.to_degrees().max(1e-12)));
        let first = |m: &Attitude| m.dumps.first().map(|d| d.start_s);
        let shift = match (first(&m), first(&rm)) {
            (Some(x), Some(y)) => format!("{:.1}", (x - y).abs()),
            (None, None) => "none".into(),
            _ => "one run only".into(),
        };
        err_pts.push((h, att_err.to_degrees()));
        time_pts.push((h, wall * 1e3));
        rows.push(vec![
            format!("{h}"),
            format!("{}", m.substeps),
            format!("{:.3e}", calm_err.to_degrees()),
            format!("{:.3e}", att_err.to_degrees()),
            format!("{h_err:.3e}"),
            format!("{} / {}", m.dumps.len(), rm.dumps.len()),
            shift,
            format!("{:.1}", wall * 1e3),
        ]);
    }
    let report = Report {
        name: "station_attitude_accuracy".into(),
        title: "Space Station study: attitude integration, what accuracy costs in time".into(),
        notes: vec![format!(
            "The run's {} configurations (mass properties and drag geometry, one per study step) integrated again with RK4 at each substep (the thruster pulses are integration boundaries at every substep) against the same at {fine} s. Errors are the largest over the study's steps: the attitude's angle from the reference's, and the CMG momentum's distance from it. Before the first desaturation the error is the integrator's; over the whole run it is dominated by when each desaturation starts (the threshold is checked at the end of each substep, so the pulses shift by up to a substep and the attitude's response to them with it).",
            ar.configs.len()
        )],
        table: Table {
            columns: vec![
                "substep (s)".into(),
                "substeps".into(),
                "attitude error before the first desaturation (deg)".into(),
                "attitude error vs reference, whole run (deg)".into(),
                "CMG momentum error vs reference (N·m·s)".into(),
                "desaturations (this / reference)".into(),
                "first desaturation shifted by (s)".into(),
                "wall time (ms)".into(),
            ],
            rows,
        },
        plots: vec![
            Plot {
                title: "Attitude error against substep".into(),
                x_label: "substep (s)".into(),
                y_label: "largest error (deg)".into(),
                log_x: true,
                log_y: true,
                series: vec![Series {
                    label: "RK4".into(),
                    points: err_pts,
                }],
            },
            Plot {
                title: "Wall time against substep".into(),
                x_label: "substep (s)".into(),
                y_label: "wall time (ms)".into(),
                log_x: true,
                log_y: true,
                series: vec![Series {
                    label: "RK4".into(),
                    points: time_pts,
                }],
            },
        ],
    };
    robosim_report::write_report(dir, &report)?;
    Ok(report)
}
