//! How a walker's speed over the next minute relates to the speed observed now.
//!
//! CLiFF-LHMP keeps the observed speed for the whole horizon. A speed observed over a
//! few seconds is noisy: a person seen slow for 3 s (looking around, slowing for a
//! crowd) mostly walks on faster, one seen fast mostly walks on slower. Over the
//! 1,133 people of ATC's training hours with 50 s of ground truth, the mean speed of the
//! next 50 s regresses to the mean: `0.43 + 0.65 v0` (m/s), and the same fit holds
//! from 10 s to 50 s ahead (slope 0.60 to 0.71).
//!
//! A [`SpeedPrior`] is that regression, learned from the tracks a map is built from
//! ([`SpeedPrior::fit`], in `cliff::eval::speed_prior_fit` because it cuts the tracks
//! with the evaluation protocols; `cliff map build` runs it and stores the prior with the map) and
//! applied to the start speed by the `improved` method: `v = mean + keep (v0 - mean)`.
//!
//! Long recordings of few people give too few people for the fit; it then takes windows
//! along each track as the `windows` evaluation protocol cuts them. The first 8 minutes
//! of the THÖR-MAGNI recording (9 helmets) give 144 windows with 10 s or more ahead, and
//! there the speed ahead does not follow the speed seen at all: `keep` 0, `mean`
//! 1.13 m/s.
//!
//! ```
//! use cliff::motion::SpeedPrior;
//! let prior = SpeedPrior { mean: 1.2, keep: 0.6, pairs: 1000 };
//! assert!((prior.apply(0.5) - 0.78).abs() < 1e-12); // a slow start: faster
//! assert!((prior.apply(1.2) - 1.2).abs() < 1e-12); // the typical speed stays
//! assert!((prior.apply(2.0) - 1.68).abs() < 1e-12); // a fast start: slower
//! ```

use serde::{Deserialize, Serialize};

/// The regression of the speed ahead on the observed speed (see the
/// [module documentation](self)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpeedPrior {
    /// The speed the regression pulls towards (m/s).
    pub mean: f64,
    /// The share of the observed speed's offset from `mean` that is kept, in `[0, 1]`
    /// (1: the observed speed, the paper's rule).
    pub keep: f64,
    /// How many (observed, ahead) pairs the fit used.
    pub pairs: u64,
}

/// Largest typical walking speed a prior may hold (m/s).
pub const MAX_PRIOR_SPEED: f64 = 5.0;

impl SpeedPrior {
    /// The start speed for an observed speed `v0`: `mean + keep (v0 - mean)`, never
    /// negative.
    #[inline]
    pub fn apply(&self, v0: f64) -> f64 {
        (self.mean + self.keep * (v0 - self.mean)).max(0.0)
    }

    /// Check the values (a prior read from a file is not trusted); the error says
    /// which is wrong.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.mean.is_finite() && self.mean > 0.0 && self.mean <= MAX_PRIOR_SPEED) {
            return Err(format!(
                "speed prior mean {} is not in (0, {MAX_PRIOR_SPEED}] m/s",
                self.mean
            ));
        }
        if !(self.keep.is_finite() && (0.0..=1.0).contains(&self.keep)) {
            return Err(format!("speed prior keep {} is not in [0, 1]", self.keep));
        }
        Ok(())
    }
}
