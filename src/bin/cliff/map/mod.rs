//! `cliff map ...`: one file per subcommand.

pub mod build;
pub mod convert;
pub mod diff;
pub mod info;
pub mod score;
pub mod update;
