//! Observe requests ([`KIND_OBSERVE`]): tracked people's rows sent to a daemon that learns
//! a map, their validation ([`validate_observe`]) and the counts of the answer
//! ([`ObserveReply`]).
//!
//! An observe request is a [`RequestHeader`] with `kind` [`KIND_OBSERVE`] and the map's
//! name (every other field is ignored, `agents` included), and up to
//! [`MAX_OBSERVE_ROWS`] [`Observation`] rows. Each row's `agent` is the track id the
//! client gives that person (any `u32`, stable while it tracks them); the rows of one
//! track come in runs whose times strictly increase, oldest first, and several tracks
//! may share a request. A robot may send each person's whole recent history every time:
//! the daemon counts a row once per (client, track, time), so rows it has seen are
//! counted as duplicates and skipped.

use cliff::tracks::{MAX_ANGLE, MAX_POSITION, MAX_SPEED, MAX_TIME};

use super::codes::{
    FLAG_TRACK_END, FLAG_VELOCITY, KIND_OBSERVE, MAX_OBSERVE_ROWS, PROTOCOL_VERSION,
};
use super::request::{Observation, RequestHeader};
use super::response::ResponseHeader;
use super::status::{Field, Rejection, Status};

/// What a daemon did with an observe request: read from (and written into) the header of
/// its empty response. The shape fields stay zero; `agent` holds the rows taken, `row`
/// the duplicates, and `map_version` the version of the learned map at the time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ObserveReply {
    /// Rows taken (new to the daemon).
    pub accepted: u32,
    /// Rows skipped because the daemon had them already (same client, track and time, or
    /// older than the track's last row).
    pub duplicates: u32,
    /// The learned map's version when the rows were taken.
    pub map_version: u32,
}

impl ObserveReply {
    /// Write the counts into an OK response header.
    pub fn write_to(&self, h: &mut ResponseHeader) {
        h.status = Status::Ok.code();
        h.agents = 0;
        h.k = 0;
        h.steps = 0;
        h.agent = self.accepted;
        h.row = self.duplicates;
        h.field = 0;
        h.map_version = self.map_version;
    }

    /// Read the counts from an OK response header.
    pub fn from_header(h: &ResponseHeader) -> ObserveReply {
        ObserveReply {
            accepted: h.agent,
            duplicates: h.row,
            map_version: h.map_version,
        }
    }
}

/// Check an observe request before any work: version and kind, the number of rows (1 to
/// `max_rows`, itself at most [`MAX_OBSERVE_ROWS`]), the row flags ([`FLAG_VELOCITY`],
/// [`FLAG_TRACK_END`](super::FLAG_TRACK_END)), every value finite and
/// within the bounds of the tracks readers ([`cliff::tracks::MAX_TIME`], ...), speeds not
/// negative, and times strictly increasing within each run of one track's rows. The map
/// name is checked by the caller. A rejection names the track (`agent`) and the row's
/// index in the request (`row`).
pub fn validate_observe(
    h: &RequestHeader,
    rows: &[Observation],
    max_rows: u32,
) -> Result<(), Rejection> {
    use Status::*;
    if h.version != PROTOCOL_VERSION {
        return Err(Rejection::over(
            BadVersion,
            Field::Version,
            PROTOCOL_VERSION,
        ));
    }
    if h.kind != KIND_OBSERVE {
        return Err(Rejection::new(UnknownKind, Field::None));
    }
    let max_rows = max_rows.min(MAX_OBSERVE_ROWS);
    if rows.is_empty() || rows.len() > max_rows as usize {
        return Err(Rejection::over(HistoryTooLong, Field::Rows, max_rows));
    }
    for (i, o) in rows.iter().enumerate() {
        let at = |status, field| Rejection::at(status, field, o.agent, i as u32);
        if o.flags & !(FLAG_VELOCITY | FLAG_TRACK_END) != 0 {
            return Err(at(BadValue, Field::Flags));
        }
        if !o.t.is_finite() {
            return Err(at(NonFinite, Field::Time));
        }
        if o.t.abs() > MAX_TIME {
            return Err(at(BadValue, Field::Time));
        }
        if !(o.x.is_finite() && o.y.is_finite()) {
            return Err(at(NonFinite, Field::Position));
        }
        if o.x.abs() > MAX_POSITION || o.y.abs() > MAX_POSITION {
            return Err(at(BadValue, Field::Position));
        }
        if o.flags & FLAG_VELOCITY != 0 {
            if !o.speed.is_finite() {
                return Err(at(NonFinite, Field::Speed));
            }
            if !(0.0..=MAX_SPEED).contains(&o.speed) {
                return Err(at(BadValue, Field::Speed));
            }
            if !o.heading.is_finite() {
                return Err(at(NonFinite, Field::Heading));
            }
            if o.heading.abs() > MAX_ANGLE {
                return Err(at(BadValue, Field::Heading));
            }
        }
        if i > 0 && rows[i - 1].agent == o.agent && o.t <= rows[i - 1].t {
            return Err(at(HistoryNotIncreasing, Field::Time));
        }
    }
    Result::Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> RequestHeader {
        let mut h = RequestHeader {
            kind: KIND_OBSERVE,
            ..RequestHeader::default()
        };
        h.set_map_name("demo").unwrap();
        h
    }

    fn rows(track: u32, n: usize) -> Vec<Observation> {
        (0..n)
            .map(|i| Observation {
                agent: track,
                ..Observation::position(0.4 * i as f64, i as f64, 0.0)
            })
            .collect()
    }

    #[test]
    fn observe_requests_are_checked_row_by_row() {
        let h = header();
        let mut good = rows(7, 5);
        good.extend(rows(9, 3));
        assert_eq!(validate_observe(&h, &good, 64), Ok(()));
        let status = |r: &[Observation], max| validate_observe(&h, r, max).unwrap_err();
        assert_eq!(status(&[], 64).status, Status::HistoryTooLong);
        let r = status(&good, 4);
        assert_eq!(
            (r.status, r.field, r.limit),
            (Status::HistoryTooLong, Field::Rows, 4)
        );
        // a daemon's setting cannot lift the protocol's bound
        assert_eq!(status(&rows(1, 5000), u32::MAX).limit, MAX_OBSERVE_ROWS);
        let mut bad = good.clone();
        bad[6].t = f64::NAN;
        let r = status(&bad, 64);
        assert_eq!(
            (r.status, r.field, r.agent, r.row),
            (Status::NonFinite, Field::Time, Some(9), Some(6))
        );
        let mut bad = good.clone();
        bad[2].x = 2e6;
        assert_eq!(status(&bad, 64).field, Field::Position);
        let mut bad = good.clone();
        bad[3].t = bad[2].t;
        assert_eq!(status(&bad, 64).status, Status::HistoryNotIncreasing);
        let mut bad = good.clone();
        bad[1] = Observation {
            agent: 7,
            ..Observation::with_velocity(0.4, 1.0, 0.0, -1.0, 0.0)
        };
        assert_eq!(status(&bad, 64).field, Field::Speed);
        let mut bad = good.clone();
        bad[0].flags = 4;
        assert_eq!(status(&bad, 64).field, Field::Flags);
        let predict = RequestHeader {
            kind: crate::protocol::KIND_PREDICT,
            ..h
        };
        assert_eq!(
            validate_observe(&predict, &good, 64).unwrap_err().status,
            Status::UnknownKind
        );
    }

    #[test]
    fn observe_counts_round_trip_through_the_response_header() {
        let reply = ObserveReply {
            accepted: 12,
            duplicates: 30,
            map_version: 4,
        };
        let mut h = ResponseHeader::default();
        reply.write_to(&mut h);
        assert_eq!(h.payload_words(), 0);
        assert_eq!(Rejection::from_header(&h), None);
        assert_eq!(ObserveReply::from_header(&h), reply);
    }
}
