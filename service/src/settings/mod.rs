//! What a daemon serves and how: one part per file.
//!
//! | file | what it holds |
//! |---|---|
//! | `daemon` | [`Settings`] (the maps, the limits, the workers), [`MapSpec`], [`StartError`] |
//! | `learning` | what a learning daemon learns and how: [`LearnSettings`], the per-client [`Budgets`] and the [`Guards`] |
//! | `options_file` | cliffd's configuration file (`--config FILE`: its options, one per line): [`parse_options_file`], [`FileOption`], [`OptionsFileError`] |

mod daemon;
mod learning;
mod options_file;

pub use daemon::{
    DEFAULT_CHUNK_POSITIONS, DEFAULT_TABLE_BUDGET, DEFAULT_TABLE_RADII, MapSpec,
    RADIUS_LIMIT_STEPS, Settings, StartError, available_cores,
};
pub use learning::{Budgets, Guards, LearnSettings};
pub use options_file::{FileOption, OptionsFileError, parse_options_file};
