//! The studies a sweep can run: for each, the parameters a point may set (name, unit, kind),
//! the scalar results that summarise one run (the CSV's result columns), and the run itself
//! — the same code as `robosim study …` / `robosim demo`, headless (no frames, no files).
//!
//! * `surgical` — seed §2.7: the reach and encoder-accuracy sweep of the surgical positioner
//!   ([`crate::surgical::reach`]): 861 tool poses over the head, IK, collision, the bits' bound.
//! * `welding` — the downhand welding cell ([`crate::welding::simulate`]).
//! * `station` — the Space Station's orbit, power and ORU swap ([`crate::station::simulate`]).

pub use super::params::{Kind, ParamDef, StudyDef};

use super::params::Value;
use crate::{Result, StudyError, station, surgical, welding};
use robosim_collision::Mode;

/// Every study a sweep can run.
pub static STUDIES: &[StudyDef] = &[SURGICAL, WELDING, STATION];

/// The study named `name`.
pub fn find(name: &str) -> Option<&'static StudyDef> {
    STUDIES.iter().find(|s| s.name == name)
}

fn num(params: &[(String, Value)], name: &str) -> Result<Option<f64>> {
    match params.iter().find(|(n, _)| n == name) {
        None => Ok(None),
        Some((_, Value::Num(v))) if v.is_finite() => Ok(Some(*v)),
        Some((_, v)) => Err(StudyError::Message(format!(
            "{name} = {v}: expected a finite number"
        ))),
    }
}

fn word<'a>(params: &'a [(String, Value)], name: &str) -> Result<Option<&'a str>> {
    match params.iter().find(|(n, _)| n == name) {
        None => Ok(None),
        Some((_, Value::Word(w))) => Ok(Some(w)),
        Some((_, v)) => Err(StudyError::Message(format!(
            "{name} = {v}: expected a word"
        ))),
    }
}

fn mode(params: &[(String, Value)]) -> Result<Option<Mode>> {
    Ok(match word(params, "mode")? {
        None => None,
        Some("bbox") => Some(Mode::BBox),
        Some("polygon") => Some(Mode::Polygon),
        Some("exact") => Some(Mode::Exact),
        Some(other) => {
            return Err(StudyError::Message(format!(
                "mode {other:?}: bbox, polygon or exact"
            )));
        }
    })
}

/// Refuses names the study does not have (the worker's guard: a coordinator checks them
/// before, but a worker is a process of its own and takes jobs from anywhere).
fn known(def: &StudyDef, params: &[(String, Value)]) -> Result<()> {
    for (n, _) in params {
        if !def.params.iter().any(|p| p.name == n) {
            return Err(StudyError::Message(format!(
                "study {} has no parameter {n:?}; it has {}",
                def.name,
                def.param_list()
            )));
        }
    }
    Ok(())
}

const MODES: &[&str] = &["bbox", "polygon", "exact"];

// ---- surgical ----

const SURGICAL: StudyDef = StudyDef {
    name: "surgical",
    what: "seed §2.7: the surgical positioner's reach and encoder accuracy over 861 tool poses at the head",
    params: &[
        ParamDef {
            name: "bits",
            unit: "bits",
            kind: Kind::Whole,
            what: "encoder bits per joint, 1 to 52 (scene: 12)",
        },
        ParamDef {
            name: "upper_arm",
            unit: "m",
            kind: Kind::Number,
            what: "upper arm length (scene: 0.22)",
        },
        ParamDef {
            name: "forearm",
            unit: "m",
            kind: Kind::Number,
            what: "forearm length (scene: 0.20)",
        },
        ParamDef {
            name: "stand_off",
            unit: "m",
            kind: Kind::Number,
            what: "robot base from the head's axis (scene: 0.25)",
        },
    ],
    results: &[
        "points",
        "reached",
        "out_of_reach",
        "blocked",
        "reached_pct",
        "worst_position_bound_mm",
        "mean_position_bound_mm",
        "worst_orientation_bound_mrad",
        "worst_at_along_cm",
        "worst_at_angle_deg",
    ],
    check: |p| surgical_params(p).map(drop),
    run: |p| {
        let r = surgical::reach(&surgical_params(p)?)?;
        Ok(vec![
            r.points as f64,
            r.reached as f64,
            r.unreachable as f64,
            (r.points - r.reached - r.unreachable) as f64,
            100.0 * r.reached as f64 / r.points.max(1) as f64,
            r.worst_position.0 * 1e3,
            r.mean_position * 1e3,
            r.worst_orientation * 1e3,
            r.worst_position.1 * 100.0,
            r.worst_position.2,
        ])
    },
};

fn surgical_params(p: &[(String, Value)]) -> Result<surgical::ReachParams> {
    known(&SURGICAL, p)?;
    let bits = match num(p, "bits")? {
        None => None,
        Some(b) if b.fract() == 0.0 && (1.0..=52.0).contains(&b) => Some(b as u32),
        Some(b) => {
            return Err(StudyError::Message(format!(
                "bits {b}: expected a whole number 1 to 52"
            )));
        }
    };
    let len = |name: &str| -> Result<Option<f64>> {
        match num(p, name)? {
            Some(v) if !(v > 0.0 && v < 10.0) => Err(StudyError::Message(format!(
                "{name} {v} m: expected a length in (0, 10) m"
            ))),
            v => Ok(v),
        }
    };
    Ok(surgical::ReachParams {
        bits,
        upper_arm_m: len("upper_arm")?,
        forearm_m: len("forearm")?,
        stand_off_m: len("stand_off")?,
    })
}

// ---- welding ----

const WELDING: StudyDef = StudyDef {
    name: "welding",
    what: "the downhand welding cell: the positioner and the arm welding the circle and saddle seams",
    params: &[
        ParamDef {
            name: "speed",
            unit: "mm/s",
            kind: Kind::Number,
            what: "torch travel speed along the seam (default 8)",
        },
        ParamDef {
            name: "step",
            unit: "s",
            kind: Kind::Number,
            what: "time step (default 0.25)",
        },
        ParamDef {
            name: "branch_height",
            unit: "m",
            kind: Kind::Number,
            what: "the branch's axis above the flange (scene: 0.18)",
        },
        ParamDef {
            name: "arm_x",
            unit: "m",
            kind: Kind::Number,
            what: "the arm's base along world x (scene: -1.1)",
        },
        ParamDef {
            name: "travel_angle",
            unit: "deg",
            kind: Kind::Number,
            what: "torch travel (push) angle (default 10)",
        },
        ParamDef {
            name: "standoff",
            unit: "mm",
            kind: Kind::Number,
            what: "contact tip to work distance (default 15)",
        },
        ParamDef {
            name: "seam",
            unit: "",
            kind: Kind::Choice(&["circle", "saddle", "both"]),
            what: "the seams welded (default both)",
        },
        ParamDef {
            name: "mode",
            unit: "",
            kind: Kind::Choice(MODES),
            what: "collision mode of the clearance checks (default exact)",
        },
    ],
    results: &[
        "covered_pct",
        "worst_downhand_error_deg",
        "worst_work_angle_error_deg",
        "worst_travel_angle_error_deg",
        "worst_tip_error_mm",
        "min_clearance_mm",
        "worst_speed_over_limit",
        "mid_step_downhand_error_deg",
        "mid_step_tip_error_mm",
        "infeasible_sections",
        "cycle_time_s",
    ],
    check: |p| welding_params(p)?.check(),
    run: |p| {
        let wp = welding_params(p)?;
        let s = welding::setup(&wp)?;
        let run = welding::simulate(&s, &wp)?;
        let weld: Vec<&welding::Step> = run.steps.iter().filter(|st| st.s >= 0.0).collect();
        let ok: Vec<&&welding::Step> = weld.iter().filter(|st| st.problem.is_empty()).collect();
        let worst =
            |f: &dyn Fn(&welding::Step) -> f64| ok.iter().map(|st| f(st).abs()).fold(0.0, f64::max);
        Ok(vec![
            100.0 * ok.len() as f64 / weld.len().max(1) as f64,
            worst(&|st| st.downhand_err).to_degrees(),
            worst(&|st| st.work_err).to_degrees(),
            worst(&|st| st.travel_err).to_degrees(),
            worst(&|st| st.tip_err) * 1e3,
            run.steps
                .iter()
                .map(|st| st.clearance)
                .fold(f64::INFINITY, f64::min)
                * 1e3,
            worst(&|st| st.arm_speed_ratio.max(st.pos_speed_ratio)),
            run.mid_downhand.to_degrees(),
            run.mid_tip * 1e3,
            welding::sections(&s, &run).len() as f64,
            run.steps.last().map_or(0.0, |st| st.t),
        ])
    },
};

fn welding_params(p: &[(String, Value)]) -> Result<welding::WeldingParams> {
    known(&WELDING, p)?;
    let d = welding::WeldingParams::default();
    let wp = welding::WeldingParams {
        seams: match word(p, "seam")? {
            Some("circle") => vec![welding::SeamKind::Circle],
            Some("saddle") => vec![welding::SeamKind::Saddle],
            Some("both") | None => d.seams.clone(),
            Some(other) => {
                return Err(StudyError::Message(format!(
                    "seam {other:?}: circle, saddle or both"
                )));
            }
        },
        speed_m_s: num(p, "speed")?.map_or(d.speed_m_s, |v| v * 1e-3),
        step_s: num(p, "step")?.unwrap_or(d.step_s),
        branch_height_m: num(p, "branch_height")?,
        arm_x_m: num(p, "arm_x")?,
        travel_angle: num(p, "travel_angle")?.map_or(d.travel_angle, f64::to_radians),
        standoff_m: num(p, "standoff")?.map_or(d.standoff_m, |v| v * 1e-3),
        mode: mode(p)?.unwrap_or(d.mode),
        frames: 0,
        ..d
    };
    wp.check()?;
    Ok(wp)
}

// ---- station ----

const STATION: StudyDef = StudyDef {
    name: "station",
    what: "the Space Station: orbit, sun-tracking arrays, power and battery, the ORU swap",
    params: &[
        ParamDef {
            name: "altitude",
            unit: "km",
            kind: Kind::Number,
            what: "orbit altitude (scene: 400)",
        },
        ParamDef {
            name: "beta",
            unit: "deg",
            kind: Kind::Number,
            what: "beta angle (scene: 20)",
        },
        ParamDef {
            name: "step",
            unit: "s",
            kind: Kind::Number,
            what: "time step (default 10)",
        },
        ParamDef {
            name: "orbits",
            unit: "orbits",
            kind: Kind::Number,
            what: "length of the run (default 1)",
        },
        ParamDef {
            name: "keep_out",
            unit: "m",
            kind: Kind::Number,
            what: "servicer to array keep-out distance (default 1)",
        },
        ParamDef {
            name: "load",
            unit: "kW",
            kind: Kind::Number,
            what: "constant station load (default 100)",
        },
        ParamDef {
            name: "battery",
            unit: "kWh",
            kind: Kind::Number,
            what: "battery capacity (default 150)",
        },
        ParamDef {
            name: "task_start",
            unit: "s",
            kind: Kind::Number,
            what: "when the ORU swap starts (default 300)",
        },
        ParamDef {
            name: "mode",
            unit: "",
            kind: Kind::Choice(MODES),
            what: "collision mode of the clearance checks (default exact)",
        },
    ],
    results: &[
        "period_min",
        "eclipse_fraction",
        "orbit_average_power_kw",
        "energy_kwh",
        "lost_to_feathering_kwh",
        "min_state_of_charge",
        "unserved_kwh",
        "min_array_clearance_m",
        "min_between_step_clearance_m",
        "keep_out_breaks_between_steps",
        "min_structure_clearance_m",
        "feathered_steps",
        "blocked_steps",
    ],
    check: |p| station_params(p)?.check(),
    run: |p| {
        let sp = station_params(p)?;
        let s = station::setup(&sp)?;
        let run = station::simulate(&s, &sp)?;
        let t_end = run.steps.last().map_or(0.0, |st| st.t);
        let shadow: f64 = run.eclipses.iter().map(|[a, b]| b - a).sum();
        let min = |f: &dyn Fn(&station::Step) -> f64| {
            run.steps.iter().map(f).fold(f64::INFINITY, f64::min)
        };
        let count =
            |f: &dyn Fn(&station::Step) -> bool| run.steps.iter().filter(|st| f(st)).count() as f64;
        Ok(vec![
            run.period_s / 60.0,
            if t_end > 0.0 { shadow / t_end } else { 0.0 },
            run.energy_j / t_end.max(1e-9) / 1e3,
            run.energy_j / 3.6e6,
            run.lost_j / 3.6e6,
            min(&|st| st.soc).min(sp.soc0),
            run.unserved_j / 3.6e6,
            min(&|st| st.clearance_arrays),
            min(&|st| st.between_clearance),
            count(&|st| st.between_clearance < sp.keep_out_m),
            min(&|st| st.clearance_structure),
            count(&|st| st.arrays.iter().any(|a| a.2)),
            count(&|st| st.blocked),
        ])
    },
};

fn station_params(p: &[(String, Value)]) -> Result<station::StationParams> {
    known(&STATION, p)?;
    let d = station::StationParams::default();
    let sp = station::StationParams {
        altitude_m: num(p, "altitude")?.map(|km| km * 1e3),
        beta_rad: num(p, "beta")?.map(f64::to_radians),
        step_s: num(p, "step")?.unwrap_or(d.step_s),
        orbits: num(p, "orbits")?.unwrap_or(d.orbits),
        keep_out_m: num(p, "keep_out")?.unwrap_or(d.keep_out_m),
        load_w: num(p, "load")?.map_or(d.load_w, |kw| kw * 1e3),
        battery_j: num(p, "battery")?.map_or(d.battery_j, |kwh| kwh * 3.6e6),
        task_start_s: num(p, "task_start")?.unwrap_or(d.task_start_s),
        mode: mode(p)?.unwrap_or(d.mode),
        frames: 0,
        ..d
    };
    sp.check()?;
    Ok(sp)
}

/// `--param` parsing against a real study's parameters (welding's): moved here from spec.rs so
/// that spec.rs need not import this file.
#[cfg(test)]
mod spec_tests {
    use super::super::SweepError;
    use super::super::spec::{self, Axis, Value, parse_axis};
    use super::*;

    fn axis(s: &str) -> std::result::Result<Axis, SweepError> {
        parse_axis(find("welding").expect("welding"), s)
    }

    #[test]
    fn a_range_has_n_values_from_a_to_b_exactly() {
        let a = axis("speed=2:7:11").expect("range");
        assert_eq!(a.values.len(), 11);
        assert_eq!(a.values[0], Value::Num(2.0));
        assert_eq!(a.values[10], Value::Num(7.0));
        assert_eq!(a.values[5], Value::Num(4.5));
        let a = axis("arm_x=-1.2:-0.9:4").expect("negative range");
        assert_eq!(a.values[0], Value::Num(-1.2));
        assert_eq!(a.values[3], Value::Num(-0.9));
        assert_eq!(axis("speed=3:3:1").expect("one").values, [Value::Num(3.0)]);
    }

    #[test]
    fn lists_take_numbers_and_a_choice_its_words() {
        let a = axis("mode=bbox, exact").expect("choice");
        assert_eq!(
            a.values,
            [Value::Word("bbox".into()), Value::Word("exact".into())]
        );
        assert_eq!(
            axis("step=0.5,1e-1").expect("numbers").values,
            [Value::Num(0.5), Value::Num(0.1)]
        );
    }

    #[test]
    fn bad_arguments_are_refused_naming_them() {
        for (arg, want) in [
            ("speed", "expected NAME=A:B:N"),
            ("speed=", "no value for speed"),
            ("speeds=1,2", "has no parameter \"speeds\""),
            ("speed=1:2", "expected A:B:N"),
            ("speed=1:2:3:4", "expected A:B:N"),
            ("speed=1:2:0", "at least 1"),
            ("speed=1:2:1", "ambiguous"),
            ("speed=1:2:x", "not a whole number"),
            ("speed=1:inf:3", "not a finite number"),
            ("speed=NaN", "not a finite number"),
            ("speed=1,,2", "empty value"),
            ("speed=fast", "\"fast\" is not a number"),
            ("mode=exact,quick", "expected one of bbox, polygon, exact"),
            ("seam=1:2:2", "is a choice"),
        ] {
            let e = axis(arg).expect_err(arg).to_string();
            assert!(e.contains(arg), "{e:?} does not name {arg:?}");
            assert!(e.contains(want), "{arg}: {e:?} does not say {want:?}");
        }
    }

    #[test]
    fn jobs_are_the_product_first_axis_slowest() {
        let axes = [
            axis("speed=1,2").expect("speed"),
            axis("mode=bbox,polygon,exact").expect("mode"),
        ];
        let jobs = spec::jobs(&axes).expect("jobs");
        assert_eq!(jobs.len(), 6);
        for (i, j) in jobs.iter().enumerate() {
            assert_eq!(j.index, i);
            assert_eq!(j.params[0].1, axes[0].values[i / 3]);
            assert_eq!(j.params[1].1, axes[1].values[i % 3]);
        }
        assert_eq!(spec::jobs(&[]).expect("defaults").len(), 1);
        let twice = [axis("speed=1").expect("a"), axis("speed=2").expect("b")];
        assert!(spec::jobs(&twice).is_err());
        let huge = [
            axis("speed=1:2:1000").expect("a"),
            axis("step=0.1:1:1000").expect("b"),
            axis("arm_x=-1:1:2").expect("c"),
        ];
        assert!(matches!(spec::jobs(&huge), Err(SweepError::TooMany { .. })));
    }
}
