//! The floor: what the transport alone costs. [`serve`] is the echo server (the hidden
//! `--serve-floor` mode): it answers every request at once with a response of the
//! shape cliffd would send (same header, same payload size), without decoding the
//! request or predicting. It serves the same iceoryx2 services as cliffd (the
//! request-response service and its two events, under its own service name), waits
//! the way cliffd does (polls while requests come, sleeps on the request event after
//! cliffd's default idle spin) and wakes blocking clients the same way, so that the
//! ordinary [`Client`](cliff_client::Client), with its wait modes, measures it. With
//! zenoh it also answers queries in its queryable's callback (a bare queryable).
//!
//! [`FloorServer`] starts it as a child process (as cliffd is another process) and
//! stops it.

use std::io::{BufRead, BufReader, Read};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cliff_client::protocol::{
    self, FLAG_SCORES, Observation, PROTOCOL_VERSION, RequestHeader, ResponseHeader, Status,
    payload_words,
};
use cliff_client::{Wakeups, iceoryx_config, request_event_name, response_event_name};
use iceoryx2::port::listener::ListenerWaitError;
use iceoryx2::prelude::*;

use crate::args::{Args, Target};

/// cliffd's default `--idle-spin-us`: how long it polls after a request before it sleeps.
const IDLE_SPIN: Duration = Duration::from_millis(1);
/// cliffd's serving loop yields its core between polls after this long without requests.
const POLITE_AFTER: Duration = Duration::from_micros(50);
/// The line the echo server prints when it serves.
const READY: &str = "floor ready";

/// The shape of the responses the floor sends: what cliffd answers to the run's requests.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Shape {
    pub(crate) agents: usize,
    pub(crate) k: usize,
    pub(crate) steps: usize,
    pub(crate) scores: bool,
}

impl Shape {
    /// `agents,k,steps,scores` (scores 0 or 1), as `--serve-floor` takes it.
    pub(crate) fn arg(&self) -> String {
        format!(
            "{},{},{},{}",
            self.agents,
            self.k,
            self.steps,
            u8::from(self.scores)
        )
    }

    pub(crate) fn parse(s: &str) -> Result<Shape, String> {
        let v: Vec<usize> = s
            .split(',')
            .map(|x| x.trim().parse::<usize>())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("--serve-floor {s}: {e}"))?;
        match v[..] {
            [agents, k, steps, scores @ (0 | 1)]
                if agents > 0 && k > 0 && steps > 0 && agents * k * steps <= 1 << 24 =>
            {
                Ok(Shape {
                    agents,
                    k,
                    steps,
                    scores: scores == 1,
                })
            }
            _ => Err(format!(
                "--serve-floor {s}: expected agents,k,steps,scores (at least 1 each, scores 0 or 1)"
            )),
        }
    }

    fn words(&self) -> usize {
        payload_words(self.agents, self.k, self.steps, self.scores)
    }

    /// The response header for the request `request_id`.
    fn header(&self, request_id: u64) -> ResponseHeader {
        ResponseHeader {
            version: PROTOCOL_VERSION,
            status: Status::Ok.code(),
            request_id,
            agents: self.agents as u32,
            k: self.k as u32,
            steps: self.steps as u32,
            agent: u32::MAX,
            row: u32::MAX,
            awake_us: IDLE_SPIN.as_micros() as u32,
            flags: if self.scores { FLAG_SCORES } else { 0 },
            ..ResponseHeader::default()
        }
    }

    /// The payload the floor sends: positions, then every sample at its full length,
    /// then the scores.
    fn payload(&self) -> Vec<u32> {
        let samples = self.agents * self.k;
        let mut p = vec![0u32; self.words()];
        let lens = samples * self.steps * 2;
        for l in &mut p[lens..lens + samples] {
            *l = self.steps as u32;
        }
        p
    }
}

/// A running echo server, stopped (its standard input closed, then killed if it has
/// not exited within two seconds) when dropped.
pub(crate) struct FloorServer {
    child: Child,
    pub(crate) ipc: Target,
    #[cfg(feature = "zenoh")]
    pub(crate) zenoh: Option<Target>,
}

impl FloorServer {
    /// Start this executable as an echo server of `shape`, in `a`'s namespace, under a
    /// service name of its own; with `zenoh`, also on a free port of 127.0.0.1.
    pub(crate) fn start(a: &Args, shape: Shape, zenoh: bool) -> Result<FloorServer, String> {
        let service = format!("{}/floor-{}", a.service, std::process::id());
        let exe = std::env::current_exe()
            .map_err(|e| format!("cannot find this executable to start the floor: {e}"))?;
        let mut cmd = Command::new(exe);
        cmd.args(["--serve-floor", &shape.arg(), "--service", &service])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit());
        if let Some(p) = a.prefix.as_deref().filter(|p| !p.is_empty()) {
            cmd.args(["--prefix", p]);
        }
        let endpoint = if zenoh {
            let port = std::net::TcpListener::bind("127.0.0.1:0")
                .and_then(|l| l.local_addr())
                .map_err(|e| format!("cannot find a free port for the zenoh floor: {e}"))?
                .port();
            let ep = format!("tcp/127.0.0.1:{port}");
            cmd.args(["--floor-zenoh", &ep]);
            Some(ep)
        } else {
            None
        };
        let mut child = cmd
            .spawn()
            .map_err(|e| format!("cannot start the floor's echo server: {e}"))?;
        let mut lines = BufReader::new(child.stdout.take().expect("piped"));
        let mut line = String::new();
        loop {
            line.clear();
            match lines.read_line(&mut line) {
                Ok(0) | Err(_) => {
                    let _ = child.kill();
                    let _ = child.wait();
                    return Err("the floor's echo server stopped before it was ready".into());
                }
                Ok(_) if line.contains(READY) => break,
                Ok(_) => {}
            }
        }
        #[cfg(not(feature = "zenoh"))]
        let _ = endpoint;
        Ok(FloorServer {
            child,
            ipc: Target::Ipc {
                service: service.clone(),
            },
            #[cfg(feature = "zenoh")]
            zenoh: endpoint.map(|ep| Target::Zenoh {
                endpoints: vec![ep],
                config: None,
                service,
            }),
        })
    }
}

impl Drop for FloorServer {
    fn drop(&mut self) {
        // closing its standard input asks it to stop (it then removes its resources)
        drop(self.child.stdin.take());
        let end = Instant::now() + Duration::from_secs(2);
        while Instant::now() < end {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The hidden `--serve-floor` mode: serve until standard input closes.
pub(crate) fn serve(a: &Args, shape: &str) -> Result<(), String> {
    let shape = Shape::parse(shape)?;
    let ipc_err = |what: &str, e: &dyn std::fmt::Debug| format!("floor: {what}: {e:?}");
    let config = iceoryx_config(a.prefix.as_deref().filter(|p| !p.is_empty()))?;
    let node = NodeBuilder::new()
        .config(&config)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| ipc_err("cannot create node", &e))?;
    let name = |s: &str| ServiceName::new(s).map_err(|e| format!("service name '{s}': {e:?}"));
    let clients = 64;
    let service = node
        .service_builder(&name(&protocol::ipc_service_name(&a.service))?)
        .request_response::<[Observation], [u32]>()
        .request_user_header::<RequestHeader>()
        .response_user_header::<ResponseHeader>()
        .max_clients(clients)
        .max_servers(1)
        .max_nodes(clients + 2)
        .max_active_requests_per_client(1)
        .max_loaned_requests(1)
        .max_response_buffer_size(1)
        .max_borrowed_responses_per_pending_response(1)
        .create()
        .map_err(|e| ipc_err("cannot create the service", &e))?;
    let wake_service = node
        .service_builder(&name(&request_event_name(&a.service))?)
        .event()
        .max_notifiers(clients + 2)
        .max_listeners(2)
        .max_nodes(clients + 2)
        .create()
        .map_err(|e| ipc_err("cannot create the request event", &e))?;
    let response_events = node
        .service_builder(&name(&response_event_name(&a.service))?)
        .event()
        .max_notifiers(2)
        .max_listeners(clients + 2)
        .max_nodes(clients + 2)
        .create()
        .map_err(|e| ipc_err("cannot create the response event", &e))?;
    let server = service
        .server_builder()
        .initial_max_slice_len(shape.words())
        .max_loaned_responses_per_request(1)
        .create()
        .map_err(|e| ipc_err("cannot create the server port", &e))?;
    let wake = wake_service
        .listener_builder()
        .create()
        .map_err(|e| ipc_err("cannot create the request listener", &e))?;
    let mut wakeups = Wakeups::new(
        response_events
            .notifier_builder()
            .create()
            .map_err(|e| ipc_err("cannot create the response notifier", &e))?,
        256,
    );
    let payload = shape.payload();

    #[cfg(feature = "zenoh")]
    let _zenoh = match &a.floor_zenoh {
        Some(ep) => Some(zenoh_floor::serve(ep, &a.service, shape, payload.clone())?),
        None => None,
    };
    #[cfg(not(feature = "zenoh"))]
    if a.floor_zenoh.is_some() {
        return Err("--floor-zenoh needs cliff-bench built with the feature zenoh".into());
    }

    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    std::thread::spawn(move || {
        let mut sink = [0u8; 64];
        let mut stdin = std::io::stdin();
        while matches!(stdin.read(&mut sink), Ok(n) if n > 0) {}
        flag.store(true, Ordering::Relaxed);
    });
    println!("{READY} on {}", a.service);

    let mut last = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        let mut served = false;
        while let Ok(Some(req)) = server.receive() {
            served = true;
            let h = *req.user_header();
            if let Ok(resp) = req.loan_slice_uninit(payload.len()) {
                let mut resp = resp.write_from_slice(&payload);
                *resp.user_header_mut() = shape.header(h.request_id);
                let _ = resp.send();
            }
            wakeups.notify(&h);
        }
        let now = Instant::now();
        if served {
            last = now;
        } else if now.duration_since(last) >= IDLE_SPIN {
            match wake.timed_wait(|_| {}, Duration::from_millis(50)) {
                Ok(_) | Err(ListenerWaitError::InterruptSignal) => {}
                Err(e) => return Err(ipc_err("waiting on the request event failed", &e)),
            }
        } else if now.duration_since(last) >= POLITE_AFTER {
            std::thread::yield_now();
        } else {
            std::hint::spin_loop();
        }
    }
    Ok(())
}

/// The zenoh floor: a queryable that answers every query in its callback.
#[cfg(feature = "zenoh")]
mod zenoh_floor {
    use zenoh::Wait;
    use zenoh::bytes::ZBytes;
    use zenoh::query::{Query, Queryable};

    use cliff_client::wire;

    use super::Shape;

    /// The session and queryable, answering until dropped.
    pub(super) struct ZenohFloor {
        _queryable: Queryable<()>,
        _session: zenoh::Session,
    }

    pub(super) fn serve(
        endpoint: &str,
        service: &str,
        shape: Shape,
        payload: Vec<u32>,
    ) -> Result<ZenohFloor, String> {
        let mut config = zenoh::Config::default();
        for (key, value) in [
            ("mode", r#""peer""#.to_string()),
            ("scouting/multicast/enabled", "false".into()),
            ("scouting/gossip/enabled", "false".into()),
            ("listen/endpoints", format!("[{endpoint:?}]")),
        ] {
            config
                .insert_json5(key, &value)
                .map_err(|e| format!("floor: zenoh config {key} = {value}: {e}"))?;
        }
        let session = zenoh::open(config)
            .wait()
            .map_err(|e| format!("floor: cannot open a zenoh session on {endpoint}: {e}"))?;
        let key = cliff_client::zenoh::key_expr_for(service);
        let queryable = session
            .declare_queryable(key)
            .callback(move |query: Query| {
                let id = query
                    .payload()
                    .map(|p| wire::peek_request_id(&p.to_bytes()))
                    .unwrap_or(0);
                let mut bytes = Vec::new();
                wire::encode_response(&shape.header(id), &payload, &mut bytes);
                let _ = query
                    .reply(query.key_expr().clone(), ZBytes::from(bytes))
                    .wait();
            })
            .wait()
            .map_err(|e| format!("floor: cannot declare the zenoh queryable: {e}"))?;
        Ok(ZenohFloor {
            _queryable: queryable,
            _session: session,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_floor_answers_in_the_shape_cliffd_would() {
        let s = Shape::parse("2,5,12,1").unwrap();
        assert_eq!(Shape::parse(&s.arg()).unwrap(), s);
        let h = s.header(77);
        assert_eq!(h.request_id, 77);
        assert!(h.has_scores());
        assert_eq!(h.payload_words(), s.payload().len());
        assert_eq!(s.payload().len(), 2 * 5 * (12 * 2 + 2));
        for bad in ["", "1,2,3", "0,1,1,0", "1,1,1,2", "1,x,1,0"] {
            assert!(Shape::parse(bad).is_err(), "{bad}");
        }
    }
}
