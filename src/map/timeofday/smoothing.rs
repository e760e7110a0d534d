//! How the slices of a set were smoothed: [`Smoothing`].

use serde::{Deserialize, Serialize};

use crate::map::MapError;

/// How the slices of a set were smoothed (see [`build_map_set`]); stored in the file
/// for `cliff map info`.
///
/// The map of slice `h` at a grid node `x` is a mixture of mixtures:
///
/// ```text
/// p_h(v | x) = ( sum_k K(h, k) n_k(x) f_k(v | x) + prior_weight * f_all(v | x) )
///              / ( sum_k K(h, k) n_k(x) + prior_weight )
/// ```
///
/// where `f_k` is the mixture fitted (mean shift + EM, as for any map) to slice `k`'s
/// own observations at `x`, `n_k(x)` the number of those observations, `f_all` the
/// all-day mixture and `K(h, k) = exp(-d^2 / (2 kernel_width^2))` a Gaussian kernel
/// over the time-of-day distance `d` between the slices' centres (around the clock).
/// The all-day map is a prior worth `prior_weight` observations at every location: a
/// node that the slice's data hardly visit keeps the all-day mixture, a busy one gets
/// its own. Near-duplicate components (Bhattacharyya distance below
/// `merge_distance`) are merged by moment matching and at most `max_components` kept
/// per location (the lightest merged into its closest), so sampling stays cheap.
///
/// Observation ratios (which location within the sampling radius a prediction uses)
/// follow the same weights: `sum_k K(h, k) n_k(x) + prior_weight * r_all(x)`, scaled so
/// that the busiest location has 1.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Smoothing {
    /// Standard deviation of the time kernel over slices (s); 0: each slice's own data
    /// only.
    pub kernel_width: f64,
    /// Observations the all-day mixture is worth at every location; 0: no prior (a
    /// location keeps the all-day mixture only where no slice in reach has data).
    pub prior_weight: f64,
    /// Share of the all-day mixture in every slice mixture, whatever the slice's data
    /// (0: none; 1: the all-day map everywhere).
    pub all_day_share: f64,
    /// Components closer than this Bhattacharyya distance are merged.
    pub merge_distance: f64,
    /// Largest number of components per location of a slice map.
    pub max_components: usize,
}

impl Default for Smoothing {
    fn default() -> Self {
        Self {
            kernel_width: 0.0,
            prior_weight: 50.0,
            all_day_share: 0.3,
            merge_distance: 0.1,
            max_components: 8,
        }
    }
}

impl Smoothing {
    /// Check the values, naming the first bad one.
    pub fn check(&self) -> Result<(), MapError> {
        let bad = |m: String| Err(MapError::TimeOfDay(m));
        if !(self.kernel_width.is_finite() && self.kernel_width >= 0.0) {
            return bad(format!(
                "kernel width {} s must be finite and not negative",
                self.kernel_width
            ));
        }
        if !(self.prior_weight.is_finite() && self.prior_weight >= 0.0) {
            return bad(format!(
                "prior weight {} must be finite and not negative",
                self.prior_weight
            ));
        }
        if !(0.0..=1.0).contains(&self.all_day_share) {
            return bad(format!(
                "all-day share {} is not in [0, 1]",
                self.all_day_share
            ));
        }
        if !(self.merge_distance.is_finite() && self.merge_distance >= 0.0) {
            return bad(format!(
                "merge distance {} must be finite and not negative",
                self.merge_distance
            ));
        }
        if !(1..=crate::map::MAX_COMPONENTS).contains(&self.max_components) {
            return bad(format!(
                "at most {} components per location is not in 1..={}",
                self.max_components,
                crate::map::MAX_COMPONENTS
            ));
        }
        Ok(())
    }
}
