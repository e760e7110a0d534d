//! Evaluation protocols: which people are evaluated, from which start state, for how long.
//!
//! * [`Protocol::Reference`]: exactly what the published CLiFF-LHMP code does (row based:
//!   observe `n` rows, start at row `n`, horizon floored to whole seconds, 10-row idle
//!   filter). Used for parity on THÖR and comparison with the paper.
//! * [`Protocol::Seconds`]: the same ideas stated in time, for data at any rate.
//! * [`Protocol::Windows`]: the seconds rules applied to windows along long recordings
//!   (see [`super::windows`]); [`prepare_all`] gives every window.
//!
//! See `../shared/docs/evaluation-protocol.md` for the rules.

use std::fmt;
use std::str::FromStr;

use glam::DVec2;

use crate::motion::{DEFAULT_SIGMA, State, velocity_from_speed_angle};
use crate::predict::steps_for;
use crate::tracks::{Row, Track};

/// The two evaluation protocols.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Protocol {
    /// The published implementation's row-based rules.
    Reference,
    /// The same rules stated in seconds (default for new data).
    #[default]
    Seconds,
    /// The seconds rules in a window every [`Settings::window_every`] seconds along each
    /// track (long recordings such as THÖR-MAGNI).
    Windows,
}

impl FromStr for Protocol {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "reference" | "ref" => Ok(Protocol::Reference),
            "seconds" | "time" => Ok(Protocol::Seconds),
            "windows" | "window" => Ok(Protocol::Windows),
            other => Err(format!(
                "unknown protocol '{other}' (expected reference, seconds or windows)"
            )),
        }
    }
}

impl fmt::Display for Protocol {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Protocol::Reference => "reference",
            Protocol::Seconds => "seconds",
            Protocol::Windows => "windows",
        })
    }
}

/// Protocol settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Protocol.
    pub protocol: Protocol,
    /// Observation horizon (s). The reference protocol turns it into rows at `dt`
    /// (3.2 s at 0.4 s = 8 rows).
    pub obs: f64,
    /// Prediction time step (s).
    pub dt: f64,
    /// Longest prediction horizon (s).
    pub horizon: f64,
    /// Velocity kernel width.
    pub sigma: f64,
    /// Idle filter: people moving less than `idle_distance` metres within any
    /// window (`idle_window` seconds; [`REFERENCE_IDLE_ROWS`] rows in the reference
    /// protocol) are skipped.
    pub idle_distance: f64,
    /// Idle filter window (s) of the `seconds` protocol. The reference protocol ignores
    /// it and uses [`REFERENCE_IDLE_ROWS`] rows whatever the rate, as published.
    pub idle_window: f64,
    /// Windows protocol: a new window every this many seconds along a track; 0 (the
    /// default) means back to back, every `obs + horizon` seconds.
    pub window_every: f64,
    /// [`prepare_all`] keeps only the people (or windows) whose ground truth lasts the
    /// whole horizon, so that every horizon is evaluated on the same people.
    pub full_horizon_only: bool,
}

impl Default for Settings {
    /// THÖR settings: reference protocol, 3.2 s observed, dt 0.4 s, 12 s horizon.
    fn default() -> Self {
        Self {
            protocol: Protocol::Reference,
            obs: 3.2,
            dt: 0.4,
            horizon: 12.0,
            sigma: DEFAULT_SIGMA,
            idle_distance: 1.0,
            idle_window: 4.0,
            window_every: 0.0,
            full_horizon_only: false,
        }
    }
}

impl Settings {
    /// Observed rows in the reference protocol: `round(obs / dt)`.
    pub fn obs_rows(&self) -> usize {
        (self.obs / self.dt).round().max(1.0) as usize
    }
}

/// Rows of the reference protocol's idle window: the published code compares row `i`
/// with row `i + 10` whatever the data rate (4 s at 2.5 Hz, 10 s at 1 Hz).
pub const REFERENCE_IDLE_ROWS: usize = 10;

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

    /// The number a prediction's seed is mixed with: the person id, and for a window
    /// also its number (so that every window draws its own samples).
    pub fn seed_key(&self) -> u64 {
        self.id ^ (u64::from(self.window) << 40)
    }
}

/// Position at time `t` by linear interpolation between the rows around it.
fn interpolate(rows: &[Row], t: f64) -> Option<DVec2> {
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

/// Prepare a track for evaluation, or `None` when the protocol skips the person.
pub fn prepare(track: &Track, s: &Settings) -> Option<Case> {
    match s.protocol {
        Protocol::Reference => prepare_reference(track, s),
        Protocol::Seconds => prepare_seconds(track, s),
        Protocol::Windows => super::windows::first_window(track, s),
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
                super::windows::windows_of(t, s, &mut out);
            }
            out
        }
        _ => tracks.iter().filter_map(|t| prepare(t, s)).collect(),
    }
}

fn prepare_reference(track: &Track, s: &Settings) -> Option<Case> {
    let rows = &track.rows;
    let obs = s.obs_rows();
    if rows.len() < obs + 2 {
        return None;
    }
    let last_t = rows[rows.len() - 1].t;
    if last_t - rows[obs].t < s.dt {
        return None;
    }
    let w = REFERENCE_IDLE_ROWS;
    if rows.len() > w
        && rows
            .windows(w + 1)
            .any(|win| win[0].position.distance(win[w].position) < s.idle_distance)
    {
        return None;
    }
    let observed = rows[..obs].to_vec();
    let speeds: Vec<f64> = observed.iter().map(|r| r.speed).collect();
    let angles: Vec<f64> = observed.iter().map(|r| r.angle).collect();
    let v = velocity_from_speed_angle(&speeds, &angles, s.sigma).ok()?;
    let start_row = rows[obs];
    let horizon = (last_t - start_row.t).floor().min(s.horizon).max(0.0);
    // The reference: int(H / dt) with Python float division.
    let steps = (horizon / s.dt) as usize;
    Some(Case {
        id: track.id,
        observed,
        start: State {
            position: start_row.position,
            speed: v.speed,
            heading: v.heading,
            time: start_row.t,
        },
        future: rows[obs..].to_vec(),
        horizon,
        steps,
        window: 0,
    })
}

pub(super) fn prepare_seconds(track: &Track, s: &Settings) -> Option<Case> {
    let rows = &track.rows;
    let first = rows.first()?;
    let last_t = rows.last()?.t;
    // Start at the first row at least `obs` seconds after the first.
    let si = rows.iter().position(|r| r.t >= first.t + s.obs - 1e-6)?;
    let start_row = rows[si];
    if last_t - start_row.t < s.dt {
        return None;
    }
    // Idle: less than idle_distance within any idle_window seconds.
    for r in rows {
        if r.t + s.idle_window > last_t + 1e-9 {
            break;
        }
        if let Some(p) = interpolate(rows, r.t + s.idle_window)
            && p.distance(r.position) < s.idle_distance
        {
            return None;
        }
    }
    // Observed velocity from the speed and angle columns resampled at dt before the start.
    let n = steps_for(s.obs, s.dt).max(1);
    let mut speeds = Vec::with_capacity(n);
    let mut angles = Vec::with_capacity(n);
    for m in (1..=n).rev() {
        let t = start_row.t - m as f64 * s.dt;
        if t < first.t - 1e-9 {
            continue;
        }
        let (sp, an) = resample_velocity(&rows[..=si], t)?;
        speeds.push(sp);
        angles.push(an);
    }
    if speeds.is_empty() {
        return None;
    }
    let v = velocity_from_speed_angle(&speeds, &angles, s.sigma).ok()?;
    let horizon = (last_t - start_row.t).min(s.horizon);
    Some(Case {
        id: track.id,
        observed: rows[..si].to_vec(),
        start: State {
            position: start_row.position,
            speed: v.speed,
            heading: v.heading,
            time: start_row.t,
        },
        future: rows[si..].to_vec(),
        horizon,
        steps: steps_for(horizon, s.dt),
        window: 0,
    })
}

/// Speed (linear) and angle (circular, along the shorter arc) interpolated at `t`.
fn resample_velocity(rows: &[Row], t: f64) -> Option<(f64, f64)> {
    let i = rows.partition_point(|r| r.t < t);
    if i == 0 {
        return rows.first().map(|r| (r.speed, r.angle));
    }
    if i >= rows.len() {
        return rows.last().map(|r| (r.speed, r.angle));
    }
    let (a, b) = (&rows[i - 1], &rows[i]);
    let w = (t - a.t) / (b.t - a.t);
    let u = DVec2::from_angle(a.angle).lerp(DVec2::from_angle(b.angle), w);
    let angle = if u.length_squared() > 1e-24 {
        u.to_angle()
    } else {
        a.angle
    };
    Some((a.speed + w * (b.speed - a.speed), angle))
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn circular_resampling_takes_the_short_arc() {
        let rows = [
            Row {
                t: 0.0,
                position: DVec2::ZERO,
                speed: 1.0,
                angle: 3.0,
            },
            Row {
                t: 1.0,
                position: DVec2::X,
                speed: 2.0,
                angle: -3.0,
            },
        ];
        let (sp, an) = resample_velocity(&rows, 0.5).unwrap();
        assert!((sp - 1.5).abs() < 1e-12);
        assert!((an.abs() - std::f64::consts::PI).abs() < 1e-9, "{an}");
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
