//! The `cliff` command line on real data: the contracts other tools rely on.

use std::path::PathBuf;
use std::process::Output;

mod common;
use common::{cliff, data};

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cliff-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn eval_contract_writes_summary_and_per_person() {
    let out = tmp("eval");
    let o = cliff(&[
        "eval",
        "--map",
        &data("thor1/cliffmap.csv"),
        "--tracks",
        &data("thor1/exp-1-run-2.csv"),
        "--format",
        "thor",
        "--protocol",
        "reference",
        "--obs",
        "3.2",
        "--dt",
        "0.4",
        "--horizon",
        "12",
        "--radius",
        "0.7071",
        "--beta",
        "1",
        "--k",
        "20",
        "--seeds",
        "3",
        "--methods",
        "cliff,cvm",
        "--out",
        out.to_str().unwrap(),
    ]);
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(stdout.contains("62 of 87 people"), "{stdout}");
    for h in ["2.0s", "4.0s", "12.0s"] {
        assert!(stdout.contains(h), "{stdout}");
    }
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let mut lines = summary.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    for col in [
        "method", "horizon", "people", "ade", "fde", "min_ade", "min_fde", "ade_sd", "fde_sd",
    ] {
        assert!(header.contains(&col), "missing column {col}");
    }
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let cvm4 = rows
        .iter()
        .find(|r| r[0] == "cvm" && r[1] == "4.0")
        .expect("cvm at 4.0 s");
    let ade: f64 = cvm4[header.iter().position(|h| *h == "ade").unwrap()]
        .parse()
        .unwrap();
    assert!((ade - 0.5145).abs() < 0.002, "{ade}");
    // 30 steps of 0.4 s per method
    assert_eq!(rows.iter().filter(|r| r[0] == "cliff").count(), 30);
    let per_person = std::fs::read_to_string(out.join("per_person.csv")).unwrap();
    assert!(
        per_person.starts_with("person_id,method,horizon,ade,fde,min_ade,min_fde,samples_reaching")
    );
    assert!(per_person.lines().count() > 62);
}

#[test]
fn predict_writes_one_persons_samples() {
    let out = tmp("predict").join("p.csv");
    let run = |out: &std::path::Path| {
        cliff(&[
            "predict",
            "--map",
            &data("thor1/cliffmap.csv"),
            "--tracks",
            &data("thor1/exp-1-run-2.csv"),
            "--format",
            "thor",
            "--protocol",
            "reference",
            "--person",
            "12007",
            "--k",
            "5",
            "--seed",
            "7",
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let o = run(&out);
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stdout.contains("person 12007") && stdout.contains("30 steps"),
        "{stdout}"
    );
    let csv = std::fs::read_to_string(&out).unwrap();
    assert!(csv.starts_with("sample,step,t,x,y,score\n"));
    // one score per sample, and the sample named most likely has the highest
    let mut scores = std::collections::BTreeMap::new();
    for l in csv.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        let v: f64 = f[5].parse().unwrap();
        assert_eq!(*scores.entry(f[0].to_string()).or_insert(v), v, "{l}");
    }
    let named = stdout
        .split("the most likely is sample ")
        .nth(1)
        .and_then(|r| r.split(')').next())
        .unwrap_or_else(|| panic!("{stdout}"));
    let top = scores.values().copied().fold(f64::NEG_INFINITY, f64::max);
    assert_eq!(scores[named], top, "{stdout}");
    let samples: std::collections::BTreeSet<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert!(!samples.is_empty() && samples.len() <= 5);
    // same seed, same file
    let out2 = out.with_file_name("p2.csv");
    let o = run(&out2);
    assert!(o.status.success());
    assert_eq!(std::fs::read_to_string(&out2).unwrap(), csv);
}

#[test]
fn map_info_and_convert_round_trip() {
    let dir = tmp("convert");
    let o = cliff(&["map", "info", &data("atc/cliffmap-20121024.csv")]);
    let (stdout, _) = text(&o);
    assert!(o.status.success());
    assert!(
        stdout.contains("locations           1368") && stdout.contains("components          2423"),
        "{stdout}"
    );
    assert!(stdout.contains("grid step           1 m"), "{stdout}");
    assert!(stdout.contains("covariances clamped"), "{stdout}");
    let snap = dir.join("atc.cliff");
    let back = dir.join("atc.csv");
    assert!(
        cliff(&[
            "map",
            "convert",
            &data("atc/cliffmap-20121024.csv"),
            snap.to_str().unwrap()
        ])
        .status
        .success()
    );
    assert!(
        cliff(&[
            "map",
            "convert",
            snap.to_str().unwrap(),
            back.to_str().unwrap()
        ])
        .status
        .success()
    );
    let original = std::fs::read_to_string(data("atc/cliffmap-20121024.csv")).unwrap();
    let again = std::fs::read_to_string(&back).unwrap();
    let parse = |t: &str| -> Vec<Vec<f64>> {
        t.lines()
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect()
    };
    assert_eq!(parse(&original), parse(&again));
}

#[test]
fn bad_input_gets_a_clear_error() {
    let dir = tmp("bad");
    let bad = dir.join("bad.csv");
    std::fs::write(
        &bad,
        "0,0,1,1,0.1,0,0,0.1,1,1,1\n0,1,1,oops,0.1,0,0,0.1,1,1,1\n",
    )
    .unwrap();
    let o = cliff(&["map", "info", bad.to_str().unwrap()]);
    let (_, stderr) = text(&o);
    assert!(!o.status.success());
    assert!(
        stderr.contains("bad.csv:2: column 4") && stderr.contains("'oops' is not a number"),
        "{stderr}"
    );
    let o = cliff(&["eval", "--tracks", "/nonexistent/tracks.csv"]);
    let (_, stderr) = text(&o);
    assert!(
        !o.status.success() && stderr.contains("/nonexistent/tracks.csv"),
        "{stderr}"
    );
    let o = cliff(&[
        "eval",
        "--tracks",
        &data("thor1/exp-1-run-2.csv"),
        "--dt",
        "0",
    ]);
    let (_, stderr) = text(&o);
    assert!(!o.status.success() && stderr.contains("dt"), "{stderr}");
    let o = cliff(&[
        "eval",
        "--tracks",
        &data("thor1/exp-1-run-2.csv"),
        "--methods",
        "magic",
    ]);
    let (_, stderr) = text(&o);
    assert!(
        !o.status.success() && stderr.contains("unknown method 'magic'"),
        "{stderr}"
    );
    let o = cliff(&[
        "predict",
        "--tracks",
        &data("thor1/exp-1-run-2.csv"),
        "--person",
        "999",
    ]);
    let (_, stderr) = text(&o);
    assert!(
        !o.status.success() && stderr.contains("person 999 is not in"),
        "{stderr}"
    );
}

/// THÖR-MAGNI end to end: a map from the recording's first 8 minutes, challenge windows
/// (8 observed, 12 predicted rows at 0.4 s) over the last 8, a window every 4 s.
#[test]
fn magni_map_from_first_half_windows_over_second_half() {
    let out = tmp("magni");
    let rec = data("magni/magni-A-first-16min.csv");
    let map = out.join("first8.cliff");
    let o = cliff(&[
        "map",
        "build",
        "--tracks",
        &rec,
        "--format",
        "magni",
        "--time-until",
        "480",
        "--grid",
        "0.5",
        "--radius",
        "0.5",
        "--out",
        map.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let eval = |extra: &[&str]| {
        let mut args = vec![
            "eval",
            "--map",
            map.to_str().unwrap(),
            "--tracks",
            &rec,
            "--protocol",
            "windows",
            "--obs",
            "3.2",
            "--dt",
            "0.4",
            "--horizon",
            "4.8",
            "--window-every",
            "4",
            "--seeds",
            "2",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = cliff(&args);
        let (stdout, stderr) = text(&o);
        assert!(o.status.success(), "{stderr}");
        let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
        let per_person = std::fs::read_to_string(out.join("per_person.csv")).unwrap();
        (stdout, summary, per_person)
    };
    let (stdout, summary, per_person) = eval(&["--format", "magni", "--time-from", "480"]);
    // the windows of the second half only: people 2 and 7 left before 480 s
    assert!(stdout.contains("windows of 7 people"), "{stdout}");
    assert!(
        per_person.starts_with("person_id,window,method,"),
        "{per_person}"
    );
    for line in per_person.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        assert!(!["2", "7"].contains(&f[0]), "{line}");
        // windows every 4 s from the track's first row at or after 480 s: numbers stay
        // small (8 minutes / 4 s = 120)
        let w: u32 = f[1].parse().unwrap();
        assert!((1..=121).contains(&w), "{line}");
    }
    // 12 predicted rows: the summary reaches 4.8 s, not beyond
    assert!(summary.contains("cliff,4.8,"), "{summary}");
    assert!(!summary.contains(",5.2,"), "{summary}");
    // the same recording through the named-column reader gives the same report
    let (stdout2, summary2, _) = eval(&[
        "--format",
        "csv",
        "--columns",
        "t=Time,id=ag_id,x=x,y=y,speed=speed,vx=x_speed,vy=y_speed",
        "--time-from",
        "480",
    ]);
    assert_eq!(summary2, summary);
    assert_eq!(stdout2.lines().nth(1), stdout.lines().nth(1));
    // a mapping for a headerless format, or a column the file lacks, is refused clearly
    let o = cliff(&[
        "eval",
        "--tracks",
        &rec,
        "--format",
        "thor",
        "--columns",
        "t=Time,id=ag_id,x=x,y=y",
    ]);
    assert!(!o.status.success());
    assert!(
        text(&o).1.contains("needs a file with a header row"),
        "{}",
        text(&o).1
    );
    let o = cliff(&[
        "eval",
        "--tracks",
        &rec,
        "--format",
        "csv",
        "--columns",
        "t=Time,id=agent,x=x,y=y",
    ]);
    assert!(
        text(&o).1.contains("no column named 'agent' in the header"),
        "{}",
        text(&o).1
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// `--full-horizon-only`: the same people at every horizon (ATC dev, 50 s).
#[test]
fn full_horizon_only_keeps_the_same_people_at_every_horizon() {
    let out = tmp("full");
    let dev: Vec<String> = [9, 11, 13, 15, 17, 19]
        .iter()
        .map(|h| data(&format!("atc/dev/atc-1024-{h}_test.csv")))
        .collect();
    // constant velocity (no map needed: the built-in demo map is loaded and not used)
    let mut args = vec!["eval", "--tracks"];
    args.extend(dev.iter().map(String::as_str));
    args.extend([
        "--format",
        "atc",
        "--methods",
        "cvm",
        "--dt",
        "1",
        "--horizon",
        "50",
        "--radius",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    let run = |extra: &[&str]| {
        let mut a = args.clone();
        a.extend_from_slice(extra);
        let o = cliff(&a);
        assert!(o.status.success(), "{}", text(&o).1);
        let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
        summary
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(2).unwrap().parse::<f64>().unwrap())
            .collect::<Vec<f64>>()
    };
    let people = run(&[]);
    // without the flag, fewer people at longer horizons
    assert!(people[0] > 2.0 * people[49], "{people:?}");
    let same = run(&["--full-horizon-only"]);
    assert_eq!(same.len(), 50);
    assert!(same.iter().all(|p| *p == people[49]), "{same:?}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn improved_is_cliff_with_the_preset_in_eval_and_predict() {
    let eval = |name: &str, extra: &[&str]| {
        let out = tmp(name);
        let mut args = vec![
            "eval",
            "--map",
            "",
            "--tracks",
            "",
            "--format",
            "thor",
            "--protocol",
            "reference",
            "--radius",
            "0.7071",
            "--seeds",
            "2",
            "--out",
            out.to_str().unwrap(),
        ];
        let (map, tracks) = (data("thor1/cliffmap.csv"), data("thor1/exp-1-run-2.csv"));
        args[2] = &map;
        args[4] = &tracks;
        args.extend_from_slice(extra);
        let o = cliff(&args);
        assert!(o.status.success(), "{}", text(&o).1);
        std::fs::read_to_string(out.join("summary.csv")).unwrap()
    };
    let improved = eval(
        "improved",
        &["--methods", "cliff,improved", "--beta", "0.5"],
    );
    let preset = [
        "--beta",
        "2",
        "--follow",
        "4",
        "--candidates",
        "2",
        "--prune",
        "--speed-prior",
        "--trust",
        "0.5",
        "--blend",
        "3",
        "--rank",
        "consensus",
        "--motion",
    ];
    let beta2 = eval("beta2", &[&["--methods", "cliff"][..], &preset].concat());
    // the improved rows are those of CLiFF-LHMP with the preset's options, whatever
    // --beta says
    let rows = |csv: &str, method: &str| -> Vec<String> {
        csv.lines()
            .filter_map(|l| l.strip_prefix(&format!("{method},")).map(String::from))
            .collect()
    };
    assert_eq!(rows(&improved, "improved").len(), 30);
    assert_eq!(rows(&improved, "improved"), rows(&beta2, "cliff"));
    assert_ne!(rows(&improved, "cliff"), rows(&beta2, "cliff"));
    let (thor_map, thor_tracks) = (data("thor1/cliffmap.csv"), data("thor1/exp-1-run-2.csv"));
    let predict = |method: &str, extra: &[&str]| {
        let mut args = vec![
            "predict",
            "--map",
            &thor_map,
            "--tracks",
            &thor_tracks,
            "--protocol",
            "reference",
            "--person",
            "12007",
            "--k",
            "5",
            "--method",
            method,
        ];
        args.extend_from_slice(extra);
        let o = cliff(&args);
        assert!(o.status.success(), "{}", text(&o).1);
        text(&o).0
    };
    assert_eq!(
        predict("improved", &["--beta", "1"]),
        predict("cliff", &preset)
    );
    let o = cliff(&[
        "predict", "--tracks", "x.csv", "--person", "1", "--method", "best",
    ]);
    assert!(!o.status.success());
    assert!(
        text(&o)
            .1
            .contains("expected cliff, cvm, improved, motion or cvm-last"),
        "{}",
        text(&o).1
    );
}
