//! The worker protocol: JSON lines, one job per line to a worker, one result line back per job.
//!
//! ```text
//! → {"index":3,"study":"welding","params":[["speed",8.0],["mode","exact"]]}
//! ← {"index":3,"values":[100.0,0.41,…]}           the study's result columns, in order
//! ← {"index":3,"error":"branch height …: …"}      the study refused or failed at this point
//! ```
//! Numbers are JSON numbers, read back bit for bit (serde_json's `float_roundtrip`); a result
//! that is not finite (a clearance with nothing near: +∞) is the string `"inf"`, `"-inf"` or
//! `"NaN"`. The line is the whole message, so any transport that carries lines (a pipe, a
//! Zenoh sample) carries the protocol.

use super::spec::{Job, Value};
use serde_json::{Value as Json, json};

/// A job's outcome: the result columns, or why the study could not give them.
pub type Outcome = Result<Vec<f64>, String>;

/// A job as the line a worker reads.
pub fn job_line(study: &str, job: &Job) -> String {
    let params: Vec<Json> = job
        .params
        .iter()
        .map(|(n, v)| match v {
            Value::Num(x) => json!([n, x]),
            Value::Word(w) => json!([n, w]),
        })
        .collect();
    json!({"index": job.index, "study": study, "params": params}).to_string()
}

/// A job line read back: (study, job).
pub fn parse_job(line: &str) -> Result<(String, Job), String> {
    let v: Json = serde_json::from_str(line).map_err(|e| format!("job line: {e}"))?;
    let index = v["index"]
        .as_u64()
        .ok_or("job line: no \"index\" (a whole number)")? as usize;
    let study = v["study"]
        .as_str()
        .ok_or("job line: no \"study\" (a name)")?
        .to_owned();
    let mut params = Vec::new();
    for p in v["params"]
        .as_array()
        .ok_or("job line: no \"params\" (a list of [name, value])")?
    {
        let (Some(name), Some(value)) = (p[0].as_str(), p.get(1)) else {
            return Err(format!("job line: parameter {p}: expected [name, value]"));
        };
        let value = match value {
            Json::Number(n) => Value::Num(
                n.as_f64()
                    .ok_or_else(|| format!("job line: {name} = {n}: not a number"))?,
            ),
            Json::String(w) => Value::Word(w.clone()),
            other => return Err(format!("job line: {name} = {other}: a number or a word")),
        };
        params.push((name.to_owned(), value));
    }
    Ok((study, Job { index, params }))
}

fn number(x: f64) -> Json {
    if x.is_finite() {
        json!(x)
    } else if x.is_nan() {
        json!("NaN")
    } else if x > 0.0 {
        json!("inf")
    } else {
        json!("-inf")
    }
}

/// A job's outcome as the line a worker writes.
pub fn result_line(index: usize, outcome: &Outcome) -> String {
    match outcome {
        Ok(values) => {
            let vs: Vec<Json> = values.iter().map(|x| number(*x)).collect();
            json!({"index": index, "values": vs}).to_string()
        }
        Err(e) => json!({"index": index, "error": e}).to_string(),
    }
}

/// A result line read back: (job index, outcome).
pub fn parse_result(line: &str) -> Result<(usize, Outcome), String> {
    let v: Json = serde_json::from_str(line).map_err(|e| format!("result line: {e}"))?;
    let index = v["index"]
        .as_u64()
        .ok_or("result line: no \"index\" (a whole number)")? as usize;
    if let Some(e) = v["error"].as_str() {
        return Ok((index, Err(e.to_owned())));
    }
    let mut values = Vec::new();
    for x in v["values"]
        .as_array()
        .ok_or("result line: neither \"values\" nor \"error\"")?
    {
        values.push(match x {
            Json::Number(n) => n.as_f64().ok_or("result line: a value out of range")?,
            Json::String(s) if s == "inf" => f64::INFINITY,
            Json::String(s) if s == "-inf" => f64::NEG_INFINITY,
            Json::String(s) if s == "NaN" => f64::NAN,
            other => return Err(format!("result line: value {other}: not a number")),
        });
    }
    Ok((index, Ok(values)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_read_back_bit_for_bit() {
        let job = Job {
            index: 7,
            params: vec![
                ("speed".into(), Value::Num(0.1 + 0.2)),
                ("mode".into(), Value::Word("exact".into())),
            ],
        };
        let (study, back) = parse_job(&job_line("welding", &job)).expect("job");
        assert_eq!(study, "welding");
        assert_eq!(back, job);
        let out: Outcome = Ok(vec![1.0 / 3.0, f64::INFINITY, f64::NEG_INFINITY, -0.0]);
        let (i, back) = parse_result(&result_line(7, &out)).expect("result");
        assert_eq!(i, 7);
        let back = back.expect("values");
        let want = out.expect("values");
        assert_eq!(
            back.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            want.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        let err: Outcome = Err("no \"seam\", here".into());
        assert_eq!(parse_result(&result_line(2, &err)), Ok((2, err)));
        assert!(parse_result("{\"index\":1}").is_err());
        assert!(parse_job("{\"index\":-1}").is_err());
    }
}
