//! The [`Daemon`]: its maps, iceoryx2 services and ports, scheduler and counters; how
//! it is created (and what it reports). Serving is in the sibling files: `run.rs` (the
//! loop), `accept.rs` (requests in), `respond.rs` (responses out), `reload.rs` and
//! `old_clients.rs`.

use std::sync::Arc;

use cliff::motion::MotionModel;
use cliff_client::Wakeups;
use cliff_client::protocol::{self, Observation, PROTOCOL_VERSION, RequestHeader, ResponseHeader};
use cliff_client::{PredictService, legacy, request_event_name, response_event_name};
use iceoryx2::port::listener::Listener;
use iceoryx2::prelude::*;
use tracing::info;

use crate::registry::{Registry, TablePolicy};
use crate::scheduler::Scheduler;
use crate::settings::{Settings, StartError};

use super::output::Out;
#[cfg(feature = "zenoh")]
use super::output::Remote;
use super::ports::{Active, LegacyPort, LegacyService, Port};
use super::stats::Stats;

/// The prediction daemon: maps, iceoryx2 ports and the scheduler.
pub struct Daemon {
    pub(super) settings: Settings,
    pub(super) registry: Registry,
    pub(super) scheduler: Scheduler<Out>,
    // ports before services before node (drop order)
    pub(super) server: Port,
    /// Protocol version 1's service, where every request gets `bad-version`.
    pub(super) legacy_server: LegacyPort,
    pub(super) wake: Listener<ipc::Service>,
    pub(super) wakeups: Wakeups,
    pub(super) service: PredictService,
    _legacy_service: LegacyService,
    _wake_service: iceoryx2::service::port_factory::event::PortFactory<ipc::Service>,
    _response_events: iceoryx2::service::port_factory::event::PortFactory<ipc::Service>,
    pub(super) node: Node<ipc::Service>,
    /// Reload requests and the reload generation that answers each.
    pub(super) reload_waiters: Vec<(u64, Active)>,
    pub(super) stats: Stats,
    /// Cores of this host (for the busy hint of responses).
    pub(super) cores: usize,
    /// Observations and the learner, when the daemon learns maps.
    pub(super) learning: Option<crate::learn::Learning>,
    /// Remote clients over zenoh, once [`Daemon::serve_zenoh`] started them.
    #[cfg(feature = "zenoh")]
    pub(super) remote: Option<Remote>,
    /// Maps that follow another daemon's, once [`Daemon::follow`] started them.
    #[cfg(feature = "zenoh")]
    pub(super) following: Option<crate::zenoh::Following>,
}

/// Scheduler slots kept for remote requests: every remote session's requests in flight
/// (none without the feature `zenoh`).
fn remote_slots(settings: &Settings) -> usize {
    if cfg!(feature = "zenoh") {
        settings.max_remote_sessions * settings.max_active_requests
    } else {
        0
    }
}

/// A failure of iceoryx2 at start: what failed and its error.
fn ipc(what: &str, e: impl std::fmt::Debug) -> StartError {
    StartError::Ipc(format!("{what}: {e:?}"))
}

impl Daemon {
    /// Load the maps and create the iceoryx2 service and ports.
    pub fn new(settings: Settings) -> Result<Daemon, StartError> {
        settings.check()?;
        let l = settings.limits;
        let words = l.max_payload_words();
        let mut registry = Registry::load(&settings.maps, TablePolicy::from_settings(&settings))?;
        let learning = crate::learn::Learning::start(
            &settings.learn,
            &mut registry,
            TablePolicy::from_settings(&settings),
        )?;

        let config = cliff_client::iceoryx_config(settings.prefix.as_deref())
            .map_err(StartError::Settings)?;
        let node = NodeBuilder::new()
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
            .map_err(|e| ipc("cannot create node", e))?;
        let name = |s: &str| {
            ServiceName::new(s)
                .map_err(|e| StartError::Settings(format!("service name '{s}': {e:?}")))
        };
        let clients = settings.max_clients;
        let nodes = clients + 4;
        let service = node
            .service_builder(&name(&protocol::ipc_service_name(&settings.service))?)
            .request_response::<[Observation], [u32]>()
            .request_user_header::<RequestHeader>()
            .response_user_header::<ResponseHeader>()
            .max_clients(clients)
            .max_servers(2)
            .max_nodes(nodes)
            .max_active_requests_per_client(settings.max_active_requests)
            .max_loaned_requests(1)
            .max_response_buffer_size(1)
            .max_borrowed_responses_per_pending_response(1)
            .open_or_create()
            .map_err(|e| ipc("cannot open or create the service", e))?;
        if service.dynamic_config().number_of_servers() > 0 {
            return Err(StartError::AlreadyServed(settings.service.clone()));
        }
        // protocol version 1's name and types, only to tell old clients the version
        let legacy_service = node
            .service_builder(&name(&legacy::ipc_service_name(&settings.service))?)
            .request_response::<[legacy::Observation], [u32]>()
            .request_user_header::<legacy::RequestHeader>()
            .response_user_header::<legacy::ResponseHeader>()
            .max_clients(clients)
            .max_servers(2)
            .max_nodes(nodes)
            .max_active_requests_per_client(settings.max_active_requests)
            .max_loaned_requests(1)
            .max_response_buffer_size(1)
            .max_borrowed_responses_per_pending_response(1)
            .open_or_create()
            .map_err(|e| {
                ipc(
                    &format!(
                        "cannot open or create '{}' for clients of protocol version 1 \
                         (does a daemon of version 1 serve it?)",
                        settings.service
                    ),
                    e,
                )
            })?;
        if legacy_service.dynamic_config().number_of_servers() > 0 {
            return Err(StartError::AlreadyServed(settings.service.clone()));
        }
        let wake_service = node
            .service_builder(&name(&request_event_name(&settings.service))?)
            .event()
            .max_notifiers(clients + 2)
            .max_listeners(2)
            .max_nodes(nodes)
            .open_or_create()
            .map_err(|e| ipc("cannot open or create the request event service", e))?;
        let response_events = node
            .service_builder(&name(&response_event_name(&settings.service))?)
            .event()
            .max_notifiers(2)
            .max_listeners(clients + 2)
            .max_nodes(nodes)
            .open_or_create()
            .map_err(|e| ipc("cannot open or create the response event service", e))?;
        let server = service
            .server_builder()
            .initial_max_slice_len(words)
            .max_loaned_responses_per_request(1)
            .create()
            .map_err(|e| ipc("cannot create the server port", e))?;
        let legacy_server = legacy_service
            .server_builder()
            .initial_max_slice_len(1)
            .max_loaned_responses_per_request(1)
            .create()
            .map_err(|e| ipc("cannot create the server port of protocol version 1", e))?;
        let wake = wake_service
            .listener_builder()
            .create()
            .map_err(|e| ipc("cannot create the request listener", e))?;
        let notifier = response_events
            .notifier_builder()
            .create()
            .map_err(|e| ipc("cannot create the response notifier", e))?;
        info!(
            service = %settings.service,
            prefix = %config.global.prefix,
            max_clients = clients,
            max_active_requests = settings.max_active_requests,
            max_agents = l.max_agents,
            max_k = l.max_k,
            max_steps = l.max_steps,
            max_history = l.max_history,
            workers = settings.workers,
            chunk_positions = settings.chunk_positions,
            response_kib = words * 4 / 1024,
            "iceoryx2 service ready"
        );
        // requests in progress at once: everything the clients can have in flight,
        // within reason, and (with zenoh) everything remote sessions can have in flight
        let capacity =
            (clients * settings.max_active_requests).clamp(1, 64) + remote_slots(&settings);
        let motion = match &settings.motion_model {
            Some(path) => Some(Arc::new(
                MotionModel::load(path).map_err(StartError::MotionModel)?,
            )),
            None => None,
        };
        let scheduler = Scheduler::new(capacity, &l, settings.workers, settings.chunk_positions)
            .map_err(StartError::Settings)?
            .with_motion_model(motion);
        Ok(Daemon {
            registry,
            scheduler,
            server,
            legacy_server,
            wake,
            wakeups: Wakeups::new(notifier, clients * 2),
            service,
            _legacy_service: legacy_service,
            _wake_service: wake_service,
            _response_events: response_events,
            node,
            reload_waiters: Vec::new(),
            stats: Stats::default(),
            cores: crate::settings::available_cores(),
            learning,
            #[cfg(feature = "zenoh")]
            remote: None,
            #[cfg(feature = "zenoh")]
            following: None,
            settings,
        })
    }

    /// Also serve remote clients over zenoh: the same validation, limits and scheduler
    /// as local clients (their requests take turns in the same rounds), each remote
    /// session with the local clients' [`Settings::max_active_requests`] in flight and
    /// at most [`Settings::max_remote_sessions`] sessions at once (these replace the
    /// values in `settings`). zenoh runs on its own threads and wakes the serving loop
    /// through the iceoryx2 request event; returns what it serves on, for the ready
    /// line.
    #[cfg(feature = "zenoh")]
    pub fn serve_zenoh(
        &mut self,
        settings: &crate::zenoh::ZenohSettings,
    ) -> Result<String, StartError> {
        let mut settings = settings.clone();
        settings.max_sessions = self.settings.max_remote_sessions;
        settings.max_active = self.settings.max_active_requests;
        let waker = crate::zenoh::RequestWaker::open(
            &self.settings.service,
            self.settings.prefix.as_deref(),
        )?;
        let frontend =
            crate::zenoh::ZenohFrontend::start(&settings, &self.settings.limits, move || {
                waker.wake()
            })?;
        let description = frontend.description().to_string();
        let bound = frontend.memory_bound().bytes();
        info!(
            zid = %frontend.zid(),
            max_remote_sessions = settings.max_sessions,
            max_active_requests = settings.max_active,
            memory_bound_mib = bound as f64 / (1 << 20) as f64,
            "serving remote clients on {description}"
        );
        let entries = self.registry.entries();
        let maps = frontend.serve_maps(
            &settings.key,
            entries
                .iter()
                .map(|e| (e.name.clone(), e.version, e.set.clone()))
                .collect(),
        )?;
        let published = entries.iter().map(|e| e.version).collect();
        self.remote = Some(Remote {
            frontend,
            buffers: Vec::new(),
            maps,
            published,
        });
        Ok(description)
    }

    /// Follow maps that another daemon serves over zenoh ([`crate::zenoh::Following`]):
    /// each followed map must be served (`--map NAME=PATH`, what is served until the
    /// first version comes) and not learned here.
    #[cfg(feature = "zenoh")]
    pub fn follow(&mut self, settings: &crate::zenoh::FollowSettings) -> Result<(), StartError> {
        let following = crate::zenoh::Following::start(
            settings,
            &mut self.registry,
            TablePolicy::from_settings(&self.settings),
            &self.settings.learn.maps,
        )?;
        info!(
            maps = settings.maps.len(),
            every_ms = settings.every.as_millis() as u64,
            "following the site's maps"
        );
        self.following = Some(following);
        Ok(())
    }

    /// Between requests: swap in the followed maps' versions, and publish every map's
    /// new version to followers.
    #[cfg(feature = "zenoh")]
    pub(super) fn zenoh_housekeeping(&mut self) {
        if let Some(f) = self.following.as_mut() {
            f.housekeeping(&mut self.registry);
        }
        if let Some(r) = self.remote.as_mut() {
            for (e, published) in self.registry.entries().iter().zip(&mut r.published) {
                if e.version != *published {
                    r.maps.publish(&e.name, e.version, &e.set);
                    *published = e.version;
                }
            }
        }
    }

    /// What following counted (nothing when the daemon follows no map).
    #[cfg(feature = "zenoh")]
    pub fn follow_stats(&self) -> crate::zenoh::FollowStats {
        self.following
            .as_ref()
            .map(|f| f.stats())
            .unwrap_or_default()
    }

    /// The line printed once the daemon serves (contains `ready`).
    pub fn ready_line(&self) -> String {
        let maps: Vec<String> = self
            .registry
            .entries()
            .iter()
            .map(|m| {
                let learning = if self.settings.learn.maps.contains(&m.name) {
                    format!(", learning, version {}", m.version)
                } else if self.follows(&m.name) {
                    format!(", following, version {}", m.version)
                } else {
                    String::new()
                };
                format!(
                    "{} ({} locations{learning})",
                    m.name,
                    m.map.locations().len()
                )
            })
            .collect();
        format!(
            "cliffd ready: serving {} on service '{}' (iceoryx2 prefix '{}'), protocol v{}",
            maps.join(", "),
            self.settings.service,
            self.node.config().global.prefix,
            PROTOCOL_VERSION
        )
    }

    /// Whether the map `name` follows another daemon's.
    fn follows(&self, name: &str) -> bool {
        #[cfg(feature = "zenoh")]
        if let Some(f) = &self.following {
            return f.follows(&self.registry, name);
        }
        let _ = name;
        false
    }

    /// Counters so far.
    pub fn stats(&self) -> Stats {
        Stats {
            reloads: self.registry.reloads_done(),
            parallel: self.scheduler.parallel_chunks,
            learn: self
                .learning
                .as_ref()
                .map(|l| l.stats())
                .unwrap_or_default(),
            ..self.stats
        }
    }

    /// Names of the loaded maps.
    pub fn map_names(&self) -> Vec<String> {
        self.registry
            .entries()
            .iter()
            .map(|m| m.name.clone())
            .collect()
    }

    /// The largest sampling radius requests may use on each map (m), by name.
    pub fn radius_limits(&self) -> Vec<(String, f64)> {
        self.registry
            .entries()
            .iter()
            .map(|m| (m.name.clone(), m.max_radius))
            .collect()
    }

    pub(super) fn cleanup_dead_nodes(&mut self) {
        let state = self.node.try_cleanup_dead_nodes();
        if state.cleanups > 0 || state.failed_cleanups > 0 {
            info!(
                cleaned = state.cleanups,
                failed = state.failed_cleanups,
                "removed resources of dead processes"
            );
            self.wakeups.forget();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::MapSpec;

    #[test]
    fn bad_settings_and_maps_are_refused_before_serving() {
        let bad = |f: &dyn Fn(&mut Settings)| {
            let mut s = Settings {
                prefix: Some("cliff_unit_settings_".into()),
                ..Settings::default()
            };
            f(&mut s);
            Daemon::new(s).err().expect("refused").to_string()
        };
        assert!(bad(&|s| s.limits.max_k = 0).contains("at least 1"));
        let e = bad(&|s| {
            s.maps = vec![MapSpec {
                name: "x".into(),
                path: Some("/nonexistent/map.csv".into()),
            }]
        });
        assert!(
            e.contains("map 'x'") && e.contains("/nonexistent/map.csv"),
            "{e}"
        );
        let e = bad(&|s| {
            let m = MapSpec {
                name: "x".into(),
                path: None,
            };
            s.maps = vec![m.clone(), m];
        });
        assert!(e.contains("twice"), "{e}");
    }
}
