//! `cliff`: CLiFF-maps and CLiFF-LHMP from the command line.
//!
//! A thin layer over the `cliff` library: `main` parses the command line and hands
//! each subcommand to its own file. The files:
//!
//! - `main.rs`: this map and `main`: parse, dispatch, report errors
//! - `cli.rs`: the command tree (`cliff`, `cliff map ...`, `cliff plot ...`)
//!
//! One file per command, each with its arguments and its `run`:
//!
//! - `eval.rs`: `cliff eval`, methods evaluated on trajectory files
//! - `predict.rs`: `cliff predict`, one person's samples as CSV
//! - `demo.rs`: `cliff demo`, the guided tour from nothing to three pictures
//! - `observe.rs`: `cliff observe`, tracks streamed to a learning daemon (runs
//!   `cliff-observe`)
//! - `motion/fit.rs`, `motion/info.rs`: `cliff motion fit | info`
//! - `map/info.rs`, `map/convert.rs`, `map/build.rs`, `map/score.rs`,
//!   `map/update.rs`: `cliff map info | convert | build | score | update`
//! - `plot/map.rs`, `plot/predict.rs`, `plot/occupancy.rs`, `plot/curves.rs`:
//!   `cliff plot map | predict | occupancy | curves`
//!
//! What the commands share (a command imports these, never another command):
//!
//! - `args.rs`: argument groups several commands flatten in (prediction, reading,
//!   trajectory input, floor plan) and their value parsers
//! - `clock.rs`: values of time (durations, clock offsets, times of day)
//! - `load.rs`: reading maps, map sets, tracks, observations, floor plans, summaries
//! - `person.rs`: one prepared person's prediction (`predict`, `plot predict`, `demo`)

mod args;
mod cli;
mod clock;
mod demo;
mod eval;
mod load;
mod map;
mod motion;
mod observe;
mod person;
mod plot;
mod predict;

use clap::Parser;

use cli::{Cli, Command, MapCommand, MotionCommand, PlotCommand};

fn main() -> std::process::ExitCode {
    // Like other Unix tools: end quietly when the reader of our output goes away
    // (`cliff eval ... | head`) instead of panicking on a broken pipe.
    // SAFETY: called first thing in main, before any other thread exists.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Map(MapCommand::Info(a)) => map::info::run(a),
        Command::Map(MapCommand::Convert(a)) => map::convert::run(a),
        Command::Map(MapCommand::Build(a)) => map::build::run(a),
        Command::Map(MapCommand::Score(a)) => map::score::run(a),
        Command::Map(MapCommand::Update(a)) => map::update::run(a),
        Command::Map(MapCommand::Diff(a)) => map::diff::run(a),
        Command::Motion(MotionCommand::Fit(a)) => motion::fit::run(*a),
        Command::Motion(MotionCommand::Info(a)) => motion::info::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Predict(a) => predict::run(a),
        Command::Plot(PlotCommand::Map(a)) => plot::map::run(a),
        Command::Plot(PlotCommand::Predict(a)) => plot::predict::run(a),
        Command::Plot(PlotCommand::Occupancy(a)) => plot::occupancy::run(a),
        Command::Plot(PlotCommand::Curves(a)) => plot::curves::run(a),
        Command::Demo(a) => demo::run(a),
        Command::Observe(a) => observe::run(a),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
