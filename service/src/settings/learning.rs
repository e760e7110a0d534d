//! What a learning daemon learns and how: the maps, the per-client [`Budgets`] of
//! observations, the [`Guards`], and the learner's pace ([`LearnSettings`]).

use std::path::PathBuf;
use std::time::Duration;

/// How long a quiet track is kept by default.
pub(crate) const DEFAULT_TRACK_TIMEOUT: Duration = Duration::from_secs(5);

/// Per-client budgets of observations, and how tracks are cut for the learner. Every
/// bound holds per client; the number of clients is bounded too, so the intake's memory
/// is at most about `max_clients x (max_rows_held x 32 + max_tracks x 100)` bytes (32 MiB
/// with the defaults).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Budgets {
    /// New rows per second a client may send (duplicates are not counted); a client may
    /// send one second's worth at once.
    pub rows_per_s: f64,
    /// Open tracks per client.
    pub max_tracks: usize,
    /// Rows a client's open tracks may hold in the daemon, not yet learned.
    pub max_rows_held: usize,
    /// Clients with observations at once.
    pub max_clients: usize,
    /// A track without a new row for this long is finished (and dropped), and so is a
    /// client without tracks.
    pub track_timeout: Duration,
    /// A track's rows go to the learner in segments of this many.
    pub segment_rows: usize,
    /// A finished track shorter than this is not learned.
    pub min_segment_rows: usize,
}

impl Default for Budgets {
    fn default() -> Self {
        Budgets {
            rows_per_s: 2000.0,
            max_tracks: 256,
            max_rows_held: 16384,
            max_clients: 64,
            track_timeout: DEFAULT_TRACK_TIMEOUT,
            segment_rows: 64,
            min_segment_rows: 4,
        }
    }
}

impl Budgets {
    /// The most new rows a client may send at once: one second's worth (a request with
    /// more new rows than that is always over budget: send smaller ones).
    pub fn burst(&self) -> f64 {
        self.rows_per_s
    }

    /// `Err` naming the first setting out of range.
    pub fn check(&self) -> Result<(), String> {
        if !(self.rows_per_s.is_finite() && self.rows_per_s > 0.0) {
            return Err(format!(
                "observe rate {} rows/s must be positive",
                self.rows_per_s
            ));
        }
        for (v, name) in [
            (self.max_tracks, "observe tracks"),
            (self.max_rows_held, "observe rows held"),
            (self.max_clients, "observing clients"),
            (self.segment_rows, "segment rows"),
            (self.min_segment_rows, "minimum segment rows"),
        ] {
            if v == 0 {
                return Err(format!("{name} must be at least 1"));
            }
        }
        if self.min_segment_rows > self.segment_rows {
            return Err(format!(
                "minimum segment rows {} exceed segment rows {}",
                self.min_segment_rows, self.segment_rows
            ));
        }
        Ok(())
    }
}

/// What a daemon learns (`cliffd --learn NAME`) and how.
#[derive(Debug, Clone, PartialEq)]
pub struct LearnSettings {
    /// Names of the served maps that learn from observations (none: the daemon answers
    /// observe requests `not-learning`).
    pub maps: Vec<String>,
    /// Where learned snapshots are kept (`None`: learned versions live in memory only).
    pub dir: Option<PathBuf>,
    /// Per-client budgets.
    pub budgets: Budgets,
    /// Rows per observe request.
    pub max_observe_rows: u32,
    /// A new version is learned once this many rows wait ...
    pub every_rows: usize,
    /// ... or once the oldest waiting row has waited this long.
    pub every: Duration,
    /// How often learned maps are written to `dir` (and at shutdown).
    pub snapshot_every: Duration,
    /// Decay of the map's counts per update ([`cliff::map::update::UpdateParams::decay`];
    /// 1 keeps every row's weight).
    pub decay: f64,
    /// Moving samples the served map's observation ratio 1 stands for (`None`: the
    /// busiest node of the first update, as `cliff map update` does).
    pub count_scale: Option<f64>,
    /// Segments waiting for the learner at most (more are dropped and counted).
    pub queue: usize,
    /// Learned versions kept in memory before the one served, for requests that ask for
    /// a version by number (`NAME@VERSION`); the map as loaded is always kept.
    pub keep_versions: usize,
    /// The guards between observations and the served map.
    pub guards: Guards,
}

impl Default for LearnSettings {
    fn default() -> Self {
        LearnSettings {
            maps: Vec::new(),
            dir: None,
            budgets: Budgets::default(),
            max_observe_rows: 1024,
            every_rows: 20_000,
            every: Duration::from_secs(30),
            snapshot_every: Duration::from_secs(60),
            decay: 1.0,
            count_scale: None,
            queue: 4096,
            keep_versions: 4,
            guards: Guards::default(),
        }
    }
}

impl LearnSettings {
    /// `Err` naming the first setting out of range.
    pub fn check(&self) -> Result<(), String> {
        self.budgets.check()?;
        self.guards.check()?;
        if self.max_observe_rows == 0 {
            return Err("observe rows per request must be at least 1".into());
        }
        if self.every_rows == 0 || self.queue == 0 {
            return Err("learning every 0 rows, or a queue of 0 segments".into());
        }
        if !(self.decay > 0.0 && self.decay <= 1.0) {
            return Err(format!("learning decay {} must be in (0, 1]", self.decay));
        }
        if let Some(s) = self.count_scale
            && !(s.is_finite() && s > 0.0)
        {
            return Err(format!("count scale {s} must be positive"));
        }
        for (i, m) in self.maps.iter().enumerate() {
            if self.maps[..i].contains(m) {
                return Err(format!("map '{m}' is learned twice"));
            }
        }
        Ok(())
    }
}

/// The guards' settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guards {
    /// Rows of one track in one update at most (a longer track is thinned evenly).
    pub track_rows: usize,
    /// One client's rows in one update at most this share of the update (counted as
    /// at least `every_rows` rows, so that a client alone is capped too); 1 turns the cap
    /// off.
    pub client_share: f64,
    /// Rows held out (never learned) to judge new versions; 0 turns the check off.
    pub held_rows: usize,
    /// Every this many segments, one is held out instead of learned.
    pub held_every: usize,
    /// A new version whose mean log-likelihood on the held rows is this much (nats)
    /// below the current version's is not served.
    pub max_score_drop: f64,
    /// Damping: a location's mixture moves at most this far per minute (total-variation
    /// distance, [`cliff::map::movement`]): an update may move it this much times the
    /// minutes since the previous update, counted up to `every`; infinity turns
    /// damping off.
    pub max_move_per_min: f64,
}

impl Default for Guards {
    fn default() -> Self {
        Guards {
            track_rows: 256,
            client_share: 0.5,
            held_rows: 4096,
            held_every: 10,
            max_score_drop: 0.05,
            max_move_per_min: 0.01,
        }
    }
}

impl Guards {
    /// `Err` naming the first setting out of range.
    pub fn check(&self) -> Result<(), String> {
        if self.track_rows == 0 || self.held_every == 0 {
            return Err("track rows per update and held-out spacing must be at least 1".into());
        }
        if !(self.client_share > 0.0 && self.client_share <= 1.0) {
            return Err(format!(
                "client share {} must be in (0, 1]",
                self.client_share
            ));
        }
        if self.max_move_per_min.is_nan() || self.max_move_per_min <= 0.0 {
            return Err(format!(
                "largest move per minute {} must be positive",
                self.max_move_per_min
            ));
        }
        if !(self.max_score_drop.is_finite() && self.max_score_drop >= 0.0) {
            return Err(format!(
                "score drop {} must be finite and not negative",
                self.max_score_drop
            ));
        }
        Ok(())
    }
}
