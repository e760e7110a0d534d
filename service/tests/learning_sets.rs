//! A time-of-day set that learns while it serves (`cliffd --learn` on a set of
//! `cliff map build --slice`), on real people (ATC): each row learned into the slice of
//! its time, everything else unchanged, versions asked for by name, a restart resumed.

mod common;

use std::time::Duration;

use cliff::map::CliffMap;
use cliff::map::build::observations_from_tracks;
use cliff::map::score::{ScoreParams, score};
use cliff::predict::Params;
use cliff::tracks::{Format, read_tracks};
use cliff_client::{Client, Error, Observation, Request, Status, WaitMode};
use common::*;

/// The snapshot bytes of one map: what "unchanged" means for a map of a set.
fn map_bytes(map: &std::sync::Arc<CliffMap>) -> Vec<u8> {
    cliff::map::MapSet::single_arc(std::sync::Arc::clone(map)).to_snapshot_bytes()
}

#[test]
fn a_time_of_day_set_learns_the_slice_of_each_rows_time_and_nothing_else() {
    use cliff::map::{MapSet, SetParts};
    use std::sync::Arc;

    // a set on the ATC mall's clock (unix time, UTC+9): the published all-day map, and
    // the published implementation's map of 13:00 as the one slice of its own
    let all_day = Arc::new(CliffMap::load(shared_data("atc/cliffmap-20121024.csv")).unwrap());
    let hour13 =
        Arc::new(CliffMap::load(shared_data("atc/reference-maps/matlab-hour13.csv")).unwrap());
    let mut slices = vec![None; 24];
    slices[13] = Some(Arc::clone(&hour13));
    let base = MapSet::from_parts(SetParts {
        all_day: Arc::clone(&all_day),
        slices,
        slice_length: 3600.0,
        clock_offset: 9.0 * 3600.0,
        smoothing: None,
        observations: Vec::new(),
    })
    .unwrap();
    let files = tempfile::tempdir().unwrap();
    let set_path = files.path().join("atc-set.cliff");
    base.save(&set_path).unwrap();
    let learn_dir = files.path().join("learned");
    let dir_arg = learn_dir.display().to_string();
    let map_arg = format!("atc={}", set_path.display());
    let args = [
        "--map",
        &map_arg,
        "--learn",
        "atc",
        "--learn-dir",
        &dir_arg,
        "--observe-rate",
        "1000000",
        "--observe-tracks",
        "4096",
        "--observe-rows-held",
        "65536",
        "--learn-every-rows",
        "100000",
        "--learn-every-s",
        "1",
        "--learn-move-per-min",
        "inf",
        "--learn-client-share",
        "1",
    ];
    let ns = Namespace::new("learn_set");
    let mut daemon = Daemon::start(&ns, &args);
    assert!(
        daemon.ready_line.contains("learning, version 0"),
        "{}",
        daemon.ready_line
    );

    // the people of the 11:00 training hour, every row in slice 11 of the set
    let train = shared_data("atc/train/atc-1024-11_train.csv");
    let tracks = read_tracks(&train, Format::Atc).unwrap();
    assert!(
        tracks
            .iter()
            .flat_map(|t| &t.rows)
            .all(|r| base.slice_index(r.t) == Some(11))
    );
    let out = std::process::Command::new(workspace_exe("cliff"))
        .args(["observe", "--map", "atc", "--tracks"])
        .arg(&train)
        .args([
            "--format",
            "atc",
            "--service",
            SERVICE,
            "--prefix",
            &ns.prefix,
            "--quiet",
        ])
        .output()
        .expect("run cliff observe");
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );

    // a person at 11:30 and the same person at 15:30 (a slice without a map of its own)
    let t11 = tracks[0].rows[0].t + 1800.0;
    let person = |t: f64| {
        let mut r = Request::new(
            "atc",
            &Params {
                k: 10,
                ..Params::default()
            },
        )
        .unwrap()
        .time(t);
        r.add_agent([Observation::with_velocity(t, 10.0, 2.0, 1.2, 3.0)]);
        r
    };
    let (at11, at15) = (person(t11), person(t11 + 4.0 * 3600.0));
    let mut c = ns.connect(WaitMode::Hybrid);
    let version = first_learned_version(&mut c, &at11, Duration::from_secs(30));
    // the last version once learning is done (ended tracks go at once, the rest within
    // the track timeout)
    std::thread::sleep(Duration::from_secs(7));
    let live = |c: &mut Client, r: &Request| {
        let p = c.predict(r).unwrap();
        (p.map_version(), bits(p.positions(), p.lens()))
    };
    let (version, learned11) = {
        let (v, b) = live(&mut c, &at11);
        assert!(v >= version);
        (v, b)
    };
    // the versions before it: the four kept answer as they were, older ones are refused
    for v in 1..version {
        let mut r = at11.clone();
        r.set_map(&format!("atc@{v}")).unwrap();
        match c.predict(&r) {
            Ok(p) => assert!(
                v + 4 >= version && p.map_version() == v,
                "version {v} of {version}"
            ),
            Err(Error::Rejected(rej)) => assert!(
                v + 4 < version && rej.status == Status::UnknownVersion && rej.limit == version,
                "version {v} of {version}: {rej}"
            ),
            Err(e) => panic!("version {v}: {e}"),
        }
    }
    // 15:30 is answered by the all-day map, unchanged; the base map pinned at 11:30 too
    let (v15, b15) = live(&mut c, &at15);
    assert_eq!((v15, b15), (version, local_bits(&all_day, &at15).1));
    let p = c.predict(&at11.clone().base_map(true)).unwrap();
    assert_eq!(
        (p.map_version(), bits(p.positions(), p.lens())),
        (0, local_bits(&all_day, &at11).1)
    );

    daemon.signal(SIGTERM);
    assert!(
        daemon
            .wait_exit(Duration::from_secs(30))
            .is_some_and(|s| s.success())
    );
    // the snapshot is the set: slice 11 learned, the all-day map and slice 13 the bytes
    // they were, every other slice still without a map of its own
    let mut snaps: Vec<_> = std::fs::read_dir(&learn_dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "cliff"))
        .collect();
    snaps.sort();
    let newest = snaps.pop().expect("a snapshot");
    assert!(
        newest
            .display()
            .to_string()
            .ends_with(&format!("atc.v{version:08}.cliff")),
        "{}",
        newest.display()
    );
    let learned = MapSet::load(&newest).unwrap();
    assert_eq!(learned.slices().len(), 24);
    assert_eq!(learned.clock_offset(), 9.0 * 3600.0);
    assert_eq!(map_bytes(learned.all_day()), map_bytes(&all_day));
    assert_eq!(
        map_bytes(learned.slices()[13].as_ref().unwrap()),
        map_bytes(&hour13)
    );
    for (i, s) in learned.slices().iter().enumerate() {
        assert_eq!(s.is_some(), i == 11 || i == 13, "slice {i}");
    }
    let slice11 = learned.slices()[11].as_ref().unwrap();
    assert_ne!(map_bytes(slice11), map_bytes(&all_day));
    // the version that answered 11:30 is the one written
    assert_eq!(local_bits(slice11, &at11).1, learned11);

    // held-out people of 11:00 (atc/dev) are explained better by the learned slice than
    // by the all-day map that answered for 11:00 before
    let dev = read_tracks(&shared_data("atc/dev/atc-1024-11_test.csv"), Format::Atc).unwrap();
    let obs = observations_from_tracks(&dev);
    let p = ScoreParams::default();
    let (before, after) = (
        score(&all_day, &obs, &p).unwrap().mean_log_likelihood,
        score(slice11, &obs, &p).unwrap().mean_log_likelihood,
    );
    assert!(
        after > before + 0.02,
        "11:00 held-out mean log-likelihood: learned slice {after}, all-day map {before}"
    );

    // a restart resumes the set from its snapshot
    let _daemon = Daemon::start(&ns, &args);
    let mut c = ns.connect(WaitMode::Hybrid);
    assert_eq!(live(&mut c, &at11), (version, learned11));
    assert_eq!(live(&mut c, &at15).1, local_bits(&all_day, &at15).1);
}
