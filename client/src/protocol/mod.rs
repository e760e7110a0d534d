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
//!
//! The files of this module (everything is re-exported here):
//!
//! * `codes.rs`: the protocol version, the service name, sizes, and the wire codes of
//!   kinds, methods, flags, time modes and heading rules;
//! * `request.rs`: [`RequestHeader`] and the [`Observation`] rows;
//! * `map_time.rs`: [`MapTime`], which map of the time of day a request asks for;
//! * `response.rs`: [`ResponseHeader`] and the size of a response payload;
//! * `status.rs`: [`Status`], [`Field`] and [`Rejection`];
//! * `limits.rs`: [`Limits`], a daemon's per-request limits;
//! * `validate.rs`: the request validation, [`decode_request`];
//! * `local.rs`: the in-process reference, [`LocalPredictor`];
//! * `observe.rs`: observe requests ([`KIND_OBSERVE`]) for a daemon that learns its
//!   map, [`validate_observe`] and the answer's counts, [`ObserveReply`].
//!
//! The same messages as little-endian bytes (for zenoh) are in [`crate::wire`].

mod codes;
mod limits;
mod local;
mod map_time;
mod observe;
mod request;
mod response;
mod status;
mod validate;

pub use codes::{
    FLAG_BASE_MAP, FLAG_SCORES, FLAG_TRACK_END, FLAG_VELOCITY, HEADING_CIRCULAR_MEAN,
    HEADING_PAPER, KIND_OBSERVE, KIND_PREDICT, KIND_RELOAD, KNOWN_FLAGS, MAP_NAME_BYTES,
    MAX_HISTORY, MAX_OBSERVE_ROWS, METHOD_CLIFF, METHOD_CVM, METHOD_CVM_LAST, METHOD_IMPROVED,
    METHOD_MOTION, PROTOCOL_VERSION, TIME_ALL_DAY, TIME_AT, TIME_NOW, ipc_service_name,
    method_code, method_from_code,
};
pub use limits::Limits;
pub use local::LocalPredictor;
pub use map_time::MapTime;
pub use observe::{ObserveReply, validate_observe};
pub use request::{Observation, RequestHeader, encode_map_name};
pub use response::{ResponseHeader, payload_words, scores_in_response};
pub use status::{Field, Rejection, Status};
pub use validate::{DecodeScratch, Decoded, decode_request};
