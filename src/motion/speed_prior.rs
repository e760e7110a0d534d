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
//! ([`SpeedPrior::fit`], which `cliff map build` runs and stores with the map) and
//! applied to the start speed by the `improved` method: `v = mean + keep (v0 - mean)`.
//!
//! ```
//! use cliff::motion::SpeedPrior;
//! let prior = SpeedPrior { mean: 1.2, keep: 0.6, pairs: 1000 };
//! assert!((prior.apply(0.5) - 0.78).abs() < 1e-12); // a slow start: faster
//! assert!((prior.apply(1.2) - 1.2).abs() < 1e-12); // the typical speed stays
//! assert!((prior.apply(2.0) - 1.68).abs() < 1e-12); // a fast start: slower
//! ```

use serde::{Deserialize, Serialize};

use crate::eval::dataset::Track;
use crate::eval::protocol::{Protocol, Settings, prepare_all};

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

/// Fewest (observed, ahead) pairs [`SpeedPrior::fit`] fits a prior from.
pub const MIN_PAIRS: usize = 50;

/// Horizons (s) at which [`SpeedPrior::fit`] measures the speed ahead.
pub const FIT_HORIZONS: [f64; 5] = [10.0, 20.0, 30.0, 40.0, 50.0];

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

    /// [`fit`](Self::fit) with the paper's 3.2 s of observation and a time step from
    /// the data: the median time between rows, within 0.4 s (THÖR's step) and 1 s
    /// (ATC's). What `cliff map build` stores with a map.
    pub fn fit_tracks(tracks: &[Track]) -> Option<SpeedPrior> {
        let mut gaps: Vec<f64> = tracks
            .iter()
            .flat_map(|t| t.rows.windows(2).map(|w| w[1].t - w[0].t))
            .filter(|g| g.is_finite() && *g > 0.0)
            .collect();
        if gaps.is_empty() {
            return None;
        }
        let mid = gaps.len() / 2;
        let (_, median, _) = gaps.select_nth_unstable_by(mid, f64::total_cmp);
        Self::fit(tracks, 3.2, median.clamp(0.4, 1.0))
    }

    /// Fit a prior from `tracks`, taking the people as the `seconds` evaluation
    /// protocol does (each track observed for `obs` seconds from its first row, start
    /// speed by the reference's velocity kernel at time step `dt`, tracks that stand
    /// still anywhere skipped): for each of [`FIT_HORIZONS`] a track's ground truth
    /// covers, one pair (start speed, mean speed along the path to that horizon). A
    /// least-squares line through all pairs gives `keep` (its slope, clamped to
    /// `[0, 1]`) and `mean` (its fixed point). `None` with fewer than [`MIN_PAIRS`]
    /// pairs or a degenerate fit (every start speed alike).
    pub fn fit(tracks: &[Track], obs: f64, dt: f64) -> Option<SpeedPrior> {
        let settings = Settings {
            protocol: Protocol::Seconds,
            obs,
            dt,
            horizon: FIT_HORIZONS[FIT_HORIZONS.len() - 1],
            full_horizon_only: false,
            ..Settings::default()
        };
        let (mut n, mut sx, mut sy, mut sxx, mut sxy) = (0usize, 0.0, 0.0, 0.0, 0.0);
        for case in prepare_all(tracks, &settings) {
            let v0 = case.start.speed;
            let mut length = 0.0;
            let mut prev = case.start.position;
            let mut rows = case.future.iter().skip_while(|r| r.t <= case.start.time);
            for h in FIT_HORIZONS {
                if h > case.horizon + 1e-9 {
                    break;
                }
                let end = case.start.time + h;
                for r in rows.by_ref() {
                    if r.t > end + 1e-9 {
                        break;
                    }
                    length += r.position.distance(prev);
                    prev = r.position;
                }
                let ahead = length / h;
                n += 1;
                sx += v0;
                sy += ahead;
                sxx += v0 * v0;
                sxy += v0 * ahead;
            }
        }
        if n < MIN_PAIRS {
            return None;
        }
        let nf = n as f64;
        let var = sxx / nf - (sx / nf).powi(2);
        if var.is_nan() || var <= 1e-6 {
            return None;
        }
        let slope = (sxy / nf - sx / nf * sy / nf) / var;
        let keep = slope.clamp(0.0, 1.0);
        // fixed point of v -> intercept + keep v; with keep 1 the mean does not matter
        let mean = if keep < 1.0 {
            (sy / nf - keep * sx / nf) / (1.0 - keep)
        } else {
            sy / nf
        };
        let prior = SpeedPrior {
            mean: mean.clamp(0.1, MAX_PRIOR_SPEED),
            keep,
            pairs: n as u64,
        };
        prior.validate().ok().map(|_| prior)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::dataset::Row;
    use glam::DVec2;

    /// A walker at `v_obs` for the first 3.2 s, then `v_after` for 60 s, east.
    fn walker(id: u64, v_obs: f64, v_after: f64) -> Track {
        let mut rows = vec![];
        let mut x = 0.0;
        let mut t = 0.0;
        while t <= 63.2 + 1e-9 {
            let v = if t < 3.2 + 1e-9 { v_obs } else { v_after };
            rows.push(Row {
                t,
                position: DVec2::new(x, 0.0),
                speed: v,
                angle: 0.0,
            });
            x += v * 0.4;
            t += 0.4;
        }
        Track { id, rows }
    }

    #[test]
    fn walkers_who_all_settle_at_one_speed_give_that_speed_and_keep_nothing() {
        // whatever they are seen at, everyone walks on at 1.3 m/s
        let tracks: Vec<Track> = (0..40)
            .map(|i| walker(i, 0.6 + 0.03 * i as f64, 1.3))
            .collect();
        let p = SpeedPrior::fit(&tracks, 3.2, 0.4).unwrap();
        // the first window of each track sees the observed speed; later windows see
        // 1.3 m/s both before and after, so the line is pulled towards keep 1 by them
        // but the first windows alone pin it below 1
        assert!(p.keep < 0.9, "{p:?}");
        assert!((p.apply(1.3) - 1.3).abs() < 0.05, "{p:?}");
        assert!(p.apply(0.6) > 0.6 + 0.05, "{p:?}");
    }

    #[test]
    fn walkers_who_keep_their_speed_keep_it_all() {
        let tracks: Vec<Track> = (0..40)
            .map(|i| {
                let v = 0.6 + 0.03 * i as f64;
                walker(i, v, v)
            })
            .collect();
        let p = SpeedPrior::fit(&tracks, 3.2, 0.4).unwrap();
        assert!(p.keep > 0.99, "{p:?}");
        for v in [0.6, 1.0, 1.7] {
            assert!((p.apply(v) - v).abs() < 0.02, "{p:?} at {v}");
        }
    }

    #[test]
    fn too_few_walkers_give_no_prior() {
        let tracks = vec![walker(1, 1.0, 1.2)];
        assert!(SpeedPrior::fit(&tracks, 3.2, 0.4).is_none());
    }

    #[test]
    fn bad_values_are_refused() {
        for (mean, keep) in [
            (0.0, 0.5),
            (f64::NAN, 0.5),
            (9.0, 0.5),
            (1.2, 1.5),
            (1.2, -0.1),
        ] {
            let p = SpeedPrior {
                mean,
                keep,
                pairs: 100,
            };
            assert!(p.validate().is_err(), "{mean} {keep}");
        }
    }
}
