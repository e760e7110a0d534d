//! The C ABI of observations: [`cliff_observe`] sends a tracked person's rows to a
//! daemon that learns its map.

use std::ffi::c_char;

use super::{CLIFF_OK, CliffClient, fail, invalid, str_arg};
use crate::error::Error;
use crate::protocol::{self, Observation};

/// What a learning daemon did with `cliff_observe`'s rows.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct CliffObserved {
    /// Status code (0 ok; on `CLIFF_ERR_REJECTED` the reason: "over-budget" means nothing
    /// was taken, send again later; see `cliff_status_name`).
    pub status: u32,
    /// Rows taken (new to the daemon).
    pub accepted: u32,
    /// Rows the daemon had already (same client, track and time).
    pub duplicates: u32,
    /// The learned map's version.
    pub map_version: u32,
}

/// Send `n` rows of one tracked person (track id `track`, chosen by the caller and
/// stable while it tracks them; oldest row first, times strictly increasing) to a daemon
/// that learns the map `map` (`cliffd --learn NAME`). `speed` and `heading` are both NULL
/// or both `n` doubles. `end` non-zero: the last row is the track's last (the person left
/// the view). A robot may send each person's whole recent history every time: the daemon
/// counts a row once per client, track and time. `*out` (when not NULL) gets the counts,
/// or on `CLIFF_ERR_REJECTED` the status.
///
/// # Safety
/// `client` is valid; `map` is a NUL-terminated string; `t`, `x`, `y` (and `speed`,
/// `heading` when not NULL) point to `n` doubles each; `out` is null or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_observe(
    client: *mut CliffClient,
    map: *const c_char,
    track: u32,
    n: usize,
    t: *const f64,
    x: *const f64,
    y: *const f64,
    speed: *const f64,
    heading: *const f64,
    end: i32,
    out: *mut CliffObserved,
) -> i32 {
    // SAFETY: valid by contract
    let Some(c) = (unsafe { client.as_mut() }) else {
        return invalid("client is NULL");
    };
    // SAFETY: NUL-terminated by contract
    let map = match unsafe { str_arg(map, "map") } {
        Ok(m) => m,
        Err(code) => return code,
    };
    if n == 0 || t.is_null() || x.is_null() || y.is_null() {
        return invalid("an observation needs n > 0 rows and non-NULL t, x, y");
    }
    if speed.is_null() != heading.is_null() {
        return invalid("give both speed and heading, or neither");
    }
    if n > protocol::MAX_OBSERVE_ROWS as usize {
        return invalid(&format!(
            "{n} rows, at most {} per call",
            protocol::MAX_OBSERVE_ROWS
        ));
    }
    let mut request = match crate::observe::ObserveRequest::new(map) {
        Ok(r) => r,
        Err(e) => return fail(&e),
    };
    // SAFETY: each points to n doubles by contract
    let (t, x, y) = unsafe {
        (
            std::slice::from_raw_parts(t, n),
            std::slice::from_raw_parts(x, n),
            std::slice::from_raw_parts(y, n),
        )
    };
    if speed.is_null() {
        request.add_track(
            track,
            (0..n).map(|i| Observation::position(t[i], x[i], y[i])),
        );
    } else {
        // SAFETY: both non-null and n doubles long by contract
        let (s, h) = unsafe {
            (
                std::slice::from_raw_parts(speed, n),
                std::slice::from_raw_parts(heading, n),
            )
        };
        request.add_track(
            track,
            (0..n).map(|i| Observation::with_velocity(t[i], x[i], y[i], s[i], h[i])),
        );
    }
    if end != 0 {
        request.end_track();
    }
    c.held = None;
    let mut got = CliffObserved::default();
    let code = match c.client.observe(&request) {
        Ok(r) => {
            got.accepted = r.accepted;
            got.duplicates = r.duplicates;
            got.map_version = r.map_version;
            CLIFF_OK
        }
        Err(e) => {
            if let Error::Rejected(rej) = &e {
                got.status = rej.status.code();
            }
            fail(&e)
        }
    };
    // SAFETY: null or valid by contract
    if let Some(o) = unsafe { out.as_mut() } {
        *o = got;
    }
    code
}
