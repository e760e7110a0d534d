//! The ATC trajectory reader on arbitrary bytes: it reads tracks whose rows keep their
//! invariants, or names the file, line and column of what is wrong.
#![no_main]

use cliff::tracks::rosbag2::is_mcap;
use cliff::tracks::{DatasetError, Format, parse_track_bytes};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // bytes that begin with the MCAP magic are a rosbag2 recording whatever the format
    // asked for (`parse_track_bytes`): the target tracks_rosbag2 reads those
    if is_mcap(data) {
        return;
    }
    match parse_track_bytes(data, "fuzz.csv", Format::Atc) {
        Ok(tracks) => {
            for t in &tracks {
                assert!(!t.rows.is_empty());
                assert!(t.rows.windows(2).all(|w| w[0].t < w[1].t));
                assert!(
                    t.rows
                        .iter()
                        .all(|r| r.position.is_finite() && r.speed >= 0.0)
                );
            }
        }
        Err(DatasetError::Parse { file, line, .. }) => {
            assert_eq!(file, "fuzz.csv");
            assert!(line >= 1);
        }
        Err(e) => panic!("a track error without line and column: {e}"),
    }
});
