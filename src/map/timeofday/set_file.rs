//! Reading and writing a [`MapSet`]: a version-2 snapshot, or a version-1 snapshot or
//! CSV map read as a set without slices.

use std::path::Path;

use super::set::MapSet;
use crate::bounded_read::read_at_most;
use crate::map::csv::read_csv_bytes;
use crate::map::snapshot::{decode_set, encode_set};
use crate::map::{MAX_MAP_FILE_BYTES, MapError, MapFormat};

impl MapSet {
    /// Read a set: a version-2 snapshot, or a version-1 snapshot or CSV map as a set
    /// without slices (by extension, as [`CliffMap::load`](crate::map::CliffMap::load); at most
    /// [`MAX_MAP_FILE_BYTES`]).
    pub fn load(path: impl AsRef<Path>) -> Result<Self, MapError> {
        let path = path.as_ref();
        let format = MapFormat::from_path(path)?;
        let name = path.display().to_string();
        let bytes = read_at_most(path, MAX_MAP_FILE_BYTES).map_err(|source| MapError::Io {
            file: name.clone(),
            source,
        })?;
        match format {
            MapFormat::Csv => read_csv_bytes(&bytes, &name).map(Self::single),
            MapFormat::Snapshot => decode_set(&bytes, &name),
        }
    }

    /// Read a set from snapshot bytes (version 1 or 2); `file` names the source in
    /// errors. The checks of [`read_snapshot_bytes`](super::read_snapshot_bytes) apply
    /// to every map of the set.
    pub fn from_snapshot_bytes(bytes: &[u8], file: &str) -> Result<Self, MapError> {
        decode_set(bytes, file)
    }

    /// The snapshot bytes of the set: version 2, or version 1 (readable by every build)
    /// for a set without slices.
    pub fn to_snapshot_bytes(&self) -> Vec<u8> {
        encode_set(self)
    }

    /// Write the set: a snapshot (`.cliff`). A CSV file holds one map: a set without
    /// slices can be written as CSV, a set with slices cannot (export one of its maps
    /// with [`CliffMap::save`](crate::map::CliffMap::save)).
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), MapError> {
        let path = path.as_ref();
        match MapFormat::from_path(path)? {
            MapFormat::Csv if !self.is_sliced() => self.all_day().save(path),
            MapFormat::Csv => Err(MapError::TimeOfDay(format!(
                "{}: a CSV file holds one map, not a set of {} slices (write a .cliff snapshot, or export one slice)",
                path.display(),
                self.slices().len()
            ))),
            MapFormat::Snapshot => {
                std::fs::write(path, self.to_snapshot_bytes()).map_err(|source| MapError::Io {
                    file: path.display().to_string(),
                    source,
                })
            }
        }
    }
}
