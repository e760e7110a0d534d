//! The bounds every map holds to: coordinates, grid steps and cells, components per
//! location, component values and file sizes.

/// Largest |x| and |y| (m) of a map location: maps are of buildings and sites, and this
/// bound keeps every grid computation far from overflow and rounding trouble.
pub const MAX_COORDINATE: f64 = crate::tracks::MAX_POSITION;
/// Smallest grid step (m) a map may have.
pub const MIN_GRID_STEP: f64 = 1e-3;
/// Largest grid step (m) a map may have.
pub const MAX_GRID_STEP: f64 = 1e3;
/// Largest number of cells of a map's grid index (its bounding box divided by the grid
/// step): 2^24 cells, 64 MiB of index.
pub const MAX_GRID_CELLS: usize = 1 << 24;
/// Largest number of grid cells per location beyond the first [`FREE_GRID_CELLS`]: a
/// map's index grows with its locations, so a small file cannot claim a large index
/// (real maps hold a location in every second to fifth cell).
pub const MAX_GRID_CELLS_PER_LOCATION: usize = 4096;
/// Grid cells any map may have whatever its number of locations (2^16, 256 KiB).
pub const FREE_GRID_CELLS: usize = 1 << 16;
/// Largest number of mixture components at one location (every draw scans them).
pub const MAX_COMPONENTS: usize = 64;
/// Largest magnitude of a component's direction (rad), speed (m/s) and covariance
/// entries: far beyond any real map, small enough that no derived quantity overflows.
pub const MAX_COMPONENT_VALUE: f64 = 1e6;
/// Largest map file (CSV or snapshot) read, in bytes (256 MiB).
pub const MAX_MAP_FILE_BYTES: u64 = 1 << 28;
