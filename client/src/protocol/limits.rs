//! The per-request limits of a daemon ([`Limits`]).

use super::codes::MAX_HISTORY;
use super::response::payload_words;

/// Per-request limits of a daemon (and of [`decode_request`](super::decode_request)).
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
    /// CLiFF-LHMP per position ([`cliff::predict::preset::cost_factor`]: 3 for the
    /// improved preset, its pruned candidates and its follow draw) may hold
    /// that many positions
    /// divided by the factor.
    pub fn max_cost(&self) -> u64 {
        self.max_agents as u64 * self.max_k as u64 * self.max_steps as u64
    }
}
