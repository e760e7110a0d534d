//! What can be wrong with an occupancy call's input.

/// Errors from the occupancy calls: each names the argument (and the place in it) that
/// is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OccupancyError {
    /// The grid is unusable (resolution, size, origin).
    #[error("grid: {0}")]
    Grid(String),
    /// A time of the list is unusable (not finite, outside the predicted span).
    #[error("time {index} ({time} s): {why}")]
    Time {
        /// Its place in the list.
        index: usize,
        /// The time.
        time: f64,
        /// What is wrong.
        why: String,
    },
    /// The samples' buffers do not have the shape they claim, or `dt` is unusable.
    #[error("samples: {0}")]
    Samples(String),
    /// A setting is unusable.
    #[error("setting {name}: {why}")]
    Setting {
        /// The setting.
        name: &'static str,
        /// What is wrong.
        why: String,
    },
    /// A point of a robot's plan is unusable.
    #[error("plan point {index}: {why}")]
    Plan {
        /// Its place in the plan.
        index: usize,
        /// What is wrong.
        why: String,
    },
    /// The output would not fit in memory (layers x cells overflows or cannot be
    /// allocated).
    #[error("{layers} layers of {cells} cells are too large to allocate")]
    TooLarge {
        /// Layers (times).
        layers: usize,
        /// Cells per layer.
        cells: usize,
    },
}
