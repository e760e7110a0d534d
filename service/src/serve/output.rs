//! Where a request's prediction goes ([`Out`]): its loaned shared-memory response, or
//! the buffer of a remote (zenoh) reply.

use crate::scheduler::Output;

use super::ports::{Active, Response};

/// Where a request's prediction goes: straight into its loaned shared-memory response,
/// or (a remote request over zenoh) into a buffer encoded into the reply.
pub(super) enum Out {
    Ipc {
        request: Active,
        response: Response,
    },
    #[cfg(feature = "zenoh")]
    Remote {
        reply: crate::zenoh::PendingReply,
        words: Vec<u32>,
        /// The version of the map that answers ([`ResponseHeader::map_version`](cliff_client::ResponseHeader::map_version)).
        map_version: u32,
    },
}

impl Output for Out {
    #[inline]
    fn words(&mut self) -> &mut [u32] {
        match self {
            Out::Ipc { response, .. } => response.payload_mut(),
            #[cfg(feature = "zenoh")]
            Out::Remote { words, .. } => words,
        }
    }
}

/// The zenoh frontend and the payload buffers of remote requests (reused).
#[cfg(feature = "zenoh")]
pub(super) struct Remote {
    pub(super) frontend: crate::zenoh::ZenohFrontend,
    pub(super) buffers: Vec<Vec<u32>>,
    /// The maps' versions for followers, and the version published of each entry.
    pub(super) maps: crate::zenoh::MapServer,
    pub(super) published: Vec<u32>,
}
