//! A trajectory file's format recognised from the file itself (`Format::detect`,
//! `read_many_as` without a format, the commands without `--format`): the shipped files,
//! files that could be either THÖR or ATC, and files that are none of the formats.

use std::path::{Path, PathBuf};

use cliff::tracks::{DatasetError, Format, read_many_as, read_tracks};

mod common;
use common::{cliff, data};

fn files(dir: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(data(dir))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    v.sort();
    v
}

fn detect(p: &str) -> Result<Format, DatasetError> {
    Format::detect(Path::new(&data(p)))
}

#[test]
fn detects_each_shipped_trajectory_file() {
    assert_eq!(detect("thor1/exp-1-run-2.csv").unwrap(), Format::Thor);
    assert_eq!(detect("thor3/exp-3-run-2.csv").unwrap(), Format::Thor);
    assert_eq!(detect("magni/magni-A.csv").unwrap(), Format::Magni);
    assert_eq!(
        detect("magni/magni-A-first-16min.csv").unwrap(),
        Format::Magni
    );
    let (train, dev) = (files("atc/train"), files("atc/dev"));
    assert_eq!((train.len(), dev.len()), (11, 6));
    for f in train.iter().chain(&dev) {
        assert_eq!(Format::detect(f).unwrap(), Format::Atc, "{}", f.display());
    }
}

#[test]
fn a_headerless_file_whose_times_could_be_either_names_thor_and_atc() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("either.csv");
    std::fs::write(&f, "5000000,1,0,0,1,0\n5000001,1,1,0,1,0\n").unwrap();
    let e = Format::detect(&f).unwrap_err();
    match &e {
        DatasetError::Unrecognised { file, choices, .. } => {
            assert!(file.ends_with("either.csv"), "{file}");
            assert_eq!(choices, &[Format::Thor, Format::Atc]);
        }
        other => panic!("{other}"),
    }
    let msg = e.to_string();
    assert!(
        msg.contains("either.csv: the format is not recognised")
            && msg.contains("first time 5000000")
            && msg.ends_with("name it: thor or atc"),
        "{msg}"
    );
    // named, it reads: THÖR and ATC are the same six-column reader
    for format in [Format::Thor, Format::Atc] {
        assert_eq!(read_tracks(&f, format).unwrap()[0].rows.len(), 2);
    }
    // the time scale names the one recognised
    for (text, format) in [
        ("0.4,1,0,0,1,0\n", Format::Thor),
        ("-3,1,0,0,1,0\n", Format::Thor),
        ("999999,1,0,0,1,0\n", Format::Thor),
        ("100000000,1,0,0,1,0\n", Format::Atc),
        ("1351044035.976,1,0,0,1,0\n", Format::Atc),
    ] {
        assert_eq!(
            Format::detect_bytes(text.as_bytes(), "t").unwrap(),
            format,
            "{text}"
        );
    }
    for text in [
        "1000000,1,0,0,1,0\n",
        "99999999,1,0,0,1,0\n",
        "-5e6,1,0,0,1,0\n",
    ] {
        assert!(
            matches!(Format::detect_bytes(text.as_bytes(), "t"),
                Err(DatasetError::Unrecognised { ref choices, .. }) if choices.len() == 2),
            "{text}"
        );
    }
}

#[test]
fn an_unknown_file_is_an_error_naming_the_file_and_every_format() {
    let every = "name it: thor, atc, magni, csv or rosbag2";
    // a CLiFF-map file: 11 headerless columns
    let e = detect("thor1/cliffmap.csv").unwrap_err().to_string();
    assert!(
        e.contains("thor1/cliffmap.csv: the format is not recognised: its first row holds 11 values and no header")
            && e.ends_with(every),
        "{e}"
    );
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes, why) in [
        ("empty.csv", &b"\n \n"[..], "no rows"),
        (
            "picture.png",
            &b"\x89PNG\r\n\x1a\n\xff\xfe"[..],
            "not UTF-8 text",
        ),
        (
            "five.csv",
            &b"0,1,2,3,4\n"[..],
            "holds 5 values and no header",
        ),
    ] {
        let f = dir.path().join(name);
        std::fs::write(&f, bytes).unwrap();
        let e = Format::detect(&f).unwrap_err().to_string();
        assert!(
            e.contains(name) && e.contains(why) && e.ends_with(every),
            "{e}"
        );
    }
    // a folder without recordings, a file that does not exist
    let e = Format::detect(dir.path()).unwrap_err().to_string();
    assert!(e.contains("a folder without .mcap files"), "{e}");
    let e = Format::detect(&dir.path().join("missing.csv")).unwrap_err();
    assert!(matches!(e, DatasetError::Io { .. }), "{e}");
}

#[test]
fn headers_recordings_and_the_start_only() {
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str, bytes: &[u8]| {
        let f = dir.path().join(name);
        std::fs::write(&f, bytes).unwrap();
        Format::detect(&f).unwrap()
    };
    assert_eq!(at("p.csv", b"t,id,x,y\n0,1,0,0\n"), Format::Csv);
    assert_eq!(
        at("q.csv", b"\n\nwhen,who,east,north\r\n0,a,0,0\r\n"),
        Format::Csv
    );
    assert_eq!(
        at("m.csv", b"Time,ag_id,x,y,speed,x_speed,y_speed\n"),
        Format::Magni
    );
    assert_eq!(at("r.mcap", b"not yet recorded"), Format::Rosbag2);
    assert_eq!(at("r.bin", b"\x89MCAP0\r\n"), Format::Rosbag2);
    // a bag's folder
    let bag = dir.path().join("bag");
    std::fs::create_dir(&bag).unwrap();
    std::fs::write(bag.join("bag_0.mcap"), b"\x89MCAP0\r\n").unwrap();
    assert_eq!(Format::detect(&bag).unwrap(), Format::Rosbag2);
    // only the start is read: a THÖR row, then 2 GiB (a sparse file costs no disk)
    let big = dir.path().join("big.csv");
    std::fs::write(&big, b"0.02,12001,-0.046,-3.443,0.141,2.356\n").unwrap();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&big)
        .unwrap()
        .set_len(2 << 30)
        .unwrap();
    assert_eq!(Format::detect(&big).unwrap(), Format::Thor);
}

#[test]
fn files_of_different_formats_are_each_read_in_their_own() {
    let thor = PathBuf::from(data("thor1/exp-1-run-2.csv"));
    let dev = PathBuf::from(data("atc/dev/atc-1024-9_test.csv"));
    let dir = tempfile::tempdir().unwrap();
    let named = dir.path().join("named.csv");
    std::fs::write(&named, "t,id,x,y\n0,5,0,0\n1,5,1,0\n").unwrap();
    let both = read_many_as(&[&thor, &dev, &named], None, None, None).unwrap();
    let one = |p: &Path, f| read_tracks(p, f).unwrap();
    let apart = [
        one(&thor, Format::Thor),
        one(&dev, Format::Atc),
        one(&named, Format::Csv),
    ]
    .concat();
    assert_eq!(both, apart);
    // a named format is used for every file, as before
    let e = read_many_as(&[&thor, &named], Some(Format::Thor), None, None).unwrap_err();
    assert!(e.to_string().contains("named.csv:1"), "{e}");
}

#[test]
fn map_build_without_format_writes_the_map_of_format_thor() {
    let dir = tempfile::tempdir().unwrap();
    let thor = data("thor1/exp-1-run-2.csv");
    let mut maps = Vec::new();
    for (out, format) in [("detected.csv", None), ("named.csv", Some("thor"))] {
        let out = dir.path().join(out).display().to_string();
        let mut args = vec!["map", "build", "--tracks", &thor, "--out", &out, "--quiet"];
        if let Some(f) = format {
            args.extend(["--format", f]);
        }
        let o = cliff(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        maps.push(std::fs::read(&out).unwrap());
    }
    assert!(!maps[0].is_empty());
    assert!(maps[0] == maps[1], "the maps differ");
}

#[test]
fn the_commands_name_the_format_options_of_an_ambiguous_file() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("either.csv");
    std::fs::write(&f, "5000000,1,0,0,1,0\n5000000.4,1,0.5,0,1.2,0\n").unwrap();
    let f = f.display().to_string();
    let out = dir.path().join("m.csv").display().to_string();
    let o = cliff(&["map", "build", "--tracks", &f, "--out", &out]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("either.csv: the format is not recognised")
            && e.contains("give --format thor or --format atc"),
        "{e}"
    );
    let o = cliff(&["eval", "--tracks", &f]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && e.contains("give --format thor or --format atc"),
        "{e}"
    );
    // named, it is read
    let o = cliff(&[
        "map", "build", "--tracks", &f, "--format", "atc", "--out", &out,
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!e.contains("not recognised"), "{e}");
}
