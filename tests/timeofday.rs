//! Time-of-day map sets: a synthetic flow that reverses at noon, and real ATC hours
//! (the library, then the command line).

use std::f64::consts::{FRAC_PI_2, PI};
use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::Arc;

use cliff::eval::protocol::{Protocol, Settings};
use cliff::eval::{EvalConfig, evaluate};
use cliff::map::build::{BuildParams, Observation, timed_observations_from_tracks};
use cliff::map::score::{ScoreParams, score, score_set};
use cliff::map::{CliffMap, MapSet, SliceParams, Smoothing, build_map_set};
use cliff::math::wrap_2pi;
use cliff::motion::State;
use cliff::predict::{Method, Params, TrajectoryBatch, predict};
use cliff::tracks::{Format, read_many};
use glam::DVec2;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};

mod common;
use common::cliff;

/// ATC: unix time, recorded in Japan (UTC+9).
const JST: f64 = 9.0 * 3600.0;
/// 2012-10-24 00:00 local time in Japan, as unix time.
const MIDNIGHT_JST: f64 = 1_351_036_800.0 - JST;

fn data(rel: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data")).join(rel)
}

/// People walking along a corridor (x from -10 to 10 m, y within 3 m of 0) at about
/// 1.2 m/s, one row a second: east from 08:00 to 12:00 local time, west from 12:00 to
/// 15:00, `per_hour` people an hour except in the quiet hour 11:00-12:00 (three
/// people, all near the west end): as many people each way.
fn reversing_flow(per_hour: usize) -> (Vec<Observation>, Vec<f64>) {
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(12);
    let (mut obs, mut times) = (Vec::new(), Vec::new());
    for hour in 8..15 {
        let east = hour < 12;
        let people = if hour == 11 { 3 } else { per_hour };
        for p in 0..people {
            let start = MIDNIGHT_JST + hour as f64 * 3600.0 + 3500.0 * p as f64 / people as f64;
            let y: f64 = rng.random_range(-3.0..3.0);
            let z: f64 = StandardNormal.sample(&mut rng);
            let speed = 1.2 + 0.1 * z;
            let heading = if east { 0.0 } else { PI };
            let rows = if hour == 11 {
                5
            } else {
                (20.0 / speed) as usize
            };
            for i in 0..rows {
                let along = -10.0 + speed * i as f64;
                let x = if east { along } else { -along };
                let noise: f64 = StandardNormal.sample(&mut rng);
                obs.push(Observation {
                    position: DVec2::new(x, y),
                    theta: wrap_2pi(heading + 0.1 * noise),
                    rho: speed,
                });
                times.push(start + i as f64);
            }
        }
    }
    (obs, times)
}

/// Where the samples of a person at the corridor's centre, heading north (across the
/// flows), are after 8 s: the mean x, the share east of x = 2 m and the share west of
/// x = -2 m. (beta 0.1: the heading turns readily to the sampled directions.)
fn east_west(map: &CliffMap, time: f64) -> (f64, f64, f64) {
    let start = State {
        position: DVec2::ZERO,
        speed: 1.2,
        heading: FRAC_PI_2,
        time,
    };
    let params = Params {
        method: Method::Cliff,
        k: 200,
        dt: 1.0,
        horizon: 8.0,
        radius: 1.0,
        beta: 0.1,
        seed: 5,
        ..Params::default()
    };
    let mut out = TrajectoryBatch::new();
    predict(map, &[start], &params, &mut out).unwrap();
    let xs: Vec<f64> = (0..params.k)
        .map(|s| out.sample(0, s).last().expect("at least one step")[0] as f64)
        .collect();
    let k = params.k as f64;
    (
        xs.iter().sum::<f64>() / k,
        xs.iter().filter(|&&x| x > 2.0).count() as f64 / k,
        xs.iter().filter(|&&x| x < -2.0).count() as f64 / k,
    )
}

/// The share of direction draws at the location used at (0, 0) within 45 degrees of east.
fn east_draws(map: &CliffMap) -> f64 {
    use rand::distr::Distribution as _;
    let i = map.best_near(DVec2::ZERO, 1.0).unwrap();
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3);
    let n = 4000;
    let east = (0..n)
        .filter(|_| {
            let t: f64 = map.direction_at(i).sample(&mut rng);
            !(PI / 4.0..=7.0 * PI / 4.0).contains(&t)
        })
        .count();
    east as f64 / n as f64
}

#[test]
fn a_flow_that_reverses_at_noon_is_predicted_both_ways_by_the_right_slices() {
    let (obs, times) = reversing_flow(400);
    // The default smoothing: a prior of 50 observations and 30 % of the all-day map.
    let slicing = SliceParams {
        slice_length: 3600.0,
        clock_offset: JST,
        smoothing: Smoothing::default(),
    };
    let built = build_map_set(&obs, &times, &BuildParams::default(), &slicing).unwrap();
    let set = &built.set;
    let at = |hour: f64| MIDNIGHT_JST + hour * 3600.0;
    assert_eq!(set.slice_index(at(10.5)), Some(10));
    assert_eq!(set.slice_index(at(14.5)), Some(14));
    // All day, half the people go each way.
    let day = set.all_day();
    let d = east_draws(day);
    assert!(
        (0.35..0.65).contains(&d),
        "all day: {d} of the draws go east"
    );
    let (x, e, w) = east_west(day, at(10.5));
    println!("all day: {d:.2} of the draws east; mean x {x:.2}, east {e:.2}, west {w:.2}");
    assert!(
        x.abs() < 1.0 && e > 0.3 && w > 0.3,
        "all day: mean x {x}, east {e}, west {w}"
    );
    // Morning slices go east, afternoon slices west.
    for hour in [8.5, 9.5, 10.5] {
        let m = set.at(at(hour));
        assert!(east_draws(m) > 0.7, "{hour} h: {}", east_draws(m));
        let (x, e, w) = east_west(m, at(hour));
        println!(
            "{hour} h: {:.2} of the draws east; mean x {x:.2}, east {e:.2}, west {w:.2}",
            east_draws(m)
        );
        assert!(
            x > 4.0 && e > 0.7 && w < 0.15,
            "{hour} h: mean x {x}, east {e}, west {w}"
        );
    }
    for hour in [12.5, 13.5, 14.5] {
        let m = set.at(at(hour));
        assert!(east_draws(m) < 0.3, "{hour} h: {}", east_draws(m));
        let (x, e, w) = east_west(m, at(hour));
        println!(
            "{hour} h: {:.2} of the draws east; mean x {x:.2}, east {e:.2}, west {w:.2}",
            east_draws(m)
        );
        assert!(
            x < -4.0 && w > 0.7 && e < 0.15,
            "{hour} h: mean x {x}, east {e}, west {w}"
        );
    }
    // Hours without data use the all-day map.
    assert!(Arc::ptr_eq(set.at(at(3.0)), set.all_day()));
    assert!(set.slices()[3].is_none() && set.slices()[15].is_none());
    // The quiet hour (three people near the west end) keeps every all-day location,
    // and where its people never went, the all-day mixture as it is: it predicts as
    // the all-day map does at the centre.
    let quiet = set.slices()[11].as_ref().expect("the quiet hour has a map");
    assert_eq!(built.slices[11].observations, 15);
    assert!(quiet.locations().len() >= day.locations().len());
    for p in [DVec2::new(9.0, 0.0), DVec2::ZERO] {
        let i = day.nearest(p, 0.5).unwrap();
        let same = quiet
            .locations()
            .iter()
            .find(|l| l.position == day.locations()[i].position)
            .unwrap();
        assert_eq!(same.components, day.locations()[i].components);
    }
    let (x, e, w) = east_west(quiet, at(11.5));
    println!("quiet hour: mean x {x:.2}, east {e:.2}, west {w:.2}");
    assert!(
        x.abs() < 1.0 && e > 0.3 && w > 0.3,
        "quiet hour: mean x {x}, east {e}, west {w}"
    );
    // The figures of the build add up.
    assert_eq!(
        built.slices.iter().map(|s| s.observations).sum::<usize>(),
        obs.len()
    );
    assert_eq!(set.observations()[11], 15);
}

#[test]
fn bad_build_input_is_refused_with_its_place() {
    let (obs, mut times) = reversing_flow(5);
    let slicing = SliceParams {
        clock_offset: JST,
        ..SliceParams::default()
    };
    let p = BuildParams::default();
    let e = build_map_set(&obs, &times[1..], &p, &slicing)
        .unwrap_err()
        .to_string();
    assert!(e.contains("timestamps for"), "{e}");
    times[7] = f64::NAN;
    let e = build_map_set(&obs, &times, &p, &slicing)
        .unwrap_err()
        .to_string();
    assert!(e.contains("observation 7: time NaN is not finite"), "{e}");
    times[7] = 0.0;
    for (slicing, what) in [
        (
            SliceParams {
                slice_length: 7.0 * 60.0,
                ..slicing
            },
            "does not divide the day",
        ),
        (
            SliceParams {
                clock_offset: 1e7,
                ..slicing
            },
            "clock offset",
        ),
        (
            SliceParams {
                smoothing: Smoothing {
                    all_day_share: 1.5,
                    ..Smoothing::default()
                },
                ..slicing
            },
            "all-day share 1.5",
        ),
    ] {
        let e = build_map_set(&obs, &times, &p, &slicing)
            .unwrap_err()
            .to_string();
        assert!(e.contains(what), "{e}");
    }
}

fn atc(dir: &str, hours: &[u32]) -> Vec<PathBuf> {
    let kind = if dir == "train" { "train" } else { "test" };
    hours
        .iter()
        .map(|h| data(&format!("atc/{dir}/atc-1024-{h}_{kind}.csv")))
        .collect()
}

fn eval_config() -> EvalConfig {
    EvalConfig {
        motion_model: None,
        settings: Settings {
            protocol: Protocol::Seconds,
            obs: 3.2,
            dt: 1.0,
            horizon: 20.0,
            ..Settings::default()
        },
        params: Params {
            k: 20,
            radius: 1.0,
            ..Params::default()
        },
        seeds: 2,
        methods: vec![Method::Cliff],
        options: Default::default(),
    }
}

#[test]
fn atc_hours_pick_their_slice_by_timestamp() {
    // A set from the training files of 09:00 and 19:00 (unix time; Japan is UTC+9).
    let train = read_many(&atc("train", &[9, 19]), Format::Atc).unwrap();
    let (obs, times) = timed_observations_from_tracks(&train);
    let slicing = SliceParams {
        clock_offset: JST,
        ..SliceParams::default()
    };
    let built = build_map_set(&obs, &times, &BuildParams::default(), &slicing).unwrap();
    let set = &built.set;
    let own: Vec<usize> = (0..24).filter(|&k| set.slices()[k].is_some()).collect();
    assert_eq!(own, vec![9, 19]);
    // Every row of the dev file of hour h falls in slice h.
    for hour in [9u32, 11, 19] {
        let dev = read_many(&atc("dev", &[hour]), Format::Atc).unwrap();
        for r in dev.iter().flat_map(|t| &t.rows) {
            assert_eq!(
                set.slice_index(r.t),
                Some(hour as usize),
                "{hour}: t {}",
                r.t
            );
        }
    }
    // Without the offset, 09:00 in Japan is midnight: another slice, the all-day map.
    let mut utc = set.clone();
    utc.set_clock_offset(0.0).unwrap();
    let dev9 = read_many(&atc("dev", &[9]), Format::Atc).unwrap();
    assert_eq!(utc.slice_index(dev9[0].rows[0].t), Some(0));
    assert!(Arc::ptr_eq(utc.at(dev9[0].rows[0].t), utc.all_day()));

    // Each hour's slice explains that hour's held-out people better than the map of
    // both hours does (mean log-likelihood of their velocities).
    for hour in [9u32, 19] {
        let dev = read_many(&atc("dev", &[hour]), Format::Atc).unwrap();
        let (o, t) = timed_observations_from_tracks(&dev);
        let p = ScoreParams::default();
        let by_slice = score_set(set, &o, &t, &p).unwrap();
        let by_day = score(set.all_day(), &o, &p).unwrap();
        let by_slice_map = score(set.slice_map(hour as usize).unwrap(), &o, &p).unwrap();
        println!(
            "dev {hour} h: mean log-likelihood {:.4} with the set, {:.4} with the all-day map",
            by_slice.mean_log_likelihood, by_day.mean_log_likelihood
        );
        assert_eq!(by_slice, by_slice_map);
        assert!(
            by_slice.mean_log_likelihood > by_day.mean_log_likelihood + 0.02,
            "{by_slice:?} {by_day:?}"
        );
        assert!(by_slice.unmatched <= by_day.unmatched);
    }

    // Evaluation picks each person's slice: with the set it is the evaluation with
    // the slice's map, and not the one with the all-day map.
    let cfg = eval_config();
    let set_report = evaluate(set, &dev9, &cfg, &|| {}).unwrap();
    let slice_report = evaluate(&**set.slice_map(9).unwrap(), &dev9, &cfg, &|| {}).unwrap();
    let day_report = evaluate(&**set.all_day(), &dev9, &cfg, &|| {}).unwrap();
    assert!(set_report.people_evaluated > 10);
    assert_eq!(set_report, slice_report);
    assert_ne!(set_report.per_person, day_report.per_person);
    // A set without slices evaluates exactly as its map.
    let single = MapSet::single_arc(set.all_day().clone());
    assert_eq!(evaluate(&single, &dev9, &cfg, &|| {}).unwrap(), day_report);

    // The file: a set round trips, and read as one map it is the all-day map.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("atc-set.cliff");
    set.save(&file).unwrap();
    let back = MapSet::load(&file).unwrap();
    assert_eq!(back.clock_offset(), JST);
    assert_eq!(
        back.slice_map(19).unwrap().locations(),
        set.slice_map(19).unwrap().locations()
    );
    assert_eq!(
        CliffMap::load(&file).unwrap().locations(),
        set.all_day().locations()
    );
    let e = set
        .save(dir.path().join("set.csv"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("a CSV file holds one map"), "{e}");
}

// The command line.

fn ok(o: &Output) -> String {
    assert!(
        o.status.success(),
        "stdout: {}\nstderr: {}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn err(o: &Output) -> String {
    assert!(
        !o.status.success(),
        "should have failed: {}",
        String::from_utf8_lossy(&o.stdout)
    );
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

#[test]
fn command_line_builds_shows_exports_and_predicts_with_slices() {
    let dir = tempfile::tempdir().unwrap();
    let set = s(&dir.path().join("set.cliff"));
    let train = atc("train", &[9, 19]);
    let mut args = vec!["map", "build", "--tracks"];
    let train_s: Vec<String> = train.iter().map(|p| s(p)).collect();
    args.extend(train_s.iter().map(String::as_str));
    args.extend([
        "--format",
        "atc",
        "--slice",
        "1h",
        "--clock-offset",
        "+9h",
        "--out",
        &set,
        "--quiet",
    ]);
    let out = ok(&cliff(&args));
    assert!(
        out.contains("09:00-10:00") && out.contains("19:00-20:00"),
        "{out}"
    );
    assert!(
        out.contains("22 slices without data use the all-day map"),
        "{out}"
    );
    // A set needs a snapshot; a slice length must divide the day.
    let mut bad = args.clone();
    let csv = s(&dir.path().join("set.csv"));
    *bad.iter_mut().rev().nth(1).unwrap() = csv.as_str();
    assert!(err(&cliff(&bad)).contains("a time-of-day set is written as a .cliff snapshot"));
    let mut bad = args.clone();
    let i = bad.iter().position(|a| *a == "1h").unwrap();
    bad[i] = "7min";
    assert!(err(&cliff(&bad)).contains("does not divide the day"));

    let info = ok(&cliff(&["map", "info", &set]));
    assert!(
        info.contains("24 slices of 3600 s, clock offset 32400 s"),
        "{info}"
    );
    assert!(info.contains("prior 50 observations"), "{info}");
    assert!(
        info.contains("10:00-11:00") && info.contains("(all-day map)"),
        "{info}"
    );

    // Export one slice to CSV; the whole set to CSV writes its all-day map.
    let h19 = s(&dir.path().join("h19.csv"));
    ok(&cliff(&["map", "convert", &set, &h19, "--slice", "19:30"]));
    let day_csv = s(&dir.path().join("day.csv"));
    let o = cliff(&["map", "convert", &set, &day_csv]);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stderr).contains("--slice HH exports a slice"));
    let loaded = MapSet::load(&set).unwrap();
    assert_eq!(
        CliffMap::load(&h19).unwrap().locations(),
        loaded.slice_map(19).unwrap().locations()
    );
    assert_eq!(
        CliffMap::load(&day_csv).unwrap().locations(),
        loaded.all_day().locations()
    );
    let copy = s(&dir.path().join("copy.cliff"));
    ok(&cliff(&["map", "convert", &set, &copy]));
    assert_eq!(std::fs::read(&copy).unwrap(), std::fs::read(&set).unwrap());
    assert!(
        err(&cliff(&["map", "convert", &set, &h19, "--slice", "25"])).contains("not a time of day")
    );
    assert!(
        err(&cliff(&["map", "convert", &day_csv, &h19, "--slice", "9"]))
            .contains("not a time-of-day set")
    );

    // Evaluation with the set is the evaluation with the slice's map; with the clock
    // offset set to 0 the dev people fall at midnight: the all-day map.
    let dev19 = s(&data("atc/dev/atc-1024-19_test.csv"));
    let eval = |map: &str, extra: &[&str]| {
        let mut a = vec![
            "eval",
            "--map",
            map,
            "--tracks",
            &dev19,
            "--format",
            "atc",
            "--protocol",
            "seconds",
            "--dt",
            "1",
            "--horizon",
            "20",
            "--radius",
            "1",
            "--seeds",
            "2",
            "--methods",
            "cliff",
        ];
        a.extend(extra);
        let o = ok(&cliff(&a));
        // the table, without the timing line
        o.lines().skip(1).collect::<Vec<_>>().join("\n")
    };
    let with_set = eval(&set, &[]);
    assert_eq!(with_set, eval(&h19, &[]));
    let utc = eval(&set, &["--clock-offset", "0"]);
    assert_eq!(utc, eval(&day_csv, &[]));
    assert_ne!(with_set, utc);

    // One person: the slice is named, and the samples are the slice map's.
    let tracks = read_many(&[data("atc/dev/atc-1024-19_test.csv")], Format::Atc).unwrap();
    let settings = eval_config().settings;
    let person = tracks
        .iter()
        .find(|t| cliff::eval::protocol::prepare(t, &settings).is_some_and(|c| c.steps == 20))
        .expect("a person with 20 s to predict")
        .id
        .to_string();
    let predict = |map: &str| {
        let f = s(&dir.path().join("p.csv"));
        let o = ok(&cliff(&[
            "predict",
            "--map",
            map,
            "--tracks",
            &dev19,
            "--format",
            "atc",
            "--person",
            &person,
            "--protocol",
            "seconds",
            "--dt",
            "1",
            "--horizon",
            "20",
            "--radius",
            "1",
            "--out",
            &f,
        ]));
        (o, std::fs::read_to_string(&f).unwrap())
    };
    let (msg, samples) = predict(&set);
    assert!(msg.contains("(slice 19:00-20:00)"), "{msg}");
    assert_eq!(samples, predict(&h19).1);
    assert!(
        err(&cliff(&[
            "eval",
            "--map",
            &set,
            "--tracks",
            &dev19,
            "--format",
            "atc",
            "--clock-offset",
            "2d"
        ]))
        .contains("not a duration")
    );
}
