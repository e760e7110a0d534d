//! Arguments several functions share: the trajectory files (`tracks`, `format`, `topic`) and
//! positive numbers, checked with errors that name the argument.

use std::path::PathBuf;

use cliff::tracks::{DatasetError, Format, ReadError, Track, read_many_as};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyString;

use crate::errors::io_err;

/// Which format a `format=` argument names.
pub fn parse_format(format: &str) -> PyResult<Format> {
    format
        .parse()
        .map_err(|e: String| PyValueError::new_err(format!("format: {e}")))
}

/// The `tracks` argument: one path or a sequence of paths, read with `format` (rosbag2
/// recordings, MCAP files, whatever the format: their `topic`, or their one topic of
/// people).
pub fn read_tracks_arg(
    tracks: &Bound<'_, PyAny>,
    format: Format,
    topic: Option<&str>,
) -> PyResult<Vec<Track>> {
    let paths: Vec<PathBuf> = if tracks.is_instance_of::<PyString>()
        || tracks.hasattr("__fspath__")?
    {
        vec![tracks.extract()?]
    } else {
        tracks.extract().map_err(|_| {
            PyTypeError::new_err(
                "tracks: expected a path (str or os.PathLike) or a list of paths to trajectory files",
            )
        })?
    };
    if paths.is_empty() {
        return Err(PyValueError::new_err("tracks: names no file"));
    }
    for p in &paths {
        if !p.exists() {
            return Err(pyo3::exceptions::PyFileNotFoundError::new_err(format!(
                "tracks: {} does not exist",
                p.display()
            )));
        }
    }
    read_many_as(&paths, format, None, topic).map_err(|e| match &e {
        ReadError::Dataset(DatasetError::Io { file, source }) => io_err("tracks", file, source),
        _ => PyValueError::new_err(format!("tracks: {e}")),
    })
}

/// `v` when it is a finite positive number, else a ValueError naming `name`.
pub fn positive(name: &str, v: f64) -> PyResult<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(PyValueError::new_err(format!(
            "{name}: {v} is not a positive number"
        )))
    }
}
