//! Maps that learn while they serve (`cliffd --learn`), on real people (THÖR1 round 2):
//! observations counted once per client, track and time; budgets; learned versions
//! swapped in with every response naming its version; the base map pinned; snapshots
//! that survive SIGKILL.

mod common;

use std::path::Path;
use std::time::{Duration, Instant};

use cliff::map::CliffMap;
use cliff::map::build::observations_from_tracks;
use cliff::map::score::{ScoreParams, score};
use cliff::predict::Params;
use cliff::tracks::{Format, Track, read_tracks};
use cliff_client::{Client, Error, Field, Observation, ObserveRequest, Request, Status, WaitMode};
use common::*;

fn thor1_round2() -> Vec<Track> {
    read_tracks(&shared_data("thor1/exp-1-run-2.csv"), Format::Thor).expect("THÖR1 round 2")
}

fn thor1_map() -> String {
    format!("thor1={}", shared_data("thor1/cliffmap.csv").display())
}

#[test]
fn overlapping_histories_of_real_people_count_each_row_once_per_client() {
    let ns = Namespace::new("learn_dedup");
    let thor3 = format!("thor3={}", shared_data("thor3/cliffmap.csv").display());
    let _daemon = Daemon::start(
        &ns,
        &[
            "--map",
            &thor1_map(),
            "--map",
            &thor3,
            "--learn",
            "thor1",
            "--observe-rate",
            "1000000",
        ],
    );
    let tracks = thor1_round2();
    let rows: u64 = tracks.iter().map(|t| t.rows.len() as u64).sum();
    let mut a = ns.connect(WaitMode::Hybrid);
    let (accepted, duplicates, _) = observe_like_a_robot(&mut a, "thor1", &tracks, 8);
    assert_eq!(accepted, rows, "every row of the recording once");
    assert!(
        duplicates > 3 * rows,
        "the histories overlapped: {duplicates} duplicates"
    );
    // the same people again: all duplicates
    let (again, _, _) = observe_like_a_robot(&mut a, "thor1", &tracks, 8);
    assert_eq!(again, 0);
    // another client's track ids are other people
    let mut b = ns.connect(WaitMode::Hybrid);
    let (other, _, _) = observe_like_a_robot(&mut b, "thor1", &tracks[..10], 4);
    assert_eq!(
        other,
        tracks[..10]
            .iter()
            .map(|t| t.rows.len() as u64)
            .sum::<u64>()
    );

    // a map served but not learned, a map not served, a bad row: statuses, and serving goes on
    let mut r = ObserveRequest::new("thor3").unwrap();
    r.add_track(1, [Observation::position(0.0, 1.0, 1.0)]);
    let status = |c: &mut Client, r: &ObserveRequest| match c.observe(r) {
        Err(Error::Rejected(rej)) => rej,
        other => panic!("expected a rejection, got {other:?}"),
    };
    assert_eq!(status(&mut a, &r).status, Status::NotLearning);
    let mut r = ObserveRequest::new("nowhere").unwrap();
    r.add_track(1, [Observation::position(0.0, 1.0, 1.0)]);
    assert_eq!(status(&mut a, &r).status, Status::UnknownMap);
    let mut r = ObserveRequest::new("thor1").unwrap();
    r.add_track(
        1,
        [
            Observation::position(0.0, 1.0, 1.0),
            Observation::position(1.0, f64::NAN, 1.0),
        ],
    );
    let rej = status(&mut a, &r);
    assert_eq!(
        (rej.status, rej.field, rej.row),
        (Status::NonFinite, Field::Position, Some(1))
    );
    let p = Request::new("thor1", &Params::default()).unwrap();
    let mut p = p;
    p.add_agent([Observation::with_velocity(0.0, 1.0, 1.0, 1.0, 0.0)]);
    assert!(a.predict(&p).is_ok(), "predictions still served");
}

#[test]
fn a_client_over_its_budget_gets_a_status_and_nothing_is_taken() {
    let ns = Namespace::new("learn_budget");
    let _daemon = Daemon::start(
        &ns,
        &[
            "--map",
            &thor1_map(),
            "--learn",
            "thor1",
            "--observe-rate",
            "100",
            "--observe-tracks",
            "4",
        ],
    );
    let tracks = thor1_round2();
    let mut c = ns.connect(WaitMode::Hybrid);
    let over = |c: &mut Client, r: &ObserveRequest| match c.observe(r) {
        Err(Error::Rejected(rej)) => (rej.status, rej.field, rej.limit),
        other => panic!("expected over-budget, got {other:?}"),
    };
    // five new tracks: over the four open tracks allowed
    let mut r = ObserveRequest::new("thor1").unwrap();
    for (id, t) in tracks.iter().take(5).enumerate() {
        r.add_track_rows(id as u32, &t.rows[..2]);
    }
    assert_eq!(over(&mut c, &r), (Status::OverBudget, Field::Tracks, 4));
    // the first `n` rows of the four people tracked longest, person after person
    let mut longest = tracks.clone();
    longest.sort_by_key(|t| std::cmp::Reverse(t.rows.len()));
    let first = |n: usize| {
        let mut r = ObserveRequest::new("thor1").unwrap();
        let mut left = n;
        for (id, t) in longest.iter().take(4).enumerate() {
            let k = left.min(t.rows.len());
            r.add_track_rows(id as u32, &t.rows[..k]);
            left -= k;
        }
        assert_eq!(left, 0, "four people have {n} rows");
        r
    };
    // 120 rows at once: over the 100 per second
    assert_eq!(
        over(&mut c, &first(120)),
        (Status::OverBudget, Field::Rows, 100)
    );
    // nothing of either was taken: the first 80 rows are all new
    assert_eq!(c.observe(&first(80)).unwrap().accepted, 80);
    // the budget refills at 100 rows per second: 50 new rows now are over the 20 left,
    // but fit 0.4 s later
    assert_eq!(over(&mut c, &first(130)).1, Field::Rows);
    std::thread::sleep(Duration::from_millis(400));
    let r = c.observe(&first(130)).unwrap();
    assert_eq!((r.accepted, r.duplicates), (50, 80));
}

/// The map of the newest snapshot of `name` in `dir` and its version.
fn newest_snapshot(dir: &Path, name: &str) -> Option<(u32, CliffMap)> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().into_string().unwrap())
        .filter(|f| f.starts_with(&format!("{name}.v")) && f.ends_with(".cliff"))
        .collect();
    files.sort();
    let f = files.pop()?;
    let v = f[name.len() + 2..name.len() + 10].parse().unwrap();
    Some((
        v,
        cliff::map::read_snapshot(&dir.join(f)).expect("snapshot loads"),
    ))
}

#[test]
fn learned_versions_are_swapped_in_and_each_response_names_its_version() {
    let ns = Namespace::new("learn_versions");
    let dir = tempfile::tempdir().unwrap();
    let dir_arg = dir.path().display().to_string();
    let mut daemon = Daemon::start(
        &ns,
        &[
            "--map",
            &thor1_map(),
            "--learn",
            "thor1",
            "--learn-dir",
            &dir_arg,
            "--observe-rate",
            "1000000",
            "--learn-every-rows",
            "100000",
            "--learn-every-s",
            "1",
            // no damping: this checks what one version learns from real people
            "--learn-move-per-min",
            "inf",
        ],
    );
    assert!(
        daemon.ready_line.contains("learning, version 0"),
        "{}",
        daemon.ready_line
    );
    let mut tracks = thor1_round2();
    // people are learned or held out for scoring, alternately
    let held: Vec<Track> = tracks.iter().skip(1).step_by(2).cloned().collect();
    tracks = tracks.into_iter().step_by(2).collect();
    let mut c = ns.connect(WaitMode::Hybrid);
    observe_like_a_robot(&mut c, "thor1", &tracks, 6);

    let base = CliffMap::load(shared_data("thor1/cliffmap.csv")).unwrap();
    let mut request = Request::new(
        "thor1",
        &Params {
            k: 10,
            ..Params::default()
        },
    )
    .unwrap();
    request.add_agent([Observation::with_velocity(0.0, 1.0, 2.0, 1.1, 0.3)]);
    // the learned version comes within the learning interval (ended tracks go at once)
    let version = first_learned_version(&mut c, &request, Duration::from_secs(20));
    assert_eq!(version, 1, "one learning interval, one version");
    let learned = c
        .predict(&request)
        .map(|p| bits(p.positions(), p.lens()))
        .unwrap();
    // the base map pinned: version 0, the numbers of the map file
    let pinned = request.clone().base_map(true);
    let p = c.predict(&pinned).unwrap();
    assert_eq!(p.map_version(), 0);
    assert_eq!(
        (p.shape(), bits(p.positions(), p.lens())),
        local_bits(&base, &request)
    );
    assert_ne!(
        learned,
        local_bits(&base, &request).1,
        "the learned map differs"
    );
    // versions by name: NAME@0 is the map as loaded, NAME@VERSION the one learned; a
    // version the daemon does not hold is refused with the version served
    let named = |c: &mut Client, name: &str| {
        let mut r = request.clone();
        r.set_map(name).unwrap();
        c.predict(&r)
            .map(|p| (p.map_version(), bits(p.positions(), p.lens())))
    };
    assert_eq!(
        named(&mut c, "thor1@0").unwrap(),
        (0, local_bits(&base, &request).1)
    );
    assert_eq!(
        named(&mut c, &format!("thor1@{version}")).unwrap(),
        (version, learned.clone())
    );
    for (name, status, limit) in [
        ("thor1@2", Status::UnknownVersion, version),
        ("thor1@99999999999", Status::UnknownMap, 0),
        ("thor1@", Status::UnknownMap, 0),
        ("elsewhere@0", Status::UnknownMap, 0),
    ] {
        match named(&mut c, name) {
            Err(Error::Rejected(rej)) => {
                assert_eq!(
                    (rej.status, rej.field, rej.limit),
                    (status, Field::Map, limit),
                    "{name}"
                )
            }
            other => panic!("{name}: expected {status}, got {other:?}"),
        }
    }

    // at shutdown the served version is written; it is the map that answered
    daemon.signal(SIGTERM);
    assert!(
        daemon
            .wait_exit(Duration::from_secs(20))
            .is_some_and(|s| s.success())
    );
    let (v, snap) = newest_snapshot(dir.path(), "thor1").expect("a snapshot");
    assert_eq!(v, version);
    assert_eq!(local_bits(&snap, &request).1, learned);
    // and it explains the held-out people of round 2 better than the round-1 map did
    let obs = observations_from_tracks(&held);
    let p = ScoreParams::default();
    let (before, after) = (
        score(&base, &obs, &p).unwrap(),
        score(&snap, &obs, &p).unwrap(),
    );
    assert!(
        after.mean_log_likelihood > before.mean_log_likelihood + 0.05,
        "held-out mean log-likelihood {} learned, {} base",
        after.mean_log_likelihood,
        before.mean_log_likelihood
    );

    // a restart resumes from the snapshot
    let daemon = Daemon::start(
        &ns,
        &[
            "--map",
            &thor1_map(),
            "--learn",
            "thor1",
            "--learn-dir",
            &dir_arg,
        ],
    );
    assert!(
        daemon
            .ready_line
            .contains(&format!("learning, version {version}")),
        "{}",
        daemon.ready_line
    );
    let mut c = ns.connect(WaitMode::Hybrid);
    let p = c.predict(&request).unwrap();
    assert_eq!(
        (p.map_version(), bits(p.positions(), p.lens())),
        (version, learned)
    );
}

/// Versions of `name` with a snapshot file in `dir`, oldest first, and whether every one
/// of them loads (its checksum and checks pass).
fn snapshot_versions(dir: &Path, name: &str) -> Vec<u32> {
    let mut v: Vec<u32> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().into_string().unwrap())
        .filter(|f| f.starts_with(&format!("{name}.v")) && f.ends_with(".cliff"))
        .map(|f| {
            let path = dir.join(&f);
            if let Err(e) = cliff::map::read_snapshot(&path) {
                panic!("a torn or unreadable snapshot {f}: {e}");
            }
            f[name.len() + 2..name.len() + 10].parse().unwrap()
        })
        .collect();
    v.sort_unstable();
    v
}

#[test]
fn killed_at_random_points_while_learning_the_daemon_resumes_from_its_newest_snapshot() {
    use rand::{RngExt, SeedableRng};
    let ns = Namespace::new("learn_kill");
    let dir = tempfile::tempdir().unwrap();
    let dir_arg = dir.path().display().to_string();
    let snapshot_every = 0.3;
    let args = [
        "--map",
        &thor1_map(),
        "--learn",
        "thor1",
        "--learn-dir",
        &dir_arg,
        "--observe-rate",
        "1000000",
        "--learn-every-rows",
        "100",
        "--learn-every-s",
        "0.1",
        "--snapshot-every-s",
        "0.3",
        "--learn-held-rows",
        "0",
    ]
    .map(String::from);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let tracks = thor1_round2();
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(7);
    let mut resumed = 0u32;
    for round in 0..12 {
        let mut daemon = Daemon::start_tagged(&ns, &args, &format!("round{round}"));
        let ready = &daemon.ready_line;
        assert!(
            ready.contains(&format!("learning, version {resumed}")),
            "round {round}: {ready}"
        );
        let mut c = ns.connect(WaitMode::Hybrid);
        // the people of the recording again, later each round (new rows for the daemon)
        let shift = 1000.0 * (round + 1) as f64;
        let moved: Vec<Track> = tracks
            .iter()
            .map(|t| Track {
                id: t.id,
                rows: t
                    .rows
                    .iter()
                    .map(|r| cliff::tracks::Row {
                        t: r.t + shift,
                        ..*r
                    })
                    .collect(),
            })
            .collect();
        let kill_at = Instant::now() + Duration::from_millis(rng.random_range(400..1500));
        // (version, when it was answered) of the observe replies
        let mut answered: Vec<(u32, Instant)> = Vec::new();
        let mut request = ObserveRequest::new("thor1").unwrap();
        'send: for chunk in moved.chunks(4) {
            for (i, t) in chunk.iter().enumerate() {
                request.clear();
                request.add_track_rows(
                    i as u32 + 100 * round as u32,
                    &t.rows[..t.rows.len().min(200)],
                );
                request.end_track();
                match c.observe(&request) {
                    Ok(r) => answered.push((r.map_version, Instant::now())),
                    Err(e) => panic!("round {round}: {e}"),
                }
                if Instant::now() >= kill_at {
                    break 'send;
                }
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        while Instant::now() < kill_at {
            std::thread::sleep(Duration::from_millis(10));
        }
        daemon.signal(SIGKILL);
        let killed = Instant::now();
        daemon.wait_exit(Duration::from_secs(5)).expect("killed");
        // never a torn file: every snapshot loads
        let versions = snapshot_versions(dir.path(), "thor1");
        let newest = versions.last().copied().unwrap_or(0);
        // never more lost than the last interval: what was served a snapshot interval
        // (and a learning step) before the kill is on disk
        let safe = answered
            .iter()
            .filter(|(_, at)| killed.duration_since(*at).as_secs_f64() > snapshot_every + 0.5)
            .map(|(v, _)| *v)
            .max()
            .unwrap_or(0);
        assert!(
            newest >= safe,
            "round {round}: snapshot {newest}, served {safe} well before the kill"
        );
        assert!(
            newest >= resumed,
            "round {round}: went back from {resumed} to {newest}"
        );
        resumed = newest;
    }
    assert!(
        resumed >= 5,
        "learning went on across the kills: version {resumed}"
    );
}

#[test]
fn cliff_observe_streams_a_recording_at_the_daemons_pace_or_at_a_rate() {
    let ns = Namespace::new("learn_cli");
    let _daemon = Daemon::start(
        &ns,
        &[
            "--map",
            &thor1_map(),
            "--learn",
            "thor1",
            "--observe-rate",
            "500",
        ],
    );
    let rows: usize = thor1_round2().iter().map(|t| t.rows.len()).sum();
    let file = shared_data("thor1/exp-1-run-2.csv").display().to_string();
    let observe = |extra: &[&str]| {
        let start = Instant::now();
        let out = std::process::Command::new(workspace_exe("cliff"))
            .args([
                "observe", "--map", "thor1", "--tracks", &file, "--format", "thor",
            ])
            .args(["--service", SERVICE, "--prefix", &ns.prefix, "--quiet"])
            .args(extra)
            .output()
            .expect("run cliff observe");
        let text = String::from_utf8_lossy(&out.stdout).to_string();
        assert!(
            out.status.success(),
            "{text}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        (text, start.elapsed())
    };
    // as fast as accepted: over the 500 rows per second, requests are sent again (and
    // made smaller than the 512 rows asked for)
    let (text, took) = observe(&[]);
    assert!(
        text.contains(&format!("observed {rows} rows"))
            && text.contains(&format!("{rows} taken, 0 duplicates")),
        "{text}"
    );
    let retries = |text: &str| -> u64 {
        let before = text.split(" retries").next().unwrap();
        before.rsplit(' ').next().unwrap().parse().unwrap()
    };
    assert!(retries(&text) > 0, "{text}");
    assert!(
        took.as_secs_f64() > (rows as f64 / 500.0 - 1.0),
        "{took:?} for {rows} rows"
    );
    // another run is another client (its people are new to the daemon): at a rate below
    // the budget, nothing is refused
    let (text, took) = observe(&["--rate", "450"]);
    assert!(
        text.contains(&format!("{rows} taken, 0 duplicates")),
        "{text}"
    );
    assert_eq!(retries(&text), 0, "{text}");
    assert!(
        took.as_secs_f64() >= rows as f64 / 450.0 * 0.9,
        "{took:?} for {rows} rows at 450/s"
    );
    // a map that is not learned is an error naming it
    let out = std::process::Command::new(workspace_exe("cliff-observe"))
        .args(["--map", "elsewhere", "--tracks", &file, "--format", "thor"])
        .args(["--service", SERVICE, "--prefix", &ns.prefix, "--quiet"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("'elsewhere'") && err.contains("unknown-map"),
        "{err}"
    );
}

#[test]
fn the_c_abi_observes_and_reports_the_map_version() {
    use cliff_client::ffi::*;
    use std::ffi::{CStr, CString};
    let ns = Namespace::new("learn_c");
    let _daemon = Daemon::start(
        &ns,
        &[
            "--map",
            &thor1_map(),
            "--learn",
            "thor1",
            "--observe-rate",
            "1000000",
            "--learn-every-rows",
            "1000000",
            "--learn-every-s",
            "0.3",
            "--learn-held-rows",
            "0",
        ],
    );
    let service = CString::new(SERVICE).unwrap();
    let prefix = CString::new(ns.prefix.clone()).unwrap();
    let map = CString::new("thor1").unwrap();
    let mut client = std::ptr::null_mut();
    // SAFETY: valid strings and out pointer
    assert_eq!(
        unsafe { cliff_client_connect(service.as_ptr(), prefix.as_ptr(), &mut client) },
        CLIFF_OK
    );
    let tracks = thor1_round2();
    let mut total = 0u32;
    for (id, tr) in tracks.iter().enumerate() {
        let col = |f: fn(&cliff::tracks::Row) -> f64| tr.rows.iter().map(f).collect::<Vec<f64>>();
        let (t, x, y, s, h) = (
            col(|r| r.t),
            col(|r| r.position.x),
            col(|r| r.position.y),
            col(|r| r.speed),
            col(|r| r.angle),
        );
        let mut out = CliffObserved::default();
        for _ in 0..2 {
            // SAFETY: every array holds n doubles
            let code = unsafe {
                cliff_observe(
                    client,
                    map.as_ptr(),
                    id as u32,
                    t.len(),
                    t.as_ptr(),
                    x.as_ptr(),
                    y.as_ptr(),
                    s.as_ptr(),
                    h.as_ptr(),
                    1,
                    &mut out,
                )
            };
            assert_eq!(code, CLIFF_OK);
        }
        // the second time every row is a duplicate
        assert_eq!((out.accepted, out.duplicates), (0, t.len() as u32));
        total += t.len() as u32;
    }
    assert!(total > 1000);
    // a map that is not served: rejected with the status named
    let other = CString::new("elsewhere").unwrap();
    let (t, x, y) = ([0.0], [1.0], [1.0]);
    let mut out = CliffObserved::default();
    // SAFETY: one double each; speed and heading NULL
    let code = unsafe {
        cliff_observe(
            client,
            other.as_ptr(),
            1,
            1,
            t.as_ptr(),
            x.as_ptr(),
            y.as_ptr(),
            std::ptr::null(),
            std::ptr::null(),
            0,
            &mut out,
        )
    };
    assert_eq!(code, CLIFF_ERR_REJECTED);
    // SAFETY: a static string
    assert_eq!(
        unsafe { CStr::from_ptr(cliff_status_name(out.status)) }
            .to_str()
            .unwrap(),
        "unknown-map"
    );

    // predictions name the version that answered: a learned one soon, 0 when pinned
    let mut p = default_params();
    p.k = 5;
    // SAFETY: a valid map name and params
    let request = unsafe { cliff_request_new(map.as_ptr(), &p) };
    let (t, x, y, s, h) = ([0.0], [1.0], [2.0], [1.2], [0.2]);
    // SAFETY: one double each
    assert_eq!(
        unsafe {
            cliff_request_add_agent(
                request,
                1,
                t.as_ptr(),
                x.as_ptr(),
                y.as_ptr(),
                s.as_ptr(),
                h.as_ptr(),
            )
        },
        CLIFF_OK
    );
    let mut pred = std::mem::MaybeUninit::<CliffPrediction>::uninit();
    let end = Instant::now() + Duration::from_secs(20);
    loop {
        // SAFETY: valid client, request and out
        assert_eq!(
            unsafe { cliff_predict(client, request, pred.as_mut_ptr()) },
            CLIFF_OK
        );
        // SAFETY: valid client
        if unsafe { cliff_client_map_version(client) } > 0 {
            break;
        }
        assert!(Instant::now() < end, "no learned version within 20 s");
        std::thread::sleep(Duration::from_millis(50));
    }
    p.flags = CLIFF_FLAG_BASE_MAP;
    // SAFETY: valid request and params
    assert_eq!(unsafe { cliff_request_set_params(request, &p) }, CLIFF_OK);
    // SAFETY: valid client, request and out
    assert_eq!(
        unsafe { cliff_predict(client, request, pred.as_mut_ptr()) },
        CLIFF_OK
    );
    // SAFETY: valid client
    assert_eq!(unsafe { cliff_client_map_version(client) }, 0);
    // SAFETY: created above, freed once
    unsafe {
        cliff_request_free(request);
        cliff_client_free(client);
    }
}

/// `cliff_params_default`'s parameters.
fn default_params() -> cliff_client::ffi::CliffParams {
    let mut p = std::mem::MaybeUninit::uninit();
    // SAFETY: writes a whole CliffParams
    unsafe {
        cliff_client::ffi::cliff_params_default(p.as_mut_ptr());
        p.assume_init()
    }
}

/// Fabricated people on ATC's training paths, walking across the mall's flows: each
/// row's heading turned a quarter turn to the left (the mall's corridors carry people
/// both ways, so paths walked backwards would be real traffic), at most 120 rows a track
/// (so that whole tracks fill requests of at most 1020 rows).
fn atc_across() -> Vec<Track> {
    let files: Vec<_> = std::fs::read_dir(shared_data("atc/train"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    let tracks = cliff::tracks::read_many(&files, Format::Atc).expect("atc/train");
    tracks
        .into_iter()
        .filter(|t| t.rows.len() >= 4)
        .map(|t| {
            let rows = &t.rows[..t.rows.len().min(120)];
            Track {
                id: t.id,
                rows: rows
                    .iter()
                    .map(|r| cliff::tracks::Row {
                        angle: cliff::math::wrap_pi(r.angle + std::f64::consts::FRAC_PI_2),
                        ..*r
                    })
                    .collect(),
            }
        })
        .collect()
}

/// Send whole `tracks` (each ended) as fast as the daemon's budget lets through, for
/// `seconds`; the rows taken.
fn flood(client: &mut Client, map: &str, tracks: &[Track], seconds: f64) -> u64 {
    let end = Instant::now() + Duration::from_secs_f64(seconds);
    let mut request = ObserveRequest::new(map).unwrap();
    let mut taken = 0u64;
    let mut next = tracks.iter().enumerate().cycle();
    while Instant::now() < end {
        request.clear();
        while request.rows().len() < 900 {
            let (id, t) = next.next().unwrap();
            request.add_track_rows(id as u32, &t.rows);
            request.end_track();
        }
        // over budget: wait for the bucket to refill, then the same request again
        loop {
            match client.observe(&request) {
                Ok(r) => {
                    taken += r.accepted as u64;
                    break;
                }
                Err(Error::Rejected(rej)) if rej.status == Status::OverBudget => {
                    if Instant::now() >= end {
                        return taken;
                    }
                    std::thread::sleep(Duration::from_millis(2));
                }
                Err(e) => panic!("observe: {e}"),
            }
        }
    }
    taken
}

/// One hostile minute (scaled: see the test) against a daemon learning ATC's map, and the
/// map's mean log-likelihood on atc/dev's real people before and after, scored by the
/// library on the snapshot written; with the damping of `move_per_min` ("inf": none).
/// The scores are (mean, median) log-likelihoods.
fn hostile_minute(
    tag: &str,
    move_per_min: &str,
    tracks: &[Track],
) -> ((f64, f64), (f64, f64), u64, u32) {
    let ns = Namespace::new(tag);
    let dir = tempfile::tempdir().unwrap();
    let dir_arg = dir.path().display().to_string();
    let atc = shared_data("atc/cliffmap-20121024.csv");
    // Time runs ten times faster than with the defaults: a second stands for ten, so the
    // budget is ten times the default 2000 rows/s and the intervals a tenth of theirs;
    // --learn-every-rows stays 20000, so the minute's 120,000 rows make the same six
    // versions as at the defaults' pace.
    let mut daemon = Daemon::start_tagged(
        &ns,
        &[
            "--map",
            &format!("atc={}", atc.display()),
            "--learn",
            "atc",
            "--learn-dir",
            &dir_arg,
            "--observe-rate",
            "20000",
            "--learn-every-s",
            "3",
            "--track-timeout-s",
            "0.5",
            "--snapshot-every-s",
            "6",
            "--learn-move-per-min",
            move_per_min,
        ],
        tag,
    );
    let mut c = ns.connect(WaitMode::Hybrid);
    let taken = flood(&mut c, "atc", tracks, 6.0);
    daemon.signal(SIGINT);
    assert!(
        daemon
            .wait_exit(Duration::from_secs(60))
            .is_some_and(|s| s.success()),
        "{}",
        daemon.log_text()
    );
    let (version, learned) = newest_snapshot(dir.path(), "atc").expect("a snapshot");
    let dev: Vec<_> = std::fs::read_dir(shared_data("atc/dev"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    let people = observations_from_tracks(&cliff::tracks::read_many(&dev, Format::Atc).unwrap());
    let base = CliffMap::load(&atc).unwrap();
    let p = ScoreParams::default();
    let (b, a) = (
        score(&base, &people, &p).unwrap(),
        score(&learned, &people, &p).unwrap(),
    );
    let (before, after) = (b.mean_log_likelihood, a.mean_log_likelihood);
    println!(
        "{tag}: {taken} rows taken, version {version}, atc/dev mean log-likelihood {before:.4} -> {after:.4}, median {:.4} -> {:.4}, below -10 {:.2} % -> {:.2} %",
        b.median_log_likelihood,
        a.median_log_likelihood,
        100.0 * b.share_below,
        100.0 * a.share_below
    );
    (
        (before, b.median_log_likelihood),
        (after, a.median_log_likelihood),
        taken,
        version,
    )
}

#[test]
fn a_hostile_client_at_its_full_budget_for_a_minute_barely_lowers_the_score_of_real_people() {
    let tracks = atc_across();
    // the default damping (0.01 per minute, here ten times faster: 0.1)
    let (before, after, taken, version) = hostile_minute("learn_hostile", "0.1", &tracks);
    // the client really sent a minute at its full budget, and the map learned from it
    assert!(taken >= 100_000, "{taken} rows taken");
    assert!(version >= 4, "version {version}");
    // the mean, and the median (the mean rises where a little fabricated weight lifts
    // the worst-explained observations)
    for (what, b, a) in [("mean", before.0, after.0), ("median", before.1, after.1)] {
        let drop = (b - a) / b.abs();
        assert!(
            drop <= 0.02,
            "{what} log-likelihood on atc/dev {b:.4} before, {a:.4} after: {:.1} % lower",
            100.0 * drop
        );
    }
    // the same minute without damping lowers both far more: the attack is real
    let (before, undamped, _, _) = hostile_minute("learn_hostile_free", "inf", &tracks);
    assert!(
        (before.0 - undamped.0) / before.0.abs() > 0.05
            && (before.1 - undamped.1) / before.1.abs() > 0.05,
        "undamped: {before:?} -> {undamped:?}"
    );
}
