//! A person's recent path on the motion model's grid: what a [`MotionModel`] reads.
//!
//! The model sees the last [`HISTORY_POINTS`] positions at [`MODEL_DT`] steps, the
//! newest last (2.8 s of walking in 0.4 s steps), whatever rate the tracker delivers: a
//! [`History`] interpolates the observed rows at those times. Where the rows begin later
//! than the oldest point, the path is carried back at the velocity of its first two rows
//! (a person seen for one second is taken to have walked that way before); a single row
//! or a bare [`State`] gives a path at the state's velocity.
//!
//! [`MotionModel`]: super::MotionModel
//!
//! ```
//! use cliff::motion::{History, HISTORY_POINTS, MODEL_DT};
//! use glam::DVec2;
//! // rows at 1 Hz, walking east at 1.2 m/s
//! let times = [0.0, 1.0, 2.0, 3.0];
//! let points: Vec<DVec2> = times.iter().map(|&t| DVec2::new(1.2 * t, 0.0)).collect();
//! let h = History::from_points(&times, &points).unwrap();
//! let p = h.points();
//! assert_eq!(p.len(), HISTORY_POINTS);
//! assert!((p[HISTORY_POINTS - 1].x - 3.6).abs() < 1e-12);
//! assert!((p[HISTORY_POINTS - 1].x - p[HISTORY_POINTS - 2].x - 1.2 * MODEL_DT).abs() < 1e-12);
//! ```

use glam::DVec2;

use super::{HistoryError, State};
use crate::tracks::Row;

/// The motion model's time step (s): its history and its forecast are on this grid.
pub const MODEL_DT: f64 = 0.4;

/// Positions of the history the model reads, the newest last (so `HISTORY_POINTS - 1`
/// displacements, 2.8 s).
pub const HISTORY_POINTS: usize = 8;

/// The recent path of one person on the model's grid (see the [module
/// documentation](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct History {
    points: [DVec2; HISTORY_POINTS],
}

impl History {
    /// The path of a person at constant velocity up to `state` (when no rows are at hand).
    pub fn from_state(state: &State) -> Self {
        let step = DVec2::from_angle(state.heading) * (state.speed * MODEL_DT);
        Self::backwards(state.position, step)
    }

    /// The path from observed rows (oldest first, times increasing; speeds and angles
    /// are not read).
    pub fn from_rows(rows: &[Row]) -> Result<Self, HistoryError> {
        Self::from_fn(rows.len(), |i| (rows[i].t, rows[i].position))
    }

    /// The path from timestamped positions (oldest first, times increasing).
    pub fn from_points(times: &[f64], points: &[DVec2]) -> Result<Self, HistoryError> {
        if times.len() != points.len() {
            return Err(HistoryError::LengthMismatch);
        }
        Self::from_fn(times.len(), |i| (times[i], points[i]))
    }

    /// The positions, oldest first, [`MODEL_DT`] apart; the last is the newest row's.
    pub fn points(&self) -> &[DVec2; HISTORY_POINTS] {
        &self.points
    }

    /// The newest position.
    pub fn last(&self) -> DVec2 {
        self.points[HISTORY_POINTS - 1]
    }

    /// The displacement of the last step (m per [`MODEL_DT`]).
    pub fn last_step(&self) -> DVec2 {
        self.points[HISTORY_POINTS - 1] - self.points[HISTORY_POINTS - 2]
    }

    /// A path already on the grid, oldest first.
    pub(super) fn from_grid(points: [DVec2; HISTORY_POINTS]) -> Self {
        Self { points }
    }

    /// A path ending at `last` that moved by `step` every grid step.
    fn backwards(last: DVec2, step: DVec2) -> Self {
        let mut points = [last; HISTORY_POINTS];
        for (i, p) in points.iter_mut().enumerate() {
            *p = last - step * (HISTORY_POINTS - 1 - i) as f64;
        }
        Self { points }
    }

    fn from_fn(n: usize, row: impl Fn(usize) -> (f64, DVec2)) -> Result<Self, HistoryError> {
        if n == 0 {
            return Err(HistoryError::TooShort { got: 0, need: 1 });
        }
        for i in 0..n {
            let (t, p) = row(i);
            if !t.is_finite() || !p.is_finite() {
                return Err(HistoryError::NonFinite(i));
            }
            if i > 0 && t <= row(i - 1).0 {
                return Err(HistoryError::NotIncreasing(i));
            }
        }
        let (t_last, last) = row(n - 1);
        if n == 1 {
            return Ok(Self::backwards(last, DVec2::ZERO));
        }
        let (t0, p0) = row(0);
        let (t1, p1) = row(1);
        let first_velocity = (p1 - p0) / (t1 - t0);
        let mut points = [last; HISTORY_POINTS];
        // walk back from the newest row: `j` is the row at or before the point's time
        let mut j = n - 1;
        for (i, p) in points.iter_mut().enumerate().rev() {
            let t = t_last - (HISTORY_POINTS - 1 - i) as f64 * MODEL_DT;
            while j > 0 && row(j).0 > t {
                j -= 1;
            }
            let (tj, pj) = row(j);
            *p = if t < t0 {
                p0 + first_velocity * (t - t0)
            } else if j + 1 < n {
                let (tk, pk) = row(j + 1);
                pj.lerp(pk, (t - tj) / (tk - tj))
            } else {
                pj
            };
        }
        Ok(Self { points })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_on_the_grid_are_taken_as_they_are() {
        let times: Vec<f64> = (0..10).map(|i| i as f64 * MODEL_DT).collect();
        let points: Vec<DVec2> = (0..10)
            .map(|i| DVec2::new(i as f64, (i * i) as f64))
            .collect();
        let h = History::from_points(&times, &points).unwrap();
        for (i, p) in h.points().iter().enumerate() {
            assert!(
                p.distance(points[i + 2]) < 1e-9,
                "{i}: {p} {}",
                points[i + 2]
            );
        }
    }

    #[test]
    fn a_short_history_is_carried_back_at_its_first_velocity() {
        // two rows 0.4 s apart, moving north 0.5 m: the six older points go on south
        let h = History::from_points(&[5.0, 5.4], &[DVec2::new(1.0, 0.0), DVec2::new(1.0, 0.5)])
            .unwrap();
        for (i, p) in h.points().iter().enumerate() {
            let back = (HISTORY_POINTS - 1 - i) as f64;
            assert!(
                p.distance(DVec2::new(1.0, 0.5 - 0.5 * back)) < 1e-9,
                "{i}: {p}"
            );
        }
        let one = History::from_points(&[1.0], &[DVec2::new(2.0, 3.0)]).unwrap();
        assert!(one.points().iter().all(|p| *p == DVec2::new(2.0, 3.0)));
    }

    #[test]
    fn a_state_gives_its_constant_velocity_path() {
        let s = State {
            position: DVec2::new(1.0, 1.0),
            speed: 1.0,
            heading: std::f64::consts::FRAC_PI_2,
            time: 0.0,
        };
        let h = History::from_state(&s);
        assert!(h.last_step().distance(DVec2::new(0.0, MODEL_DT)) < 1e-12);
        assert_eq!(h.last(), s.position);
    }

    #[test]
    fn bad_rows_are_refused() {
        let p = [DVec2::ZERO, DVec2::ONE];
        assert_eq!(
            History::from_points(&[0.0, 0.0], &p),
            Err(HistoryError::NotIncreasing(1))
        );
        assert_eq!(
            History::from_points(&[0.0, f64::NAN], &p),
            Err(HistoryError::NonFinite(1))
        );
        assert_eq!(
            History::from_points(&[], &[]),
            Err(HistoryError::TooShort { got: 0, need: 1 })
        );
        assert_eq!(
            History::from_points(&[0.0], &p),
            Err(HistoryError::LengthMismatch)
        );
    }
}
