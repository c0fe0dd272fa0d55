//! A circular Earth orbit, the sun vector in the station's LVLH frame and eclipses from the
//! geometry: the `orbit` effect a scene may declare (`effects { orbit { altitude, beta } }`),
//! used by the simulator daemon's space stage (`robosim up space_station_study --with
//! simulator`) and by `robosim study station` alike. One model, stated:
//!
//! * Earth: a sphere of the mean equatorial radius [`EARTH_RADIUS_M`], point-mass gravity
//!   [`MU_EARTH`]; no J2, no drag; the orbit is circular, so the angular rate is constant.
//! * Sun: infinitely far (parallel rays), fixed in inertial space over the run (the sun moves
//!   ~1°/day; a study covers hours). β is the angle between the sun vector and the orbit plane.
//! * Inertial frame of the orbit: ê1 in the orbit plane towards the sun's projection on it, ĥ
//!   the orbit normal, ê2 = ĥ × ê1. The orbit angle θ is measured from ê1 (θ = 0 is orbit noon).
//!   Sun: ŝ = cos β ê1 + sin β ĥ.
//! * Eclipse: the cylindrical shadow (no penumbra): in eclipse when r·ŝ < 0 and the distance of
//!   r from the sun line is below the Earth's radius. Entry and exit are found by bisection on
//!   the shadow function inside a step, so their times do not depend on the step.
//! * LVLH hold: the station's body axes are x along the velocity (ram), y along the orbit normal
//!   ĥ, z along the radius (zenith). (The ISS convention has y = −ĥ, z = nadir: the same frame
//!   turned 180° about x.) The truss of the model runs along body y, across the orbit plane.
//!
//! Entry points: [`Orbit::new`], [`Orbit::period_s`], [`Orbit::sun_body`], [`Orbit::eclipse_at`],
//! [`Orbit::eclipse_fraction_closed_form`], [`Orbit::eclipse_intervals`].

use nalgebra::Vector3;

/// Earth's gravitational parameter, m³/s² (WGS 84 / EGM 96).
pub const MU_EARTH: f64 = 3.986_004_418e14;
/// Earth's mean equatorial radius, m (WGS 84).
pub const EARTH_RADIUS_M: f64 = 6_378_137.0;

/// Why an orbit cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OrbitError {
    #[error("orbit altitude {0} m: expected a finite altitude above 100 km")]
    Altitude(f64),
    #[error("beta angle {0} rad: expected a finite angle in [-90°, 90°]")]
    Beta(f64),
}

/// A circular orbit at `altitude_m` with sun angle `beta_rad`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orbit {
    pub altitude_m: f64,
    pub beta_rad: f64,
}

impl Orbit {
    /// Refuses a non-finite altitude, one below 100 km (no orbit there) and |β| > 90°.
    pub fn new(altitude_m: f64, beta_rad: f64) -> Result<Orbit, OrbitError> {
        if !altitude_m.is_finite() || altitude_m < 100e3 {
            return Err(OrbitError::Altitude(altitude_m));
        }
        if !beta_rad.is_finite() || beta_rad.abs() > std::f64::consts::FRAC_PI_2 + 1e-12 {
            return Err(OrbitError::Beta(beta_rad));
        }
        Ok(Orbit {
            altitude_m,
            beta_rad,
        })
    }

    /// Orbit radius, m.
    pub fn radius_m(&self) -> f64 {
        EARTH_RADIUS_M + self.altitude_m
    }

    /// Angular rate, rad/s: √(μ/a³).
    pub fn rate(&self) -> f64 {
        (MU_EARTH / self.radius_m().powi(3)).sqrt()
    }

    /// Period, s: 2π √(a³/μ).
    pub fn period_s(&self) -> f64 {
        std::f64::consts::TAU / self.rate()
    }

    /// Orbit angle from orbit noon at time `t_s` (the run starts at angle `theta0`).
    pub fn angle(&self, theta0: f64, t_s: f64) -> f64 {
        theta0 + self.rate() * t_s
    }

    /// Position in the inertial orbit frame (ê1, ê2, ĥ), m.
    pub fn position(&self, theta: f64) -> Vector3<f64> {
        self.radius_m() * Vector3::new(theta.cos(), theta.sin(), 0.0)
    }

    /// The sun direction in the inertial orbit frame.
    pub fn sun_inertial(&self) -> Vector3<f64> {
        Vector3::new(self.beta_rad.cos(), 0.0, self.beta_rad.sin())
    }

    /// The sun direction in the station's body frame under LVLH hold (x ram, y orbit normal,
    /// z zenith) at orbit angle `theta`.
    pub fn sun_body(&self, theta: f64) -> Vector3<f64> {
        let cb = self.beta_rad.cos();
        Vector3::new(-cb * theta.sin(), self.beta_rad.sin(), cb * theta.cos())
    }

    /// The shadow function: negative inside the Earth's cylindrical shadow, positive outside.
    /// Its zeros are the eclipse entry and exit.
    pub fn shadow(&self, theta: f64) -> f64 {
        let r = self.position(theta);
        let s = self.sun_inertial();
        let along = r.dot(&s);
        if along >= 0.0 {
            // the sunlit half: the distance to the sun line does not matter
            return along.max(1.0);
        }
        let perp = (r - along * s).norm();
        perp - EARTH_RADIUS_M
    }

    /// Whether the station is in the Earth's shadow at orbit angle `theta`.
    pub fn eclipse_at(&self, theta: f64) -> bool {
        self.shadow(theta) < 0.0
    }

    /// The closed form: the fraction of the orbit in shadow,
    /// `acos(√(h² + 2Rh) / ((R + h) cos β)) / π`, zero when the argument is ≥ 1 (β beyond
    /// `asin(R/(R+h))`: the orbit never enters the shadow).
    pub fn eclipse_fraction_closed_form(&self) -> f64 {
        let h = self.altitude_m;
        let r = EARTH_RADIUS_M;
        let arg = (h * h + 2.0 * r * h).sqrt() / ((r + h) * self.beta_rad.cos());
        if arg >= 1.0 {
            0.0
        } else {
            arg.acos() / std::f64::consts::PI
        }
    }

    /// Eclipse intervals `[entry, exit]` (s from the start, orbit angle `theta0` at t = 0) in
    /// `[0, t_end]`, the crossings found by bisection to 1 µs inside each step of `step_s`.
    /// An interval open at either end of the run is cut there.
    pub fn eclipse_intervals(&self, theta0: f64, t_end: f64, step_s: f64) -> Vec<[f64; 2]> {
        let f = |t: f64| self.shadow(self.angle(theta0, t));
        let mut out = Vec::new();
        let mut entry = (f(0.0) < 0.0).then_some(0.0);
        let n = (t_end / step_s).ceil().max(1.0) as usize;
        let mut t0 = 0.0;
        for k in 1..=n {
            let t1 = (k as f64 * step_s).min(t_end);
            let (f0, f1) = (f(t0), f(t1));
            if (f0 < 0.0) != (f1 < 0.0) {
                let (mut a, mut b) = (t0, t1);
                while b - a > 1e-6 {
                    let m = 0.5 * (a + b);
                    if (f(m) < 0.0) == (f0 < 0.0) {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                let tc = 0.5 * (a + b);
                if f1 < 0.0 {
                    entry = Some(tc);
                } else if let Some(e) = entry.take() {
                    out.push([e, tc]);
                }
            }
            t0 = t1;
        }
        if let Some(e) = entry {
            out.push([e, t_end]);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn period_is_the_closed_form_and_the_published_value() {
        // 400 km: 2π √((6778.137 km)³ / μ) = 5553.6 s (92.56 min), the ISS-like figure.
        let o = Orbit::new(400e3, 0.0).expect("a valid orbit");
        let t = o.period_s();
        let a: f64 = 6_778_137.0;
        assert!((t - std::f64::consts::TAU * (a.powi(3) / 3.986_004_418e14).sqrt()).abs() < 1e-9);
        assert!((t - 5553.6).abs() < 0.1, "{t}");
        // one period brings the station back: the angle advanced is 2π
        assert!((o.angle(0.3, t) - 0.3 - std::f64::consts::TAU).abs() < 1e-12);
    }

    #[test]
    fn eclipse_fraction_from_the_geometry_matches_the_closed_form() {
        for (h, beta_deg) in [
            (400e3, 0.0),
            (400e3, 20.0),
            (400e3, 60.0),
            (800e3, 35.0),
            (350e3, -45.0),
        ] {
            let o = Orbit::new(h, f64::to_radians(beta_deg)).expect("a valid orbit");
            let t = o.period_s();
            // start just after orbit noon so the run holds one whole eclipse
            let iv = o.eclipse_intervals(0.01, t, 30.0);
            let shadow: f64 = iv.iter().map(|[a, b]| b - a).sum();
            let cf = o.eclipse_fraction_closed_form();
            assert!(
                (shadow / t - cf).abs() < 1e-6,
                "h {h} β {beta_deg}: geometry {} closed form {cf}",
                shadow / t
            );
            assert!(iv.len() <= 1);
            // the step does not change the crossing times
            let coarse = o.eclipse_intervals(0.01, t, 600.0);
            assert_eq!(coarse.len(), iv.len());
            for (a, b) in coarse.iter().zip(&iv) {
                assert!((a[0] - b[0]).abs() < 1e-5 && (a[1] - b[1]).abs() < 1e-5);
            }
        }
        // β = 0 at 400 km: 39.0 % of the orbit in shadow (35.9 of 92.6 min).
        let o = Orbit::new(400e3, 0.0).expect("a valid orbit");
        assert!((o.eclipse_fraction_closed_form() - 0.3901).abs() < 1e-4);
    }

    #[test]
    fn beyond_the_critical_beta_there_is_no_eclipse() {
        let h: f64 = 400e3;
        let crit = (EARTH_RADIUS_M / (EARTH_RADIUS_M + h)).asin();
        let o = Orbit::new(h, crit + 0.01).expect("a valid orbit");
        assert_eq!(o.eclipse_fraction_closed_form(), 0.0);
        assert!(o.eclipse_intervals(0.0, o.period_s(), 10.0).is_empty());
        let o = Orbit::new(h, crit - 0.01).expect("a valid orbit");
        assert!(o.eclipse_fraction_closed_form() > 0.0);
        assert_eq!(o.eclipse_intervals(0.01, o.period_s(), 10.0).len(), 1);
    }

    #[test]
    fn the_sun_in_the_body_frame_is_a_unit_vector_overhead_at_noon() {
        let o = Orbit::new(400e3, 0.5).expect("a valid orbit");
        let s = o.sun_body(0.0);
        assert!((s - Vector3::new(0.0, 0.5f64.sin(), 0.5f64.cos())).norm() < 1e-15);
        for k in 0..16 {
            assert!((o.sun_body(k as f64 * 0.4).norm() - 1.0).abs() < 1e-15);
        }
        // at midnight (θ = π) the sun is below (−z), in eclipse for a low β
        assert!(o.sun_body(std::f64::consts::PI).z < 0.0);
        assert!(o.eclipse_at(std::f64::consts::PI));
        assert!(!o.eclipse_at(0.0));
    }

    #[test]
    fn bad_orbits_are_refused() {
        assert_eq!(Orbit::new(-1.0, 0.0), Err(OrbitError::Altitude(-1.0)));
        assert!(Orbit::new(f64::NAN, 0.0).is_err());
        assert!(Orbit::new(50e3, 0.0).is_err());
        assert!(Orbit::new(400e3, 2.0).is_err());
        assert!(Orbit::new(400e3, f64::INFINITY).is_err());
    }
}
