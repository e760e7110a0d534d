//! # cliff: long-term human motion prediction with CLiFF-maps
//!
//! The modules are layers, lowest first; each imports only the layers below it (the
//! test `tests/layers.rs` holds the library to that, and to no circle of files):
//!
//! | layer | what it holds |
//! |---|---|
//! | [`math`] | angle wrapping and the prediction loop's fast kernels |
//! | [`tracks`] | [`Track`](tracks::Track)s, their bounds and the readers (THÖR, ATC, MAGNI, named-column CSV), the demo scene's people |
//! | [`motion`] | a person's [`State`](motion::State), observed velocity, the speed prior, the learned [`MotionModel`](motion::MotionModel) |
//! | [`map`] | CLiFF-maps: the type, lookups, sampling tables, files, building, scoring, online update, time-of-day sets |
//! | [`predict`] | CLiFF-LHMP and constant velocity into reusable batches; options and presets |
//! | [`occupancy`] | the probability that a grid cell holds someone at given times or in a window, the chance a robot's timed path meets each person |
//! | [`eval`] | evaluation protocols, metrics, reports; fitting the speed prior |
//! | [`plot`] | pictures of maps, predictions and error curves (PNG or SVG) |
//!
//! The `cliff` command line (`src/bin/cliff`), the daemon and client crates and the
//! Python package are built on top; docs/architecture.md shows the whole house.
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
mod framed;
pub mod map;
pub mod math;
pub mod motion;
pub mod occupancy;
pub mod plot;
pub mod predict;
pub mod tracks;

pub use glam;
