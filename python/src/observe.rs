//! `Client.observe`: tracked people's rows sent to a `cliffd` that learns its map
//! (`cliffd --learn NAME`).

use cliff_client::protocol::MAX_OBSERVE_ROWS;
use cliff_client::{Observation, ObserveRequest};
use numpy::PyUntypedArrayMethods;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::client::Client;
use crate::errors::client_err;
use crate::histories::as_f64_array;

const COLUMNS: [&str; 5] = ["t", "x", "y", "speed", "heading"];

#[pymethods]
impl Client {
    /// Send one tracked person's rows to a daemon that learns the map ``map``.
    ///
    /// ``rows`` is a 2-D array of rows (t, x, y) or (t, x, y, speed, heading), oldest
    /// first, times strictly increasing; ``track`` is the id this client gives the person
    /// (stable while it tracks them); ``end=True`` says the last row is the track's last
    /// (the person left the view). A robot may send each person's whole recent history
    /// every time: the daemon counts a row once per client, track and time.
    ///
    /// Returns a dict: ``accepted`` (rows new to the daemon), ``duplicates`` (rows it had)
    /// and ``map_version`` (the learned map's version). Raises ``Rejected`` with status
    /// "over-budget" when the client is over its budget (nothing was taken: send again
    /// later), "not-learning" for a map the daemon serves but does not learn, and over
    /// zenoh "not-allowed" when the site's access rules keep this robot from teaching.
    ///
    /// Example:
    ///     >>> c.observe("thor1", 7, np.array([[0.0, 1.0, 2.0], [0.4, 1.5, 2.0]]))
    ///     {'accepted': 2, 'duplicates': 0, 'map_version': 0}
    #[pyo3(signature = (map, track, rows, *, end = false))]
    fn observe<'py>(
        &self,
        py: Python<'py>,
        map: &str,
        track: u32,
        rows: &Bound<'py, PyAny>,
        end: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mut request = ObserveRequest::new(map).map_err(|e| client_err(py, e))?;
        let arr = as_f64_array(py, rows, 0)?;
        let shape = arr.shape();
        let (len, cols) = (shape[0], shape[1]);
        if cols != 3 && cols != 5 {
            return Err(PyValueError::new_err(format!(
                "rows: expected 3 columns (t, x, y) or 5 (t, x, y, speed, heading), got shape ({len}, {cols})"
            )));
        }
        if len == 0 || len > MAX_OBSERVE_ROWS as usize {
            return Err(PyValueError::new_err(format!(
                "rows: {len} rows, give 1 to {MAX_OBSERVE_ROWS}"
            )));
        }
        let v = arr.as_array();
        for (r, row) in v.outer_iter().enumerate() {
            if let Some(c) = row.iter().position(|x| !x.is_finite()) {
                return Err(PyValueError::new_err(format!(
                    "rows: row {r} {} (column {c}): {} is not a finite number",
                    COLUMNS[c], row[c]
                )));
            }
        }
        request.add_track(
            track,
            v.outer_iter().map(|row| {
                if cols == 5 {
                    Observation::with_velocity(row[0], row[1], row[2], row[3], row[4])
                } else {
                    Observation::position(row[0], row[1], row[2])
                }
            }),
        );
        if end {
            request.end_track();
        }
        let reply = py
            .detach(|| {
                self.inner
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .observe(&request)
            })
            .map_err(|e| client_err(py, e))?;
        let d = PyDict::new(py);
        d.set_item("accepted", reply.accepted)?;
        d.set_item("duplicates", reply.duplicates)?;
        d.set_item("map_version", reply.map_version)?;
        Ok(d)
    }
}
