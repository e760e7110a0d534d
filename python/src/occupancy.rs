//! `Prediction.occupancy`, `Prediction.occupancy_window` and `Prediction.path_meets`:
//! the core library's occupancy over a grid from a prediction's samples.

use cliff::occupancy::{
    GridSpec, Occupancy, OccupancyError, PlanPoint, Samples, Settings, Stopped, path_meets,
};
use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray1, PyArray3, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::prediction::Prediction;

fn occ_err(e: OccupancyError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// A grid from a dict (`origin`, `resolution`, `width`, `height`) or a tuple
/// `(origin_x, origin_y, resolution, width, height)`.
fn grid_arg(grid: &Bound<'_, PyAny>) -> PyResult<GridSpec> {
    let bad = |why: &str| PyValueError::new_err(format!("grid: {why}"));
    let spec = if let Ok(d) = grid.cast::<PyDict>() {
        let get = |k: &str| -> PyResult<Bound<'_, PyAny>> {
            d.get_item(k)?
                .ok_or_else(|| bad(&format!("the dict has no '{k}'")))
        };
        let origin: (f64, f64) = get("origin")?
            .extract()
            .map_err(|_| bad("'origin' is not a pair of numbers"))?;
        GridSpec {
            origin: [origin.0, origin.1],
            resolution: get("resolution")?
                .extract()
                .map_err(|_| bad("'resolution' is not a number"))?,
            width: get("width")?
                .extract()
                .map_err(|_| bad("'width' is not a whole number of cells"))?,
            height: get("height")?
                .extract()
                .map_err(|_| bad("'height' is not a whole number of cells"))?,
        }
    } else {
        let (x, y, resolution, width, height): (f64, f64, f64, usize, usize) =
            grid.extract().map_err(|_| {
                bad("expected a dict (origin, resolution, width, height) or a tuple (origin_x, origin_y, resolution, width, height)")
            })?;
        GridSpec {
            origin: [x, y],
            resolution,
            width,
            height,
        }
    };
    spec.validate().map_err(occ_err)?;
    Ok(spec)
}

fn settings_arg(person_radius: f64, bandwidth_scale: f64, stopped: &str) -> PyResult<Settings> {
    let stopped = match stopped.trim().to_ascii_lowercase().as_str() {
        "renormalise" | "renormalize" => Stopped::Renormalise,
        "drop" => Stopped::Drop,
        "hold" => Stopped::Hold,
        other => {
            return Err(PyValueError::new_err(format!(
                "stopped: unknown rule '{other}' (expected renormalise, drop or hold)"
            )));
        }
    };
    let s = Settings {
        person_radius,
        bandwidth_scale,
        stopped,
        ..Settings::default()
    };
    s.validate().map_err(occ_err)?;
    Ok(s)
}

/// The prediction's buffers, flat, as the core library reads them.
fn flat(p: &Prediction, py: Python<'_>) -> PyResult<(Vec<[f32; 2]>, Vec<u32>)> {
    let pos = p.positions_array(py).readonly();
    let pos: Vec<[f32; 2]> = pos
        .as_array()
        .as_standard_layout()
        .as_slice()
        .unwrap_or(&[])
        .chunks_exact(2)
        .map(|c| [c[0], c[1]])
        .collect();
    let lens = p.lengths_array(py).readonly();
    let lens: Vec<u32> = lens.as_array().iter().map(|&v| v.max(0) as u32).collect();
    Ok((pos, lens))
}

/// A float32 array (layers, height, width) of an occupancy's cells.
fn cells_array<'py>(
    py: Python<'py>,
    occ: &Occupancy,
    grid: &GridSpec,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let a = Array3::from_shape_vec(
        (occ.layers(), grid.height, grid.width),
        occ.cells().to_vec(),
    )
    .map_err(|e| PyValueError::new_err(format!("internal shape error: {e}")))?;
    Ok(a.into_pyarray(py))
}

#[pymethods]
impl Prediction {
    /// occupancy(grid, times, person_radius=0.3, bandwidth_scale=1.0, stopped="renormalise") -> ndarray
    ///
    /// The probability that each cell of ``grid`` holds someone at each of ``times``
    /// (seconds after the prediction's start, from ``dt`` to ``steps * dt``): a float32
    /// array of shape (len(times), height, width), row 0 at the grid's origin (the
    /// smallest y), column 0 at the smallest x. ``grid`` is a dict with ``origin``
    /// (x, y of the corner of cell (0, 0)), ``resolution`` (m), ``width`` and
    /// ``height`` (cells), or a tuple (origin_x, origin_y, resolution, width, height).
    /// Each sample is a normal kernel of sigma sqrt(person_radius^2 + bandwidth^2),
    /// the bandwidth Silverman's from the person's samples times ``bandwidth_scale``;
    /// people are independent. ``stopped``: what a sample that stopped means later:
    /// ``renormalise`` (the person spread over the samples that go on), ``drop``,
    /// ``hold`` (it stays where it stopped).
    #[pyo3(signature = (grid, times, person_radius=0.3, bandwidth_scale=1.0, stopped="renormalise"))]
    fn occupancy<'py>(
        &self,
        py: Python<'py>,
        grid: &Bound<'py, PyAny>,
        times: Vec<f64>,
        person_radius: f64,
        bandwidth_scale: f64,
        stopped: &str,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let grid = grid_arg(grid)?;
        let settings = settings_arg(person_radius, bandwidth_scale, stopped)?;
        let (pos, lens) = flat(self, py)?;
        let shape = self.shape3();
        let dt = self.dt_value();
        let mut occ = Occupancy::new();
        py.detach(|| {
            let samples = Samples::new(&pos, &lens, shape, dt)?;
            occ.compute(&samples, &grid, &times, &settings)
        })
        .map_err(occ_err)?;
        cells_array(py, &occ, &grid)
    }

    /// occupancy_window(grid, start, end, person_radius=0.3, bandwidth_scale=1.0, stopped="renormalise") -> ndarray
    ///
    /// The probability that someone is in each cell at some time between ``start`` and
    /// ``end`` (s): a float32 array of shape (height, width). Per person, the fraction
    /// of the predicted futures (samples, each smoothed like ``occupancy``) that pass
    /// through the cell; people are independent.
    #[pyo3(signature = (grid, start, end, person_radius=0.3, bandwidth_scale=1.0, stopped="renormalise"))]
    #[allow(clippy::too_many_arguments)]
    fn occupancy_window<'py>(
        &self,
        py: Python<'py>,
        grid: &Bound<'py, PyAny>,
        start: f64,
        end: f64,
        person_radius: f64,
        bandwidth_scale: f64,
        stopped: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let grid = grid_arg(grid)?;
        let settings = settings_arg(person_radius, bandwidth_scale, stopped)?;
        let (pos, lens) = flat(self, py)?;
        let shape = self.shape3();
        let dt = self.dt_value();
        let mut occ = Occupancy::new();
        py.detach(|| {
            let samples = Samples::new(&pos, &lens, shape, dt)?;
            occ.window(&samples, &grid, start, end, &settings)
        })
        .map_err(occ_err)?;
        cells_array(py, &occ, &grid)?.get_item(0)
    }

    /// path_meets(plan, robot_radius, person_radius=0.3, stopped="renormalise") -> ndarray
    ///
    /// For each person, the probability that a robot following ``plan`` meets them: the
    /// fraction of their samples that come within ``robot_radius + person_radius`` of
    /// the robot at the same time. ``plan``: rows (x, y, t), times non-decreasing, t in
    /// seconds after the prediction's start; the robot and the samples move in straight
    /// lines between their points. A float32 array of shape (agents,).
    #[pyo3(signature = (plan, robot_radius, person_radius=0.3, stopped="renormalise"))]
    fn path_meets<'py>(
        &self,
        py: Python<'py>,
        plan: Vec<(f64, f64, f64)>,
        robot_radius: f64,
        person_radius: f64,
        stopped: &str,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let settings = settings_arg(person_radius, 1.0, stopped)?;
        let plan: Vec<PlanPoint> = plan
            .into_iter()
            .map(|(x, y, t)| PlanPoint {
                position: [x, y],
                time: t,
            })
            .collect();
        let (pos, lens) = flat(self, py)?;
        let shape = self.shape3();
        let dt = self.dt_value();
        let mut out = vec![0.0f32; shape.0];
        py.detach(|| {
            let samples = Samples::new(&pos, &lens, shape, dt)?;
            path_meets(&samples, &plan, robot_radius, &settings, &mut out)
        })
        .map_err(occ_err)?;
        Ok(out.into_pyarray(py))
    }
}
