//! Solar arrays, sun tracking, array power and the battery: the `sun_tracking` and `power`
//! effects a scene may declare (both need `orbit`, [`crate::orbit`]). The simulator daemon's
//! space stage and `robosim study station` use these same functions. The model, stated:
//!
//! * **Arrays** are robots whose links carry cell panels: box parts whose name starts with
//!   `panel` or `blanket` ([`is_panel`]). Area = the two large sides of each box; the cells
//!   face along the box's thin axis; an array's panels ride on one link (the last one found).
//! * **Tracking**: for one joint, n·ŝ = A + B cos q + C sin q, so q* = atan2(C, B) (three
//!   evaluations); for two (alpha, beta), beta in closed form for each alpha and alpha by a 10°
//!   scan then golden-section search to the tolerance, ties to the angle nearest the previous
//!   one ([`track`]).
//! * **Power** = area × efficiency × [`SOLAR_FLUX`] × max(0, cos incidence), zero in eclipse
//!   ([`SolarArray::power_w`]). No shadowing of one array by another.
//! * **Battery**: one energy store; the net power P − L charges at `charge_eff` and discharges
//!   at 1/`discharge_eff`, held over each step, clamped to [0, capacity] (a surplus is shunted,
//!   a shortfall is load not served) ([`Battery::step`]).
//!
//!   [`Battery::supply`] accounts for every joule of an interval ([`Flow`]): produced = served +
//!   shunted + Δstored + losses.
//!
//! Entry points: [`solar_array`], [`SolarArray::from_panels`], [`track`], [`Battery`].

use nalgebra::{Matrix3, Vector3};
use robosim_kinematics::{Robot, fk};
use robosim_model::parts::BoxPart;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Solar flux at 1 AU, W/m² (the total solar irradiance, SORCE/TIM 2008: 1360.8 ± 0.5).
pub const SOLAR_FLUX: f64 = 1361.0;

/// Whether a part named `leaf` (its last path component) is a cell panel.
pub fn is_panel(leaf: &str) -> bool {
    leaf.starts_with("panel") || leaf.starts_with("blanket")
}

/// One box part of a robot, as [`SolarArray::from_panels`] reads it.
#[derive(Debug, Clone, Copy)]
pub struct PanelBox {
    /// The link frame it rides on (0 = base).
    pub link: usize,
    /// Box sizes along its own axes, m.
    pub size: [f64; 3],
    /// Its orientation in the link frame.
    pub rotation: Matrix3<f64>,
}

/// A solar array: the panels of one robot.
#[derive(Debug, Clone, PartialEq)]
pub struct SolarArray {
    /// Cell area, m² (both large sides of every panel).
    pub area_m2: f64,
    /// The cell normal in the frame of `link`.
    pub normal: Vector3<f64>,
    /// The link the panels ride on (index into `fk::link_frames`; 0 = base).
    pub link: usize,
}

impl SolarArray {
    /// The array of a robot's panel boxes (`None`: no panels).
    pub fn from_panels(panels: impl IntoIterator<Item = PanelBox>) -> Option<SolarArray> {
        let mut out: Option<SolarArray> = None;
        for p in panels {
            let thin = (0..3)
                .min_by(|&a, &b| p.size[a].total_cmp(&p.size[b]))
                .unwrap_or(1);
            let area = p.size.iter().product::<f64>() / p.size[thin];
            let normal = p.rotation * Vector3::ith(thin, 1.0);
            let a = out.get_or_insert(SolarArray {
                area_m2: 0.0,
                normal,
                link: p.link,
            });
            a.area_m2 += area;
            a.normal = normal;
            a.link = p.link;
        }
        out
    }

    /// The cell normal in the robot's world frame at joint values `q`.
    pub fn normal_at(&self, robot: &Robot, q: &[f64]) -> Vector3<f64> {
        let f = fk::link_frames(robot, q);
        f[self.link].fixed_view::<3, 3>(0, 0) * self.normal
    }

    /// Electrical power, W, at cos incidence `cos_incidence` (0 when the sun is behind the
    /// cells), `efficiency` in (0, 1].
    pub fn power_w(&self, efficiency: f64, cos_incidence: f64) -> f64 {
        self.area_m2 * efficiency * SOLAR_FLUX * cos_incidence.max(0.0)
    }
}

/// The solar array of a robot's box parts per frame (`frames[j]`: the boxes of link j, 0 =
/// base; [`robosim_model::parts::RobotParts::frames`]): its boxes named `panel…`/`blanket…`
/// ([`is_panel`]); `None` when it has none.
pub fn solar_array(frames: &[Vec<BoxPart>]) -> Option<SolarArray> {
    let panels = frames
        .iter()
        .enumerate()
        .flat_map(|(link, parts)| parts.iter().map(move |s| (link, s)))
        .filter(|(_, s)| is_panel(s.leaf()))
        .map(|(link, s)| PanelBox {
            link,
            size: s.size,
            rotation: s.transform.fixed_view::<3, 3>(0, 0).into_owned(),
        });
    SolarArray::from_panels(panels)
}

/// Wraps an angle into (−π, π].
pub fn wrap(a: f64) -> f64 {
    let w = a.rem_euclid(TAU);
    if w > PI { w - TAU } else { w }
}

/// The best angle of joint `j` (the others as in `q`) for n·ŝ, in closed form, kept within the
/// joint's limits; `q[j]` is set to it and n·ŝ returned.
fn best_joint(robot: &Robot, a: &SolarArray, q: &mut [f64], j: usize, sun: &Vector3<f64>) -> f64 {
    let mut at = |v: f64| {
        q[j] = v;
        a.normal_at(robot, q).dot(sun)
    };
    let (f0, f1, f2) = (at(0.0), at(FRAC_PI_2), at(PI));
    let b = 0.5 * (f0 - f2);
    let c = f1 - 0.5 * (f0 + f2);
    let lim = robot.joints[j].qlim;
    q[j] = wrap(c.atan2(b)).clamp(lim[0], lim[1]);
    a.normal_at(robot, q).dot(sun)
}

/// Sun tracking for one array: gimbal angles facing the sun `sun` (robot world frame, unit),
/// starting from `prev`; returns them and the cos of the incidence. One joint: the closed form.
/// More: the last joint in closed form for each angle of the first, the first by a 10° scan and
/// golden-section search to `tol` (rad), ties to the angle nearest `prev`.
pub fn track(
    robot: &Robot,
    a: &SolarArray,
    prev: &[f64],
    sun: &Vector3<f64>,
    tol: f64,
) -> (Vec<f64>, f64) {
    let mut q = prev.to_vec();
    let n = q.len();
    if n == 1 {
        let c = best_joint(robot, a, &mut q, 0, sun);
        return (q, c);
    }
    let j1 = n - 1;
    let f = |alpha: f64, q: &mut Vec<f64>| {
        q[0] = alpha;
        best_joint(robot, a, q, j1, sun)
    };
    let mut best = (f64::NEG_INFINITY, 0.0);
    for k in 0..36 {
        let al = wrap(-PI + (k as f64 + 0.5) * TAU / 36.0);
        let v = f(al, &mut q);
        // ties (the mirror solution) go to the one nearest the previous angle
        let better = v > best.0 + 1e-12
            || ((v - best.0).abs() <= 1e-12
                && wrap(al - prev[0]).abs() < wrap(best.1 - prev[0]).abs());
        if better {
            best = (v, al);
        }
    }
    let h = TAU / 36.0;
    let alpha = crate::numeric::golden_max(|x| f(x, &mut q), best.1 - h, best.1 + h, tol);
    let c = f(wrap(alpha), &mut q);
    (q, c)
}

/// One energy store (module docs). Defaults: 150 kWh usable, 80 % charged, 0.9 / 0.9, a
/// constant 100 kW load (the station study's, stated in docs/studies.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Battery {
    /// Usable capacity, J.
    pub capacity_j: f64,
    /// State of charge, 0–1.
    pub soc: f64,
    pub charge_eff: f64,
    pub discharge_eff: f64,
    /// Constant load, W.
    pub load_w: f64,
}

impl Default for Battery {
    fn default() -> Self {
        Battery {
            capacity_j: 150.0 * 3.6e6,
            soc: 0.8,
            charge_eff: 0.9,
            discharge_eff: 0.9,
            load_w: 100e3,
        }
    }
}

impl Battery {
    /// Stored energy, J.
    pub fn energy_j(&self) -> f64 {
        self.soc * self.capacity_j
    }

    /// Array power `power_w` held for `dt_s` against the load: charges or discharges; returns
    /// the load not served (J) when the store runs empty ([`Battery::supply`] with the
    /// constant load).
    pub fn step(&mut self, power_w: f64, dt_s: f64) -> f64 {
        self.supply(power_w, self.load_w, dt_s).unserved_j
    }

    /// Array power `power_w` held for `dt_s` against a demand `demand_w`: the surplus charges
    /// the store at `charge_eff` (what the store cannot take is shunted), a shortfall is drawn
    /// from it at 1/`discharge_eff` (what it cannot give is not served). Every joule is
    /// accounted for: `produced = served + shunted + Δstored + losses` ([`Flow`]).
    pub fn supply(&mut self, power_w: f64, demand_w: f64, dt_s: f64) -> Flow {
        let produced = power_w.max(0.0) * dt_s;
        let demand = demand_w.max(0.0) * dt_s;
        let stored = self.energy_j();
        let mut f = Flow {
            produced_j: produced,
            served_j: demand,
            ..Flow::default()
        };
        if produced >= demand {
            // the surplus: what the store has room for (at the charge efficiency), the rest shunted
            let surplus = produced - demand;
            let room = (self.capacity_j - stored).max(0.0);
            let accepted = surplus.min(room / self.charge_eff);
            f.stored_j = accepted * self.charge_eff;
            f.losses_j = accepted - f.stored_j;
            f.shunted_j = surplus - accepted;
        } else {
            let deficit = demand - produced;
            let drawn = (deficit / self.discharge_eff).min(stored);
            let delivered = drawn * self.discharge_eff;
            f.stored_j = -drawn;
            f.losses_j = drawn - delivered;
            f.unserved_j = deficit - delivered;
            f.served_j = produced + delivered;
        }
        self.soc = ((stored + f.stored_j) / self.capacity_j).clamp(0.0, 1.0);
        f
    }
}

/// Where the energy of one interval went ([`Battery::supply`]), J: produced = served + shunted +
/// stored + losses (stored < 0 when the store gave energy); unserved = demand − served.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Flow {
    /// What the arrays produced.
    pub produced_j: f64,
    /// What the loads received.
    pub served_j: f64,
    /// The surplus the full store could not take (the shunt regulators dissipate it).
    pub shunted_j: f64,
    /// The change of the stored energy.
    pub stored_j: f64,
    /// Charge and discharge losses (the efficiencies).
    pub losses_j: f64,
    /// Demand the store could not cover.
    pub unserved_j: f64,
}

impl Flow {
    /// produced − (served + shunted + stored + losses): zero to rounding.
    pub fn imbalance_j(&self) -> f64 {
        self.produced_j - (self.served_j + self.shunted_j + self.stored_j + self.losses_j)
    }

    /// Adds another interval's flows.
    pub fn add(&mut self, o: &Flow) {
        self.produced_j += o.produced_j;
        self.served_j += o.served_j;
        self.shunted_j += o.shunted_j;
        self.stored_j += o.stored_j;
        self.losses_j += o.losses_j;
        self.unserved_j += o.unserved_j;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panel_box_has_two_sides_of_cells_facing_its_thin_axis() {
        let a = SolarArray::from_panels([
            PanelBox {
                link: 2,
                size: [10.0, 0.1, 30.0],
                rotation: Matrix3::identity(),
            },
            PanelBox {
                link: 2,
                size: [10.0, 0.1, 30.0],
                rotation: Matrix3::identity(),
            },
        ])
        .expect("an array");
        // 2 panels × 2 sides × 10 m × 30 m
        assert!((a.area_m2 - 600.0).abs() < 1e-9);
        assert_eq!(a.normal, Vector3::y());
        assert_eq!(a.link, 2);
        assert!(SolarArray::from_panels([]).is_none());
        // 600 m² × 0.14 × 1361 W/m² at normal incidence; half at 60°; none from behind
        assert!((a.power_w(0.14, 1.0) - 114_324.0).abs() < 1e-6);
        assert!((a.power_w(0.14, 0.5) - 57_162.0).abs() < 1e-6);
        assert_eq!(a.power_w(0.14, -0.3), 0.0);
    }

    #[test]
    fn the_battery_charges_discharges_and_runs_empty_as_stated() {
        let mut b = Battery::default();
        // 130 kW against 100 kW for an hour: +30 kWh × 0.9 = 27 kWh
        assert_eq!(b.step(130e3, 3600.0), 0.0);
        assert!((b.energy_j() - (120.0 + 27.0) * 3.6e6).abs() < 1e-3);
        // full: the surplus is shunted
        b.step(1e6, 3600.0);
        assert_eq!(b.soc, 1.0);
        // nothing for 2 h: 200 kWh / 0.9 needed, 150 stored: 150 × 0.9 = 135 kWh served
        let unserved = b.step(0.0, 7200.0);
        assert_eq!(b.soc, 0.0);
        assert!(
            (unserved / 3.6e6 - (200.0 - 135.0)).abs() < 1e-9,
            "{unserved}"
        );
    }

    /// Every joule of an interval is accounted for, in the three regimes (charging with room,
    /// charging into a full store, drawing it empty): produced = served + shunted + Δstored +
    /// losses, and the store's change is what its state of charge says.
    #[test]
    fn the_battery_accounts_for_every_joule() {
        let cases = [
            (0.5, 250e3, 180e3),
            (0.99, 300e3, 100e3),
            (0.02, 10e3, 200e3),
            (0.4, 0.0, 120e3),
        ];
        for (soc, p, d) in cases {
            let mut b = Battery {
                soc,
                ..Battery::default()
            };
            let before = b.energy_j();
            let f = b.supply(p, d, 600.0);
            assert!(f.imbalance_j().abs() < 1e-6, "{soc} {p} {d}: {f:?}");
            assert!((b.energy_j() - before - f.stored_j).abs() < 1e-6, "{f:?}");
            assert!(
                (f.served_j + f.unserved_j - d * 600.0).abs() < 1e-6,
                "{f:?}"
            );
            assert!(f.shunted_j >= 0.0 && f.losses_j >= 0.0 && f.unserved_j >= 0.0);
        }
        // full store: the surplus is all shunted, nothing lost
        let mut b = Battery {
            soc: 1.0,
            ..Battery::default()
        };
        let f = b.supply(200e3, 100e3, 10.0);
        assert!(
            (f.shunted_j - 1e6).abs() < 1e-6 && f.losses_j == 0.0,
            "{f:?}"
        );
        // charging with room: 10 % of the surplus lost
        let mut b = Battery::default();
        let f = b.supply(200e3, 100e3, 10.0);
        assert!(
            (f.losses_j - 1e5).abs() < 1e-6 && f.shunted_j == 0.0,
            "{f:?}"
        );
    }

    #[test]
    fn wrap_keeps_angles_in_the_half_open_turn() {
        assert!((wrap(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap(-PI) - PI).abs() < 1e-12);
        assert!((wrap(0.5 + TAU) - 0.5).abs() < 1e-12);
    }
}
