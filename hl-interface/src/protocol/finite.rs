//! The one check every op's numeric answer passes before it is put into JSON: JSON has no
//! `inf` or `NaN` (serde_json writes them as `null`), so a result that left f64's range would
//! otherwise reach the client as `"ok": true` with `null` numbers. Finite inputs whose result
//! is not finite (links of 1e308 m, masses near `f64::MAX`) are refused as `overflow`, naming
//! the quantity and the first bad element.
//!
//! Entry points: [`Finite`] (implemented by every result shape the ops answer: numbers,
//! slices, arrays, nalgebra matrices, and `(name, value)` lists) and [`check`].

use crate::{ErrorKind, ProtocolError};

/// A result whose numbers can be checked for finiteness before they are serialised.
pub trait Finite {
    /// The first non-finite number, with its index path (`""`, `"[3]"`, `"[1][2]"`).
    fn first_non_finite(&self) -> Option<(String, f64)>;
}

impl Finite for f64 {
    fn first_non_finite(&self) -> Option<(String, f64)> {
        (!self.is_finite()).then(|| (String::new(), *self))
    }
}

impl<T: Finite> Finite for [T] {
    fn first_non_finite(&self) -> Option<(String, f64)> {
        self.iter().enumerate().find_map(|(i, x)| {
            x.first_non_finite()
                .map(|(path, v)| (format!("[{i}]{path}"), v))
        })
    }
}

impl<T: Finite, const N: usize> Finite for [T; N] {
    fn first_non_finite(&self) -> Option<(String, f64)> {
        self.as_slice().first_non_finite()
    }
}

impl<T: Finite> Finite for Vec<T> {
    fn first_non_finite(&self) -> Option<(String, f64)> {
        self.as_slice().first_non_finite()
    }
}

/// An absent value (a distance the mode does not give) is not a non-finite one.
impl<T: Finite> Finite for Option<T> {
    fn first_non_finite(&self) -> Option<(String, f64)> {
        self.as_ref().and_then(Finite::first_non_finite)
    }
}

impl Finite for nalgebra::Point3<f64> {
    fn first_non_finite(&self) -> Option<(String, f64)> {
        [self.x, self.y, self.z].first_non_finite()
    }
}

impl<R, C, S> Finite for nalgebra::Matrix<f64, R, C, S>
where
    R: nalgebra::Dim,
    C: nalgebra::Dim,
    S: nalgebra::RawStorage<f64, R, C>,
{
    /// Row-major paths, as the answers write matrices (`[row][column]`).
    fn first_non_finite(&self) -> Option<(String, f64)> {
        (0..self.nrows()).find_map(|r| {
            (0..self.ncols()).find_map(|c| {
                let x = self[(r, c)];
                (!x.is_finite()).then(|| (format!("[{r}][{c}]"), x))
            })
        })
    }
}

/// `Ok(())` when every number of `value` is finite, else an `overflow` refusal naming
/// `quantity` (the answer field, e.g. `` `pose` ``), the element and its value.
pub fn check<T: Finite + ?Sized>(quantity: &str, value: &T) -> Result<(), ProtocolError> {
    match value.first_non_finite() {
        None => Ok(()),
        Some((path, x)) => Err(overflow(&format!("{quantity}{path}"), x)),
    }
}

/// The `overflow` refusal of a non-finite result `x` at `what` (a field and index path).
pub fn overflow(what: &str, x: f64) -> ProtocolError {
    let value = if x.is_nan() {
        "NaN"
    } else if x > 0.0 {
        "+inf"
    } else {
        "-inf"
    };
    ProtocolError::new(
        ErrorKind::Overflow,
        format!(
            "`{what}` overflowed: the result is {value}, outside f64's range (±1.8e308), \
             although the inputs are finite (lengths, masses or velocities too large?)"
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_names_the_first_non_finite_element_by_its_path() {
        assert!(check("x", &1.0).is_ok());
        let e = check("tau", &vec![1.0, f64::INFINITY]).expect_err("inf");
        assert_eq!(e.kind, ErrorKind::Overflow);
        assert!(e.message.contains("`tau[1]` overflowed"), "{}", e.message);
        let m = nalgebra::Matrix2::new(1.0, 2.0, f64::NAN, 4.0);
        let e = check("mass_matrix", &m).expect_err("nan");
        assert!(e.message.contains("`mass_matrix[1][0]`"), "{}", e.message);
        assert!(e.message.contains("NaN"), "{}", e.message);
        let rows = vec![vec![0.0], vec![-f64::INFINITY]];
        let e = check("frames", rows.as_slice()).expect_err("-inf");
        assert!(e.message.contains("`frames[1][0]`"), "{}", e.message);
    }
}
