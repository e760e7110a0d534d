//! The C ABI: `client/include/cliff_client.h` (generated from this folder by cbindgen;
//! a test fails when the committed header is stale).
//!
//! Objects are opaque pointers; every fallible call returns a `CLIFF_*` result code and
//! leaves a message for [`cliff_last_error`]. A prediction is read in place from shared
//! memory: the pointers in [`CliffPrediction`] stay valid until the next
//! [`cliff_predict`], [`cliff_prediction_release`] or [`cliff_client_free`] on the same
//! client. A client may move between threads, one call at a time.
//!
//! ```c
//! CliffClient *c;
//! if (cliff_client_connect("cliff/predict", NULL, &c) != CLIFF_OK) { puts(cliff_last_error()); }
//! CliffParams p; cliff_params_default(&p);
//! CliffRequest *r = cliff_request_new("demo", &p);
//! double t[] = {0.0, 0.4}, x[] = {-10.0, -9.5}, y[] = {0.5, 0.5};
//! cliff_request_add_agent(r, 2, t, x, y, NULL, NULL);
//! CliffPrediction out;
//! if (cliff_predict(c, r, &out) == CLIFF_OK) { /* out.positions[2 * i], out.lens[s] */ }
//! ```
//!
//! The options beyond the paper, scores and the map of the time of day are fields of
//! [`CliffParams`] (`speed_beta`, `coast`, `flags` with [`CLIFF_FLAG_SCORES`],
//! `time_mode` and `time`); the scores come back in [`CliffPrediction::scores`].
//!
//! A daemon that learns its map (`cliffd --learn NAME`) takes tracked people's rows
//! through [`cliff_observe`]; [`cliff_client_map_version`] says which version of the map
//! answered the last prediction, and [`CLIFF_FLAG_BASE_MAP`] pins the map as loaded.

use std::cell::RefCell;
use std::ffi::{CStr, CString, c_char};
use std::ptr;
use std::time::Duration;

use cliff::predict::Params;

use crate::client::{Answer, Client};
use crate::error::Error;
use crate::ipc::DEFAULT_SERVICE;
use crate::options::{ClientOptions, WaitMode};
use crate::prediction::{RawResponse, best_of, split_payload};
use crate::protocol::{self, Observation, Status};
use crate::request::Request;

/// Success.
pub const CLIFF_OK: i32 = 0;
/// No daemon serves the service.
pub const CLIFF_ERR_NO_DAEMON: i32 = 1;
/// The daemon died or stopped while the request was in flight.
pub const CLIFF_ERR_DAEMON_GONE: i32 = 2;
/// No response within the deadline.
pub const CLIFF_ERR_DEADLINE: i32 = 3;
/// The daemon refused the request; `CliffPrediction.status` holds the status code.
pub const CLIFF_ERR_REJECTED: i32 = 4;
/// A bad argument (null pointer, bad map name, mismatched lengths).
pub const CLIFF_ERR_INVALID: i32 = 5;
/// The response broke the protocol.
pub const CLIFF_ERR_PROTOCOL: i32 = 6;
/// iceoryx2 failed.
pub const CLIFF_ERR_IPC: i32 = 7;
/// zenoh failed (configuration, session) or answered with an error.
pub const CLIFF_ERR_ZENOH: i32 = 8;

/// Wait mode: busy-poll.
pub const CLIFF_WAIT_SPIN: u32 = 0;
/// Wait mode: busy-poll, then sleep (the default).
pub const CLIFF_WAIT_HYBRID: u32 = 1;
/// Wait mode: sleep on the daemon's event.
pub const CLIFF_WAIT_BLOCK: u32 = 2;

// (literal values: cbindgen writes constants it can evaluate; a test checks that they
// are the protocol's)

/// Method: CLiFF-LHMP, the paper's method.
pub const CLIFF_METHOD_CLIFF: u32 = 0;
/// Method: constant velocity.
pub const CLIFF_METHOD_CVM: u32 = 1;
/// Method: the improved method (a preset of the options beyond the paper).
pub const CLIFF_METHOD_IMPROVED: u32 = 2;
/// Method: the learned motion model alone (the daemon's built-in model, from each
/// agent's observed rows; no map).
pub const CLIFF_METHOD_MOTION: u32 = 3;
/// Method: constant velocity of the last observed displacement.
pub const CLIFF_METHOD_CVM_LAST: u32 = 4;

/// `CliffParams.flags` bit: the response carries a score per sample
/// (`CliffPrediction.scores`).
pub const CLIFF_FLAG_SCORES: u32 = 1;

/// `CliffParams.flags` bit: predict on the map as the daemon loaded it, not on a version
/// it learned since (`cliffd --learn`).
pub const CLIFF_FLAG_BASE_MAP: u32 = 2;

/// `CliffParams.time_mode`: the map for the daemon's wall clock when the request
/// arrives (the default).
pub const CLIFF_TIME_NOW: u32 = 0;
/// `CliffParams.time_mode`: the map for `CliffParams.time` (s on the map's clock: unix
/// time, as the tracks had it).
pub const CLIFF_TIME_AT: u32 = 1;
/// `CliffParams.time_mode`: the all-day map.
pub const CLIFF_TIME_ALL_DAY: u32 = 2;

/// Prediction parameters (see `cliff::predict::Params` and `cliff::predict::Options`).
/// Codes are sent as they are: an unknown one is refused by the daemon with its status.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct CliffParams {
    /// `CLIFF_METHOD_CLIFF` (0), `CLIFF_METHOD_CVM` (1), `CLIFF_METHOD_IMPROVED` (2),
    /// `CLIFF_METHOD_MOTION` (3) or `CLIFF_METHOD_CVM_LAST` (4).
    pub method: u32,
    /// 0: circular mean (reference), 1: the paper's rule.
    pub heading_rule: u32,
    /// Samples per agent.
    pub k: u32,
    /// Time step (s).
    pub dt: f64,
    /// Horizon (s); steps = floor(horizon / dt).
    pub horizon: f64,
    /// Kernel parameter.
    pub beta: f64,
    /// Sampling radius (m).
    pub radius: f64,
    /// Seed.
    pub seed: u64,
    /// Speed kernel parameter; 0 keeps the observed speed (the paper).
    pub speed_beta: f64,
    /// Seconds a sample goes on at constant velocity where the map has no data (at most
    /// the horizon); 0 stops it there (the paper).
    pub coast: f64,
    /// Bits: `CLIFF_FLAG_SCORES`.
    pub flags: u32,
    /// `CLIFF_TIME_NOW` (0), `CLIFF_TIME_AT` (1) or `CLIFF_TIME_ALL_DAY` (2).
    pub time_mode: u32,
    /// For `CLIFF_TIME_AT`: the time (s); must be finite in every mode.
    pub time: f64,
}

/// A prediction, read in place; valid until the next call on the client.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct CliffPrediction {
    /// The request id the daemon echoed.
    pub request_id: u64,
    /// Status code (0 ok; on `CLIFF_ERR_REJECTED` the reason, see `cliff_status_name`).
    pub status: u32,
    /// Agents.
    pub agents: u32,
    /// Samples per agent.
    pub k: u32,
    /// Steps per sample.
    pub steps: u32,
    /// `agents * k * steps` points as x, y pairs (`2 * agents * k * steps` floats),
    /// sample-major: sample `a * k + s`, step `j` at `((a * k + s) * steps + j) * 2`.
    pub positions: *const f32,
    /// Valid length of each of the `agents * k` samples (NaN past it).
    pub lens: *const u32,
    /// The score of each of the `agents * k` samples when the request set
    /// `CLIFF_FLAG_SCORES`, else NULL (higher: more likely under the map; compare the
    /// samples of one prediction).
    pub scores: *const f32,
}

/// Opaque client handle.
pub struct CliffClient {
    client: Client,
    held: Option<RawResponse>,
    /// The map version of the last prediction (`cliff_client_map_version`).
    map_version: u32,
}

/// Opaque request handle.
pub struct CliffRequest {
    request: Request,
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_error(msg: impl Into<String>) {
    let msg = msg.into().replace('\0', " ");
    LAST_ERROR.with(|e| *e.borrow_mut() = CString::new(msg).unwrap_or_default());
}

fn code_of(e: &Error) -> i32 {
    match e {
        Error::NoDaemon { .. } => CLIFF_ERR_NO_DAEMON,
        Error::DaemonGone { .. } => CLIFF_ERR_DAEMON_GONE,
        Error::Deadline { .. } => CLIFF_ERR_DEADLINE,
        Error::Rejected(_) => CLIFF_ERR_REJECTED,
        Error::InvalidRequest(_) => CLIFF_ERR_INVALID,
        Error::Protocol(_) => CLIFF_ERR_PROTOCOL,
        Error::Ipc(_) => CLIFF_ERR_IPC,
        Error::Zenoh(_) => CLIFF_ERR_ZENOH,
    }
}

fn fail(e: &Error) -> i32 {
    set_error(e.to_string());
    code_of(e)
}

fn invalid(msg: &str) -> i32 {
    set_error(msg);
    CLIFF_ERR_INVALID
}

/// # Safety
/// `p` is null or a NUL-terminated string.
unsafe fn str_arg<'a>(p: *const c_char, what: &str) -> Result<&'a str, i32> {
    if p.is_null() {
        return Err(invalid(&format!("{what} is NULL")));
    }
    // SAFETY: the caller passes a NUL-terminated string
    unsafe { CStr::from_ptr(p) }
        .to_str()
        .map_err(|_| invalid(&format!("{what} is not UTF-8")))
}

/// A request against `map` with the parameters of `p`, every code and option written
/// to the header as given (the daemon validates them).
fn request_from(map: &str, p: &CliffParams) -> Result<Request, Error> {
    let params = Params {
        k: p.k as usize,
        dt: p.dt,
        horizon: p.horizon,
        beta: p.beta,
        radius: p.radius,
        seed: p.seed,
        ..Params::default()
    };
    let mut request = Request::new(map, &params)?;
    write_codes(&mut request, p);
    Ok(request)
}

fn write_codes(request: &mut Request, p: &CliffParams) {
    let h = request.header_mut();
    h.method = p.method;
    h.heading_rule = p.heading_rule;
    h.speed_beta = p.speed_beta;
    h.coast = p.coast;
    h.flags = p.flags;
    h.time_mode = p.time_mode;
    h.time = p.time;
}

/// The message of the last failed call on this thread (empty when none). Valid until
/// the next failing call on this thread.
#[unsafe(no_mangle)]
pub extern "C" fn cliff_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// The name of a status code (`"unknown-map"`, ...); a static string.
#[unsafe(no_mangle)]
pub extern "C" fn cliff_status_name(status: u32) -> *const c_char {
    const NAMES: [&CStr; 23] = [
        c"ok",
        c"bad-version",
        c"unknown-map",
        c"unknown-method",
        c"non-finite",
        c"bad-k",
        c"bad-steps",
        c"bad-agents",
        c"history-too-short",
        c"history-not-increasing",
        c"bad-value",
        c"bad-layout",
        c"history-too-long",
        c"unknown-kind",
        c"reload-failed",
        c"internal",
        c"radius-too-large",
        c"busy",
        c"too-many-sessions",
        c"over-budget",
        c"not-learning",
        c"unknown-version",
        c"not-allowed",
    ];
    match Status::from_code(status) {
        Some(s) => NAMES[s.code() as usize].as_ptr(),
        None => c"unknown-status".as_ptr(),
    }
}

/// Fill `out` with the default parameters (k 20, dt 0.4 s, horizon 12 s, beta 1,
/// radius 0.7071 m, seed 0, CLiFF-LHMP, no options, no scores, the map for the daemon's
/// clock).
///
/// # Safety
/// `out` is null or points to writable memory for a `CliffParams`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_params_default(out: *mut CliffParams) {
    if out.is_null() {
        return;
    }
    let p = Params::default();
    let v = CliffParams {
        method: 0,
        heading_rule: 0,
        k: p.k as u32,
        dt: p.dt,
        horizon: p.horizon,
        beta: p.beta,
        radius: p.radius,
        seed: p.seed,
        speed_beta: 0.0,
        coast: 0.0,
        flags: 0,
        time_mode: protocol::TIME_NOW,
        time: 0.0,
    };
    // SAFETY: checked non-null; the caller guarantees it is writable
    unsafe { out.write(v) };
}

/// Connect to the daemon serving `service` (NULL: "cliff/predict"). `prefix` is the
/// iceoryx2 prefix (NULL: the CLIFF_IPC_PREFIX environment variable, else the default).
/// Wait mode hybrid, deadline 1 s. On success `*out` holds the client.
///
/// # Safety
/// `service` and `prefix` are null or NUL-terminated strings; `out` is a valid pointer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_client_connect(
    service: *const c_char,
    prefix: *const c_char,
    out: *mut *mut CliffClient,
) -> i32 {
    if out.is_null() {
        return invalid("out is NULL");
    }
    let service = if service.is_null() {
        DEFAULT_SERVICE
    } else {
        // SAFETY: non-null, NUL-terminated by contract
        match unsafe { str_arg(service, "service") } {
            Ok(s) => s,
            Err(c) => return c,
        }
    };
    let mut options = ClientOptions::default();
    if !prefix.is_null() {
        // SAFETY: non-null, NUL-terminated by contract
        match unsafe { str_arg(prefix, "prefix") } {
            Ok(p) => options.prefix = Some(p.to_string()),
            Err(c) => return c,
        }
    }
    match Client::connect_with(service, options) {
        Ok(client) => {
            let b = Box::new(CliffClient {
                client,
                held: None,
                map_version: 0,
            });
            // SAFETY: checked non-null
            unsafe { out.write(Box::into_raw(b)) };
            CLIFF_OK
        }
        Err(e) => fail(&e),
    }
}

/// Connect over zenoh to the daemon serving `service` (NULL: "cliff/predict") that
/// listens on `endpoint` (e.g. "tcp/192.0.2.7:7447"; NULL when `config_file` names the
/// endpoints). `config_file` (NULL: none) is a zenoh configuration file (TLS
/// certificates, ...). Deadline 1 s (`cliff_client_set_deadline_us`); the wait mode does
/// not apply (a zenoh client blocks on its reply). `CLIFF_ERR_NO_DAEMON` when nothing
/// answers at the endpoint. Only in a library built with the cargo feature `zenoh`:
/// define `CLIFF_CLIENT_ZENOH` before including this header to declare it.
///
/// # Safety
/// `endpoint`, `service` and `config_file` are null or NUL-terminated strings; `out` is
/// a valid pointer.
#[cfg(feature = "zenoh")]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_client_connect_zenoh(
    endpoint: *const c_char,
    service: *const c_char,
    config_file: *const c_char,
    out: *mut *mut CliffClient,
) -> i32 {
    if out.is_null() {
        return invalid("out is NULL");
    }
    // SAFETY (all three): null or NUL-terminated by contract
    let opt = |p: *const c_char, what: &str| -> Result<Option<String>, i32> {
        if p.is_null() {
            Ok(None)
        } else {
            unsafe { str_arg(p, what) }.map(|s| Some(s.to_string()))
        }
    };
    let (endpoint, service, config_file) = match (
        opt(endpoint, "endpoint"),
        opt(service, "service"),
        opt(config_file, "config_file"),
    ) {
        (Ok(e), Ok(s), Ok(f)) => (e, s, f),
        (Err(c), _, _) | (_, Err(c), _) | (_, _, Err(c)) => return c,
    };
    let service = service.unwrap_or_else(|| DEFAULT_SERVICE.to_string());
    let endpoints: Vec<String> = endpoint.into_iter().collect();
    let config = config_file.as_deref().map(std::path::Path::new);
    match Client::connect_zenoh_with(&endpoints, config, &service, ClientOptions::default()) {
        Ok(client) => {
            let b = Box::new(CliffClient {
                client,
                held: None,
                map_version: 0,
            });
            // SAFETY: checked non-null
            unsafe { out.write(Box::into_raw(b)) };
            CLIFF_OK
        }
        Err(e) => fail(&e),
    }
}

/// Close the client (releases a held prediction). NULL is ignored.
///
/// # Safety
/// `client` is null or came from `cliff_client_connect` and is not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_client_free(client: *mut CliffClient) {
    if !client.is_null() {
        // SAFETY: allocated by cliff_client_connect, freed once
        drop(unsafe { Box::from_raw(client) });
    }
}

/// Set the wait mode (`CLIFF_WAIT_*`) and, for hybrid, how long to spin (us).
///
/// # Safety
/// `client` is a valid client.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_client_set_wait(
    client: *mut CliffClient,
    mode: u32,
    spin_us: u64,
) -> i32 {
    // SAFETY: valid client by contract
    let Some(c) = (unsafe { client.as_mut() }) else {
        return invalid("client is NULL");
    };
    let wait = match mode {
        CLIFF_WAIT_SPIN => WaitMode::Spin,
        CLIFF_WAIT_HYBRID => WaitMode::Hybrid,
        CLIFF_WAIT_BLOCK => WaitMode::Block,
        _ => return invalid("unknown wait mode"),
    };
    c.client.set_wait(wait);
    c.client.set_spin(Duration::from_micros(spin_us));
    CLIFF_OK
}

/// Set the deadline of each later call (us).
///
/// # Safety
/// `client` is a valid client.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_client_set_deadline_us(
    client: *mut CliffClient,
    deadline_us: u64,
) -> i32 {
    // SAFETY: valid client by contract
    let Some(c) = (unsafe { client.as_mut() }) else {
        return invalid("client is NULL");
    };
    c.client.set_deadline(Duration::from_micros(deadline_us));
    CLIFF_OK
}

/// A new request against map `map` with `params` (NULL: defaults). NULL on a bad map
/// name (see `cliff_last_error`).
///
/// # Safety
/// `map` is a NUL-terminated string; `params` is null or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_request_new(
    map: *const c_char,
    params: *const CliffParams,
) -> *mut CliffRequest {
    // SAFETY: NUL-terminated by contract
    let Ok(map) = (unsafe { str_arg(map, "map") }) else {
        return ptr::null_mut();
    };
    // SAFETY: null or valid by contract
    let made = match unsafe { params.as_ref() } {
        Some(p) => request_from(map, p),
        None => Request::new(map, &Params::default()),
    };
    match made {
        Ok(request) => Box::into_raw(Box::new(CliffRequest { request })),
        Err(e) => {
            fail(&e);
            ptr::null_mut()
        }
    }
}

/// Free a request. NULL is ignored.
///
/// # Safety
/// `request` is null or came from `cliff_request_new` and is not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_request_free(request: *mut CliffRequest) {
    if !request.is_null() {
        // SAFETY: allocated by cliff_request_new, freed once
        drop(unsafe { Box::from_raw(request) });
    }
}

/// Replace the parameters (keeps map and agents).
///
/// # Safety
/// `request` and `params` are valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_request_set_params(
    request: *mut CliffRequest,
    params: *const CliffParams,
) -> i32 {
    // SAFETY: valid by contract
    let (Some(r), Some(p)) = (unsafe { request.as_mut() }, unsafe { params.as_ref() }) else {
        return invalid("request or params is NULL");
    };
    r.request.set_params(&Params {
        k: p.k as usize,
        dt: p.dt,
        horizon: p.horizon,
        beta: p.beta,
        radius: p.radius,
        seed: p.seed,
        ..Params::default()
    });
    write_codes(&mut r.request, p);
    CLIFF_OK
}

/// Remove all agents (keeps the memory for the next ones).
///
/// # Safety
/// `request` is valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_request_clear(request: *mut CliffRequest) -> i32 {
    // SAFETY: valid by contract
    let Some(r) = (unsafe { request.as_mut() }) else {
        return invalid("request is NULL");
    };
    r.request.clear_agents();
    CLIFF_OK
}

/// Add an agent with `n` history rows, oldest first: times `t`, positions `x`, `y`, and
/// optionally the tracker's `speed` and `heading` (both NULL: the velocity comes from
/// the positions; then `n` must be at least 2).
///
/// # Safety
/// `request` is valid; `t`, `x`, `y` (and `speed`, `heading` when not NULL) point to
/// `n` doubles each.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_request_add_agent(
    request: *mut CliffRequest,
    n: usize,
    t: *const f64,
    x: *const f64,
    y: *const f64,
    speed: *const f64,
    heading: *const f64,
) -> i32 {
    // SAFETY: valid by contract
    let Some(r) = (unsafe { request.as_mut() }) else {
        return invalid("request is NULL");
    };
    if n == 0 || t.is_null() || x.is_null() || y.is_null() {
        return invalid("an agent needs n > 0 rows and non-NULL t, x, y");
    }
    if speed.is_null() != heading.is_null() {
        return invalid("give both speed and heading, or neither");
    }
    // SAFETY: each points to n doubles by contract
    let (t, x, y) = unsafe {
        (
            std::slice::from_raw_parts(t, n),
            std::slice::from_raw_parts(x, n),
            std::slice::from_raw_parts(y, n),
        )
    };
    if speed.is_null() {
        r.request
            .add_agent((0..n).map(|i| Observation::position(t[i], x[i], y[i])));
    } else {
        // SAFETY: both non-null and n doubles long by contract
        let (s, h) = unsafe {
            (
                std::slice::from_raw_parts(speed, n),
                std::slice::from_raw_parts(heading, n),
            )
        };
        r.request
            .add_agent((0..n).map(|i| Observation::with_velocity(t[i], x[i], y[i], s[i], h[i])));
    }
    CLIFF_OK
}

/// Send the request and wait (wait mode and deadline of the client). On `CLIFF_OK`
/// `*out` describes the batch, read in place from shared memory until the next call on
/// this client; on `CLIFF_ERR_REJECTED` `out->status` holds the reason.
///
/// # Safety
/// `client`, `request` and `out` are valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_predict(
    client: *mut CliffClient,
    request: *const CliffRequest,
    out: *mut CliffPrediction,
) -> i32 {
    // SAFETY: valid by contract
    let (Some(c), Some(r)) = (unsafe { client.as_mut() }, unsafe { request.as_ref() }) else {
        return invalid("client or request is NULL");
    };
    if out.is_null() {
        return invalid("out is NULL");
    }
    c.held = None;
    let mut pred = CliffPrediction {
        request_id: 0,
        status: 0,
        agents: 0,
        k: 0,
        steps: 0,
        positions: ptr::null(),
        lens: ptr::null(),
        scores: ptr::null(),
    };
    let deadline = c.client.options().deadline;
    let result = c
        .client
        .round_trip(r.request.header(), r.request.rows(), deadline);
    let code = match result {
        Ok(answer) => {
            let (h, payload) = match &answer {
                Answer::Shm(resp) => (*resp.user_header(), resp.payload()),
                // the payload stays in the client's buffer until the next call
                Answer::Buffered(h) => (*h, c.client.buffered_payload()),
            };
            let parts = split_payload(&h, payload);
            c.map_version = h.map_version;
            pred = CliffPrediction {
                request_id: h.request_id,
                status: h.status,
                agents: h.agents,
                k: h.k,
                steps: h.steps,
                positions: parts.positions.as_ptr().cast(),
                lens: parts.lens.as_ptr(),
                scores: if h.has_scores() {
                    parts.scores.as_ptr()
                } else {
                    ptr::null()
                },
            };
            if let Answer::Shm(resp) = answer {
                c.held = Some(resp);
            }
            CLIFF_OK
        }
        Err(e) => {
            if let Error::Rejected(rej) = &e {
                pred.status = rej.status.code();
            }
            fail(&e)
        }
    };
    // SAFETY: checked non-null
    unsafe { out.write(pred) };
    code
}

/// The sample of `agent` with the highest score (the first of equals) in `prediction`,
/// or -1 when it carries no scores (`CLIFF_FLAG_SCORES` not set), `agent` is out of
/// range or `prediction` is NULL.
///
/// # Safety
/// `prediction` is null or was filled by `cliff_predict` and its data is still valid
/// (no later call on its client).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_prediction_best_sample(
    prediction: *const CliffPrediction,
    agent: u32,
) -> i64 {
    // SAFETY: null or valid by contract
    let Some(p) = (unsafe { prediction.as_ref() }) else {
        return -1;
    };
    if p.scores.is_null() || agent >= p.agents || p.k == 0 {
        return -1;
    }
    let k = p.k as usize;
    // SAFETY: scores holds agents * k floats while the prediction is valid
    let scores = unsafe { std::slice::from_raw_parts(p.scores.add(agent as usize * k), k) };
    best_of(scores).map_or(-1, |s| s as i64)
}

/// Give the last prediction's shared memory back to the daemon before the next call.
///
/// # Safety
/// `client` is null or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_prediction_release(client: *mut CliffClient) {
    // SAFETY: null or valid by contract
    if let Some(c) = unsafe { client.as_mut() } {
        c.held = None;
    }
}

/// Ask the daemon to reload every map from its file (as SIGHUP does), waiting at most
/// the client's deadline. A map that fails to load keeps its old version and the call
/// returns `CLIFF_ERR_REJECTED` (status "reload-failed"; `cliff_last_error` names the
/// map). Releases a held prediction.
///
/// # Safety
/// `client` is a valid client.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_client_reload_maps(client: *mut CliffClient) -> i32 {
    // SAFETY: valid by contract
    let Some(c) = (unsafe { client.as_mut() }) else {
        return invalid("client is NULL");
    };
    c.held = None;
    let deadline = c.client.options().deadline;
    match c.client.reload_maps(deadline) {
        Ok(()) => CLIFF_OK,
        Err(e) => fail(&e),
    }
}

/// The version of the map that answered the last successful `cliff_predict` on this
/// client: 0 for the map as the daemon loaded it, one more for every version a learning
/// daemon (`cliffd --learn`) swapped in since. 0 before any prediction or for NULL.
///
/// # Safety
/// `client` is null or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cliff_client_map_version(client: *const CliffClient) -> u32 {
    // SAFETY: null or valid by contract
    unsafe { client.as_ref() }.map_or(0, |c| c.map_version)
}

mod observe;
#[cfg(test)]
mod tests;

pub use observe::{CliffObserved, cliff_observe};
