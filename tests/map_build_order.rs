//! The same rows give the same map: building (as `cliff map build` does by default,
//! speed prior included) and updating an online map give the same snapshot bytes for
//! THÖR1's rows in the file's order, with the tracks shuffled and renumbered, and
//! grouped by time as a recording holds them. THÖR1's run holds too few people for a
//! speed prior; the prior's fit is checked on an hour of ATC.

use std::path::{Path, PathBuf};

use cliff::map::CliffMap;
use cliff::map::build::{BuildParams, Observation, build_map, observations_from_tracks};
use cliff::map::update::{OnlineMap, UpdateParams};
use cliff::math::wrap_2pi;
use cliff::motion::SpeedPrior;
use cliff::tracks::{Format, Row, Track, read_many};
use rand::SeedableRng;
use rand::seq::SliceRandom;

fn data(rel: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data")).join(rel)
}

fn thor1() -> Vec<Track> {
    read_many(&[data("thor1/exp-1-run-2.csv")], Format::Thor).unwrap()
}

/// The tracks in another order (a fixed seed), each with another id.
fn shuffled(tracks: &[Track]) -> Vec<Track> {
    let mut out = tracks.to_vec();
    out.shuffle(&mut rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(7));
    for (i, t) in out.iter_mut().enumerate() {
        t.id = 900_000 + 13 * i as u64;
    }
    out
}

/// The tracks as a recording's reader gives them: in the order people first appear.
fn by_first_appearance(tracks: &[Track]) -> Vec<Track> {
    let mut out = tracks.to_vec();
    out.sort_by(|a, b| a.rows[0].t.total_cmp(&b.rows[0].t));
    out
}

/// Every row of the tracks, interleaved by time stamp as a recording holds them (one
/// message per time stamp with everyone seen then; the file's order among equal times).
fn rows_by_time(tracks: &[Track]) -> Vec<Row> {
    let mut rows: Vec<Row> = tracks.iter().flat_map(|t| t.rows.iter().copied()).collect();
    rows.sort_by(|a, b| a.t.total_cmp(&b.t));
    rows
}

fn observations_of(rows: &[Row]) -> Vec<Observation> {
    rows.iter()
        .map(|r| Observation {
            position: r.position,
            theta: wrap_2pi(r.angle),
            rho: r.speed,
        })
        .collect()
}

/// The snapshot bytes of a map.
fn snapshot(map: &CliffMap, name: &str) -> Vec<u8> {
    let dir = std::env::temp_dir().join(format!("cliff-map-build-order-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{name}.cliff"));
    cliff::map::write_snapshot(map, &path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    bytes
}

/// The map `cliff map build` writes with its defaults: the map of the observations and
/// the speed prior of the tracks.
fn built(obs: &[Observation], tracks: &[Track], name: &str) -> Vec<u8> {
    let mut map = build_map(obs, &BuildParams::default()).unwrap().map;
    map.set_speed_prior(SpeedPrior::fit_tracks(tracks)).unwrap();
    snapshot(&map, name)
}

#[test]
fn a_built_map_does_not_depend_on_the_order_of_tracks_and_rows() {
    let tracks = thor1();
    assert!(tracks.len() > 5, "{} tracks", tracks.len());
    let in_file = built(&observations_from_tracks(&tracks), &tracks, "file");
    let shuffled_tracks = shuffled(&tracks);
    let shuffled = built(
        &observations_from_tracks(&shuffled_tracks),
        &shuffled_tracks,
        "shuffled",
    );
    let recorded = built(
        &observations_of(&rows_by_time(&tracks)),
        &by_first_appearance(&tracks),
        "by-time",
    );
    assert!(in_file.len() > 1000, "{} bytes", in_file.len());
    assert!(
        in_file == shuffled,
        "tracks shuffled and renumbered: another map"
    );
    assert!(in_file == recorded, "rows grouped by time: another map");
}

#[test]
fn an_updated_map_does_not_depend_on_the_order_of_the_batch() {
    // the map of the first half of the tracks, updated with the rows of the other half
    let tracks = thor1();
    let (first, second) = tracks.split_at(tracks.len() / 2);
    let params = BuildParams::default();
    let update = |batch: &[Observation], name: &str| {
        let mut online = OnlineMap::build(
            &observations_from_tracks(first),
            &params,
            UpdateParams::default(),
        )
        .unwrap();
        online.update(batch).unwrap();
        snapshot(&online.to_map().unwrap(), name)
    };
    let in_file = update(&observations_from_tracks(second), "update-file");
    let shuffled = update(
        &observations_from_tracks(&shuffled(second)),
        "update-shuffled",
    );
    let recorded = update(&observations_of(&rows_by_time(second)), "update-by-time");
    assert!(in_file == shuffled, "batch's tracks shuffled: another map");
    assert!(
        in_file == recorded,
        "batch's rows grouped by time: another map"
    );
}

#[test]
fn the_speed_prior_does_not_depend_on_the_order_of_tracks() {
    let file = data("atc/train/atc-1024-13_train.csv");
    let tracks = read_many(&[file], Format::Atc).unwrap();
    let bits = |p: SpeedPrior| (p.mean.to_bits(), p.keep.to_bits(), p.pairs);
    let in_file = bits(SpeedPrior::fit_tracks(&tracks).expect("a prior from ATC's hour 13"));
    let shuffled = bits(SpeedPrior::fit_tracks(&shuffled(&tracks)).unwrap());
    let recorded = bits(SpeedPrior::fit_tracks(&by_first_appearance(&tracks)).unwrap());
    assert_eq!(in_file, shuffled, "tracks shuffled and renumbered");
    assert_eq!(in_file, recorded, "tracks in the order people first appear");
}
