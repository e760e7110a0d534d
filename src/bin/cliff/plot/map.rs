//! `cliff plot map`: a CLiFF-map as coloured arrows (PNG or SVG).

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use cliff::plot::{MapStyle, plot_map};

use crate::args::FloorplanArgs;
use crate::load::{load_floorplan, load_map};

/// Arguments of `cliff plot map`.
#[derive(Args, Debug)]
pub struct MapArgs {
    /// Map file (.csv or .cliff); omit for the built-in demo scene.
    #[arg(long)]
    pub map: Option<PathBuf>,
    #[command(flatten)]
    pub frame: FloorplanArgs,
    /// Arrow length per unit of speed, in seconds (an arrow is as long as the way
    /// walked in that time) [default: the fastest component's arrow is 0.45 grid
    /// steps long].
    #[arg(long)]
    pub arrow_seconds: Option<f64>,
    /// Skip components whose weight (normalised per location) is below this.
    #[arg(long, default_value_t = 0.0)]
    pub min_weight: f64,
    /// Leave out the direction colour wheel.
    #[arg(long)]
    pub no_legend: bool,
    /// Output picture: .png or .svg.
    #[arg(long)]
    pub out: PathBuf,
}

/// Run `cliff plot map`.
pub fn run(a: MapArgs) -> Result<()> {
    let map = load_map(a.map.as_ref())?;
    let floorplan = load_floorplan(&a.frame, a.map.as_ref())?;
    let style = MapStyle {
        width: a.frame.width,
        view: a.frame.view,
        arrow_seconds: a.arrow_seconds,
        min_weight: a.min_weight,
        floorplan_strength: a.frame.floorplan_strength,
        title: a.frame.title.clone(),
        legend: !a.no_legend,
        ..MapStyle::default()
    };
    let frame = plot_map(&map, floorplan.as_ref(), &style, &a.out)
        .with_context(|| format!("drawing {}", a.out.display()))?;
    let info = map.info();
    println!(
        "wrote {} ({}x{} px): {} locations, {} components, arrows {:.2} s x speed",
        a.out.display(),
        frame.size.0,
        frame.size.1,
        info.locations,
        info.components,
        style.arrow_seconds_for(&map)
    );
    Ok(())
}
