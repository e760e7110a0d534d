//! `cliff motion fit`: a motion model fitted to recorded tracks, with a validation
//! split's errors beside constant velocity's.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use cliff::motion::{
    HorizonErrors, MODEL_DT, MotionFit, NetworkFit, fit_motion_model_sources, motion_model_errors,
};
use cliff::tracks::{Format, Track};

use crate::args::TrackArgs;
use crate::load::{load_tracks, load_tracks_with};

/// Options of `cliff motion fit`.
#[derive(Args, Debug)]
pub struct FitArgs {
    #[command(flatten)]
    pub input: TrackArgs,
    /// More trajectory files, each of its own format: FILE (the format recognised from
    /// the file) or FORMAT:FILE (thor, atc, magni, csv or rosbag2), e.g.
    /// magni:../shared/data/magni/magni-A-first-16min.csv. Each is a source of its own:
    /// the --tracks files together and each of these weigh the same in the fit, however
    /// many windows they hold.
    #[arg(long, num_args = 1.., value_name = "[FORMAT:]FILE", value_parser = format_file)]
    pub more_tracks: Vec<(Option<Format>, PathBuf)>,
    /// Output model file (.motion).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Seconds ahead the model forecasts (0.4 s steps; past them the path goes on at the
    /// last step's velocity).
    #[arg(long, default_value_t = 12.0)]
    pub horizon: f64,
    /// Ridge penalty (m^2) on the displacement coefficients.
    #[arg(long, default_value_t = MotionFit::default().lambda)]
    pub lambda: f64,
    /// Steps faster than this (m/s) are tracking jumps: left out of the fit.
    #[arg(long, default_value_t = MotionFit::default().max_speed)]
    pub max_speed: f64,
    /// A track is cut where two rows are further apart than this (s).
    #[arg(long, default_value_t = MotionFit::default().max_gap)]
    pub max_gap: f64,
    /// Hidden units per layer of the network that corrects the linear part where
    /// walking is not linear in the history (people slowing to a stop, starting,
    /// turning); 0 fits the linear part alone. The network is trained on at most
    /// 300,000 windows (every n-th beyond) and costs a few seconds per 10,000 windows.
    #[arg(long, default_value_t = NetworkFit::default().hidden)]
    pub hidden: usize,
    /// Passes of the network's training over the windows.
    #[arg(long, default_value_t = NetworkFit::default().epochs)]
    pub epochs: usize,
    /// Seed of the network's training (shuffling, starting weights).
    #[arg(long, default_value_t = NetworkFit::default().seed)]
    pub seed: u64,
    /// Share of the data held out to print the validation errors: every n-th track
    /// (with 10 tracks or more), else the last part of each track in time. The model
    /// written is fitted on all the tracks.
    #[arg(long, default_value_t = 0.2)]
    pub validation: f64,
}

/// `FORMAT:FILE`, or `FILE` alone (also when what precedes a colon names no format).
fn format_file(s: &str) -> Result<(Option<Format>, PathBuf), String> {
    if s.is_empty() {
        return Err("names no file: expected [FORMAT:]FILE (e.g. magni:recording.csv)".into());
    }
    Ok(match s.split_once(':') {
        Some((format, file)) if format.parse::<Format>().is_ok() && !file.is_empty() => {
            (format.parse().ok(), PathBuf::from(file))
        }
        _ => (None, PathBuf::from(s)),
    })
}

/// The name of a source: `FORMAT:FILE`, with the format named or recognised.
fn source(format: Option<Format>, file: &Path) -> String {
    let format = format.map_or_else(|| Format::detect(file), Ok);
    match format {
        Ok(f) => format!("{f}:{}", file.display()),
        Err(_) => file.display().to_string(),
    }
}

/// Run `cliff motion fit`.
pub fn run(a: FitArgs) -> Result<()> {
    if !(a.validation.is_finite() && (0.0..0.9).contains(&a.validation)) {
        bail!("--validation {} is not a share in [0, 0.9)", a.validation);
    }
    let mut groups = vec![load_tracks_with(
        &a.input.tracks,
        a.input.format,
        &a.input.read,
    )?];
    let mut sources: Vec<String> = a
        .input
        .tracks
        .iter()
        .map(|p| source(a.input.format, p))
        .collect();
    for (format, file) in &a.more_tracks {
        groups.push(load_tracks(std::slice::from_ref(file), *format)?);
        sources.push(source(*format, file));
    }
    let steps = (a.horizon / MODEL_DT).round();
    if !(steps >= 1.0 && steps <= cliff::motion::MAX_MODEL_STEPS as f64) {
        bail!(
            "--horizon {} s is not 0.4 to {} s",
            a.horizon,
            cliff::motion::MAX_MODEL_STEPS as f64 * MODEL_DT
        );
    }
    let fit = MotionFit {
        steps: steps as usize,
        lambda: a.lambda,
        max_speed: a.max_speed,
        max_gap: a.max_gap,
        source: sources.join(" "),
        network: (a.hidden > 0).then_some(NetworkFit {
            hidden: a.hidden,
            epochs: a.epochs,
            seed: a.seed,
        }),
        ..MotionFit::default()
    };
    let tracks: usize = groups.iter().map(Vec::len).sum();
    if a.validation > 0.0 {
        let mut train = Vec::new();
        let mut held_out = Vec::new();
        let mut hows = Vec::new();
        for g in &groups {
            let (t, h, how) = split(g, a.validation);
            train.push(t);
            held_out.extend(h);
            hows.push(how);
        }
        let how = hows.join("; ");
        let train: Vec<&[Track]> = train.iter().map(Vec::as_slice).collect();
        let model =
            fit_motion_model_sources(&train, &fit).context("fitting the validation split")?;
        let horizons: Vec<f64> = [1.2, 2.4, 4.8, 8.0, 12.0]
            .into_iter()
            .filter(|h| *h <= fit.steps as f64 * MODEL_DT + 1e-9)
            .collect();
        let errors = motion_model_errors(&model, &held_out, &fit, &horizons);
        println!("validation: {how}; the model fitted on the rest");
        print_errors(&errors);
    }
    let all: Vec<&[Track]> = groups.iter().map(Vec::as_slice).collect();
    let model = fit_motion_model_sources(&all, &fit)?;
    model.save(&a.out)?;
    let info = model.info();
    let network = model.network().map_or_else(
        || "no network".to_string(),
        |n| format!("a network of 2 x {} units", n.hidden),
    );
    println!(
        "wrote {}: {} steps ({:.1} s) fitted on {} windows of {} tracks (lambda {}, {network}, steps over {} m/s left out)",
        a.out.display(),
        model.steps(),
        model.steps() as f64 * MODEL_DT,
        info.windows,
        tracks,
        info.lambda,
        info.max_speed
    );
    Ok(())
}

/// The tracks to fit on and those held out, and how they were split.
fn split(tracks: &[Track], share: f64) -> (Vec<Track>, Vec<Track>, String) {
    let every = (1.0 / share).round().max(2.0) as usize;
    if tracks.len() >= 10 {
        let (mut train, mut held) = (Vec::new(), Vec::new());
        for (i, t) in tracks.iter().enumerate() {
            if i % every == every - 1 {
                held.push(t.clone());
            } else {
                train.push(t.clone());
            }
        }
        let how = format!(
            "every {every}th track held out ({} of {})",
            held.len(),
            tracks.len()
        );
        return (train, held, how);
    }
    let (mut train, mut held) = (Vec::new(), Vec::new());
    for t in tracks {
        let (Some(first), Some(last)) = (t.rows.first(), t.rows.last()) else {
            continue;
        };
        let cut = last.t - share * (last.t - first.t);
        let at = t.rows.partition_point(|r| r.t < cut);
        train.push(Track {
            id: t.id,
            rows: t.rows[..at].to_vec(),
        });
        held.push(Track {
            id: t.id,
            rows: t.rows[at..].to_vec(),
        });
    }
    let how = format!(
        "the last {:.0} % of each of the {} tracks' time held out",
        share * 100.0,
        tracks.len()
    );
    (train, held, how)
}

fn print_errors(errors: &[HorizonErrors]) {
    println!("horizon   windows   ADE model  ADE cvm-last   FDE model  FDE cvm-last");
    for e in errors {
        println!(
            "{:>5.1} s {:>9} {:>11.3} {:>13.3} {:>11.3} {:>13.3}",
            e.horizon, e.windows, e.ade, e.cvm_ade, e.fde, e.cvm_fde
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn more_tracks_take_a_format_or_a_file_alone() {
        let f = |s: &str| format_file(s).unwrap();
        assert_eq!(
            f("magni:a.csv"),
            (Some(Format::Magni), PathBuf::from("a.csv"))
        );
        assert_eq!(f("a.csv"), (None, PathBuf::from("a.csv")));
        // a colon that follows no format's name is part of the file's name
        assert_eq!(f("run:2.csv"), (None, PathBuf::from("run:2.csv")));
        assert_eq!(f("thor:"), (None, PathBuf::from("thor:")));
        assert!(format_file("").is_err());
    }
}
