//! `cliff map build | score | update | info` as a user runs them, on real THÖR, ATC and
//! THÖR-MAGNI files.

use std::path::PathBuf;
use std::process::Output;

mod common;
use common::{cliff, data};

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

fn p(dir: &tempfile::TempDir, name: &str) -> String {
    let f: PathBuf = dir.path().join(name);
    f.display().to_string()
}

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

fn json(s: &str) -> serde_json::Value {
    serde_json::from_str(s.trim()).unwrap_or_else(|e| panic!("not one JSON object ({e}): {s}"))
}

#[test]
fn build_then_score_json_on_thor() {
    let dir = tmp();
    let map = p(&dir, "thor1.cliff");
    let thor = data("thor1/exp-1-run-2.csv");
    let out = ok(&cliff(&[
        "map", "build", "--tracks", &thor, "--format", "thor", "--grid", "0.5", "--radius", "0.5",
        "--out", &map, "--quiet",
    ]));
    assert!(out.contains("locations"), "{out}");
    // The snapshot loads, sits on the 0.5 m grid and scores its own data well.
    let info = ok(&cliff(&["map", "info", &map]));
    assert!(info.contains("grid step           0.5 m"), "{info}");
    let s = json(&ok(&cliff(&[
        "map", "score", "--map", &map, "--tracks", &thor, "--format", "thor", "--radius", "0.5",
        "--json",
    ])));
    let n = s["observations"].as_u64().unwrap();
    let unmatched = s["unmatched"].as_u64().unwrap();
    let mean = s["mean_log_likelihood"].as_f64().unwrap();
    assert!(n > 2000, "{s}");
    // Only where a node had fewer than 3 samples.
    assert!(unmatched <= 5, "{s}");
    assert!(mean > -2.0 && mean < 3.0, "{s}");
    assert!(s["median_log_likelihood"].as_f64().is_some() && s["share_below"].as_f64().is_some());
    // The shipped THÖR1 map was built from another round: it explains this one worse
    // than a map built on it.
    let shipped = json(&ok(&cliff(&[
        "map",
        "score",
        "--map",
        &data("thor1/cliffmap.csv"),
        "--tracks",
        &thor,
        "--format",
        "thor",
        "--radius",
        "0.5",
        "--json",
    ])));
    assert!(
        shipped["mean_log_likelihood"].as_f64().unwrap() < mean,
        "{shipped} vs {s}"
    );
}

#[test]
fn build_is_byte_identical_across_runs_and_thread_counts() {
    let dir = tmp();
    let (a, b) = (p(&dir, "a.csv"), p(&dir, "b.csv"));
    let hour = data("atc/train/atc-1024-9_train.csv");
    for (out, threads) in [(&a, "1"), (&b, "2")] {
        ok(&cliff(&[
            "map",
            "build",
            "--tracks",
            &hour,
            "--out",
            out,
            "--threads",
            threads,
            "--quiet",
        ]));
    }
    let (x, y) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    assert!(x.len() > 10_000);
    assert!(x == y, "maps differ between runs");
}

#[test]
fn update_chains_and_improves_on_new_data() {
    let dir = tmp();
    let (m9, m10) = (p(&dir, "h9.csv"), p(&dir, "h10.csv"));
    let h9 = data("atc/train/atc-1024-9_train.csv");
    let h10 = data("atc/train/atc-1024-10_train.csv");
    let out = ok(&cliff(&[
        "map", "build", "--tracks", &h9, "--out", &m9, "--quiet",
    ]));
    let scale = out
        .lines()
        .find(|l| l.starts_with("busiest node"))
        .and_then(|l| l.split_whitespace().nth(2))
        .unwrap()
        .to_string();
    let out = ok(&cliff(&[
        "map",
        "update",
        "--map",
        &m9,
        "--count-scale",
        &scale,
        "--tracks",
        &h10,
        "--out",
        &m10,
    ]));
    assert!(out.contains("pass --count-scale"), "{out}");
    let dev = data("atc/dev/atc-1024-11_test.csv");
    let score = |m: &str| {
        json(&ok(&cliff(&[
            "map", "score", "--map", m, "--tracks", &dev, "--json",
        ])))["mean_log_likelihood"]
            .as_f64()
            .unwrap()
    };
    let (before, after) = (score(&m9), score(&m10));
    assert!(
        after > before,
        "hour 9 map {before}, updated with hour 10 {after}"
    );
}

#[test]
fn bad_input_gets_clear_errors() {
    let dir = tmp();
    let out = p(&dir, "m.csv");
    let hour = data("atc/train/atc-1024-9_train.csv");
    // Bad option values.
    let e = err(&cliff(&[
        "map", "build", "--tracks", &hour, "--grid", "0", "--out", &out,
    ]));
    assert!(e.contains("grid step 0 m must be positive"), "{e}");
    let e = err(&cliff(&[
        "map",
        "build",
        "--tracks",
        &hour,
        "--radius=-1",
        "--out",
        &out,
    ]));
    assert!(e.contains("radius -1 m must be positive"), "{e}");
    let e = err(&cliff(&[
        "map", "build", "--tracks", &hour, "--format", "xyz", "--out", &out,
    ]));
    assert!(e.contains("unknown track format 'xyz'"), "{e}");
    let e = err(&cliff(&[
        "map",
        "build",
        "--tracks",
        &hour,
        "--out",
        &p(&dir, "m.txt"),
        "--quiet",
    ]));
    assert!(e.contains("m.txt: unknown map format"), "{e}");
    // A broken trajectory file: file, line and column.
    let bad = p(&dir, "bad.csv");
    std::fs::write(&bad, "1.0,1,0.0,0.0,1.0,0.0\n2.0,1,0.5,x,1.0,0.0\n").unwrap();
    let e = err(&cliff(&["map", "build", "--tracks", &bad, "--out", &out]));
    assert!(
        e.contains("bad.csv:2: column 4: 'x' is not a number"),
        "{e}"
    );
    // Too little data for any mixture.
    let few = p(&dir, "few.csv");
    std::fs::write(&few, "1.0,1,0.0,0.0,1.0,0.0\n2.0,1,5.0,0.0,1.0,0.0\n").unwrap();
    let e = err(&cliff(&["map", "build", "--tracks", &few, "--out", &out]));
    assert!(e.contains("no location got a mixture"), "{e}");
    // Missing files.
    let e = err(&cliff(&[
        "map",
        "score",
        "--map",
        &p(&dir, "none.csv"),
        "--tracks",
        &hour,
    ]));
    assert!(e.contains("none.csv"), "{e}");
    let e = err(&cliff(&[
        "map",
        "score",
        "--map",
        &data("atc/cliffmap-20121024.csv"),
        "--tracks",
        &hour,
        "--radius",
        "0",
    ]));
    assert!(e.contains("radius 0 m must be positive"), "{e}");
    let e = err(&cliff(&[
        "map",
        "update",
        "--map",
        &data("atc/cliffmap-20121024.csv"),
        "--tracks",
        &hour,
        "--decay",
        "0",
        "--out",
        &out,
    ]));
    assert!(e.contains("decay 0 must be in (0, 1]"), "{e}");
}

/// Crashes found by fuzzing the loaders: a map CSV with one x of 1e20 made `cliff map info` panic
/// (an overflowing grid cell count), and a snapshot with a grid step of 1e300 m loaded.
#[test]
fn absurd_maps_get_errors_with_file_line_and_column_not_panics() {
    let dir = tmp();
    let thor = std::fs::read_to_string(data("thor1/cliffmap.csv")).unwrap();
    let rows = thor.lines().count();
    let far = p(&dir, "far.csv");
    std::fs::write(&far, format!("{thor}1e20,0,1,1,0.1,0,0,0.1,1,1,1\n")).unwrap();
    for cmd in [
        vec!["map", "info", &far],
        vec!["map", "convert", &far, &p(&dir, "far.cliff")],
    ] {
        let e = err(&cliff(&cmd));
        assert!(
            e.contains(&format!(
                "far.csv:{}: column 1: coordinate 1e20 is beyond",
                rows + 1
            )),
            "{e}"
        );
        assert!(!e.contains("panicked") && !e.contains("backtrace"), "{e}");
    }
    // A bounding box of too many cells names the stray location's line.
    let wide = p(&dir, "wide.csv");
    std::fs::write(&wide, format!("{thor}9e5,9e5,1,1,0.1,0,0,0.1,1,1,1\n")).unwrap();
    let e = err(&cliff(&["map", "info", &wide]));
    assert!(
        e.contains(&format!("wide.csv:{}: column 1", rows + 1)) && e.contains("cells"),
        "{e}"
    );

    // A one-location snapshot, then the same with its grid step set to 1e300 m.
    let one = p(&dir, "one.csv");
    std::fs::write(&one, "2,3,1,1,0.1,0,0,0.1,1,1,1\n").unwrap();
    let snap = p(&dir, "one.cliff");
    ok(&cliff(&["map", "convert", &one, &snap]));
    assert!(ok(&cliff(&["map", "info", &snap])).contains("grid step           1 m"));
    let mut bytes = std::fs::read(&snap).unwrap();
    // header: magic (8), version (4), payload length (8), CRC-32 (4); the payload
    // starts with the grid step (f64, little-endian)
    bytes[24..32].copy_from_slice(&1e300f64.to_le_bytes());
    let crc = crc32fast::hash(&bytes[24..]);
    bytes[20..24].copy_from_slice(&crc.to_le_bytes());
    let huge = p(&dir, "huge-step.cliff");
    std::fs::write(&huge, &bytes).unwrap();
    let e = err(&cliff(&["map", "info", &huge]));
    assert!(
        e.contains("huge-step.cliff: not a valid cliff snapshot")
            && e.contains("grid step 1e300 m is not in [0.001, 1000] m"),
        "{e}"
    );
}

#[test]
fn a_map_of_few_long_tracks_keeps_a_speed_prior_from_windows_and_info_shows_it() {
    // the first 8 minutes of THÖR-MAGNI: 9 helmets, too few people, enough windows
    let dir = tmp();
    let map = p(&dir, "magni-first8.cliff");
    let magni = data("magni/magni-A-first-16min.csv");
    // the README's MAGNI map: the first 8 minutes, 0.5 m grid
    let build = |out: &str, extra: &[&str]| {
        let mut args = vec![
            "map",
            "build",
            "--tracks",
            &magni,
            "--format",
            "magni",
            "--time-until",
            "480",
            "--grid",
            "0.5",
            "--radius",
            "0.5",
            "--out",
            out,
            "--quiet",
        ];
        args.extend_from_slice(extra);
        ok(&cliff(&args))
    };
    let built = build(&map, &[]);
    let mut tracks =
        cliff::tracks::read_tracks(magni.as_ref(), cliff::tracks::Format::Magni).unwrap();
    cliff::tracks::keep_time_range(&mut tracks, f64::NEG_INFINITY, 480.0);
    let prior = cliff::motion::SpeedPrior::fit_tracks(&tracks).expect("a prior from windows");
    let line = format!(
        "speed prior         v = {:.3} + {:.3} (v0 - {:.3}) m/s, from {} pairs",
        prior.mean, prior.keep, prior.mean, prior.pairs
    );
    assert!(built.contains(&line), "{built}\nexpected: {line}");
    let info = ok(&cliff(&["map", "info", &map]));
    assert!(info.contains(&line), "{info}\nexpected: {line}");
    // without it, info says so
    let none = p(&dir, "none.cliff");
    build(&none, &["--no-speed-prior"]);
    let info = ok(&cliff(&["map", "info", &none]));
    assert!(info.contains("speed prior         none"), "{info}");
}

#[test]
fn map_diff_counts_what_an_update_of_real_data_changed() {
    use cliff::map::CliffMap;
    let dir = tmp();
    let base = data("thor1/cliffmap.csv");
    let new = p(&dir, "updated.cliff");
    // THÖR1's round-1 map updated with round 2's people, weighed as 100 samples
    ok(&cliff(&[
        "map",
        "update",
        "--map",
        &base,
        "--count-scale",
        "100",
        "--decay",
        "1",
        "--tracks",
        &data("thor1/exp-1-run-2.csv"),
        "--format",
        "thor",
        "--out",
        &new,
    ]));
    let j = json(&ok(&cliff(&["map", "diff", &base, &new, "--json"])));
    // the counts again, by comparing every location with every other
    let (old, upd) = (
        CliffMap::load(&base).unwrap(),
        CliffMap::load(&new).unwrap(),
    );
    let tol = 1e-3 * old.grid().step();
    let found = |l: &cliff::map::Location, m: &CliffMap| {
        m.locations()
            .iter()
            .any(|o| o.position.distance(l.position) < tol)
    };
    let added = upd.locations().iter().filter(|l| !found(l, &old)).count();
    let removed = old.locations().iter().filter(|l| !found(l, &upd)).count();
    let common = upd.locations().len() - added;
    let len = |k: &str| j[k].as_array().unwrap().len();
    assert_eq!(
        (len("added"), len("removed"), len("common")),
        (added, removed, common)
    );
    assert!(added > 0, "round 2 reaches places round 1 did not");
    // a location whose mixture is unchanged (weights renormalised) did not move; one that
    // moved more than 0.01 changed
    let normalised = |l: &cliff::map::Location| {
        let t: f64 = l.components.iter().map(|c| c.weight).sum();
        l.components
            .iter()
            .map(|c| [c.theta, c.rho, c.cov[0], c.cov[1], c.cov[3], c.weight / t])
            .collect::<Vec<_>>()
    };
    let (mut unchanged, mut moved) = (0, 0);
    for c in j["common"].as_array().unwrap() {
        let (i, k) = (
            c["old"].as_u64().unwrap() as usize,
            c["new"].as_u64().unwrap() as usize,
        );
        let (a, b) = (&old.locations()[i], &upd.locations()[k]);
        let m = c["moved"].as_f64().unwrap();
        assert_eq!(
            c["components"][0].as_u64().unwrap() as usize,
            a.components.len()
        );
        assert_eq!(
            c["components"][1].as_u64().unwrap() as usize,
            b.components.len()
        );
        let same = a.components.len() == b.components.len()
            && normalised(a)
                .iter()
                .zip(normalised(b))
                .all(|(x, y)| x.iter().zip(y).all(|(u, v)| (u - v).abs() < 1e-9));
        if same {
            unchanged += 1;
            assert!(m < 1e-6, "unchanged location moved {m}");
        }
        if m > 0.01 {
            moved += 1;
            assert!(!same);
        }
    }
    assert!(
        unchanged > 0 && moved > 20,
        "{unchanged} unchanged, {moved} moved"
    );
    // the text says the same
    let text = ok(&cliff(&["map", "diff", &base, &new, "--top", "3"]));
    assert!(
        text.contains(&format!(
            "locations           {added} added, {removed} removed, {common} in both"
        )),
        "{text}"
    );
    assert!(
        text.contains(&format!(
            "moved               {moved} of {common} by more than 0.01"
        )),
        "{text}"
    );
    // and the picture
    let png = p(&dir, "diff.png");
    ok(&cliff(&[
        "map", "diff", &base, &new, "--png", &png, "--width", "600",
    ]));
    let img = image::open(&png).expect("a PNG").to_rgb8();
    assert_eq!(img.width(), 600);
    // some squares of moved locations are red
    let red = img
        .pixels()
        .filter(|p| p[0] > 200 && p[1] < 120 && p[2] < 120)
        .count();
    assert!(red > 100, "{red} red pixels");
    assert!(err(&cliff(&["map", "diff", &base, "nowhere.csv"])).contains("nowhere.csv"));
}
