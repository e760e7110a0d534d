//! `cliff demo`: the guided tour, from nothing to three pictures.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use cliff::eval::protocol::{Case, prepare};
use cliff::eval::{EvalConfig, evaluate, summary_table, write_reports};
use cliff::math::wrap_2pi;
use cliff::plot::{
    CurveRun, CurvesStyle, MapStyle, PersonPrediction, PredictStyle, plot_curves, plot_map,
    plot_predictions,
};
use cliff::predict::{Method, TrajectoryBatch};
use cliff::tracks::Format;
use cliff::tracks::scene::{SceneOptions, demo_tracks, tracks_csv};

use crate::args::{FloorplanArgs, PredictionArgs, Spread};
use crate::load::{load_floorplan, load_map, load_tracks, run_rows};
use crate::person::predict_case;
/// Arguments of `cliff demo`.
#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Output folder for the pictures and reports (created if missing).
    #[arg(long, default_value = "cliff-demo")]
    pub out: PathBuf,
    /// Map file (.csv or .cliff) [default: the built-in demo hall].
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Trajectory file [default: synthetic walkers in the demo hall].
    #[arg(long)]
    pub tracks: Option<PathBuf>,
    /// Trajectory file format of --tracks: thor, atc, magni, csv or rosbag2 [default:
    /// recognised from the file].
    #[arg(long)]
    pub format: Option<Format>,
    /// Synthetic walkers to make (without --tracks).
    #[arg(long, default_value_t = 40)]
    pub people: usize,
    /// Seed of the synthetic walkers (without --tracks).
    #[arg(long, default_value_t = 7)]
    pub scene_seed: u64,
    /// People drawn in the prediction picture.
    #[arg(long, default_value_t = 3)]
    pub show: usize,
    /// Seeds per stochastic method in the evaluation.
    #[arg(long, default_value_t = 5)]
    pub seeds: usize,
    #[command(flatten)]
    pub prediction: PredictionArgs,
    #[command(flatten)]
    pub frame: FloorplanArgs,
}

/// How much a person turns over the ground truth (rad): between the start heading
/// and the direction from the start to the last truth row.
fn turn_of(case: &Case) -> f64 {
    let Some(last) = case
        .future
        .iter()
        .rev()
        .find(|r| r.t <= case.start.time + case.horizon + 1e-6)
    else {
        return 0.0;
    };
    let d = last.position - case.start.position;
    if d.length() < 1.0 {
        return 0.0;
    }
    let a = wrap_2pi(d.to_angle() - case.start.heading);
    a.min(std::f64::consts::TAU - a)
}

/// Pick up to `n` people worth a look: the one who turns most, then the ones with
/// the longest ground truth that start at least 4 m from those already picked.
fn pick_people(cases: &[Case], n: usize) -> Vec<&Case> {
    let mut picked: Vec<&Case> = Vec::new();
    if n == 0 || cases.is_empty() {
        return picked;
    }
    if let Some(c) = cases
        .iter()
        .max_by(|a, b| turn_of(a).total_cmp(&turn_of(b)).then(b.id.cmp(&a.id)))
    {
        picked.push(c);
    }
    let mut rest: Vec<&Case> = cases.iter().collect();
    rest.sort_by(|a, b| b.horizon.total_cmp(&a.horizon).then(a.id.cmp(&b.id)));
    for c in rest {
        if picked.len() >= n {
            break;
        }
        if picked
            .iter()
            .all(|p| p.start.position.distance(c.start.position) >= 4.0)
        {
            picked.push(c);
        }
    }
    picked
}

/// Run `cliff demo`.
pub fn run(a: DemoArgs) -> Result<()> {
    let t0 = Instant::now();
    let map = load_map(a.map.as_ref())?;
    let floorplan = load_floorplan(&a.frame, a.map.as_ref())?;
    let synthetic = a.tracks.is_none();
    let tracks = match (&a.map, &a.tracks) {
        (_, Some(t)) => load_tracks(std::slice::from_ref(t), a.format)?,
        (None, None) => demo_tracks(&SceneOptions {
            people: a.people,
            seed: a.scene_seed,
            ..SceneOptions::default()
        }),
        (Some(_), None) => {
            bail!("--tracks is needed with --map (the synthetic walkers only walk the demo hall)")
        }
    };
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("creating output folder {}", a.out.display()))?;
    let info = map.info();
    let map_name = a.map.as_ref().map_or(
        "built-in demo hall (30 m x 20 m, two crossing corridors)".to_string(),
        |p| p.display().to_string(),
    );
    println!(
        "map      {map_name}: {} locations, {} components",
        info.locations, info.components
    );
    let tracks_file = a.out.join("tracks.csv");
    if synthetic {
        std::fs::write(&tracks_file, tracks_csv(&tracks))
            .with_context(|| format!("writing {}", tracks_file.display()))?;
        println!(
            "people   {} synthetic walkers (seed {}), {} rows at 0.4 s, written to {}",
            tracks.len(),
            a.scene_seed,
            tracks.iter().map(|t| t.rows.len()).sum::<usize>(),
            tracks_file.display()
        );
    } else if let Some(t) = &a.tracks {
        println!("people   {} from {}", tracks.len(), t.display());
    }

    // 1. The evaluation: every method on the same people.
    let settings = a.prediction.settings();
    let cfg = EvalConfig {
        motion_model: None,
        settings,
        params: a.prediction.params(Method::Cliff, 0),
        seeds: a.seeds.max(1),
        methods: vec![Method::Cliff, Method::Cvm],
        options: Default::default(),
    };
    let report = evaluate(&map, &tracks, &cfg, &|| {}).context("evaluation")?;
    if report.people_evaluated == 0 {
        bail!(
            "the {} protocol keeps none of the {} people (tracks too short or idle)",
            settings.protocol,
            report.people_total
        );
    }
    write_reports(&report, &a.out)
        .with_context(|| format!("writing reports to {}", a.out.display()))?;
    println!(
        "evaluated {} of {} people ({} protocol, {:.1} s observed, k {}, {} seeds)",
        report.people_evaluated,
        report.people_total,
        settings.protocol,
        settings.obs,
        cfg.params.k,
        cfg.seeds
    );
    let horizons: Vec<f64> = [2.0, 4.0, 8.0, 12.0, 20.0, 30.0, 50.0]
        .into_iter()
        .filter(|h| *h <= settings.horizon + 1e-9)
        .collect();
    print!("{}", summary_table(&report.summary, &horizons));

    // 2. The pictures.
    let map_png = a.out.join("map.png");
    let map_style = MapStyle {
        width: a.frame.width,
        view: a.frame.view,
        floorplan_strength: a.frame.floorplan_strength,
        ..MapStyle::default()
    };
    plot_map(&map, floorplan.as_ref(), &map_style, &map_png)
        .with_context(|| format!("drawing {}", map_png.display()))?;

    let cases: Vec<Case> = tracks
        .iter()
        .filter_map(|t| prepare(t, &settings))
        .collect();
    let shown = pick_people(&cases, a.show);
    let mut people = Vec::with_capacity(shown.len());
    let mut batch = TrajectoryBatch::new();
    let mut k = 0;
    for case in &shown {
        let params = predict_case(&map, case, &a.prediction, Method::Cliff, 0, &mut batch)?;
        k = params.k;
        people.push(PersonPrediction::from_case(case, &batch, 0));
    }
    let ids: Vec<String> = shown.iter().map(|c| c.id.to_string()).collect();
    let predict_png = a.out.join("predictions.png");
    let predict_style = PredictStyle {
        width: a.frame.width,
        view: a.frame.view,
        floorplan_strength: a.frame.floorplan_strength,
        title: Some(format!(
            "CLiFF-LHMP: people {}, {:.1} s observed, up to {:.0} s predicted, k = {k}",
            ids.join(", "),
            settings.obs,
            settings.horizon
        )),
        ..PredictStyle::default()
    };
    plot_predictions(
        &map,
        floorplan.as_ref(),
        &people,
        &predict_style,
        &predict_png,
    )
    .with_context(|| format!("drawing {}", predict_png.display()))?;

    let summary = a.out.join("summary.csv");
    let curves_png = a.out.join("curves.png");
    // The paper's figures: mean and standard deviation over people.
    let rows = run_rows(&summary, Spread::People)?;
    plot_curves(
        &[CurveRun {
            label: "demo".into(),
            rows,
        }],
        &CurvesStyle {
            title: Some(format!(
                "ADE / FDE against horizon: mean ± 1 sd over {} people ({} seeds each)",
                report.people_evaluated, cfg.seeds
            )),
            ..CurvesStyle::default()
        },
        &curves_png,
    )
    .with_context(|| format!("drawing {}", curves_png.display()))?;

    println!("wrote");
    println!(
        "  {}  the map: one arrow per component, colour = direction, opacity = weight",
        map_png.display()
    );
    println!(
        "  {}  people {}: observed (green), ground truth (red), {k} samples (blue)",
        predict_png.display(),
        ids.join(", ")
    );
    println!(
        "  {}  ADE and FDE against horizon, cliff vs cvm, with 1-sd bands",
        curves_png.display()
    );
    println!(
        "  {} and {}",
        summary.display(),
        a.out.join("per_person.csv").display()
    );
    println!("done in {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}
