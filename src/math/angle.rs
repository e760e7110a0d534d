//! Angles: wrapping to the ranges the maps and the predictor use. Directions are in
//! `[0, 2pi)` ([`wrap_2pi`]); differences of directions in `[-pi, pi)` ([`wrap_pi`]).
//!
//! ```
//! use cliff::math::{wrap_2pi, wrap_pi};
//! assert!((wrap_2pi(-0.5) - (std::f64::consts::TAU - 0.5)).abs() < 1e-12);
//! assert!((wrap_pi(std::f64::consts::TAU - 0.1) + 0.1).abs() < 1e-12);
//! ```

use std::f64::consts::{PI, TAU};

/// Wrap an angle to `[0, 2pi)` (NaN stays NaN).
#[inline]
pub fn wrap_2pi(a: f64) -> f64 {
    if a.is_nan() || a.abs() >= 1e15 {
        // Huge or NaN: the slow, general way.
        let w = a.rem_euclid(TAU);
        return if w >= TAU { 0.0 } else { w };
    }
    // floor(a / 2pi) by the 1.5 * 2^52 rounding trick: branch-free and no libm call
    // (directions near 0 cross the wrap half of the time, so a branch would mispredict).
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    let n = ((a * (1.0 / TAU) - 0.5) + MAGIC) - MAGIC;
    let w = a - n * TAU;
    let w = if w < 0.0 { w + TAU } else { w };
    if w >= TAU { w - TAU } else { w }
}

/// Wrap an angle difference to `[-pi, pi)`.
#[inline]
pub fn wrap_pi(a: f64) -> f64 {
    let w = (a + PI).rem_euclid(TAU) - PI;
    if w >= PI { -PI } else { w }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_2pi_handles_every_range() {
        for (a, w) in [
            (0.0, 0.0),
            (-0.5, TAU - 0.5),
            (TAU, 0.0),
            (3.0 * TAU + 1.0, 1.0),
            (-5.0 * TAU - 1.0, TAU - 1.0),
            (1.0, 1.0),
        ] {
            assert!((wrap_2pi(a) - w).abs() < 1e-12, "{a}: {}", wrap_2pi(a));
        }
        assert!(wrap_2pi(-1e-300) < TAU && wrap_2pi(-1e-300) >= 0.0);
        assert!(wrap_2pi(f64::NAN).is_nan());
    }

    #[test]
    fn wrap_pi_range() {
        assert!((wrap_pi(TAU - 0.1) + 0.1).abs() < 1e-12);
        assert!((wrap_pi(0.1 - TAU) - 0.1).abs() < 1e-12);
        assert_eq!(wrap_pi(PI), -PI);
        assert!((wrap_pi(3.0 * TAU + 0.5) - 0.5).abs() < 1e-12);
    }
}
