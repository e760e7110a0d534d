//! The protocol and its settings: which rules, how much is observed, the step and the
//! horizon.

use std::fmt;
use std::str::FromStr;

use crate::eval::metrics::Counting;
use crate::motion::DEFAULT_SIGMA;

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
    /// The THÖR-MAGNI benchmark's tracklets: each track's contiguous rows cut back to
    /// back into `obs + horizon` seconds' rows, observed for [`Settings::obs`] and
    /// predicted for [`Settings::horizon`], without an idle filter (see
    /// [`tracklets`](super::tracklets)).
    Tracklets,
}

impl FromStr for Protocol {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "reference" | "ref" => Ok(Protocol::Reference),
            "seconds" | "time" => Ok(Protocol::Seconds),
            "windows" | "window" => Ok(Protocol::Windows),
            "tracklets" | "tracklet" => Ok(Protocol::Tracklets),
            other => Err(format!(
                "unknown protocol '{other}' (expected reference, seconds, windows or tracklets)"
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
            Protocol::Tracklets => "tracklets",
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
    /// Tracklets protocol: a tracklet with a step faster than this (m/s, a tracking
    /// jump) is left out, as the benchmark leaves out tracklets outside its speed
    /// bounds (infinite: every tracklet).
    pub max_speed: f64,
    /// Which samples count at a horizon: every sample, a stopped one where it stopped
    /// ([`Counting::Everyone`], so every method is scored over the same people; the
    /// default), or only those that reached it ([`Counting::Reached`], the published
    /// code's rule, for parity with it).
    pub counting: Counting,
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
            max_speed: f64::INFINITY,
            counting: Counting::Everyone,
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
