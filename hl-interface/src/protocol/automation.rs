//! Query-protocol ops of the automation layer (DESIGN.md, "The query protocol").
//!
//! | op | request | answer |
//! |---|---|---|
//! | `diag_check` | `model` | `processes, failure_modes, alarms, edges, findings: [{severity, code, message, line, col}], consistent` |
//! | `diag_simulate` | `model, faults: [{fault, t?}], seed?, sample?` | `alarms: [{t, alarm}]` |
//! | `diag_diagnose` | `model, alarms: [{t, alarm}], drop?: [alarm], until?` | `candidates: [path], multiple: [[path]], components, ilm: {depth, processes, failure_modes, restarts}` |
//!
//! `model` is a shipped model name (`eclss`) or a model file path.

use crate::{ErrorKind, ProtocolError};
use robosim_automation::diag::{FaultGraph, Ilm};
use robosim_automation::model::check::{Severity, check_model};
use robosim_automation::model::{Model, load_model};
use robosim_automation::sim::{SimOptions, simulate};
use robosim_instance_space::error_chain;
use robosim_kinematics::Robot;
use serde_json::{Value, json};

fn model_of(req: &Value) -> Result<Model, ProtocolError> {
    let name = req.get("model").and_then(Value::as_str).ok_or_else(|| {
        ProtocolError::new(ErrorKind::BadRequest, "`model` (a string) is required")
    })?;
    load_model(name).map_err(|e| ProtocolError::new(ErrorKind::BadModel, error_chain(&e)))
}

fn f64_field(v: &Value, key: &str, default: Option<f64>) -> Result<f64, ProtocolError> {
    match v.get(key) {
        None => default.ok_or_else(|| {
            ProtocolError::new(
                ErrorKind::BadRequest,
                format!("`{key}` (a number) is required"),
            )
        }),
        Some(x) => x.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
            ProtocolError::new(
                ErrorKind::BadRequest,
                format!("`{key}` must be a finite number"),
            )
        }),
    }
}

/// Answers the ops above; `None` for any other op. `robots` (the common robot resolver) is
/// unused here: these ops take fault models, not robots.
pub fn dispatch(
    op: &str,
    req: &Value,
    robots: &dyn Fn(&str) -> Option<Robot>,
) -> Option<Result<Value, ProtocolError>> {
    let _ = robots;
    let r = match op {
        "diag_check" => check(req),
        "diag_simulate" => simulate_op(req),
        "diag_diagnose" => diagnose(req),
        _ => return None,
    };
    Some(r)
}

fn check(req: &Value) -> Result<Value, ProtocolError> {
    let m = model_of(req)?;
    let f = check_model(&m);
    let findings: Vec<Value> = f
        .iter()
        .map(|x| {
            json!({"severity": if x.severity == Severity::Error {"error"} else {"warning"},
                   "code": x.code, "message": x.message, "line": x.span.line, "col": x.span.col})
        })
        .collect();
    Ok(json!({
        "processes": m.processes.len(), "failure_modes": m.failure_modes.len(), "alarms": m.alarms.len(),
        "edges": m.edges.len(), "findings": findings,
        "consistent": f.iter().all(|x| x.severity != Severity::Error),
    }))
}

fn simulate_op(req: &Value) -> Result<Value, ProtocolError> {
    let m = model_of(req)?;
    let g = FaultGraph::new(&m);
    let faults = req.get("faults").and_then(Value::as_array).ok_or_else(|| {
        ProtocolError::new(ErrorKind::BadRequest, "`faults` (an array) is required")
    })?;
    let mut inj = Vec::new();
    for (i, f) in faults.iter().enumerate() {
        let name = f.get("fault").and_then(Value::as_str).ok_or_else(|| {
            ProtocolError::new(
                ErrorKind::BadRequest,
                format!("faults[{i}].fault (a string) is required"),
            )
        })?;
        let fm = m.find_failure_mode(name).map_err(|e| {
            ProtocolError::new(ErrorKind::UnknownFault, format!("faults[{i}]: {e}"))
        })?;
        inj.push((fm, f64_field(f, "t", Some(0.0))?));
    }
    let seed = req.get("seed").and_then(Value::as_u64).unwrap_or(1);
    let sample = req.get("sample").and_then(Value::as_bool).unwrap_or(false);
    let sim = simulate(
        &g,
        &inj,
        &SimOptions {
            seed,
            sample_probabilities: sample,
            ..SimOptions::default()
        },
    );
    let alarms: Vec<Value> = sim
        .alarms
        .iter()
        .map(|e| json!({"t": e.time, "alarm": m.alarms[e.alarm].name}))
        .collect();
    Ok(json!({ "alarms": alarms }))
}

fn diagnose(req: &Value) -> Result<Value, ProtocolError> {
    let m = model_of(req)?;
    let g = FaultGraph::new(&m);
    let mut present = vec![true; m.alarms.len()];
    if let Some(d) = req.get("drop").and_then(Value::as_array) {
        for (i, a) in d.iter().enumerate() {
            let name = a.as_str().ok_or_else(|| {
                ProtocolError::new(
                    ErrorKind::BadRequest,
                    format!("drop[{i}] must be an alarm name"),
                )
            })?;
            present[m.find_alarm(name).map_err(|e| {
                ProtocolError::new(ErrorKind::UnknownAlarm, format!("drop[{i}]: {e}"))
            })?] = false;
        }
    }
    let alarms = req.get("alarms").and_then(Value::as_array).ok_or_else(|| {
        ProtocolError::new(ErrorKind::BadRequest, "`alarms` (an array) is required")
    })?;
    let mut ilm = Ilm::new(&m, &g, Some(&present));
    let mut events = Vec::new();
    for (i, a) in alarms.iter().enumerate() {
        let name = a.get("alarm").and_then(Value::as_str).ok_or_else(|| {
            ProtocolError::new(
                ErrorKind::BadRequest,
                format!("alarms[{i}].alarm (a string) is required"),
            )
        })?;
        let id = m.find_alarm(name).map_err(|e| {
            ProtocolError::new(ErrorKind::UnknownAlarm, format!("alarms[{i}]: {e}"))
        })?;
        events.push((id, f64_field(a, "t", None)?));
    }
    // Alarms with the same time stamp rang together: one update.
    for batch in events.chunk_by(|x, y| x.1 == y.1) {
        ilm.on_alarms(batch)
            .map_err(|e| ProtocolError::new(ErrorKind::BadAlarm, error_chain(&e)))?;
    }
    if req.get("until").is_some() {
        ilm.advance_to(f64_field(req, "until", None)?);
    }
    ilm.run_to_completion();
    let v = ilm.diagnoser().clone().global_verdict();
    let fm = |f: &usize| m.failure_modes[*f].path.clone();
    let guess = ilm.best_guess();
    Ok(json!({
        "candidates": v.single.iter().map(|c| fm(&c.fm)).collect::<Vec<_>>(),
        "multiple": v.multiple.iter().map(|h| h.iter().map(fm).collect::<Vec<_>>()).collect::<Vec<_>>(),
        "components": guess.as_ref().map(|g| g.components.iter().map(|&c| m.components[c].name.clone()).collect::<Vec<_>>()).unwrap_or_default(),
        "ilm": guess.as_ref().map(|g| json!({"depth": g.depth,
            "processes": g.processes.iter().map(|&p| m.processes[p].path.clone()).collect::<Vec<_>>(),
            "failure_modes": g.failure_modes.iter().map(fm).collect::<Vec<_>>(), "restarts": ilm.restarts})),
    }))
}
