//! Property tests of the file readers: random mutations of the real map CSV,
//! snapshot and trajectory files (and of rosbag2 recordings) never panic, and each
//! either loads (and keeps its invariants) or gives an error naming the file, line and
//! column (for a recording: the file, and the message of a bad one). Seeded, so a failure
//! reproduces; the same readers are fuzzed for much longer by the targets in `fuzz/`.

use std::path::Path;

use std::collections::HashSet;

use cliff::map::{
    CliffMap, MapError, MapSet, SET_SNAPSHOT_VERSION, SNAPSHOT_MAGIC, SNAPSHOT_VERSION, SetParts,
    read_csv_bytes, read_csv_str, read_snapshot_bytes, write_csv_string,
};
use cliff::tracks::{Columns, NamedTracks, parse_named};
use cliff::tracks::{
    DatasetError, Format, MAX_ANGLE, MAX_POSITION, MAX_SPEED, MAX_TIME, Track, parse_recording,
    parse_track_bytes,
};
use rand::{Rng, RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

mod common;
use common::data;

/// Values that are absurd, borderline or malformed somewhere in a row.
const ODD_FIELDS: &[&str] = &[
    "1e20",
    "-1e20",
    "1e300",
    "1e-300",
    "1000000",
    "-1000001",
    "0",
    "-0",
    "nan",
    "inf",
    "-inf",
    "",
    " ",
    "1e",
    "0x10",
    "99999999999999999999",
    "18446744073709551616",
    "-1",
    "0.0001",
    "5000",
    "1.5",
    "3.3e6",
];

/// Apply 1 to 4 random edits to `text`: byte flips, insertions and deletions, a field
/// replaced by an odd value, a line duplicated, dropped or swapped.
fn mutate(text: &[u8], rng: &mut impl Rng) -> Vec<u8> {
    let mut b = text.to_vec();
    for _ in 0..rng.random_range(1..=4) {
        let n = b.len().max(1);
        match rng.random_range(0..7) {
            0 if !b.is_empty() => {
                let i = rng.random_range(0..b.len());
                b[i] ^= 1 << rng.random_range(0..8);
            }
            1 => {
                let i = rng.random_range(0..=b.len());
                b.insert(
                    i,
                    *b",.-e0123456789\n\xff"
                        .get(rng.random_range(0..16))
                        .unwrap(),
                );
            }
            2 if !b.is_empty() => {
                let i = rng.random_range(0..b.len());
                let j = (i + rng.random_range(1..40)).min(b.len());
                b.drain(i..j);
            }
            3 | 4 => {
                // replace one field of one line
                let text = String::from_utf8_lossy(&b).into_owned();
                let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
                if lines.is_empty() {
                    continue;
                }
                let l = rng.random_range(0..lines.len());
                let mut fields: Vec<&str> = lines[l].split(',').collect();
                let f = rng.random_range(0..fields.len());
                fields[f] = ODD_FIELDS[rng.random_range(0..ODD_FIELDS.len())];
                lines[l] = fields.join(",");
                b = (lines.join("\n") + "\n").into_bytes();
            }
            5 => {
                let text = String::from_utf8_lossy(&b).into_owned();
                let mut lines: Vec<&str> = text.lines().collect();
                if lines.is_empty() {
                    continue;
                }
                let l = rng.random_range(0..lines.len());
                match rng.random_range(0..3) {
                    0 => lines.insert(rng.random_range(0..=lines.len()), lines[l]),
                    1 => {
                        lines.remove(l);
                    }
                    _ => {
                        let m = rng.random_range(0..lines.len());
                        lines.swap(l, m);
                    }
                }
                b = (lines.join("\n") + "\n").into_bytes();
            }
            _ => {
                let i = rng.random_range(0..n);
                b.truncate(i);
            }
        }
    }
    b
}

fn lines_of(bytes: &[u8]) -> usize {
    bytes.split(|&c| c == b'\n').count()
}

/// The first `n` rows of a real map (a smaller map loads faster, so more mutations run).
fn head(path: &str, n: usize) -> Vec<u8> {
    let text = std::fs::read_to_string(data(path)).unwrap();
    let rows: Vec<&str> = text.lines().take(n).collect();
    (rows.join("\n") + "\n").into_bytes()
}

#[test]
fn mutated_map_csv_loads_or_names_line_and_column() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
    let (mut loaded, mut refused) = (0, 0);
    for (path, rows, runs) in [
        ("thor1/cliffmap.csv", 60, 1500),
        ("atc/cliffmap-20121024.csv", 60, 1500),
        ("thor3/cliffmap.csv", 10_000, 200),
    ] {
        let original = head(path, rows);
        assert!(read_csv_bytes(&original, "m.csv").is_ok(), "{path}");
        for _ in 0..runs {
            let bytes = mutate(&original, &mut rng);
            match read_csv_bytes(&bytes, "m.csv") {
                Ok(map) => {
                    loaded += 1;
                    let back = read_csv_str(&write_csv_string(&map)).unwrap();
                    assert_eq!(back.locations(), map.locations());
                }
                Err(MapError::Parse {
                    file,
                    line,
                    column,
                    message,
                }) => {
                    refused += 1;
                    assert_eq!(file, "m.csv");
                    assert!(line <= lines_of(&bytes), "{line}: {message}");
                    assert!(column <= 11 || message.contains("UTF-8"), "{message}");
                    assert!(line > 0 || message == "no map rows", "{message}");
                }
                Err(e) => panic!("an error without line and column: {e}"),
            }
        }
    }
    // both outcomes are exercised
    assert!(
        loaded > 100 && refused > 1000,
        "{loaded} loaded, {refused} refused"
    );
}

fn with_header(body: &[u8]) -> Vec<u8> {
    with_version(SNAPSHOT_VERSION, body)
}

fn with_version(version: u32, body: &[u8]) -> Vec<u8> {
    let mut out = SNAPSHOT_MAGIC.to_vec();
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(body).to_le_bytes());
    out.extend_from_slice(body);
    out
}

#[test]
fn snapshots_round_trip_and_mutations_load_or_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(10);
    let mut loaded = 0;
    for path in ["thor1/cliffmap.csv", "atc/cliffmap-20121024.csv"] {
        let map = CliffMap::load(data(path)).unwrap();
        let file = dir.path().join("m.cliff");
        map.save(&file).unwrap();
        let bytes = std::fs::read(&file).unwrap();
        let back = read_snapshot_bytes(&bytes, "m.cliff").unwrap();
        assert_eq!(back.locations(), map.locations());
        assert_eq!(back.grid().step(), map.grid().step());
        assert_eq!(write_csv_string(&back), write_csv_string(&map));
        // Mutations of a smaller snapshot (the first 200 rows): more of them per second.
        let small = read_csv_bytes(&head(path, 200), "m.csv").unwrap();
        small.save(&file).unwrap();
        let bytes = std::fs::read(&file).unwrap();
        let payload = &bytes[24..];
        for i in 0..1500 {
            // Mutate the payload and give it a correct header (so the decoder and the
            // map checks see it), or mutate the whole file.
            let m = if i % 4 == 0 {
                mutate(&bytes, &mut rng)
            } else {
                let mut p = payload.to_vec();
                for _ in 0..rng.random_range(1..4) {
                    let j = rng.random_range(0..p.len());
                    p[j] = rng.random();
                }
                if rng.random_range(0..4) == 0 {
                    p.truncate(rng.random_range(0..p.len()));
                }
                with_header(&p)
            };
            match read_snapshot_bytes(&m, "m.cliff") {
                Ok(map) => {
                    loaded += 1;
                    assert!(!map.locations().is_empty());
                }
                Err(MapError::Snapshot { file, .. }) => assert_eq!(file, "m.cliff"),
                Err(e) => panic!("a snapshot error of the wrong kind: {e}"),
            }
        }
    }
    assert!(loaded > 50, "{loaded}");
}

#[test]
fn mutated_track_files_load_or_name_line_and_column() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
    let (mut loaded, mut refused) = (0, 0);
    for (path, format) in [
        ("thor1/exp-1-run-2.csv", Format::Thor),
        ("thor3/exp-3-run-2.csv", Format::Thor),
        ("atc/dev/atc-1024-13_test.csv", Format::Atc),
    ] {
        let original = head(path, 300);
        assert!(parse_track_bytes(&original, "t.csv", format).is_ok());
        for _ in 0..1500 {
            let bytes = mutate(&original, &mut rng);
            match parse_track_bytes(&bytes, "t.csv", format) {
                Ok(tracks) => {
                    loaded += 1;
                    for t in &tracks {
                        assert!(!t.rows.is_empty());
                        assert!(t.rows.windows(2).all(|w| w[0].t < w[1].t));
                        assert!(
                            t.rows.iter().all(|r| r.position.is_finite()
                                && r.speed >= 0.0
                                && r.t.is_finite())
                        );
                    }
                }
                Err(DatasetError::Parse {
                    file,
                    line,
                    column,
                    message,
                }) => {
                    refused += 1;
                    assert_eq!(file, "t.csv");
                    assert!(line >= 1 && line <= lines_of(&bytes), "{line}: {message}");
                    assert!(column <= 6 || message.contains("UTF-8"), "{message}");
                }
                Err(e) => panic!("a track error without line and column: {e}"),
            }
        }
    }
    assert!(
        loaded > 300 && refused > 1000,
        "{loaded} loaded, {refused} refused"
    );
}

#[test]
fn real_files_still_load() {
    for path in [
        "thor1/cliffmap.csv",
        "thor3/cliffmap.csv",
        "atc/cliffmap-20121024.csv",
    ] {
        assert!(CliffMap::load(Path::new(&data(path))).is_ok(), "{path}");
    }
}

/// Every file of the fuzz seed corpus through its reader, as the fuzz targets run them:
/// among them the input with which the `map_csv` target found the overflowing grid cell
/// count of the old loader (a y of -3.4e93), which now gets an error at its line.
#[test]
fn fuzz_seed_corpus_replays_without_panics() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus");
    let files = |target: &str| {
        let mut v: Vec<_> = std::fs::read_dir(root.join(target))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        v.sort();
        assert!(!v.is_empty(), "{target}");
        v.into_iter()
            .map(|p| (p.display().to_string(), std::fs::read(&p).unwrap()))
    };
    for (name, bytes) in files("map_csv") {
        match read_csv_bytes(&bytes, &name) {
            Ok(_) => assert!(!name.contains("regression"), "{name}"),
            Err(e) => {
                let e = e.to_string();
                assert!(e.starts_with(&format!("{name}:")), "{e}");
                if name.ends_with("regression-y-3e93.csv") {
                    assert!(e.contains(":19: column 2: coordinate -3.4444"), "{e}");
                }
            }
        }
    }
    for (name, bytes) in files("snapshot") {
        // as the target: an odd first byte, a whole file; even, a payload
        let file = if bytes[0] & 1 == 1 {
            bytes[1..].to_vec()
        } else {
            with_header(&bytes[1..])
        };
        assert!(read_snapshot_bytes(&file, &name).is_ok(), "{name}");
    }
    for (target, format) in [("tracks_thor", Format::Thor), ("tracks_atc", Format::Atc)] {
        for (name, bytes) in files(target) {
            assert!(parse_track_bytes(&bytes, &name, format).is_ok(), "{name}");
        }
    }
    // the inputs with which `tracks_named` found the named-column reader's faults (fuzz
    // README): each is now read or refused as the module documentation says
    for (name, bytes) in files("tracks_named") {
        let (r, body) = read_as_tracks_named(&bytes);
        let loaded = check_named_tracks(&r, &body);
        assert!(loaded || name.contains("regression"), "{name}: {r:?}");
        if name.ends_with("regression-same-number-ids.csv") {
            // ids `1` and `01`: two agents, numbered by first appearance
            let ids: Vec<u64> = r.as_ref().unwrap().iter().map(|t| t.id).collect();
            assert_eq!(ids, [1, 2]);
        } else if name.ends_with("regression-angle-without-speed.csv") {
            // an angle column without a speed column: velocities from the positions
            let tracks = r.as_ref().unwrap();
            assert!(tracks.iter().any(|t| t.rows.iter().any(|r| r.speed > 0.1)));
        } else if name.ends_with("regression-speed-from-positions.csv") {
            let e = r.unwrap_err().to_string();
            assert!(
                e.starts_with("fuzz.csv:3: column 0: speed 19175")
                    && e.ends_with(
                        "of agent Helmet_8 from its positions at lines 2 and 3 is beyond 1000000"
                    ),
                "{e}"
            );
        }
    }
    // rosbag2 recordings written by the `rosbags` package (fuzz README), the mode byte
    // picking the topic as the `tracks_rosbag2` target does; each holds people, and
    // every cut of one is an error naming the file, never a panic
    for (name, bytes) in files("tracks_rosbag2") {
        let topic = match bytes[0] % 3 {
            0 => None,
            1 => Some("/people"),
            _ => Some("/perception/object_recognition/tracking/objects"),
        };
        let tracks = parse_recording(&bytes[1..], &name, topic).expect(&name);
        assert!(
            tracks.iter().map(|t| t.rows.len()).sum::<usize>() >= 2,
            "{name}"
        );
        for n in (0..bytes.len() - 1).step_by(13) {
            let e = parse_recording(&bytes[1..1 + n], &name, topic).unwrap_err();
            assert!(e.to_string().starts_with(&format!("{name}: ")), "{e}");
        }
    }
}

/// An input of the `tracks_named` fuzz target read as the target reads it: the first
/// byte (modulo 4) picks `Format::Magni` (0), `Format::Csv` (1), a column mapping in the
/// first line parsed as `--columns` is (2) or header names of `t, id, x, y, speed,
/// angle, vx, vy` put into `Columns` directly (3); returns the tracks and the bytes read
/// as the file.
fn read_as_tracks_named(data: &[u8]) -> (Result<Vec<Track>, DatasetError>, Vec<u8>) {
    let (mode, rest) = data.split_first().expect("a mode byte");
    let (spec, body) = match rest.iter().position(|&b| b == b'\n') {
        Some(i) => (&rest[..i], &rest[i + 1..]),
        None => (rest, &[][..]),
    };
    let spec = String::from_utf8_lossy(spec);
    let columns = match mode % 4 {
        0 => {
            return (
                parse_track_bytes(rest, "fuzz.csv", Format::Magni),
                rest.to_vec(),
            );
        }
        1 => {
            return (
                parse_track_bytes(rest, "fuzz.csv", Format::Csv),
                rest.to_vec(),
            );
        }
        2 => spec.parse::<Columns>().expect("a seed's mapping parses"),
        _ => {
            let mut names = spec.split(',').map(|s| s.trim().to_string());
            let mut next = || names.next().filter(|s| !s.is_empty());
            Columns {
                t: next().unwrap_or_default(),
                id: next().unwrap_or_default(),
                x: next().unwrap_or_default(),
                y: next().unwrap_or_default(),
                speed: next(),
                angle: next(),
                vx: next(),
                vy: next(),
            }
        }
    };
    let r = parse_named(&String::from_utf8_lossy(body), "fuzz.csv", &columns);
    if let Ok(named) = &r {
        check_names(named);
    }
    (r.map(|n| n.tracks), body.to_vec())
}

/// The invariants the `tracks_named` fuzz target checks: tracks with distinct ids and
/// rows strictly increasing in time within the bounds of the THÖR and ATC readers, or a
/// `DatasetError::Parse` naming `fuzz.csv`, a line of the input and a column no further
/// right than its fields. True when the tracks loaded.
fn check_named_tracks(r: &Result<Vec<Track>, DatasetError>, bytes: &[u8]) -> bool {
    let lines = lines_of(bytes);
    match r {
        Ok(tracks) => {
            let mut ids = HashSet::new();
            let mut rows = 0;
            for t in tracks {
                assert!(ids.insert(t.id), "two tracks with id {}", t.id);
                assert!(!t.rows.is_empty());
                rows += t.rows.len();
                assert!(t.rows.windows(2).all(|w| w[0].t < w[1].t));
                for r in &t.rows {
                    assert!(r.t.is_finite() && r.t.abs() <= MAX_TIME, "{r:?}");
                    assert!(r.position.is_finite(), "{r:?}");
                    assert!(r.position.abs().max_element() <= MAX_POSITION, "{r:?}");
                    assert!((0.0..=MAX_SPEED).contains(&r.speed), "{r:?}");
                    assert!(r.angle.is_finite() && r.angle.abs() <= MAX_ANGLE, "{r:?}");
                }
            }
            assert!(rows < lines, "{rows} rows from {lines} lines");
            true
        }
        Err(DatasetError::Parse {
            file,
            line,
            column,
            message,
        }) => {
            assert_eq!(file, "fuzz.csv");
            assert!(
                *line >= 1 && *line <= lines,
                "line {line} of {lines}: {message}"
            );
            if !message.contains("UTF-8") {
                let fields = bytes
                    .split(|&b| b == b'\n')
                    .map(|l| l.iter().filter(|&&b| b == b',').count() + 1)
                    .max()
                    .unwrap_or(1);
                assert!(*column <= fields, "column {column} of {fields}: {message}");
            }
            false
        }
        Err(e) => panic!("a track error without line and column: {e}"),
    }
}

/// One name per track, each a distinct agent id of the file.
fn check_names(n: &NamedTracks) {
    assert_eq!(n.names.len(), n.tracks.len());
    let mut seen = HashSet::new();
    for ((id, name), t) in n.names.iter().zip(&n.tracks) {
        assert_eq!(*id, t.id);
        assert!(!name.is_empty() && name.trim() == name && !name.contains(','));
        assert!(seen.insert(name), "agent {name} twice");
    }
}

/// The named-column readers (THÖR-MAGNI and CSV with a column mapping) under the same
/// mutations as the THÖR and ATC files: MAGNI rows as `Format::Magni`, the same rows
/// with positions only under a mapping, THÖR1 rows with a header under a mapping naming
/// speed and angle (numeric ids), ATC rows as `Format::Csv` (unix times, large ids).
/// The mappings themselves are mutated too: each is refused with a message or writes
/// back to itself.
#[test]
fn mutated_named_column_files_load_or_name_line_and_column() {
    let magni = head("magni/magni-A-first-16min.csv", 300);
    let thor = [
        b"when,who,px,py,v,dir\n".as_slice(),
        &head("thor1/exp-1-run-2.csv", 300),
    ]
    .concat();
    let atc = [
        b"t,id,x,y,speed,angle\n".as_slice(),
        &head("atc/dev/atc-1024-13_test.csv", 300),
    ]
    .concat();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(13);
    let (mut loaded, mut refused) = (0, 0);
    let inputs: [(&[u8], &str); 4] = [
        (&magni, "magni"),
        (&magni, "t=Time,id=ag_id,x=x,y=y"),
        (&thor, "t=when,id=who,x=px,y=py,speed=v,angle=dir"),
        (&atc, "csv"),
    ];
    for (original, how) in inputs {
        let read = |bytes: &[u8], columns: &str| match columns {
            "magni" => parse_track_bytes(bytes, "fuzz.csv", Format::Magni),
            "csv" => parse_track_bytes(bytes, "fuzz.csv", Format::Csv),
            spec => {
                let columns: Columns = spec.parse().unwrap();
                let r = parse_named(&String::from_utf8_lossy(bytes), "fuzz.csv", &columns);
                if let Ok(named) = &r {
                    check_names(named);
                }
                r.map(|n| n.tracks)
            }
        };
        let tracks = read(original, how).unwrap();
        assert!(
            tracks.len() >= 2 && check_named_tracks(&Ok(tracks), original),
            "{how}"
        );
        for _ in 0..1500 {
            let bytes = mutate(original, &mut rng);
            if check_named_tracks(&read(&bytes, how), &bytes) {
                loaded += 1;
            } else {
                refused += 1;
            }
        }
        if how.contains('=') {
            for _ in 0..300 {
                let spec = String::from_utf8_lossy(&mutate(how.as_bytes(), &mut rng)).into_owned();
                match spec.trim().parse::<Columns>() {
                    Ok(c) => assert_eq!(c.to_string().parse::<Columns>(), Ok(c.clone()), "{spec}"),
                    Err(message) => assert!(!message.is_empty(), "{spec}"),
                }
            }
        }
    }
    assert!(
        loaded > 500 && refused > 2500,
        "{loaded} loaded, {refused} refused"
    );
}

#[test]
fn mutated_time_of_day_sets_load_or_are_refused() {
    // A set of the first 120 rows of the THÖR1 map all day, two one-hour slices cut
    // from it and the rest left to the all-day map.
    let day = read_csv_bytes(&head("thor1/cliffmap.csv", 120), "m.csv").unwrap();
    let part = |keep: i64| {
        let locs: Vec<_> = day
            .locations()
            .iter()
            .filter(|l| ((l.position.x * 2.0).round() as i64).rem_euclid(2) == keep)
            .cloned()
            .collect();
        std::sync::Arc::new(CliffMap::with_grid_step(locs, Some(day.grid().step())).unwrap())
    };
    let mut slices = vec![None; 24];
    slices[8] = Some(part(0));
    slices[17] = Some(part(1));
    let set = MapSet::from_parts(SetParts {
        all_day: std::sync::Arc::new(day.clone()),
        slices,
        slice_length: 3600.0,
        clock_offset: 3600.0,
        smoothing: None,
        observations: Vec::new(),
    })
    .unwrap();
    let bytes = set.to_snapshot_bytes();
    let back = MapSet::from_snapshot_bytes(&bytes, "s.cliff").unwrap();
    assert_eq!(
        back.slices()[17].as_ref().unwrap().locations(),
        set.slices()[17].as_ref().unwrap().locations()
    );
    let payload = &bytes[24..];
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(12);
    let (mut loaded, mut refused) = (0, 0);
    for i in 0..1500 {
        let m = if i % 4 == 0 {
            mutate(&bytes, &mut rng)
        } else {
            let mut p = payload.to_vec();
            for _ in 0..rng.random_range(1..4) {
                let j = rng.random_range(0..p.len());
                p[j] = rng.random();
            }
            if rng.random_range(0..4) == 0 {
                p.truncate(rng.random_range(0..p.len()));
            }
            with_version(SET_SNAPSHOT_VERSION, &p)
        };
        match MapSet::from_snapshot_bytes(&m, "s.cliff") {
            Ok(set) => {
                loaded += 1;
                assert!(set.maps().all(|m| !m.locations().is_empty()));
                // read as one map, the same file gives the set's all-day map
                let one = read_snapshot_bytes(&m, "s.cliff").unwrap();
                assert_eq!(one.locations(), set.all_day().locations());
            }
            Err(MapError::Snapshot { file, .. }) => {
                refused += 1;
                assert_eq!(file, "s.cliff");
            }
            Err(e) => panic!("a snapshot error of the wrong kind: {e}"),
        }
    }
    assert!(
        loaded > 50 && refused > 500,
        "{loaded} loaded, {refused} refused"
    );
}

/// Apply 1 to 4 random binary edits to a recording: bit flips, a 4- or 8-byte field
/// overwritten with an odd value (a length of four billion, zero, NaN, a huge float),
/// a span deleted, the file cut.
fn mutate_binary(bytes: &[u8], rng: &mut impl Rng) -> Vec<u8> {
    const ODD: [[u8; 8]; 5] = [
        [0xff; 8],
        [0; 8],
        [0, 0, 0, 0, 0, 0, 0xf8, 0x7f], // NaN, little-endian
        [0, 0, 0, 0, 0, 0, 0xf0, 0x7f], // infinity
        [0x00, 0x00, 0x00, 0x80, 0x00, 0x00, 0x00, 0x00],
    ];
    let mut b = bytes.to_vec();
    for _ in 0..rng.random_range(1..=4) {
        if b.len() < 16 {
            break;
        }
        let i = rng.random_range(0..b.len() - 8);
        match rng.random_range(0..5) {
            0 | 1 => b[i] ^= 1 << rng.random_range(0..8),
            2 => {
                let width = if rng.random_range(0..2) == 0 { 4 } else { 8 };
                let odd = ODD[rng.random_range(0..ODD.len())];
                b[i..i + width].copy_from_slice(&odd[8 - width..]);
            }
            3 => {
                let j = (i + rng.random_range(1..40)).min(b.len());
                b.drain(i..j);
            }
            _ => b.truncate(i),
        }
    }
    b
}

#[test]
fn mutated_recordings_load_or_name_the_file() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(14);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/tracks_rosbag2");
    let mut outcomes = [0usize; 3]; // loaded, a bad message, a bad recording
    for entry in std::fs::read_dir(root).unwrap() {
        let path = entry.unwrap().path();
        let bytes = std::fs::read(&path).unwrap();
        for _ in 0..1500 {
            let m = mutate_binary(&bytes[1..], &mut rng);
            match parse_recording(&m, "m.mcap", None) {
                Ok(tracks) => {
                    outcomes[0] += 1;
                    for t in &tracks {
                        assert!(t.rows.windows(2).all(|w| w[0].t < w[1].t));
                        for r in &t.rows {
                            assert!(r.t.abs() <= MAX_TIME && r.position.is_finite(), "{r:?}");
                            assert!(r.position.abs().max_element() <= MAX_POSITION);
                            assert!((0.0..=MAX_SPEED).contains(&r.speed), "{r:?}");
                            assert!(r.angle.abs() <= MAX_ANGLE, "{r:?}");
                        }
                    }
                }
                Err(DatasetError::Message { file, index, .. }) => {
                    outcomes[1] += 1;
                    assert_eq!(file, "m.mcap");
                    assert!(index >= 1);
                }
                Err(DatasetError::Recording { file, .. }) => {
                    outcomes[2] += 1;
                    assert_eq!(file, "m.mcap");
                }
                Err(e) => panic!("{e}"),
            }
        }
    }
    // the mutations reach every outcome: CDR fields as well as the MCAP records
    assert!(outcomes.iter().all(|&n| n > 20), "{outcomes:?}");
}
