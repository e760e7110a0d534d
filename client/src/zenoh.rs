//! Reaching a `cliffd` on another host over zenoh (feature `zenoh`).
//!
//! A [`Client`](crate::Client) made with [`Client::connect_zenoh`](crate::Client::connect_zenoh)
//! sends the same [`Request`](crate::Request) as a zenoh query on the daemon's key
//! expression ([`key_expr_for`]) in the byte encoding of [`crate::wire`], and reads the
//! reply into a buffer of its own that the [`Prediction`](crate::Prediction) borrows.
//! The zenoh session is in client mode (it never listens), connects only to the given
//! endpoints, with multicast and gossip scouting off and a reconnection retry of
//! 100-500 ms, unless a configuration file says otherwise.
//!
//! Observe requests go to the daemon's observe key ([`crate::map_wire::observe_key_for`]),
//! which zenoh's access control may close to sessions that are not allowed to teach the
//! map: when nothing answers there, the client asks the prediction key, where a daemon
//! answers an observe request [`Status::NotAllowed`](crate::Status::NotAllowed)
//! ([`Error::Rejected`]), and reports [`Error::NoDaemon`] only when nothing answers there
//! either.
//!
//! A request whose link drops before its reply (the daemon restarts, the network goes
//! away, or zenoh's `tls/` link closes itself under load: eclipse-zenoh/zenoh#2557) is
//! sent again, with its id, on the same session once zenoh has reconnected, within the
//! request's deadline (at most three attempts, each after 10 ms for the old link to
//! go). This is safe for every kind: a prediction has no side effect, and the daemon
//! answers an observe request it has taken already with its first answer's counts
//! without taking its rows again. A query that gets no reply on a live link is tried
//! the same way, so nobody answering on the key costs about 20 ms before
//! [`Error::NoDaemon`].
//!
//! Failures map to the same [`Error`]s as locally: [`Error::NoDaemon`] when the daemon
//! cannot be reached within the deadline or does not answer on the key (zenoh reports no
//! daemon on a live link and an access-control denial alike: no reply),
//! [`Error::Deadline`], [`Error::Rejected`]. [`Error::DaemonGone`] is never returned over
//! zenoh.

use std::path::Path;
use std::time::{Duration, Instant};

use zenoh::Wait;
use zenoh::bytes::ZBytes;
use zenoh::key_expr::KeyExpr;
use zenoh::qos::CongestionControl;
use zenoh::query::ConsolidationMode;

use crate::error::{Error, version_mismatch};
use crate::protocol::{KIND_OBSERVE, Observation, RequestHeader, ResponseHeader};
use crate::wire;

/// The key expression a daemon serving the service `service` answers on: the service
/// name itself (`cliff/predict`).
pub fn key_expr_for(service: &str) -> String {
    service.to_string()
}

/// The zenoh configuration of a client: the file (if any), then `mode` client and, for
/// what the file does not name, `scouting.multicast` and `scouting.gossip` off and
/// `connect.retry` 100-500 ms. `endpoints`, when given, replace `connect.endpoints`.
/// (A key counts as named when the file's text has it followed by a colon:
/// [`config_names`].)
pub fn client_config(
    endpoints: &[String],
    config_file: Option<&Path>,
) -> Result<zenoh::Config, String> {
    let (mut config, text) = match config_file {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .map_err(|e| format!("zenoh config {}: {e}", p.display()))?;
            let c = zenoh::Config::from_json5(&text)
                .map_err(|e| format!("zenoh config {}: {e}", p.display()))?;
            (c, text)
        }
        None => (zenoh::Config::default(), String::new()),
    };
    let named = |key: &str| config_names(&text, key);
    let mut set = |key: &str, value: &str| {
        config
            .insert_json5(key, value)
            .map_err(|e| format!("zenoh config {key} = {value}: {e}"))
    };
    set("mode", r#""client""#)?;
    if !named("multicast") {
        set("scouting/multicast/enabled", "false")?;
    }
    if !named("gossip") {
        set("scouting/gossip/enabled", "false")?;
    }
    if !named("retry") {
        set("connect/retry", "{period_init_ms: 100, period_max_ms: 500}")?;
    }
    if !endpoints.is_empty() {
        let list = endpoints
            .iter()
            .map(|e| format!("{e:?}"))
            .collect::<Vec<_>>()
            .join(",");
        set("connect/endpoints", &format!("[{list}]"))?;
    }
    Ok(config)
}

/// Whether JSON5 configuration text names the key `key` (as `key:`, `"key":` or
/// `'key':`, not as part of a longer name such as `listen_certificate`): the sections a
/// configuration file sets itself, which cliff's safe defaults leave alone.
pub fn config_names(text: &str, key: &str) -> bool {
    let b = text.as_bytes();
    let ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    text.match_indices(key).any(|(i, _)| {
        if i > 0 && ident(b[i - 1]) {
            return false;
        }
        let mut j = i + key.len();
        if j < b.len() && (b[j] == b'"' || b[j] == b'\'') {
            j += 1;
        }
        while j < b.len() && b[j].is_ascii_whitespace() {
            j += 1;
        }
        j < b.len() && b[j] == b':'
    })
}

/// A client's zenoh session and its response buffer.
pub(crate) struct ZenohLink {
    session: zenoh::Session,
    key: KeyExpr<'static>,
    /// Where observe requests go.
    observe_key: KeyExpr<'static>,
    /// Where the daemon is, for messages (`cliff/predict via zenoh tcp/...`).
    target: String,
    /// The last response's payload words (what a [`crate::Prediction`] borrows).
    pub(crate) payload: Vec<u32>,
}

impl ZenohLink {
    pub(crate) fn open(
        endpoints: &[String],
        config_file: Option<&Path>,
        service: &str,
    ) -> Result<ZenohLink, Error> {
        let target = if endpoints.is_empty() {
            format!("{service} via zenoh")
        } else {
            format!("{service} via zenoh {}", endpoints.join(", "))
        };
        if endpoints.is_empty() && config_file.is_none() {
            return Err(Error::InvalidRequest(
                "a zenoh client needs an endpoint (e.g. tcp/127.0.0.1:7447) or a configuration file".into(),
            ));
        }
        let key = KeyExpr::try_from(key_expr_for(service)).map_err(|e| {
            Error::InvalidRequest(format!(
                "service name '{service}' is not a zenoh key expression: {e}"
            ))
        })?;
        let observe_key = KeyExpr::try_from(crate::map_wire::observe_key_for(service))
            .map_err(|e| Error::InvalidRequest(format!("service name '{service}': {e}")))?;
        let config = client_config(endpoints, config_file).map_err(Error::InvalidRequest)?;
        let session = zenoh::open(config).wait().map_err(|e| {
            // a client-mode session fails at once when no endpoint answers
            let text = e.to_string();
            if text.contains("Unable to connect") || text.contains("timeout") {
                Error::NoDaemon {
                    service: target.clone(),
                }
            } else {
                Error::Zenoh(format!("cannot open a session: {text}"))
            }
        })?;
        Ok(ZenohLink {
            session,
            key,
            observe_key,
            target,
            payload: Vec::new(),
        })
    }

    /// Send one request (its id already set) and read the reply into `self.payload`.
    pub(crate) fn round_trip(
        &mut self,
        header: &RequestHeader,
        rows: &[Observation],
        deadline: Duration,
    ) -> Result<ResponseHeader, Error> {
        let start = Instant::now();
        // zenoh takes the buffer over (no copy), so each request has its own
        let mut bytes = Vec::new();
        wire::encode_request(header, rows, &mut bytes);
        if header.kind != KIND_OBSERVE {
            return self.query(false, bytes, deadline, start);
        }
        match self.query(true, bytes, deadline, start) {
            Err(Error::NoDaemon { .. }) => {
                // no daemon, or access control keeps this session off the observe key:
                // the prediction key tells which (a daemon answers `not-allowed` there)
                let mut probe = Vec::new();
                wire::encode_request(header, &[], &mut probe);
                self.query(false, probe, deadline, start)
            }
            r => r,
        }
    }

    /// One query on the prediction key (or the observe key) with the encoded request
    /// `bytes`, within `deadline` from `start`; sent again when the session's link
    /// dropped before the reply and zenoh reconnects in time.
    fn query(
        &mut self,
        observe: bool,
        bytes: Vec<u8>,
        deadline: Duration,
        start: Instant,
    ) -> Result<ResponseHeader, Error> {
        // A query that ends without a reply on a live link means nobody answers on the
        // key; but the link may also have dropped under the query (zenoh reconnects
        // within milliseconds, so the drop cannot be told from the link's state
        // afterwards): a few more attempts, each once the old link is gone and the
        // session has a link again, tell the two apart.
        const ATTEMPTS: usize = 3;
        // (cloning the payload for another attempt shares its buffer)
        let payload = ZBytes::from(bytes);
        let mut attempt = 1;
        loop {
            match self.query_once(observe, payload.clone(), deadline, start) {
                Err(Error::NoDaemon { .. })
                    if attempt < ATTEMPTS && self.wait_for_link(deadline, start) =>
                {
                    attempt += 1;
                }
                r => return r,
            }
        }
    }

    /// Whether the session has a link to a peer or router now.
    fn linked(&self) -> bool {
        let info = self.session.info();
        info.peers_zid().wait().next().is_some() || info.routers_zid().wait().next().is_some()
    }

    /// Wait until a link that was closing is gone (a query sent meanwhile could follow
    /// it and wait out its deadline) and the session has a link (zenoh reconnects by
    /// itself): true when it has one before `deadline` from `start`.
    fn wait_for_link(&self, deadline: Duration, start: Instant) -> bool {
        const SETTLE: Duration = Duration::from_millis(10);
        const POLL: Duration = Duration::from_millis(2);
        std::thread::sleep(SETTLE.min(deadline.saturating_sub(start.elapsed())));
        loop {
            if self.linked() {
                return start.elapsed() < deadline;
            }
            let left = deadline.saturating_sub(start.elapsed());
            if left.is_zero() {
                return false;
            }
            std::thread::sleep(POLL.min(left));
        }
    }

    /// One attempt of [`query`](Self::query).
    fn query_once(
        &mut self,
        observe: bool,
        payload: ZBytes,
        deadline: Duration,
        start: Instant,
    ) -> Result<ResponseHeader, Error> {
        let left = deadline.saturating_sub(start.elapsed());
        if left.is_zero() {
            return Err(Error::Deadline { deadline });
        }
        let key = if observe {
            &self.observe_key
        } else {
            &self.key
        };
        let replies = self
            .session
            .get(key)
            .payload(payload)
            // the session this request counts for (the daemon allows each session as
            // many requests in flight as a local client)
            .attachment(ZBytes::from(self.session.zid().to_le_bytes()))
            .consolidation(ConsolidationMode::None)
            .congestion_control(CongestionControl::Drop)
            .timeout(left)
            .wait()
            .map_err(|e| Error::Zenoh(format!("cannot send the query: {e}")))?;
        // zenoh ends the query at the deadline; the margin only guards against a stuck
        // channel
        let reply = match replies.recv_timeout(left + Duration::from_millis(100)) {
            // zenoh's query timer counts whole milliseconds, so a shorter deadline can
            // pass before zenoh ends the query: a reply after it is late all the same
            Ok(Some(_)) if start.elapsed() > deadline => {
                return Err(Error::Deadline { deadline });
            }
            Ok(Some(reply)) => reply,
            Ok(None) => return Err(Error::Deadline { deadline }),
            Err(_) if start.elapsed() >= deadline => return Err(Error::Deadline { deadline }),
            // the query ended without a reply: nobody answers on the key
            Err(_) => {
                return Err(Error::NoDaemon {
                    service: self.target.clone(),
                });
            }
        };
        match reply.into_result() {
            Ok(sample) => {
                let bytes = sample.payload().to_bytes();
                wire::decode_response(&bytes, usize::MAX, &mut self.payload).map_err(|e| match e {
                    wire::WireError::Version { found } => version_mismatch(found),
                    e => Error::Protocol(e.to_string()),
                })
            }
            Err(err) => {
                let text = err.payload().to_bytes();
                let text = String::from_utf8_lossy(&text);
                if text.eq_ignore_ascii_case("timeout") {
                    Err(Error::Deadline { deadline })
                } else {
                    Err(Error::Zenoh(format!("error reply: {text}")))
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_keys_are_named_only_as_keys() {
        let text = r#"{ transport: { link: { tls: { listen_certificate: "a.pem" } } },
                        scouting: { "multicast" : { enabled: true } }, 'retry':{} }"#;
        assert!(config_names(text, "multicast"));
        assert!(config_names(text, "retry"));
        assert!(!config_names(text, "listen"));
        assert!(!config_names(text, "gossip"));
        assert!(!config_names("mode_x: 1, model: 2", "mode"));
        assert!(config_names("mode:\"peer\"", "mode"));
    }

    #[test]
    fn the_client_config_is_client_mode_without_scouting() {
        let c = client_config(&["tcp/127.0.0.1:7447".into()], None).unwrap();
        assert_eq!(c.get_json("mode").unwrap(), r#""client""#);
        assert_eq!(c.get_json("scouting/multicast/enabled").unwrap(), "false");
        assert_eq!(c.get_json("scouting/gossip/enabled").unwrap(), "false");
        assert!(
            c.get_json("connect/endpoints")
                .unwrap()
                .contains("tcp/127.0.0.1:7447")
        );
        // a file that turns multicast scouting on keeps it, and still gets client mode
        let dir = std::env::temp_dir().join(format!("cliff-zenoh-cfg-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("client.json5");
        std::fs::write(
            &f,
            r#"{ mode: "peer", scouting: { multicast: { enabled: true } } }"#,
        )
        .unwrap();
        let c = client_config(&[], Some(&f)).unwrap();
        assert_eq!(c.get_json("mode").unwrap(), r#""client""#);
        assert_eq!(c.get_json("scouting/multicast/enabled").unwrap(), "true");
        assert_eq!(c.get_json("scouting/gossip/enabled").unwrap(), "false");
        std::fs::write(&f, "{ mode: ").unwrap();
        let e = client_config(&[], Some(&f)).unwrap_err();
        assert!(e.contains("client.json5"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
