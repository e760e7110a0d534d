//! Remote sessions and their requests in flight ([`Sessions`]): every remote session
//! may have as many requests in flight as a local client (`--max-active-requests`),
//! and at most [`Sessions::max_sessions`] sessions have requests in flight at once.
//! A query that finds its session at its limit, or the table full, is refused on
//! zenoh's thread before it is queued or decoded past its request id.
//!
//! A session is named by the query's attachment: the 16 bytes of the querier's zenoh
//! id (`ZenohId::to_le_bytes`), which cliff's clients send with every request. Queries
//! without such an attachment (other clients) share one session, the anonymous one.
//! The id is the client's word (zenoh does not tell a queryable which transport a
//! query came through): separating clients that might lie about it is the job of
//! zenoh's authentication and access control.

use std::sync::{Arc, Mutex, MutexGuard};

use zenoh::query::Query;

/// The session of queries that carry no 16-byte attachment.
pub const ANONYMOUS: u128 = 0;

/// The session a query belongs to: its 16-byte attachment, or [`ANONYMOUS`].
pub fn session_of(query: &Query) -> u128 {
    let Some(a) = query.attachment() else {
        return ANONYMOUS;
    };
    if a.len() != 16 {
        return ANONYMOUS;
    }
    let bytes = a.to_bytes();
    bytes
        .as_ref()
        .try_into()
        .map(u128::from_le_bytes)
        .unwrap_or(ANONYMOUS)
}

/// Why a query was refused before it was queued.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// Its session already has `max_active` requests in flight.
    Busy,
    /// `max_sessions` other sessions have requests in flight.
    TooManySessions,
}

/// The sessions with requests in flight (shared by zenoh's threads, the serving loop
/// and the reply thread; a short lock, no allocation after creation).
#[derive(Debug)]
pub struct Sessions {
    table: Mutex<Vec<(u128, u32)>>,
    max_sessions: usize,
    max_active: u32,
}

impl Sessions {
    /// A table for `max_sessions` sessions of `max_active` requests in flight each.
    pub fn new(max_sessions: usize, max_active: usize) -> Sessions {
        Sessions {
            table: Mutex::new(Vec::with_capacity(max_sessions)),
            max_sessions,
            max_active: max_active.min(u32::MAX as usize) as u32,
        }
    }

    /// Sessions with requests in flight at most.
    pub fn max_sessions(&self) -> usize {
        self.max_sessions
    }

    /// Requests in flight per session at most.
    pub fn max_active(&self) -> usize {
        self.max_active as usize
    }

    fn lock(&self) -> MutexGuard<'_, Vec<(u128, u32)>> {
        // a panic while holding the lock cannot leave the table inconsistent (one
        // counter changes at a time), so a poisoned lock is used as it is
        self.table.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Count one more request in flight for `session`, or say why not.
    pub fn admit(&self, session: u128) -> Result<(), Refusal> {
        let mut t = self.lock();
        if let Some(e) = t.iter_mut().find(|e| e.0 == session) {
            if e.1 >= self.max_active {
                return Err(Refusal::Busy);
            }
            e.1 += 1;
            return Ok(());
        }
        if t.len() >= self.max_sessions {
            return Err(Refusal::TooManySessions);
        }
        t.push((session, 1));
        Ok(())
    }

    /// One request of `session` is no longer in flight.
    pub fn release(&self, session: u128) {
        let mut t = self.lock();
        if let Some(i) = t.iter().position(|e| e.0 == session) {
            t[i].1 -= 1;
            if t[i].1 == 0 {
                t.swap_remove(i);
            }
        }
    }

    /// Requests in flight now, over all sessions.
    pub fn in_flight(&self) -> usize {
        self.lock().iter().map(|e| e.1 as usize).sum()
    }
}

/// A query admitted for its session: it counts as in flight until this is dropped
/// (after its reply was handed to zenoh, or when it is dropped unanswered).
pub struct Admitted {
    query: Option<Query>,
    session: u128,
    sessions: Arc<Sessions>,
}

impl Admitted {
    /// Admit `query` for its session ([`session_of`]), or give it back with the reason.
    // (the query is handed back as it is: boxing it would allocate for every refusal)
    #[allow(clippy::result_large_err)]
    pub fn new(query: Query, sessions: &Arc<Sessions>) -> Result<Admitted, (Query, Refusal)> {
        let session = session_of(&query);
        match sessions.admit(session) {
            Ok(()) => Ok(Admitted {
                query: Some(query),
                session,
                sessions: Arc::clone(sessions),
            }),
            Err(r) => Err((query, r)),
        }
    }

    /// The session the query counts for.
    pub fn session(&self) -> u128 {
        self.session
    }

    /// The query.
    pub fn query(&self) -> &Query {
        self.query.as_ref().expect("held until dropped")
    }

    /// Let go of the request's bytes and attachment (once decoded): zenoh's receive
    /// buffer is freed while the query waits for its answer.
    pub fn forget_payload(&mut self) {
        if let Some(q) = self.query.as_mut() {
            forget_bytes(q);
        }
    }
}

/// Let go of a query's payload and attachment (they may pin one of zenoh's receive
/// buffers); its key and its place in the reply path stay.
pub fn forget_bytes(query: &mut Query) {
    if let Some(p) = query.payload_mut() {
        *p = zenoh::bytes::ZBytes::new();
    }
    if let Some(a) = query.attachment_mut() {
        *a = zenoh::bytes::ZBytes::new();
    }
}

impl Drop for Admitted {
    fn drop(&mut self) {
        // the query first (dropping it ends the zenoh query), then its place
        drop(self.query.take());
        self.sessions.release(self.session);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_session_gets_its_share_and_the_table_its_cap() {
        let s = Sessions::new(2, 2);
        assert_eq!(s.admit(1), Ok(()));
        assert_eq!(s.admit(1), Ok(()));
        assert_eq!(s.admit(1), Err(Refusal::Busy));
        assert_eq!(s.admit(2), Ok(()));
        assert_eq!(s.admit(3), Err(Refusal::TooManySessions));
        assert_eq!(s.in_flight(), 3);
        s.release(1);
        assert_eq!(s.admit(1), Ok(()));
        assert_eq!(s.admit(3), Err(Refusal::TooManySessions));
        // a session whose requests are all answered leaves the table
        s.release(2);
        assert_eq!(s.admit(3), Ok(()));
        assert_eq!(s.admit(3), Ok(()));
        assert_eq!(s.admit(3), Err(Refusal::Busy));
        for session in [1, 1, 3, 3] {
            s.release(session);
        }
        assert_eq!(s.in_flight(), 0);
        // releasing an unknown session changes nothing
        s.release(9);
        assert_eq!(s.in_flight(), 0);
    }
}
