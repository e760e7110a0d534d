//! What a daemon serves and how: one part per file.
//!
//! | file | what it holds |
//! |---|---|
//! | `daemon` | [`Settings`] (the maps, the limits, the workers), [`MapSpec`], [`StartError`] |
//! | `learning` | what a learning daemon learns and how: [`LearnSettings`], the per-client [`Budgets`] and the [`Guards`] |

mod daemon;
mod learning;

pub use daemon::{
    DEFAULT_CHUNK_POSITIONS, DEFAULT_TABLE_BUDGET, DEFAULT_TABLE_RADII, MapSpec,
    RADIUS_LIMIT_STEPS, Settings, StartError, available_cores,
};
pub use learning::{Budgets, Guards, LearnSettings};
