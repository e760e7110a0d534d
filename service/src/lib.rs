//! # cliff-service: the `cliffd` prediction daemon
//!
//! [`Daemon`] holds named CLiFF-maps in memory and answers prediction requests over one
//! iceoryx2 request-response service (protocol: [`cliff_client::protocol`]). The crate's
//! parts:
//!
//! * `settings/`: what a daemon serves and its limits ([`Settings`], [`MapSpec`],
//!   [`StartError`]), what a learning daemon learns and how
//!   ([`LearnSettings`](learn::LearnSettings)), and the configuration file that
//!   `cliffd --config FILE` reads ([`parse_options_file`]);
//! * `registry.rs`: the map registry: maps, their radius limits and neighbour tables
//!   (built at load, on reload and by a background thread, never on the serving thread),
//!   and reloads on their own thread;
//! * `scheduler.rs`: accepted requests cut into chunks of agents that take turns,
//!   predicted by the workers straight into the responses;
//! * `serve/`: the [`Daemon`] and its serving loop: iceoryx2 ports, requests in
//!   (validation against the maps), responses out, reloads, old clients, housekeeping
//!   (one part per file, listed in `serve/mod.rs`);
//! * [`learn`]: maps that learn while they serve (`cliffd --learn`): observations in,
//!   the background learner, new versions swapped in, snapshots;
//! * `zenoh` (feature `zenoh`): the frontend for remote requests over a zenoh queryable,
//!   validated and scheduled like local ones; observations on a key of their own; the
//!   maps' versions for daemons that follow them, and following another daemon's map
//!   (`cliffd --follow`).
//!
//! ## What one request can cost
//!
//! Every request is validated ([`cliff_client::protocol::decode_request`]) before any
//! work: at most `max_agents x max_k x max_steps` predicted positions (32 x 50 x 100 by
//! default; a method that costs a multiple of CLiFF-LHMP per position,
//! [`cost_factor`](cliff::predict::preset::cost_factor), that many times fewer: the
//! improved preset counts 9: its 5 candidates pruned to 2 per kept sample halfway, times
//! 2 for its follow draw, times 1.25 for the candidates' scores), and a sampling radius of
//! at most the map's limit (4 grid steps by default).
//! Each position costs one map lookup, which tests at most `(floor(2 r / step) + 1)^2`
//! locations through the grid scan (81 at the default limit) and usually one through a
//! neighbour table, plus one direction draw. So the work of an accepted request is at
//! most `agents x k x steps x (1 + 81)` distance tests and draws: about 4 ms on one
//! core for the largest request with tables (BENCHMARKS.md), and it is done in chunks of
//! about 0.2 ms that take turns with other requests. The response is
//! `agents x k x (2 steps + 1)` words of shared memory, plus `agents x k` scores when
//! asked for, allocated once at start.
//!
//! ## Protocol versions
//!
//! Version 2 ([`cliff_client::protocol`]) is served on `{service}/v2`. The daemon also
//! serves version 1's service name with version 1's types ([`cliff_client::legacy`]) and
//! answers every request there with `bad-version` (its version in `limit`); zenoh
//! requests of another version get the same answer in the layout every version reads.
//!
//! The serving loop busy-polls for [`Settings::idle_spin`] after the last request, then
//! sleeps on an iceoryx2 event that clients signal with every request. Dead clients'
//! resources are cleaned up once a second.
#![warn(missing_docs)]

pub mod learn;
mod registry;
mod scheduler;
mod serve;
mod settings;
#[cfg(feature = "zenoh")]
pub mod zenoh;

pub use serve::{Daemon, Stats};
pub use settings::{
    DEFAULT_CHUNK_POSITIONS, DEFAULT_TABLE_BUDGET, DEFAULT_TABLE_RADII, FileOption, MapSpec,
    OptionsFileError, RADIUS_LIMIT_STEPS, Settings, StartError, available_cores,
    parse_options_file,
};
