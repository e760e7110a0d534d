//! Sending observations to a daemon that learns its map: the [`ObserveRequest`] builder
//! and [`Client::observe`].

use std::time::Duration;

use cliff::tracks::Row;

use crate::client::{Answer, Client};
use crate::error::Error;
use crate::protocol::{
    KIND_OBSERVE, MAX_OBSERVE_ROWS, Observation, ObserveReply, RequestHeader, encode_map_name,
};

/// Rows of tracked people for a map the daemon learns (`cliffd --learn NAME`): each
/// track under the id the client gives the person, oldest row first. Track ids belong to
/// the client: the same id from two clients is two people (over zenoh, a client is its
/// zenoh session: one [`Client`]). Reuse it between
/// calls ([`clear`](Self::clear) keeps the allocation). The daemon counts each row once
/// per client, track and time, so a robot may send every person's whole recent history
/// each time.
///
/// ```
/// use cliff_client::{ObserveRequest, Observation};
/// let mut o = ObserveRequest::new("atc")?;
/// o.add_track(17, (0..5).map(|i| Observation::position(0.1 * i as f64, i as f64, 2.0)));
/// o.add_track(18, [Observation::with_velocity(0.0, 4.0, 1.0, 1.2, 3.1)]);
/// assert_eq!((o.rows().len(), o.rows()[5].agent), (6, 18));
/// # Ok::<(), cliff_client::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct ObserveRequest {
    header: RequestHeader,
    rows: Vec<Observation>,
}

impl ObserveRequest {
    /// An observe request for the map `map`, with no rows yet.
    pub fn new(map: &str) -> Result<Self, Error> {
        let map = encode_map_name(map).map_err(Error::InvalidRequest)?;
        Ok(ObserveRequest {
            header: RequestHeader {
                kind: KIND_OBSERVE,
                map,
                seed: session_id(),
                ..RequestHeader::default()
            },
            rows: Vec::new(),
        })
    }

    /// Add rows of the track `id`, oldest first (times strictly increasing).
    pub fn add_track(&mut self, id: u32, rows: impl IntoIterator<Item = Observation>) {
        self.rows
            .extend(rows.into_iter().map(|o| Observation { agent: id, ..o }));
    }

    /// Add rows as the tracks layer reads them (`cliff::tracks`): position, time, and
    /// the file's speed and motion angle.
    pub fn add_track_rows(&mut self, id: u32, rows: &[Row]) {
        self.add_track(
            id,
            rows.iter().map(|r| {
                Observation::with_velocity(r.t, r.position.x, r.position.y, r.speed, r.angle)
            }),
        );
    }

    /// Mark the last row added as its track's last: the person left the view, and the
    /// daemon learns the track at once ([`FLAG_TRACK_END`](crate::protocol::FLAG_TRACK_END)).
    pub fn end_track(&mut self) {
        if let Some(o) = self.rows.last_mut() {
            o.flags |= crate::protocol::FLAG_TRACK_END;
        }
    }

    /// Remove all rows.
    pub fn clear(&mut self) {
        self.rows.clear();
    }

    /// The wire header.
    pub fn header(&self) -> &RequestHeader {
        &self.header
    }

    /// The wire rows.
    pub fn rows(&self) -> &[Observation] {
        &self.rows
    }
}

/// A number the header's `seed` carries for each `ObserveRequest` (daemons count
/// observations per client port, or per zenoh session, and ignore it). Time, process id
/// and a counter, mixed.
fn session_id() -> u64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static N: AtomicU64 = AtomicU64::new(0);
    let t = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0);
    let mut x = t ^ ((std::process::id() as u64) << 32) ^ N.fetch_add(1, Ordering::Relaxed);
    // splitmix64's finaliser
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d049bb133111eb);
    x ^ (x >> 31)
}

impl Client {
    /// Send observations with the client's deadline; the daemon's counts on success.
    /// [`Error::Rejected`] with [`Status::OverBudget`](crate::Status::OverBudget) means
    /// nothing was taken (the client sends faster, or holds more open tracks, than its
    /// budget): send again later. Over zenoh, [`Status::NotAllowed`](crate::Status::NotAllowed)
    /// means the daemon's access rules keep this session from teaching the map. At most
    /// [`MAX_OBSERVE_ROWS`] rows per call (a daemon may accept fewer).
    pub fn observe(&mut self, request: &ObserveRequest) -> Result<ObserveReply, Error> {
        let deadline = self.options().deadline;
        self.observe_with_deadline(request, deadline)
    }

    /// [`observe`](Self::observe) with an explicit deadline.
    pub fn observe_with_deadline(
        &mut self,
        request: &ObserveRequest,
        deadline: Duration,
    ) -> Result<ObserveReply, Error> {
        if request.rows.len() > MAX_OBSERVE_ROWS as usize {
            return Err(Error::InvalidRequest(format!(
                "{} rows, at most {MAX_OBSERVE_ROWS} per observe request",
                request.rows.len()
            )));
        }
        let h = match self.round_trip(&request.header, &request.rows, deadline)? {
            Answer::Shm(response) => *response.user_header(),
            Answer::Buffered(h) => h,
        };
        Ok(ObserveReply::from_header(&h))
    }
}
