//! Why a call failed: the [`Error`] of every client call.

use std::fmt;
use std::time::Duration;

use crate::protocol::{PROTOCOL_VERSION, Rejection, Status};

/// Why a call failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// No daemon serves this service (never started, or stopped).
    #[error(
        "no cliffd daemon serves '{service}' (is it running, with the same --service and --prefix? see docs/troubleshooting.md)"
    )]
    NoDaemon {
        /// The service name.
        service: String,
    },
    /// The daemon died or shut down while the request was in flight.
    #[error("the cliffd daemon serving '{service}' is gone (died or shut down mid-request)")]
    DaemonGone {
        /// The service name.
        service: String,
    },
    /// No response within the deadline.
    #[error("no response within the deadline of {deadline:?}")]
    Deadline {
        /// The deadline that passed.
        deadline: Duration,
    },
    /// The daemon refused the request.
    #[error("request rejected by cliffd: {0}")]
    Rejected(Rejection),
    /// The request cannot be sent as it is (caught before sending).
    #[error("invalid request: {0}")]
    InvalidRequest(String),
    /// The response breaks the protocol, or the daemon speaks another protocol version
    /// (a daemon of version 1 found at connect time; a daemon of a later version
    /// answers `bad-version`, which is reported as this).
    #[error("protocol: {0}")]
    Protocol(String),
    /// iceoryx2 failed (shared memory, permissions, limits).
    #[error("iceoryx2: {0}")]
    Ipc(String),
    /// zenoh failed (configuration, session) or answered with an error.
    #[error("zenoh: {0}")]
    Zenoh(String),
}

impl Error {
    /// The rejection status, when the daemon refused the request.
    pub fn status(&self) -> Option<Status> {
        match self {
            Error::Rejected(r) => Some(r.status),
            _ => None,
        }
    }
}

/// The error for a daemon that speaks another protocol version.
pub(crate) fn version_mismatch(daemon: u32) -> Error {
    Error::Protocol(format!(
        "the daemon speaks protocol version {daemon}, this client {PROTOCOL_VERSION} (run a daemon and clients of one release; see docs/troubleshooting.md)"
    ))
}

/// An iceoryx2 failure: what failed and iceoryx2's error.
pub(crate) fn ipc_err(what: &str, e: impl fmt::Debug) -> Error {
    Error::Ipc(format!("{what}: {e:?}"))
}
