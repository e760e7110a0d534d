//! `cliff`: CLiFF-maps and CLiFF-LHMP from the command line.
//!
//! A thin layer over the `cliff` library: each subcommand group lives in its own module.

mod map_build_cmd;
mod map_cmd;

use clap::{Parser, Subcommand};

/// CLiFF-maps and long-term human motion prediction (CLiFF-LHMP).
///
/// Without --map, commands use the built-in demo scene: a hall with two crossing
/// pedestrian flows, so everything runs on a fresh machine without data.
#[derive(Parser)]
#[command(name = "cliff", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Inspect, convert, build, score and update CLiFF-maps.
    #[command(subcommand)]
    Map(map_cmd::MapCommand),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Map(c) => map_cmd::run(c),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
