//! Building, scoring and updating CLiFF-maps: synthetic recovery and real ATC data.
//!
//! The ATC tests share one map built from all of atc/train (built once per test
//! binary). Figures are printed (`--nocapture`) for the report.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use cliff::map::CliffMap;
use cliff::map::build::{
    BuildParams, Built, FitParams, MeanShift, Observation, build_map, fit_mixture,
    observations_from_tracks,
};
use cliff::map::score::{ScoreParams, ScoreReport, score};
use cliff::map::update::{OnlineMap, UpdateParams};
use cliff::math::{wrap_2pi, wrap_pi};
use cliff::tracks::{Format, read_many};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

fn data(rel: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data")).join(rel)
}

fn atc_files(dir: &str, hours: &[u32]) -> Vec<PathBuf> {
    let kind = if dir == "train" { "train" } else { "test" };
    hours
        .iter()
        .map(|h| data(&format!("atc/{dir}/atc-1024-{h}_{kind}.csv")))
        .collect()
}

const TRAIN_HOURS: [u32; 11] = [9, 10, 11, 13, 14, 15, 16, 17, 18, 19, 20];
const DEV_HOURS: [u32; 6] = [9, 11, 13, 15, 17, 19];

fn atc_obs(files: &[PathBuf]) -> Vec<Observation> {
    observations_from_tracks(&read_many(files, Format::Atc).unwrap())
}

fn dev_obs() -> &'static Vec<Observation> {
    static DEV: OnceLock<Vec<Observation>> = OnceLock::new();
    DEV.get_or_init(|| atc_obs(&atc_files("dev", &DEV_HOURS)))
}

/// The map built from all of atc/train (1 m grid, radius 1 m), built once.
fn train_map() -> &'static Built {
    static MAP: OnceLock<Built> = OnceLock::new();
    MAP.get_or_init(|| {
        let obs = atc_obs(&atc_files("train", &TRAIN_HOURS));
        build_map(&obs, &BuildParams::default()).unwrap()
    })
}

fn atc_score(map: &CliffMap, obs: &[Observation]) -> ScoreReport {
    score(map, obs, &ScoreParams::default()).unwrap()
}

fn show(name: &str, s: &ScoreReport) {
    println!(
        "{name:<28} mean {:.4}  median {:.4}  below -10 {:.2} %  unmatched {} of {}",
        s.mean_log_likelihood,
        s.median_log_likelihood,
        100.0 * s.share_below,
        s.unmatched,
        s.observations
    );
}

/// Draw from a semi-wrapped normal mixture: (theta, rho, cov, weight).
fn draw(mix: &[([f64; 2], [f64; 3], f64)], n: usize, seed: u64) -> Vec<[f64; 2]> {
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let u: f64 = rand::RngExt::random(&mut rng);
        let mut acc = 0.0;
        let (mu, c, _) = mix
            .iter()
            .find(|m| {
                acc += m.2;
                u < acc
            })
            .unwrap_or(mix.last().unwrap());
        // Cholesky of [[a, b], [b, d]].
        let l11 = c[0].sqrt();
        let l21 = c[1] / l11;
        let l22 = (c[2] - l21 * l21).sqrt();
        let z1: f64 = StandardNormal.sample(&mut rng);
        let z2: f64 = StandardNormal.sample(&mut rng);
        let rho = mu[1] + l21 * z1 + l22 * z2;
        if rho > 0.0 {
            out.push([wrap_2pi(mu[0] + l11 * z1), rho]);
        }
    }
    out
}

#[test]
fn synthetic_mixture_is_recovered_including_one_across_zero() {
    // (mean (theta, rho), covariance (tt, tr, rr), weight)
    let truth = [
        ([0.05, 1.2], [0.04, 0.004, 0.01], 0.4), // straddles 0 / 2pi
        ([PI / 2.0 + 0.3, 0.8], [0.02, -0.003, 0.015], 0.35),
        ([3.8, 1.5], [0.03, 0.0, 0.04], 0.25),
    ];
    let x = draw(&truth, 6000, 11);
    // About a third of the first component's samples lie below 2pi.
    assert!(x.iter().filter(|s| s[0] > 5.5).count() > 500);
    let fit = fit_mixture(&x, &FitParams::default());
    println!("{fit:?}");
    let mut used = vec![false; fit.len()];
    for (mu, c, w) in truth {
        let (j, f) = fit
            .iter()
            .enumerate()
            .min_by(|a, b| {
                let d = |f: &cliff::map::Component| {
                    wrap_pi(f.theta - mu[0]).abs() + (f.rho - mu[1]).abs()
                };
                d(a.1).total_cmp(&d(b.1))
            })
            .unwrap();
        used[j] = true;
        assert!(
            wrap_pi(f.theta - mu[0]).abs() < 0.02,
            "mean direction {f:?} vs {mu:?}"
        );
        assert!((f.rho - mu[1]).abs() < 0.02, "mean speed {f:?} vs {mu:?}");
        assert!(
            (f.cov[0] / c[0] - 1.0).abs() < 0.15,
            "var theta {f:?} vs {c:?}"
        );
        assert!(
            (f.cov[3] / c[2] - 1.0).abs() < 0.15,
            "var rho {f:?} vs {c:?}"
        );
        assert!((f.cov[1] - c[1]).abs() < 0.003, "cov {f:?} vs {c:?}");
        assert!((f.weight - w).abs() < 0.03, "weight {f:?} vs {w}");
    }
    // Anything else the fit found carries little weight.
    let extra: f64 = fit
        .iter()
        .zip(&used)
        .filter(|(_, u)| !**u)
        .map(|(f, _)| f.weight)
        .sum();
    assert!(extra < 0.03, "extra weight {extra}");
}

#[test]
fn build_is_reproducible_and_independent_of_threads() {
    let tracks = read_many(&[data("thor1/exp-1-run-2.csv")], Format::Thor).unwrap();
    let obs = observations_from_tracks(&tracks);
    let params = BuildParams {
        grid: 0.5,
        radius: 0.5,
        ..BuildParams::default()
    };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| cliff::map::write_csv_string(&build_map(&obs, &params).unwrap().map))
    };
    let a = run(1);
    assert_eq!(a, run(2));
    assert_eq!(a, run(2));
    assert!(a.lines().count() > 100, "{}", a.lines().count());
}

#[test]
fn binned_mean_shift_matches_exact_on_small_nodes() {
    // A 12 m x 8 m part of the hall in hour 13: nodes of tens to a few hundred samples,
    // where the exact O(n^2) mean shift is affordable.
    let inside = |o: &Observation| {
        (0.0..12.0).contains(&o.position.x) && (-8.0..0.0).contains(&o.position.y)
    };
    let obs: Vec<Observation> = atc_obs(&atc_files("train", &[13]))
        .into_iter()
        .filter(inside)
        .collect();
    let test: Vec<Observation> = atc_obs(&atc_files("dev", &[13, 15]))
        .into_iter()
        .filter(inside)
        .collect();
    assert!(
        obs.len() > 1000 && test.len() > 100,
        "{} {}",
        obs.len(),
        test.len()
    );
    let exact = BuildParams {
        fit: FitParams {
            mean_shift: MeanShift::Exact,
            ..FitParams::default()
        },
        ..BuildParams::default()
    };
    let a = build_map(&obs, &exact).unwrap();
    let b = build_map(&obs, &BuildParams::default()).unwrap();
    let (sa, sb) = (atc_score(&a.map, &test), atc_score(&b.map, &test));
    show("exact mean shift", &sa);
    show("binned mean shift", &sb);
    println!(
        "components: exact {}, binned {}",
        a.summary.components, b.summary.components
    );
    assert_eq!(a.summary.locations, b.summary.locations);
    assert!((sa.mean_log_likelihood - sb.mean_log_likelihood).abs() < 0.02);
    assert!((sa.median_log_likelihood - sb.median_log_likelihood).abs() < 0.02);
    let (ca, cb) = (a.summary.components as f64, b.summary.components as f64);
    assert!((ca - cb).abs() <= 0.05 * ca, "{ca} vs {cb}");
}

#[test]
fn hour13_map_scores_at_least_as_well_as_the_matlab_reference() {
    let obs = atc_obs(&atc_files("train", &[13]));
    let built = build_map(&obs, &BuildParams::default()).unwrap();
    let test = atc_obs(&atc_files("dev", &[13]));
    let ours = atc_score(&built.map, &test);
    let matlab = atc_score(
        &CliffMap::load(data("atc/reference-maps/matlab-hour13.csv")).unwrap(),
        &test,
    );
    show("ours, hour 13", &ours);
    show("MATLAB, hour 13", &matlab);
    // The scorer reproduces the published figures of the reference map.
    assert_eq!((matlab.observations, matlab.unmatched), (7973, 47));
    assert!((matlab.mean_log_likelihood + 1.78).abs() < 0.005);
    assert!((matlab.median_log_likelihood + 1.23).abs() < 0.005);
    assert!(ours.mean_log_likelihood >= matlab.mean_log_likelihood);
    assert!(ours.median_log_likelihood >= matlab.median_log_likelihood);
    assert!(ours.unmatched <= matlab.unmatched);
    // Same nodes as the original: whole-metre positions, the same busiest count.
    assert_eq!(built.summary.max_count, 3598);
    assert!(
        built
            .map
            .locations()
            .iter()
            .all(|l| l.position.x.fract() == 0.0 && l.position.y.fract() == 0.0)
    );
}

#[test]
fn atc_train_map_scores_on_dev_at_least_as_well_as_the_shipped_map() {
    let built = train_map();
    let dev = dev_obs();
    let ours = atc_score(&built.map, dev);
    let shipped = atc_score(
        &CliffMap::load(data("atc/cliffmap-20121024.csv")).unwrap(),
        dev,
    );
    show("built from atc/train", &ours);
    show("shipped (whole day)", &shipped);
    assert_eq!(ours.observations, shipped.observations);
    assert!(ours.mean_log_likelihood >= shipped.mean_log_likelihood);
    assert!(ours.median_log_likelihood >= shipped.median_log_likelihood);
    assert!(
        ours.unmatched * 1000 <= ours.observations,
        "{}",
        ours.unmatched
    );
}

#[test]
fn hourly_online_updates_end_close_to_the_batch_map() {
    let dev = dev_obs();
    let batch = atc_score(&train_map().map, dev);
    let mut hours = TRAIN_HOURS.iter();
    let first = atc_obs(&atc_files("train", &[*hours.next().unwrap()]));
    let mut online =
        OnlineMap::build(&first, &BuildParams::default(), UpdateParams::default()).unwrap();
    for &h in hours {
        let r = online.update(&atc_obs(&atc_files("train", &[h]))).unwrap();
        println!("hour {h}: {r:?}");
    }
    let map = online.to_map().unwrap();
    let s = atc_score(&map, dev);
    show("batch, atc/train", &batch);
    show("online, hour by hour", &s);
    // Nodes do not grow without bound.
    let max_c = map
        .locations()
        .iter()
        .map(|l| l.components.len())
        .max()
        .unwrap();
    assert!(max_c <= UpdateParams::default().max_components);
    let gap = (s.mean_log_likelihood - batch.mean_log_likelihood) / batch.mean_log_likelihood.abs();
    println!("online vs batch: {:.2} %", 100.0 * gap);
    assert!(
        gap >= -0.02,
        "online mean {} vs batch {}",
        s.mean_log_likelihood,
        batch.mean_log_likelihood
    );
}

#[test]
fn predictions_with_the_built_map_are_as_good_as_with_the_shipped_map() {
    use cliff::eval::protocol::{Protocol, Settings};
    use cliff::eval::{EvalConfig, SummaryRow, evaluate};
    use cliff::predict::{Method, Params};
    let tracks = read_many(&atc_files("dev", &DEV_HOURS), Format::Atc).unwrap();
    let cfg = EvalConfig {
        motion_model: None,
        settings: Settings {
            protocol: Protocol::Seconds,
            obs: 3.2,
            dt: 1.0,
            horizon: 50.0,
            ..Settings::default()
        },
        params: Params {
            k: 20,
            beta: 1.0,
            radius: 1.0,
            ..Params::default()
        },
        seeds: 20,
        methods: vec![Method::Cliff],
        options: Default::default(),
    };
    let at_50 = |map: &CliffMap| -> SummaryRow {
        let report = evaluate(map, &tracks, &cfg, &|| {}).unwrap();
        report
            .summary
            .into_iter()
            .find(|r| r.method == Method::Cliff && (r.horizon - 50.0).abs() < 1e-9)
            .expect("a row at 50 s")
    };
    let ours = at_50(&train_map().map);
    let shipped = at_50(&CliffMap::load(data("atc/cliffmap-20121024.csv")).unwrap());
    for (name, r) in [
        ("built from atc/train", &ours),
        ("shipped (whole day)", &shipped),
    ] {
        println!(
            "{name:<22} at 50 s: ADE {:.3} (sd {:.3})  FDE {:.3} (sd {:.3})  people {:.2}",
            r.ade, r.ade_sd, r.fde, r.fde_sd, r.people
        );
    }
    assert!(ours.people > 30.0, "{}", ours.people);
    assert!(
        ours.ade <= 1.05 * shipped.ade,
        "ADE {} vs {}",
        ours.ade,
        shipped.ade
    );
    assert!(
        ours.fde <= 1.05 * shipped.fde,
        "FDE {} vs {}",
        ours.fde,
        shipped.fde
    );
}

/// The total-variation distance between two locations' mixtures by plain Monte Carlo
/// (samples of `(p + q) / 2`, covariance eigenvalues floored at 1e-4 as the measure
/// defines): independent of the library's quadrature.
fn monte_carlo_tv(a: &[cliff::map::Component], b: &[cliff::map::Component], seed: u64) -> f64 {
    use cliff::map::stats::floor_eigenvalues;
    // (weight, theta, rho, covariance, inverse, normalising constant)
    type Part = (f64, f64, f64, [f64; 4], [f64; 3], f64);
    let prep = |cs: &[cliff::map::Component]| -> Vec<Part> {
        let total: f64 = cs.iter().map(|c| c.weight).sum();
        cs.iter()
            .map(|c| {
                let v = floor_eigenvalues(c.cov, 1e-4);
                let det = v[0] * v[3] - v[1] * v[1];
                let inv = [v[3] / det, -v[1] / det, v[0] / det];
                let w = c.weight / total;
                (w, c.theta, c.rho, v, inv, w / (2.0 * PI * det.sqrt()))
            })
            .collect()
    };
    let dens = |parts: &[Part], t: f64, r: f64| -> f64 {
        let mut sum = 0.0;
        for &(_, mt, mr, _, inv, norm) in parts {
            for k in [-1.0, 0.0, 1.0] {
                let d = t - mt + 2.0 * PI * k;
                let e = r - mr;
                sum +=
                    norm * (-0.5 * (inv[0] * d * d + 2.0 * inv[1] * d * e + inv[2] * e * e)).exp();
            }
        }
        sum
    };
    let (p, q) = (prep(a), prep(b));
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
    let n = 20_000;
    let mut sum = 0.0;
    for _ in 0..n {
        let u: f64 = rand::RngExt::random(&mut rng);
        let (from, mut u) = if u < 0.5 {
            (&p, 2.0 * u)
        } else {
            (&q, 2.0 * u - 1.0)
        };
        let &(_, mt, mr, v, _, _) = from
            .iter()
            .find(|c| {
                u -= c.0;
                u <= 0.0
            })
            .unwrap_or(from.last().unwrap());
        let l11 = v[0].sqrt();
        let l21 = v[1] / l11;
        let l22 = (v[3] - l21 * l21).sqrt();
        let z1: f64 = StandardNormal.sample(&mut rng);
        let z2: f64 = StandardNormal.sample(&mut rng);
        let t = wrap_2pi(mt + l11 * z1);
        let r = mr + l21 * z1 + l22 * z2;
        let (dp, dq) = (dens(&p, t, r), dens(&q, t, r));
        sum += (dp - dq).abs() / (dp + dq);
    }
    sum / n as f64
}

#[test]
fn damping_bounds_how_far_a_burst_against_the_flow_moves_each_location() {
    // THÖR1's map (round 1), and a burst of fabricated people: round 2's people walking
    // their paths backwards, against the room's flow
    let base = CliffMap::load(data("thor1/cliffmap.csv")).unwrap();
    let tracks = read_many(&[data("thor1/exp-1-run-2.csv")], Format::Thor).unwrap();
    let burst: Vec<Observation> = observations_from_tracks(&tracks)
        .into_iter()
        .map(|o| Observation {
            theta: wrap_2pi(o.theta + PI),
            ..o
        })
        .collect();
    assert!(burst.len() > 2000, "{}", burst.len());
    let bound = 0.05;
    let learn = |max_move: Option<f64>| {
        let params = UpdateParams {
            decay: 1.0,
            max_move,
            ..UpdateParams::default()
        };
        // the map weighs 200 samples at its busiest location: the burst is heavy
        let mut online = OnlineMap::from_map(&base, 200.0, params).unwrap();
        let report = online.update(&burst).unwrap();
        (online.to_map().unwrap(), report)
    };
    // each location of the base map against the same place after the update
    let moves = |after: &CliffMap| -> Vec<f64> {
        base.locations()
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let j = after
                    .nearest(l.position, 1e-6)
                    .expect("every location stays");
                monte_carlo_tv(&l.components, &after.locations()[j].components, i as u64)
            })
            .collect()
    };
    let (free, free_report) = learn(None);
    let (damped, report) = learn(Some(bound));
    let (free_moves, damped_moves) = (moves(&free), moves(&damped));
    let largest = |m: &[f64]| m.iter().copied().fold(0.0, f64::max);
    let far = |m: &[f64]| m.iter().filter(|&&v| v > bound).count();
    println!(
        "undamped: {} locations moved beyond {bound}, largest {:.3}; damped ({} locations): largest {:.3}",
        far(&free_moves),
        largest(&free_moves),
        report.damped,
        largest(&damped_moves)
    );
    assert_eq!(free_report.damped, 0);
    // the burst really moves the map: many locations far beyond the bound without damping
    assert!(
        far(&free_moves) >= 20 && largest(&free_moves) > 0.3,
        "{free_moves:?}"
    );
    // damped, no location moves beyond the bound (with Monte Carlo's error, about 0.005)
    assert!(largest(&damped_moves) <= bound + 0.01, "{damped_moves:?}");
    // and the damped ones move up to the bound, not to nothing
    assert!(report.damped >= far(&free_moves) / 2, "{report:?}");
    let near_bound = damped_moves.iter().filter(|&&v| v > 0.8 * bound).count();
    assert!(
        near_bound >= report.damped / 2,
        "{near_bound} of {}",
        report.damped
    );
}

#[test]
fn small_updates_grow_the_locations_a_batch_build_of_all_the_data_has() {
    // The daemon learns in batches of a few thousand rows spread over the whole mall:
    // a place that gets one or two samples per batch must still get its location once
    // it has gathered enough, as the batch build over all the rows gives it one.
    let first = atc_obs(&atc_files("train", &[10]));
    let mut online =
        OnlineMap::build(&first, &BuildParams::default(), UpdateParams::default()).unwrap();
    let start = online.len();
    let rest: Vec<u32> = TRAIN_HOURS.iter().copied().filter(|&h| h != 10).collect();
    let rest = atc_obs(&atc_files("train", &rest));
    let mut created = 0;
    for chunk in rest.chunks(5_000) {
        created += online.update(chunk).unwrap().created;
    }
    let map = online.to_map().unwrap();
    let key = |p: glam::DVec2| ((p.x * 1e3).round() as i64, (p.y * 1e3).round() as i64);
    let learned: std::collections::HashSet<_> =
        map.locations().iter().map(|l| key(l.position)).collect();
    let batch = &train_map().map;
    let missing = batch
        .locations()
        .iter()
        .filter(|l| !learned.contains(&key(l.position)))
        .count();
    let (seeds, seeded) = online.seeds();
    println!(
        "hour 10: {start} locations; after {} updates of 5,000: {} ({created} created, {seeds} places waiting with {seeded} samples); batch build of all hours: {}, {missing} of them missing",
        rest.len().div_ceil(5_000),
        map.locations().len(),
        batch.locations().len()
    );
    assert!(
        missing * 100 <= batch.locations().len(),
        "{missing} of the batch build's {} locations missing",
        batch.locations().len()
    );
    assert!(seeded <= cliff::map::update::SEED_BUDGET);
}
