//! `cliff plot curves`: ADE and FDE against the horizon from `cliff eval` summaries
//! (PNG or SVG).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use cliff::plot::{CurveRun, CurvesStyle, plot_curves};

use crate::args::Spread;
use crate::load::run_rows;

/// Arguments of `cliff plot curves`.
#[derive(Args, Debug)]
pub struct CurvesArgs {
    /// summary.csv files written by `cliff eval --out DIR` (DIR/summary.csv); give
    /// several to compare runs.
    #[arg(long, required = true, num_args = 1..)]
    pub summary: Vec<PathBuf>,
    /// A legend label per summary, in the same order [default: the summary's folder
    /// name].
    #[arg(long, num_args = 1..)]
    pub label: Vec<String>,
    /// Picture width in pixels.
    #[arg(long, default_value_t = 1100)]
    pub width: u32,
    /// Picture height in pixels.
    #[arg(long, default_value_t = 460)]
    pub height: u32,
    /// Where means and bands come from: `summary` (the summary's ade, ade_sd, fde,
    /// fde_sd; `cliff eval` writes the spread over seeds there) or `people` (mean and
    /// standard deviation over people, from the per_person.csv beside each summary,
    /// as in the CLiFF-LHMP paper's figures).
    #[arg(long, value_enum, default_value_t = Spread::Summary)]
    pub spread: Spread,
    /// Leave out the one-standard-deviation bands.
    #[arg(long)]
    pub no_bands: bool,
    /// Title above the picture.
    #[arg(long)]
    pub title: Option<String>,
    /// Output picture: .png or .svg.
    #[arg(long)]
    pub out: PathBuf,
}

/// A run's default label: the summary's folder name, else its path.
fn default_label(path: &Path) -> String {
    path.parent()
        .and_then(|p| p.file_name())
        .map(|n| n.to_string_lossy().into_owned())
        .filter(|n| !n.is_empty())
        .unwrap_or_else(|| path.display().to_string())
}

/// Run `cliff plot curves`.
pub fn run(a: CurvesArgs) -> Result<()> {
    if !a.label.is_empty() && a.label.len() != a.summary.len() {
        bail!(
            "{} --label value(s) for {} --summary file(s): give one label per summary or none",
            a.label.len(),
            a.summary.len()
        );
    }
    let mut runs = Vec::with_capacity(a.summary.len());
    for (i, path) in a.summary.iter().enumerate() {
        let rows = run_rows(path, a.spread)?;
        let label = a
            .label
            .get(i)
            .cloned()
            .unwrap_or_else(|| default_label(path));
        runs.push(CurveRun { label, rows });
    }
    // Same folder names: fall back to the full paths.
    if a.label.is_empty() {
        let labels: Vec<&String> = runs.iter().map(|r| &r.label).collect();
        if (1..labels.len()).any(|i| labels[..i].contains(&labels[i])) {
            for (r, p) in runs.iter_mut().zip(&a.summary) {
                r.label = p.display().to_string();
            }
        }
    }
    let style = CurvesStyle {
        size: (a.width, a.height),
        bands: !a.no_bands,
        title: a.title.clone().or_else(|| {
            (a.spread == Spread::People).then(|| {
                "Displacement error against prediction horizon (mean ± 1 sd over people)"
                    .to_string()
            })
        }),
    };
    let layout = plot_curves(&runs, &style, &a.out)
        .with_context(|| format!("drawing {}", a.out.display()))?;
    let names: Vec<&str> = layout.series.iter().map(|s| s.0.as_str()).collect();
    println!(
        "wrote {} ({}x{} px): {} curve(s) up to {:.1} s: {}",
        a.out.display(),
        layout.size.0,
        layout.size.1,
        names.len(),
        layout.ade.extent.x1,
        names.join(", ")
    );
    Ok(())
}
