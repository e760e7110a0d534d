//! The wire codes of the protocol: its version and service name, the sizes, and the
//! numbers that stand for request kinds, methods, flags, time modes and heading rules.

use cliff::predict::Method;

/// Version of the wire protocol; a request with another version is answered with
/// [`Status::BadVersion`](super::Status::BadVersion) (its `limit` holds this version).
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

/// [`RequestHeader::kind`](super::RequestHeader::kind): predict trajectories.
pub const KIND_PREDICT: u32 = 0;
/// [`RequestHeader::kind`](super::RequestHeader::kind): reload every map from its file (answered
/// with an empty response; status [`Status::ReloadFailed`](super::Status::ReloadFailed) names the
/// first map that failed, which keeps its old version).
pub const KIND_RELOAD: u32 = 1;

/// [`RequestHeader::kind`](super::RequestHeader::kind): observations for a map the daemon
/// learns (`cliffd --learn`): the rows are tracked people's positions, each row's `agent`
/// their track id, answered with an empty response whose header counts the rows taken
/// ([`ObserveReply`](super::ObserveReply)). A daemon that does not know this kind
/// answers [`Status::UnknownKind`](super::Status::UnknownKind); see
/// [`validate_observe`](super::validate_observe).
pub const KIND_OBSERVE: u32 = 2;

/// The most rows one observe request may carry ([`KIND_OBSERVE`]); a daemon may accept
/// fewer (`cliffd --max-observe-rows`).
pub const MAX_OBSERVE_ROWS: u32 = 4096;

/// [`RequestHeader::method`](super::RequestHeader::method) for CLiFF-LHMP.
pub const METHOD_CLIFF: u32 = 0;
/// [`RequestHeader::method`](super::RequestHeader::method) for the constant-velocity model.
pub const METHOD_CVM: u32 = 1;
/// [`RequestHeader::method`](super::RequestHeader::method) for the improved method
/// (`Method::Improved`: CLiFF-LHMP with a preset of parameters and options, resolved by the
/// library, `cliff::predict::preset`; the preset's beta and options replace the request's).
pub const METHOD_IMPROVED: u32 = 2;
/// [`RequestHeader::method`](super::RequestHeader::method) for the learned motion model alone
/// (`Method::Motion`: the daemon's built-in model, from each agent's observed rows).
pub const METHOD_MOTION: u32 = 3;
/// [`RequestHeader::method`](super::RequestHeader::method) for constant velocity of the last
/// observed displacement (`Method::CvmLast`).
pub const METHOD_CVM_LAST: u32 = 4;

/// [`RequestHeader::flags`](super::RequestHeader::flags) and
/// [`ResponseHeader::flags`](super::ResponseHeader::flags) bit: the response carries a score per
/// sample after the lengths ([`cliff::predict::Options::scores`]). A response to
/// [`METHOD_IMPROVED`] always does (its preset scores the samples): read the response's flag.
pub const FLAG_SCORES: u32 = 1;
/// [`RequestHeader::flags`](super::RequestHeader::flags) bit: predict on the map as the daemon
/// loaded it, not on a version it learned since (`cliffd --learn`); the response's
/// [`map_version`](super::ResponseHeader::map_version) is then 0. A daemon from before
/// learning refuses the bit (`bad-value (flags)`).
pub const FLAG_BASE_MAP: u32 = 2;
/// Every [`RequestHeader::flags`](super::RequestHeader::flags) bit this version knows; a request
/// with another bit set is refused ([`Status::BadValue`](super::Status::BadValue),
/// [`Field::Flags`](super::Field::Flags)).
pub const KNOWN_FLAGS: u32 = FLAG_SCORES | FLAG_BASE_MAP;

/// [`RequestHeader::time_mode`](super::RequestHeader::time_mode): the map for the daemon's wall
/// clock when the request arrives (the default).
/// [`RequestHeader::time`](super::RequestHeader::time) is not used (but must be finite).
pub const TIME_NOW: u32 = 0;
/// [`RequestHeader::time_mode`](super::RequestHeader::time_mode): the map for
/// [`RequestHeader::time`](super::RequestHeader::time), seconds on the map's clock (unix time, as
/// the tracks the map was built from had it).
pub const TIME_AT: u32 = 1;
/// [`RequestHeader::time_mode`](super::RequestHeader::time_mode): the all-day map, whatever the
/// time.
pub const TIME_ALL_DAY: u32 = 2;

/// [`RequestHeader::heading_rule`](super::RequestHeader::heading_rule): the reference
/// implementation's circular mean.
pub const HEADING_CIRCULAR_MEAN: u32 = 0;
/// [`RequestHeader::heading_rule`](super::RequestHeader::heading_rule): the paper's formula.
pub const HEADING_PAPER: u32 = 1;

/// [`Observation::flags`](super::Observation::flags) bit: the row's `speed` and `heading` are set.
/// When every row of an agent has it, the observed velocity comes from these columns (the reference
/// rule); when none has it, from the timestamped positions.
pub const FLAG_VELOCITY: u32 = 1;

/// [`Observation::flags`](super::Observation::flags) bit, in observe requests only
/// ([`KIND_OBSERVE`]): the row is its track's last (the person left the tracker's view),
/// so the daemon learns the track now instead of waiting for it to go quiet, and it no
/// longer counts as open. Rows of the track sent again later are still recognised as
/// seen (for the track timeout).
pub const FLAG_TRACK_END: u32 = 2;

/// The wire code of a method ([`RequestHeader::method`](super::RequestHeader::method)).
pub fn method_code(method: Method) -> u32 {
    match method {
        Method::Cliff => METHOD_CLIFF,
        Method::Cvm => METHOD_CVM,
        Method::Improved => METHOD_IMPROVED,
        Method::Motion => METHOD_MOTION,
        Method::CvmLast => METHOD_CVM_LAST,
    }
}

/// The method of a wire code; `None` for an unknown code.
pub fn method_from_code(code: u32) -> Option<Method> {
    match code {
        METHOD_CLIFF => Some(Method::Cliff),
        METHOD_CVM => Some(Method::Cvm),
        METHOD_IMPROVED => Some(Method::Improved),
        METHOD_MOTION => Some(Method::Motion),
        METHOD_CVM_LAST => Some(Method::CvmLast),
        _ => None,
    }
}
