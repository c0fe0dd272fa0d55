//! The station's electrical consumers and how an interval's energy is shared among them (issue
//! 38 item 3): the ECLSS subsystems of seed §4.3 (air control for the crew modules and for the
//! experiment modules, potable water, hygiene), the station's base load, the mobile servicer
//! and the experiments, each with a priority ([`Priority`]) and a mode the scheduler sets
//! ([`Mode`]). The model (what a consumer *is*) is [`Consumer`] and [`Experiment`]; what they
//! are doing is the caller's (the station study's scheduler state).
//!
//! Demands are assumptions scaled to the study's model station (its arrays give 302 kW at best,
//! 170 kW over an orbit; the 1988 station's 75 kW): each names its source in
//! [`Consumer::source`], docs/studies.md lists them.
//!
//! Entry points: [`default_consumers`], [`default_experiments`], [`share`].

/// How much a consumer matters when energy is short (seed §4.2: "there are vital subsystems on
/// the Station whose energy demands must be satisfied … the air control subsystems for the
/// experiment modules might operate at a reduced capacity, while it is not true for the crew
/// modules").
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Priority {
    /// Must be served (crew air, potable water, the station's base load, the servicer while it
    /// holds an ORU).
    Vital,
    /// May run at a reduced capacity (the experiment modules' air control).
    Reducible,
    /// May be switched off or deferred (hygiene, experiments).
    Sheddable,
}

impl Priority {
    /// The name the rule base and the outputs use.
    pub fn name(self) -> &'static str {
        match self {
            Priority::Vital => "vital",
            Priority::Reducible => "reducible",
            Priority::Sheddable => "sheddable",
        }
    }

    pub const ALL: [Priority; 3] = [Priority::Vital, Priority::Reducible, Priority::Sheddable];
}

/// What a consumer is allowed to draw.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    Full,
    Reduced,
    Off,
}

impl Mode {
    pub fn name(self) -> &'static str {
        match self {
            Mode::Full => "full",
            Mode::Reduced => "reduced",
            Mode::Off => "off",
        }
    }

    /// The mode named `s` (`full`, `reduced`, `off`).
    pub fn parse(s: &str) -> Option<Mode> {
        match s {
            "full" => Some(Mode::Full),
            "reduced" => Some(Mode::Reduced),
            "off" => Some(Mode::Off),
            _ => None,
        }
    }
}

/// One continuous consumer.
#[derive(Debug, Clone, PartialEq)]
pub struct Consumer {
    /// Name (a CLIPS symbol: letters, digits, `_`).
    pub name: &'static str,
    /// The ECLSS process it is (a path of the fault model, `ECLSS.PotableWater`), or what else
    /// it is (`station`, `servicer`).
    pub subsystem: &'static str,
    pub priority: Priority,
    /// Demand at full capacity, W.
    pub full_w: f64,
    /// Demand at reduced capacity, W (= `full_w` when it cannot be reduced).
    pub reduced_w: f64,
    /// Where the figure comes from.
    pub source: &'static str,
}

impl Consumer {
    /// Demand in `mode`, W.
    pub fn demand_w(&self, mode: Mode) -> f64 {
        match mode {
            Mode::Full => self.full_w,
            Mode::Reduced => self.reduced_w,
            Mode::Off => 0.0,
        }
    }
}

/// An experiment in the experiment modules: runs of `duration_s` at `power_w`, one asked for
/// every `every_s` from `first_s`. `sensitive`: a microgravity experiment that a desaturation or
/// a docking disturbs (seed §4.2, constraint 1).
#[derive(Debug, Clone, PartialEq)]
pub struct Experiment {
    pub name: &'static str,
    pub power_w: f64,
    pub duration_s: f64,
    pub sensitive: bool,
    pub first_s: f64,
    pub every_s: f64,
    pub source: &'static str,
}

/// The base load the station study's `--load` sets, W (avionics, communications, thermal
/// control, lighting: the part of the station's load no scheduler touches).
pub const BASE_LOAD_W: f64 = 100e3;

/// The servicer's demand while it moves or holds an ORU, W (assumed: the SSRMS's drive draws
/// about 2 kW, its base and cameras the rest).
pub const SERVICER_W: f64 = 3e3;

/// The station's consumers with the base load `base_w` (module docs; their order is the
/// outputs' column order). The servicer's demand applies only while its task runs.
pub fn default_consumers(base_w: f64) -> Vec<Consumer> {
    const SCALE: &str = "assumed; scaled to the model station's 302 kW arrays (the 1988 station's ECLSS drew ~1/4 of its 75 kW)";
    vec![
        Consumer {
            name: "station_base",
            subsystem: "station",
            priority: Priority::Vital,
            full_w: base_w,
            reduced_w: base_w,
            source: "the study's --load: avionics, communications, thermal control, lighting",
        },
        Consumer {
            name: "air_crew",
            subsystem: "ECLSS.AirControl",
            priority: Priority::Vital,
            full_w: 18e3,
            reduced_w: 18e3,
            source: SCALE,
        },
        Consumer {
            name: "air_experiment",
            subsystem: "ECLSS.AirControl",
            priority: Priority::Reducible,
            full_w: 18e3,
            reduced_w: 7e3,
            source: "assumed like the crew modules'; reduced: fans and CO2 removal only, no O2 generation or thermal margin (40 %)",
        },
        Consumer {
            name: "potable_water",
            subsystem: "ECLSS.PotableWater",
            priority: Priority::Vital,
            full_w: 5e3,
            reduced_w: 5e3,
            source: SCALE,
        },
        Consumer {
            name: "hygiene",
            subsystem: "ECLSS.Hygiene",
            priority: Priority::Sheddable,
            full_w: 6e3,
            reduced_w: 6e3,
            source: "assumed: shower water heating and waste-water processing, deferrable by hours",
        },
        Consumer {
            name: "servicer",
            subsystem: "servicer",
            priority: Priority::Vital,
            full_w: SERVICER_W,
            reduced_w: SERVICER_W,
            source: "assumed (SERVICER_W); vital while the ORU swap runs: an ORU in hand is not let go",
        },
    ]
}

/// The experiments of the default study (assumed: a furnace, crystal growth, a life-science
/// rack and Earth observation; powers of the order of the 1988 station's payload racks,
/// scaled).
pub fn default_experiments() -> Vec<Experiment> {
    vec![
        Experiment {
            name: "materials_furnace",
            power_w: 30e3,
            duration_s: 3600.0,
            sensitive: true,
            first_s: 1200.0,
            every_s: 2.0 * 5554.0,
            source: "assumed: a high-temperature furnace, 1 h melts, microgravity-sensitive",
        },
        Experiment {
            name: "crystal_growth",
            power_w: 12e3,
            duration_s: 7200.0,
            sensitive: true,
            first_s: 600.0,
            every_s: 3.0 * 5554.0,
            source: "assumed: protein crystal growth, 2 h, microgravity-sensitive",
        },
        Experiment {
            name: "life_sciences",
            power_w: 8e3,
            duration_s: 5400.0,
            sensitive: false,
            first_s: 0.0,
            every_s: 5554.0,
            source: "assumed: a life-science rack, 1.5 h per orbit",
        },
        Experiment {
            name: "earth_observation",
            power_w: 10e3,
            duration_s: 2700.0,
            sensitive: false,
            first_s: 2400.0,
            every_s: 5554.0,
            source: "assumed: an Earth-observation payload, 45 min per orbit",
        },
    ]
}

/// What a failed process's consumer still draws, share of its demand, from the failure until
/// its spare runs (assumed: controllers, sensors and heaters stay on). The fault model of the
/// in-process station study (`robosim_studies::station::faults`) and of the daemon's ops stage.
pub const STANDBY: f64 = 0.1;
/// How long a spare takes from on line to running, s (assumed: priming and checkout).
pub const SPARE_START_S: f64 = 300.0;
/// The catch-up rate once the spare runs, times the demand (assumed: the processor's margin).
pub const CATCH_UP: f64 = 2.0;

/// How long a failed process's catch-up takes, s, when it failed at `failed_s` and its spare
/// came on line at `spare_s`: the work missed from the failure to the spare running
/// ([`SPARE_START_S`] after `spare_s`), made up at ([`CATCH_UP`] − 1) × the demand.
pub fn catch_up_s(failed_s: f64, spare_s: f64) -> f64 {
    (spare_s + SPARE_START_S - failed_s) / (CATCH_UP - 1.0)
}

/// How a shortfall is shared when the loads allowed draw more than the bus can give.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sharing {
    /// Every load gets the same fraction of its demand (a bus browning out: no one decides).
    Proportional,
}

/// Shares `served_w` (≤ Σ demands) among `demands_w` ([`Sharing`]): each consumer's served
/// power, W. Σ result = min(served, Σ demands).
pub fn share(demands_w: &[f64], served_w: f64, sharing: Sharing) -> Vec<f64> {
    let total: f64 = demands_w.iter().map(|d| d.max(0.0)).sum();
    if total <= 0.0 {
        return vec![0.0; demands_w.len()];
    }
    match sharing {
        Sharing::Proportional => {
            let f = (served_w / total).clamp(0.0, 1.0);
            demands_w.iter().map(|d| d.max(0.0) * f).collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shortfall_is_shared_in_proportion_and_nothing_is_made_up() {
        let s = share(&[100.0, 50.0, 0.0, 50.0], 100.0, Sharing::Proportional);
        assert_eq!(s, vec![50.0, 25.0, 0.0, 25.0]);
        let s = share(&[100.0, 50.0], 500.0, Sharing::Proportional);
        assert_eq!(s, vec![100.0, 50.0]);
        assert_eq!(share(&[0.0], 10.0, Sharing::Proportional), vec![0.0]);
    }

    #[test]
    fn the_default_consumers_are_named_as_clips_symbols_and_ordered_by_what_matters() {
        let c = default_consumers(BASE_LOAD_W);
        for x in &c {
            assert!(
                x.name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_')
            );
            assert!(x.reduced_w <= x.full_w && x.reduced_w >= 0.0);
            assert_eq!(x.demand_w(Mode::Off), 0.0);
        }
        let crew = c.iter().find(|x| x.name == "air_crew").expect("crew air");
        let exp = c
            .iter()
            .find(|x| x.name == "air_experiment")
            .expect("exp air");
        // seed §4.2: the experiment modules' air control is reduced, the crew modules' is not
        assert!(crew.priority < exp.priority && exp.reduced_w < exp.full_w);
        assert!(Priority::Vital < Priority::Reducible && Priority::Reducible < Priority::Sheddable);
    }
}
