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

use super::protocol::{Case, Settings, prepare_seconds};
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::protocol::{Protocol, prepare, prepare_all};
    use glam::DVec2;

    fn challenge() -> Settings {
        Settings {
            protocol: Protocol::Windows,
            obs: 3.2,
            dt: 0.4,
            horizon: 4.8,
            window_every: 4.0,
            ..Settings::default()
        }
    }

    /// A person at 0.4 s rows: walking east at 1 m/s, except standing still for
    /// `stand` seconds from `stand_from`; rows missing in `gap`.
    fn track(n: usize, stand_from: f64, stand: f64, gap: (f64, f64)) -> Track {
        let mut x = 0.0;
        let mut rows = Vec::new();
        for i in 0..n {
            let t = i as f64 * 0.4;
            let standing = t > stand_from && t <= stand_from + stand;
            if i > 0 && !standing {
                x += 0.4;
            }
            if t > gap.0 && t < gap.1 {
                continue;
            }
            rows.push(Row {
                t,
                position: DVec2::new(x, 0.0),
                speed: if standing { 0.0 } else { 1.0 },
                angle: 0.0,
            });
        }
        Track { id: 3, rows }
    }

    #[test]
    fn windows_slide_along_the_track() {
        let t = track(101, 1e9, 0.0, (1e9, 1e9)); // 40 s of walking
        let cases = prepare_all(std::slice::from_ref(&t), &challenge());
        // starts every 4 s while start + 3.2 + 0.4 <= 40: 0, 4, ..., 36
        assert_eq!(cases.len(), 10);
        for (m, c) in cases.iter().enumerate() {
            let t_w = 4.0 * m as f64;
            assert_eq!(c.window, m as u32 + 1);
            assert_eq!(c.observed.len(), 8);
            assert!((c.start.time - (t_w + 3.2)).abs() < 1e-9);
            assert!((c.start.position.x - (t_w + 3.2)).abs() < 1e-9);
            assert!((c.start.speed - 1.0).abs() < 1e-12);
            // 12 steps where the track lasts, fewer at its end
            let left = 40.0 - c.start.time;
            assert_eq!(
                c.steps,
                if left >= 4.8 {
                    12
                } else {
                    (left / 0.4 + 1e-9) as usize
                }
            );
            assert!(c.future.last().unwrap().t <= c.start.time + 4.8 + 1e-6);
        }
        // distinct windows of one person draw distinct seeds
        assert_ne!(cases[0].seed_key(), cases[1].seed_key());
        // the first window is what `prepare` gives
        assert_eq!(prepare(&t, &challenge()).unwrap(), cases[0]);
        // only the windows with 4.8 s of ground truth: the last one (from 36 s) is shorter
        let full = Settings {
            full_horizon_only: true,
            ..challenge()
        };
        let kept = prepare_all(std::slice::from_ref(&t), &full);
        assert_eq!(kept.len(), 9);
        assert!(kept.iter().all(|c| c.steps == 12));
        // back to back (window_every 0): starts at 0, 8, ..., 32
        let s = Settings {
            window_every: 0.0,
            ..challenge()
        };
        assert_eq!(prepare_all(std::slice::from_ref(&t), &s).len(), 5);
    }

    #[test]
    fn idle_filter_and_gaps_apply_per_window() {
        // standing from 12 s to 22 s: the seconds protocol drops the whole person, the
        // windows protocol only the windows with 4 s of standing... or of little motion
        let t = track(101, 12.0, 10.0, (1e9, 1e9));
        let seconds = Settings {
            protocol: Protocol::Seconds,
            ..challenge()
        };
        assert!(prepare(&t, &seconds).is_none());
        let kept: Vec<u32> = prepare_all(std::slice::from_ref(&t), &challenge())
            .iter()
            .map(|c| c.window)
            .collect();
        // window m covers [4(m-1), 4(m-1) + 8]; it is idle when a 4 s span in it moves
        // less than 1 m, i.e. when 4 s of it hold more than 3 s of the standing [12, 22]:
        // windows 3 to 5 ([8, 16] to [16, 24])
        assert_eq!(kept, vec![1, 2, 6, 7, 8, 9, 10]);
        // rows missing from 20 s to 21 s (a 1.2 s gap): windows are cut at the gap
        let t = track(101, 1e9, 0.0, (20.0, 21.0));
        let cases = prepare_all(std::slice::from_ref(&t), &challenge());
        for c in &cases {
            assert!(c.future.windows(2).all(|w| w[1].t - w[0].t < 0.8 + 1e-9));
            assert!(c.observed.windows(2).all(|w| w[1].t - w[0].t < 0.8 + 1e-9));
        }
        // window 5 ([16, 24]) observes 16..19.2, predicts from 19.2 up to the gap (0.8 s)
        let w5 = cases.iter().find(|c| c.window == 5).unwrap();
        assert_eq!(w5.steps, 2);
        // window 6 starts at 20 s, inside the gap: skipped
        assert!(cases.iter().all(|c| c.window != 6));
    }

    #[test]
    fn challenge_windows_on_the_magni_recording() {
        use crate::tracks::{Columns, read_named};
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../shared/data/magni/magni-A-first-16min.csv"
        );
        let tracks = read_named(path.as_ref(), &Columns::magni()).unwrap().tracks;
        let s = challenge();
        let cases = prepare_all(&tracks, &s);
        let seconds = Settings {
            protocol: Protocol::Seconds,
            ..s
        };
        // every helmet waits somewhere: the whole-track protocol keeps nobody
        assert_eq!(
            tracks.iter().filter_map(|t| prepare(t, &seconds)).count(),
            0
        );
        // but many walking windows remain (2,000 s of tracks at one window per 4 s)
        assert!(cases.len() > 300, "{}", cases.len());
        let mut keys = std::collections::HashSet::new();
        for c in &cases {
            assert!(keys.insert(c.seed_key()));
            // 3.2 s observed: 8 rows, give or take a row missing (a gap of 0.8 s at most)
            // or doubled (a 0.01 s shift of the clock)
            assert!((7..=9).contains(&c.observed.len()), "{}", c.observed.len());
            let observed = c.start.time - c.observed[0].t;
            assert!((3.2 - 1e-6..3.2 + 0.8).contains(&observed), "{observed}");
            assert!(c.steps >= 1 && c.steps <= 12);
            // the window walks: at least 1 m in every 4 s of it
            let rows: Vec<_> = c.observed.iter().chain(&c.future).collect();
            let span = rows.last().unwrap().t - rows[0].t;
            let moved = rows[0].position.distance(rows.last().unwrap().position);
            assert!(
                span < 4.0 || moved >= 1.0,
                "window {} of {}",
                c.window,
                c.id
            );
        }
        // most windows predict the full 12 rows
        let full = cases.iter().filter(|c| c.steps == 12).count();
        assert!(full * 10 > cases.len() * 8, "{full} of {}", cases.len());
    }
}
