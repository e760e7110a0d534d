//! `improved` near the present: on held-out people of THÖR1, THÖR3 and the THÖR-MAGNI
//! recording, with the right map and with a wrong one (every direction turned 90
//! degrees), its mean ADE and FDE are never more than 1 % above the motion model's alone
//! ([`Method::Motion`], the built-in model) at any step up to 4.8 s ahead,  and, with the
//! right map, its best-ranked sample's never more than 3 % above the model's expected
//! path, paired over the same people (windows), every person counted at every
//! step (a sample that stopped counts where it stopped), for each of several seeds on its
//! own (not only on average).

use std::path::{Path, PathBuf};

use cliff::eval::metrics::{Counting, Scratch, StepErrors, person_errors};
use cliff::eval::person_seed;
use cliff::eval::protocol::{Case, Protocol, Settings, prepare_all};
use cliff::map::CliffMap;
use cliff::predict::{Method, Options, Params, TrajectoryBatch, predict_with_histories};
use cliff::tracks::{Format, keep_time_range, read_tracks};

mod common;
use common::{cliff, data};

const DT: f64 = 0.4;
/// The short horizon the claim is about (12 steps: THÖR-MAGNI's challenge setting).
const NEAR: usize = 12;
const SEEDS: [u64; 3] = [0, 3, 7];
/// How far above the motion model's `improved`'s mean errors may be.
const LIMIT: f64 = 1.01;
/// How far above the motion model's expected path `improved`'s best-ranked sample may be
/// (one sample of one seed: a wrong map's share near the present moves it by up to 2 %).
const TOP1_LIMIT: f64 = 1.03;

/// Per step: mean ADE, FDE, top-1 ADE and top-1 FDE, summed over the cases.
#[derive(Debug, Default, Clone, Copy)]
struct Pair {
    n: usize,
    improved: [f64; 4],
    motion: [f64; 4],
}

/// Every case's errors per step for `method`, into `out` (one entry per step).
#[allow(clippy::too_many_arguments)]
fn errors_of(
    map: &CliffMap,
    case: &Case,
    method: Method,
    seed: u64,
    radius: f64,
    batch: &mut TrajectoryBatch,
    scratch: &mut Scratch,
    out: &mut Vec<Option<StepErrors>>,
) {
    let params = Params {
        method,
        k: 20,
        dt: DT,
        horizon: case.steps as f64 * DT,
        radius,
        seed: person_seed(seed, case.seed_key()),
        ..Params::default()
    };
    let options = Options {
        scores: true,
        ..Options::default()
    };
    predict_with_histories(
        map,
        std::slice::from_ref(&case.start),
        std::slice::from_ref(&case.history()),
        &params,
        &options,
        batch,
    )
    .unwrap();
    person_errors(
        case,
        DT,
        Counting::Everyone,
        (0..params.k).map(|s| batch.sample(0, s)),
        batch.scores(),
        scratch,
        out,
    );
}

fn paired(map: &CliffMap, cases: &[Case], seed: u64, radius: f64) -> Vec<Pair> {
    let mut pairs = vec![Pair::default(); NEAR];
    let mut batch = TrajectoryBatch::new();
    let mut scratch = Scratch::default();
    let (mut ours, mut alone): (Vec<Option<StepErrors>>, Vec<Option<StepErrors>>) =
        (Vec::new(), Vec::new());
    for case in cases {
        let case = Case {
            steps: case.steps.min(NEAR),
            ..case.clone()
        };
        let (b, s) = (&mut batch, &mut scratch);
        errors_of(map, &case, Method::Improved, seed, radius, b, s, &mut ours);
        errors_of(map, &case, Method::Motion, seed, radius, b, s, &mut alone);
        for (j, (a, b)) in ours.iter().zip(&alone).enumerate() {
            if let (Some(a), Some(b)) = (a, b) {
                let p = &mut pairs[j];
                p.n += 1;
                for (sum, e) in [(&mut p.improved, a), (&mut p.motion, b)] {
                    sum[0] += e.ade;
                    sum[1] += e.fde;
                    sum[2] += e.top1_ade;
                    sum[3] += e.top1_fde;
                }
            }
        }
    }
    pairs
}

/// Every step, every seed: improved's errors at most `LIMIT` (`TOP1_LIMIT`) times the
/// motion model's (`wrong`: the map is wrong, its best-ranked sample is not bounded).
fn check(name: &str, map: &CliffMap, cases: &[Case], radius: f64, wrong: bool) {
    assert!(cases.len() > 40, "{name}: {} cases", cases.len());
    for seed in SEEDS {
        for (j, p) in paired(map, cases, seed, radius).iter().enumerate() {
            assert!(p.n > 20, "{name}: {} people at step {}", p.n, j + 1);
            for (m, what) in ["ADE", "FDE", "top-1 ADE", "top-1 FDE"].iter().enumerate() {
                let ratio = p.improved[m] / p.motion[m];
                let limit = match (m < 2, wrong) {
                    (true, _) => LIMIT,
                    (false, false) => TOP1_LIMIT,
                    // a wrong map's best-ranked sample: reported, not bounded here
                    (false, true) => f64::INFINITY,
                };
                eprintln!(
                    "{name} seed {seed} {:.1} s {what}: {ratio:.4}",
                    (j + 1) as f64 * DT
                );
                assert!(
                    ratio <= limit,
                    "{name}, seed {seed}, {:.1} s ahead: improved's {what} is {ratio:.4} of the motion model's ({} people)",
                    (j + 1) as f64 * DT,
                    p.n
                );
            }
        }
    }
}

/// The map with every direction turned a quarter turn: a map that is wrong everywhere.
fn turned(map: &CliffMap) -> CliffMap {
    let mut locations = map.locations().to_vec();
    for c in locations.iter_mut().flat_map(|l| l.components.iter_mut()) {
        c.theta = (c.theta + std::f64::consts::FRAC_PI_2).rem_euclid(std::f64::consts::TAU);
    }
    let mut out = CliffMap::new(locations).unwrap();
    out.set_speed_prior(map.speed_prior()).unwrap();
    out
}

fn thor_cases(file: &str) -> Vec<Case> {
    let tracks = read_tracks(Path::new(&data(file)), Format::Thor).unwrap();
    let settings = Settings {
        protocol: Protocol::Reference,
        obs: 3.2,
        dt: DT,
        horizon: 12.0,
        ..Settings::default()
    };
    prepare_all(&tracks, &settings)
}

#[test]
fn improved_is_within_a_percent_of_the_motion_model_near_the_present_on_thor() {
    // the shipped maps are built from round 1; the people are round 2's
    for (round, map) in [
        ("thor1/exp-1-run-2.csv", "thor1/cliffmap.csv"),
        ("thor3/exp-3-run-2.csv", "thor3/cliffmap.csv"),
    ] {
        let map = CliffMap::load(data(map)).unwrap();
        let cases = thor_cases(round);
        let radius = std::f64::consts::FRAC_1_SQRT_2;
        check(round, &map, &cases, radius, false);
        check(
            &format!("{round}, turned"),
            &turned(&map),
            &cases,
            radius,
            true,
        );
    }
}

#[test]
fn improved_is_within_a_percent_of_the_motion_model_near_the_present_on_magni_windows() {
    // the map (and its speed prior) from the recording's first 8 minutes, the windows
    // from the last 8
    let dir: PathBuf = std::env::temp_dir().join(format!("cliff-near-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let map_file = dir.join("magni-first8.cliff");
    let recording = data("magni/magni-A-first-16min.csv");
    let o = cliff(&[
        "map",
        "build",
        "--tracks",
        &recording,
        "--format",
        "magni",
        "--time-until",
        "480",
        "--grid",
        "0.5",
        "--radius",
        "0.5",
        "--out",
        map_file.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let map = CliffMap::load(&map_file).unwrap();
    assert!(map.speed_prior().is_some());
    let mut tracks = read_tracks(Path::new(&recording), Format::Magni).unwrap();
    keep_time_range(&mut tracks, 480.0, f64::INFINITY);
    let settings = Settings {
        protocol: Protocol::Windows,
        obs: 3.2,
        dt: DT,
        horizon: NEAR as f64 * DT,
        window_every: 4.0,
        ..Settings::default()
    };
    let cases = prepare_all(&tracks, &settings);
    let radius = std::f64::consts::FRAC_1_SQRT_2;
    check("THÖR-MAGNI windows", &map, &cases, radius, false);
    check(
        "THÖR-MAGNI windows, turned",
        &turned(&map),
        &cases,
        radius,
        true,
    );
    let _ = std::fs::remove_dir_all(&dir);
}
