//! Graphviz DOT export of a control graph with its live state (the MEE's graphic monitor,
//! seed §3.4): actors are boxes (yellow when ready, orange while firing) labelled with their
//! firing and drive modes, firing count and pending requests; data nodes are ellipses with
//! their retention, queued-token count and last value; input edges show the tokens that port
//! has not read yet.

use super::{Drive, Firing, Retention, State};
use std::fmt::Write;

fn esc(s: &str) -> String {
    s.replace('\\', "\\\\").replace('"', "\\\"")
}

pub(super) fn render(st: &State) -> String {
    let mut s = String::from("digraph control_graph {\n  rankdir=LR;\n");
    for (i, d) in st.data.iter().enumerate() {
        let Some(d) = d else { continue };
        let kind = match d.retention {
            Retention::Stream => format!("stream, {} held", d.buf.len()),
            Retention::LastValue => "last value".to_string(),
        };
        let last = d.last.as_ref().map_or("-".to_string(), |v| v.to_string());
        let _ = writeln!(
            s,
            "  d{i} [shape=ellipse, label=\"{}\\n{kind}\\nlast = {}\"];",
            esc(&d.name),
            esc(&last)
        );
    }
    for (i, a) in st.actors.iter().enumerate() {
        let Some(a) = a else { continue };
        let fill = if a.running {
            "orange"
        } else if a.queued {
            "yellow"
        } else {
            "white"
        };
        let pool = if a.pool == 0 {
            String::new()
        } else {
            format!(", pool {}", st.pools[a.pool])
        };
        let mode = format!(
            "{}, {}",
            match a.firing {
                Firing::IfAll => "ifall",
                Firing::IfAny => "ifany",
            },
            match a.drive {
                Drive::Data => "data-driven",
                Drive::Demand => "demand-driven",
            }
        );
        let _ = writeln!(
            s,
            "  a{i} [shape=box, style=filled, fillcolor={fill}, label=\"{}\\n{mode}{pool}\\nfired {} requests {}\"];",
            esc(&a.name),
            a.fired,
            a.requests
        );
        for p in &a.inputs {
            if let Some(d) = p.source {
                let pending = st.data.get(d.0).and_then(|x| x.as_ref()).map_or(0, |dn| {
                    let n = dn.next.saturating_sub(p.cursor);
                    if dn.retention == Retention::LastValue {
                        n.min(1)
                    } else {
                        n
                    }
                });
                let _ = writeln!(
                    s,
                    "  d{} -> a{i} [label=\"{} ({pending})\"];",
                    d.0,
                    esc(&p.name)
                );
            }
        }
        for p in &a.outputs {
            for d in &p.targets {
                let _ = writeln!(s, "  a{i} -> d{} [label=\"{}\"];", d.0, esc(&p.name));
            }
        }
    }
    s.push_str("}\n");
    s
}
