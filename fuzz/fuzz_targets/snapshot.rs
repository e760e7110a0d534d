//! The snapshot reader. The first byte chooses what the rest is: odd, a whole file
//! (header included: magic, version, length and checksum checks); even, a payload that
//! the target wraps in a valid header (of version 1, a single map, or with bit 1 set
//! version 2, a time-of-day set), so that mutations reach the postcard decoder and the
//! map checks instead of failing the checksum. Every file is read as one map and as a
//! set.
#![no_main]

use cliff::map::{
    MapError, MapSet, SET_SNAPSHOT_VERSION, SNAPSHOT_MAGIC, SNAPSHOT_VERSION, read_snapshot_bytes,
};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let file = if mode & 1 == 1 {
        rest.to_vec()
    } else {
        let mut f = Vec::with_capacity(24 + rest.len());
        f.extend_from_slice(&SNAPSHOT_MAGIC);
        let version = if mode & 2 == 2 {
            SET_SNAPSHOT_VERSION
        } else {
            SNAPSHOT_VERSION
        };
        f.extend_from_slice(&version.to_le_bytes());
        f.extend_from_slice(&(rest.len() as u64).to_le_bytes());
        f.extend_from_slice(&crc32fast::hash(rest).to_le_bytes());
        f.extend_from_slice(rest);
        f
    };
    match read_snapshot_bytes(&file, "fuzz.cliff") {
        Ok(map) => assert!(!map.locations().is_empty()),
        Err(MapError::Snapshot { file, .. }) => assert_eq!(file, "fuzz.cliff"),
        Err(e) => panic!("a snapshot error of the wrong kind: {e}"),
    }
    match MapSet::from_snapshot_bytes(&file, "fuzz.cliff") {
        Ok(set) => {
            assert!(!set.all_day().locations().is_empty());
            assert!(set.maps().all(|m| !m.locations().is_empty()));
        }
        Err(MapError::Snapshot { file, .. }) => assert_eq!(file, "fuzz.cliff"),
        Err(e) => panic!("a set snapshot error of the wrong kind: {e}"),
    }
});
