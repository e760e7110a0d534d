//! `cliff_lhmp.Client`: predictions from a running `cliffd` over shared memory.

use std::sync::Mutex;
use std::time::Duration;

use cliff_client::{Client as RustClient, ClientOptions, WaitMode};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::errors::client_err;
use crate::histories::{PredictArgs, add_histories, time_arg};
use crate::prediction::Prediction;

/// A connection to the ``cliffd`` daemon serving ``service``.
///
/// ``Client(service="cliff/predict", prefix=None, wait="hybrid", deadline=0.05)``
/// connects at once and raises ``NoDaemon`` when no daemon serves the service.
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
    inner: Mutex<RustClient>,
    service: String,
    deadline: Duration,
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
        })
    }

    /// Ask the daemon for ``k`` samples per person with the map it serves as ``map``.
    /// Arguments and result are those of ``cliff_lhmp.predict`` (``method="improved"``,
    /// ``speed_beta``, ``coast``, ``scores=True``, ``time=`` included; ``time`` picks the
    /// daemon's map of that time of day, once it serves time-of-day maps); the same
    /// map, histories and seed give the same numbers. Raises ``Rejected`` (a ValueError,
    /// with ``.status`` and ``.field``) when the daemon refuses the request (unknown
    /// map, limits), ``NoDaemon``/``DaemonGone`` (ConnectionError) and
    /// ``DeadlinePassed`` (TimeoutError).
    #[pyo3(signature = (map, histories, *, k = 20, dt = 0.4, horizon = 12.0, beta = 1.0,
        radius = 0.7071067811865476, seed = 0, method = "cliff", heading = "circular-mean",
        speed_beta = 0.0, coast = 0.0, scores = false, time = None))]
    #[allow(clippy::too_many_arguments)]
    fn predict(
        &self,
        py: Python<'_>,
        map: &str,
        histories: &Bound<'_, PyAny>,
        k: i64,
        dt: f64,
        horizon: f64,
        beta: f64,
        radius: f64,
        seed: i128,
        method: &str,
        heading: &str,
        speed_beta: f64,
        coast: f64,
        scores: bool,
        time: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Prediction> {
        let args = PredictArgs {
            k,
            dt,
            horizon,
            beta,
            radius,
            seed,
            method,
            heading,
            speed_beta,
            coast,
            scores,
            time: time_arg(time)?,
        };
        let params = args.params()?;
        let mut request = args.request(map)?;
        add_histories(py, histories, &mut request)?;
        let (shape, positions, lens, scores) = py
            .detach(|| {
                let mut client = self.inner.lock().unwrap_or_else(|p| p.into_inner());
                let p = client.predict(&request)?;
                let positions: Vec<f32> = p.positions().as_flattened().to_vec();
                let scores = p.has_scores().then(|| p.scores().to_vec());
                Ok((p.shape(), positions, p.lens().to_vec(), scores))
            })
            .map_err(|e| client_err(py, e))?;
        Prediction::from_flat(py, shape, positions, &lens, scores, params.dt)
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

    fn __repr__(&self) -> String {
        format!(
            "Client(service={:?}, deadline={})",
            self.service,
            self.deadline.as_secs_f64()
        )
    }
}
