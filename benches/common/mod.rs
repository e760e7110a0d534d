//! What the predictor benchmarks share: the benchmark people, their maps and settings.
//!
//! * THÖR1: the first person of exp-1-run-2 that passes the reference filter, 20
//!   samples, 12 s at 0.4 s (30 steps), radius 0.7071, on thor1/cliffmap.csv.
//! * ATC: the first atc/dev person (hour 13, seconds protocol) with 50 s of ground
//!   truth, 20 samples, 50 s at 1 s, radius 1, on atc/cliffmap-20121024.csv.
//! * The ATC time-of-day set: a map set of one-hour slices built from atc/train with the
//!   library's defaults (as `cliff map build --slice 1h --clock-offset 9h`), kept in the
//!   build directory after the first run (it takes seconds to build).

#![allow(dead_code)] // each bench uses its share

use std::path::{Path, PathBuf};

use cliff::eval::protocol::{Case, Protocol, Settings, prepare};
use cliff::map::build::{BuildParams, timed_observations_from_tracks};
use cliff::map::{CliffMap, MapSet, SliceParams, Smoothing, build_map_set};
use cliff::predict::Params;
use cliff::tracks::{Format, read_many, read_tracks};

/// A path under the shared data folder.
pub fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(p)
}

/// The first person of `tracks` that passes the filter with at least `min_steps` steps.
pub fn first_case(tracks: &str, format: Format, settings: &Settings, min_steps: usize) -> Case {
    read_tracks(&data(tracks), format)
        .expect("tracks")
        .iter()
        .filter_map(|t| prepare(t, settings))
        .find(|c| c.steps >= min_steps)
        .expect("a person that passes the filter")
}

/// A benchmark person: the map, the person and the prediction parameters.
pub struct Person {
    pub map: CliffMap,
    pub case: Case,
    pub params: Params,
}

/// The THÖR1 person (k 20, 30 steps).
pub fn thor1_person() -> Person {
    Person {
        map: CliffMap::load(data("thor1/cliffmap.csv")).expect("THÖR1 map"),
        case: first_case(
            "thor1/exp-1-run-2.csv",
            Format::Thor,
            &Settings::default(),
            1,
        ),
        params: Params {
            k: 20,
            dt: 0.4,
            horizon: 12.0,
            radius: 0.7071,
            beta: 1.0,
            ..Params::default()
        },
    }
}

/// The ATC person (k 20, 50 steps).
pub fn atc_person() -> Person {
    let settings = Settings {
        protocol: Protocol::Seconds,
        obs: 3.2,
        dt: 1.0,
        horizon: 50.0,
        ..Settings::default()
    };
    Person {
        map: CliffMap::load(data("atc/cliffmap-20121024.csv")).expect("ATC map"),
        case: first_case("atc/dev/atc-1024-13_test.csv", Format::Atc, &settings, 50),
        params: Params {
            k: 20,
            dt: 1.0,
            horizon: 50.0,
            radius: 1.0,
            beta: 1.0,
            ..Params::default()
        },
    }
}

/// The ATC time-of-day set (one-hour slices, clock offset 9 h), loaded from the build
/// directory or built there from atc/train.
pub fn atc_set() -> MapSet {
    let cached = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bench-atc-train-1h.cliff");
    if let Ok(set) = MapSet::load(&cached) {
        return set;
    }
    let files: Vec<PathBuf> = (9..=20)
        .map(|h| data(&format!("atc/train/atc-1024-{h}_train.csv")))
        .filter(|p| p.exists())
        .collect();
    let tracks = read_many(&files, Format::Atc).expect("atc/train");
    let (obs, times) = timed_observations_from_tracks(&tracks);
    let slicing = SliceParams {
        slice_length: 3600.0,
        clock_offset: 9.0 * 3600.0,
        smoothing: Smoothing::default(),
    };
    let set = build_map_set(&obs, &times, &BuildParams::default(), &slicing)
        .expect("the ATC set")
        .set;
    set.save(&cached).expect("cache the ATC set");
    set
}
