//! # cliff-client: talk to the `cliffd` prediction daemon over iceoryx2 shared memory
//!
//! The crate's modules, one part each:
//!
//! * [`protocol`]: the wire types (`#[repr(C)]`, versioned), the request validation
//!   shared with the daemon, and the in-process reference [`LocalPredictor`];
//! * [`legacy`]: version 1's types, with which a daemon answers old clients
//!   `bad-version`;
//! * [`wire`]: the same messages as little-endian bytes, for transports other than
//!   iceoryx2 (`docs/zenoh-protocol.md`);
//! * [`map_wire`]: map versions over zenoh, for a daemon that follows another's map,
//!   and the zenoh keys of observations and maps;
//! * `client.rs`: the [`Client`]: connect to a daemon, send a [`Request`], get a
//!   [`Prediction`] that borrows the response in shared memory (no copy);
//! * `options.rs`: [`ClientOptions`] and the [`WaitMode`];
//! * `request.rs`: the [`Request`] builder;
//! * `observe.rs`: the [`ObserveRequest`] builder and [`Client::observe`], observations
//!   for a daemon that learns its map;
//! * `prediction.rs`: the [`Prediction`] view and one agent's [`AgentPrediction`];
//! * `error.rs`: the [`Error`] of every call;
//! * `ipc.rs`: what daemon and clients share on one host: [`DEFAULT_SERVICE`], the
//!   event services' names, the iceoryx2 configuration ([`iceoryx_config`],
//!   [`PREFIX_ENV`]) and service types ([`PredictService`], [`ClientIpc`]);
//! * [`ffi`]: the C ABI (header `client/include/cliff_client.h`);
//! * `zenoh` (feature `zenoh`): `Client::connect_zenoh` reaches a daemon on another
//!   host with the same [`Request`], [`Prediction`] and errors.
//!
//! Everything outside [`protocol`], [`legacy`], [`wire`], [`map_wire`], [`ffi`] and `zenoh` is
//! re-exported here, at the crate root.
//!
//! ```no_run
//! use cliff_client::{Client, Observation, Request};
//! use cliff::predict::Params;
//!
//! let mut client = Client::connect("cliff/predict")?;
//! let mut request = Request::new("demo", &Params::default())?;
//! // one person walking east, observed at 2.5 Hz
//! request.add_agent((0..4).map(|i| Observation::position(0.4 * i as f64, -10.0 + 0.5 * i as f64, 0.5)));
//! let prediction = client.predict(&request)?;
//! for agent in prediction.agents() {
//!     for sample in agent.samples() {
//!         for [x, y] in sample {
//!             let _ = (x, y); // a predicted position every dt seconds
//!         }
//!     }
//! }
//! # Ok::<(), cliff_client::Error>(())
//! ```
//!
//! ## Waiting
//!
//! [`WaitMode::Spin`] busy-polls for the response (lowest latency, one core busy while
//! waiting); [`WaitMode::Block`] sleeps on an iceoryx2 event the daemon signals (no CPU,
//! but a wake-up across cores costs tens of microseconds); [`WaitMode::Hybrid`], the
//! default, spins for [`ClientOptions::spin`] and then blocks.
//!
//! ## Failures
//!
//! Every call has a deadline ([`ClientOptions::deadline`]). [`Error::NoDaemon`] means no
//! daemon serves the service, [`Error::DaemonGone`] that it died while the request was
//! in flight, [`Error::Deadline`] that no answer came in time, [`Error::Rejected`] that
//! the daemon refused the request (with the [`Status`] and where). After a daemon
//! restart the same `Client` works again: there is nothing to rebuild.
#![warn(missing_docs)]

mod client;
mod error;
pub mod ffi;
mod ipc;
pub mod legacy;
pub mod map_wire;
mod observe;
mod options;
mod prediction;
pub mod protocol;
mod request;
mod wakeups;
pub mod wire;
#[cfg(feature = "zenoh")]
pub mod zenoh;

pub use client::Client;
pub use error::Error;
pub use ipc::{
    ClientIpc, DEFAULT_SERVICE, PREFIX_ENV, PredictService, iceoryx_config, prefix_from_env,
    request_event_name, response_event_name,
};
pub use observe::ObserveRequest;
pub use options::{ClientOptions, WaitMode};
pub use prediction::{AgentPrediction, Prediction};
pub use protocol::{
    Field, KIND_RELOAD, Limits, LocalPredictor, MapTime, Observation, ObserveReply,
    PROTOCOL_VERSION, Rejection, RequestHeader, ResponseHeader, Status,
};
pub use request::Request;
pub use wakeups::Wakeups;
