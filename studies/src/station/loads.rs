//! The station's loads in the study (issue 38 item 3): the consumers and experiments of
//! [`robosim_simulator::consumers`] with their state over a run — each consumer's mode, each
//! experiment's runs — what they demand at a step, how the interval's energy
//! ([`power::Battery::supply`]) is shared among them, and the totals the summary reports.
//! The decisions are the scheduler's ([`super::scheduler`]); with the scheduler off every
//! consumer runs at full and every experiment starts when it is asked for.
//!
//! Entry points: [`Loads::new`], [`Loads::demands`], [`Loads::serve`], [`Forecast`].

use robosim_simulator::consumers::{Consumer, Experiment, Mode, Priority, Sharing, share};
use robosim_simulator::power::{self, Flow};

/// One experiment's runs over the study.
#[derive(Debug, Clone, PartialEq)]
pub struct ExpState {
    /// Runs asked for so far, started, completed.
    pub asked: usize,
    pub started: usize,
    pub completed: usize,
    /// The run under way or waiting: running, time left (s), not before (s), deferred for
    /// energy said already.
    pub running: bool,
    pub remaining_s: f64,
    pub not_before: f64,
    pub deferred: bool,
    /// Time run, s, and of it with a desaturation or docking under way (a sensitive run
    /// disturbed), s.
    pub run_s: f64,
    pub disturbed_s: f64,
    /// Times moved out of a window, stopped.
    pub moved: usize,
    pub stopped: usize,
}

/// The state of the loads over a run.
#[derive(Debug, Clone)]
pub struct Loads {
    pub consumers: Vec<Consumer>,
    pub experiments: Vec<Experiment>,
    /// Each consumer's mode (the scheduler's, or full).
    pub modes: Vec<Mode>,
    /// Each consumer's demand at full and reduced capacity now, W: the model's, changed by a
    /// fault (a failed unit's process stands still, then catches up) and by the servicer's
    /// task (none when it is idle).
    pub full_w: Vec<f64>,
    pub reduced_w: Vec<f64>,
    pub exps: Vec<ExpState>,
}

/// One step's loads: what each consumer and experiment demanded from this step to the next,
/// and what it was served (W, averaged over the interval; filled when the interval ends).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LoadStep {
    /// Per consumer, then per experiment (in [`Loads::names`] order).
    pub demand_w: Vec<f64>,
    pub served_w: Vec<f64>,
    pub modes: Vec<Mode>,
    /// The interval's energy flows (zero at the last step).
    pub flow: Flow,
    pub interval_s: f64,
}

/// Energy totals over the run, J.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Totals {
    pub flow: Flow,
    /// Per priority ([`Priority::ALL`] order): demanded by the plan, served.
    pub demanded_j: [f64; 3],
    pub served_j: [f64; 3],
    /// Demand shed by the scheduler (full demand − the plan's), per priority.
    pub shed_j: [f64; 3],
}

impl Loads {
    pub fn new(consumers: Vec<Consumer>, experiments: Vec<Experiment>) -> Loads {
        let n = consumers.len();
        let full_w = consumers.iter().map(|c| c.full_w).collect();
        let reduced_w = consumers.iter().map(|c| c.reduced_w).collect();
        let exps = experiments
            .iter()
            .map(|_| ExpState {
                asked: 0,
                started: 0,
                completed: 0,
                running: false,
                remaining_s: 0.0,
                not_before: 0.0,
                deferred: false,
                run_s: 0.0,
                disturbed_s: 0.0,
                moved: 0,
                stopped: 0,
            })
            .collect();
        Loads {
            consumers,
            experiments,
            modes: vec![Mode::Full; n],
            full_w,
            reduced_w,
            exps,
        }
    }

    /// Consumers' then experiments' names (the outputs' column order).
    pub fn names(&self) -> Vec<&'static str> {
        self.consumers
            .iter()
            .map(|c| c.name)
            .chain(self.experiments.iter().map(|e| e.name))
            .collect()
    }

    /// The priority of load `i` ([`Loads::names`] order): experiments are sheddable.
    pub fn priority(&self, i: usize) -> Priority {
        self.consumers
            .get(i)
            .map_or(Priority::Sheddable, |c| c.priority)
    }

    /// Demand of consumer `i` in `mode` now, W.
    pub fn consumer_w(&self, i: usize, mode: Mode) -> f64 {
        match mode {
            Mode::Full => self.full_w[i],
            Mode::Reduced => self.reduced_w[i],
            Mode::Off => 0.0,
        }
    }

    /// Runs asked for up to `t`: an experiment's next run waits once the last is done.
    pub fn ask(&mut self, t: f64) {
        for (e, x) in self.experiments.iter().zip(&mut self.exps) {
            let due = if t + 1e-9 >= e.first_s {
                ((t - e.first_s) / e.every_s).floor() as usize + 1
            } else {
                0
            };
            if due > x.asked {
                // a run asked for while the last is still waiting or running is not queued
                // behind it (it counts as asked, not completed)
                if !x.running && x.remaining_s <= 0.0 {
                    x.remaining_s = e.duration_s;
                    x.not_before = t;
                    x.deferred = false;
                }
                x.asked = due;
            }
        }
    }

    /// Whether experiment `j` has a run waiting to start (asked, not running).
    pub fn waiting(&self, j: usize) -> bool {
        let x = &self.exps[j];
        !x.running && x.remaining_s > 0.0
    }

    /// Starts experiment `j`'s waiting run.
    pub fn start(&mut self, j: usize) {
        let x = &mut self.exps[j];
        if !x.running && x.remaining_s > 0.0 {
            if (x.remaining_s - self.experiments[j].duration_s).abs() < 1e-9 {
                x.started += 1;
            }
            x.running = true;
        }
    }

    /// Stops experiment `j`'s run (its time left kept) until `not_before`.
    pub fn stop(&mut self, j: usize, not_before: f64) {
        let x = &mut self.exps[j];
        if x.running {
            x.running = false;
            x.stopped += 1;
            x.not_before = not_before;
        }
    }

    /// What every load demands from now to the next step, W ([`Loads::names`] order).
    pub fn demands(&self) -> Vec<f64> {
        (0..self.consumers.len())
            .map(|i| self.consumer_w(i, self.modes[i]))
            .chain(
                self.experiments
                    .iter()
                    .zip(&self.exps)
                    .map(|(e, x)| if x.running { e.power_w } else { 0.0 }),
            )
            .collect()
    }

    /// What every load would demand at full (nothing shed), W.
    pub fn full_demands(&self) -> Vec<f64> {
        (0..self.consumers.len())
            .map(|i| self.full_w[i])
            .chain(
                self.experiments
                    .iter()
                    .zip(&self.exps)
                    .map(|(e, x)| if x.running { e.power_w } else { 0.0 }),
            )
            .collect()
    }

    /// This step's record (served filled by [`Loads::serve`]).
    pub fn record(&self) -> LoadStep {
        let demand_w = self.demands();
        LoadStep {
            served_w: vec![0.0; demand_w.len()],
            demand_w,
            modes: self.modes.clone(),
            flow: Flow::default(),
            interval_s: 0.0,
        }
    }

    /// The interval of `dt` s after the step recorded in `rec`: the arrays' `power_w` against
    /// its demand through the battery ([`power::Battery::supply`]), shared among the loads
    /// ([`share`]); the experiments' runs advance (`disturbed`: a desaturation or docking under
    /// way). Fills `rec`, adds to `totals`.
    pub fn serve(
        &mut self,
        rec: &mut LoadStep,
        battery: &mut power::Battery,
        power_w: f64,
        dt: f64,
        disturbed: bool,
        totals: &mut Totals,
    ) -> Flow {
        let demand: f64 = rec.demand_w.iter().sum();
        let flow = battery.supply(power_w, demand, dt);
        rec.served_w = share(&rec.demand_w, flow.served_j / dt, Sharing::Proportional);
        rec.flow = flow;
        rec.interval_s = dt;
        totals.flow.add(&flow);
        let full = self.full_demands();
        for (i, (d, s)) in rec.demand_w.iter().zip(&rec.served_w).enumerate() {
            let k = self.priority(i) as usize;
            totals.demanded_j[k] += d * dt;
            totals.served_j[k] += s * dt;
            if i < self.consumers.len() {
                totals.shed_j[k] += (full[i] - d).max(0.0) * dt;
            }
        }
        for (e, x) in self.experiments.iter().zip(&mut self.exps) {
            if x.running {
                x.run_s += dt;
                if disturbed && e.sensitive {
                    x.disturbed_s += dt;
                }
                x.remaining_s -= dt;
                if x.remaining_s <= 1e-9 {
                    x.running = false;
                    x.remaining_s = 0.0;
                    x.completed += 1;
                }
            }
        }
        flow
    }
}

/// The generation the power model predicts over the coming orbit, per phase: sunlit phases at
/// the mean power delivered over the sunlit steps of the last orbit (persistence; at the start,
/// the power now if sunlit), eclipses at 0 — from the orbit's eclipse intervals.
#[derive(Debug, Clone, PartialEq)]
pub struct Forecast {
    /// (kind, start s, end s, power W), in time order.
    pub phases: Vec<(&'static str, f64, f64, f64)>,
}

impl Forecast {
    /// Over [t, t + horizon] with `eclipses` (the run's, extended past its end) and the
    /// predicted sunlit power `sun_w`.
    pub fn new(t: f64, horizon: f64, eclipses: &[[f64; 2]], sun_w: f64) -> Forecast {
        let end = t + horizon;
        let mut phases = Vec::new();
        let mut at = t;
        for &[a, b] in eclipses {
            if b <= at || a >= end {
                continue;
            }
            if a > at {
                phases.push(("sunlit", at, a, sun_w));
            }
            let b = b.min(end);
            phases.push(("eclipse", at.max(a), b, 0.0));
            at = b;
        }
        if at < end {
            phases.push(("sunlit", at, end, sun_w));
        }
        Forecast { phases }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use robosim_simulator::consumers::{default_consumers, default_experiments};

    #[test]
    fn the_forecast_covers_the_horizon_with_its_eclipses_in_order() {
        let f = Forecast::new(
            100.0,
            1000.0,
            &[[0.0, 200.0], [600.0, 800.0], [2000.0, 2100.0]],
            5.0,
        );
        assert_eq!(
            f.phases,
            vec![
                ("eclipse", 100.0, 200.0, 0.0),
                ("sunlit", 200.0, 600.0, 5.0),
                ("eclipse", 600.0, 800.0, 0.0),
                ("sunlit", 800.0, 1100.0, 5.0),
            ]
        );
    }

    /// Served never exceeds demand, the interval's flows close, the experiments' runs advance
    /// and complete, and runs are asked for on their period.
    #[test]
    fn loads_are_served_from_the_battery_and_runs_complete() {
        let mut l = Loads::new(default_consumers(100e3), default_experiments());
        l.ask(0.0);
        let j = l
            .experiments
            .iter()
            .position(|e| e.name == "life_sciences")
            .expect("life sciences");
        assert!(l.waiting(j));
        l.start(j);
        let mut b = power::Battery::default();
        let mut tot = Totals::default();
        let mut t = 0.0;
        while l.exps[j].running {
            let mut rec = l.record();
            let f = l.serve(&mut rec, &mut b, 50e3, 60.0, false, &mut tot);
            assert!(f.imbalance_j().abs() < 1e-6);
            for (d, s) in rec.demand_w.iter().zip(&rec.served_w) {
                assert!(*s <= d + 1e-9);
            }
            t += 60.0;
            l.ask(t);
        }
        assert_eq!(l.exps[j].completed, 1);
        assert!((l.exps[j].run_s - 5400.0).abs() < 1e-6);
        // the battery ran empty on the way (50 kW against ~160 kW): some vital demand unserved
        assert!(tot.flow.unserved_j > 0.0);
        assert!((tot.flow.imbalance_j()).abs() < 1e-3);
        // the next run is asked for one orbit after the first
        assert_eq!(l.exps[j].asked, 1);
        l.ask(5554.0);
        assert_eq!(l.exps[j].asked, 2);
        assert!(l.waiting(j));
    }
}
