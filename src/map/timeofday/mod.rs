//! Time-of-day map sets: one CLiFF-map per slice of the day beside the all-day map.
//!
//! Where people walk changes over a day (a flow into a hall in the morning, out of it in
//! the evening). A [`MapSet`] holds the all-day map and one map per time-of-day slice
//! (one hour, say); a prediction takes the map of the slice its observation time falls
//! in ([`MapSet::at`]), and the all-day map where a slice has no map of its own.
//!
//! Datasets store time as they please (ATC: unix time), so a set carries a *clock
//! offset*: seconds added to a timestamp to get the local time whose time of day picks
//! the slice (ATC, recorded in Japan: `+32400`, UTC+9). The offset is stored in the file
//! and can be changed at prediction ([`MapSet::set_clock_offset`]).
//!
//! [`build_map_set`] learns a set from timestamped observations: each slice's map
//! borrows strength from the neighbouring slices and from the all-day map where its
//! own data are thin (the rule is in [`Smoothing`]), so that a quiet hour is no worse
//! than the all-day map.
//!
//! Files: a set is a version-2 snapshot (`.cliff`); [`MapSet::load`] also reads
//! version-1 snapshots and CSV maps (a set without slices), and [`CliffMap::load`] reads
//! a version-2 file as its all-day map, so every reader of single maps keeps working.
//!
//! ```
//! use std::sync::Arc;
//! use cliff::map::{CliffMap, MapSet, SetParts};
//! let day = Arc::new(CliffMap::demo());
//! // 24 one-hour slices; only 13:00-14:00 has a map of its own here.
//! let mut slices = vec![None; 24];
//! let afternoon = Arc::new(CliffMap::demo());
//! slices[13] = Some(afternoon.clone());
//! let set = MapSet::from_parts(SetParts {
//!     all_day: day.clone(),
//!     slices,
//!     slice_length: 3600.0,
//!     clock_offset: 9.0 * 3600.0, // timestamps are UTC, local time is UTC+9
//!     smoothing: None,
//!     observations: Vec::new(),
//! })
//! .unwrap();
//! // 2012-10-24 04:30 UTC is 13:30 local time
//! assert!(Arc::ptr_eq(set.at(1_351_053_000.0), &afternoon));
//! assert_eq!(set.slice_index(1_351_053_000.0), Some(13));
//! // 08:30 local: no slice map, the all-day map stands in
//! assert!(Arc::ptr_eq(set.at(1_351_053_000.0 - 5.0 * 3600.0), &day));
//! ```
//!
//! | file | what it holds |
//! |---|---|
//! | [`clock`] | the day, slice lengths and clock offsets: [`slice_count`], [`slice_label`] |
//! | [`smoothing`] | [`Smoothing`]: how a slice borrows from its neighbours and the day |
//! | [`set`] | [`MapSet`], [`SetParts`]: the maps of a set and the slice of a time |
//! | `set_file` | reading and writing a set ([`MapSet::load`], [`MapSet::save`]) |
//! | [`map_at`] | [`MapAt`]: a single map or a set, as evaluation takes them |
//! | `build` | [`build_map_set`]: learning a set from timestamped observations |

mod build;
pub mod clock;
pub mod map_at;
pub mod set;
mod set_file;
pub mod smoothing;

pub use build::{BuiltSet, SliceParams, SliceSummary, build_map_set, build_map_set_with_progress};
pub use clock::{
    DAY_SECONDS, MAX_CLOCK_OFFSET, MIN_SLICE_SECONDS, clock_label, slice_count, slice_label,
};
pub use map_at::MapAt;
pub use set::{MapSet, SetParts};
pub use smoothing::Smoothing;
