//! What daemon and clients share on one host besides the wire types: the default
//! service name, the event services' names, the iceoryx2 configuration (prefix) and the
//! iceoryx2 service types.

use iceoryx2::prelude::*;

use crate::protocol::{Observation, RequestHeader, ResponseHeader};

/// The service name `cliffd` serves on by default.
pub const DEFAULT_SERVICE: &str = "cliff/predict";

/// Environment variable naming the iceoryx2 prefix (namespace) used when
/// [`ClientOptions::prefix`](crate::ClientOptions::prefix) is not set; `cliffd --prefix` reads it
/// too.
pub const PREFIX_ENV: &str = "CLIFF_IPC_PREFIX";

/// Name of the event service a client signals after sending a request (wakes a
/// sleeping daemon).
pub fn request_event_name(service: &str) -> String {
    format!("{service}/requests")
}

/// Name of the event service the daemon signals a blocking client on.
pub fn response_event_name(service: &str) -> String {
    format!("{service}/responses")
}

/// The iceoryx2 configuration for an optional prefix (namespace): processes with
/// different prefixes never see each other. Starts from iceoryx2's built-in defaults
/// (not a config file), so that daemon and clients always agree.
pub fn iceoryx_config(prefix: Option<&str>) -> Result<Config, String> {
    let mut config = Config::default();
    if let Some(p) = prefix {
        config.global.prefix = FileName::new(p.as_bytes())
            .map_err(|e| format!("iceoryx2 prefix '{p}' is not a valid file name: {e:?}"))?;
    }
    Ok(config)
}

/// The prefix from [`PREFIX_ENV`], if set and not empty.
pub fn prefix_from_env() -> Option<String> {
    std::env::var(PREFIX_ENV).ok().filter(|s| !s.is_empty())
}

/// The iceoryx2 service variant of a [`Client`](crate::Client)'s ports: `ipc_threadsafe`, so that a
/// client can move to (or be shared with) another thread. It talks to a daemon on plain
/// `ipc` ports: both variants use the same shared-memory resources.
pub type ClientIpc = ipc_threadsafe::Service;

/// The iceoryx2 request-response service type of the protocol (`S`: the daemon's plain
/// `ipc` by default, [`ClientIpc`] for clients).
pub type PredictService<S = ipc::Service> =
    iceoryx2::service::port_factory::request_response::PortFactory<
        S,
        [Observation],
        RequestHeader,
        [u32],
        ResponseHeader,
    >;
