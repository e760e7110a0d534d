//! The counters of a running daemon ([`Stats`]).

/// Counters of a running daemon.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Requests answered with a batch.
    pub served: u64,
    /// Requests answered with a rejection.
    pub rejected: u64,
    /// Responses that could not be sent (client gone, memory exhausted).
    pub failed: u64,
    /// Requests of protocol version 1 (answered `bad-version`; counted in `rejected`).
    pub old_clients: u64,
    /// Completed map reloads.
    pub reloads: u64,
    /// Chunks predicted in parallel with others (with more than one worker).
    pub parallel: u64,
    /// Observations and learned versions (`cliffd --learn`; zero without).
    pub learn: crate::learn::LearnStats,
}
