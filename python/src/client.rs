//! `cliff_lhmp.Client`: predictions from a running `cliffd`, over shared memory on this
//! host (iceoryx2) or over zenoh from another one (cargo feature `zenoh`).

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Duration;

use cliff_client::{Client as RustClient, ClientOptions, WaitMode};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyString;

use crate::errors::{client_err, io_err};
use crate::histories::add_histories;
use crate::predict_args::predict_fn;
use crate::prediction::Prediction;

/// Whether this build has the zenoh client (`cliff_lhmp.HAS_ZENOH`).
pub const HAS_ZENOH: bool = cfg!(feature = "zenoh");

/// What `Client.connect_zenoh` says in a build without the feature.
const NO_ZENOH: &str = "this cliff_lhmp was built without zenoh (cliff_lhmp.HAS_ZENOH is False): \
rebuild the package with the cargo feature zenoh, e.g. `maturin build --release --features zenoh` \
in python/, or `pip install ./python -C maturin.build-args=\"--features zenoh\"`";

/// A connection to the ``cliffd`` daemon serving ``service``.
///
/// ``Client(service="cliff/predict", prefix=None, wait="hybrid", deadline=0.05)``
/// connects on this host over shared memory (iceoryx2) and raises ``NoDaemon`` when no
/// daemon serves the service. ``Client.connect_zenoh("tcp/192.0.2.10:7447")`` reaches a
/// ``cliffd --zenoh`` on another host instead (a package built with the cargo feature
/// ``zenoh``); ``predict`` and its exceptions are the same either way.
///
/// Args:
///     service: the daemon's ``--service`` name.
///     prefix: the daemon's ``--prefix`` (iceoryx2 namespace); ``None``: the
///         ``CLIFF_IPC_PREFIX`` environment variable, else iceoryx2's default.
///     wait: how to wait for a response: "spin" (lowest latency, a busy core),
///         "hybrid" (spin 200 us, then sleep) or "block" (sleep at once).
///     deadline: seconds each call may take before ``DeadlinePassed``.
///
/// Calls release the GIL. One client serves one call at a time (calls from several
/// threads take turns); give each thread its own client for parallel requests. After
/// the daemon restarts, the same client works again.
///
/// Example:
///     >>> c = cliff_lhmp.Client()
///     >>> p = c.predict("demo", [np.array([[0.0, -10.0, 0.5], [0.4, -9.5, 0.5]])], k=5)
///     >>> p.positions.shape
///     (1, 5, 30, 2)
#[pyclass(module = "cliff_lhmp", frozen)]
pub struct Client {
    pub(crate) inner: Mutex<RustClient>,
    service: String,
    deadline: Duration,
    /// The zenoh endpoints the client connected to (empty over iceoryx2, and when a
    /// configuration file names them).
    endpoints: Vec<String>,
    /// `"iceoryx2"` or `"zenoh"`.
    transport: &'static str,
}

fn deadline_arg(seconds: f64) -> PyResult<Duration> {
    if seconds.is_finite() && seconds > 0.0 && seconds < 1e9 {
        Ok(Duration::from_secs_f64(seconds))
    } else {
        Err(PyValueError::new_err(format!(
            "deadline: {seconds} is not a positive number of seconds"
        )))
    }
}

/// The `endpoint` argument of `connect_zenoh`: one endpoint, a sequence of them, or None.
fn endpoints_arg(endpoint: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<String>> {
    const EXPECTED: &str =
        "a str such as 'tcp/192.0.2.10:7447', a list of them, or None (the config file names them)";
    let list = match endpoint {
        None => Vec::new(),
        Some(e) if e.is_instance_of::<PyString>() => vec![e.extract::<String>()?],
        Some(e) => e.extract::<Vec<String>>().map_err(|_| {
            PyTypeError::new_err(format!(
                "endpoint: expected {EXPECTED}, got {}",
                e.get_type()
                    .name()
                    .map(|n| n.to_string())
                    .unwrap_or_else(|_| "?".into())
            ))
        })?,
    };
    for (i, e) in list.iter().enumerate() {
        if e.trim().is_empty() {
            let at = if list.len() > 1 {
                format!("[{i}]")
            } else {
                String::new()
            };
            return Err(PyValueError::new_err(format!(
                "endpoint{at}: empty; expected {EXPECTED}"
            )));
        }
    }
    Ok(list)
}

/// Open the zenoh client (the GIL released).
#[cfg(feature = "zenoh")]
fn open_zenoh(
    py: Python<'_>,
    endpoints: &[String],
    config: Option<&Path>,
    service: &str,
    deadline: Duration,
) -> PyResult<RustClient> {
    let options = ClientOptions {
        deadline,
        ..ClientOptions::default()
    };
    py.detach(|| RustClient::connect_zenoh_with(endpoints, config, service, options))
        .map_err(|e| client_err(py, e))
}

#[cfg(not(feature = "zenoh"))]
fn open_zenoh(
    _py: Python<'_>,
    _endpoints: &[String],
    _config: Option<&Path>,
    _service: &str,
    _deadline: Duration,
) -> PyResult<RustClient> {
    Err(PyRuntimeError::new_err(NO_ZENOH))
}

#[pymethods]
impl Client {
    #[new]
    #[pyo3(signature = (service = "cliff/predict", prefix = None, wait = "hybrid", deadline = 0.05))]
    fn new(
        py: Python<'_>,
        service: &str,
        prefix: Option<String>,
        wait: &str,
        deadline: f64,
    ) -> PyResult<Self> {
        let wait: WaitMode = wait
            .parse()
            .map_err(|e: String| PyValueError::new_err(format!("wait: {e}")))?;
        let deadline = deadline_arg(deadline)?;
        let options = ClientOptions {
            wait,
            deadline,
            prefix: prefix.or_else(cliff_client::prefix_from_env),
            ..ClientOptions::default()
        };
        let svc = service.to_string();
        let client = py
            .detach(move || RustClient::connect_with(&svc, options))
            .map_err(|e| client_err(py, e))?;
        Ok(Client {
            inner: Mutex::new(client),
            service: service.to_string(),
            deadline,
            endpoints: Vec::new(),
            transport: "iceoryx2",
        })
    }

    /// Client.connect_zenoh(endpoint, service="cliff/predict", *, config=None, deadline=0.05)
    /// --
    ///
    /// Connect over zenoh to a ``cliffd --zenoh ENDPOINT`` on this or another host.
    ///
    /// Args:
    ///     endpoint: where the daemon listens, e.g. ``"tcp/192.0.2.10:7447"`` or
    ///         ``"quic/cliffd.lan:7447"``; a list of endpoints; or ``None`` when
    ///         ``config`` names them (``connect.endpoints``).
    ///     service: the daemon's ``--service`` name (its zenoh key expression).
    ///     config: a zenoh configuration file (JSON5: TLS certificates, ...; cliff's
    ///         defaults fill in what it does not name: client mode, no scouting).
    ///     deadline: seconds each call may take before ``DeadlinePassed``.
    ///
    /// The client never listens; it blocks on its reply (no ``wait`` mode). ``predict``
    /// gives the same numbers and raises the same exceptions as over shared memory:
    /// ``Rejected``, ``NoDaemon`` (nothing answers at the endpoint or on the key; a
    /// daemon that died mid-request looks the same, so ``DaemonGone`` does not occur),
    /// ``DeadlinePassed``. ``reload_maps`` is local only (``Rejected``, status
    /// "unknown-kind"). After the daemon restarts, the same client works again.
    ///
    /// Raises ``RuntimeError`` in a package built without the cargo feature ``zenoh``
    /// (``cliff_lhmp.HAS_ZENOH`` is False): build it with
    /// ``maturin build --release --features zenoh``.
    ///
    /// Example:
    ///     >>> c = cliff_lhmp.Client.connect_zenoh("tcp/127.0.0.1:7447")
    ///     >>> c.predict("demo", [np.array([[0.0, -10.0, 0.5], [0.4, -9.5, 0.5]])]).k
    ///     20
    #[staticmethod]
    #[pyo3(signature = (endpoint, service = "cliff/predict", *, config = None, deadline = 0.05))]
    fn connect_zenoh(
        py: Python<'_>,
        endpoint: Option<&Bound<'_, PyAny>>,
        service: &str,
        config: Option<PathBuf>,
        deadline: f64,
    ) -> PyResult<Self> {
        if !HAS_ZENOH {
            return Err(PyRuntimeError::new_err(NO_ZENOH));
        }
        let endpoints = endpoints_arg(endpoint)?;
        let deadline = deadline_arg(deadline)?;
        if let Some(path) = &config {
            std::fs::metadata(path)
                .map_err(|e| io_err("config", &path.display().to_string(), &e))?;
        }
        let client = open_zenoh(py, &endpoints, config.as_deref(), service, deadline)?;
        Ok(Client {
            inner: Mutex::new(client),
            service: service.to_string(),
            deadline,
            endpoints,
            transport: "zenoh",
        })
    }

    /// reload_maps() -> None
    ///
    /// Ask the daemon to reload every map from its file (as ``SIGHUP`` does). Raises
    /// ``Rejected`` with status "reload-failed" when a file failed to load (that map
    /// keeps its old version).
    fn reload_maps(&self, py: Python<'_>) -> PyResult<()> {
        let deadline = self.deadline.max(Duration::from_secs(5));
        py.detach(|| {
            self.inner
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .reload_maps(deadline)
        })
        .map_err(|e| client_err(py, e))
    }

    /// The service name.
    #[getter]
    fn service(&self) -> &str {
        &self.service
    }

    /// How the client reaches its daemon: "iceoryx2" (shared memory, this host) or
    /// "zenoh".
    #[getter]
    fn transport(&self) -> &'static str {
        self.transport
    }

    fn __repr__(&self) -> String {
        let deadline = self.deadline.as_secs_f64();
        match self.transport {
            "zenoh" => format!(
                "Client.connect_zenoh({:?}, service={:?}, deadline={deadline})",
                self.endpoints, self.service
            ),
            _ => format!("Client(service={:?}, deadline={deadline})", self.service),
        }
    }
}

predict_fn! {
    #[pymethods]
    impl Client {
        /// Ask the daemon for ``k`` samples per person with the map it serves as ``map``.
        /// Arguments and result are those of ``cliff_lhmp.predict`` (``method="improved"``,
        /// ``speed_beta``, ``coast``, ``scores=True``, ``time=`` included; ``time`` picks the
        /// daemon's map of that time of day); the same map, histories and seed give the
        /// same numbers, over shared memory and over zenoh. Raises ``Rejected`` (a
        /// ValueError, with ``.status``, ``.field``, ``.agent`` and ``.row``) when the daemon
        /// refuses the request (unknown map, limits), ``NoDaemon``/``DaemonGone``
        /// (ConnectionError) and ``DeadlinePassed`` (TimeoutError).
        fn predict(
            &self,
            py: Python<'_>,
            map: &str,
            histories: &Bound<'_, PyAny>,
            ..args: PredictArgs
        ) -> PyResult<Prediction> {
            let params = args.params()?;
            let mut request = args.request(map)?;
            add_histories(py, histories, &mut request)?;
            let (shape, positions, lens, scores, version) = py
                .detach(|| {
                    let mut client = self.inner.lock().unwrap_or_else(|p| p.into_inner());
                    let p = client.predict(&request)?;
                    let positions: Vec<f32> = p.positions().as_flattened().to_vec();
                    let scores = p.has_scores().then(|| p.scores().to_vec());
                    Ok((p.shape(), positions, p.lens().to_vec(), scores, p.map_version()))
                })
                .map_err(|e| client_err(py, e))?;
            Prediction::from_flat(py, shape, positions, &lens, scores, params.dt, version)
        }
    }
}
