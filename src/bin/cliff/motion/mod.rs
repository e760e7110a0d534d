//! `cliff motion ...`: the learned motion model.
//!
//! - `fit.rs`: `cliff motion fit`, a model fitted to trajectory files
//! - `info.rs`: `cliff motion info`, what a model file holds

pub mod fit;
pub mod info;
