//! The snapshot reader. The first byte chooses what the rest is: odd, a whole file
//! (header included: magic, version, length and checksum checks); even, a payload that
//! the target wraps in a valid header, so that mutations reach the postcard decoder and
//! the map checks instead of failing the checksum.
#![no_main]

use cliff::map::{MapError, SNAPSHOT_MAGIC, SNAPSHOT_VERSION, read_snapshot_bytes};
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
        f.extend_from_slice(&SNAPSHOT_VERSION.to_le_bytes());
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
});
