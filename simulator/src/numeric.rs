//! Small numeric tools shared by the simulator's models and the studies.
//!
//! Entry point: [`golden_max`].

/// The maximiser of a unimodal `f` on `[lo, hi]` by golden-section search: the bracket shrinks
/// by 1/φ per evaluation until it is no wider than `tol`; returns the bracket's midpoint (within
/// `tol / 2` of the maximiser when `f` is unimodal there). Two evaluations to start, one per
/// shrink after. A `tol` that is not positive, or a bracket that is empty or not finite, returns
/// the midpoint without searching (never loops).
pub fn golden_max(mut f: impl FnMut(f64) -> f64, lo: f64, hi: f64, tol: f64) -> f64 {
    let (mut lo, mut hi) = (lo, hi);
    if !(tol > 0.0 && lo.is_finite() && hi.is_finite() && hi > lo) {
        return 0.5 * (lo + hi);
    }
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (f(x1), f(x2));
    while hi - lo > tol {
        if f1 < f2 {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = f(x2);
        } else {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = f(x1);
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_max_finds_a_known_maximum_to_the_tolerance() {
        // −(x − 0.3)² + 2 has its maximum at 0.3
        let mut calls = 0;
        let x = golden_max(
            |x| {
                calls += 1;
                2.0 - (x - 0.3) * (x - 0.3)
            },
            -1.0,
            2.0,
            1e-6,
        );
        assert!((x - 0.3).abs() <= 0.5e-6, "{x}");
        // ln(3 / 1e-6) / ln φ ≈ 31 shrinks, plus the two starting evaluations
        assert!((31..=35).contains(&calls), "{calls} evaluations");
        // cos on [−1, 2]: the maximum at 0 (near a flat maximum f resolves x only to about
        // √ε, so tolerances far below 1e-8 buy nothing)
        assert!(golden_max(f64::cos, -1.0, 2.0, 1e-6).abs() <= 0.5e-6);
        // a maximum at the bracket's end is approached to the tolerance
        assert!((golden_max(|x| x, 0.0, 1.0, 1e-6) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn golden_max_of_an_empty_or_bad_bracket_does_not_search() {
        let mut calls = 0;
        let mut f = |x: f64| {
            calls += 1;
            x
        };
        assert_eq!(golden_max(&mut f, 1.0, 1.0, 1e-6), 1.0);
        assert_eq!(golden_max(&mut f, 0.0, 1.0, 0.0), 0.5);
        assert!(golden_max(&mut f, 0.0, f64::NAN, 1e-3).is_nan());
        assert_eq!(calls, 0);
    }
}
