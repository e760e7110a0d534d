//! Preparing tracks for evaluation with the protocol the settings name.

use super::case::Case;
use super::reference::prepare_reference;
use super::seconds::prepare_seconds;
use super::settings::{Protocol, Settings};
use super::tracklets;
use crate::eval::windows;
use crate::predict::steps_for;
use crate::tracks::Track;

/// Prepare a track for evaluation, or `None` when the protocol skips the person.
pub fn prepare(track: &Track, s: &Settings) -> Option<Case> {
    match s.protocol {
        Protocol::Reference => prepare_reference(track, s),
        Protocol::Seconds => prepare_seconds(track, s),
        Protocol::Windows => windows::first_window(track, s),
        Protocol::Tracklets => tracklets::first_tracklet(track, s),
    }
}

/// Every case the protocol makes of `tracks`: one per kept person, or, with
/// [`Protocol::Windows`], one per kept window, in track order (with
/// [`Settings::full_horizon_only`], only those with the whole horizon of ground truth).
pub fn prepare_all(tracks: &[Track], s: &Settings) -> Vec<Case> {
    let mut cases = prepare_each(tracks, s);
    if s.full_horizon_only {
        let full = steps_for(s.horizon, s.dt);
        cases.retain(|c| c.steps >= full);
    }
    cases
}

fn prepare_each(tracks: &[Track], s: &Settings) -> Vec<Case> {
    match s.protocol {
        Protocol::Windows => {
            let mut out = Vec::new();
            for t in tracks {
                windows::windows_of(t, s, &mut out);
            }
            out
        }
        Protocol::Tracklets => {
            let mut out = Vec::new();
            for t in tracks {
                tracklets::tracklets_of(t, s, &mut out);
            }
            out
        }
        _ => tracks.iter().filter_map(|t| prepare(t, s)).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracks::Row;
    use glam::DVec2;

    fn track(n: usize, dt: f64, v: f64) -> Track {
        Track {
            id: 1,
            rows: (0..n)
                .map(|i| Row {
                    t: i as f64 * dt,
                    position: DVec2::new(i as f64 * dt * v, 0.0),
                    speed: v,
                    angle: 0.0,
                })
                .collect(),
        }
    }

    #[test]
    fn reference_start_and_horizon() {
        let t = track(40, 0.4, 1.0); // 15.6 s of track
        let c = prepare(&t, &Settings::default()).unwrap();
        assert_eq!(c.observed.len(), 8);
        assert_eq!(c.start.time, 8.0 * 0.4);
        assert!((c.start.speed - 1.0).abs() < 1e-12);
        // t_last - t0 = 12.4 -> floor 12 -> 30 steps
        assert_eq!((c.horizon, c.steps), (12.0, 30));
        assert!((c.truth_at(c.start.time + 1.0).unwrap().x - (c.start.time + 1.0)).abs() < 1e-12);
    }

    #[test]
    fn reference_filters_short_and_idle_people() {
        let s = Settings::default();
        assert!(prepare(&track(9, 0.4, 1.0), &s).is_none());
        // 10 rows have 0.4 s after row 8, but 9 * 0.4 - 8 * 0.4 < 0.4 in floating point
        // (as in the reference): 11 rows pass
        assert!(prepare(&track(10, 0.4, 1.0), &s).is_none());
        assert!(prepare(&track(11, 0.4, 1.0), &s).is_some());
        // 10 rows of 0.4 s covering 0.9 m: idle
        assert!(prepare(&track(30, 0.4, 0.9 / 4.0), &s).is_none());
        assert!(prepare(&track(30, 0.4, 1.1 / 4.0), &s).is_some());
    }

    #[test]
    fn reference_idle_filter_counts_rows_at_any_rate() {
        // At 1 Hz the published code still compares rows 10 apart (10 s), not 4 s.
        let s = Settings {
            obs: 8.0,
            dt: 1.0,
            horizon: 50.0,
            ..Settings::default()
        };
        // 0.15 m/s: 0.6 m in 4 s (idle by a 4 s window), 1.5 m in 10 rows (moving)
        assert!(prepare(&track(30, 1.0, 0.15), &s).is_some());
        // 0.09 m/s: 0.9 m in 10 rows: idle
        assert!(prepare(&track(30, 1.0, 0.09), &s).is_none());
        // the seconds protocol keeps its 4 s window
        let secs = Settings {
            protocol: Protocol::Seconds,
            ..s
        };
        assert!(prepare(&track(30, 1.0, 0.15), &secs).is_none());
    }

    #[test]
    fn seconds_protocol_at_one_hertz() {
        let s = Settings {
            protocol: Protocol::Seconds,
            obs: 3.2,
            dt: 1.0,
            horizon: 50.0,
            ..Settings::default()
        };
        let c = prepare(&track(20, 1.0, 1.0), &s).unwrap();
        // first row at or after 3.2 s is t = 4
        assert_eq!(c.start.time, 4.0);
        assert_eq!((c.horizon, c.steps), (15.0, 15));
        assert!((c.start.speed - 1.0).abs() < 1e-12 && c.start.heading.abs() < 1e-12);
        let idle = prepare(&track(20, 1.0, 0.2), &s);
        assert!(idle.is_none());
    }
}

#[cfg(test)]
mod shipped {
    use super::*;
    use crate::tracks::{Format, read_tracks};

    #[test]
    fn reference_filter_passes_the_published_counts() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data");
        for (f, n) in [("thor1/exp-1-run-2.csv", 62), ("thor3/exp-3-run-2.csv", 90)] {
            let tracks = read_tracks(&std::path::Path::new(dir).join(f), Format::Thor).unwrap();
            let passed = tracks
                .iter()
                .filter_map(|t| prepare(t, &Settings::default()))
                .count();
            assert_eq!(passed, n, "{f}");
        }
    }
}
