//! `cliff_lhmp.evaluate`: the evaluation of `cliff eval`, returning tables as lists of dicts.

use cliff::eval::protocol::{Protocol, Settings};
use cliff::eval::{
    EvalConfig, EvalReport, evaluate as rust_evaluate, summary_table, table_horizons,
};
use cliff::predict::{HeadingRule, Method, Params};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::args::{parse_format, read_tracks_arg};
use crate::map::Map;

/// The result of ``evaluate``.
///
/// Attributes:
///     summary: list of dicts, one per method and horizon (every dt step), keys
///         ``method``, ``horizon`` (s), ``people``, ``ade``, ``fde``, ``min_ade``,
///         ``min_fde``, ``ade_sd``, ``fde_sd``, ``min_ade_sd``, ``min_fde_sd``,
///         ``reach``, ``seeds`` (the columns of ``cliff eval``'s summary.csv).
///     per_person: list of dicts, one per person, method and horizon, keys
///         ``person_id``, ``method``, ``horizon``, ``ade``, ``fde``, ``min_ade``,
///         ``min_fde``, ``samples_reaching`` (per_person.csv).
///     people_total: people in the files.
///     people_evaluated: people the protocol kept.
///
/// ``pandas.DataFrame(result.summary)`` makes a data frame of either table.
#[pyclass(module = "cliff_lhmp", frozen)]
pub struct Evaluation {
    /// list of dicts, one per method and horizon step: method, horizon (s), people,
    /// ade, fde, min_ade, min_fde, ade_sd, fde_sd, min_ade_sd, min_fde_sd, top1_ade, top1_fde (the best-scored sample), reach, seeds.
    #[pyo3(get)]
    summary: Py<PyList>,
    /// list of dicts, one per person, method and horizon step: person_id, method,
    /// horizon (s), ade, fde, min_ade, min_fde, top1_ade, top1_fde, samples_reaching.
    #[pyo3(get)]
    per_person: Py<PyList>,
    /// People in the track files.
    #[pyo3(get)]
    people_total: usize,
    /// People the protocol kept (evaluated).
    #[pyo3(get)]
    people_evaluated: usize,
    report: EvalReport,
    horizon: f64,
    dt: f64,
}

#[pymethods]
impl Evaluation {
    /// table(horizons=None) -> str
    ///
    /// The summary as ``cliff eval`` prints it, at ``horizons`` (s; default: 2, 4, ...,
    /// 12 s up to the horizon, or 5, 10, 20, ... s beyond 12 s).
    #[pyo3(signature = (horizons = None))]
    fn table(&self, horizons: Option<Vec<f64>>) -> String {
        let hs = horizons.unwrap_or_else(|| table_horizons(self.horizon, self.dt));
        summary_table(&self.report.summary, &hs)
    }

    fn __repr__(&self) -> String {
        format!(
            "Evaluation(people_evaluated={}, people_total={}, summary=[{} rows], per_person=[{} rows])",
            self.people_evaluated,
            self.people_total,
            self.report.summary.len(),
            self.report.per_person.len()
        )
    }
}

/// Evaluate prediction methods on recorded trajectories, exactly as ``cliff eval``
/// with the same options (same people, seeds and numbers). Each person is observed
/// for ``obs`` seconds and predicted ``k`` times per seed up to ``horizon`` seconds
/// (or the end of their track); ADE/FDE and their top-k minimum are reported at every
/// ``dt`` step, averaged over the people counted there (``count``), then over ``seeds``
/// seeds (constant velocity, ``cvm`` and ``cvm-last``, runs once).
///
/// Args:
///     map: the Map to predict with.
///     tracks: a trajectory file or a list of them (rosbag2 recordings too, as in
///         ``build_map``).
///     format: ``None`` (the format recognised from each file: a rosbag2 bag or
///         ``.mcap`` file, a THÖR-MAGNI header row, another header row (csv), or six
///         headerless columns, "thor" or "atc" by the scale of their times) or "thor",
///         "atc", "magni", "csv", "rosbag2" (MCAP files are read as recordings whatever
///         the format).
///     topic: the topic of rosbag2 recordings (None: their one topic of people).
///     protocol: "reference" (the published code's row-based rules, for parity),
///         "seconds" (the same rules stated in time), "windows" (windows along long
///         tracks) or "tracklets" (the THÖR-MAGNI benchmark's cut: ``obs`` and
///         ``horizon`` rows of ``dt`` back to back along each track).
///     methods: list of "cliff", "cvm", "improved", "motion" (the built-in learned
///         motion model) and/or "cvm-last" (constant velocity of the last displacement)
///         (None: cliff and cvm).
///     count: "everyone" (every sample, a stopped one where it stopped, so every
///         method is scored over the same people; ``reach`` still says how many it
///         reached; the default) or "reached" (only the samples that reached a horizon,
///         the published code's rule).
///     max_speed: with "tracklets", leave out tracklets with a step faster than this
///         (m/s, tracking jumps); None keeps every one.
///
/// Example (the README's THÖR1 parity run):
///     >>> r = cliff_lhmp.evaluate(cliff_lhmp.Map.load("../shared/data/thor1/cliffmap.csv"),
///     ...     "../shared/data/thor1/exp-1-run-2.csv", protocol="reference", seeds=20)
///     >>> print(r.table())
#[pyfunction]
#[pyo3(signature = (map, tracks, *, format = None, protocol = "seconds", obs = 3.2, dt = 0.4,
    horizon = 12.0, radius = 0.7071067811865476, beta = 1.0, k = 20, seeds = 1,
    methods = None, sigma = 1.5,
    heading = "circular-mean", topic = None, count = "everyone", max_speed = None))]
#[allow(clippy::too_many_arguments)]
pub fn evaluate(
    py: Python<'_>,
    map: &Bound<'_, Map>,
    tracks: &Bound<'_, PyAny>,
    format: Option<&str>,
    protocol: &str,
    obs: f64,
    dt: f64,
    horizon: f64,
    radius: f64,
    beta: f64,
    k: i64,
    seeds: i64,
    methods: Option<Vec<String>>,
    sigma: f64,
    heading: &str,
    topic: Option<&str>,
    count: &str,
    max_speed: Option<f64>,
) -> PyResult<Evaluation> {
    let counting: cliff::eval::metrics::Counting = count
        .parse()
        .map_err(|e: String| PyValueError::new_err(format!("count: {e}")))?;
    let max_speed = match max_speed {
        None => f64::INFINITY,
        Some(v) if v > 0.0 => v,
        Some(v) => {
            return Err(PyValueError::new_err(format!(
                "max_speed: {v} is not a positive speed"
            )));
        }
    };
    let format = parse_format(format)?;
    let protocol: Protocol = protocol
        .parse()
        .map_err(|e: String| PyValueError::new_err(format!("protocol: {e}")))?;
    let heading: HeadingRule = heading
        .parse()
        .map_err(|e: String| PyValueError::new_err(format!("heading: {e}")))?;
    let methods =
        methods.unwrap_or_else(|| vec![Method::Cliff.name().into(), Method::Cvm.name().into()]);
    if methods.is_empty() {
        return Err(PyValueError::new_err("methods: names no method"));
    }
    let methods = methods
        .iter()
        .map(|m| m.parse::<Method>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| PyValueError::new_err(format!("methods: {e}")))?;
    for (name, v) in [("obs", obs), ("dt", dt), ("sigma", sigma)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(PyValueError::new_err(format!(
                "{name}: {v} is not a positive number"
            )));
        }
    }
    if k < 1 {
        return Err(PyValueError::new_err(format!("k: {k} must be at least 1")));
    }
    if seeds < 1 {
        return Err(PyValueError::new_err(format!(
            "seeds: {seeds} must be at least 1"
        )));
    }
    let params = Params {
        method: Method::Cliff,
        k: k as usize,
        dt,
        horizon,
        beta,
        radius,
        seed: 0,
        heading,
    };
    params.validate().map_err(|e| match e {
        cliff::predict::PredictError::Param { name, why } => {
            PyValueError::new_err(format!("{name}: {why}"))
        }
        e => PyValueError::new_err(e.to_string()),
    })?;
    let cfg = EvalConfig {
        motion_model: None,
        settings: Settings {
            protocol,
            obs,
            dt,
            horizon,
            sigma,
            max_speed,
            counting,
            ..Settings::default()
        },
        params,
        seeds: seeds as usize,
        methods,
        options: Default::default(),
    };
    let tracks = read_tracks_arg(tracks, format, topic)?;
    let m = map.get().inner.clone();
    let report = py
        .detach(move || rust_evaluate(&m, &tracks, &cfg, &|| {}))
        .map_err(|e| PyValueError::new_err(format!("evaluate: {e}")))?;
    let summary = PyList::empty(py);
    for r in &report.summary {
        let d = PyDict::new(py);
        d.set_item("method", r.method.name())?;
        d.set_item("horizon", r.horizon)?;
        d.set_item("people", r.people)?;
        d.set_item("ade", r.ade)?;
        d.set_item("fde", r.fde)?;
        d.set_item("min_ade", r.min_ade)?;
        d.set_item("min_fde", r.min_fde)?;
        d.set_item("ade_sd", r.ade_sd)?;
        d.set_item("fde_sd", r.fde_sd)?;
        d.set_item("min_ade_sd", r.min_ade_sd)?;
        d.set_item("min_fde_sd", r.min_fde_sd)?;
        d.set_item("top1_ade", r.top1_ade)?;
        d.set_item("top1_fde", r.top1_fde)?;
        d.set_item("reach", r.reach)?;
        d.set_item("seeds", r.seeds)?;
        summary.append(d)?;
    }
    let per_person = PyList::empty(py);
    for r in &report.per_person {
        let d = PyDict::new(py);
        d.set_item("person_id", r.person_id)?;
        d.set_item("method", r.method.name())?;
        d.set_item("horizon", r.horizon)?;
        d.set_item("ade", r.ade)?;
        d.set_item("fde", r.fde)?;
        d.set_item("min_ade", r.min_ade)?;
        d.set_item("min_fde", r.min_fde)?;
        d.set_item("top1_ade", r.top1_ade)?;
        d.set_item("top1_fde", r.top1_fde)?;
        d.set_item("samples_reaching", r.samples_reaching)?;
        per_person.append(d)?;
    }
    Ok(Evaluation {
        summary: summary.unbind(),
        per_person: per_person.unbind(),
        people_total: report.people_total,
        people_evaluated: report.people_evaluated,
        report,
        horizon,
        dt,
    })
}
