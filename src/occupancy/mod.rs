//! Occupancy over space and time from a prediction's samples: how likely each cell of
//! a grid is to hold someone at given times or within a time window, how likely a
//! robot's timed path is to meet each person, and one person's predicted density at a
//! point.
//!
//! A planner does not want twenty sampled paths per person; it wants to know how
//! likely a place is to hold someone at a given time. Each person's samples at a time
//! are smoothed by a normal kernel the size of a person widened by the samples' spread
//! ([`Settings`]), a cell receives the kernel's probability mass over its area (for a
//! kernel many cells wide, from a coarser grid: `levels.rs`), and people are combined
//! as independent: a cell is occupied with probability
//! `1 - prod_i (1 - p_i)`. Samples that stop before a time (method `cliff`, where the
//! map has no data) are handled by [`Stopped`]: by default the person's probability is
//! spread over the samples that reached the time.
//!
//! | file | holds |
//! |---|---|
//! | `grid.rs` | [`GridSpec`]: origin, resolution, width and height, laid out like a ROS `OccupancyGrid` |
//! | `samples.rs` | [`Samples`], the view of a batch the calls read, and [`Stopped`] |
//! | `kernel.rs` | [`Settings`] (the kernel's width and cut-off), the spread, the normal distribution function |
//! | `layers.rs` | [`Occupancy`], the reusable buffer of layers, and the kernel loop of [`Occupancy::compute`] |
//! | `levels.rs` | coarser grids for wide kernels: their layers and the interpolation onto the grid |
//! | `tile.rs` | one person's box of cells as a dense buffer of rows eight cells wide, and a sample's kernel placed on it |
//! | `window.rs` | [`Occupancy::window`]: the chance that anyone is in a cell between two times |
//! | `path.rs` | [`path_meets`] and [`PlanPoint`]: the chance that a robot's timed path meets each person |
//! | `density.rs` | [`person_density`]: one person's density at a point (for log-likelihoods) |
//! | `error.rs` | [`OccupancyError`] |
//!
//! ```
//! use cliff::map::CliffMap;
//! use cliff::motion::State;
//! use cliff::occupancy::{GridSpec, Occupancy, Samples, Settings};
//! use cliff::predict::{predict, Params, TrajectoryBatch};
//! use glam::DVec2;
//!
//! let map = CliffMap::demo();
//! let walker = State { position: DVec2::new(-10.0, 0.5), speed: 1.2, heading: 0.0, time: 0.0 };
//! let params = Params { k: 20, dt: 0.4, horizon: 12.0, ..Params::default() };
//! let mut batch = TrajectoryBatch::new();
//! predict(&map, &[walker], &params, &mut batch).unwrap();
//!
//! let samples = Samples::from_batch(&batch, params.dt).unwrap();
//! let grid = GridSpec::around([0.0, 0.0], [20.0, 20.0], 0.1); // 200 x 200 cells
//! let mut occupancy = Occupancy::new();
//! occupancy.compute(&samples, &grid, &[2.0, 4.0], &Settings::default()).unwrap();
//! // one person, wholly on the grid: the layer's cells add up to about one
//! let total: f32 = occupancy.layer(0).iter().sum();
//! assert!((total - 1.0).abs() < 0.02);
//! // the likeliest cell at 2 s lies about 2.4 m east of the start
//! let best = (0..grid.cells()).max_by(|&a, &b| occupancy.layer(0)[a].total_cmp(&occupancy.layer(0)[b])).unwrap();
//! let [x, _] = grid.cell_center(best / grid.width, best % grid.width);
//! assert!((x + 7.6).abs() < 1.0, "{x}");
//! ```

mod density;
mod error;
mod grid;
mod kernel;
mod layers;
mod levels;
mod path;
mod samples;
#[cfg(test)]
mod tests;
mod tile;
mod window;

pub use density::person_density;
pub use error::OccupancyError;
pub use grid::{GridSpec, MAX_CELLS};
pub use kernel::{Settings, normal_cdf, spread};
pub use layers::Occupancy;
pub use path::{MAX_PLAN_POINTS, PlanPoint, path_meets};
pub use samples::{Samples, Stopped};
