//! `cliff`: CLiFF-maps and CLiFF-LHMP from the command line.
//!
//! A thin layer over the `cliff` library: each subcommand group lives in its own module.

mod clock;
mod demo_cmd;
mod eval_cmd;
mod map_build_cmd;
mod map_cmd;
mod plot_cmd;

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
    /// Evaluate methods on trajectory files: ADE/FDE, top-k, per horizon, over seeds.
    ///
    /// Example (THÖR1, parity with the published implementation):
    /// cliff eval --map ../shared/data/thor1/cliffmap.csv --tracks ../shared/data/thor1/exp-1-run-2.csv
    ///   --format thor --protocol reference --radius 0.7071 --seeds 20 --out thor1-eval
    Eval(eval_cmd::EvalArgs),
    /// Predict the samples of one person of a trajectory file and write them as CSV.
    Predict(eval_cmd::PredictArgs),
    /// Draw pictures: a map as coloured arrows, a person's prediction, error curves.
    #[command(subcommand)]
    Plot(plot_cmd::PlotCommand),
    /// The guided tour: predict and evaluate in the demo hall (or on --map/--tracks)
    /// and write a map, a prediction and an error-curve picture as PNG.
    ///
    /// Example: cliff demo --out cliff-demo
    Demo(demo_cmd::DemoArgs),
}

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
        Command::Map(c) => map_cmd::run(c),
        Command::Eval(a) => eval_cmd::run_eval(a),
        Command::Predict(a) => eval_cmd::run_predict(a),
        Command::Plot(c) => plot_cmd::run(c),
        Command::Demo(a) => demo_cmd::run(a),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
