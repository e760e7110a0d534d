//! Serving requests: the [`Daemon`] and its loop. One part per file:
//!
//! * `daemon.rs`: the [`Daemon`] (maps, iceoryx2 services and ports, scheduler), its
//!   creation and what it reports;
//! * `run.rs`: the serving loop (poll, then sleep on the request event) and its
//!   housekeeping;
//! * `accept.rs`: requests in: validation against the loaded maps, handing accepted
//!   requests (local and remote) to the scheduler;
//! * `respond.rs`: responses out: response headers, rejections, the responses of
//!   finished predictions;
//! * `reload.rs`: map reloads and the answers to reload requests;
//! * `observe.rs`: observe requests, handed to the learning intake and answered at
//!   once;
//! * `old_clients.rs`: the `bad-version` answers to clients of protocol version 1;
//! * `ports.rs`: the iceoryx2 port and request types;
//! * `output.rs`: where a prediction goes (a shared-memory response or a zenoh reply);
//! * `stats.rs`: the daemon's counters, [`Stats`].

mod accept;
mod daemon;
mod observe;
mod old_clients;
mod output;
mod ports;
mod reload;
mod respond;
mod run;
mod stats;

pub use daemon::Daemon;
pub use stats::Stats;
