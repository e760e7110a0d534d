//! What the node sees, sent to a daemon that learns its map (parameter `observe`,
//! `cliffd --learn NAME`): each track's rows once, under the track's number, and the
//! track's end once the keeper forgets it.
//!
//! Rows the daemon did not take (it was away, or over this client's budget) are sent
//! again at the next cycle, as long as the track still holds them; the daemon counts a
//! row once per client, track and time, so sending one again costs nothing but the
//! bytes. A track's end is its newest row taken, sent again with the end flag (the daemon
//! then learns the track at once instead of waiting for it to go quiet). Requests hold
//! at most as many rows as the daemon takes in one (`cliffd --max-observe-rows`, learned
//! from its answer) and at most half of what its rows-per-second budget lets through, so
//! that a node that was cut off from the daemon catches up in several calls.

use cliff_client::protocol::{Field, MAX_OBSERVE_ROWS, ObserveReply, Status};
use cliff_client::{Observation, ObserveRequest};

use crate::predictor::{ObserveError, Predictor};
use crate::tracks::{Keeper, Obs};

/// Where the observer's requests go: the daemon of a [`Predictor`] (its connection), or a
/// stand-in in tests.
pub trait Sink {
    /// Send one observe request.
    fn observe(&mut self, request: &ObserveRequest) -> Result<ObserveReply, ObserveError>;
}

impl Sink for Predictor {
    fn observe(&mut self, request: &ObserveRequest) -> Result<ObserveReply, ObserveError> {
        Predictor::observe(self, request)
    }
}

/// What the observer sent and what the daemon made of it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ObserveStats {
    /// Rows the daemon took (new to it).
    pub rows: u64,
    /// Rows the daemon had already (each track end sends one of these).
    pub duplicates: u64,
    /// Track ends delivered.
    pub ends: u64,
    /// Calls the daemon turned down for its budget (sent again later).
    pub over_budget: u64,
    /// Calls the daemon turned down with a status other than over budget (`not-allowed`,
    /// `not-learning`, ...; the last one is [`Observer::last_refusal`]) or that could not
    /// be sent: the rows are sent again at the next cycle.
    pub refused: u64,
    /// Calls that failed otherwise (daemon away, too many rows at once).
    pub failed: u64,
    /// Track ends given up on (more tracks ended while the daemon was away than are kept).
    pub ends_dropped: u64,
}

/// Sends each cycle's new rows and ended tracks through a [`Sink`] (the daemon).
pub struct Observer {
    request: ObserveRequest,
    /// The newest row the daemon took of each track it has rows of, by track number
    /// (sorted by number).
    sent: Vec<(u32, Obs)>,
    /// Tracks forgotten whose end the daemon has not taken yet, with their newest row.
    ending: Vec<(u32, Obs)>,
    /// The tracks of the request being built: number and newest row added.
    batch: Vec<(u32, Obs)>,
    /// How many of `ending` the request being built carries.
    batch_ends: usize,
    max_ending: usize,
    /// Rows per request (the protocol's limit until the daemon says less).
    max_rows: usize,
    stats: ObserveStats,
    last_refusal: Option<Status>,
}

impl Observer {
    /// An observer of the map named `map` at the daemon, for at most `max_tracks` tracks.
    pub fn new(map: &str, max_tracks: usize) -> anyhow::Result<Observer> {
        let request =
            ObserveRequest::new(map).map_err(|e| anyhow::anyhow!("daemon_map '{map}': {e}"))?;
        Ok(Observer {
            request,
            sent: Vec::with_capacity(max_tracks),
            ending: Vec::with_capacity(max_tracks),
            batch: Vec::with_capacity(max_tracks),
            batch_ends: 0,
            max_ending: max_tracks.max(1),
            max_rows: MAX_OBSERVE_ROWS as usize,
            stats: ObserveStats::default(),
            last_refusal: None,
        })
    }

    /// The counters.
    pub fn stats(&self) -> ObserveStats {
        self.stats
    }

    /// The status of the last call the daemon turned down (not for over budget or too
    /// many rows, which the observer adapts to), if any.
    pub fn last_refusal(&self) -> Option<Status> {
        self.last_refusal
    }

    /// Rows per request now (lowered by the daemon's answers).
    pub fn max_rows(&self) -> usize {
        self.max_rows
    }

    /// Track ends waiting to be delivered.
    pub fn pending_ends(&self) -> usize {
        self.ending.len()
    }

    /// The tracks numbered `ended` were forgotten: their ends go with the next send.
    pub fn ended(&mut self, ended: &[u32]) {
        for &n in ended {
            if let Ok(i) = self.sent.binary_search_by_key(&n, |e| e.0) {
                let e = self.sent.remove(i);
                if self.ending.len() >= self.max_ending {
                    self.ending.remove(0);
                    self.stats.ends_dropped += 1;
                }
                self.ending.push(e);
            }
        }
    }

    /// Send the pending ends and every track's rows the daemon has not taken, in calls
    /// of at most [`Observer::max_rows`] rows (a track's rows split over calls when they
    /// do not fit, oldest first). Stops at the first call that fails (what is left waits
    /// for the next cycle) and returns its error; an answer that names a smaller limit
    /// (rows per request, rows per second) lowers the rows per request first.
    pub fn send(&mut self, keeper: &Keeper, sink: &mut impl Sink) -> Result<(), ObserveError> {
        self.start_batch();
        while self.batch_ends < self.ending.len() {
            if self.request.rows().len() >= self.max_rows {
                self.flush(sink)?;
            }
            let (n, last) = self.ending[self.batch_ends];
            self.request.add_track(n, [row(last)]);
            self.request.end_track();
            self.batch_ends += 1;
        }
        for t in keeper.tracks() {
            let after = match self.sent.binary_search_by_key(&t.number, |e| e.0) {
                Ok(i) => self.sent[i].1.t,
                Err(_) => f64::NEG_INFINITY,
            };
            let mut rows = t.iter().filter(|o| o.t > after).peekable();
            while rows.peek().is_some() {
                let room = self.max_rows.saturating_sub(self.request.rows().len());
                if room == 0 {
                    self.flush(sink)?;
                    continue;
                }
                let mut newest = None;
                self.request.add_track(
                    t.number,
                    rows.by_ref()
                        .take(room)
                        .inspect(|&o| newest = Some(o))
                        .map(row),
                );
                let newest = newest.expect("at least one row was added");
                self.batch.push((t.number, newest));
            }
        }
        if !self.request.rows().is_empty() {
            self.flush(sink)?;
        }
        Ok(())
    }

    fn start_batch(&mut self) {
        self.request.clear();
        self.batch.clear();
        self.batch_ends = 0;
    }

    /// Send the request built; on success the daemon has its rows and ends, and a new
    /// request is started.
    fn flush(&mut self, sink: &mut impl Sink) -> Result<(), ObserveError> {
        match sink.observe(&self.request) {
            Ok(reply) => {
                self.stats.rows += reply.accepted as u64;
                self.stats.duplicates += reply.duplicates as u64;
                self.stats.ends += self.batch_ends as u64;
                self.ending.drain(..self.batch_ends);
                for &(n, newest) in &self.batch {
                    match self.sent.binary_search_by_key(&n, |e| e.0) {
                        Ok(i) => self.sent[i].1 = newest,
                        Err(i) => self.sent.insert(i, (n, newest)),
                    }
                }
                self.start_batch();
                Ok(())
            }
            Err(e) => {
                match &e {
                    ObserveError::OverBudget(r) => {
                        self.stats.over_budget += 1;
                        if r.field == Field::Rows && r.limit > 0 {
                            // at most half of what the budget lets through in a second
                            self.lower_max_rows(r.limit as usize / 2);
                        }
                    }
                    ObserveError::TooManyRows(limit) => {
                        self.stats.failed += 1;
                        self.lower_max_rows(*limit as usize);
                    }
                    ObserveError::Rejected(r) => {
                        self.stats.refused += 1;
                        self.last_refusal = Some(r.status);
                    }
                    ObserveError::Refused(_) => self.stats.refused += 1,
                    ObserveError::Unavailable(_) => self.stats.failed += 1,
                }
                Err(e)
            }
        }
    }

    fn lower_max_rows(&mut self, to: usize) {
        self.max_rows = self.max_rows.min(to.max(1));
    }
}

fn row(o: Obs) -> Observation {
    Observation::position(o.t, o.x, o.y)
}

#[cfg(test)]
mod tests {
    use std::collections::{BTreeMap, HashMap};
    use std::path::Path;
    use std::time::Instant;

    use cliff::tracks::{Format, read_tracks};
    use cliff_client::protocol::{FLAG_TRACK_END, Rejection, Status};

    use super::*;
    use crate::tracks::KeeperSettings;

    /// A daemon as the observer sees it, written from the protocol's rules: per track
    /// number the newest time taken (a row at or before it is a duplicate), the rows
    /// taken, and the ends; at most `limit` rows per request; and a schedule of failures.
    #[derive(Default)]
    struct Daemon {
        calls: usize,
        limit: usize,
        /// Call numbers answered as if the daemon were away, and over budget (rows, 300).
        away: Vec<usize>,
        over: Vec<usize>,
        newest: HashMap<u32, f64>,
        taken: Vec<(u32, f64, f64, f64)>,
        /// Per number: the times of its end flags, and the newest row taken then.
        ends: HashMap<u32, Vec<f64>>,
        most_rows: usize,
        too_many: usize,
    }

    impl Sink for Daemon {
        fn observe(&mut self, request: &ObserveRequest) -> Result<ObserveReply, ObserveError> {
            self.calls += 1;
            if self.away.contains(&self.calls) {
                return Err(ObserveError::Unavailable("stopped".into()));
            }
            if self.over.contains(&self.calls) {
                return Err(ObserveError::OverBudget(Rejection {
                    status: Status::OverBudget,
                    agent: None,
                    row: None,
                    field: Field::Rows,
                    limit: 300,
                }));
            }
            let rows = request.rows();
            if rows.len() > self.limit {
                self.too_many += 1;
                return Err(ObserveError::TooManyRows(self.limit as u32));
            }
            self.most_rows = self.most_rows.max(rows.len());
            let mut reply = ObserveReply::default();
            for (i, o) in rows.iter().enumerate() {
                if i > 0 && rows[i - 1].agent == o.agent {
                    assert!(o.t > rows[i - 1].t, "times within a track's run increase");
                }
                let newest = self.newest.entry(o.agent).or_insert(f64::NEG_INFINITY);
                if o.t <= *newest {
                    reply.duplicates += 1;
                } else {
                    *newest = o.t;
                    reply.accepted += 1;
                    self.taken.push((o.agent, o.t, o.x, o.y));
                }
                if o.flags & FLAG_TRACK_END != 0 {
                    self.ends.entry(o.agent).or_default().push(*newest);
                }
            }
            Ok(reply)
        }
    }

    /// One tracker message: its stamp and every person seen then (id, x, y).
    type Frame = (f64, Vec<(String, f64, f64)>);

    /// THÖR1 round 2 as a tracker would publish it: one message per time stamp.
    fn frames() -> Vec<Frame> {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/thor1/exp-1-run-2.csv");
        let tracks = read_tracks(&path, Format::Thor).expect("THÖR1 round 2");
        let mut by_t: BTreeMap<u64, Vec<(String, f64, f64)>> = BTreeMap::new();
        for t in &tracks {
            for r in &t.rows {
                by_t.entry(r.t.to_bits()).or_default().push((
                    t.id.to_string(),
                    r.position.x,
                    r.position.y,
                ));
            }
        }
        by_t.into_iter()
            .map(|(t, p)| (f64::from_bits(t), p))
            .collect()
    }

    #[test]
    fn every_row_reaches_the_daemon_once_and_every_ended_track_its_end_despite_failures() {
        let frames = frames();
        assert!(frames.len() > 500, "{} frames", frames.len());
        let mut keeper = Keeper::new(KeeperSettings::default());
        let mut observer = Observer::new("thor1", 64).unwrap();
        // the daemon takes at most 8 rows per request, is away for calls 5 to 8 (1.6 s of
        // the recording: shorter than the track timeout, so no track ends unsent), over
        // budget at calls 30 and 31 (then requests hold at most 150 rows: more than 8)
        let mut daemon = Daemon {
            limit: 8,
            away: (5..9).collect(),
            over: vec![30, 31],
            ..Daemon::default()
        };
        let now = Instant::now();
        let mut fed: Vec<(String, f64, f64, f64)> = Vec::new();
        let mut ended = Vec::new();
        let mut numbers: HashMap<u32, String> = HashMap::new();
        let mut send = |keeper: &mut Keeper, observer: &mut Observer, daemon: &mut Daemon| {
            keeper.expire(now);
            keeper.take_ended(&mut ended);
            observer.ended(&ended);
            for t in keeper.tracks() {
                numbers.entry(t.number).or_insert_with(|| t.id.clone());
            }
            let _ = observer.send(keeper, daemon);
        };
        for (t, people) in &frames {
            let applied = keeper.apply(
                "map",
                *t,
                people.iter().map(|(id, x, y)| (id.as_str(), *x, *y)),
                now,
                |_| {},
            );
            assert_eq!(applied.skipped, 0, "a clean recording: nothing skipped");
            fed.extend(people.iter().map(|(id, x, y)| (id.clone(), *t, *x, *y)));
            send(&mut keeper, &mut observer, &mut daemon);
        }
        // the tracker goes quiet: an empty message well past the timeout ends every track
        let last = frames.last().unwrap().0;
        keeper.apply(
            "map",
            last + 10.0,
            std::iter::empty::<(&str, f64, f64)>(),
            now,
            |_| {},
        );
        send(&mut keeper, &mut observer, &mut daemon);
        assert!(keeper.tracks().is_empty());
        assert_eq!(observer.pending_ends(), 0);

        // every row fed was taken exactly once, under a number that is one person's
        let mut want: Vec<(String, u64, u64, u64)> = fed
            .iter()
            .map(|(id, t, x, y)| (id.clone(), t.to_bits(), x.to_bits(), y.to_bits()))
            .collect();
        let mut got: Vec<(String, u64, u64, u64)> = daemon
            .taken
            .iter()
            .map(|(n, t, x, y)| (numbers[n].clone(), t.to_bits(), x.to_bits(), y.to_bits()))
            .collect();
        want.sort();
        got.sort();
        assert_eq!(got.len(), want.len());
        assert!(got == want, "the rows taken are the rows fed");
        // every track the daemon has rows of got exactly one end, after its newest row
        for (n, newest) in &daemon.newest {
            let ends = daemon.ends.get(n).map(Vec::as_slice).unwrap_or(&[]);
            assert_eq!(ends, &[*newest], "track {n}: one end, after its newest row");
        }
        let s = observer.stats();
        assert_eq!(s.rows, fed.len() as u64);
        assert_eq!(
            (s.ends, s.duplicates),
            (daemon.newest.len() as u64, daemon.newest.len() as u64)
        );
        assert_eq!((s.over_budget, s.ends_dropped), (2, 0));
        // the four calls while away, and the one call that held more rows than the
        // daemon takes: it said so, and every request after it held at most 8
        assert_eq!((s.failed, daemon.too_many), (5, 1), "{s:?}");
        assert_eq!(observer.max_rows(), 8);
        assert_eq!(daemon.most_rows, 8);
    }

    #[test]
    fn a_track_of_more_rows_than_a_request_holds_is_sent_over_several_oldest_first() {
        let mut keeper = Keeper::new(KeeperSettings::default());
        let now = Instant::now();
        for i in 0..40 {
            keeper.apply("map", i as f64 * 0.1, [("a", i as f64, 0.0)], now, |_| {});
        }
        let mut observer = Observer::new("hall", 4).unwrap();
        let mut daemon = Daemon {
            limit: 16,
            ..Daemon::default()
        };
        assert!(matches!(
            observer.send(&keeper, &mut daemon),
            Err(ObserveError::TooManyRows(16))
        ));
        observer.send(&keeper, &mut daemon).unwrap();
        let xs: Vec<f64> = daemon.taken.iter().map(|r| r.2).collect();
        assert_eq!(xs, (0..40).map(f64::from).collect::<Vec<_>>());
        assert_eq!(daemon.calls, 1 + 3);
        // nothing new: nothing sent
        observer.send(&keeper, &mut daemon).unwrap();
        assert_eq!(daemon.calls, 4);
    }
}
