//! What a map reports about itself: [`MapReport`] (what was fixed when it was built)
//! and [`MapInfo`] (the figures `cliff map info` prints).

use glam::DVec2;
use serde::{Deserialize, Serialize};

/// What was wrong with a map's values and was fixed when it was built.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MapReport {
    /// Components whose covariance was not symmetric positive semi-definite and was clamped.
    pub clamped_covariances: usize,
    /// Locations whose weights did not sum to one (within 1e-6) and were renormalised.
    pub renormalised_locations: usize,
}

/// Summary figures of a map, as printed by `cliff map info`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MapInfo {
    /// Number of locations.
    pub locations: usize,
    /// Number of components over all locations.
    pub components: usize,
    /// Smallest and largest number of components at one location.
    pub components_per_location: (usize, usize),
    /// Grid step (m).
    pub grid_step: f64,
    /// Extent of the locations: `(min, max)`.
    pub extent: (DVec2, DVec2),
    /// Smallest and largest observation ratio.
    pub observation_ratio: (f64, f64),
    /// Fixes applied when the map was built.
    pub report: MapReport,
}
