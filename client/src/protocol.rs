//! The wire protocol between clients and `cliffd`, defined once for both sides.
//!
//! One iceoryx2 request-response service per daemon:
//!
//! * request: a [`RequestHeader`] (iceoryx2 user header) and a slice of [`Observation`]
//!   rows, grouped by agent (`agent` 0, 0, 0, 1, 1, ...), oldest row first;
//! * response: a [`ResponseHeader`] (status, request id echo, shape) and a slice of
//!   `u32` words: first `agents x k x steps` points as `[f32; 2]` bit patterns
//!   (sample-major, exactly as [`cliff::predict::predict_into`] writes them), then the
//!   `agents x k` valid lengths, then (when the request set [`FLAG_SCORES`]) the
//!   `agents x k` scores as `f32` bit patterns. A rejected request gets an empty slice.
//!
//! All types are `#[repr(C)]`, hold no pointers, and carry a stable iceoryx2 type name
//! that includes [`PROTOCOL_VERSION`]. The iceoryx2 service of version 2 is named after
//! the daemon's service with the version appended ([`ipc_service_name`]); a daemon
//! also serves version 1's name with version 1's types ([`crate::legacy`]) only to
//! answer every request there with [`Status::BadVersion`], so an old client learns why
//! instead of finding no daemon.
//!
//! Version 2 added, over version 1: the method [`METHOD_IMPROVED`]; the options beyond
//! the paper ([`RequestHeader::speed_beta`], [`RequestHeader::coast`], scores through
//! [`FLAG_SCORES`], see [`cliff::predict::Options`]); the time that picks a map of the
//! time of day ([`RequestHeader::time_mode`], [`RequestHeader::time`]); and
//! [`ResponseHeader::flags`] with the scores in the payload.
//!
//! [`decode_request`] is the one place that validates a request and turns it into
//! prediction parameters and agent states: the daemon calls it, and so does the
//! in-process reference ([`LocalPredictor`]), which is why the two give the same bytes.

use std::fmt;
use std::sync::Arc;

use cliff::glam::DVec2;
use cliff::map::{CliffMap, MapSet};
use cliff::motion::{DEFAULT_SIGMA, State, velocity_from_positions, velocity_from_speed_angle};
use cliff::predict::preset::cost_factor;
use cliff::predict::{HeadingRule, Method, Options, Params, TrajectoryBatch, predict_with};
use iceoryx2::prelude::ZeroCopySend;

/// Version of the wire protocol; a request with another version is answered with
/// [`Status::BadVersion`] (its `limit` holds this version).
pub const PROTOCOL_VERSION: u32 = 2;

/// The iceoryx2 service name of this protocol version for the daemon's service name
/// `service` (`cliff/predict` is served as `cliff/predict/v2`). Version 1 used the bare
/// name ([`crate::legacy`]); the event services (`{service}/requests`,
/// `{service}/responses`) carry no types and are shared by all versions.
///
/// ```
/// assert_eq!(cliff_client::protocol::ipc_service_name("cliff/predict"), "cliff/predict/v2");
/// ```
pub fn ipc_service_name(service: &str) -> String {
    format!("{service}/v{PROTOCOL_VERSION}")
}

/// Bytes reserved for a map name in a request (names are at most one byte shorter: the
/// rest is NUL padding).
pub const MAP_NAME_BYTES: usize = 64;

/// The longest history (rows per agent) any daemon accepts. The observed velocity weighs
/// row `n` back with `exp(-n^2 / 4.5)`: beyond a dozen rows nothing changes.
pub const MAX_HISTORY: u32 = 64;

/// [`RequestHeader::kind`]: predict trajectories.
pub const KIND_PREDICT: u32 = 0;
/// [`RequestHeader::kind`]: reload every map from its file (answered with an empty
/// response; status [`Status::ReloadFailed`] names the first map that failed, which keeps
/// its old version).
pub const KIND_RELOAD: u32 = 1;

/// [`RequestHeader::method`] for CLiFF-LHMP.
pub const METHOD_CLIFF: u32 = 0;
/// [`RequestHeader::method`] for the constant-velocity model.
pub const METHOD_CVM: u32 = 1;
/// [`RequestHeader::method`] for the improved method (`Method::Improved`: CLiFF-LHMP
/// with a preset of parameters and options, resolved by the library,
/// `cliff::predict::preset`; the preset's beta and options replace the request's).
pub const METHOD_IMPROVED: u32 = 2;

/// [`RequestHeader::flags`] and [`ResponseHeader::flags`] bit: the response carries a
/// score per sample after the lengths ([`cliff::predict::Options::scores`]). A response
/// to [`METHOD_IMPROVED`] always does (its preset scores the samples): read the
/// response's flag.
pub const FLAG_SCORES: u32 = 1;
/// Every [`RequestHeader::flags`] bit this version knows; a request with another bit
/// set is refused ([`Status::BadValue`], [`Field::Flags`]).
pub const KNOWN_FLAGS: u32 = FLAG_SCORES;

/// [`RequestHeader::time_mode`]: the map for the daemon's wall clock when the request
/// arrives (the default). [`RequestHeader::time`] is not used (but must be finite).
pub const TIME_NOW: u32 = 0;
/// [`RequestHeader::time_mode`]: the map for [`RequestHeader::time`], seconds on the
/// map's clock (unix time, as the tracks the map was built from had it).
pub const TIME_AT: u32 = 1;
/// [`RequestHeader::time_mode`]: the all-day map, whatever the time.
pub const TIME_ALL_DAY: u32 = 2;

/// [`RequestHeader::heading_rule`]: the reference implementation's circular mean.
pub const HEADING_CIRCULAR_MEAN: u32 = 0;
/// [`RequestHeader::heading_rule`]: the paper's formula.
pub const HEADING_PAPER: u32 = 1;

/// [`Observation::flags`] bit: the row's `speed` and `heading` are set. When every row of
/// an agent has it, the observed velocity comes from these columns (the reference rule);
/// when none has it, from the timestamped positions.
pub const FLAG_VELOCITY: u32 = 1;

/// Fixed part of a request (the iceoryx2 request user header).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("cliff.protocol.v2.RequestHeader")]
#[repr(C)]
pub struct RequestHeader {
    /// Must be [`PROTOCOL_VERSION`].
    pub version: u32,
    /// [`KIND_PREDICT`] or [`KIND_RELOAD`].
    pub kind: u32,
    /// Chosen by the client, echoed in the response.
    pub request_id: u64,
    /// iceoryx2 listener id (low, high 64 bits) the daemon notifies when the response is
    /// sent; `[0, 0]` for none (a busy-polling client).
    pub listener_id: [u64; 2],
    /// Map name, UTF-8, NUL-padded.
    pub map: [u8; MAP_NAME_BYTES],
    /// [`METHOD_CLIFF`], [`METHOD_CVM`] or [`METHOD_IMPROVED`].
    pub method: u32,
    /// [`HEADING_CIRCULAR_MEAN`] or [`HEADING_PAPER`].
    pub heading_rule: u32,
    /// Samples per agent.
    pub k: u32,
    /// Number of agents; the rows hold agents `0..agents`.
    pub agents: u32,
    /// Time step (s).
    pub dt: f64,
    /// Horizon (s); steps = `floor(horizon / dt)`.
    pub horizon: f64,
    /// CLiFF-LHMP kernel parameter.
    pub beta: f64,
    /// Sampling radius (m).
    pub radius: f64,
    /// Seed of the request's random generator.
    pub seed: u64,
    /// Speed kernel parameter ([`Options::speed_beta`]); 0 keeps the observed speed.
    pub speed_beta: f64,
    /// Seconds a sample coasts where the map has no data ([`Options::coast`], at most
    /// the horizon); 0 stops it there.
    pub coast: f64,
    /// Bits: [`FLAG_SCORES`].
    pub flags: u32,
    /// Which map of the time of day: [`TIME_NOW`], [`TIME_AT`] or [`TIME_ALL_DAY`].
    pub time_mode: u32,
    /// For [`TIME_AT`]: the time (s on the map's clock); must be finite in every mode.
    pub time: f64,
}

impl Default for RequestHeader {
    fn default() -> Self {
        RequestHeader::from_params(&Params::default())
    }
}

impl RequestHeader {
    /// A predict header for `params` (map name empty, no agents, no listener).
    pub fn from_params(params: &Params) -> Self {
        RequestHeader {
            version: PROTOCOL_VERSION,
            kind: KIND_PREDICT,
            request_id: 0,
            listener_id: [0, 0],
            map: [0; MAP_NAME_BYTES],
            method: method_code(params.method),
            heading_rule: match params.heading {
                HeadingRule::CircularMean => HEADING_CIRCULAR_MEAN,
                HeadingRule::Paper => HEADING_PAPER,
            },
            k: params.k.min(u32::MAX as usize) as u32,
            agents: 0,
            dt: params.dt,
            horizon: params.horizon,
            beta: params.beta,
            radius: params.radius,
            seed: params.seed,
            speed_beta: 0.0,
            coast: 0.0,
            flags: 0,
            time_mode: TIME_NOW,
            time: 0.0,
        }
    }

    /// Set the options beyond the paper (speed kernel, coasting, scores).
    pub fn set_options(&mut self, options: &Options) {
        self.speed_beta = options.speed_beta;
        self.coast = options.coast;
        self.flags = if options.scores {
            self.flags | FLAG_SCORES
        } else {
            self.flags & !FLAG_SCORES
        };
    }

    /// The options as sent (not validated).
    pub fn options(&self) -> Options {
        Options {
            speed_beta: self.speed_beta,
            coast: self.coast,
            scores: self.flags & FLAG_SCORES != 0,
            // not on the wire: only through a preset method (improved)
            ..Options::default()
        }
    }

    /// Set which map of the time of day the request asks for.
    pub fn set_map_time(&mut self, when: MapTime) {
        (self.time_mode, self.time) = when.to_wire();
    }

    /// The map name as bytes (without the NUL padding).
    pub fn map_name(&self) -> &[u8] {
        let end = self
            .map
            .iter()
            .position(|&b| b == 0)
            .unwrap_or(MAP_NAME_BYTES);
        &self.map[..end]
    }

    /// Set the map name; `Err` when it is empty, longer than `MAP_NAME_BYTES - 1` bytes or
    /// holds a NUL byte.
    pub fn set_map_name(&mut self, name: &str) -> Result<(), String> {
        encode_map_name(name).map(|m| self.map = m)
    }
}

/// The wire code of a method ([`RequestHeader::method`]).
pub fn method_code(method: Method) -> u32 {
    match method {
        Method::Cliff => METHOD_CLIFF,
        Method::Cvm => METHOD_CVM,
        Method::Improved => METHOD_IMPROVED,
    }
}

/// The method of a wire code; `None` for an unknown code.
pub fn method_from_code(code: u32) -> Option<Method> {
    match code {
        METHOD_CLIFF => Some(Method::Cliff),
        METHOD_CVM => Some(Method::Cvm),
        METHOD_IMPROVED => Some(Method::Improved),
        _ => None,
    }
}

/// Whether the response to a request of `params` and `options` carries scores: when
/// the request asks for them ([`FLAG_SCORES`]) or its method's preset scores its
/// samples (`Improved`, [`cliff::predict::preset`]).
pub fn scores_in_response(params: &Params, options: &Options) -> bool {
    options.scores || cliff::predict::preset::resolve(params, options).1.scores
}

/// Which map of the time of day a request asks for ([`RequestHeader::time_mode`] and
/// [`RequestHeader::time`]); [`map_in`](Self::map_in) picks it from a time-of-day map
/// set, as the daemon does for a map served as a set.
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

/// A map name in its wire form; `Err` names what is wrong with it.
pub fn encode_map_name(name: &str) -> Result<[u8; MAP_NAME_BYTES], String> {
    let b = name.as_bytes();
    if b.is_empty() {
        return Err("map name is empty".into());
    }
    if b.len() >= MAP_NAME_BYTES {
        return Err(format!(
            "map name '{name}' is {} bytes, at most {} are allowed",
            b.len(),
            MAP_NAME_BYTES - 1
        ));
    }
    if b.contains(&0) {
        return Err(format!(
            "map name '{}' holds a NUL byte",
            name.escape_debug()
        ));
    }
    let mut out = [0u8; MAP_NAME_BYTES];
    out[..b.len()].copy_from_slice(b);
    Ok(out)
}

/// One row of an agent's observed history.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("cliff.protocol.v2.Observation")]
#[repr(C)]
pub struct Observation {
    /// Agent index in the request (`0..agents`, rows grouped by agent).
    pub agent: u32,
    /// [`FLAG_VELOCITY`] when `speed` and `heading` are set.
    pub flags: u32,
    /// Time (s), strictly increasing within an agent.
    pub t: f64,
    /// Position x (m).
    pub x: f64,
    /// Position y (m).
    pub y: f64,
    /// Speed (m/s), when [`FLAG_VELOCITY`] is set.
    pub speed: f64,
    /// Heading (rad), when [`FLAG_VELOCITY`] is set.
    pub heading: f64,
}

impl Observation {
    /// A timestamped position.
    pub fn position(t: f64, x: f64, y: f64) -> Self {
        Observation {
            agent: 0,
            flags: 0,
            t,
            x,
            y,
            speed: 0.0,
            heading: 0.0,
        }
    }

    /// A timestamped position with the tracker's speed and heading.
    pub fn with_velocity(t: f64, x: f64, y: f64, speed: f64, heading: f64) -> Self {
        Observation {
            agent: 0,
            flags: FLAG_VELOCITY,
            t,
            x,
            y,
            speed,
            heading,
        }
    }
}

/// Fixed part of a response (the iceoryx2 response user header).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ZeroCopySend)]
#[type_name("cliff.protocol.v2.ResponseHeader")]
#[repr(C)]
pub struct ResponseHeader {
    /// The daemon's [`PROTOCOL_VERSION`].
    pub version: u32,
    /// A [`Status`] code.
    pub status: u32,
    /// The request's id.
    pub request_id: u64,
    /// Agents in the batch (0 when rejected).
    pub agents: u32,
    /// Samples per agent.
    pub k: u32,
    /// Steps per sample.
    pub steps: u32,
    /// For a rejection: the agent it concerns, or `u32::MAX`.
    pub agent: u32,
    /// For a rejection: the row (within the agent) it concerns, or `u32::MAX`.
    pub row: u32,
    /// For a rejection: the [`Field`] code it concerns.
    pub field: u32,
    /// For a rejection over a limit: the limit. For a batch: how many others compete for
    /// the daemon (see [`ResponseHeader::busy`]).
    pub limit: u32,
    /// How long (us) the daemon keeps polling for requests after this response before
    /// it sleeps on its event (0: not said). A request sent within this time finds it
    /// awake; a later one has to wake it, and a [`WaitMode::Hybrid`](crate::WaitMode)
    /// client then sleeps at once instead of spinning.
    pub awake_us: u32,
    /// For a batch: [`FLAG_SCORES`] when the payload carries the scores.
    pub flags: u32,
    /// Zero (keeps the header free of padding).
    pub reserved: u32,
}

impl ResponseHeader {
    /// For a batch: how many others compete for the daemon: the requests it had in
    /// progress when it answered, plus the other connected clients when clients outnumber
    /// the cores (0: this client has it to itself). A [`WaitMode::Hybrid`](crate::WaitMode)
    /// client spins only while this is 0: when requests queue up or clients outnumber
    /// cores, the daemon needs the cores that spinning clients would take.
    pub fn busy(&self) -> u32 {
        if self.status == Status::Ok as u32 {
            self.limit
        } else {
            0
        }
    }

    /// True when the payload carries the scores ([`FLAG_SCORES`]).
    pub fn has_scores(&self) -> bool {
        self.flags & FLAG_SCORES != 0
    }

    /// Number of `u32` words of the payload for this header's shape (and scores).
    pub fn payload_words(&self) -> usize {
        payload_words(
            self.agents as usize,
            self.k as usize,
            self.steps as usize,
            self.has_scores(),
        )
    }
}

/// `u32` words of a response payload: `2` per point plus one length per sample, plus
/// one score per sample when `scores`.
pub fn payload_words(agents: usize, k: usize, steps: usize, scores: bool) -> usize {
    let samples = agents * k;
    samples * steps * 2 + samples + if scores { samples } else { 0 }
}

/// Outcome of a request, as sent in [`ResponseHeader::status`].
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
    /// The method code is not one of [`METHOD_CLIFF`], [`METHOD_CVM`],
    /// [`METHOD_IMPROVED`] (or the heading rule code is unknown).
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
        }
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Which value a rejection concerns ([`ResponseHeader::field`]).
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

    /// Read a rejection from a response header (`None` when the status is OK).
    pub fn from_header(h: &ResponseHeader) -> Option<Rejection> {
        let status = Status::from_code(h.status).unwrap_or(Status::Internal);
        if status == Status::Ok {
            return None;
        }
        let opt = |v: u32| (v != u32::MAX).then_some(v);
        Some(Rejection {
            status,
            agent: opt(h.agent),
            row: opt(h.row),
            field: Field::from_code(h.field),
            limit: h.limit,
        })
    }

    /// Write the rejection into a response header (shape zero).
    pub fn write_to(&self, h: &mut ResponseHeader) {
        h.status = self.status.code();
        h.agents = 0;
        h.k = 0;
        h.steps = 0;
        h.agent = self.agent.unwrap_or(u32::MAX);
        h.row = self.row.unwrap_or(u32::MAX);
        h.field = self.field as u32;
        h.limit = self.limit;
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

/// Per-request limits of a daemon (and of [`decode_request`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Agents per request.
    pub max_agents: u32,
    /// Samples per agent.
    pub max_k: u32,
    /// Steps per sample.
    pub max_steps: u32,
    /// History rows per agent (at most [`MAX_HISTORY`]).
    pub max_history: u32,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_agents: 32,
            max_k: 50,
            max_steps: 100,
            max_history: MAX_HISTORY,
        }
    }
}

impl Limits {
    /// The largest response payload (in `u32` words) these limits allow (with scores).
    pub fn max_payload_words(&self) -> usize {
        payload_words(
            self.max_agents as usize,
            self.max_k as usize,
            self.max_steps as usize,
            true,
        )
    }

    /// The most positions of CLiFF-LHMP's cost one request may ask for:
    /// `max_agents x max_k x max_steps`. A request whose method costs a multiple of
    /// CLiFF-LHMP per position ([`cliff::predict::preset::cost_factor`]: 10 for the
    /// improved preset, its 5 candidates per kept sample and its follow draw) may hold
    /// that many positions
    /// divided by the factor.
    pub fn max_cost(&self) -> u64 {
        self.max_agents as u64 * self.max_k as u64 * self.max_steps as u64
    }
}

/// Reusable buffers for [`decode_request`]: sized once, then no allocation per request.
#[derive(Debug, Clone)]
pub struct DecodeScratch {
    times: Vec<f64>,
    positions: Vec<DVec2>,
    speeds: Vec<f64>,
    headings: Vec<f64>,
    states: Vec<State>,
}

impl DecodeScratch {
    /// Buffers for requests within `limits`.
    pub fn new(limits: &Limits) -> Self {
        let h = limits.max_history.min(MAX_HISTORY) as usize;
        DecodeScratch {
            times: Vec::with_capacity(h),
            positions: Vec::with_capacity(h),
            speeds: Vec::with_capacity(h),
            headings: Vec::with_capacity(h),
            states: Vec::with_capacity(limits.max_agents as usize),
        }
    }

    /// The agents' start states decoded by the last successful [`decode_request`].
    pub fn states(&self) -> &[State] {
        &self.states
    }
}

fn finite(v: f64) -> bool {
    v.is_finite()
}

/// A validated predict request: what [`decode_request`] returns (the agents' start
/// states are in the [`DecodeScratch`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decoded {
    /// The prediction parameters, as asked (a preset method such as `Improved` is
    /// resolved by the predictor).
    pub params: Params,
    /// The options beyond the paper, as asked (all off for a request that asks for
    /// none), except `scores`: whether the response carries scores, i.e. the request
    /// set [`FLAG_SCORES`] or its method's preset scores its samples (`Improved`).
    pub options: Options,
    /// Which map of the time of day the request asks for.
    pub map_time: MapTime,
}

impl Decoded {
    /// The payload words of the response to this request for `agents` agents.
    pub fn payload_words(&self, agents: usize) -> usize {
        payload_words(
            agents,
            self.params.k,
            self.params.steps(),
            self.options.scores,
        )
    }
}

/// Validate a predict request and decode its parameters; the agents' start states are
/// left in `scratch` ([`DecodeScratch::states`]). Checks, in order: version, kind,
/// method and heading rule, flags and time mode, parameters and options (finite, then
/// in range), `k`, steps, agents (and the cost of a method dearer than CLiFF-LHMP),
/// then every row. The map name is checked by the caller (who holds the maps).
///
/// Each agent starts at its last row's position and time; its speed and heading come
/// from the speed/heading columns when its rows carry them, else from the positions
/// ([`cliff::motion`], sigma [`DEFAULT_SIGMA`]).
pub fn decode_request(
    h: &RequestHeader,
    rows: &[Observation],
    limits: &Limits,
    scratch: &mut DecodeScratch,
) -> Result<Decoded, Rejection> {
    use Status::*;
    scratch.states.clear();
    if h.version != PROTOCOL_VERSION {
        return Err(Rejection::over(
            BadVersion,
            Field::Version,
            PROTOCOL_VERSION,
        ));
    }
    if h.kind != KIND_PREDICT {
        return Err(Rejection::new(UnknownKind, Field::None));
    }
    let Some(method) = method_from_code(h.method) else {
        return Err(Rejection::new(UnknownMethod, Field::Method));
    };
    let heading = match h.heading_rule {
        HEADING_CIRCULAR_MEAN => HeadingRule::CircularMean,
        HEADING_PAPER => HeadingRule::Paper,
        _ => return Err(Rejection::new(UnknownMethod, Field::HeadingRule)),
    };
    if h.flags & !KNOWN_FLAGS != 0 {
        return Err(Rejection::new(BadValue, Field::Flags));
    }
    let map_time = MapTime::from_wire(h.time_mode, h.time)?;
    for (v, f) in [
        (h.dt, Field::Dt),
        (h.horizon, Field::Horizon),
        (h.beta, Field::Beta),
        (h.radius, Field::Radius),
        (h.speed_beta, Field::SpeedBeta),
        (h.coast, Field::Coast),
    ] {
        if !finite(v) {
            return Err(Rejection::new(NonFinite, f));
        }
    }
    if h.dt <= 0.0 {
        return Err(Rejection::new(BadValue, Field::Dt));
    }
    if h.horizon < 0.0 {
        return Err(Rejection::new(BadValue, Field::Horizon));
    }
    if h.beta < 0.0 {
        return Err(Rejection::new(BadValue, Field::Beta));
    }
    if h.radius <= 0.0 {
        return Err(Rejection::new(BadValue, Field::Radius));
    }
    if h.speed_beta < 0.0 {
        return Err(Rejection::new(BadValue, Field::SpeedBeta));
    }
    if h.coast < 0.0 || h.coast > h.horizon {
        return Err(Rejection::new(BadValue, Field::Coast));
    }
    if h.k == 0 || h.k > limits.max_k {
        return Err(Rejection::over(BadK, Field::K, limits.max_k));
    }
    let ratio = h.horizon / h.dt;
    let steps = if ratio.is_finite() && ratio < (limits.max_steps as f64 + 2.0) {
        cliff::predict::steps_for(h.horizon, h.dt)
    } else {
        usize::MAX
    };
    if steps == 0 || steps > limits.max_steps as usize {
        return Err(Rejection::over(BadSteps, Field::Steps, limits.max_steps));
    }
    if h.agents == 0 || h.agents > limits.max_agents {
        return Err(Rejection::over(BadAgents, Field::Agents, limits.max_agents));
    }
    let params = Params {
        method,
        k: h.k as usize,
        dt: h.dt,
        horizon: h.horizon,
        beta: h.beta,
        radius: h.radius,
        seed: h.seed,
        heading,
    };
    let mut options = h.options();
    let factor = cost_factor(&params, &options) as u64;
    if factor > 1 {
        // the most agents of this k and steps within the cost of the largest request
        let per_agent = h.k as u64 * steps as u64 * factor;
        let most = (limits.max_cost() / per_agent).min(limits.max_agents as u64) as u32;
        if h.agents > most {
            return Err(Rejection::over(BadAgents, Field::Agents, most));
        }
    }
    let max_history = limits.max_history.min(MAX_HISTORY) as usize;

    let mut start = 0usize;
    for a in 0..h.agents {
        // the run of rows of agent `a`
        if rows.get(start).map(|o| o.agent) != Some(a) {
            return Err(Rejection {
                agent: Some(a),
                ..Rejection::new(BadLayout, Field::Agents)
            });
        }
        let mut end = start;
        while end < rows.len() && rows[end].agent == a {
            end += 1;
        }
        let run = &rows[start..end];
        if run.len() > max_history {
            return Err(Rejection {
                agent: Some(a),
                ..Rejection::over(HistoryTooLong, Field::None, max_history as u32)
            });
        }
        let state = agent_state(a, run, scratch_bufs(scratch))?;
        scratch.states.push(state);
        start = end;
    }
    if let Some(extra) = rows.get(start) {
        // rows after the last agent, or an agent index out of order
        return Err(Rejection {
            agent: Some(extra.agent),
            ..Rejection::new(BadLayout, Field::Agents)
        });
    }
    options.scores = scores_in_response(&params, &options);
    Result::Ok(Decoded {
        params,
        options,
        map_time,
    })
}

type Bufs<'a> = (
    &'a mut Vec<f64>,
    &'a mut Vec<DVec2>,
    &'a mut Vec<f64>,
    &'a mut Vec<f64>,
);

fn scratch_bufs(s: &mut DecodeScratch) -> Bufs<'_> {
    (
        &mut s.times,
        &mut s.positions,
        &mut s.speeds,
        &mut s.headings,
    )
}

/// The start state of agent `a` from its rows (already grouped, at most MAX_HISTORY).
fn agent_state(a: u32, run: &[Observation], bufs: Bufs<'_>) -> Result<State, Rejection> {
    use Status::*;
    let (times, positions, speeds, headings) = bufs;
    let with_velocity = run[0].flags & FLAG_VELOCITY != 0;
    let need = if with_velocity { 1 } else { 2 };
    if run.len() < need {
        return Err(Rejection {
            agent: Some(a),
            ..Rejection::over(HistoryTooShort, Field::None, need as u32)
        });
    }
    times.clear();
    positions.clear();
    speeds.clear();
    headings.clear();
    for (i, o) in run.iter().enumerate() {
        let row = i as u32;
        if (o.flags & FLAG_VELOCITY != 0) != with_velocity {
            return Err(Rejection::at(BadLayout, Field::Speed, a, row));
        }
        if !finite(o.t) {
            return Err(Rejection::at(NonFinite, Field::Time, a, row));
        }
        if !(finite(o.x) && finite(o.y)) {
            return Err(Rejection::at(NonFinite, Field::Position, a, row));
        }
        if with_velocity {
            if !finite(o.speed) {
                return Err(Rejection::at(NonFinite, Field::Speed, a, row));
            }
            if !finite(o.heading) {
                return Err(Rejection::at(NonFinite, Field::Heading, a, row));
            }
            if o.speed < 0.0 {
                return Err(Rejection::at(BadValue, Field::Speed, a, row));
            }
            speeds.push(o.speed);
            headings.push(o.heading);
        }
        if i > 0 && o.t <= run[i - 1].t {
            return Err(Rejection::at(HistoryNotIncreasing, Field::Time, a, row));
        }
        times.push(o.t);
        positions.push(DVec2::new(o.x, o.y));
    }
    let v = if with_velocity {
        velocity_from_speed_angle(speeds, headings, DEFAULT_SIGMA)
    } else {
        velocity_from_positions(times, positions, DEFAULT_SIGMA)
    };
    // Everything the velocity functions check was checked above; a failure here would
    // be a disagreement between the two, reported rather than unwrapped.
    let v = v.map_err(|_| Rejection::at(BadLayout, Field::None, a, u32::MAX))?;
    if !(v.speed.is_finite() && v.heading.is_finite()) {
        // e.g. positions so far apart in so little time that the speed overflows
        return Err(Rejection::at(NonFinite, Field::Speed, a, u32::MAX));
    }
    let last = run[run.len() - 1];
    Result::Ok(State {
        position: DVec2::new(last.x, last.y),
        speed: v.speed,
        heading: v.heading,
        time: last.t,
    })
}

/// The in-process reference: decodes a request exactly as the daemon does and predicts
/// into a reusable [`TrajectoryBatch`]. The same map, request and seed give the same
/// bytes as the daemon's response.
///
/// ```
/// use cliff::map::CliffMap;
/// use cliff::predict::Params;
/// use cliff_client::protocol::LocalPredictor;
/// use cliff_client::{Observation, Request};
///
/// let map = CliffMap::demo();
/// let mut request = Request::new("demo", &Params { k: 5, horizon: 4.0, ..Params::default() }).unwrap();
/// // one person walking east along the demo hall's corridor, observed at 2.5 Hz
/// request.add_agent((0..4).map(|i| Observation::position(0.4 * i as f64, -10.0 + 0.5 * i as f64, 0.5)));
/// let mut local = LocalPredictor::default();
/// let batch = local.predict(&map, request.header(), request.rows()).unwrap();
/// assert_eq!(batch.shape(), (1, 5, 10)); // 1 agent, 5 samples, 4 s at 0.4 s
/// assert!(batch.sample(0, 0)[0][0] > -8.5); // moving east from x = -8.5
/// ```
#[derive(Debug, Clone)]
pub struct LocalPredictor {
    limits: Limits,
    scratch: DecodeScratch,
    batch: TrajectoryBatch,
}

impl Default for LocalPredictor {
    fn default() -> Self {
        Self::new(Limits::default())
    }
}

impl LocalPredictor {
    /// A predictor that applies `limits` (use the daemon's to get the same rejections).
    pub fn new(limits: Limits) -> Self {
        LocalPredictor {
            limits,
            scratch: DecodeScratch::new(&limits),
            batch: TrajectoryBatch::new(),
        }
    }

    /// Decode and predict with the request's options
    /// ([`cliff::predict::predict_with`]); the result stays in [`batch`](Self::batch),
    /// with [`TrajectoryBatch::scores`] when the response would carry them. The
    /// request's [`MapTime`] is validated and `map` used whatever it says: for a
    /// time-of-day set, pass the map the daemon would pick ([`MapTime::map_in`]).
    pub fn predict(
        &mut self,
        map: &CliffMap,
        header: &RequestHeader,
        rows: &[Observation],
    ) -> Result<&TrajectoryBatch, Rejection> {
        let d = decode_request(header, rows, &self.limits, &mut self.scratch)?;
        let states = &self.scratch.states;
        predict_with(map, states, &d.params, &d.options, &mut self.batch)
            .map_err(|_| Rejection::new(Status::Internal, Field::None))?;
        Ok(&self.batch)
    }

    /// The last batch.
    pub fn batch(&self) -> &TrajectoryBatch {
        &self.batch
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(agents: u32) -> RequestHeader {
        let mut h = RequestHeader::from_params(&Params::default());
        h.agents = agents;
        h.set_map_name("demo").unwrap();
        h
    }

    fn walk(agent: u32, n: usize) -> Vec<Observation> {
        (0..n)
            .map(|i| Observation {
                agent,
                ..Observation::position(i as f64 * 0.4, -10.0 + i as f64 * 0.5, 0.5)
            })
            .collect()
    }

    fn reject(h: &RequestHeader, rows: &[Observation]) -> Rejection {
        let mut s = DecodeScratch::new(&Limits::default());
        decode_request(h, rows, &Limits::default(), &mut s).unwrap_err()
    }

    #[test]
    fn a_good_request_decodes_to_the_last_position_and_observed_velocity() {
        let mut rows = walk(0, 4);
        rows.extend(walk(1, 3));
        rows.push(Observation {
            agent: 2,
            ..Observation::with_velocity(1.0, 2.0, 3.0, 1.5, std::f64::consts::FRAC_PI_2)
        });
        let mut s = DecodeScratch::new(&Limits::default());
        let d = decode_request(&header(3), &rows, &Limits::default(), &mut s).unwrap();
        let p = d.params;
        assert_eq!((p.k, p.steps()), (20, 30));
        assert_eq!((d.options, d.map_time), (Options::default(), MapTime::Now));
        let st = s.states();
        assert_eq!(st.len(), 3);
        // 0.5 m per 0.4 s eastwards
        assert!((st[0].speed - 1.25).abs() < 1e-12 && st[0].heading.abs() < 1e-12);
        assert_eq!(st[0].position, DVec2::new(-8.5, 0.5));
        assert!((st[0].time - 1.2).abs() < 1e-12);
        assert_eq!(st[1].position, DVec2::new(-9.0, 0.5));
        assert!((st[2].speed - 1.5).abs() < 1e-12);
        assert!((st[2].heading - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // every method's code decodes to the method
        for method in [Method::Cliff, Method::Cvm, Method::Improved] {
            let mut h = RequestHeader::from_params(&Params {
                method,
                ..Params::default()
            });
            h.agents = 3;
            let p = decode_request(&h, &rows, &Limits::default(), &mut s).unwrap();
            assert_eq!(p.params.method, method);
            assert_eq!(method_from_code(method_code(method)), Some(method));
        }
        assert_eq!(method_from_code(3), None);
    }

    #[test]
    fn every_kind_of_bad_request_gets_its_status() {
        let rows = walk(0, 3);
        let bad = |f: &dyn Fn(&mut RequestHeader)| {
            let mut h = header(1);
            f(&mut h);
            reject(&h, &rows)
        };
        let r = bad(&|h| h.version = 1);
        assert_eq!(
            (r.status, r.field, r.limit),
            (Status::BadVersion, Field::Version, PROTOCOL_VERSION)
        );
        assert_eq!(
            r.to_string(),
            "bad-version (version): the daemon speaks protocol version 2"
        );
        assert_eq!(bad(&|h| h.version = 99).status, Status::BadVersion);
        assert_eq!(bad(&|h| h.kind = 7).status, Status::UnknownKind);
        assert_eq!(bad(&|h| h.method = 5).status, Status::UnknownMethod);
        let r = bad(&|h| h.dt = f64::NAN);
        assert_eq!((r.status, r.field), (Status::NonFinite, Field::Dt));
        let r = bad(&|h| h.radius = f64::INFINITY);
        assert_eq!((r.status, r.field), (Status::NonFinite, Field::Radius));
        assert_eq!(bad(&|h| h.dt = -0.1).status, Status::BadValue);
        assert_eq!(bad(&|h| h.k = 0).status, Status::BadK);
        let r = bad(&|h| h.k = 51);
        assert_eq!((r.status, r.limit), (Status::BadK, 50));
        assert_eq!(bad(&|h| h.horizon = 0.1).status, Status::BadSteps);
        assert_eq!(bad(&|h| h.horizon = 1e300).status, Status::BadSteps);
        assert_eq!(bad(&|h| h.dt = 1e-300).status, Status::BadSteps);
        assert_eq!(bad(&|h| h.agents = 0).status, Status::BadAgents);
        assert_eq!(bad(&|h| h.agents = 33).status, Status::BadAgents);
        // the fields of version 2, each named
        let named = |f: &dyn Fn(&mut RequestHeader)| {
            let r = bad(f);
            (r.status, r.field)
        };
        use Status::{BadValue, NonFinite};
        assert_eq!(
            named(&|h| h.speed_beta = f64::NAN),
            (NonFinite, Field::SpeedBeta)
        );
        assert_eq!(
            named(&|h| h.speed_beta = -0.5),
            (BadValue, Field::SpeedBeta)
        );
        assert_eq!(
            named(&|h| h.coast = f64::INFINITY),
            (NonFinite, Field::Coast)
        );
        assert_eq!(named(&|h| h.coast = -1.0), (BadValue, Field::Coast));
        // coast at most the horizon (12 s)
        assert_eq!(named(&|h| h.coast = 12.5), (BadValue, Field::Coast));
        assert_eq!(named(&|h| h.flags = 2), (BadValue, Field::Flags));
        assert_eq!(named(&|h| h.flags = 1 << 31), (BadValue, Field::Flags));
        assert_eq!(named(&|h| h.time_mode = 3), (BadValue, Field::TimeMode));
        assert_eq!(named(&|h| h.time = f64::NAN), (NonFinite, Field::MapTime));
        let r = bad(&|h| {
            h.time_mode = TIME_AT;
            h.time = f64::NEG_INFINITY
        });
        assert_eq!((r.status, r.field), (NonFinite, Field::MapTime));
        assert_eq!(r.to_string(), "non-finite (map time)");
        // and the good values of every new field decode
        let mut h = header(1);
        h.speed_beta = 2.0;
        h.coast = 12.0;
        h.flags = FLAG_SCORES;
        h.set_map_time(MapTime::At(1.35e9));
        let mut s = DecodeScratch::new(&Limits::default());
        let d = decode_request(&h, &rows, &Limits::default(), &mut s).unwrap();
        let want = Options {
            speed_beta: 2.0,
            coast: 12.0,
            scores: true,
            ..Options::default()
        };
        assert_eq!((d.options, d.map_time), (want, MapTime::At(1.35e9)));
        h.set_map_time(MapTime::AllDay);
        let d = decode_request(&h, &rows, &Limits::default(), &mut s).unwrap();
        assert_eq!(d.map_time, MapTime::AllDay);
        assert_eq!(d.payload_words(1), payload_words(1, 20, 30, true));
        // rows
        let h = header(1);
        let r = reject(&h, &walk(0, 1));
        assert_eq!((r.status, r.agent), (Status::HistoryTooShort, Some(0)));
        let mut rows = walk(0, 3);
        rows[2].t = rows[1].t;
        let r = reject(&h, &rows);
        assert_eq!(
            (r.status, r.agent, r.row),
            (Status::HistoryNotIncreasing, Some(0), Some(2))
        );
        let mut rows = walk(0, 3);
        rows[1].y = f64::NAN;
        let r = reject(&h, &rows);
        assert_eq!(
            (r.status, r.field, r.row),
            (Status::NonFinite, Field::Position, Some(1))
        );
        let r = reject(&h, &walk(0, 65));
        assert_eq!((r.status, r.limit), (Status::HistoryTooLong, 64));
        // layout: two agents announced, one given; agent 1 before agent 0; extra rows
        assert_eq!(reject(&header(2), &walk(0, 3)).status, Status::BadLayout);
        assert_eq!(reject(&h, &walk(1, 3)).status, Status::BadLayout);
        let mut rows = walk(0, 3);
        rows.extend(walk(1, 2));
        assert_eq!(reject(&h, &rows).status, Status::BadLayout);
        // mixed velocity flags within one agent
        let mut rows = walk(0, 3);
        rows[1].flags = FLAG_VELOCITY;
        assert_eq!(reject(&h, &rows).status, Status::BadLayout);
        // negative tracker speed
        let rows = [Observation::with_velocity(0.0, 0.0, 0.0, -1.0, 0.0)];
        let r = reject(&h, &rows);
        assert_eq!((r.status, r.field), (Status::BadValue, Field::Speed));
    }

    #[test]
    fn a_method_that_costs_more_may_hold_fewer_agents() {
        // k 50, 100 steps: the largest request of the default limits
        let improved = Params {
            method: Method::Improved,
            k: 50,
            horizon: 40.0,
            ..Params::default()
        };
        let factor = cost_factor(&improved, &Options::default());
        assert!(factor > 1, "the improved preset draws candidates");
        let most = (32 * 50 * 100 / (50 * 100 * factor)) as u32;
        let rows = |n: u32| (0..n).flat_map(|a| walk(a, 2)).collect::<Vec<_>>();
        let mut s = DecodeScratch::new(&Limits::default());
        let mut h = RequestHeader::from_params(&improved);
        h.set_map_name("demo").unwrap();
        h.agents = most + 1;
        let r = decode_request(&h, &rows(most + 1), &Limits::default(), &mut s).unwrap_err();
        assert_eq!(
            (r.status, r.field, r.limit),
            (Status::BadAgents, Field::Agents, most)
        );
        h.agents = most;
        assert!(decode_request(&h, &rows(most), &Limits::default(), &mut s).is_ok());
        // the paper's method: up to the limit on agents
        let mut h = RequestHeader::from_params(&Params {
            method: Method::Cliff,
            ..improved
        });
        h.agents = 32;
        assert!(decode_request(&h, &rows(32), &Limits::default(), &mut s).is_ok());
    }

    #[test]
    fn rejection_round_trips_through_the_response_header() {
        let r = Rejection::at(Status::NonFinite, Field::Time, 3, 7);
        let mut h = ResponseHeader::default();
        r.write_to(&mut h);
        assert_eq!(Rejection::from_header(&h), Some(r));
        assert_eq!(r.to_string(), "non-finite (time) at agent 3 row 7");
        for c in 0..21 {
            assert_eq!(Field::from_code(c) as u32, c);
        }
        assert_eq!(Field::from_code(21), Field::None);
        for c in 0..17 {
            let s = Status::from_code(c).unwrap();
            assert_eq!(s.code(), c);
            // the C ABI names every status as the Rust side does
            let name = unsafe { std::ffi::CStr::from_ptr(crate::ffi::cliff_status_name(c)) };
            assert_eq!(name.to_str().unwrap(), s.name());
        }
        assert_eq!(Status::from_code(17), None);
        let r = Rejection::over(Status::RadiusTooLarge, Field::Radius, 2000);
        assert_eq!(r.to_string(), "radius-too-large (radius), limit 2000 mm");
    }

    #[test]
    fn map_names_are_checked() {
        assert!(encode_map_name("demo").is_ok());
        assert!(encode_map_name("").is_err());
        assert!(encode_map_name(&"x".repeat(64)).is_err());
        assert!(encode_map_name(&"x".repeat(63)).is_ok());
        assert!(encode_map_name("a\0b").is_err());
        let mut h = RequestHeader::default();
        h.set_map_name("thor1").unwrap();
        assert_eq!(h.map_name(), b"thor1");
    }

    #[test]
    fn local_predictor_matches_the_core_predictor() {
        let map = CliffMap::demo();
        let rows = walk(0, 4);
        let mut lp = LocalPredictor::default();
        let mut h = header(1);
        h.seed = 7;
        let b = lp.predict(&map, &h, &rows).unwrap().clone();
        let mut s = DecodeScratch::new(&Limits::default());
        let p = decode_request(&h, &rows, &Limits::default(), &mut s)
            .unwrap()
            .params;
        let mut direct = TrajectoryBatch::new();
        cliff::predict::predict(&map, s.states(), &p, &mut direct).unwrap();
        let bits = |t: &TrajectoryBatch| {
            t.positions()
                .iter()
                .flatten()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(b.shape(), direct.shape());
        assert_eq!(b.lens(), direct.lens());
        assert_eq!(bits(&b), bits(&direct));
        assert!(b.scores().is_empty());

        // with options and scores: the bytes of predict_with
        let options = Options {
            speed_beta: 2.0,
            coast: 4.0,
            scores: true,
            ..Options::default()
        };
        h.set_options(&options);
        h.set_map_time(MapTime::At(3600.0));
        let b = lp.predict(&map, &h, &rows).unwrap().clone();
        let mut direct = TrajectoryBatch::new();
        predict_with(&map, s.states(), &p, &options, &mut direct).unwrap();
        assert_eq!(b.lens(), direct.lens());
        assert_eq!(bits(&b), bits(&direct));
        assert_eq!(b.scores().len(), 20);
        let score_bits =
            |t: &TrajectoryBatch| t.scores().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(score_bits(&b), score_bits(&direct));
        assert!(b.scores().iter().all(|v| v.is_finite()));
        assert!(b.scores().iter().any(|v| *v != b.scores()[0]));
    }

    /// Random bit patterns and random near-valid requests: decoding never panics, and
    /// whatever it accepts predicts without error into a buffer of the announced shape.
    #[test]
    fn random_requests_never_panic_and_accepted_ones_predict() {
        use rand::{RngExt, SeedableRng};
        let map = CliffMap::demo();
        let limits = Limits {
            max_agents: 4,
            max_k: 5,
            max_steps: 12,
            max_history: 8,
        };
        let mut s = DecodeScratch::new(&limits);
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(17);
        let mut accepted = 0;
        let mut with_options = 0;
        let specials = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.4,
            1e-300,
            1e300,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            f64::MAX,
        ];
        for _ in 0..20_000 {
            // mostly plausible values, sometimes special or random bit patterns
            let num = |rng: &mut rand_xoshiro::Xoshiro256PlusPlus, near: f64| -> f64 {
                match rng.random_range(0..40) {
                    0 => specials[rng.random_range(0..specials.len())],
                    1 => f64::from_bits(rng.random()),
                    _ => near * rng.random_range(0.5..1.5),
                }
            };
            let agents = rng.random_range(0..6u32);
            let mut h = header(if rng.random_ratio(1, 20) {
                rng.random_range(0..8)
            } else {
                agents
            });
            h.version = if rng.random_ratio(1, 40) {
                rng.random()
            } else {
                PROTOCOL_VERSION
            };
            h.kind = if rng.random_ratio(1, 40) {
                rng.random()
            } else {
                KIND_PREDICT
            };
            h.method = if rng.random_ratio(1, 40) {
                rng.random()
            } else {
                rng.random_range(0..3)
            };
            h.heading_rule = if rng.random_ratio(1, 40) {
                7
            } else {
                rng.random_range(0..2)
            };
            h.k = rng.random_range(0..7);
            h.dt = num(&mut rng, 0.4);
            h.horizon = num(&mut rng, 3.0);
            h.beta = num(&mut rng, 1.0);
            h.radius = num(&mut rng, 0.7);
            h.seed = rng.random();
            if rng.random_ratio(1, 2) {
                h.speed_beta = num(&mut rng, 2.0);
            }
            if rng.random_ratio(1, 2) {
                h.coast = num(&mut rng, 1.5);
            }
            h.flags = if rng.random_ratio(1, 40) {
                rng.random()
            } else {
                rng.random_range(0..2)
            };
            h.time_mode = if rng.random_ratio(1, 40) {
                rng.random()
            } else {
                rng.random_range(0..3)
            };
            h.time = num(&mut rng, 1.3e9);
            let mut rows = Vec::new();
            for a in 0..agents {
                let flags = rng.random_range(0..2);
                let mut t = num(&mut rng, 10.0);
                for _ in 0..rng.random_range(1..10) {
                    t += num(&mut rng, 0.4);
                    rows.push(Observation {
                        agent: if rng.random_ratio(1, 100) {
                            rng.random()
                        } else {
                            a
                        },
                        flags: if rng.random_ratio(1, 100) {
                            1 - flags
                        } else {
                            flags
                        },
                        t,
                        x: num(&mut rng, -5.0),
                        y: num(&mut rng, 1.0),
                        speed: num(&mut rng, 1.2),
                        heading: num(&mut rng, 3.0),
                    });
                }
            }
            if let Result::Ok(d) = decode_request(&h, &rows, &limits, &mut s) {
                accepted += 1;
                let (p, o) = (d.params, d.options);
                if !o.is_paper() {
                    with_options += 1;
                }
                let st = s.states();
                assert!(st.len() <= 4 && p.k <= 5 && p.steps() <= 12 && p.steps() > 0);
                assert!(o.coast <= p.horizon);
                let mut pos = vec![[0f32; 2]; st.len() * p.k * p.steps()];
                let mut lens = vec![0u32; st.len() * p.k];
                let mut scores = vec![0f32; if o.scores { st.len() * p.k } else { 0 }];
                let out = cliff::predict::BatchMut {
                    positions: &mut pos,
                    lens: &mut lens,
                };
                cliff::predict::predict_into_with(&map, st, &p, &o, out, &mut scores)
                    .expect("accepted requests predict");
            }
        }
        assert!(accepted > 100, "only {accepted} random requests were valid");
        assert!(with_options > 50, "only {with_options} with options");
    }
}
