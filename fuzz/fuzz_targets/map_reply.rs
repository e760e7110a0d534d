//! Map replies over zenoh (a followed map's versions): `decode_map_reply` on arbitrary
//! bytes, then `MapSet::from_snapshot_bytes` on the snapshot of a reply it takes.
//!
//! First byte odd: the rest is a whole reply (magic, layout version, status, version,
//! length, checksum, snapshot); even: the rest is a snapshot the target wraps in a valid
//! header, so mutations reach the snapshot decoder. The bound is 1 MiB, as a follower's
//! `--follow-max-mib 1`.
#![no_main]

use cliff::map::MapSet;
use cliff_client::map_wire::{MapStatus, decode_map_query, decode_map_reply, encode_map_reply};
use libfuzzer_sys::fuzz_target;

const MAX: usize = 1 << 20;

fuzz_target!(|data: &[u8]| {
    let Some((&first, rest)) = data.split_first() else {
        return;
    };
    let _ = decode_map_query(rest);
    let wrapped;
    let bytes = if first & 1 == 1 {
        rest
    } else {
        let mut out = Vec::new();
        encode_map_reply(MapStatus::Newer, u32::from(first), rest, &mut out);
        wrapped = out;
        &wrapped[..]
    };
    match decode_map_reply(bytes, MAX) {
        Ok((h, snapshot)) => {
            assert_eq!(h.len as usize, snapshot.len());
            assert!(snapshot.len() <= MAX);
            if h.status == MapStatus::Newer {
                let _ = MapSet::from_snapshot_bytes(snapshot, "fuzz");
            }
        }
        Err(e) => assert!(!e.to_string().is_empty()),
    }
});
