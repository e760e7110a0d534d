//! Why a request was refused: the [`Status`] codes, the [`Field`] a rejection concerns,
//! and the [`Rejection`] that holds both and where (its place in a response header:
//! `response.rs`).

use std::fmt;

/// Outcome of a request, as sent in [`ResponseHeader::status`](super::ResponseHeader::status).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Status {
    /// The batch is in the payload.
    Ok = 0,
    /// The request's protocol version differs from the daemon's (`limit`: the daemon's
    /// version).
    BadVersion = 1,
    /// No map of that name is loaded.
    UnknownMap = 2,
    /// The method code is not one of [`METHOD_CLIFF`](super::METHOD_CLIFF),
    /// [`METHOD_CVM`](super::METHOD_CVM), [`METHOD_IMPROVED`](super::METHOD_IMPROVED) (or the
    /// heading rule code is unknown).
    UnknownMethod = 3,
    /// A parameter or a history value is NaN or infinite.
    NonFinite = 4,
    /// `k` is zero or above the daemon's limit.
    BadK = 5,
    /// `floor(horizon / dt)` is zero or above the daemon's limit.
    BadSteps = 6,
    /// No agents, or more than the daemon's limit (for a method that costs more than
    /// CLiFF-LHMP, the limit for the request's `k` and steps).
    BadAgents = 7,
    /// An agent's history has too few rows (2 with positions only, 1 with velocity).
    HistoryTooShort = 8,
    /// An agent's timestamps do not strictly increase.
    HistoryNotIncreasing = 9,
    /// A finite parameter or value out of its range (dt or radius not positive, beta,
    /// horizon, speed_beta, coast or a speed negative, coast beyond the horizon), an
    /// unknown flag bit or time mode.
    BadValue = 10,
    /// The rows are not grouped by agent `0..agents`, or an agent mixes rows with and
    /// without velocity.
    BadLayout = 11,
    /// An agent's history has more rows than the daemon accepts.
    HistoryTooLong = 12,
    /// The request kind is unknown.
    UnknownKind = 13,
    /// A map reload failed; that map keeps its old version.
    ReloadFailed = 14,
    /// The daemon could not build the response (shared memory exhausted); retry.
    Internal = 15,
    /// The sampling radius is above the daemon's limit for the map (the limit is sent in
    /// millimetres; the default limit is four grid steps of the map).
    RadiusTooLarge = 16,
    /// The client already has as many requests in flight as the daemon allows one
    /// client (`limit`); over zenoh, where the daemon counts them itself (locally,
    /// iceoryx2 refuses the send). Retry once an answer has arrived.
    Busy = 17,
    /// The daemon serves as many remote sessions with requests in flight as it allows
    /// (`limit`); retry later.
    TooManySessions = 18,
    /// An observe request ([`KIND_OBSERVE`](super::KIND_OBSERVE)) is over the client's
    /// budget: rows per second ([`Field::Rows`]), open tracks ([`Field::Tracks`]) or rows
    /// held ([`Field::Memory`]); `limit` holds the budget. Nothing of the request was
    /// taken; retry later, or with fewer rows or tracks.
    OverBudget = 19,
    /// An observe request names a map the daemon serves but does not learn
    /// (`cliffd --learn NAME`).
    NotLearning = 20,
    /// The map name asks for a version (`NAME@VERSION`) the daemon does not hold: a
    /// learning daemon keeps the map as loaded (version 0), the version served and the
    /// few before it (`cliffd --learn-keep-versions`); `limit` holds the version served.
    UnknownVersion = 21,
    /// Over zenoh, an observe request on the prediction key: a daemon takes observations
    /// only on its observe key (the service name followed by `/observe`), which zenoh's
    /// access control may close to sessions that are not allowed to teach the map; a
    /// client whose query there got no answer is told this status. Nothing was taken.
    NotAllowed = 22,
}

impl Status {
    /// The status for a wire code; unknown codes become `None`.
    pub fn from_code(code: u32) -> Option<Status> {
        use Status::*;
        Some(match code {
            0 => Ok,
            1 => BadVersion,
            2 => UnknownMap,
            3 => UnknownMethod,
            4 => NonFinite,
            5 => BadK,
            6 => BadSteps,
            7 => BadAgents,
            8 => HistoryTooShort,
            9 => HistoryNotIncreasing,
            10 => BadValue,
            11 => BadLayout,
            12 => HistoryTooLong,
            13 => UnknownKind,
            14 => ReloadFailed,
            15 => Internal,
            16 => RadiusTooLarge,
            17 => Busy,
            18 => TooManySessions,
            19 => OverBudget,
            20 => NotLearning,
            21 => UnknownVersion,
            22 => NotAllowed,
            _ => return None,
        })
    }

    /// The wire code.
    pub fn code(self) -> u32 {
        self as u32
    }

    /// A short name (`unknown-map`, ...), as in logs and the C header.
    pub fn name(self) -> &'static str {
        use Status::*;
        match self {
            Ok => "ok",
            BadVersion => "bad-version",
            UnknownMap => "unknown-map",
            UnknownMethod => "unknown-method",
            NonFinite => "non-finite",
            BadK => "bad-k",
            BadSteps => "bad-steps",
            BadAgents => "bad-agents",
            HistoryTooShort => "history-too-short",
            HistoryNotIncreasing => "history-not-increasing",
            BadValue => "bad-value",
            BadLayout => "bad-layout",
            HistoryTooLong => "history-too-long",
            UnknownKind => "unknown-kind",
            ReloadFailed => "reload-failed",
            Internal => "internal",
            RadiusTooLarge => "radius-too-large",
            Busy => "busy",
            TooManySessions => "too-many-sessions",
            OverBudget => "over-budget",
            NotLearning => "not-learning",
            UnknownVersion => "unknown-version",
            NotAllowed => "not-allowed",
        }
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Which value a rejection concerns ([`ResponseHeader::field`](super::ResponseHeader::field)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Field {
    /// None in particular.
    None = 0,
    /// `dt`.
    Dt = 1,
    /// `horizon`.
    Horizon = 2,
    /// `beta`.
    Beta = 3,
    /// `radius`.
    Radius = 4,
    /// A row's time.
    Time = 5,
    /// A row's position.
    Position = 6,
    /// A row's speed.
    Speed = 7,
    /// A row's heading.
    Heading = 8,
    /// `k`.
    K = 9,
    /// The number of steps.
    Steps = 10,
    /// The number of agents.
    Agents = 11,
    /// The map name.
    Map = 12,
    /// The method.
    Method = 13,
    /// The heading rule.
    HeadingRule = 14,
    /// The protocol version.
    Version = 15,
    /// `speed_beta`.
    SpeedBeta = 16,
    /// `coast`.
    Coast = 17,
    /// The request flags.
    Flags = 18,
    /// `time_mode`.
    TimeMode = 19,
    /// `time` (the time that picks the map, not a row's time).
    MapTime = 20,
    /// The rows of an observe request (their number, or rows per second of a budget).
    Rows = 21,
    /// A client's open tracks.
    Tracks = 22,
    /// The rows a client's open tracks hold in the daemon.
    Memory = 23,
}

impl Field {
    /// The field for a wire code (unknown codes become [`Field::None`]).
    pub fn from_code(code: u32) -> Field {
        use Field::*;
        match code {
            1 => Dt,
            2 => Horizon,
            3 => Beta,
            4 => Radius,
            5 => Time,
            6 => Position,
            7 => Speed,
            8 => Heading,
            9 => K,
            10 => Steps,
            11 => Agents,
            12 => Map,
            13 => Method,
            14 => HeadingRule,
            15 => Version,
            16 => SpeedBeta,
            17 => Coast,
            18 => Flags,
            19 => TimeMode,
            20 => MapTime,
            21 => Rows,
            22 => Tracks,
            23 => Memory,
            _ => None,
        }
    }

    /// The field's name as used in messages.
    pub fn name(self) -> &'static str {
        use Field::*;
        match self {
            None => "-",
            Dt => "dt",
            Horizon => "horizon",
            Beta => "beta",
            Radius => "radius",
            Time => "time",
            Position => "position",
            Speed => "speed",
            Heading => "heading",
            K => "k",
            Steps => "steps",
            Agents => "agents",
            Map => "map",
            Method => "method",
            HeadingRule => "heading rule",
            Version => "version",
            SpeedBeta => "speed_beta",
            Coast => "coast",
            Flags => "flags",
            TimeMode => "time_mode",
            MapTime => "map time",
            Rows => "rows",
            Tracks => "tracks",
            Memory => "memory",
        }
    }
}

/// Why a request was refused: the status and where.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rejection {
    /// The status (never [`Status::Ok`]).
    pub status: Status,
    /// The agent concerned, if any.
    pub agent: Option<u32>,
    /// The row (within the agent) concerned, if any.
    pub row: Option<u32>,
    /// The value concerned.
    pub field: Field,
    /// The limit that was exceeded (0 when none; millimetres for
    /// [`Status::RadiusTooLarge`]).
    pub limit: u32,
}

impl Rejection {
    pub(crate) fn new(status: Status, field: Field) -> Self {
        Rejection {
            status,
            agent: None,
            row: None,
            field,
            limit: 0,
        }
    }

    pub(crate) fn at(status: Status, field: Field, agent: u32, row: u32) -> Self {
        Rejection {
            status,
            agent: Some(agent),
            row: Some(row),
            field,
            limit: 0,
        }
    }

    pub(crate) fn over(status: Status, field: Field, limit: u32) -> Self {
        Rejection {
            status,
            agent: None,
            row: None,
            field,
            limit,
        }
    }
}

impl fmt::Display for Rejection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.status)?;
        if self.field != Field::None {
            write!(f, " ({})", self.field.name())?;
        }
        if let Some(a) = self.agent {
            write!(f, " at agent {a}")?;
            if let Some(r) = self.row {
                write!(f, " row {r}")?;
            }
        }
        if self.status == Status::BadVersion && self.limit > 0 {
            write!(f, ": the daemon speaks protocol version {}", self.limit)?;
        } else if self.limit > 0 {
            write!(f, ", limit {}", self.limit)?;
            if self.status == Status::RadiusTooLarge {
                f.write_str(" mm")?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_and_field_codes_round_trip_and_rejections_read_well() {
        for c in 0..24 {
            assert_eq!(Field::from_code(c) as u32, c);
        }
        assert_eq!(Field::from_code(24), Field::None);
        for c in 0..23 {
            let s = Status::from_code(c).unwrap();
            assert_eq!(s.code(), c);
        }
        assert_eq!(Status::from_code(23), None);
        let r = Rejection::over(Status::Busy, Field::None, 2);
        assert_eq!(r.to_string(), "busy, limit 2");
        let r = Rejection::at(Status::NonFinite, Field::Time, 3, 7);
        assert_eq!(r.to_string(), "non-finite (time) at agent 3 row 7");
        let r = Rejection::over(Status::RadiusTooLarge, Field::Radius, 2000);
        assert_eq!(r.to_string(), "radius-too-large (radius), limit 2000 mm");
    }
}
