//! The registry of built-in actor kinds a graph file may name, and the one script that runs
//! them. Every value is a number (a boolean is 1 or 0). An input that has never had a value
//! makes the firing emit nothing (an `ifany` actor fires before all its inputs have arrived);
//! an input without a fresh token this firing is read at its node's last value.

use crate::kernel::{ActorSpec, Ctx, Script, Value};
use std::collections::BTreeMap;

/// A kind of actor: its ports and parameters.
#[derive(Debug, Clone, Copy)]
pub struct KindInfo {
    pub name: &'static str,
    pub inputs: &'static [&'static str],
    pub outputs: &'static [&'static str],
    /// `(name, default)`; `None`: required. `dt` (s) is filled from the graph's `rate`.
    pub params: &'static [(&'static str, Option<f64>)],
    /// One line for `robosim dataflow --kinds` and docs/dataflow.md.
    pub doc: &'static str,
}

const BINARY: &[&str] = &["a", "b"];
const X: &[&str] = &["x"];
const Y: &[&str] = &["y"];

/// Every built-in kind, in the order docs/dataflow.md lists them.
pub fn kinds() -> &'static [KindInfo] {
    KINDS
}

const KINDS: &[KindInfo] = &[
    KindInfo {
        name: "add",
        inputs: BINARY,
        outputs: Y,
        params: &[],
        doc: "y = a + b",
    },
    KindInfo {
        name: "sub",
        inputs: BINARY,
        outputs: Y,
        params: &[],
        doc: "y = a - b",
    },
    KindInfo {
        name: "mul",
        inputs: BINARY,
        outputs: Y,
        params: &[],
        doc: "y = a * b",
    },
    KindInfo {
        name: "div",
        inputs: BINARY,
        outputs: Y,
        params: &[],
        doc: "y = a / b (b = 0 is the firing's error, nothing emitted)",
    },
    KindInfo {
        name: "min",
        inputs: BINARY,
        outputs: Y,
        params: &[],
        doc: "y = min(a, b)",
    },
    KindInfo {
        name: "max",
        inputs: BINARY,
        outputs: Y,
        params: &[],
        doc: "y = max(a, b)",
    },
    KindInfo {
        name: "gain",
        inputs: X,
        outputs: Y,
        params: &[("k", None)],
        doc: "y = k x",
    },
    KindInfo {
        name: "affine",
        inputs: X,
        outputs: Y,
        params: &[("k", Some(1.0)), ("b", Some(0.0))],
        doc: "y = k x + b",
    },
    KindInfo {
        name: "abs",
        inputs: X,
        outputs: Y,
        params: &[],
        doc: "y = |x|",
    },
    KindInfo {
        name: "clamp",
        inputs: X,
        outputs: Y,
        params: &[("lo", None), ("hi", None)],
        doc: "y = x limited to [lo, hi]",
    },
    KindInfo {
        name: "lowpass",
        inputs: X,
        outputs: Y,
        params: &[("tau", None), ("dt", None)],
        doc: "first-order low-pass, time constant tau (s): y += dt/(tau+dt) (x - y) (backward Euler); the first sample sets y = x",
    },
    KindInfo {
        name: "integrator",
        inputs: X,
        outputs: Y,
        params: &[("k", Some(1.0)), ("y0", Some(0.0)), ("dt", None)],
        doc: "y += k x dt, from y0",
    },
    KindInfo {
        name: "derivative",
        inputs: X,
        outputs: Y,
        params: &[("dt", None)],
        doc: "y = (x - x_prev) / dt; 0 on the first sample",
    },
    KindInfo {
        name: "ratelimit",
        inputs: X,
        outputs: Y,
        params: &[("rate", None), ("dt", None)],
        doc: "y follows x by at most rate*dt per firing; the first sample sets y = x",
    },
    KindInfo {
        name: "pd",
        inputs: &["e"],
        outputs: &["u"],
        params: &[("kp", None), ("kd", Some(0.0)), ("dt", None)],
        doc: "u = kp e + kd de/dt (de/dt = 0 on the first sample)",
    },
    KindInfo {
        name: "pid",
        inputs: &["e"],
        outputs: &["u"],
        params: &[
            ("kp", None),
            ("ki", Some(0.0)),
            ("kd", Some(0.0)),
            ("lo", Some(f64::NEG_INFINITY)),
            ("hi", Some(f64::INFINITY)),
            ("dt", None),
        ],
        doc: "u = kp e + ki ∫e dt + kd de/dt, limited to [lo, hi]; the integral stops while the output is limited (anti-windup)",
    },
    KindInfo {
        name: "threshold",
        inputs: X,
        outputs: Y,
        params: &[
            ("above", Some(f64::NAN)),
            ("below", Some(f64::NAN)),
            ("hysteresis", Some(0.0)),
        ],
        doc: "alarm: y = 1 once x > above (or x < below), back to 0 only once x is hysteresis inside the bound again",
    },
];

/// The kind named `name`.
pub(crate) fn kind(name: &str) -> Option<&'static KindInfo> {
    KINDS.iter().find(|k| k.name == name)
}

/// What a dynamic actor remembers between firings (its MEE "local parameter structure").
#[derive(Debug, Default, Clone)]
struct Memory {
    /// Output (lowpass, integrator, ratelimit) or integral (pid).
    y: Option<f64>,
    /// Previous input (derivative, pd, pid).
    prev: Option<f64>,
    /// Whether the threshold alarm is on.
    on: bool,
}

/// The script of every built-in kind (one per actor: it carries the actor's parameters).
struct Builtin {
    kind: &'static KindInfo,
    params: BTreeMap<String, f64>,
}

impl Builtin {
    fn p(&self, name: &str) -> f64 {
        // The parser fills every parameter of the kind (module `parse`): a missing one is NaN,
        // which every kind treats as "not set".
        self.params.get(name).copied().unwrap_or(f64::NAN)
    }
}

fn number(v: &Value) -> Option<f64> {
    match v {
        Value::F64(x) => Some(*x),
        Value::Bool(b) => Some(f64::from(u8::from(*b))),
        _ => None,
    }
}

/// The value on `port`: this firing's token, else the node's last value.
fn read(ctx: &Ctx<'_>, port: &str) -> Option<f64> {
    ctx.input(port)
        .or_else(|| ctx.latest(port))
        .and_then(number)
}

impl Script for Builtin {
    fn fire(&self, ctx: &mut Ctx<'_>) -> Result<(), String> {
        let mut xs = Vec::with_capacity(self.kind.inputs.len());
        for port in self.kind.inputs {
            match read(ctx, port) {
                Some(x) => xs.push(x),
                None => return Ok(()), // not every input has had a value yet
            }
        }
        let out = self.kind.outputs[0];
        let y = match self.compute(&xs, ctx)? {
            Some(y) => y,
            None => return Ok(()),
        };
        ctx.emit(out, Value::F64(y))
    }
}

impl Builtin {
    /// The output for inputs `xs` (the kind's port order); `None`: emit nothing.
    fn compute(&self, xs: &[f64], ctx: &mut Ctx<'_>) -> Result<Option<f64>, String> {
        let x = xs.first().copied().unwrap_or(f64::NAN);
        let b = xs.get(1).copied().unwrap_or(f64::NAN);
        let dt = self.p("dt");
        let y = match self.kind.name {
            "add" => x + b,
            "sub" => x - b,
            "mul" => x * b,
            "div" => {
                if b == 0.0 {
                    return Err(format!("div: division of {x} by zero"));
                }
                x / b
            }
            "min" => x.min(b),
            "max" => x.max(b),
            "gain" => self.p("k") * x,
            "affine" => self.p("k") * x + self.p("b"),
            "abs" => x.abs(),
            "clamp" => x.clamp(self.p("lo"), self.p("hi")),
            "lowpass" => {
                let m = memory(ctx)?;
                let a = dt / (self.p("tau") + dt);
                let y = m.y.map_or(x, |y| y + a * (x - y));
                m.y = Some(y);
                y
            }
            "integrator" => {
                let m = memory(ctx)?;
                let y = m.y.unwrap_or(self.p("y0")) + self.p("k") * x * dt;
                m.y = Some(y);
                y
            }
            "derivative" => {
                let m = memory(ctx)?;
                let d = m.prev.map_or(0.0, |p| (x - p) / dt);
                m.prev = Some(x);
                d
            }
            "ratelimit" => {
                let m = memory(ctx)?;
                let step = self.p("rate") * dt;
                let y = m.y.map_or(x, |y| y + (x - y).clamp(-step, step));
                m.y = Some(y);
                y
            }
            "pd" => {
                let m = memory(ctx)?;
                let d = m.prev.map_or(0.0, |p| (x - p) / dt);
                m.prev = Some(x);
                self.p("kp") * x + self.p("kd") * d
            }
            "pid" => {
                let m = memory(ctx)?;
                let d = m.prev.map_or(0.0, |p| (x - p) / dt);
                m.prev = Some(x);
                let integral = m.y.unwrap_or(0.0);
                let (lo, hi) = (self.p("lo"), self.p("hi"));
                let trial = integral + x * dt;
                let raw = self.p("kp") * x + self.p("ki") * trial + self.p("kd") * d;
                // Anti-windup: the integral moves only while the output is not limited.
                if raw >= lo && raw <= hi {
                    m.y = Some(trial);
                    raw
                } else {
                    let u = self.p("kp") * x + self.p("ki") * integral + self.p("kd") * d;
                    u.clamp(lo, hi)
                }
            }
            "threshold" => {
                let m = memory(ctx)?;
                let (above, below, h) = (self.p("above"), self.p("below"), self.p("hysteresis"));
                let out = |x: f64, margin: f64| {
                    (!above.is_nan() && x > above - margin)
                        || (!below.is_nan() && x < below + margin)
                };
                // On: beyond the bound. Off again: back inside by the hysteresis.
                m.on = if m.on { out(x, h) } else { out(x, 0.0) };
                f64::from(u8::from(m.on))
            }
            other => return Err(format!("no built-in actor kind `{other}`")),
        };
        if y.is_finite() {
            Ok(Some(y))
        } else {
            Err(format!(
                "{} gave a non-finite value {y} from inputs {xs:?}",
                self.kind.name
            ))
        }
    }
}

fn memory<'c>(ctx: &'c mut Ctx<'_>) -> Result<&'c mut Memory, String> {
    ctx.context::<Memory>()
        .ok_or_else(|| "the actor's memory is missing (a kernel bug)".to_owned())
}

/// The kernel actor for a declaration (ports named as the kind names them).
pub(crate) fn spec(decl: &super::ActorDecl) -> Result<ActorSpec, String> {
    let kind = kind(&decl.kind).ok_or_else(|| format!("no built-in actor kind `{}`", decl.kind))?;
    Ok(ActorSpec::new(
        &decl.name,
        Builtin {
            kind,
            params: decl.params.clone(),
        },
    )
    .inputs(kind.inputs)
    .outputs(kind.outputs)
    .firing(decl.firing)
    .drive(decl.drive)
    .context(Memory::default()))
}
