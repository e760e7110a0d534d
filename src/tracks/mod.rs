//! Tracks: what people were seen doing, the ground floor every other layer reads.
//!
//! A [`Track`] is the [`Row`]s of one person in time order (time, position, speed,
//! motion angle). Readers turn files into tracks and hold every value to the bounds of
//! [`track`] ([`MAX_TIME`], [`MAX_POSITION`], [`MAX_SPEED`], [`MAX_ANGLE`], at most
//! [`MAX_TRACK_FILE_BYTES`] per file), with errors naming the file, line and column.
//!
//! | file | what it holds |
//! |---|---|
//! | [`track`] | [`Row`], [`Track`], the bounds, [`DatasetError`], [`keep_time_range`] |
//! | [`format`] | [`Format`]: `thor`, `atc`, `magni`, `csv`, `rosbag2` |
//! | [`detect`] | [`Format::detect`]: a file's format recognised from its start |
//! | [`read`] | the entry points: [`read_tracks`], [`read_many`], [`parse_tracks`], [`read_many_as`] (which recognises each file's format when none is named) |
//! | `six_columns` | the THÖR and ATC reader (no header, six columns) |
//! | [`columns`] | the named-column reader (THÖR-MAGNI, any CSV with a header): [`Columns`] |
//! | [`rosbag2`] | rosbag2 recordings (MCAP) of people trackers: [`read_recording`] |
//! | [`scene`] | synthetic people walking in the built-in demo hall |
//!
//! ```
//! use cliff::tracks::{parse_tracks, Format};
//! let tracks = parse_tracks("0.0,7,1.0,2.0,1.2,0.5\n0.4,7,1.4,2.2,1.1,0.4\n", "inline.csv", Format::Thor)?;
//! assert_eq!((tracks[0].id, tracks[0].rows.len()), (7, 2));
//! # Ok::<(), cliff::tracks::DatasetError>(())
//! ```

pub mod columns;
pub mod detect;
pub mod format;
pub mod read;
pub mod rosbag2;
pub mod scene;
mod six_columns;
pub mod track;

pub use columns::{Columns, NamedTracks, parse_named, read_many_named, read_named};
pub use format::Format;
pub use read::{ReadError, parse_track_bytes, parse_tracks, read_many, read_many_as, read_tracks};
pub use rosbag2::{parse_recording, read_recording};
pub use track::{
    DatasetError, MAX_ANGLE, MAX_POSITION, MAX_SPEED, MAX_TIME, MAX_TRACK_FILE_BYTES, Row, Track,
    keep_time_range,
};
