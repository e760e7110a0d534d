//! # cliff: long-term human motion prediction with CLiFF-maps
//!
//! * [`map`]: CLiFF-maps (published CSV format, our snapshot format, grid index, the
//!   built-in demo scene).
//! * [`motion`]: motion state and observed velocity from a history.
//! * [`predict`]: CLiFF-LHMP and constant-velocity prediction into reusable batches.
//! * [`eval`]: dataset readers, evaluation protocols and metrics.
//! * [`plot`]: pictures of maps, predictions and error curves (PNG or SVG).
//! * [`scene`]: synthetic people walking in the built-in demo hall.
//!
//! ```
//! use cliff::{map::CliffMap, motion::State, predict::{predict, Params, TrajectoryBatch}};
//! let map = CliffMap::demo();
//! let person = State { position: glam::DVec2::new(-12.0, -1.0), speed: 1.3, heading: 0.0, time: 0.0 };
//! let mut batch = TrajectoryBatch::new();
//! predict(&map, &[person], &Params::default(), &mut batch).unwrap();
//! println!("{} samples of up to {} steps", batch.shape().1, batch.shape().2);
//! ```
#![warn(missing_docs)]

mod bounded_read;
pub mod eval;
pub mod map;
pub mod math;
pub mod motion;
pub mod plot;
pub mod predict;
pub mod tracks;

pub use glam;
