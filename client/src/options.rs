//! A client's settings: how it waits for responses ([`WaitMode`]) and its
//! [`ClientOptions`].

use std::fmt;
use std::time::Duration;

use crate::ipc::prefix_from_env;

/// How a client waits for its response.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WaitMode {
    /// Busy-poll until the response is there. Needs a core of its own: on a host with
    /// more busy threads than cores, use [`WaitMode::Hybrid`].
    Spin,
    /// Busy-poll for [`ClientOptions::spin`], then sleep on the daemon's event. When the daemon has
    /// gone to sleep since this client's last response (its responses say how long it stays awake;
    /// other clients' requests may have kept it awake since, which this client cannot see), sleep
    /// at once: the daemon has to be woken first, and a spinning client only delays that on a busy
    /// or virtualised host. Likewise when the daemon had other requests in progress at its last
    /// response ([`ResponseHeader::busy`](crate::ResponseHeader::busy)), or the last round trip
    /// took longer than the spin: with clients queueing, spinning clients take the cores the daemon
    /// needs (four spinning clients on two cores cost it a third of its throughput), and a response
    /// that has to wait for others is not worth a spin. A client alone keeps spinning.
    #[default]
    Hybrid,
    /// Sleep on the daemon's event at once.
    Block,
}

impl std::str::FromStr for WaitMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "spin" => Ok(WaitMode::Spin),
            "hybrid" | "spin-then-block" => Ok(WaitMode::Hybrid),
            "block" => Ok(WaitMode::Block),
            other => Err(format!(
                "unknown wait mode '{other}' (expected spin, hybrid or block)"
            )),
        }
    }
}

impl fmt::Display for WaitMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            WaitMode::Spin => "spin",
            WaitMode::Hybrid => "hybrid",
            WaitMode::Block => "block",
        })
    }
}

/// Settings of a [`Client`](crate::Client).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ClientOptions {
    /// How to wait for responses (default [`WaitMode::Hybrid`]).
    pub wait: WaitMode,
    /// How long [`WaitMode::Hybrid`] spins before it blocks (default 200 us).
    pub spin: Duration,
    /// Deadline of each call (default 1 s).
    pub deadline: Duration,
    /// iceoryx2 prefix (namespace); default: the [`PREFIX_ENV`](crate::PREFIX_ENV) variable, else
    /// iceoryx2's.
    pub prefix: Option<String>,
}

impl Default for ClientOptions {
    fn default() -> Self {
        ClientOptions {
            wait: WaitMode::Hybrid,
            spin: Duration::from_micros(200),
            deadline: Duration::from_secs(1),
            prefix: prefix_from_env(),
        }
    }
}
