//! Arguments several functions share: the trajectory files (`tracks`, `format`, `topic`) and
//! positive numbers, checked with errors that name the argument.

use std::path::PathBuf;

use cliff::tracks::{DatasetError, Format, ReadError, Track, read_many_as};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyString;

use crate::errors::io_err;

/// Which format a `format=` argument names (`None`: each file's own, recognised from it).
pub fn parse_format(format: Option<&str>) -> PyResult<Option<Format>> {
    format
        .map(str::parse)
        .transpose()
        .map_err(|e: String| PyValueError::new_err(format!("format: {e}")))
}

/// The `tracks` argument: one path or a sequence of paths, read with `format` (`None`:
/// each file in the format recognised from it; rosbag2 recordings, MCAP files, whatever
/// the format: their `topic`, or their one topic of people). A file whose format is not
/// recognised is a ValueError naming the `format=` values to choose from.
pub fn read_tracks_arg(
    tracks: &Bound<'_, PyAny>,
    format: Option<Format>,
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
        ReadError::Dataset(DatasetError::Unrecognised {
            file,
            reason,
            choices,
        }) => {
            let give: Vec<String> = choices.iter().map(|c| format!("format=\"{c}\"")).collect();
            let give = match give.split_last() {
                Some((last, init)) if !init.is_empty() => format!("{} or {last}", init.join(", ")),
                _ => give.join(""),
            };
            PyValueError::new_err(format!(
                "tracks: {file}: the format is not recognised: {reason}; give {give}"
            ))
        }
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
