//! Which map of the time of day a request asks for ([`MapTime`]), in its wire form and
//! as picked from a time-of-day map set.

use std::sync::Arc;

use cliff::map::{CliffMap, MapSet};

use super::codes::{TIME_ALL_DAY, TIME_AT, TIME_NOW};
use super::status::{Field, Rejection, Status};

/// Which map of the time of day a request asks for
/// ([`RequestHeader::time_mode`](super::RequestHeader::time_mode) and
/// [`RequestHeader::time`](super::RequestHeader::time)); [`map_in`](Self::map_in) picks it from a
/// time-of-day map set, as the daemon does for a map served as a set.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum MapTime {
    /// The map for the daemon's wall clock when the request arrives.
    #[default]
    Now,
    /// The map for this time (s on the map's clock: unix time, as the tracks had it).
    At(f64),
    /// The all-day map.
    AllDay,
}

impl MapTime {
    /// The map of `set` this asks for: the slice that holds `t` for [`MapTime::At`]`(t)`,
    /// the slice that holds the wall clock (unix time, read now) for [`MapTime::Now`],
    /// the all-day map for [`MapTime::AllDay`] (a time without a slice map, or a set
    /// without slices: the all-day map). The one rule for the daemon and in-process
    /// callers.
    pub fn map_in(self, set: &MapSet) -> &Arc<CliffMap> {
        match self {
            MapTime::AllDay => set.all_day(),
            MapTime::At(t) => set.at(t),
            MapTime::Now => {
                let now = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0.0, |d| d.as_secs_f64());
                set.at(now)
            }
        }
    }

    /// The wire form: `(time_mode, time)`.
    pub fn to_wire(self) -> (u32, f64) {
        match self {
            MapTime::Now => (TIME_NOW, 0.0),
            MapTime::At(t) => (TIME_AT, t),
            MapTime::AllDay => (TIME_ALL_DAY, 0.0),
        }
    }

    /// Read the wire form; the rejection names the field that is wrong (an unknown mode,
    /// a time that is not finite, in any mode).
    pub fn from_wire(mode: u32, time: f64) -> Result<MapTime, Rejection> {
        let when = match mode {
            TIME_NOW => MapTime::Now,
            TIME_AT => MapTime::At(time),
            TIME_ALL_DAY => MapTime::AllDay,
            _ => return Err(Rejection::new(Status::BadValue, Field::TimeMode)),
        };
        if !time.is_finite() {
            return Err(Rejection::new(Status::NonFinite, Field::MapTime));
        }
        Ok(when)
    }
}
