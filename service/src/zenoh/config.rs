//! The daemon's zenoh configuration ([`zenoh_config`]), the sizes it bounds (the largest
//! message, [`max_request_bytes`]) and what remote clients may cost in memory
//! ([`MemoryBound`]).

use cliff_client::protocol::Limits;
use cliff_client::wire;

use super::ZenohSettings;

/// Bytes a received message may hold beyond the largest request: zenoh's own headers
/// and the 16-byte session attachment.
pub const MESSAGE_SLACK: usize = 4096;

/// Refused queries waiting for their answer at most (beyond, they get no reply).
pub const REFUSED_QUEUE: usize = 256;

/// What a refused query still holds while it waits for its answer (its payload and
/// attachment are let go at once): the query's own bookkeeping, about this much.
pub const REFUSED_QUERY_BYTES: usize = 1024;

/// zenoh transports (remote sessions connected at once, with or without requests)
/// per remote session with requests in flight, unless the configuration file names
/// `max_sessions`.
pub const TRANSPORTS_PER_SESSION: usize = 2;

/// Rows per request the daemon decodes at most (every agent at the longest history).
pub fn max_rows(limits: &Limits) -> usize {
    limits.max_agents as usize * limits.max_history as usize
}

/// Bytes of the largest request the limits allow.
pub fn max_request_bytes(limits: &Limits) -> usize {
    wire::REQUEST_HEADER_BYTES + max_rows(limits) * wire::ROW_BYTES
}

/// Bytes of the largest response the limits allow (with scores).
pub fn max_response_bytes(limits: &Limits) -> usize {
    wire::RESPONSE_HEADER_BYTES + 4 * limits.max_payload_words()
}

/// The largest message the daemon accepts by default: the largest request plus
/// [`MESSAGE_SLACK`].
pub fn default_max_message_bytes(limits: &Limits) -> usize {
    max_request_bytes(limits) + MESSAGE_SLACK
}

/// The zenoh configuration of the daemon: the file (if any), then cliffd's safe values
/// for what the file does not name: `mode` peer; `scouting.multicast` and
/// `scouting.gossip` off; `transport.unicast.max_sessions`
/// [`TRANSPORTS_PER_SESSION`] x `max_sessions`; `listen.endpoints` none. `endpoints`,
/// when given, replace `listen.endpoints`. `transport.link.rx.max_message_size` is
/// always [`ZenohSettings::max_message_bytes`] (by default the largest request the
/// `limits` allow plus [`MESSAGE_SLACK`]), whatever the file says. (A key counts as
/// named when the file's text has it followed by a colon:
/// [`cliff_client::zenoh::config_names`].)
pub fn zenoh_config(s: &ZenohSettings, limits: &Limits) -> Result<zenoh::Config, String> {
    let (mut config, text) = match &s.config_file {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .map_err(|e| format!("zenoh config {}: {e}", p.display()))?;
            let c = zenoh::Config::from_json5(&text)
                .map_err(|e| format!("zenoh config {}: {e}", p.display()))?;
            (c, text)
        }
        None => (zenoh::Config::default(), String::new()),
    };
    let named = |key: &str| cliff_client::zenoh::config_names(&text, key);
    let mut set = |key: &str, value: String| {
        config
            .insert_json5(key, &value)
            .map_err(|e| format!("zenoh config {key} = {value}: {e}"))
    };
    if !named("mode") {
        set("mode", r#""peer""#.into())?;
    }
    if !named("multicast") {
        set("scouting/multicast/enabled", "false".into())?;
    }
    if !named("gossip") {
        set("scouting/gossip/enabled", "false".into())?;
    }
    let bytes = s
        .max_message_bytes
        .unwrap_or_else(|| default_max_message_bytes(limits));
    set("transport/link/rx/max_message_size", bytes.to_string())?;
    if !named("max_sessions") {
        let transports = TRANSPORTS_PER_SESSION * s.max_sessions.max(1);
        set("transport/unicast/max_sessions", transports.to_string())?;
    }
    if !s.endpoints.is_empty() || !named("listen") {
        let list = s
            .endpoints
            .iter()
            .map(|e| format!("{e:?}"))
            .collect::<Vec<_>>()
            .join(",");
        set("listen/endpoints", format!("[{list}]"))?;
    }
    Ok(config)
}

/// Whether `config` listens on or connects to a zenoh `tls/` endpoint. zenoh 1.10's TLS
/// link reads and writes one TLS connection from two threads at once
/// (eclipse-zenoh/zenoh#2557): under steady traffic it drops connections and can
/// corrupt memory, so the daemon warns and docs/zenoh.md uses `quic/` (the same
/// certificates and `tls` settings).
pub fn uses_tls_link(config: &zenoh::Config) -> bool {
    ["listen/endpoints", "connect/endpoints"].iter().any(|key| {
        config
            .get_json(key)
            .is_ok_and(|list| list.contains("\"tls/"))
    })
}

/// The warning [`uses_tls_link`] calls for, naming `what` uses the link.
pub fn tls_link_warning(what: &str) -> String {
    format!(
        "{what} uses zenoh's tls/ link, which in zenoh 1.10 can drop connections and corrupt \
         memory under steady traffic (eclipse-zenoh/zenoh#2557): use quic/ with the same \
         certificates (docs/zenoh.md)"
    )
}

/// The memory the zenoh side of the daemon may hold for remote clients, from its
/// configuration and limits (docs/zenoh.md has the formula):
///
/// `sessions x active x (max(rx_buffer, message) + 2 x response)` for the requests in
/// flight (each pins its received bytes until decoded, then a prediction buffer and
/// its encoded reply), plus `transports x (tx_batches x batch + rx_buffer + message)`
/// for zenoh's queues and reassembly buffer of each connected session, plus
/// [`REFUSED_QUEUE`] x [`REFUSED_QUERY_BYTES`] for refused queries waiting for their
/// answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemoryBound {
    /// Remote sessions with requests in flight at once.
    pub sessions: usize,
    /// Requests in flight per session.
    pub active: usize,
    /// zenoh transports at once (`transport.unicast.max_sessions`).
    pub transports: usize,
    /// The largest message accepted (`transport.link.rx.max_message_size`).
    pub message: usize,
    /// A link's receive buffer (`transport.link.rx.buffer_size`).
    pub rx_buffer: usize,
    /// A transmission batch (`transport.link.tx.batch_size`).
    pub batch: usize,
    /// Batches of a link's transmission queues, all priorities
    /// (`transport.link.tx.queue.size`).
    pub tx_batches: usize,
    /// The largest response.
    pub response: usize,
}

impl MemoryBound {
    /// The bound of a daemon with configuration `config`, `limits`, `sessions` remote
    /// sessions of `active` requests in flight each.
    pub fn of(
        config: &zenoh::Config,
        limits: &Limits,
        sessions: usize,
        active: usize,
    ) -> Result<MemoryBound, String> {
        let number = |key: &str| -> Result<usize, String> {
            let v = config
                .get_json(key)
                .map_err(|e| format!("zenoh config {key}: {e}"))?;
            v.trim()
                .parse()
                .map_err(|e| format!("zenoh config {key} = {v}: {e}"))
        };
        let queue = config
            .get_json("transport/link/tx/queue/size")
            .map_err(|e| format!("zenoh config transport/link/tx/queue/size: {e}"))?;
        // {"control":2,"real_time":2,...}: the sum of the numbers
        let tx_batches = queue
            .split(|c: char| !c.is_ascii_digit())
            .filter_map(|n| n.parse::<usize>().ok())
            .sum();
        Ok(MemoryBound {
            sessions,
            active,
            transports: number("transport/unicast/max_sessions")?,
            message: number("transport/link/rx/max_message_size")?,
            rx_buffer: number("transport/link/rx/buffer_size")?,
            batch: number("transport/link/tx/batch_size")?,
            tx_batches,
            response: max_response_bytes(limits),
        })
    }

    /// The bound in bytes.
    pub fn bytes(&self) -> usize {
        let requests =
            self.sessions * self.active * (self.rx_buffer.max(self.message) + 2 * self.response);
        let links =
            self.transports * (self.tx_batches * self.batch + self.rx_buffer + self.message);
        requests + links + REFUSED_QUEUE * REFUSED_QUERY_BYTES
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn get(c: &zenoh::Config, key: &str) -> String {
        c.get_json(key).unwrap()
    }

    #[test]
    fn tls_endpoints_are_told_apart_from_quic_and_tcp() {
        let limits = Limits::default();
        let with = |endpoints: Vec<String>| {
            let s = ZenohSettings::new("cliff/predict", endpoints, None);
            uses_tls_link(&zenoh_config(&s, &limits).unwrap())
        };
        assert!(with(vec!["tls/127.0.0.1:7447".into()]));
        assert!(with(vec![
            "tcp/127.0.0.1:7447".into(),
            "tls/0.0.0.0:7448".into()
        ]));
        assert!(!with(vec!["quic/127.0.0.1:7447".into()]));
        assert!(!with(vec!["tcp/127.0.0.1:7447".into()]));
        let client = cliff_client::zenoh::client_config(&["tls/site:7447".into()], None).unwrap();
        assert!(uses_tls_link(&client));
        assert!(tls_link_warning("--follow atc").starts_with("--follow atc uses"));
    }

    #[test]
    fn the_daemon_config_is_a_peer_listening_only_where_asked() {
        let limits = Limits::default();
        let s = ZenohSettings::new("cliff/predict", vec!["tcp/127.0.0.1:7447".into()], None);
        assert_eq!(s.key, "cliff/predict");
        let c = zenoh_config(&s, &limits).unwrap();
        assert_eq!(get(&c, "mode"), r#""peer""#);
        assert_eq!(get(&c, "scouting/multicast/enabled"), "false");
        assert_eq!(get(&c, "scouting/gossip/enabled"), "false");
        assert_eq!(get(&c, "listen/endpoints"), r#"["tcp/127.0.0.1:7447"]"#);
        // 32 agents x 64 rows x 48 bytes + the 184-byte header + 4096
        let want = 32 * 64 * 48 + 184 + 4096;
        assert_eq!(
            get(&c, "transport/link/rx/max_message_size"),
            want.to_string()
        );
        // two transports per remote session (8 by default)
        assert_eq!(get(&c, "transport/unicast/max_sessions"), "16");
        // no endpoint and no file: no listener at all (a peer's default is every interface)
        let c = zenoh_config(&ZenohSettings::new("cliff/predict", vec![], None), &limits).unwrap();
        assert_eq!(get(&c, "listen/endpoints"), "[]");
    }

    #[test]
    fn the_message_bound_holds_whatever_the_file_says_unless_raised_by_name() {
        let dir = tempfile_dir("max-message");
        let f = dir.join("cliffd.json5");
        std::fs::write(
            &f,
            "{ transport: { link: { rx: { max_message_size: 1073741824 } } } }",
        )
        .unwrap();
        let limits = Limits {
            max_agents: 4,
            ..Limits::default()
        };
        let mut s = ZenohSettings::new("cliff/predict", vec![], Some(f));
        let c = zenoh_config(&s, &limits).unwrap();
        let want = 4 * 64 * 48 + 184 + 4096;
        assert_eq!(
            get(&c, "transport/link/rx/max_message_size"),
            want.to_string()
        );
        s.max_message_bytes = Some(1 << 22);
        let c = zenoh_config(&s, &limits).unwrap();
        assert_eq!(
            get(&c, "transport/link/rx/max_message_size"),
            (1 << 22).to_string()
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_memory_bound_follows_the_documented_formula() {
        let limits = Limits::default();
        let s = ZenohSettings::new("cliff/predict", vec![], None);
        let c = zenoh_config(&s, &limits).unwrap();
        let b = MemoryBound::of(&c, &limits, 8, 2).unwrap();
        // zenoh's defaults: 8 priorities of 2 batches of 65535 bytes, a 65535-byte
        // receive buffer
        assert_eq!((b.tx_batches, b.batch, b.rx_buffer), (16, 65535, 65535));
        assert_eq!((b.transports, b.message), (16, 32 * 64 * 48 + 184 + 4096));
        // 32 agents x 50 samples x (2 x 100 + 1 + 1) words + the 56-byte header
        assert_eq!(b.response, 32 * 50 * 202 * 4 + 56);
        let want = 8 * 2 * (b.message + 2 * b.response)
            + 16 * (16 * 65535 + 65535 + b.message)
            + 256 * 1024;
        assert_eq!(b.bytes(), want);
    }

    #[test]
    fn a_config_file_keeps_what_it_names_and_gets_safe_values_for_the_rest() {
        let dir = tempfile_dir("cfg");
        let f = dir.join("cliffd.json5");
        std::fs::write(
            &f,
            r#"{ scouting: { gossip: { enabled: true } },
                 listen: { endpoints: ["tcp/127.0.0.1:7999"] },
                 transport: { unicast: { max_sessions: 3 },
                              link: { tls: { listen_certificate: "x.pem" } } } }"#,
        )
        .unwrap();
        let limits = Limits::default();
        let mut s = ZenohSettings::new("cliff/predict", vec![], Some(f.clone()));
        let c = zenoh_config(&s, &limits).unwrap();
        assert_eq!(get(&c, "scouting/gossip/enabled"), "true");
        assert_eq!(get(&c, "scouting/multicast/enabled"), "false");
        assert_eq!(get(&c, "transport/unicast/max_sessions"), "3");
        assert!(get(&c, "listen/endpoints").contains("7999"));
        s.endpoints = vec!["tcp/127.0.0.1:7448".into()];
        let c = zenoh_config(&s, &limits).unwrap();
        assert_eq!(get(&c, "listen/endpoints"), r#"["tcp/127.0.0.1:7448"]"#);
        // a file that does not name `listen` (only listen_certificate) listens nowhere
        std::fs::write(
            &f,
            r#"{ transport: { link: { tls: { listen_certificate: "x.pem" } } } }"#,
        )
        .unwrap();
        s.endpoints.clear();
        let c = zenoh_config(&s, &limits).unwrap();
        assert_eq!(get(&c, "listen/endpoints"), "[]");
        std::fs::write(&f, "{ scouting: ").unwrap();
        let e = zenoh_config(&s, &limits).unwrap_err();
        assert!(e.contains("cliffd.json5"), "{e}");
        let e = zenoh_config(
            &ZenohSettings::new("x", vec![], Some(dir.join("none.json5"))),
            &limits,
        )
        .unwrap_err();
        assert!(e.contains("none.json5"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    fn tempfile_dir(tag: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("cliffd-zenoh-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }
}
