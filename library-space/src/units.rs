//! Quantities with unit dimensions. Values are stored in SI (m, kg, rad, s); the dimension is a
//! vector of exponents of length, mass, angle and time. Angle is kept as its own dimension (SI
//! calls it dimensionless) so that `5 mm + 3 deg` is caught.

use std::fmt;

/// Exponents of (length, mass, angle, time).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct Dim(pub [i8; 4]);

impl Dim {
    pub const NONE: Dim = Dim([0, 0, 0, 0]);
    pub const LENGTH: Dim = Dim([1, 0, 0, 0]);
    pub const MASS: Dim = Dim([0, 1, 0, 0]);
    pub const ANGLE: Dim = Dim([0, 0, 1, 0]);
    pub const TIME: Dim = Dim([0, 0, 0, 1]);
    pub const DENSITY: Dim = Dim([-3, 1, 0, 0]);
    pub const INERTIA: Dim = Dim([2, 1, 0, 0]);
    pub const ACCEL: Dim = Dim([1, 0, 0, -2]);

    pub fn mul(self, o: Dim) -> Dim {
        Dim(std::array::from_fn(|i| self.0[i] + o.0[i]))
    }
    pub fn div(self, o: Dim) -> Dim {
        Dim(std::array::from_fn(|i| self.0[i] - o.0[i]))
    }
    pub fn pow(self, k: i8) -> Dim {
        Dim(self.0.map(|e| e * k))
    }
    /// Half the exponents, if all are even (for `sqrt`).
    pub fn half(self) -> Option<Dim> {
        if self.0.iter().all(|e| e % 2 == 0) {
            Some(Dim(self.0.map(|e| e / 2)))
        } else {
            None
        }
    }

    /// The bare noun: "a length", "an angle", "a plain number", or "a quantity in kg*m^2".
    pub fn noun(self) -> String {
        let d = self.describe();
        match d.find(" (") {
            Some(k) if !d.starts_with("a quantity") => d[..k].to_string(),
            _ => d,
        }
    }

    /// A human name with its usual units: "a length (m, cm, mm)", or the unit formula.
    pub fn describe(self) -> String {
        let named = match self {
            Dim::NONE => "a plain number (no unit)",
            Dim::LENGTH => "a length (m, cm, mm)",
            Dim::MASS => "a mass (kg, g)",
            Dim::ANGLE => "an angle (deg, rad)",
            Dim::TIME => "a time (s, ms)",
            Dim::DENSITY => "a density (kg/m^3)",
            Dim::INERTIA => "a moment of inertia (kg*m^2)",
            Dim::ACCEL => "an acceleration (m/s^2)",
            _ => return format!("a quantity in {self}"),
        };
        named.to_string()
    }
}

impl fmt::Display for Dim {
    /// The SI unit formula, e.g. `kg*m^2`, `m/s^2`, `1`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names = ["m", "kg", "rad", "s"];
        let mut num = Vec::new();
        let mut den = Vec::new();
        for (i, &e) in self.0.iter().enumerate() {
            let term = |e: i8| {
                if e == 1 {
                    names[i].to_string()
                } else {
                    format!("{}^{}", names[i], e)
                }
            };
            match e.cmp(&0) {
                std::cmp::Ordering::Greater => num.push(term(e)),
                std::cmp::Ordering::Less => den.push(term(-e)),
                std::cmp::Ordering::Equal => {}
            }
        }
        // mass first reads better: kg*m^2
        num.sort_by_key(|s| !s.starts_with("kg"));
        let n = if num.is_empty() {
            "1".to_string()
        } else {
            num.join("*")
        };
        if den.is_empty() {
            write!(f, "{n}")
        } else {
            write!(f, "{n}/{}", den.join("/"))
        }
    }
}

/// The units the language knows, with their SI scale.
pub fn unit(name: &str) -> Option<(f64, Dim)> {
    Some(match name {
        "km" => (1e3, Dim::LENGTH),
        "m" => (1.0, Dim::LENGTH),
        "cm" => (1e-2, Dim::LENGTH),
        "mm" => (1e-3, Dim::LENGTH),
        "kg" => (1.0, Dim::MASS),
        "g" => (1e-3, Dim::MASS),
        "rad" => (1.0, Dim::ANGLE),
        "deg" => (std::f64::consts::PI / 180.0, Dim::ANGLE),
        "s" => (1.0, Dim::TIME),
        "ms" => (1e-3, Dim::TIME),
        _ => return None,
    })
}

/// A number with a dimension. `free` marks a unitless literal 0, which may stand for zero of
/// any dimension (`translate(0, 0, 5 cm)`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quantity {
    pub value: f64,
    pub dim: Dim,
    pub free: bool,
}

impl Quantity {
    pub fn new(value: f64, dim: Dim) -> Self {
        Quantity {
            value,
            dim,
            free: false,
        }
    }
    /// Does this quantity fit dimension `d`? (a free zero fits every dimension)
    pub fn fits(&self, d: Dim) -> bool {
        self.dim == d || (self.free && self.value == 0.0)
    }
    /// The value expressed for display in the dimension's usual unit ("45 deg", "0.5 m").
    pub fn show(&self) -> String {
        match self.dim {
            Dim::ANGLE => format!("{} deg", round_sig(self.value.to_degrees())),
            Dim::NONE => format!("{}", round_sig(self.value)),
            d => format!("{} {}", round_sig(self.value), d),
        }
    }
}

fn round_sig(v: f64) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let p = 10f64.powi(12 - v.abs().log10().ceil() as i32);
    (v * p).round() / p
}
