//! `cliff motion info`: what a motion model file holds.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use cliff::motion::{MODEL_DT, MotionModel};

/// Options of `cliff motion info`.
#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Model file (.motion) [default: the built-in model].
    pub model: Option<PathBuf>,
}

/// Run `cliff motion info`.
pub fn run(a: InfoArgs) -> Result<()> {
    let loaded;
    let (model, name) = match &a.model {
        Some(p) => {
            loaded = MotionModel::load(p)?;
            (&loaded, p.display().to_string())
        }
        None => (MotionModel::builtin(), "built-in".to_string()),
    };
    let info = model.info();
    println!("model      {name}");
    println!(
        "forecast   {} steps of {MODEL_DT} s ({:.1} s), then on at the last step's velocity",
        model.steps(),
        model.steps() as f64 * MODEL_DT
    );
    println!("windows    {}", info.windows);
    println!("lambda     {} m^2", info.lambda);
    match model.network() {
        Some(n) => println!(
            "network    2 layers of {} units correcting the linear part",
            n.hidden
        ),
        None => println!("network    none (the linear part alone)"),
    }
    println!(
        "max speed  {} m/s (faster steps left out as tracking jumps)",
        info.max_speed
    );
    println!("fitted on  {}", info.source);
    let n = model.steps();
    for j in [n.min(3), n.min(12), n] {
        let [xx, _, yy] = model.covariance()[j - 1];
        println!(
            "spread at {:>4.1} s: {:.2} m along, {:.2} m across",
            j as f64 * MODEL_DT,
            xx.sqrt(),
            yy.sqrt()
        );
    }
    Ok(())
}
