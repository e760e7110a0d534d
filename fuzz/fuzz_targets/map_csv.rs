//! The published map CSV reader on arbitrary bytes: it loads or names the file, line and
//! column of what is wrong; a map it loads writes back to CSV that loads the same.
#![no_main]

use cliff::map::{MapError, read_csv_bytes, read_csv_str, write_csv_string};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    match read_csv_bytes(data, "fuzz.csv") {
        Ok(map) => {
            let back = read_csv_str(&write_csv_string(&map)).expect("a loaded map writes back");
            assert_eq!(back.locations(), map.locations());
        }
        Err(MapError::Parse { file, .. }) => assert_eq!(file, "fuzz.csv"),
        Err(e) => panic!("a CSV error without file, line and column: {e}"),
    }
});
