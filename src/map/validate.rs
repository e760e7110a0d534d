//! Checking a map's values: each location's position, ratio and components, and
//! clamping covariances to positive semi-definite.

use glam::DVec2;

use super::error::MapError;
use super::limits::{MAX_COMPONENT_VALUE, MAX_COMPONENTS, MAX_COORDINATE};
use super::location::Location;

/// Clamp a 2x2 covariance `[a, b; c, d]` to symmetric PSD. Returns the clamped matrix
/// and whether anything changed (beyond rounding).
pub fn clamp_psd(cov: [f64; 4]) -> ([f64; 4], bool) {
    let a = cov[0];
    let d = cov[3];
    let b = 0.5 * (cov[1] + cov[2]);
    let asym = (cov[1] - cov[2]).abs() > 1e-12 * (1.0 + cov[1].abs());
    // Eigenvalues of the symmetric matrix.
    let tr = a + d;
    let det = a * d - b * b;
    let disc = ((a - d) * 0.5).hypot(b);
    let l1 = tr * 0.5 + disc;
    let l2 = tr * 0.5 - disc;
    if l2 >= 0.0 && det >= 0.0 {
        return ([a, b, b, d], asym);
    }
    // Eigenvectors; reconstruct with negative eigenvalues set to zero.
    let (v1, v2) = if b.abs() > 1e-300 {
        let v1 = DVec2::new(l1 - d, b).normalize();
        (v1, DVec2::new(-v1.y, v1.x))
    } else if a >= d {
        (DVec2::X, DVec2::Y)
    } else {
        (DVec2::Y, DVec2::X)
    };
    let l1 = l1.max(0.0);
    let l2 = l2.max(0.0);
    let m = |i: usize, j: usize| l1 * v1[i] * v1[j] + l2 * v2[i] * v2[j];
    let off = m(0, 1);
    ([m(0, 0), off, off, m(1, 1)], true)
}

pub(super) fn validate_location(index: usize, loc: &Location) -> Result<(), MapError> {
    let err = |message: String| MapError::Location {
        index,
        x: loc.position.x,
        y: loc.position.y,
        message,
    };
    if !loc.position.is_finite() {
        return Err(err("position is not finite".into()));
    }
    if loc.position.abs().max_element() > MAX_COORDINATE {
        return Err(err(format!(
            "position is beyond {MAX_COORDINATE} m from the origin"
        )));
    }
    if loc.components.is_empty() {
        return Err(err("no components".into()));
    }
    if loc.components.len() > MAX_COMPONENTS {
        return Err(err(format!(
            "{} components, at most {MAX_COMPONENTS} per location",
            loc.components.len()
        )));
    }
    if !(loc.observation_ratio.is_finite() && (0.0..=1.0 + 1e-9).contains(&loc.observation_ratio)) {
        return Err(err(format!(
            "observation ratio {} is not in [0, 1]",
            loc.observation_ratio
        )));
    }
    if !(loc.motion_ratio.is_finite() && loc.motion_ratio >= 0.0) {
        return Err(err(format!(
            "motion ratio {} is negative or not finite",
            loc.motion_ratio
        )));
    }
    let mut total = 0.0;
    for (j, c) in loc.components.iter().enumerate() {
        let vals = [
            c.theta, c.rho, c.cov[0], c.cov[1], c.cov[2], c.cov[3], c.weight,
        ];
        if vals.iter().any(|v| !v.is_finite()) {
            return Err(err(format!("component {j} has a non-finite value")));
        }
        if vals[..6].iter().any(|v| v.abs() > MAX_COMPONENT_VALUE) {
            return Err(err(format!(
                "component {j} has a direction, speed or covariance beyond {MAX_COMPONENT_VALUE}"
            )));
        }
        if c.rho < 0.0 {
            return Err(err(format!("component {j} has negative speed {}", c.rho)));
        }
        if c.weight < 0.0 {
            return Err(err(format!(
                "component {j} has negative weight {}",
                c.weight
            )));
        }
        total += c.weight;
    }
    if total <= 0.0 {
        return Err(err("component weights sum to zero".into()));
    }
    if !total.is_finite() {
        return Err(err("component weights sum to infinity".into()));
    }
    Ok(())
}
