//! The diagnostic system architecture of the seed's figure 6 on the dataflow kernel: a
//! monitoring subsystem feeds alarms into a stream; the diagnostic manager actor runs ILM
//! (FSPI/FSCI) incrementally on each alarm; a display manager actor shows the best guess.
//! Run: `cargo run -p robosim-automation --example diagnosis_pipeline [FAULT]`.
use robosim_automation::diag::{FaultGraph, Ilm};
use robosim_automation::kernel::{ActorSpec, Ctx, Graph, Retention, Value};
use robosim_automation::model::{Model, load_model};
use robosim_automation::sim::{SimOptions, simulate};

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let fault = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "Collector.collector_leak".into());
    // The diagnostic service lives as long as the program: its model and compiled graph are
    // leaked to 'static so the manager actor's context can hold an ILM session borrowing them.
    let model: &'static Model =
        Box::leak(Box::new(load_model("eclss").map_err(|e| e.to_string())?));
    let graph: &'static FaultGraph = Box::leak(Box::new(FaultGraph::new(model)));
    let f = model.find_failure_mode(&fault)?;
    // Sensors on symptoms only: the alarms of originating failure modes are not allocated.
    let present: Vec<bool> = model
        .alarms
        .iter()
        .map(|a| a.detects.iter().all(|&x| model.failure_modes[x].derived))
        .collect();

    let g = Graph::new(2);
    let alarms = g
        .edit(|e| -> Result<_, robosim_automation::kernel::KernelError> {
            let alarms = e.add_data("alarms", Retention::Stream)?;
            let guess = e.add_data("best_guess", Retention::LastValue)?;
            let present2 = present.clone();
            let manager = e.add_actor(
                ActorSpec::new("diagnostic_manager", move |ctx: &mut Ctx<'_>| {
                    let v = ctx
                        .input("alarm")
                        .and_then(Value::as_vec)
                        .ok_or("no alarm")?
                        .to_vec();
                    let ilm = ctx.context::<Ilm<'static>>().ok_or("context")?;
                    ilm.on_alarm(v[1] as usize, v[0])
                        .map_err(|e| e.to_string())?;
                    ilm.run_to_completion();
                    let text = match ilm.best_guess() {
                        Some(gs) => format!(
                            "t={:.0}s {} -> {} [{}]",
                            v[0],
                            model.alarms[v[1] as usize].name,
                            gs.failure_modes
                                .iter()
                                .map(|&f| model.failure_modes[f].path.as_str())
                                .collect::<Vec<_>>()
                                .join(" | "),
                            gs.components
                                .iter()
                                .map(|&c| model.components[c].name.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                        None => "no guess".into(),
                    };
                    ctx.emit("guess", Value::Text(text))
                })
                .inputs(&["alarm"])
                .outputs(&["guess"])
                .context(Ilm::new(model, graph, Some(&present2))),
            )?;
            let display = e.add_actor(
                ActorSpec::new("display_manager", |ctx: &mut Ctx<'_>| {
                    if let Some(Value::Text(t)) = ctx.input("guess") {
                        println!("{t}");
                    }
                    Ok(())
                })
                .inputs(&["guess"]),
            )?;
            e.connect_in(alarms, manager, "alarm")?;
            e.connect_out(manager, "guess", guess)?;
            e.connect_in(guess, display, "guess")?;
            Ok(alarms)
        })
        .map_err(|e| e.to_string())?;

    // The monitoring subsystem: the alarm pattern simulator, filtered by the allocation.
    let sim = simulate(
        graph,
        &[(f, 0.0)],
        &SimOptions {
            seed: 4,
            sample_probabilities: false,
            ..SimOptions::default()
        },
    );
    println!(
        "injected {} ; {} symptom alarms will ring",
        model.failure_modes[f].path,
        sim.alarms.iter().filter(|e| present[e.alarm]).count()
    );
    for e in sim.alarms.iter().filter(|e| present[e.alarm]) {
        g.write(alarms, Value::Vec(vec![e.time, e.alarm as f64]))
            .map_err(|e| e.to_string())?;
    }
    g.wait_idle();
    if let Some(e) = g.errors().first() {
        return Err(e.clone());
    }
    Ok(())
}
