//! The track keeper: per tracked person a bounded history of stamped positions in the
//! map frame, forgotten after a timeout, at most a set number of tracks; every input
//! that cannot be used is counted by kind ([`Skip`]) and never stops the node.
//!
//! Plain Rust, no ROS: the node feeds it decoded messages; tests feed it directly.

use std::time::{Duration, Instant};

use cliff_client::protocol::MAX_HISTORY;

/// A static transform from a tracker's frame into the map frame: a position `p` in
/// `frame` is `R(yaw) p + (x, y)` in the map frame.
#[derive(Debug, Clone, PartialEq)]
pub struct StaticTransform {
    /// The source frame id.
    pub frame: String,
    /// Translation x (m).
    pub x: f64,
    /// Translation y (m).
    pub y: f64,
    /// Rotation about z (rad).
    pub yaw: f64,
}

impl StaticTransform {
    fn apply(&self, x: f64, y: f64) -> (f64, f64) {
        let (s, c) = self.yaw.sin_cos();
        (c * x - s * y + self.x, s * x + c * y + self.y)
    }
}

/// How the keeper bounds and checks its input.
#[derive(Debug, Clone, PartialEq)]
pub struct KeeperSettings {
    /// The map's frame id: input in another frame needs a [`StaticTransform`].
    pub frame_id: String,
    /// Transforms of other frames into `frame_id`.
    pub transforms: Vec<StaticTransform>,
    /// Observations kept per track (at most the daemon's limit, [`MAX_HISTORY`]).
    pub history: usize,
    /// Only observations at most this many seconds older than the track's newest are
    /// predicted from (0: all that are kept).
    pub history_seconds: f64,
    /// A track not updated for this many seconds (of stamps, or of wall clock when no
    /// input comes at all) is forgotten.
    pub timeout: f64,
    /// At most this many tracks; a new id beyond it is skipped ([`Skip::TooManyTracks`]).
    pub max_tracks: usize,
}

impl Default for KeeperSettings {
    fn default() -> Self {
        KeeperSettings {
            frame_id: "map".into(),
            transforms: Vec::new(),
            history: MAX_HISTORY as usize,
            history_seconds: 3.2,
            timeout: 2.0,
            max_tracks: 64,
        }
    }
}

/// Why (part of) an input was not used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Skip {
    /// The message's frame is neither the map's nor one with a transform.
    WrongFrame,
    /// A position or the stamp is NaN or infinite.
    NonFinite,
    /// An observation not newer than the track's newest.
    TimeBackwards,
    /// The stamps jumped back by more than the timeout (a bag looped, a simulation
    /// restarted): every track was forgotten, the message then used.
    ClockJumpedBack,
    /// A new id while the keeper already holds its maximum of tracks.
    TooManyTracks,
    /// A person without an id.
    EmptyId,
    /// The same id twice in one message (the second is skipped).
    DuplicateId,
    /// A message that could not be decoded (counted by the node).
    Malformed,
}

impl Skip {
    /// Every kind, in the order of [`Skip::index`].
    pub const ALL: [Skip; 8] = [
        Skip::WrongFrame,
        Skip::NonFinite,
        Skip::TimeBackwards,
        Skip::ClockJumpedBack,
        Skip::TooManyTracks,
        Skip::EmptyId,
        Skip::DuplicateId,
        Skip::Malformed,
    ];

    /// Position in [`Skip::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// A short name for logs.
    pub fn name(self) -> &'static str {
        match self {
            Skip::WrongFrame => "wrong frame",
            Skip::NonFinite => "non-finite position or stamp",
            Skip::TimeBackwards => "time going backwards",
            Skip::ClockJumpedBack => "clock jumped back (tracks reset)",
            Skip::TooManyTracks => "too many tracks",
            Skip::EmptyId => "empty id",
            Skip::DuplicateId => "duplicate id in one message",
            Skip::Malformed => "malformed message",
        }
    }
}

/// One stamped position in the map frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Obs {
    /// Stamp (s).
    pub t: f64,
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
}

/// A tracked person.
#[derive(Debug, Clone)]
pub struct Track {
    /// The tracker's id.
    pub id: String,
    /// A small number that stays the track's for its life (marker ids).
    pub number: u32,
    /// Ring buffer of observations (oldest at `head`).
    ring: Vec<Obs>,
    cap: usize,
    head: usize,
    len: usize,
    /// Wall clock of the last update.
    updated: Instant,
    /// Seen in the message being applied (duplicate check).
    seen_in: u64,
}

impl Track {
    fn new(id: &str, number: u32, capacity: usize, now: Instant) -> Self {
        Track {
            id: id.to_owned(),
            number,
            ring: Vec::with_capacity(capacity),
            cap: capacity,
            head: 0,
            len: 0,
            updated: now,
            seen_in: 0,
        }
    }

    /// Observations held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// No observation held.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Observation `i`, oldest first.
    pub fn get(&self, i: usize) -> Obs {
        self.ring[(self.head + i) % self.cap]
    }

    /// The newest observation.
    pub fn last(&self) -> Option<Obs> {
        (self.len > 0).then(|| self.get(self.len - 1))
    }

    /// The observations oldest first.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = Obs> + '_ {
        (0..self.len).map(move |i| self.get(i))
    }

    /// The observations a prediction uses: the newest ones within `seconds` of the
    /// newest (all when `seconds` is 0), oldest first.
    pub fn window(&self, seconds: f64) -> impl ExactSizeIterator<Item = Obs> + '_ {
        let first = match self.last() {
            Some(last) if seconds > 0.0 => {
                // a millisecond of slack: 0.4 s steps stamped 0.41 s apart stay in
                let from = last.t - seconds - 1e-3;
                (0..self.len)
                    .find(|&i| self.get(i).t >= from)
                    .unwrap_or(self.len)
            }
            _ => 0,
        };
        (first..self.len).map(move |i| self.get(i))
    }

    fn push(&mut self, o: Obs) {
        let cap = self.cap;
        if self.ring.len() < cap {
            self.ring.push(o);
            self.len += 1;
        } else if self.len < cap {
            let i = (self.head + self.len) % cap;
            self.ring[i] = o;
            self.len += 1;
        } else {
            self.ring[self.head] = o;
            self.head = (self.head + 1) % cap;
        }
    }
}

/// What applying one message did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Applied {
    /// Observations added.
    pub added: usize,
    /// Tracks created.
    pub created: usize,
    /// Observations (or whole messages) skipped.
    pub skipped: usize,
}

/// The tracks and the counts of skipped input.
#[derive(Debug)]
pub struct Keeper {
    settings: KeeperSettings,
    tracks: Vec<Track>,
    /// Newest stamp seen (s); NaN before the first message.
    newest: f64,
    /// Wall clock of the last message.
    last_input: Option<Instant>,
    counts: [u64; Skip::ALL.len()],
    next_number: u32,
    message: u64,
    ended: Vec<u32>,
}

impl Keeper {
    /// A keeper with `settings` (the history clamped to `1..=MAX_HISTORY`).
    pub fn new(mut settings: KeeperSettings) -> Self {
        settings.history = settings.history.clamp(1, MAX_HISTORY as usize);
        Keeper {
            tracks: Vec::with_capacity(settings.max_tracks),
            settings,
            newest: f64::NAN,
            last_input: None,
            counts: [0; Skip::ALL.len()],
            next_number: 0,
            message: 0,
            ended: Vec::new(),
        }
    }

    /// The settings.
    pub fn settings(&self) -> &KeeperSettings {
        &self.settings
    }

    /// The tracks, in the order they were first seen.
    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    /// Newest stamp seen (NaN before any).
    pub fn newest(&self) -> f64 {
        self.newest
    }

    /// How often input of this kind was skipped.
    pub fn count(&self, kind: Skip) -> u64 {
        self.counts[kind.index()]
    }

    /// Count a skip the keeper did not see (a malformed message).
    pub fn count_skip(&mut self, kind: Skip) {
        self.counts[kind.index()] += 1;
    }

    /// Numbers of the tracks forgotten since the last call (their markers are deleted).
    pub fn take_ended(&mut self, out: &mut Vec<u32>) {
        out.clear();
        out.append(&mut self.ended);
    }

    /// Apply one message: `frame` and `stamp` from its header, `people` its
    /// `(id, x, y)`. `skip` is told each skip (for rate-limited warnings).
    pub fn apply<'a>(
        &mut self,
        frame: &str,
        stamp: f64,
        people: impl IntoIterator<Item = (&'a str, f64, f64)>,
        now: Instant,
        mut skip: impl FnMut(Skip),
    ) -> Applied {
        let mut out = Applied::default();
        let mut note = |counts: &mut [u64; 8], out: &mut Applied, k: Skip| {
            counts[k.index()] += 1;
            out.skipped += 1;
            skip(k);
        };
        let transform = if frame == self.settings.frame_id
            || (frame.is_empty() && self.settings.frame_id.is_empty())
        {
            None
        } else {
            match self
                .settings
                .transforms
                .iter()
                .position(|t| t.frame == frame)
            {
                Some(i) => Some(i),
                None => {
                    note(&mut self.counts, &mut out, Skip::WrongFrame);
                    return out;
                }
            }
        };
        if !stamp.is_finite() {
            note(&mut self.counts, &mut out, Skip::NonFinite);
            return out;
        }
        if stamp < self.newest - self.settings.timeout {
            note(&mut self.counts, &mut out, Skip::ClockJumpedBack);
            self.forget_all();
        }
        if self.newest.is_nan() || stamp > self.newest {
            self.newest = stamp;
        }
        self.last_input = Some(now);
        self.message += 1;
        let msg = self.message;
        for (id, x, y) in people {
            if id.is_empty() {
                note(&mut self.counts, &mut out, Skip::EmptyId);
                continue;
            }
            if !(x.is_finite() && y.is_finite()) {
                note(&mut self.counts, &mut out, Skip::NonFinite);
                continue;
            }
            let (x, y) = match transform {
                Some(i) => self.settings.transforms[i].apply(x, y),
                None => (x, y),
            };
            let i = match self.tracks.iter().position(|t| t.id == id) {
                Some(i) => i,
                None => {
                    if self.tracks.len() >= self.settings.max_tracks {
                        note(&mut self.counts, &mut out, Skip::TooManyTracks);
                        continue;
                    }
                    let number = self.next_number;
                    self.next_number = self.next_number.wrapping_add(1);
                    self.tracks
                        .push(Track::new(id, number, self.settings.history, now));
                    out.created += 1;
                    self.tracks.len() - 1
                }
            };
            let t = &mut self.tracks[i];
            if t.seen_in == msg {
                note(&mut self.counts, &mut out, Skip::DuplicateId);
                continue;
            }
            t.seen_in = msg;
            if t.last().is_some_and(|last| stamp <= last.t) {
                note(&mut self.counts, &mut out, Skip::TimeBackwards);
                continue;
            }
            t.push(Obs { t: stamp, x, y });
            t.updated = now;
            out.added += 1;
        }
        out
    }

    /// Forget tracks whose newest observation is more than the timeout older than the
    /// newest stamp seen, or that were not updated for the timeout of wall clock.
    /// Returns how many were forgotten.
    pub fn expire(&mut self, now: Instant) -> usize {
        let timeout = self.settings.timeout;
        let wall = Duration::try_from_secs_f64(timeout).unwrap_or(Duration::MAX);
        let newest = self.newest;
        let before = self.tracks.len();
        let ended = &mut self.ended;
        self.tracks.retain(|t| {
            let stale = t.last().is_none_or(|o| o.t < newest - timeout)
                || now.saturating_duration_since(t.updated) > wall;
            if stale {
                ended.push(t.number);
            }
            !stale
        });
        before - self.tracks.len()
    }

    fn forget_all(&mut self) {
        for t in self.tracks.drain(..) {
            self.ended.push(t.number);
        }
        self.newest = f64::NAN;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keeper(history: usize) -> Keeper {
        Keeper::new(KeeperSettings {
            history,
            ..KeeperSettings::default()
        })
    }

    fn ids(k: &Keeper) -> Vec<&str> {
        k.tracks().iter().map(|t| t.id.as_str()).collect()
    }

    #[test]
    fn history_is_bounded_and_oldest_first() {
        let mut k = keeper(3);
        let now = Instant::now();
        for i in 0..5 {
            let a = k.apply("map", i as f64 * 0.4, [("a", i as f64, 0.0)], now, |_| {});
            assert_eq!(a.added, 1);
        }
        let t = &k.tracks()[0];
        assert_eq!(t.len(), 3);
        let xs: Vec<f64> = t.iter().map(|o| o.x).collect();
        assert_eq!(xs, [2.0, 3.0, 4.0]);
        assert_eq!(t.last().unwrap().x, 4.0);
        // the window keeps what is within the seconds of the newest
        let w: Vec<f64> = t.window(0.4).map(|o| o.x).collect();
        assert_eq!(w, [3.0, 4.0]);
        assert_eq!(t.window(0.0).len(), 3);
        // the history is clamped to the daemon's limit
        let k = keeper(1000);
        assert_eq!(k.settings().history, MAX_HISTORY as usize);
    }

    #[test]
    fn stale_tracks_are_forgotten_by_stamp_and_by_wall_clock() {
        let mut k = keeper(8);
        let now = Instant::now();
        k.apply("map", 0.0, [("a", 0.0, 0.0), ("b", 1.0, 0.0)], now, |_| {});
        k.apply("map", 1.0, [("a", 0.1, 0.0)], now, |_| {});
        assert_eq!(k.expire(now), 0);
        k.apply("map", 2.5, [("a", 0.2, 0.0)], now, |_| {});
        // b last seen at 0.0, newest 2.5, timeout 2
        assert_eq!(k.expire(now), 1);
        assert_eq!(ids(&k), ["a"]);
        let mut ended = Vec::new();
        k.take_ended(&mut ended);
        assert_eq!(ended, [1]);
        // no input at all: the wall clock forgets
        assert_eq!(k.expire(now + Duration::from_secs(1)), 0);
        assert_eq!(k.expire(now + Duration::from_secs(3)), 1);
        assert!(k.tracks().is_empty());
    }

    #[test]
    fn bad_input_is_counted_and_skipped() {
        let mut k = Keeper::new(KeeperSettings {
            max_tracks: 2,
            ..KeeperSettings::default()
        });
        let now = Instant::now();
        let mut told = Vec::new();
        let a = k.apply(
            "map",
            1.0,
            [
                ("a", 0.0, 0.0),
                ("", 1.0, 1.0),
                ("b", f64::NAN, 0.0),
                ("a", 5.0, 5.0),
                ("c", 0.0, 1.0),
                ("d", 0.0, 2.0),
            ],
            now,
            |s| told.push(s),
        );
        assert_eq!((a.added, a.created, a.skipped), (2, 2, 4));
        assert_eq!(
            told,
            [
                Skip::EmptyId,
                Skip::NonFinite,
                Skip::DuplicateId,
                Skip::TooManyTracks
            ]
        );
        assert_eq!(ids(&k), ["a", "c"]);
        // the same stamp again, and an older one within the timeout: time going backwards
        k.apply("map", 1.0, [("a", 0.0, 0.0)], now, |_| {});
        k.apply("map", 0.5, [("a", 0.0, 0.0)], now, |_| {});
        assert_eq!(k.count(Skip::TimeBackwards), 2);
        assert_eq!(k.tracks()[0].len(), 1);
        // a NaN stamp and a foreign frame skip the whole message
        assert_eq!(
            k.apply("map", f64::NAN, [("a", 0.0, 0.0)], now, |_| {})
                .skipped,
            1
        );
        assert_eq!(
            k.apply("odom", 2.0, [("a", 0.0, 0.0)], now, |_| {}).skipped,
            1
        );
        assert_eq!(k.count(Skip::WrongFrame), 1);
        assert_eq!(k.count(Skip::NonFinite), 2);
        // a jump back by more than the timeout resets the tracks and then applies
        let a = k.apply("map", -100.0, [("z", 0.0, 0.0)], now, |_| {});
        assert_eq!(k.count(Skip::ClockJumpedBack), 1);
        assert_eq!((a.added, a.created), (1, 1));
        assert_eq!(ids(&k), ["z"]);
        assert_eq!(k.newest(), -100.0);
        // a flood of ids never grows past the cap
        let names: Vec<String> = (0..1000).map(|i| format!("p{i}")).collect();
        k.apply(
            "map",
            -99.0,
            names.iter().map(|n| (n.as_str(), 0.0, 0.0)),
            now,
            |_| {},
        );
        assert_eq!(k.tracks().len(), 2);
        assert_eq!(k.count(Skip::TooManyTracks), 1 + 999);
    }

    #[test]
    fn a_configured_static_transform_maps_a_foreign_frame() {
        let mut k = Keeper::new(KeeperSettings {
            transforms: vec![StaticTransform {
                frame: "odom".into(),
                x: 1.0,
                y: 2.0,
                yaw: std::f64::consts::FRAC_PI_2,
            }],
            ..KeeperSettings::default()
        });
        let now = Instant::now();
        k.apply("odom", 0.0, [("a", 1.0, 0.0)], now, |_| {});
        let o = k.tracks()[0].last().unwrap();
        assert!(
            (o.x - 1.0).abs() < 1e-12 && (o.y - 3.0).abs() < 1e-12,
            "{o:?}"
        );
        assert_eq!(k.count(Skip::WrongFrame), 0);
    }
}
