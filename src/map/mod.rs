//! CLiFF-maps: per-location semi-wrapped Gaussian mixtures over velocity.
//!
//! A [`CliffMap`] holds [`Location`]s on a regular grid. Each location carries a
//! mixture of [`Component`]s over (direction, speed) and the share of observations
//! seen there ([`Location::observation_ratio`]).
//!
//! Locations keep the values they were given (so that a CSV file written back holds
//! the same numbers); at construction the map derives sampling tables from them with
//! every covariance clamped to positive semi-definite and every location's weights
//! renormalised to sum to one. [`CliffMap::report`] counts what had to be fixed.
//!
//! ```
//! use cliff::map::CliffMap;
//! let map = CliffMap::demo();
//! let info = map.info();
//! assert!(info.locations > 100);
//! // The location chosen by CLiFF-LHMP near a point in the demo hall:
//! let near = map.best_near(glam::DVec2::new(0.0, 0.0), 1.0);
//! assert!(near.is_some());
//! ```
//!
//! | file | what it holds |
//! |---|---|
//! | `cliff_map` | [`CliffMap`]: construction, files, summary |
//! | `location` | [`Location`], [`Component`] |
//! | `validate` | checks of a map's values, [`clamp_psd`] |
//! | `limits` | the bounds ([`MAX_COORDINATE`], [`MAX_COMPONENTS`], ...) |
//! | `file` | [`CliffMap::load`], [`CliffMap::save`] |
//! | `error` | [`MapError`], [`MapFormat`] |
//! | `info` | [`MapReport`], [`MapInfo`] |
//! | `lookup` | [`Lookup`] and the radius queries ([`CliffMap::best_near`], ...) |
//! | `sampling_tables` | the tables the draws read, built at construction |
//! | `sampling` | the draws: [`DirectionSampler`], follow, velocity |
//! | `mixture` | merging and capping a location's components |
//! | [`movement`] | how far a location's mixture moved (total variation) |
//! | [`diff`] | what changed between two maps |
//! | `log_density`, `density` | the map's density of a step (scores) |
//! | `grid`, `neighbours`, `tables` | the grid index, neighbour tables and their cache |
//! | `csv`, `snapshot` | the published CSV format and our snapshot format |
//! | `demo` | the built-in demo map |
//! | [`stats`] | circular-linear statistics and the 2x2 Gaussian helpers of building, updates, densities and scores |
//! | [`build`] | building a map from tracks (mean shift + EM) |
//! | [`score`] | scoring a map on held-out tracks |
//! | [`update`] | the online update |
//! | [`timeofday`] | time-of-day map sets |

#[cfg(target_arch = "x86_64")]
mod block_loads;
pub mod build;
mod cliff_map;
mod csv;
mod demo;
mod density;
pub mod diff;
mod error;
mod file;
mod grid;
mod info;
mod limits;
mod location;
mod log_density;
mod lookup;
mod mixture;
pub mod movement;
mod neighbours;
mod sampling;
mod sampling_tables;
pub mod score;
mod snapshot;
pub mod stats;
mod tables;
#[cfg(test)]
mod tests;
pub mod timeofday;
pub mod update;
mod validate;

pub use build::{BuildParams, Observation, build_map};
pub use cliff_map::CliffMap;
pub use csv::{read_csv, read_csv_bytes, read_csv_str, write_csv, write_csv_string};
pub use error::{MapError, MapFormat};
pub use grid::GridIndex;
pub use info::{MapInfo, MapReport};
pub use limits::*;
pub use location::{Component, Location};
pub use lookup::Lookup;
pub use neighbours::NeighbourTable;
pub use neighbours::TableError;
#[cfg(target_arch = "x86_64")]
pub(crate) use neighbours::{Probe8, lane_mask};
pub use sampling::DirectionSampler;
pub use sampling_tables::FollowWeights;
pub use score::{ScoreParams, ScoreReport, score};
pub use snapshot::{
    SET_SNAPSHOT_VERSION, SNAPSHOT_MAGIC, SNAPSHOT_VERSION, read_snapshot, read_snapshot_bytes,
    write_snapshot,
};
pub use tables::{DEFAULT_TABLE_BUDGET, TableCache, TableStats};
pub use timeofday::{
    BuiltSet, MapAt, MapSet, SetParts, SliceParams, SliceSummary, Smoothing, build_map_set,
};
pub use update::{OnlineMap, UpdateParams};
pub use validate::clamp_psd;
