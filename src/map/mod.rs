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

pub mod build;
mod csv;
mod demo;
mod density;
mod grid;
mod neighbours;
pub mod score;
mod snapshot;
mod tables;
pub mod timeofday;
pub mod update;

use std::path::Path;
use std::sync::Arc;

use crate::math::wrap_2pi;
use crate::motion::SpeedPrior;
use build::{Gauss2, floor_eigenvalues};
use glam::DVec2;
use rand::distr::Distribution;
use rand::{Rng, RngExt};
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

pub use build::{BuildParams, Observation, build_map};
pub use csv::{read_csv, read_csv_bytes, read_csv_str, write_csv, write_csv_string};
pub use grid::GridIndex;
pub use neighbours::NeighbourTable;
pub use score::{ScoreParams, ScoreReport, score};
pub use snapshot::{
    SET_SNAPSHOT_VERSION, SNAPSHOT_MAGIC, SNAPSHOT_VERSION, read_snapshot, read_snapshot_bytes,
    write_snapshot,
};
pub use tables::{DEFAULT_TABLE_BUDGET, TableCache, TableError, TableStats};
pub use timeofday::{
    BuiltSet, MapAt, MapSet, SetParts, SliceParams, SliceSummary, Smoothing, build_map_set,
};
pub use update::{OnlineMap, UpdateParams};

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

/// One semi-wrapped normal component of a location's velocity mixture.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Component {
    /// Mean direction (rad, in `[0, 2pi)`).
    pub theta: f64,
    /// Mean speed (m/s).
    pub rho: f64,
    /// Covariance of (theta, rho), row-major: `[tt, tr, rt, rr]`.
    pub cov: [f64; 4],
    /// Mixing weight (per location the weights may sum to less than one).
    pub weight: f64,
}

/// A map location: a grid node with its velocity mixture.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Location {
    /// Position of the node (m).
    pub position: DVec2,
    /// Mixture components, in file order.
    pub components: Vec<Component>,
    /// Moving samples / all samples at this node (1 when standing samples are dropped).
    pub motion_ratio: f64,
    /// Samples seen here / the largest count of any node of the map, in `[0, 1]`.
    pub observation_ratio: f64,
}

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

/// Per-component sampling table entry, precomputed at build time.
#[derive(Debug, Clone, Copy)]
struct DirectionComponent {
    /// Cumulative normalised weight up to and including this component.
    cum_weight: f64,
    /// Mean direction.
    mu: f64,
    /// Standard deviation of the direction marginal of the PSD-clamped covariance.
    sigma: f64,
}

/// Per-component speed entry, parallel to [`DirectionComponent`]: the speed given the
/// direction draw `mu + sigma * z` is `mean + slope * z + sd * z2` (the conditional of
/// the component's bivariate normal).
#[derive(Debug, Clone, Copy)]
struct SpeedComponent {
    mean: f32,
    slope: f32,
    sd: f32,
}

/// A standard normal deviate approximated by the sum of four uniforms (the bytes of
/// `bits`): mean 0, variance 1 (to 2e-5), its distribution function within 0.01 of the
/// normal's, bounded by +-3.46 (where a normal has 5e-4 of its mass). Costs a few integer instructions against a normal draw's table lookups
/// and second random word; the speed kernel's noise needs no more.
#[inline(always)]
fn four_uniforms_normal(bits: u32) -> f32 {
    // the four bytes summed pairwise: 0..=1020
    let pairs = (bits & 0x00ff_00ff) + ((bits >> 8) & 0x00ff_00ff);
    let sum = (pairs & 0xffff) + (pairs >> 16);
    // each byte b stands for the uniform (b + 1/2) / 256 (mean 1/2, variance 1/12)
    const SCALE: f32 = 1.732_050_8 / 256.0;
    (sum as f32 + 2.0) * SCALE - 2.0 * 1.732_050_8
}

/// Four components of one location for [`CliffMap::direction_following`], field by
/// field so the four weights are computed together: normalised weights (0 for padding)
/// and the unit vectors of the mean directions (padding repeats the location's last
/// direction, so it never raises the largest cosine).
#[derive(Debug, Clone, Copy)]
struct FollowBlock {
    weight: [f32; 4],
    cos_mu: [f32; 4],
    sin_mu: [f32; 4],
}

/// The follow blocks of every location: location `i`'s are
/// `blocks[starts[i]..starts[i + 1]]`, the components in order, four to a block. On maps
/// whose widest mixture fits in two blocks every location gets the same number of blocks
/// (a count that changes from step to step costs a mispredicted branch).
fn follow_blocks(locations: &[Location]) -> (Vec<u32>, Vec<FollowBlock>) {
    let blocks_for = |n: usize| n.div_ceil(4).max(1);
    let widest = locations
        .iter()
        .map(|l| l.components.len())
        .max()
        .unwrap_or(0);
    let fixed = (blocks_for(widest) <= 2).then(|| blocks_for(widest));
    let mut starts = Vec::with_capacity(locations.len() + 1);
    let mut blocks = Vec::new();
    for loc in locations {
        starts.push(blocks.len() as u32);
        let total: f64 = loc.components.iter().map(|c| c.weight).sum();
        let n = loc.components.len();
        for b in 0..fixed.unwrap_or(blocks_for(n)) {
            let mut block = FollowBlock {
                weight: [0.0; 4],
                cos_mu: [0.0; 4],
                sin_mu: [0.0; 4],
            };
            for l in 0..4 {
                let j = 4 * b + l;
                let c = &loc.components[j.min(n - 1)];
                if j < n {
                    block.weight[l] = (c.weight / total) as f32;
                }
                block.cos_mu[l] = c.theta.cos() as f32;
                block.sin_mu[l] = c.theta.sin() as f32;
            }
            blocks.push(block);
        }
    }
    starts.push(blocks.len() as u32);
    (starts, blocks)
}

/// The cumulative follow weights of a location's `blocks` (at most `W / 4`) for the heading
/// `(ux, uy)`: the weights `w_j exp(kappa (cos_j - max cos))` are those of the rule of
/// [`CliffMap::direction_following`] scaled by a common factor (so the likeliest
/// direction's term never underflows), in single precision, four at a time; their
/// relative error (about 1e-7) moves a choice only for draws within that of a boundary.
/// Slots past the blocks hold the total.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // four lanes, indexed alike
fn follow_cumulative<const W: usize>(
    blocks: &[FollowBlock],
    ux: f32,
    uy: f32,
    kappa: f32,
) -> [f32; W] {
    use crate::math::fastmath::exp_neg_f32;
    let mut cos = [0.0f32; W];
    let mut most = -1.0f32;
    for (b, out) in blocks.iter().zip(cos.chunks_exact_mut(4)) {
        for l in 0..4 {
            out[l] = ux * b.cos_mu[l] + uy * b.sin_mu[l];
            most = most.max(out[l]);
        }
    }
    let mut weight = [0.0f32; W];
    for ((b, c), out) in blocks
        .iter()
        .zip(cos.chunks_exact(4))
        .zip(weight.chunks_exact_mut(4))
    {
        for l in 0..4 {
            out[l] = b.weight[l] * exp_neg_f32(kappa * (c[l] - most));
        }
    }
    let mut total = 0.0f32;
    for w in weight.iter_mut() {
        total += *w;
        *w = total;
    }
    weight
}

/// The number of cumulative weights at or below `u` times the total (the last slot).
#[inline(always)]
fn count_below(cum: &[f32], u: f32) -> usize {
    let x = u * cum[cum.len() - 1];
    cum.iter().map(|&c| (x >= c) as usize).sum()
}

/// The cumulative follow weights of one location for one heading
/// ([`CliffMap::follow_weights`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct FollowWeights([f32; 8]);

/// Widest mixture whose locations get padded (see [`pad_components`]): more comparisons
/// per draw than this cost more than the mispredicted branches they save.
const MAX_PADDED_COMPONENTS: usize = 8;

/// Pad every location's sampling entries to the map's largest component count (at most
/// [`MAX_PADDED_COMPONENTS`], and at most four times the unpadded table): the component
/// choice in [`DirectionSampler`] then runs the same number of comparisons at every
/// location, which the processor predicts (a count that changes from step to step costs
/// a mispredicted branch: 22.0 -> 20.8 us on the THÖR1 benchmark, widest mixture 3;
/// 23.1 -> 21.1 us on the ATC one, widest 5). Padding entries have an infinite
/// cumulative weight, so they are never chosen.
fn pad_components(
    comp_start: Vec<u32>,
    table: Vec<DirectionComponent>,
) -> (Vec<u32>, Vec<DirectionComponent>) {
    pad_with(comp_start, table, |last| DirectionComponent {
        cum_weight: f64::INFINITY,
        ..last
    })
}

/// [`pad_components`] for any per-component table: the same padding decision, each
/// location's entries followed by `filler(its last entry)`.
fn pad_with<T: Copy>(
    comp_start: Vec<u32>,
    table: Vec<T>,
    filler: impl Fn(T) -> T,
) -> (Vec<u32>, Vec<T>) {
    let counts = comp_start.windows(2).map(|w| (w[1] - w[0]) as usize);
    let widest = counts.clone().max().unwrap_or(0);
    let locations = comp_start.len() - 1;
    if widest <= 1
        || widest > MAX_PADDED_COMPONENTS
        || locations.saturating_mul(widest) > 4 * table.len()
    {
        return (comp_start, table);
    }
    let mut padded = Vec::with_capacity(locations * widest);
    let mut starts = Vec::with_capacity(locations + 1);
    for (w, n) in comp_start.windows(2).zip(counts) {
        starts.push(padded.len() as u32);
        let own = &table[w[0] as usize..w[1] as usize];
        padded.extend_from_slice(own);
        padded.extend(std::iter::repeat_n(filler(own[n - 1]), widest - n));
    }
    starts.push(padded.len() as u32);
    (starts, padded)
}

/// A CLiFF-map: locations on a regular grid with a grid index and sampling tables.
#[derive(Debug)]
pub struct CliffMap {
    locations: Vec<Location>,
    grid: GridIndex,
    /// Hot-loop copies (struct of arrays).
    positions: Vec<DVec2>,
    ratios: Vec<f64>,
    comp_start: Vec<u32>,
    table: Vec<DirectionComponent>,
    /// Speeds given the direction draw, indexed like `table`.
    speed: Vec<SpeedComponent>,
    /// Components for [`CliffMap::direction_following`] ([`follow_blocks`]).
    follow_start: Vec<u32>,
    follow: Vec<FollowBlock>,
    /// Densities for sample scores: location `i`'s components are
    /// `density[density_start[i]..density_start[i + 1]]`.
    density_start: Vec<u32>,
    density: Vec<Gauss2>,
    /// The same components for [`CliffMap::step_log_density`].
    step_density: density::StepDensities,
    report: MapReport,
    /// How speeds ahead regress to a typical speed, learned with the map (see
    /// [`SpeedPrior`](crate::motion::SpeedPrior)); `None` for maps without one.
    speed_prior: Option<SpeedPrior>,
    /// Neighbour tables built so far, one per sampling radius, under a memory budget.
    tables: TableCache,
}

impl Clone for CliffMap {
    fn clone(&self) -> Self {
        Self {
            locations: self.locations.clone(),
            grid: self.grid.clone(),
            positions: self.positions.clone(),
            ratios: self.ratios.clone(),
            comp_start: self.comp_start.clone(),
            table: self.table.clone(),
            speed: self.speed.clone(),
            follow_start: self.follow_start.clone(),
            follow: self.follow.clone(),
            density_start: self.density_start.clone(),
            density: self.density.clone(),
            step_density: self.step_density.clone(),
            report: self.report,
            speed_prior: self.speed_prior,
            tables: self.tables.clone(),
        }
    }
}

/// Finds the location CLiFF-LHMP samples from, for one sampling radius (see
/// [`CliffMap::lookup`]).
#[derive(Debug, Clone)]
pub enum Lookup<'a> {
    /// Through a precomputed neighbour table.
    Table(Arc<NeighbourTable>),
    /// Through the grid scan.
    Grid(&'a CliffMap, f64),
}

impl Lookup<'_> {
    /// Same as [`CliffMap::best_near`] for this lookup's radius.
    #[inline]
    pub fn best_near(&self, p: DVec2) -> Option<usize> {
        match self {
            Lookup::Table(t) => t.best_near(p),
            Lookup::Grid(m, r) => m.best_near(p, *r),
        }
    }

    /// The most locations one query can test for distance: a bound on the work of
    /// [`best_near`](Self::best_near), whatever the point. Through a table, the longest
    /// candidate list of a cell; through the grid scan, the cells within the radius
    /// (each holds at most one location).
    pub fn max_tests(&self) -> usize {
        match self {
            Lookup::Table(t) => t.max_scan().max(1),
            Lookup::Grid(m, r) => m.grid.max_candidates(*r),
        }
    }
}

/// Clamp a 2x2 covariance `[a, b; c, d]` to symmetric PSD. Returns the clamped matrix
/// and whether anything changed (beyond rounding).
pub fn clamp_psd(cov: [f64; 4]) -> ([f64; 4], bool) {
    let a = cov[0];
    let d = cov[3];
    let b = 0.5 * (cov[1] + cov[2]);
    let asym = (cov[1] - cov[2]).abs() > 1e-12 * (1.0 + cov[1].abs());
    // Eigenvalues of the symmetric matrix.
    let tr = a + d;
    let det = a * d - b * b;
    let disc = ((a - d) * 0.5).hypot(b);
    let l1 = tr * 0.5 + disc;
    let l2 = tr * 0.5 - disc;
    if l2 >= 0.0 && det >= 0.0 {
        return ([a, b, b, d], asym);
    }
    // Eigenvectors; reconstruct with negative eigenvalues set to zero.
    let (v1, v2) = if b.abs() > 1e-300 {
        let v1 = DVec2::new(l1 - d, b).normalize();
        (v1, DVec2::new(-v1.y, v1.x))
    } else if a >= d {
        (DVec2::X, DVec2::Y)
    } else {
        (DVec2::Y, DVec2::X)
    };
    let l1 = l1.max(0.0);
    let l2 = l2.max(0.0);
    let m = |i: usize, j: usize| l1 * v1[i] * v1[j] + l2 * v2[i] * v2[j];
    let off = m(0, 1);
    ([m(0, 0), off, off, m(1, 1)], true)
}

impl CliffMap {
    /// Build a map from locations, inferring the grid step from their positions.
    ///
    /// Fails when there are no locations, when a location is off the grid, shares its
    /// position with another, or holds a non-finite or negative value.
    pub fn new(locations: Vec<Location>) -> Result<Self, MapError> {
        Self::with_grid_step(locations, None)
    }

    /// Build a map from locations on a grid of the given step (m); `None` infers it.
    ///
    /// What a map may hold, checked here for every source (files, builders, callers):
    /// - positions finite with |x|, |y| <= [`MAX_COORDINATE`];
    /// - a grid step in [[`MIN_GRID_STEP`], [`MAX_GRID_STEP`]] (given or inferred), and a
    ///   bounding box of at most [`MAX_GRID_CELLS`] cells at that step, and at most
    ///   [`FREE_GRID_CELLS`] or [`MAX_GRID_CELLS_PER_LOCATION`] per location, whichever
    ///   is more;
    /// - every location on the grid, one per cell;
    /// - 1 to [`MAX_COMPONENTS`] components per location; directions, speeds and
    ///   covariance entries finite with magnitude at most [`MAX_COMPONENT_VALUE`],
    ///   speeds >= 0; weights finite and >= 0 with a positive, finite sum;
    /// - motion ratio finite and >= 0, observation ratio in [0, 1].
    ///
    /// ```
    /// use cliff::map::{CliffMap, Component, Location};
    /// let loc = |x: f64| Location {
    ///     position: glam::DVec2::new(x, 0.0),
    ///     components: vec![Component { theta: 0.0, rho: 1.0, cov: [0.1, 0.0, 0.0, 0.1], weight: 1.0 }],
    ///     motion_ratio: 1.0,
    ///     observation_ratio: 1.0,
    /// };
    /// assert!(CliffMap::with_grid_step(vec![loc(0.0), loc(0.5)], Some(0.5)).is_ok());
    /// // a step of 1e300 m is refused, as is a location beyond 1e6 m
    /// assert!(CliffMap::with_grid_step(vec![loc(0.0)], Some(1e300)).is_err());
    /// assert!(CliffMap::with_grid_step(vec![loc(0.0), loc(1e20)], None).is_err());
    /// ```
    pub fn with_grid_step(locations: Vec<Location>, step: Option<f64>) -> Result<Self, MapError> {
        if locations.is_empty() {
            return Err(MapError::Empty);
        }
        for (i, loc) in locations.iter().enumerate() {
            validate_location(i, loc)?;
        }
        let positions: Vec<DVec2> = locations.iter().map(|l| l.position).collect();
        let grid = GridIndex::new(&positions, step)?;
        let ratios = locations.iter().map(|l| l.observation_ratio).collect();
        let mut comp_start = Vec::with_capacity(locations.len() + 1);
        let mut table = Vec::new();
        let mut speed = Vec::new();
        let mut density_start = Vec::with_capacity(locations.len() + 1);
        let mut density = Vec::new();
        let mut report = MapReport::default();
        for loc in &locations {
            comp_start.push(table.len() as u32);
            density_start.push(density.len() as u32);
            let total: f64 = loc.components.iter().map(|c| c.weight).sum();
            if (total - 1.0).abs() > 1e-6 {
                report.renormalised_locations += 1;
            }
            let mut cum = 0.0;
            for c in &loc.components {
                let (cov, fixed) = clamp_psd(c.cov);
                if fixed {
                    report.clamped_covariances += 1;
                }
                cum += c.weight / total;
                let sigma = cov[0].max(0.0).sqrt();
                table.push(DirectionComponent {
                    cum_weight: cum,
                    mu: c.theta,
                    sigma,
                });
                speed.push(if cov[0] > 0.0 {
                    SpeedComponent {
                        mean: c.rho as f32,
                        slope: (cov[1] / sigma) as f32,
                        sd: (cov[3] - cov[1] * cov[1] / cov[0]).max(0.0).sqrt() as f32,
                    }
                } else {
                    SpeedComponent {
                        mean: c.rho as f32,
                        slope: 0.0,
                        sd: cov[3].max(0.0).sqrt() as f32,
                    }
                });
                // Scores: covariance eigenvalues floored as in `cliff map score`.
                if c.weight > 0.0
                    && let Some(g) = Gauss2::new(
                        [c.theta, c.rho],
                        floor_eigenvalues(cov, SCORE_EIGENVALUE_FLOOR),
                        c.weight / total,
                    )
                {
                    density.push(g);
                }
            }
            // Guard against rounding: the last cumulative weight is exactly one.
            if let Some(last) = table.last_mut() {
                last.cum_weight = 1.0;
            }
        }
        comp_start.push(table.len() as u32);
        density_start.push(density.len() as u32);
        let (_, speed) = pad_with(comp_start.clone(), speed, |last| last);
        let (follow_start, follow) = follow_blocks(&locations);
        let step_density = density::StepDensities::new(&density_start, &density);
        let (comp_start, table) = pad_components(comp_start, table);
        Ok(Self {
            locations,
            grid,
            positions,
            ratios,
            comp_start,
            table,
            speed,
            follow_start,
            follow,
            density_start,
            density,
            step_density,
            report,
            speed_prior: None,
            tables: TableCache::default(),
        })
    }

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

    /// The built-in synthetic scene: a 30 m x 20 m hall with two crossing pedestrian
    /// flows (east-west along the hall, north-south across it) and a mixed crossing.
    pub fn demo() -> Self {
        demo::demo_map()
    }

    /// The speed prior learned with the map (`cliff map build` fits one from its
    /// tracks and snapshots keep it; the published CSV format has no place for it).
    pub fn speed_prior(&self) -> Option<SpeedPrior> {
        self.speed_prior
    }

    /// Attach a speed prior (checked: the error says which value is wrong), or remove
    /// it with `None`.
    pub fn set_speed_prior(&mut self, prior: Option<SpeedPrior>) -> Result<(), MapError> {
        if let Some(p) = &prior {
            p.validate().map_err(MapError::SpeedPrior)?;
        }
        self.speed_prior = prior;
        Ok(())
    }

    /// The locations, in the order they were given.
    pub fn locations(&self) -> &[Location] {
        &self.locations
    }

    /// Take the locations out of the map (to edit them and build a new map).
    pub fn into_locations(self) -> Vec<Location> {
        self.locations
    }

    /// The grid index.
    pub fn grid(&self) -> &GridIndex {
        &self.grid
    }

    /// What was fixed when the map was built.
    pub fn report(&self) -> MapReport {
        self.report
    }

    /// Summary figures of the map.
    pub fn info(&self) -> MapInfo {
        let counts = self.locations.iter().map(|l| l.components.len());
        let min_c = counts.clone().min().unwrap_or(0);
        let max_c = counts.max().unwrap_or(0);
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        let mut rlo = f64::INFINITY;
        let mut rhi = f64::NEG_INFINITY;
        for l in &self.locations {
            lo = lo.min(l.position);
            hi = hi.max(l.position);
            rlo = rlo.min(l.observation_ratio);
            rhi = rhi.max(l.observation_ratio);
        }
        MapInfo {
            locations: self.locations.len(),
            components: self.locations.iter().map(|l| l.components.len()).sum(),
            components_per_location: (min_c, max_c),
            grid_step: self.grid.step(),
            extent: (lo, hi),
            observation_ratio: (rlo, rhi),
            report: self.report,
        }
    }

    /// Call `f` with the index of every location strictly within `radius` of `p`.
    /// Touches only the grid cells that can hold such a location.
    #[inline]
    pub fn for_each_near(&self, p: DVec2, radius: f64, mut f: impl FnMut(usize)) {
        let r2 = radius * radius;
        self.grid.for_each_candidate(p, radius, |i| {
            if self.positions[i].distance_squared(p) < r2 {
                f(i);
            }
        });
    }

    /// The location CLiFF-LHMP samples from at `p`: of the locations strictly within
    /// `radius`, the one with the largest observation ratio (ties: the first in order).
    #[inline]
    pub fn best_near(&self, p: DVec2, radius: f64) -> Option<usize> {
        let r2 = radius * radius;
        let mut best: Option<usize> = None;
        let mut best_ratio = f64::NEG_INFINITY;
        self.grid.for_each_candidate(p, radius, |i| {
            if self.positions[i].distance_squared(p) < r2 {
                let r = self.ratios[i];
                if r > best_ratio || (r == best_ratio && best.is_some_and(|b| i < b)) {
                    best_ratio = r;
                    best = Some(i);
                }
            }
        });
        best
    }

    /// A [`Lookup`] for `radius`: through the neighbour table, built on first use of the
    /// radius and kept under the map's table budget ([`set_table_budget`](Self::set_table_budget)),
    /// else (a table too large, or a radius whose build failed before) through the grid
    /// scan. Both give the same answers as [`best_near`](Self::best_near).
    ///
    /// Building a table takes milliseconds for the usual radii, but grows with the
    /// radius squared: a caller that must not stall uses [`cached_lookup`](Self::cached_lookup)
    /// and builds elsewhere with [`build_table`](Self::build_table).
    pub fn lookup(&self, radius: f64) -> Lookup<'_> {
        match self.build_table(radius, false) {
            Ok(t) => Lookup::Table(t),
            Err(_) => Lookup::Grid(self, radius),
        }
    }

    /// A [`Lookup`] for `radius` that never builds: the table when it is built, else
    /// the grid scan (same answers, slower for large radii).
    #[inline]
    pub fn cached_lookup(&self, radius: f64) -> Lookup<'_> {
        match self.tables.get(radius) {
            Some(t) => Lookup::Table(t),
            None => Lookup::Grid(self, radius),
        }
    }

    /// Build (or find) the neighbour table of `radius` and keep it, evicting the least
    /// recently used unpinned tables to stay within the budget; `pin` keeps it from
    /// eviction. A failed build (a table larger than the budget left by pinned tables)
    /// is remembered and returned again without building.
    pub fn build_table(&self, radius: f64, pin: bool) -> Result<Arc<NeighbourTable>, TableError> {
        self.tables.get_or_build(radius, pin, |max_bytes| {
            NeighbourTable::build(&self.grid, &self.positions, &self.ratios, radius, max_bytes)
        })
    }

    /// True when `radius` has a table or a remembered failed build (so
    /// [`build_table`](Self::build_table) would return at once).
    pub fn table_settled(&self, radius: f64) -> bool {
        self.tables.settled(radius)
    }

    /// Set the memory all neighbour tables of this map may take together (bytes;
    /// [`DEFAULT_TABLE_BUDGET`] unless set). Unpinned tables are evicted to fit.
    pub fn set_table_budget(&self, bytes: usize) {
        self.tables.set_budget(bytes);
    }

    /// The radii with a table, their size and the failed builds.
    pub fn table_stats(&self) -> TableStats {
        self.tables.stats()
    }

    /// The nearest location within `radius` of `p` (ties: the first in order).
    pub fn nearest(&self, p: DVec2, radius: f64) -> Option<usize> {
        let mut best: Option<(f64, usize)> = None;
        self.for_each_near(p, radius, |i| {
            let d = self.positions[i].distance_squared(p);
            if best.is_none_or(|(bd, bi)| d < bd || (d == bd && i < bi)) {
                best = Some((d, i));
            }
        });
        best.map(|(_, i)| i)
    }

    /// The direction distribution of location `index`: a draw picks a component by
    /// weight and returns a direction from its (PSD-clamped) normal, wrapped to `[0, 2pi)`.
    ///
    /// Only the direction marginal is drawn: CLiFF-LHMP keeps the sampled direction and
    /// discards the sampled speed, and the marginal of a bivariate normal is exactly
    /// the normal of its first coordinate.
    #[inline]
    pub fn direction_at(&self, index: usize) -> DirectionSampler<'_> {
        let a = self.comp_start[index] as usize;
        let b = self.comp_start[index + 1] as usize;
        DirectionSampler {
            table: &self.table[a..b],
        }
    }

    /// A direction draw at location `index` that favours the components going the way
    /// the walker heads (unit vector `(ux, uy)`): component `j` is chosen with
    /// probability proportional to `w_j exp(-kappa (1 - cos(heading - mu_j)))`, the
    /// posterior of the component given a heading observed with a von Mises likelihood
    /// of concentration `kappa`; the direction is then drawn from that component as in
    /// [`direction_at`](Self::direction_at) (one uniform and one normal draw, unwrapped).
    /// `kappa = 0` chooses by weight alone, like `direction_at` (up to the rounding of the
    /// cumulative weights).
    ///
    /// ```
    /// use cliff::map::{CliffMap, Component, Location};
    /// use glam::DVec2;
    /// use rand::SeedableRng;
    /// // one location, two equal flows: east and west
    /// let c = |theta: f64| Component { theta, rho: 1.0, cov: [0.01, 0.0, 0.0, 0.01], weight: 0.5 };
    /// let loc = Location { position: DVec2::ZERO, components: vec![c(0.0), c(std::f64::consts::PI)], motion_ratio: 1.0, observation_ratio: 1.0 };
    /// let map = CliffMap::new(vec![loc]).unwrap();
    /// let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(1);
    /// // a walker heading east keeps to the eastward flow
    /// let east = (0..1000).filter(|_| map.direction_following(0, 1.0, 0.0, 4.0, &mut rng).cos() > 0.0).count();
    /// assert!(east > 990);
    /// ```
    #[inline]
    pub fn direction_following<R: Rng + ?Sized>(
        &self,
        index: usize,
        ux: f64,
        uy: f64,
        kappa: f64,
        rng: &mut R,
    ) -> f64 {
        let a = self.comp_start[index] as usize;
        let b = self.comp_start[index + 1] as usize;
        let blocks =
            &self.follow[self.follow_start[index] as usize..self.follow_start[index + 1] as usize];
        let (ux, uy, kappa) = (ux as f32, uy as f32, kappa as f32);
        let u = rng.random::<f64>() as f32;
        let below = if blocks.len() <= 2 {
            count_below(&follow_cumulative::<8>(blocks, ux, uy, kappa), u)
        } else {
            count_below(
                &follow_cumulative::<MAX_COMPONENTS>(blocks, ux, uy, kappa),
                u,
            )
        };
        // (padding repeats the last component)
        let i = below.min(b - a - 1);
        let c = &self.table[a + i];
        let z: f64 = StandardNormal.sample(rng);
        c.mu + c.sigma * z
    }

    /// Whether every location's follow components fit [`FollowWeights`] (at most
    /// eight components per location): then a predictor may split
    /// [`direction_following`](Self::direction_following) into
    /// [`follow_weights`](Self::follow_weights) and
    /// [`draw_following`](Self::draw_following).
    pub fn follow_weights_fit(&self) -> bool {
        self.follow_start.windows(2).all(|w| w[1] - w[0] <= 2)
    }

    /// The part of [`direction_following`](Self::direction_following) that draws
    /// nothing: location `index`'s cumulative component weights for the heading
    /// `(ux, uy)`, scaled by a common factor. For maps where
    /// [`follow_weights_fit`](Self::follow_weights_fit) (others get the weights of their
    /// first eight components). A predictor computes them for all its samples before
    /// they draw (the samples' arithmetic then overlaps).
    #[inline(always)]
    pub fn follow_weights(&self, index: usize, ux: f32, uy: f32, kappa: f32) -> FollowWeights {
        let s = self.follow_start[index] as usize;
        let e = (self.follow_start[index + 1] as usize).min(s + 2);
        FollowWeights(follow_cumulative::<8>(&self.follow[s..e], ux, uy, kappa))
    }

    /// The draw of [`direction_following`](Self::direction_following) at location
    /// `index` with its [`follow_weights`](Self::follow_weights): the same component
    /// and direction for the same generator.
    #[inline(always)]
    pub fn draw_following<R: Rng + ?Sized>(
        &self,
        index: usize,
        weights: &FollowWeights,
        rng: &mut R,
    ) -> f64 {
        let a = self.comp_start[index] as usize;
        let b = self.comp_start[index + 1] as usize;
        let u = rng.random::<f64>() as f32;
        let i = count_below(&weights.0, u).min(b - a - 1);
        let c = &self.table[a + i];
        let z: f64 = StandardNormal.sample(rng);
        c.mu + c.sigma * z
    }

    /// A velocity draw at location `index`: a component by weight, a direction from its
    /// normal (unwrapped, as [`DirectionSampler::sample_unwrapped`]) and a speed from the
    /// component's normal given that direction (clamped at 0). One random word chooses the
    /// component (its high 32 bits) and gives the speed's noise (its low 32 bits, a sum
    /// of four uniforms: variance 1, within 0.01 of the normal's distribution function,
    /// bounded by +-3.46), then a normal draw gives the direction, so its stream differs
    /// from [`direction_at`](Self::direction_at)'s.
    #[inline(always)]
    pub fn velocity_at<R: Rng + ?Sized>(&self, index: usize, rng: &mut R) -> (f64, f64) {
        let a = self.comp_start[index] as usize;
        let b = self.comp_start[index + 1] as usize;
        let table = &self.table[a..b];
        // one word for the component (its high half) and the speed's noise (its low one)
        let bits = rng.next_u64();
        let u = (bits >> 32) as f64 * (1.0 / 4_294_967_296.0);
        let i = table
            .iter()
            .map(|e| (u >= e.cum_weight) as usize)
            .sum::<usize>()
            .min(table.len() - 1);
        let (c, sp) = (&table[i], &self.speed[a + i]);
        let z: f64 = StandardNormal.sample(rng);
        (
            c.mu + c.sigma * z,
            (sp.mean + sp.slope * z as f32 + sp.sd * four_uniforms_normal(bits as u32)).max(0.0)
                as f64,
        )
    }

    /// Log-density of the velocity `(theta, rho)` (rad, m/s) under location `index`'s
    /// mixture (weights renormalised, covariance eigenvalues floored at 1e-4, winding
    /// numbers -1, 0, 1), as [`score`](score::score) computes it; `-inf` for a location
    /// without components.
    pub fn log_density(&self, index: usize, theta: f64, rho: f64) -> f64 {
        let a = self.density_start[index] as usize;
        let b = self.density_start[index + 1] as usize;
        let theta = wrap_2pi(theta);
        // streaming log-sum-exp
        let mut m = f64::NEG_INFINITY;
        let mut sum = 0.0;
        for g in &self.density[a..b] {
            let v = g.log_density_wrapped(theta, rho);
            if v > m {
                sum = sum * (m - v).exp() + 1.0;
                m = v;
            } else if v > f64::NEG_INFINITY {
                sum += (v - m).exp();
            }
        }
        if m == f64::NEG_INFINITY {
            m
        } else {
            m + sum.ln()
        }
    }
}

impl CliffMap {
    /// [`log_density`](Self::log_density) approximated for the prediction loop's sample
    /// scores: the log-density of the likeliest component at the winding nearest the
    /// heading, in single precision, the heading given as a unit vector `(ux, uy)`. At
    /// most [`log_density`](Self::log_density) (within 1e-3 relative) and at most
    /// `ln(3 x components)` below it, equal where one component explains the step, except for
    /// strongly correlated components far in the speed tail, where this is the closer
    /// to the mixture's density (see `src/map/density.rs`). `-inf` for a location without
    /// components.
    #[inline]
    pub fn step_log_density(&self, index: usize, ux: f32, uy: f32, rho: f64) -> f64 {
        let theta = crate::math::fastmath::atan2_f32(uy, ux);
        self.step_log_density_at(index, theta, rho as f32) as f64
    }

    /// [`step_log_density`](Self::step_log_density) at the heading `theta` (rad), for
    /// the prediction loop (which takes the headings' angles four samples at a time).
    #[inline(always)]
    pub(crate) fn step_log_density_at(&self, index: usize, theta: f32, rho: f32) -> f32 {
        let v = self.step_density.log_density(index, theta, rho);
        if v <= -1e29 { f32::NEG_INFINITY } else { v }
    }
}

/// Covariance eigenvalue floor of [`CliffMap::log_density`] (as in `cliff map score`).
const SCORE_EIGENVALUE_FLOOR: f64 = 1e-4;

/// Sampling a direction at one location, as a [`Distribution`] (see [`CliffMap::direction_at`]).
#[derive(Debug, Clone, Copy)]
pub struct DirectionSampler<'a> {
    table: &'a [DirectionComponent],
}

impl DirectionSampler<'_> {
    /// A draw as [`sample`](Distribution::sample) gives it, before wrapping to
    /// `[0, 2pi)` (for callers that only take its sine and cosine).
    #[inline(always)]
    pub fn sample_unwrapped<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        let u: f64 = rng.random();
        // Branch-free choice: the number of cumulative weights at or below u.
        let i = self
            .table
            .iter()
            .map(|e| (u >= e.cum_weight) as usize)
            .sum::<usize>();
        let c = &self.table[i.min(self.table.len() - 1)];
        let z: f64 = StandardNormal.sample(rng);
        c.mu + c.sigma * z
    }
}

impl Distribution<f64> for DirectionSampler<'_> {
    #[inline(always)]
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        wrap_2pi(self.sample_unwrapped(rng))
    }
}

fn validate_location(index: usize, loc: &Location) -> Result<(), MapError> {
    let err = |message: String| MapError::Location {
        index,
        x: loc.position.x,
        y: loc.position.y,
        message,
    };
    if !loc.position.is_finite() {
        return Err(err("position is not finite".into()));
    }
    if loc.position.abs().max_element() > MAX_COORDINATE {
        return Err(err(format!(
            "position is beyond {MAX_COORDINATE} m from the origin"
        )));
    }
    if loc.components.is_empty() {
        return Err(err("no components".into()));
    }
    if loc.components.len() > MAX_COMPONENTS {
        return Err(err(format!(
            "{} components, at most {MAX_COMPONENTS} per location",
            loc.components.len()
        )));
    }
    if !(loc.observation_ratio.is_finite() && (0.0..=1.0 + 1e-9).contains(&loc.observation_ratio)) {
        return Err(err(format!(
            "observation ratio {} is not in [0, 1]",
            loc.observation_ratio
        )));
    }
    if !(loc.motion_ratio.is_finite() && loc.motion_ratio >= 0.0) {
        return Err(err(format!(
            "motion ratio {} is negative or not finite",
            loc.motion_ratio
        )));
    }
    let mut total = 0.0;
    for (j, c) in loc.components.iter().enumerate() {
        let vals = [
            c.theta, c.rho, c.cov[0], c.cov[1], c.cov[2], c.cov[3], c.weight,
        ];
        if vals.iter().any(|v| !v.is_finite()) {
            return Err(err(format!("component {j} has a non-finite value")));
        }
        if vals[..6].iter().any(|v| v.abs() > MAX_COMPONENT_VALUE) {
            return Err(err(format!(
                "component {j} has a direction, speed or covariance beyond {MAX_COMPONENT_VALUE}"
            )));
        }
        if c.rho < 0.0 {
            return Err(err(format!("component {j} has negative speed {}", c.rho)));
        }
        if c.weight < 0.0 {
            return Err(err(format!(
                "component {j} has negative weight {}",
                c.weight
            )));
        }
        total += c.weight;
    }
    if total <= 0.0 {
        return Err(err("component weights sum to zero".into()));
    }
    if !total.is_finite() {
        return Err(err("component weights sum to infinity".into()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    fn comp(theta: f64, w: f64) -> Component {
        Component {
            theta,
            rho: 1.0,
            cov: [0.1, 0.0, 0.0, 0.1],
            weight: w,
        }
    }

    fn loc(x: f64, y: f64, ratio: f64, comps: Vec<Component>) -> Location {
        Location {
            position: DVec2::new(x, y),
            components: comps,
            motion_ratio: 1.0,
            observation_ratio: ratio,
        }
    }

    #[test]
    fn clamp_psd_fixes_negative_eigenvalue_and_keeps_good_ones() {
        let good = [0.2, 0.05, 0.05, 0.1];
        assert_eq!(clamp_psd(good), (good, false));
        let (c, fixed) = clamp_psd([0.1, 0.2, 0.2, 0.1]); // eigenvalues 0.3, -0.1
        assert!(fixed);
        let det = c[0] * c[3] - c[1] * c[2];
        assert!(det > -1e-12 && c[0] >= 0.0 && c[3] >= 0.0, "{c:?}");
        assert!((c[0] - 0.15).abs() < 1e-12 && (c[1] - 0.15).abs() < 1e-12);
        let (c, fixed) = clamp_psd([-0.5, 0.0, 0.0, 0.2]);
        assert!(fixed);
        assert!(
            c[0] == 0.0 && c[1] == 0.0 && (c[3] - 0.2).abs() < 1e-12,
            "{c:?}"
        );
    }

    #[test]
    fn renormalises_weights_and_reports() {
        let m = CliffMap::new(vec![loc(
            0.0,
            0.0,
            1.0,
            vec![comp(0.0, 0.2), comp(1.0, 0.2)],
        )])
        .unwrap();
        assert_eq!(m.report().renormalised_locations, 1);
        assert_eq!(m.report().clamped_covariances, 0);
        // raw values are kept
        assert_eq!(m.locations()[0].components[0].weight, 0.2);
    }

    #[test]
    fn best_near_takes_largest_ratio_first_on_ties() {
        let m = CliffMap::new(vec![
            loc(0.0, 0.0, 0.5, vec![comp(0.0, 1.0)]),
            loc(1.0, 0.0, 0.9, vec![comp(0.0, 1.0)]),
            loc(0.0, 1.0, 0.9, vec![comp(0.0, 1.0)]),
            loc(5.0, 5.0, 1.0, vec![comp(0.0, 1.0)]),
        ])
        .unwrap();
        assert_eq!(m.best_near(DVec2::new(0.4, 0.4), 1.0), Some(1));
        assert_eq!(m.best_near(DVec2::new(0.1, 0.1), 0.5), Some(0));
        assert_eq!(m.best_near(DVec2::new(2.5, 2.5), 1.0), None);
        assert_eq!(m.nearest(DVec2::new(0.1, 0.6), 1.0), Some(2));
        // strictly within: a location at exactly the radius is not near
        assert_eq!(m.best_near(DVec2::new(0.0, -1.0), 1.0), None);
    }

    #[test]
    fn neighbour_table_agrees_with_grid_scan_on_real_maps() {
        use rand::SeedableRng;
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data");
        for f in ["thor1/cliffmap.csv", "atc/cliffmap-20121024.csv"] {
            let m = CliffMap::load(std::path::Path::new(dir).join(f)).unwrap();
            let (lo, hi) = m.info().extent;
            let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3);
            for radius in [0.3, 0.5, 0.7071, 1.0, 2.5] {
                let lookup = m.lookup(radius);
                assert!(matches!(lookup, Lookup::Table(_)));
                for _ in 0..20000 {
                    let p = DVec2::new(
                        rng.random_range(lo.x - 3.0..hi.x + 3.0),
                        rng.random_range(lo.y - 3.0..hi.y + 3.0),
                    );
                    assert_eq!(
                        lookup.best_near(p),
                        m.best_near(p, radius),
                        "{f} r {radius} at {p}"
                    );
                }
                // points exactly on cell borders and on locations
                for l in m.locations().iter().take(200) {
                    for d in [
                        DVec2::ZERO,
                        DVec2::splat(0.25),
                        DVec2::new(0.5, 0.0),
                        DVec2::new(radius, 0.0),
                    ] {
                        let p = l.position + d;
                        assert_eq!(
                            lookup.best_near(p),
                            m.best_near(p, radius),
                            "{f} r {radius} at {p}"
                        );
                    }
                }
            }
            assert!(matches!(m.lookup(f64::NAN), Lookup::Grid(..)));
        }
    }

    #[test]
    fn huge_radii_fall_back_to_the_grid_scan() {
        // (radius / step) + 1 cells of margin used to overflow for radii near f64::MAX.
        let m = CliffMap::demo();
        for radius in [1e300, f64::MAX, 1e6] {
            let lookup = m.lookup(radius);
            assert!(matches!(lookup, Lookup::Grid(..)), "{radius}");
            let p = DVec2::new(1.0, 2.0);
            let best = lookup.best_near(p);
            assert!(best.is_some());
            assert_eq!(best, m.best_near(p, radius));
        }
    }

    #[test]
    fn rejects_bad_locations() {
        assert!(matches!(CliffMap::new(vec![]), Err(MapError::Empty)));
        let mut l = loc(0.0, 0.0, 1.0, vec![comp(0.0, 1.0)]);
        l.components[0].rho = -1.0;
        let e = CliffMap::new(vec![l]).unwrap_err().to_string();
        assert!(e.contains("negative speed"), "{e}");
        let mut l = loc(0.0, 0.0, 1.0, vec![comp(0.0, 1.0)]);
        l.components[0].cov[1] = f64::NAN;
        assert!(
            CliffMap::new(vec![l])
                .unwrap_err()
                .to_string()
                .contains("non-finite")
        );
        let l = loc(0.0, 0.0, 1.0, vec![comp(0.0, 0.0)]);
        assert!(
            CliffMap::new(vec![l])
                .unwrap_err()
                .to_string()
                .contains("sum to zero")
        );
        let l = loc(
            0.0,
            0.0,
            1.0,
            vec![comp(0.0, f64::MAX), comp(1.0, f64::MAX)],
        );
        let e = CliffMap::new(vec![l]).unwrap_err().to_string();
        assert!(e.contains("sum to infinity"), "{e}");
        let mut l = loc(0.0, 0.0, 1.0, vec![comp(0.0, 1.0)]);
        l.components[0].cov[3] = -2e6;
        let e = CliffMap::new(vec![l]).unwrap_err().to_string();
        assert!(e.contains("beyond 1000000"), "{e}");
        let l = loc(0.0, 0.0, 1.0, vec![comp(0.0, 1.0); MAX_COMPONENTS + 1]);
        let e = CliffMap::new(vec![l]).unwrap_err().to_string();
        assert!(e.contains("65 components, at most 64"), "{e}");
        let l = loc(-1.5e6, 0.0, 1.0, vec![comp(0.0, 1.0)]);
        let e = CliffMap::new(vec![l]).unwrap_err().to_string();
        assert!(e.contains("beyond 1000000 m"), "{e}");
    }

    #[test]
    fn direction_sampler_wraps_around_zero() {
        use rand::SeedableRng;
        let mut c = comp(0.05, 1.0);
        c.cov[0] = 0.01;
        let m = CliffMap::new(vec![loc(0.0, 0.0, 1.0, vec![c])]).unwrap();
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(1);
        let d = m.direction_at(0);
        let mut wrapped = 0;
        let (mut s, mut co) = (0.0, 0.0);
        for _ in 0..20000 {
            let t: f64 = d.sample(&mut rng);
            assert!((0.0..TAU).contains(&t));
            if t > 3.0 {
                wrapped += 1;
            }
            s += t.sin();
            co += t.cos();
        }
        // about 31% of draws from N(0.05, 0.1^2) fall below zero and wrap
        assert!((5000..7500).contains(&wrapped), "{wrapped}");
        let mean = wrap_2pi(s.atan2(co));
        assert!((mean - 0.05).abs() < 0.01, "{mean}");
    }

    #[test]
    fn four_uniforms_make_a_standard_normal() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(5);
        let n = 400_000;
        let z: Vec<f64> = (0..n)
            .map(|_| four_uniforms_normal(rng.next_u32()) as f64)
            .collect();
        let mean = z.iter().sum::<f64>() / n as f64;
        let var = z.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n as f64;
        assert!(
            mean.abs() < 0.005 && (var - 1.0).abs() < 0.01,
            "{mean} {var}"
        );
        assert!(z.iter().all(|x| x.abs() <= 3.47));
        // the empirical distribution against the normal's, integrated numerically
        let phi = |x: f64| {
            let steps = 20_000;
            let (a, h) = (-9.0, (x + 9.0) / steps as f64);
            let f = |t: f64| (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
            h * ((f(a) + f(x)) / 2.0 + (1..steps).map(|i| f(a + i as f64 * h)).sum::<f64>())
        };
        for x in [-3.0, -2.0, -1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0, 2.5] {
            let below = z.iter().filter(|&&v| v <= x).count() as f64 / n as f64;
            assert!(
                (below - phi(x)).abs() < 0.01,
                "P(z <= {x}) = {below}, normal {}",
                phi(x)
            );
        }
    }

    #[test]
    fn direction_following_draws_the_von_mises_posterior() {
        use rand::SeedableRng;
        // narrow components 0.5 rad apart, unequal weights; 6 of them (two blocks of
        // four, padded), 11 (wider than the padding: three blocks), and a map where
        // one location has 11 and the other 1 (uneven block counts)
        let mixture = |n: usize| -> Vec<Component> {
            (0..n)
                .map(|j| {
                    let mut c = comp(0.5 * j as f64, 1.0 + j as f64);
                    c.cov[0] = 1e-6;
                    c
                })
                .collect()
        };
        for (n, other, kappa, heading) in [
            (6, None, 3.0, 1.2),
            (11, None, 2.0, 4.0),
            (11, Some(1), 5.0, 0.3),
            // far from every component with the largest follow: the terms underflow
            // unless scaled, yet the choice still favours the nearest direction
            (3, None, 100.0, 4.5),
        ] {
            let mut locs = vec![loc(0.0, 0.0, 1.0, mixture(n))];
            if let Some(m) = other {
                locs.push(loc(5.0, 0.0, 1.0, mixture(m)));
            }
            let map = CliffMap::new(locs).unwrap();
            // the rule in double precision, independently of the map's tables
            let post: Vec<f64> = (0..n)
                .map(|j| {
                    let w = (1.0 + j as f64) / (n * (n + 1) / 2) as f64;
                    w * (-kappa * (1.0 - (heading - 0.5 * j as f64).cos())).exp()
                })
                .collect();
            let total: f64 = post.iter().sum();
            let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(11);
            let draws = 60_000;
            let mut counts = vec![0usize; n];
            for _ in 0..draws {
                let t = map.direction_following(0, heading.cos(), heading.sin(), kappa, &mut rng);
                // the component whose mean is nearest on the circle
                let j = (0..n)
                    .min_by(|&a, &b| {
                        let d = |j: usize| (t - 0.5 * j as f64).sin_cos();
                        let ((sa, ca), (sb, cb)) = (d(a), d(b));
                        sa.atan2(ca).abs().total_cmp(&sb.atan2(cb).abs())
                    })
                    .unwrap();
                counts[j] += 1;
            }
            // split in two (as the predictor does where the weights fit), the same draws
            if map.follow_weights_fit() {
                let (mut r1, mut r2) = (
                    rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3),
                    rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3),
                );
                let (hx, hy) = (heading.cos(), heading.sin());
                for _ in 0..1000 {
                    let w = map.follow_weights(0, hx as f32, hy as f32, kappa as f32);
                    assert_eq!(
                        map.direction_following(0, hx, hy, kappa, &mut r1),
                        map.draw_following(0, &w, &mut r2)
                    );
                }
            }
            assert_eq!(map.follow_weights_fit(), n <= 8);
            for (j, (&c, p)) in counts.iter().zip(&post).enumerate() {
                let p = p / total;
                let sd = (p * (1.0 - p) / draws as f64).sqrt();
                let share = c as f64 / draws as f64;
                assert!(
                    (share - p).abs() <= 5.0 * sd + 1e-4,
                    "{n} components, kappa {kappa}: component {j} drawn {share}, expected {p}"
                );
            }
        }
    }

    #[test]
    fn direction_sampler_follows_weights() {
        use rand::SeedableRng;
        let mut a = comp(1.0, 3.0);
        a.cov[0] = 1e-6;
        let mut b = comp(4.0, 1.0);
        b.cov[0] = 1e-6;
        let m = CliffMap::new(vec![loc(0.0, 0.0, 1.0, vec![a, b])]).unwrap();
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(7);
        let n = 40000;
        let near_a = (0..n)
            .filter(|_| (m.direction_at(0).sample(&mut rng) - 1.0).abs() < 0.1)
            .count();
        let share = near_a as f64 / n as f64;
        assert!((share - 0.75).abs() < 0.01, "{share}");
    }

    #[test]
    fn padded_sampling_tables_draw_only_real_components() {
        use rand::SeedableRng;
        // three components at one location, one at the other: the second is padded
        let sharp = |theta: f64, w: f64| {
            let mut c = comp(theta, w);
            c.cov[0] = 1e-8;
            c
        };
        let m = CliffMap::new(vec![
            loc(
                0.0,
                0.0,
                1.0,
                vec![sharp(1.0, 0.2), sharp(2.0, 0.3), sharp(3.0, 0.5)],
            ),
            loc(1.0, 0.0, 1.0, vec![sharp(5.0, 1.0)]),
        ])
        .unwrap();
        assert_eq!(m.info().components, 4);
        assert_eq!(m.info().components_per_location, (1, 3));
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(11);
        let mut counts = [0usize; 3];
        for _ in 0..30000 {
            let t: f64 = m.direction_at(0).sample(&mut rng);
            counts[(t.round() as usize).clamp(1, 3) - 1] += 1;
            let u: f64 = m.direction_at(1).sample(&mut rng);
            assert!((u - 5.0).abs() < 1e-3, "{u}");
        }
        for (c, w) in counts.iter().zip([0.2, 0.3, 0.5]) {
            assert!((*c as f64 / 30000.0 - w).abs() < 0.015, "{counts:?}");
        }
    }
}
