//! One person (or window of a track) prepared for evaluation: the observed history, the
//! start state and the ground truth to compare with.

use glam::DVec2;

use crate::motion::{History, State};
use crate::tracks::Row;

/// One person prepared for evaluation.
#[derive(Debug, Clone, PartialEq)]
pub struct Case {
    /// Person id.
    pub id: u64,
    /// The observed rows (the history the prediction starts from).
    pub observed: Vec<Row>,
    /// The start state.
    pub start: State,
    /// Ground-truth rows from the start row to the end of the track.
    pub future: Vec<Row>,
    /// Prediction horizon for this person (s).
    pub horizon: f64,
    /// Predicted steps for this person.
    pub steps: usize,
    /// Windows protocol: the window's number along the track (1 for the window starting
    /// at the track's first row); 0 for the other protocols.
    pub window: u32,
}

impl Case {
    /// Ground-truth position at time `t`, linearly interpolated between the surrounding
    /// rows; `None` outside the future rows.
    pub fn truth_at(&self, t: f64) -> Option<DVec2> {
        interpolate(&self.future, t)
    }

    /// The person's observed path up to the start, on the motion model's grid (the
    /// observed rows and the start row; the start state's constant-velocity path if the
    /// rows give none).
    pub fn history(&self) -> History {
        let start = Row {
            t: self.start.time,
            position: self.start.position,
            speed: self.start.speed,
            angle: self.start.heading,
        };
        let rows: Vec<Row> = self.observed.iter().copied().chain([start]).collect();
        History::from_rows(&rows).unwrap_or_else(|_| History::from_state(&self.start))
    }

    /// The number a prediction's seed is mixed with: the person id, and for a window
    /// also its number (so that every window draws its own samples).
    pub fn seed_key(&self) -> u64 {
        self.id ^ (u64::from(self.window) << 40)
    }
}

/// Position at time `t` by linear interpolation between the rows around it.
pub(crate) fn interpolate(rows: &[Row], t: f64) -> Option<DVec2> {
    let first = rows.first()?;
    let last = rows.last()?;
    if t < first.t - 1e-9 || t > last.t + 1e-9 {
        return None;
    }
    let i = rows.partition_point(|r| r.t < t);
    if i == 0 {
        return Some(first.position);
    }
    if i >= rows.len() {
        return Some(last.position);
    }
    let (a, b) = (&rows[i - 1], &rows[i]);
    let w = (t - a.t) / (b.t - a.t);
    Some(a.position.lerp(b.position, w))
}
