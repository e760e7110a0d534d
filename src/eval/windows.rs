//! The `windows` protocol: many predictions along one long track.
//!
//! Long recordings such as THÖR-MAGNI hold one track per person over many minutes
//! (walking, waiting, walking again). Along each track, window `m` (1, 2, ...) starts at
//! `first_time + (m - 1) * step` (at the track's first row at or after that time), where `step` is [`Settings::window_every`] (or
//! `obs + horizon`, back to back, when it is 0). Each window is evaluated like a person
//! of the `seconds` protocol on the track's rows from the window's first row to
//! `obs + horizon` seconds after it: observe `obs` seconds, predict from the first row after them
//! for `min(horizon, rows left)`, and skip the window if it is idle (less than
//! [`Settings::idle_distance`] in any [`Settings::idle_window`] seconds of it).
//!
//! Tracking gaps: a window keeps the rows up to the first gap of more than `2 dt`
//! between rows (its horizon ends there), and a window whose first row is more than
//! `2 dt` after its start time is skipped (it begins inside a gap).
//!
//! The THÖR-MAGNI challenge setting is 8 observed and 12 predicted rows at 0.4 s:
//! `obs` 3.2 s, `dt` 0.4 s, `horizon` 4.8 s.
//!
//! ```
//! use cliff::tracks::{Row, Track};
//! use cliff::eval::protocol::{prepare_all, Protocol, Settings};
//! use glam::DVec2;
//! // one person walking east at 1 m/s for 40 s, a row every 0.4 s
//! let rows = (0..100)
//!     .map(|i| {
//!         let t = i as f64 * 0.4;
//!         Row { t, position: DVec2::new(t, 0.0), speed: 1.0, angle: 0.0 }
//!     })
//!     .collect();
//! let s = Settings { protocol: Protocol::Windows, obs: 3.2, dt: 0.4, horizon: 4.8, window_every: 8.0, ..Settings::default() };
//! let cases = prepare_all(&[Track { id: 1, rows }], &s);
//! // windows start at 0, 8, 16, 24 and 32 s; each predicts 12 steps from 3.2 s in
//! assert_eq!(cases.len(), 5);
//! assert_eq!(cases[1].window, 2);
//! assert!((cases[1].start.time - 11.2).abs() < 1e-9 && cases[1].steps == 12);
//! ```

use super::protocol::case::Case;
use super::protocol::seconds::prepare_seconds;
use super::protocol::settings::Settings;
use crate::tracks::{Row, Track};

/// Seconds from one window's start to the next one's.
pub fn window_step(s: &Settings) -> f64 {
    let step = if s.window_every > 0.0 {
        s.window_every
    } else {
        s.obs + s.horizon
    };
    // never less than a prediction step (and never 0 or NaN, which would not advance)
    if step.is_finite() && step >= s.dt {
        step
    } else {
        s.dt
    }
}

/// The largest time between two rows inside a window: `2 dt`.
pub fn max_gap(s: &Settings) -> f64 {
    2.0 * s.dt
}

/// Append the kept windows of `track` to `out`.
pub fn windows_of(track: &Track, s: &Settings, out: &mut Vec<Case>) {
    each_window(track, s, |c| {
        out.push(c);
        true
    });
}

/// The first kept window of `track`.
pub fn first_window(track: &Track, s: &Settings) -> Option<Case> {
    let mut first = None;
    each_window(track, s, |c| {
        first = Some(c);
        false
    });
    first
}

/// Call `f` with each kept window in order until it returns false.
fn each_window(track: &Track, s: &Settings, mut f: impl FnMut(Case) -> bool) {
    let rows = &track.rows;
    let (Some(first), Some(last)) = (rows.first(), rows.last()) else {
        return;
    };
    if !(s.dt > 0.0 && s.obs.is_finite() && s.horizon.is_finite()) {
        return;
    }
    let step = window_step(s);
    let mut lo = 0usize;
    for m in 0u32.. {
        let t_w = first.t + f64::from(m) * step;
        // a window needs a row to start from after its observation, and a step past it
        if t_w + s.obs + s.dt > last.t + 1e-6 || m == u32::MAX {
            break;
        }
        while lo < rows.len() && rows[lo].t < t_w - 1e-6 {
            lo += 1;
        }
        if let Some(case) = window_case(track.id, &rows[lo..], s, t_w, m + 1)
            && !f(case)
        {
            break;
        }
    }
}

/// The window starting at `t_w`; `rows` begin with the track's first row at or after it.
fn window_case(id: u64, rows: &[Row], s: &Settings, t_w: f64, number: u32) -> Option<Case> {
    let gap = max_gap(s);
    if rows.first()?.t > t_w + gap {
        return None;
    }
    // from the window's first row (which a clock shift of the recording can set a
    // little after `t_w`)
    let end = rows[0].t + s.obs + s.horizon + 1e-6;
    let mut n = 1;
    while n < rows.len() && rows[n].t <= end && rows[n].t - rows[n - 1].t <= gap + 1e-9 {
        n += 1;
    }
    let window = Track {
        id,
        rows: rows[..n].to_vec(),
    };
    let mut case = prepare_seconds(&window, s)?;
    case.window = number;
    Some(case)
}
