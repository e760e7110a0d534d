//! The values of a map: a [`Location`] on the grid with its mixture of [`Component`]s.

use glam::DVec2;
use serde::{Deserialize, Serialize};

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
