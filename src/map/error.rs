//! [`MapError`], and the map file formats ([`MapFormat`]).

use std::path::Path;

/// Errors from building, reading or writing maps.
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    /// A value in a file is unusable; names the file, line and column (1-based).
    #[error("{file}:{line}: column {column}: {message}")]
    Parse {
        /// The file (or `<string>`).
        file: String,
        /// 1-based line number.
        line: usize,
        /// 1-based column number (0 when the whole line is meant).
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A location breaks a map invariant (index into the location list).
    #[error("location {index} at ({x}, {y}): {message}")]
    Location {
        /// Index of the location in the map.
        index: usize,
        /// x of the location.
        x: f64,
        /// y of the location.
        y: f64,
        /// What is wrong.
        message: String,
    },
    /// The map has no locations.
    #[error("the map has no locations")]
    Empty,
    /// A snapshot file is damaged or of another format.
    #[error("{file}: not a valid cliff snapshot: {message}")]
    Snapshot {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A speed prior's values are unusable.
    #[error("{0}")]
    SpeedPrior(String),
    /// A time-of-day map set or its options are inconsistent.
    #[error("time-of-day maps: {0}")]
    TimeOfDay(String),
    /// The file's extension names no known map format.
    #[error("{0}: unknown map format (use .csv for the published format or .cliff for a snapshot)")]
    UnknownFormat(String),
    /// Reading or writing failed.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// The underlying error.
        source: std::io::Error,
    },
}

/// The on-disk map formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapFormat {
    /// The published CSV format (one row per component, no header).
    Csv,
    /// Our binary snapshot (postcard, magic, version, checksum).
    Snapshot,
}

impl MapFormat {
    /// The format named by a path's extension (`.csv` or `.cliff`).
    pub fn from_path(path: &Path) -> Result<Self, MapError> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
        {
            Some(e) if e == "csv" => Ok(Self::Csv),
            Some(e) if e == "cliff" || e == "snapshot" => Ok(Self::Snapshot),
            _ => Err(MapError::UnknownFormat(path.display().to_string())),
        }
    }
}
