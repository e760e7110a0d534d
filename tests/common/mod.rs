//! Helpers shared by the command-line tests.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// Path of a file under ../shared/data (the real datasets, read in place).
pub fn data(p: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(p)
        .display()
        .to_string()
}

/// Run the `cliff` binary built for these tests.
pub fn cliff(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cliff"))
        .args(args)
        .output()
        .expect("run cliff")
}
