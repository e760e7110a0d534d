//! The map type: [`CliffMap`], its construction from locations (validation, sampling
//! tables, score densities), files and summary. Lookups are in `lookup.rs`, the draws in
//! `sampling.rs`, the densities in `log_density.rs`.

use glam::DVec2;

use super::density;
use super::error::MapError;
use super::grid::GridIndex;
use super::info::{MapInfo, MapReport};
use super::location::Location;
use super::sampling_tables::{
    DirectionComponent, FollowBlock, LaneTables, SpeedComponent, follow_blocks, pad_components,
    pad_with,
};
use super::stats::{Gauss2, floor_eigenvalues};
use super::tables::TableCache;
use super::validate::{clamp_psd, validate_location};
use crate::motion::SpeedPrior;

/// A CLiFF-map: locations on a regular grid with a grid index and sampling tables.
#[derive(Debug)]
pub struct CliffMap {
    pub(super) locations: Vec<Location>,
    pub(super) grid: GridIndex,
    /// Hot-loop copies (struct of arrays).
    pub(super) positions: Vec<DVec2>,
    pub(super) ratios: Vec<f64>,
    pub(super) comp_start: Vec<u32>,
    pub(super) table: Vec<DirectionComponent>,
    /// The same in single precision, for the prediction loop's lanes.
    pub(super) lane: LaneTables,
    /// Speeds given the direction draw, indexed like `table`.
    pub(super) speed: Vec<SpeedComponent>,
    /// Components for [`CliffMap::direction_following`] ([`follow_blocks`]).
    pub(super) follow_start: Vec<u32>,
    pub(super) follow: Vec<FollowBlock>,
    /// Each location's number of components (its follow slots that are not padding).
    pub(super) follow_count: Vec<u32>,
    /// Whether every location's follow components fit two blocks
    /// ([`CliffMap::follow_weights_fit`]), found once when the map is made.
    pub(super) follow_fits: bool,
    /// Densities for sample scores: location `i`'s components are
    /// `density[density_start[i]..density_start[i + 1]]`.
    pub(super) density_start: Vec<u32>,
    pub(super) density: Vec<Gauss2>,
    /// The same components for [`CliffMap::step_log_density`].
    pub(super) step_density: density::StepDensities,
    pub(super) report: MapReport,
    /// How speeds ahead regress to a typical speed, learned with the map (see
    /// [`SpeedPrior`](crate::motion::SpeedPrior)); `None` for maps without one.
    pub(super) speed_prior: Option<SpeedPrior>,
    /// Neighbour tables built so far, one per sampling radius, under a memory budget.
    pub(super) tables: TableCache,
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
            lane: self.lane.clone(),
            speed: self.speed.clone(),
            follow_start: self.follow_start.clone(),
            follow: self.follow.clone(),
            follow_count: self.follow_count.clone(),
            follow_fits: self.follow_fits,
            density_start: self.density_start.clone(),
            density: self.density.clone(),
            step_density: self.step_density.clone(),
            report: self.report,
            speed_prior: self.speed_prior,
            tables: self.tables.clone(),
        }
    }
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
        let follow_fits = follow_start.windows(2).all(|w| w[1] - w[0] <= 2);
        let follow_count = locations
            .iter()
            .map(|l| l.components.len() as u32)
            .collect();
        let step_density = density::StepDensities::new(&density_start, &density);
        let (comp_start, table) = pad_components(comp_start, table);
        let lane = LaneTables::new(&comp_start, &table);
        Ok(Self {
            locations,
            grid,
            positions,
            ratios,
            comp_start,
            table,
            lane,
            speed,
            follow_start,
            follow,
            follow_count,
            follow_fits,
            density_start,
            density,
            step_density,
            report,
            speed_prior: None,
            tables: TableCache::default(),
        })
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
}

/// Covariance eigenvalue floor of [`CliffMap::log_density`] (as in `cliff map score`).
const SCORE_EIGENVALUE_FLOOR: f64 = 1e-4;
