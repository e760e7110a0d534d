//! Observations in: per-client budgets, deduplication by (client, track, time), open
//! tracks cut into segments for the learner, and the state of quiet clients dropped
//! ([`Intake`]).

use std::collections::HashMap;
use std::time::Instant;

use cliff::map::build::Observation as MapObservation;
use cliff::math::wrap_2pi;
use cliff_client::protocol::{
    FLAG_TRACK_END, FLAG_VELOCITY, Field, Observation, Rejection, Status,
};

use crate::settings::Budgets;

/// Who sent an observation: the iceoryx2 client port's id (or a remote session's).
pub(crate) type ClientKey = u128;

/// A finished (or long enough) piece of one track, for the learner: its rows as map
/// observations with the time of each.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Segment {
    /// The learned map (index of its learning entry).
    pub map: usize,
    /// Who sent it.
    pub client: ClientKey,
    /// The client's track id.
    pub track: u32,
    /// One observation per row (the first row of a track without velocity has none).
    pub observations: Vec<MapObservation>,
    /// The time of each observation (s, the client's clock).
    pub times: Vec<f64>,
}

/// One open track of one client.
#[derive(Debug)]
struct TrackState {
    /// Time of the newest row taken (rows at or before it are duplicates).
    last_t: f64,
    /// Position of the newest row (for the velocity of the next row without one).
    last_xy: [f64; 2],
    /// When the newest row arrived.
    seen: Instant,
    /// The client said the track ended (it no longer counts as open; it is kept until
    /// it goes quiet so that its rows sent again are still duplicates).
    ended: bool,
    /// Rows waiting to go to the learner.
    pending: Vec<MapObservation>,
    times: Vec<f64>,
}

/// One client's budget and tracks.
#[derive(Debug)]
struct ClientState {
    /// Row tokens (refilled at the budget's rate up to its burst).
    tokens: f64,
    refilled: Instant,
    seen: Instant,
    /// Tracks by (map, track id).
    tracks: HashMap<(usize, u32), TrackState>,
    /// Tracks not ended.
    open: usize,
    /// Rows held in `pending` over all tracks.
    held: usize,
    /// The last request taken: its id, map and counts (a request sent again after its
    /// reply was lost is answered with them, see [`Intake::take_request`]).
    last: Option<(u64, usize, Taken)>,
}

/// What the intake counted since the daemon started.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct IntakeStats {
    /// Rows taken.
    pub accepted: u64,
    /// Rows skipped as already seen.
    pub duplicates: u64,
    /// Requests refused for a budget.
    pub over_budget: u64,
    /// Tracks dropped after going quiet.
    pub expired_tracks: u64,
    /// Clients whose state was dropped after going quiet.
    pub expired_clients: u64,
}

/// The observations of every client, before the learner (see the module docs).
#[derive(Debug)]
pub(crate) struct Intake {
    budgets: Budgets,
    clients: HashMap<ClientKey, ClientState>,
    stats: IntakeStats,
}

/// The counts of one accepted request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Taken {
    pub accepted: u32,
    pub duplicates: u32,
}

impl Intake {
    pub fn new(budgets: Budgets) -> Self {
        Intake {
            budgets,
            clients: HashMap::new(),
            stats: IntakeStats::default(),
        }
    }

    pub fn stats(&self) -> IntakeStats {
        self.stats
    }

    /// Clients with state now.
    #[cfg(test)]
    pub fn clients(&self) -> usize {
        self.clients.len()
    }

    /// Open tracks over all clients.
    pub fn tracks(&self) -> usize {
        self.clients.values().map(|c| c.tracks.len()).sum()
    }

    /// [`take`](Self::take) the rows of the request `request` (its id): a request the
    /// client sends again with the id of the last one it had taken (its reply was lost
    /// with the link, and the client retried) takes nothing more and is answered with
    /// the first answer's counts, so that the client's counts add up as if it had been
    /// sent once.
    pub fn take_request(
        &mut self,
        client: ClientKey,
        request: u64,
        map: usize,
        rows: &[Observation],
        now: Instant,
        out: &mut impl FnMut(Segment),
    ) -> Result<Taken, Rejection> {
        if let Some(c) = self.clients.get_mut(&client)
            && let Some((id, m, taken)) = c.last
            && (id, m) == (request, map)
        {
            c.seen = now;
            return Ok(taken);
        }
        let taken = self.take(client, map, rows, now, out)?;
        if let Some(c) = self.clients.get_mut(&client) {
            c.last = Some((request, map, taken));
        }
        Ok(taken)
    }

    /// Take the rows of one validated observe request ([`validate_observe`]) for the
    /// learned map `map`: rows the client's track has already passed are duplicates,
    /// the others are taken, unless they exceed one of the client's budgets (rows per
    /// second, open tracks, rows held), in which case nothing is taken and the rejection
    /// names the budget. Segments that are long enough go to `out`.
    ///
    /// [`validate_observe`]: cliff_client::protocol::validate_observe
    pub fn take(
        &mut self,
        client: ClientKey,
        map: usize,
        rows: &[Observation],
        now: Instant,
        out: &mut impl FnMut(Segment),
    ) -> Result<Taken, Rejection> {
        let b = self.budgets;
        if !self.clients.contains_key(&client) && self.clients.len() >= b.max_clients {
            // make room: the quietest client goes first
            self.expire(now, out);
            if self.clients.len() >= b.max_clients {
                self.stats.over_budget += 1;
                return Err(over(Field::None, b.max_clients as u32));
            }
        }
        let c = self.clients.entry(client).or_insert_with(|| ClientState {
            tokens: b.burst(),
            refilled: now,
            seen: now,
            tracks: HashMap::new(),
            open: 0,
            held: 0,
            last: None,
        });
        c.seen = now;
        let dt = now.saturating_duration_since(c.refilled).as_secs_f64();
        c.tokens = (c.tokens + dt * b.rows_per_s).min(b.burst());
        c.refilled = now;

        // first pass: count without changing anything
        let (mut new_rows, mut new_tracks) = (0usize, 0usize);
        let mut i = 0;
        while i < rows.len() {
            let id = rows[i].agent;
            let end = run_end(rows, i);
            let track = c.tracks.get(&(map, id));
            let last = track.map_or(f64::NEG_INFINITY, |t| t.last_t);
            let fresh = rows[i..end].iter().filter(|o| o.t > last).count();
            if track.is_none_or(|t| t.ended && fresh > 0) {
                new_tracks += 1;
            }
            new_rows += fresh;
            i = end;
        }
        // (a track id repeated in two runs of one request counts as new twice: a bound;
        // ended tracks are kept, at most as many again as open ones, until quiet)
        if c.open + new_tracks > b.max_tracks
            || c.tracks.len() + new_tracks > b.max_tracks * ENDED_PER_OPEN
        {
            self.stats.over_budget += 1;
            return Err(over(Field::Tracks, b.max_tracks as u32));
        }
        if c.held + new_rows > b.max_rows_held {
            self.stats.over_budget += 1;
            return Err(over(Field::Memory, b.max_rows_held as u32));
        }
        if new_rows as f64 > c.tokens {
            self.stats.over_budget += 1;
            return Err(over(Field::Rows, b.rows_per_s.min(u32::MAX as f64) as u32));
        }

        // second pass: take the new rows
        let mut taken = Taken {
            accepted: 0,
            duplicates: 0,
        };
        let mut i = 0;
        while i < rows.len() {
            let id = rows[i].agent;
            let end = run_end(rows, i);
            let t = c.tracks.entry((map, id)).or_insert_with(|| {
                c.open += 1;
                TrackState {
                    last_t: f64::NEG_INFINITY,
                    last_xy: [0.0; 2],
                    seen: now,
                    ended: false,
                    pending: Vec::with_capacity(b.segment_rows),
                    times: Vec::with_capacity(b.segment_rows),
                }
            });
            for o in &rows[i..end] {
                if o.t <= t.last_t {
                    taken.duplicates += 1;
                    continue;
                }
                if t.ended {
                    // the person came back under the same id
                    t.ended = false;
                    c.open += 1;
                }
                taken.accepted += 1;
                if let Some(obs) = observation(o, t) {
                    t.pending.push(obs);
                    t.times.push(o.t);
                    c.held += 1;
                }
                t.last_t = o.t;
                t.last_xy = [o.x, o.y];
                t.seen = now;
                if t.pending.len() >= b.segment_rows {
                    c.held -= t.pending.len();
                    out(cut(map, client, id, t, b.segment_rows));
                }
            }
            let last = &rows[end - 1];
            if last.flags & FLAG_TRACK_END != 0 && !t.ended {
                c.held -= t.pending.len();
                if t.pending.len() >= b.min_segment_rows {
                    out(cut(map, client, id, t, 0));
                } else {
                    t.pending.clear();
                    t.times.clear();
                }
                t.pending.shrink_to_fit();
                t.times.shrink_to_fit();
                t.ended = true;
                c.open -= 1;
            }
            i = end;
        }
        c.tokens -= taken.accepted as f64;
        self.stats.accepted += taken.accepted as u64;
        self.stats.duplicates += taken.duplicates as u64;
        Ok(taken)
    }

    /// Finish the tracks quiet for longer than the budget's timeout (their rows go to
    /// `out` when there are enough) and drop the clients without tracks that went quiet
    /// (a client that died goes quiet).
    pub fn expire(&mut self, now: Instant, out: &mut impl FnMut(Segment)) {
        let b = self.budgets;
        let quiet = |seen: Instant| now.saturating_duration_since(seen) >= b.track_timeout;
        let stats = &mut self.stats;
        self.clients.retain(|&client, c| {
            c.tracks.retain(|&(map, id), t| {
                if !quiet(t.seen) {
                    return true;
                }
                c.held -= t.pending.len();
                if t.pending.len() >= b.min_segment_rows {
                    out(cut(map, client, id, t, b.segment_rows));
                }
                if !t.ended {
                    c.open -= 1;
                }
                stats.expired_tracks += 1;
                false
            });
            let keep = !c.tracks.is_empty() || !quiet(c.seen);
            if !keep {
                stats.expired_clients += 1;
            }
            keep
        });
    }

    /// Every open track as a segment (at shutdown), and no state left.
    pub fn flush(&mut self, out: &mut impl FnMut(Segment)) {
        let b = self.budgets;
        for (&client, c) in self.clients.iter_mut() {
            for (&(map, id), t) in c.tracks.iter_mut() {
                if t.pending.len() >= b.min_segment_rows {
                    out(cut(map, client, id, t, b.segment_rows));
                }
            }
        }
        self.clients.clear();
    }
}

fn over(field: Field, limit: u32) -> Rejection {
    Rejection {
        status: Status::OverBudget,
        agent: None,
        row: None,
        field,
        limit,
    }
}

/// The end of the run of rows of one track that starts at `i`.
fn run_end(rows: &[Observation], i: usize) -> usize {
    let id = rows[i].agent;
    let mut end = i;
    while end < rows.len() && rows[end].agent == id {
        end += 1;
    }
    end
}

/// The map observation of a new row: its speed and heading when it has them, else the
/// velocity from the track's previous row (none for a track's first row).
fn observation(o: &Observation, t: &TrackState) -> Option<MapObservation> {
    let position = cliff::glam::DVec2::new(o.x, o.y);
    if o.flags & FLAG_VELOCITY != 0 {
        return Some(MapObservation {
            position,
            theta: wrap_2pi(o.heading),
            rho: o.speed,
        });
    }
    if !t.last_t.is_finite() {
        return None;
    }
    let d = position - cliff::glam::DVec2::from(t.last_xy);
    let rho = d.length() / (o.t - t.last_t);
    if !rho.is_finite() {
        return None;
    }
    let theta = if rho > 0.0 {
        wrap_2pi(d.y.atan2(d.x))
    } else {
        0.0
    };
    Some(MapObservation {
        position,
        theta,
        rho,
    })
}

/// The track's pending rows as a segment (the track keeps its place and its last row).
fn cut(map: usize, client: ClientKey, track: u32, t: &mut TrackState, cap: usize) -> Segment {
    Segment {
        map,
        client,
        track,
        observations: std::mem::replace(&mut t.pending, Vec::with_capacity(cap)),
        times: std::mem::replace(&mut t.times, Vec::with_capacity(cap)),
    }
}

/// Ended tracks kept (until quiet) per open track of the budget.
const ENDED_PER_OPEN: usize = 4;

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn budgets() -> Budgets {
        Budgets {
            rows_per_s: 100.0,
            max_tracks: 3,
            max_rows_held: 50,
            segment_rows: 10,
            min_segment_rows: 3,
            ..Budgets::default()
        }
    }

    /// Track `id`'s rows at 10 Hz from time `from` (s) for `n` rows, walking east at
    /// 1 m/s (the times of one row are the same bits in every call).
    fn rows(id: u32, from: f64, n: usize) -> Vec<Observation> {
        let first = (from * 10.0).round() as usize;
        (first..first + n)
            .map(|i| {
                let t = i as f64 / 10.0;
                Observation {
                    agent: id,
                    ..Observation::position(t, t, 1.0)
                }
            })
            .collect()
    }

    #[test]
    fn overlapping_histories_count_each_row_once() {
        let mut intake = Intake::new(Budgets {
            rows_per_s: 1e6,
            max_rows_held: 10_000,
            ..budgets()
        });
        let now = Instant::now();
        let mut segments = Vec::new();
        let mut total = Taken {
            accepted: 0,
            duplicates: 0,
        };
        // ten times a second the last 2 s of the person (20 rows), for 10 s
        for k in 0..100 {
            let from = (k as f64 * 0.1 - 1.9).max(0.0);
            let n = ((k as f64 * 0.1 - from) / 0.1).round() as usize + 1;
            let r = rows(5, from, n);
            let got = intake
                .take(1, 0, &r, now, &mut |s| segments.push(s))
                .unwrap();
            total.accepted += got.accepted;
            total.duplicates += got.duplicates;
        }
        assert_eq!(total.accepted, 100, "each of the 100 rows once");
        assert!(total.duplicates > 1000);
        // another client's same track id is another person
        let got = intake
            .take(2, 0, &rows(5, 0.0, 5), now, &mut |_| ())
            .unwrap();
        assert_eq!(got.accepted, 5);
        // 99 observations (the first row has no velocity), in segments of 10
        let obs: usize = segments.iter().map(|s| s.observations.len()).sum();
        assert_eq!((segments.len(), obs), (9, 90));
        let o = segments[0].observations[0];
        assert!((o.rho - 1.0).abs() < 1e-9 && o.theta.abs() < 1e-9, "{o:?}");
        assert_eq!(segments[0].times[0], 0.1);
    }

    #[test]
    fn a_request_sent_again_gets_its_first_answer_and_takes_nothing() {
        let mut intake = Intake::new(budgets());
        let now = Instant::now();
        let first = intake
            .take_request(1, 7, 0, &rows(5, 0.0, 4), now, &mut |_| ())
            .unwrap();
        assert_eq!((first.accepted, first.duplicates), (4, 0));
        // the reply was lost: the same request again, answered as the first time
        let again = intake
            .take_request(1, 7, 0, &rows(5, 0.0, 4), now, &mut |_| ())
            .unwrap();
        assert_eq!(again, first);
        let s = intake.stats();
        assert_eq!((s.accepted, s.duplicates), (4, 0));
        // the same rows under a new request id are duplicates
        let next = intake
            .take_request(1, 8, 0, &rows(5, 0.0, 5), now, &mut |_| ())
            .unwrap();
        assert_eq!((next.accepted, next.duplicates), (1, 4));
        // another client's request with the same id is its own
        let other = intake
            .take_request(2, 8, 0, &rows(5, 0.0, 2), now, &mut |_| ())
            .unwrap();
        assert_eq!((other.accepted, other.duplicates), (2, 0));
        // a refused request is not remembered: sent again, it is judged again
        let many: Vec<_> = (10..14).flat_map(|id| rows(id, 0.0, 1)).collect();
        assert!(
            intake
                .take_request(1, 9, 0, &many, now, &mut |_| ())
                .is_err()
        );
        assert!(
            intake
                .take_request(1, 9, 0, &many, now, &mut |_| ())
                .is_err()
        );
    }

    #[test]
    fn over_budget_takes_nothing_and_names_the_budget() {
        let mut intake = Intake::new(budgets());
        let now = Instant::now();
        let mut sink = |_| ();
        // burst: one second of the rate (100 rows)
        let r = intake
            .take(1, 0, &rows(1, 0.0, 40), now, &mut sink)
            .unwrap();
        assert_eq!(r.accepted, 40);
        // rows held: at most 50 (the segments of 10 go to the learner at once)
        let rej = intake
            .take(1, 0, &rows(2, 0.0, 60), now, &mut sink)
            .unwrap_err();
        assert_eq!(
            (rej.status, rej.field, rej.limit),
            (Status::OverBudget, Field::Memory, 50)
        );
        // tracks: at most 3
        let mut many = rows(2, 0.0, 1);
        many.extend(rows(3, 0.0, 1));
        many.extend(rows(4, 0.0, 1));
        let rej = intake.take(1, 0, &many, now, &mut sink).unwrap_err();
        assert_eq!((rej.field, rej.limit), (Field::Tracks, 3));
        // rate: 60 tokens left, 9 more rows of track 1 and the rest of the burst
        intake.take(1, 0, &rows(1, 4.0, 9), now, &mut sink).unwrap();
        for k in 0..5 {
            intake
                .take(1, 0, &rows(1, 10.0 + k as f64, 10), now, &mut sink)
                .unwrap();
        }
        let rej = intake
            .take(1, 0, &rows(1, 20.0, 5), now, &mut sink)
            .unwrap_err();
        assert_eq!((rej.field, rej.limit), (Field::Rows, 100));
        // a tenth of a second later, ten more rows are allowed
        let later = now + Duration::from_millis(100);
        assert_eq!(
            intake
                .take(1, 0, &rows(1, 20.0, 10), later, &mut sink)
                .unwrap()
                .accepted,
            10
        );
        assert_eq!(intake.stats().over_budget, 3);
    }

    #[test]
    fn an_ended_track_is_learned_at_once_and_no_longer_open() {
        let mut intake = Intake::new(budgets());
        let now = Instant::now();
        let mut segments = Vec::new();
        for id in 0..3 {
            let mut r = rows(id, 0.0, 5);
            r.last_mut().unwrap().flags |= FLAG_TRACK_END;
            intake
                .take(1, 0, &r, now, &mut |s| segments.push(s))
                .unwrap();
        }
        // each ended track went to the learner; three more fit the budget of 3 open
        assert_eq!(segments.len(), 3);
        assert_eq!(segments[0].observations.len(), 4);
        let mut more = rows(3, 0.0, 2);
        more.extend(rows(4, 0.0, 2));
        more.extend(rows(5, 0.0, 2));
        intake.take(1, 0, &more, now, &mut |_| ()).unwrap();
        // an ended track's rows sent again are duplicates
        let again = intake.take(1, 0, &rows(0, 0.0, 5), now, &mut |_| ());
        assert_eq!(again.unwrap().duplicates, 5);
        // a track that comes back with new rows opens again: over the budget now
        let back = intake.take(1, 0, &rows(0, 0.0, 6), now, &mut |_| ());
        assert_eq!(back.unwrap_err().field, Field::Tracks);
    }

    #[test]
    fn quiet_tracks_and_clients_are_dropped() {
        let mut intake = Intake::new(Budgets {
            track_timeout: Duration::from_secs(5),
            ..budgets()
        });
        let now = Instant::now();
        let mut segments = Vec::new();
        intake
            .take(1, 0, &rows(1, 0.0, 5), now, &mut |s| segments.push(s))
            .unwrap();
        intake
            .take(2, 0, &rows(1, 0.0, 2), now, &mut |_| ())
            .unwrap();
        intake.expire(now + Duration::from_secs(4), &mut |s| segments.push(s));
        assert_eq!((intake.clients(), intake.tracks()), (2, 2));
        intake.expire(now + Duration::from_secs(6), &mut |s| segments.push(s));
        assert_eq!((intake.clients(), intake.tracks()), (0, 0));
        // client 1's 4 observations were enough for a segment, client 2's 1 was not
        assert_eq!(segments.len(), 1);
        assert_eq!(segments[0].observations.len(), 4);
        let s = intake.stats();
        assert_eq!((s.expired_tracks, s.expired_clients), (2, 2));
    }

    #[test]
    fn clients_beyond_the_limit_are_refused_until_one_goes_quiet() {
        let mut intake = Intake::new(Budgets {
            max_clients: 2,
            ..budgets()
        });
        let now = Instant::now();
        for c in 0..2 {
            intake
                .take(c, 0, &rows(1, 0.0, 2), now, &mut |_| ())
                .unwrap();
        }
        assert_eq!(
            intake
                .take(9, 0, &rows(1, 0.0, 2), now, &mut |_| ())
                .unwrap_err()
                .status,
            Status::OverBudget
        );
        let later = now + Duration::from_secs(10);
        assert!(
            intake
                .take(9, 0, &rows(1, 0.0, 2), later, &mut |_| ())
                .is_ok()
        );
    }
}
