//! The `tracklets` protocol: the THÖR-MAGNI benchmark's cut of long recordings.
//!
//! The public THÖR-MAGNI benchmark (tmralmeida/lhmp-thor-magni-challenge-extras) cuts
//! each person's continuous tracking into back-to-back tracklets of 20 rows at 0.4 s,
//! observes rows 1-8 and predicts rows 9-20 from the 8th. Here: a track's rows are
//! split where two rows are more than `1.5 dt` apart (the tracker lost the person:
//! contiguous rows at the recording's rate), and each piece is cut from its first row
//! into `obs / dt + horizon / dt` rows back to back (8 + 12 with `obs` 3.2 s, `dt`
//! 0.4 s, `horizon` 4.8 s); the rows left at a piece's end are not used. A tracklet
//! predicts from its last observed row (the 8th), and its start velocity is the
//! kernel's over its observed rows' speed and angle columns ([`Settings::sigma`]).
//! There is no idle filter: people who stand count. A tracklet with a step faster
//! than [`Settings::max_speed`] (a tracking jump) is left out, as the benchmark leaves
//! out tracklets outside its speed bounds (infinite by default: every tracklet).
//!
//! ```
//! use cliff::tracks::{Row, Track};
//! use cliff::eval::protocol::{prepare_all, Protocol, Settings};
//! use glam::DVec2;
//! // 50 rows at 0.4 s walking east, a gap, then 30 more rows
//! let rows: Vec<Row> = (0..80)
//!     .map(|i| {
//!         let t = i as f64 * 0.4 + if i >= 50 { 10.0 } else { 0.0 };
//!         Row { t, position: DVec2::new(t, 0.0), speed: 1.0, angle: 0.0 }
//!     })
//!     .collect();
//! let s = Settings { protocol: Protocol::Tracklets, obs: 3.2, dt: 0.4, horizon: 4.8, ..Settings::default() };
//! let cases = prepare_all(&[Track { id: 1, rows }], &s);
//! // 50 rows give 2 tracklets of 20, the 30 after the gap 1
//! assert_eq!(cases.len(), 3);
//! assert_eq!((cases[0].observed.len(), cases[0].future.len(), cases[0].steps), (7, 13, 12));
//! assert!((cases[1].start.time - 27.0 * 0.4).abs() < 1e-9);
//! ```

use super::case::Case;
use super::settings::Settings;
use crate::motion::{State, velocity_from_speed_angle};
use crate::predict::steps_for;
use crate::tracks::{Row, Track};

/// Rows observed and predicted per tracklet: `round(obs / dt)` and `round(horizon /
/// dt)`, each at least 1.
pub fn tracklet_rows(s: &Settings) -> (usize, usize) {
    let rows = |x: f64| (x / s.dt).round().max(1.0) as usize;
    (rows(s.obs), rows(s.horizon))
}

/// Append the kept tracklets of `track` to `out`.
pub fn tracklets_of(track: &Track, s: &Settings, out: &mut Vec<Case>) {
    each_tracklet(track, s, |c| {
        out.push(c);
        true
    });
}

/// The first kept tracklet of `track`.
pub fn first_tracklet(track: &Track, s: &Settings) -> Option<Case> {
    let mut first = None;
    each_tracklet(track, s, |c| {
        first = Some(c);
        false
    });
    first
}

fn each_tracklet(track: &Track, s: &Settings, mut f: impl FnMut(Case) -> bool) {
    if !(s.dt > 0.0 && s.obs.is_finite() && s.horizon.is_finite()) {
        return;
    }
    let (obs, pred) = tracklet_rows(s);
    let len = obs + pred;
    let rows = &track.rows;
    let mut number = 0u32;
    // the contiguous pieces, each cut back to back
    for piece in rows.chunk_by(|a, b| b.t - a.t <= 1.5 * s.dt + 1e-9) {
        for chunk in piece.chunks_exact(len) {
            number += 1;
            if let Some(case) = tracklet_case(track.id, chunk, obs, s, number)
                && !f(case)
            {
                return;
            }
        }
    }
}

/// One tracklet of `obs + pred` rows; `None` when it holds a tracking jump.
fn tracklet_case(id: u64, rows: &[Row], obs: usize, s: &Settings, number: u32) -> Option<Case> {
    let jump = rows
        .windows(2)
        .any(|w| w[1].position.distance(w[0].position) > s.max_speed * (w[1].t - w[0].t));
    if jump {
        return None;
    }
    let observed = &rows[..obs];
    let speeds: Vec<f64> = observed.iter().map(|r| r.speed).collect();
    let angles: Vec<f64> = observed.iter().map(|r| r.angle).collect();
    let v = velocity_from_speed_angle(&speeds, &angles, s.sigma).ok()?;
    let start = rows[obs - 1];
    let horizon = (rows.len() - obs) as f64 * s.dt;
    Some(Case {
        id,
        observed: rows[..obs - 1].to_vec(),
        start: State {
            position: start.position,
            speed: v.speed,
            heading: v.heading,
            time: start.t,
        },
        future: rows[obs - 1..].to_vec(),
        horizon,
        steps: steps_for(horizon, s.dt),
        window: number,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::protocol::settings::Protocol;
    use glam::DVec2;

    fn prepare_all(tracks: &[Track], s: &Settings) -> Vec<Case> {
        let mut out = Vec::new();
        for t in tracks {
            tracklets_of(t, s, &mut out);
        }
        out
    }

    fn settings() -> Settings {
        Settings {
            protocol: Protocol::Tracklets,
            obs: 3.2,
            dt: 0.4,
            horizon: 4.8,
            ..Settings::default()
        }
    }

    #[test]
    fn standing_people_count_and_jumps_are_left_out_when_asked() {
        // 40 rows standing still, then a 5 m jump in the second tracklet
        let rows: Vec<Row> = (0..40)
            .map(|i| Row {
                t: i as f64 * 0.4,
                position: DVec2::new(if i >= 30 { 5.0 } else { 0.0 }, 0.0),
                speed: 0.0,
                angle: 0.0,
            })
            .collect();
        let track = Track { id: 7, rows };
        assert_eq!(
            prepare_all(std::slice::from_ref(&track), &settings()).len(),
            2
        );
        let bounded = Settings {
            max_speed: 3.0,
            ..settings()
        };
        let kept = prepare_all(&[track], &bounded);
        assert_eq!(kept.len(), 1);
        assert_eq!((kept[0].window, kept[0].start.speed), (1, 0.0));
    }

    #[test]
    fn rows_at_the_recordings_jitter_stay_one_piece() {
        // MAGNI rows come every 0.4 s give or take 0.01 s
        let rows: Vec<Row> = (0..20)
            .map(|i| Row {
                t: i as f64 * 0.4 + if i % 2 == 0 { 0.01 } else { -0.01 },
                position: DVec2::new(i as f64 * 0.5, 0.0),
                speed: 1.25,
                angle: 0.0,
            })
            .collect();
        let cases = prepare_all(&[Track { id: 1, rows }], &settings());
        assert_eq!(cases.len(), 1);
        assert_eq!(cases[0].start.position, DVec2::new(3.5, 0.0));
        assert!((cases[0].start.speed - 1.25).abs() < 1e-12);
    }
}
