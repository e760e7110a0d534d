//! Fitting a [`SpeedPrior`] from tracks: [`SpeedPrior::fit`] and
//! [`SpeedPrior::fit_tracks`]. The prior itself (what it is, how the `improved` method
//! applies it) is in [`crate::motion::speed_prior`]; the fit lives here, above it,
//! because it cuts the tracks into people and windows with the evaluation protocols.

use crate::eval::protocol::case::Case;
use crate::eval::protocol::prepare::prepare_all;
use crate::eval::protocol::settings::{Protocol, Settings};
use crate::motion::{MAX_PRIOR_SPEED, SpeedPrior};
use crate::tracks::Track;

/// Fewest (observed, ahead) pairs [`SpeedPrior::fit`] fits a prior from.
pub const MIN_PAIRS: usize = 50;

/// Horizons (s) at which [`SpeedPrior::fit`] measures the speed ahead.
pub const FIT_HORIZONS: [f64; 5] = [10.0, 20.0, 30.0, 40.0, 50.0];

/// Horizons (s) shorter than [`FIT_HORIZONS`] that the windows fallback of
/// [`SpeedPrior::fit`] adds when the windows give too few pairs at those.
pub const SHORT_FIT_HORIZONS: [f64; 2] = [4.0, 8.0];

/// Seconds between the starts of two windows in the windows fallback of
/// [`SpeedPrior::fit`] (the `window_every` of the `windows` protocol).
pub const FIT_WINDOW_EVERY: f64 = 4.0;

impl SpeedPrior {
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

    /// Fit a prior from `tracks`: pairs (start speed, mean speed along the path to a
    /// horizon ahead), and a least-squares line through them, whose slope clamped to
    /// `[0, 1]` is `keep` and whose fixed point is `mean`.
    ///
    /// The pairs come from the first of these that gives at least [`MIN_PAIRS`]:
    ///
    /// 1. **People**, as the `seconds` evaluation protocol takes them: each track
    ///    observed for `obs` seconds from its first row (start speed by the reference's
    ///    velocity kernel at time step `dt`), tracks that stand still anywhere skipped;
    ///    one pair for each of [`FIT_HORIZONS`] a track's ground truth covers. Many
    ///    short tracks (ATC) take this.
    /// 2. **Windows** along each track, as the `windows` protocol cuts long recordings
    ///    (a window every [`FIT_WINDOW_EVERY`] seconds, observed for `obs` seconds, cut
    ///    at tracking gaps, skipped if idle): for each horizon `h` of [`FIT_HORIZONS`],
    ///    the windows of the protocol with horizon `h` whose ground truth covers `h`
    ///    give one pair each (so the idle filter looks at `obs + h` seconds, the
    ///    stretch the pair measures). Few long tracks (THÖR-MAGNI) take this.
    /// 3. The windows of 2, and as many again at each of [`SHORT_FIT_HORIZONS`]
    ///    (people who seldom walk 13 s without stopping).
    ///
    /// Pairs whose start speed or speed ahead is beyond [`MAX_PRIOR_SPEED`] are tracking
    /// glitches, not walkers, and left out. `None` when even 3 gives fewer than
    /// [`MIN_PAIRS`] pairs, or when the line is degenerate (every start speed alike).
    pub fn fit(tracks: &[Track], obs: f64, dt: f64) -> Option<SpeedPrior> {
        let mut line = Line::default();
        people_pairs(tracks, obs, dt, &mut line);
        if line.n() >= MIN_PAIRS {
            return line.prior();
        }
        let mut line = Line::default();
        window_pairs(tracks, obs, dt, &FIT_HORIZONS, &mut line);
        if line.n() < MIN_PAIRS {
            window_pairs(tracks, obs, dt, &SHORT_FIT_HORIZONS, &mut line);
        }
        line.prior()
    }
}

/// The (start speed, speed ahead) pairs of a least-squares line.
#[derive(Debug, Default)]
struct Line {
    pairs: Vec<(f64, f64)>,
}

impl Line {
    fn add(&mut self, v0: f64, ahead: f64) {
        let walking = |v: f64| v.is_finite() && (0.0..=MAX_PRIOR_SPEED).contains(&v);
        if walking(v0) && walking(ahead) {
            self.pairs.push((v0, ahead));
        }
    }

    /// The number of pairs.
    fn n(&self) -> usize {
        self.pairs.len()
    }

    /// The prior of the line; `None` with fewer than [`MIN_PAIRS`] pairs or every start
    /// speed alike. The pairs are summed in one canonical order (by the bits of the
    /// start speed, then of the speed ahead), so the same tracks in any order give the
    /// same prior, bit for bit.
    fn prior(mut self) -> Option<SpeedPrior> {
        if self.n() < MIN_PAIRS {
            return None;
        }
        // speeds are not negative: their bits order them as numbers
        self.pairs
            .sort_unstable_by_key(|&(v0, ahead)| (v0.to_bits(), ahead.to_bits()));
        let (mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0);
        for &(v0, ahead) in &self.pairs {
            sx += v0;
            sy += ahead;
            sxx += v0 * v0;
            sxy += v0 * ahead;
        }
        let nf = self.n() as f64;
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
            pairs: self.n() as u64,
        };
        prior.validate().ok().map(|_| prior)
    }
}

/// Pairs from the people of the `seconds` protocol, at each of [`FIT_HORIZONS`].
fn people_pairs(tracks: &[Track], obs: f64, dt: f64, line: &mut Line) {
    let settings = Settings {
        protocol: Protocol::Seconds,
        obs,
        dt,
        horizon: FIT_HORIZONS[FIT_HORIZONS.len() - 1],
        full_horizon_only: false,
        ..Settings::default()
    };
    for case in prepare_all(tracks, &settings) {
        case_pairs(&case, &FIT_HORIZONS, line);
    }
}

/// Pairs from the windows of the `windows` protocol run once per horizon of
/// `horizons`, each window at that horizon.
fn window_pairs(tracks: &[Track], obs: f64, dt: f64, horizons: &[f64], line: &mut Line) {
    for &h in horizons {
        let settings = Settings {
            protocol: Protocol::Windows,
            obs,
            dt,
            horizon: h,
            window_every: FIT_WINDOW_EVERY,
            full_horizon_only: false,
            ..Settings::default()
        };
        // one track at a time: the windows of a long recording copy its rows
        for track in tracks {
            for case in prepare_all(std::slice::from_ref(track), &settings) {
                case_pairs(&case, &[h], line);
            }
        }
    }
}

/// One pair for each of `horizons` (increasing) that the case's ground truth covers:
/// its start speed and the length of the path from the start position through the
/// rows up to that horizon, over the horizon.
fn case_pairs(case: &Case, horizons: &[f64], line: &mut Line) {
    let v0 = case.start.speed;
    let mut length = 0.0;
    let mut prev = case.start.position;
    let mut rows = case.future.iter().skip_while(|r| r.t <= case.start.time);
    for &h in horizons {
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
        line.add(v0, length / h);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracks::Row;
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

    /// A long track of walking episodes, one every `every` seconds (rows 0.4 s apart,
    /// tracking lost between episodes): in episode `i` the walker is seen at
    /// `v_obs(i)` for the first 3.2 s and then walks on at `a + b v_obs(i)` for
    /// `after` seconds.
    fn episodes(id: u64, n: usize, every: f64, after: f64, v_obs: impl Fn(usize) -> f64) -> Track {
        let (a, b) = (0.5, 0.6);
        let mut rows = vec![];
        let mut x = 0.0;
        for i in 0..n {
            let t0 = i as f64 * every;
            let (v0, v1) = (v_obs(i), a + b * v_obs(i));
            let steps = ((3.2 + after) / 0.4).round() as usize;
            for k in 0..=steps {
                // the row at 3.2 s is the start: rows before it hold the observed speed,
                // the step to each later row is walked at the speed ahead
                let v = if k < 8 { v0 } else { v1 };
                rows.push(Row {
                    t: t0 + k as f64 * 0.4,
                    position: DVec2::new(x, 0.0),
                    speed: v,
                    angle: 0.0,
                });
                x += if k < 8 { v0 } else { v1 } * 0.4;
            }
            x += 5.0;
        }
        Track { id, rows }
    }

    #[test]
    fn few_long_tracks_are_fitted_from_windows_along_them() {
        // three people, 20 episodes each of 3.2 s seen and 10 s ahead: as people only
        // 15 pairs, as windows one pair at 10 s per episode (the windows starting 4 s
        // and 8 s into an episode have less than 10 s ahead)
        let tracks: Vec<Track> = (0..3)
            .map(|p| {
                episodes(p, 20, 16.0, 10.0, |i| {
                    0.5 + 0.05 * (i + 20 * p as usize) as f64 / 3.0
                })
            })
            .collect();
        let p = SpeedPrior::fit(&tracks, 3.2, 0.4).unwrap();
        assert_eq!(p.pairs, 60, "{p:?}");
        // ahead = 0.5 + 0.6 v0: keep 0.6, fixed point 0.5 / 0.4
        assert!((p.keep - 0.6).abs() < 1e-9, "{p:?}");
        assert!((p.mean - 1.25).abs() < 1e-9, "{p:?}");
    }

    #[test]
    fn windows_with_less_than_ten_seconds_ahead_are_fitted_at_four_seconds() {
        // episodes of 3.2 s seen and 4 s ahead, 12 s apart: no window has 8 s ahead,
        // each episode's first window has 4 s
        let tracks: Vec<Track> = (0..3)
            .map(|p| {
                episodes(p, 20, 12.0, 4.0, |i| {
                    0.4 + 0.07 * ((i * 7 + p as usize) % 20) as f64
                })
            })
            .collect();
        let p = SpeedPrior::fit(&tracks, 3.2, 0.4).unwrap();
        assert_eq!(p.pairs, 60, "{p:?}");
        assert!((p.keep - 0.6).abs() < 1e-9, "{p:?}");
        assert!((p.mean - 1.25).abs() < 1e-9, "{p:?}");
        // with 2.8 s ahead there is no pair at all
        let short: Vec<Track> = (0..3)
            .map(|p| episodes(p, 20, 12.0, 2.8, |i| 0.4 + 0.05 * i as f64))
            .collect();
        assert!(SpeedPrior::fit(&short, 3.2, 0.4).is_none());
    }

    #[test]
    fn glitches_beyond_walking_speed_are_left_out() {
        let mut tracks: Vec<Track> = (0..3)
            .map(|p| {
                episodes(p, 20, 16.0, 10.0, |i| {
                    0.5 + 0.05 * (i + 20 * p as usize) as f64 / 3.0
                })
            })
            .collect();
        // a tracker jump: one episode seen at 12 m/s
        tracks.push(episodes(9, 1, 16.0, 10.0, |_| 12.0));
        let p = SpeedPrior::fit(&tracks, 3.2, 0.4).unwrap();
        assert_eq!(p.pairs, 60, "{p:?}");
        assert!((p.keep - 0.6).abs() < 1e-9, "{p:?}");
    }

    #[test]
    fn too_few_walkers_give_no_prior() {
        // one person for 20 s: 1 pair as a person, 9 as windows (2 at 10 s, 3 at 8 s,
        // 4 at 4 s)
        let mut one = walker(1, 1.0, 1.2);
        one.rows.retain(|r| r.t < 20.0);
        assert!(SpeedPrior::fit(&[one], 3.2, 0.4).is_none());
        // one person for a minute is 13 windows at 10 s, 11 at 20 s, 8 at 30 s, 6 at
        // 40 s and 3 at 50 s: 41, too few; with 4 s and 8 s 15 and 14 more
        let p = SpeedPrior::fit(&[walker(1, 1.0, 1.2)], 3.2, 0.4).unwrap();
        assert_eq!(p.pairs, 41 + 15 + 14, "{p:?}");
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
