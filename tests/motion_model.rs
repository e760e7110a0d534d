//! The learned motion model on real data: the built-in model is what its command fits,
//! a model fitted on a site's recording beats constant velocity on the same site's
//! later people (the THÖR-MAGNI benchmark's tracklets), constant velocity of the last
//! displacement matches a computation of its own, and counting every sample keeps every
//! tracklet at every horizon.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use cliff::eval::metrics::Counting;
use cliff::eval::protocol::{Protocol, Settings};
use cliff::eval::{EvalConfig, EvalReport, SummaryRow, evaluate};
use cliff::map::CliffMap;
use cliff::motion::{MotionFit, MotionModel, fit_motion_model, fit_motion_model_sources};
use cliff::predict::{Method, Params};
use cliff::tracks::{Format, Track, read_many, read_tracks};

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(rel)
}

/// The recording's tracks with rows in `[from, until)` seconds.
fn magni(from: f64, until: f64) -> Vec<Track> {
    let mut tracks = read_tracks(&data("magni/magni-A.csv"), Format::Magni).unwrap();
    for t in &mut tracks {
        t.rows.retain(|r| r.t >= from && r.t < until);
    }
    tracks.retain(|t| !t.rows.is_empty());
    tracks
}

fn benchmark_settings(counting: Counting) -> Settings {
    Settings {
        protocol: Protocol::Tracklets,
        obs: 3.2,
        dt: 0.4,
        horizon: 4.8,
        max_speed: 3.0,
        counting,
        ..Settings::default()
    }
}

fn row(report: &EvalReport, method: Method, horizon: f64) -> &SummaryRow {
    report
        .summary
        .iter()
        .find(|r| r.method == method && (r.horizon - horizon).abs() < 1e-9)
        .unwrap_or_else(|| panic!("no row for {method} at {horizon} s"))
}

#[test]
fn the_builtin_model_is_what_its_command_fits() {
    // `cliff motion fit --tracks ../shared/data/atc/train/*.csv --format atc --hidden 0 --out ...`:
    // the shell's glob order, paths as the command names them
    let dir = data("atc/train");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".csv"))
        .collect();
    names.sort();
    let files: Vec<PathBuf> = names.iter().map(|n| dir.join(n)).collect();
    let tracks = read_many(&files, Format::Atc).unwrap();
    let source = names
        .iter()
        .map(|n| format!("atc:../shared/data/atc/train/{n}"))
        .collect::<Vec<_>>()
        .join(" ");
    let fit = MotionFit {
        source,
        network: None,
        ..MotionFit::default()
    };
    let model = fit_motion_model_sources(&[&tracks], &fit).unwrap();
    assert_eq!(model.encode(), MotionModel::builtin().encode());
    assert_eq!(MotionModel::builtin().steps(), 30);
}

/// The benchmark's tracklets by hand: per helmet, rows split where they are more than
/// 0.6 s apart, cut back to back into 20 rows, left out when a step is faster than
/// 3 m/s; constant velocity of the 8th row minus the 7th from the 8th row, errors at the
/// rows 9-20. (tracklets, ADE, FDE)
fn cvm_last_by_hand(from: f64) -> (usize, f64, f64) {
    let text = std::fs::read_to_string(data("magni/magni-A.csv")).unwrap();
    let mut helmets: BTreeMap<String, Vec<(f64, f64, f64)>> = BTreeMap::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let t: f64 = f[0].parse().unwrap();
        if t >= from {
            let (x, y) = (f[2].parse().unwrap(), f[3].parse().unwrap());
            helmets.entry(f[1].to_string()).or_default().push((t, x, y));
        }
    }
    let (mut n, mut ade, mut fde) = (0usize, 0.0, 0.0);
    for rows in helmets.values() {
        let mut pieces = vec![vec![rows[0]]];
        for w in rows.windows(2) {
            if w[1].0 - w[0].0 > 0.6 {
                pieces.push(vec![]);
            }
            pieces.last_mut().unwrap().push(w[1]);
        }
        for piece in &pieces {
            for c in piece.chunks_exact(20) {
                let jump = c.windows(2).any(|w| {
                    let d = ((w[1].1 - w[0].1).powi(2) + (w[1].2 - w[0].2).powi(2)).sqrt();
                    d > 3.0 * (w[1].0 - w[0].0)
                });
                if jump {
                    continue;
                }
                let (vx, vy) = (
                    (c[7].1 - c[6].1) / (c[7].0 - c[6].0),
                    (c[7].2 - c[6].2) / (c[7].0 - c[6].0),
                );
                let mut sum = 0.0;
                let mut last = 0.0;
                for j in 1..=12 {
                    // the prediction at the 8th row's time + 0.4 j against the truth
                    // between the rows around that time (they are 0.4 s apart, give or
                    // take 0.01 s)
                    let t = c[7].0 + 0.4 * j as f64;
                    let i = c.iter().position(|r| r.0 >= t - 1e-9).unwrap_or(19).max(1);
                    let (a, b) = (c[i - 1], c[i]);
                    let w = ((t - a.0) / (b.0 - a.0)).clamp(0.0, 1.0);
                    let (tx, ty) = (a.1 + w * (b.1 - a.1), a.2 + w * (b.2 - a.2));
                    let (px, py) = (c[7].1 + vx * 0.4 * j as f64, c[7].2 + vy * 0.4 * j as f64);
                    last = ((px - tx).powi(2) + (py - ty).powi(2)).sqrt();
                    sum += last;
                }
                n += 1;
                ade += sum / 12.0;
                fde += last;
            }
        }
    }
    (n, ade / n as f64, fde / n as f64)
}

/// The top-1 rows of constant velocity of the last displacement and of `model`'s
/// expected path on the tracklets of the recording's last 16 minutes, at 4.8 s.
fn later_people(model: MotionModel) -> (SummaryRow, SummaryRow, usize) {
    let later = magni(960.0, f64::INFINITY);
    let cfg = EvalConfig {
        settings: benchmark_settings(Counting::Everyone),
        params: Params::default(),
        seeds: 1,
        methods: vec![Method::CvmLast, Method::Motion],
        options: Default::default(),
        motion_model: Some(std::sync::Arc::new(model)),
    };
    // neither method reads the map
    let report = evaluate(&CliffMap::demo(), &later, &cfg, &|| {}).unwrap();
    let cv = row(&report, Method::CvmLast, 4.8).clone();
    let motion = row(&report, Method::Motion, 4.8).clone();
    (cv, motion, report.people_evaluated)
}

#[test]
fn a_model_fitted_on_a_site_beats_constant_velocity_on_its_later_people() {
    // fitted on the recording's first 16 minutes, scored on the tracklets of the last 16
    let first = magni(0.0, 960.0);
    let linear = MotionFit {
        network: None,
        ..MotionFit::default()
    };
    let (cv, motion, evaluated) = later_people(fit_motion_model(&first, &linear).unwrap());
    // the benchmark's baseline, computed apart
    let (n, ade, fde) = cvm_last_by_hand(960.0);
    assert_eq!(evaluated, n);
    assert_eq!(cv.people as usize, n);
    assert!((cv.top1_ade - ade).abs() < 1e-4, "{} vs {ade}", cv.top1_ade);
    assert!((cv.top1_fde - fde).abs() < 1e-4, "{} vs {fde}", cv.top1_fde);
    // the linear model's expected path (its top-1) against it: 0.88 and 0.84 measured
    assert!(
        motion.top1_ade < 0.92 * ade && motion.top1_fde < 0.9 * fde,
        "linear {} / {}, cvm-last {ade} / {fde}",
        motion.top1_ade,
        motion.top1_fde,
    );
    assert_eq!((motion.people, motion.reach), (cv.people, 1.0));

    // with the network (the default fit): 0.825 / 0.799 of constant velocity measured,
    // the benchmark's SimpleMLP 0.89 / 0.82 on its own folds
    let model = fit_motion_model(&first, &MotionFit::default()).unwrap();
    assert!(model.network().is_some());
    let (_, net, _) = later_people(model);
    assert!(
        net.top1_ade <= 0.85 * ade && net.top1_fde <= 0.81 * fde,
        "with the network {} / {}, cvm-last {ade} / {fde}",
        net.top1_ade,
        net.top1_fde,
    );
    // and against the linear model alone: 0.94 / 0.95 measured
    assert!(
        net.top1_ade < 0.97 * motion.top1_ade && net.top1_fde < 0.97 * motion.top1_fde,
        "with the network {} / {}, linear {} / {}",
        net.top1_ade,
        net.top1_fde,
        motion.top1_ade,
        motion.top1_fde
    );
}

#[test]
fn counting_everyone_keeps_every_tracklet_where_the_paper_stops() {
    let map_tracks = magni(0.0, 960.0);
    let map = cliff::map::build::build_map(
        &cliff::map::build::observations_from_tracks(&map_tracks),
        &cliff::map::build::BuildParams {
            grid: 0.5,
            radius: 0.5,
            ..Default::default()
        },
    )
    .unwrap()
    .map;
    let later = magni(960.0, f64::INFINITY);
    let report = |counting| {
        let cfg = EvalConfig {
            settings: benchmark_settings(counting),
            params: Params {
                radius: 0.5,
                ..Params::default()
            },
            seeds: 2,
            methods: vec![Method::Cliff, Method::CvmLast],
            options: Default::default(),
            motion_model: None,
        };
        evaluate(&map, &later, &cfg, &|| {}).unwrap()
    };
    let everyone = report(Counting::Everyone);
    let reached = report(Counting::Reached);
    let all = row(&everyone, Method::CvmLast, 4.8).people;
    let cliff = row(&everyone, Method::Cliff, 4.8);
    // every tracklet counts for the paper's method too, and its reach says how many it
    // reached (the paper's samples stop where the map has no data)
    assert_eq!(cliff.people, all);
    assert!(cliff.reach < 0.95, "{}", cliff.reach);
    let only_reached = row(&reached, Method::Cliff, 4.8);
    assert!((only_reached.people - cliff.reach * all).abs() < 1e-9);
    assert_eq!(only_reached.reach, cliff.reach);
}

#[test]
fn motion_fit_writes_a_model_info_reads_and_a_damaged_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("thor1.motion");
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_cliff"))
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap()
    };
    let fit = run(&[
        "motion",
        "fit",
        "--tracks",
        "../shared/data/thor1/exp-1-run-2.csv",
        "--format",
        "thor",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&fit.stdout);
    assert!(
        fit.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&fit.stderr)
    );
    assert!(stdout.contains("every 5th track held out"), "{stdout}");
    assert!(stdout.contains("ADE cvm-last"), "{stdout}");
    let model = MotionModel::load(&out).unwrap();
    let info = run(&["motion", "info", out.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&info.stdout);
    assert!(
        stdout.contains(&format!("{} steps of 0.4 s", model.steps())),
        "{stdout}"
    );
    assert!(
        stdout.contains("thor:../shared/data/thor1/exp-1-run-2.csv"),
        "{stdout}"
    );
    let mut bytes = std::fs::read(&out).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0xff;
    std::fs::write(&out, &bytes).unwrap();
    let bad = run(&["motion", "info", out.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success());
    assert!(
        stderr.contains("thor1.motion: not a valid cliff motion model: checksum mismatch"),
        "{stderr}"
    );
}

#[test]
fn the_motion_option_leaves_the_model_where_the_map_has_nothing_and_bends_it_where_it_has() {
    use cliff::motion::State;
    use cliff::predict::{Options, Rank, TrajectoryBatch, predict_with};
    use glam::DVec2;
    let map = CliffMap::demo();
    // `improved`'s options with the motion model under the map
    let options = Options {
        scores: true,
        follow: 4.0,
        candidates: 2,
        prune: true,
        trust: 0.5,
        blend: 3.0,
        rank: Rank::Consensus,
        motion: true,
        ..Options::default()
    };
    let params = Params {
        beta: 2.0,
        k: 20,
        horizon: 12.0,
        seed: 11,
        ..Params::default()
    };
    let walker = |x: f64, y: f64| State {
        position: DVec2::new(x, y),
        speed: 1.2,
        heading: 0.0,
        time: 0.0,
    };
    let positions = |b: &TrajectoryBatch| -> Vec<[f32; 2]> {
        (0..b.shape().1)
            .flat_map(|s| b.sample(0, s).to_vec())
            .collect()
    };
    // far from every location of the map: the samples are the motion model's, but the
    // first, which is their mean path
    let far = [walker(500.0, 500.0)];
    let (mut bent, mut alone) = (TrajectoryBatch::new(), TrajectoryBatch::new());
    predict_with(&map, &far, &params, &options, &mut bent).unwrap();
    let motion = Params {
        method: Method::Motion,
        ..params
    };
    predict_with(&map, &far, &motion, &Options::default(), &mut alone).unwrap();
    assert!(bent.lens().iter().all(|&l| l == 30));
    let (b, a) = (positions(&bent), positions(&alone));
    assert_eq!(b.len(), a.len());
    let k = params.k;
    for j in 0..30 {
        let mean = |i: usize| (0..k).map(|s| f64::from(a[s * 30 + j][i])).sum::<f64>() / k as f64;
        assert!((f64::from(b[j][0]) - mean(0)).abs() < 1e-3, "step {j}");
        assert!((f64::from(b[j][1]) - mean(1)).abs() < 1e-3, "step {j}");
    }
    for (p, q) in b.iter().zip(&a).skip(30) {
        assert!(
            (p[0] - q[0]).abs() < 1e-3 && (p[1] - q[1]).abs() < 1e-3,
            "{p:?} {q:?}"
        );
    }
    // in the hall, walking along its eastward flow: the map bends the samples, and every
    // one reaches the horizon
    let hall = [walker(-10.0, 0.5)];
    predict_with(&map, &hall, &params, &options, &mut bent).unwrap();
    predict_with(&map, &hall, &motion, &Options::default(), &mut alone).unwrap();
    assert!(bent.lens().iter().all(|&l| l == 30));
    let apart = positions(&bent)
        .iter()
        .zip(&positions(&alone))
        .map(|(p, q)| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt())
        .fold(0.0f32, f32::max);
    assert!(apart > 0.5, "the map moved no sample: {apart}");
}
