//! `cliff plot ...`: one file per subcommand.

pub mod curves;
pub mod map;
pub mod occupancy;
pub mod predict;
