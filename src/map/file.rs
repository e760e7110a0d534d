//! Reading and writing one map: [`CliffMap::load`] and [`CliffMap::save`], by the
//! file's extension (`.csv`, the published format; `.cliff`, our snapshot).

use std::path::Path;

use super::cliff_map::CliffMap;
use super::csv::{read_csv, write_csv};
use super::error::{MapError, MapFormat};
use super::snapshot::{read_snapshot, write_snapshot};

impl CliffMap {
    /// Read a map from a file, by extension: `.csv` (published format) or `.cliff` (snapshot;
    /// a time-of-day set gives its all-day map, see [`MapSet::load`] for the whole set).
    pub fn load(path: impl AsRef<Path>) -> Result<Self, MapError> {
        let path = path.as_ref();
        match MapFormat::from_path(path)? {
            MapFormat::Csv => read_csv(path),
            MapFormat::Snapshot => read_snapshot(path),
        }
    }

    /// Write the map to a file, by extension: `.csv` or `.cliff`.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), MapError> {
        let path = path.as_ref();
        match MapFormat::from_path(path)? {
            MapFormat::Csv => write_csv(self, path),
            MapFormat::Snapshot => write_snapshot(self, path),
        }
    }
}
