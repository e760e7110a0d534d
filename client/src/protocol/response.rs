//! The response as it travels: its fixed header ([`ResponseHeader`]), the size of its
//! payload, and a rejection written into (and read from) the header.

use cliff::predict::{Options, Params};
use iceoryx2::prelude::ZeroCopySend;

use super::codes::FLAG_SCORES;
use super::status::{Field, Rejection, Status};

/// Fixed part of a response (the iceoryx2 response user header).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ZeroCopySend)]
#[type_name("cliff.protocol.v2.ResponseHeader")]
#[repr(C)]
pub struct ResponseHeader {
    /// The daemon's [`PROTOCOL_VERSION`](super::PROTOCOL_VERSION).
    pub version: u32,
    /// A [`Status`] code.
    pub status: u32,
    /// The request's id.
    pub request_id: u64,
    /// Agents in the batch (0 when rejected).
    pub agents: u32,
    /// Samples per agent.
    pub k: u32,
    /// Steps per sample.
    pub steps: u32,
    /// For a rejection: the agent it concerns, or `u32::MAX`.
    pub agent: u32,
    /// For a rejection: the row (within the agent) it concerns, or `u32::MAX`.
    pub row: u32,
    /// For a rejection: the [`Field`] code it concerns.
    pub field: u32,
    /// For a rejection over a limit: the limit. For a batch: how many others compete for
    /// the daemon (see [`ResponseHeader::busy`]).
    pub limit: u32,
    /// How long (us) the daemon keeps polling for requests after this response before
    /// it sleeps on its event (0: not said). A request sent within this time finds it
    /// awake; a later one has to wake it, and a [`WaitMode::Hybrid`](crate::WaitMode)
    /// client then sleeps at once instead of spinning.
    pub awake_us: u32,
    /// For a batch: [`FLAG_SCORES`] when the payload carries the scores.
    pub flags: u32,
    /// The version of the map that answered: 0 for the map as loaded (or reloaded), then
    /// one more for every learned version swapped in (`cliffd --learn`). Daemons before
    /// learning sent 0 here (the field was reserved).
    pub map_version: u32,
}

impl ResponseHeader {
    /// For a batch: how many others compete for the daemon: the requests it had in
    /// progress when it answered, plus the other connected clients when clients outnumber
    /// the cores (0: this client has it to itself). A [`WaitMode::Hybrid`](crate::WaitMode)
    /// client spins only while this is 0: when requests queue up or clients outnumber
    /// cores, the daemon needs the cores that spinning clients would take.
    pub fn busy(&self) -> u32 {
        if self.status == Status::Ok as u32 {
            self.limit
        } else {
            0
        }
    }

    /// True when the payload carries the scores ([`FLAG_SCORES`]).
    pub fn has_scores(&self) -> bool {
        self.flags & FLAG_SCORES != 0
    }

    /// Number of `u32` words of the payload for this header's shape (and scores).
    pub fn payload_words(&self) -> usize {
        payload_words(
            self.agents as usize,
            self.k as usize,
            self.steps as usize,
            self.has_scores(),
        )
    }
}

/// `u32` words of a response payload: `2` per point plus one length per sample, plus
/// one score per sample when `scores`. A shape whose count does not fit in `usize` (a
/// hostile or corrupt header) gives `usize::MAX`, which no payload in memory matches.
pub fn payload_words(agents: usize, k: usize, steps: usize, scores: bool) -> usize {
    let words = || {
        let samples = agents.checked_mul(k)?;
        let per_sample = steps.checked_mul(2)?.checked_add(1 + usize::from(scores))?;
        samples.checked_mul(per_sample)
    };
    words().unwrap_or(usize::MAX)
}

/// Whether the response to a request of `params` and `options` carries scores: when
/// the request asks for them ([`FLAG_SCORES`]) or its method's preset scores its
/// samples (`Improved`, [`cliff::predict::preset`]).
pub fn scores_in_response(params: &Params, options: &Options) -> bool {
    options.scores || cliff::predict::preset::resolve(params, options).1.scores
}

/// A rejection in a response header: [`ResponseHeader::status`], `agent`, `row`, `field`
/// and `limit`.
impl Rejection {
    /// Read a rejection from a response header (`None` when the status is OK).
    pub fn from_header(h: &ResponseHeader) -> Option<Rejection> {
        let status = Status::from_code(h.status).unwrap_or(Status::Internal);
        if status == Status::Ok {
            return None;
        }
        let opt = |v: u32| (v != u32::MAX).then_some(v);
        Some(Rejection {
            status,
            agent: opt(h.agent),
            row: opt(h.row),
            field: Field::from_code(h.field),
            limit: h.limit,
        })
    }

    /// Write the rejection into a response header (shape zero).
    pub fn write_to(&self, h: &mut ResponseHeader) {
        h.status = self.status.code();
        h.agents = 0;
        h.k = 0;
        h.steps = 0;
        h.agent = self.agent.unwrap_or(u32::MAX);
        h.row = self.row.unwrap_or(u32::MAX);
        h.field = self.field as u32;
        h.limit = self.limit;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejection_round_trips_through_the_response_header() {
        let r = Rejection::at(Status::NonFinite, Field::Time, 3, 7);
        let mut h = ResponseHeader::default();
        r.write_to(&mut h);
        assert_eq!(Rejection::from_header(&h), Some(r));
        assert_eq!(r.to_string(), "non-finite (time) at agent 3 row 7");
    }

    #[test]
    fn payload_words_count_points_lengths_and_scores_and_saturate_on_huge_shapes() {
        // 2 agents x 3 samples x 4 steps: 24 points of 2 words, 6 lengths, 6 scores
        assert_eq!(payload_words(2, 3, 4, false), 24 * 2 + 6);
        assert_eq!(payload_words(2, 3, 4, true), 24 * 2 + 6 + 6);
        assert_eq!(payload_words(0, 20, 30, true), 0);
        // a header's largest shape (u32::MAX each): 2^96 words do not fit, and must not
        // wrap around to a small count a short payload could match
        let max = u32::MAX as usize;
        assert_eq!(payload_words(max, max, max, false), usize::MAX);
        assert_eq!(payload_words(max, max, 0, true), usize::MAX);
        assert_eq!(payload_words(1, 1, usize::MAX / 2, true), usize::MAX);
        let h = ResponseHeader {
            agents: u32::MAX,
            k: u32::MAX,
            steps: u32::MAX,
            flags: FLAG_SCORES,
            ..ResponseHeader::default()
        };
        assert_eq!(h.payload_words(), usize::MAX);
    }
}
