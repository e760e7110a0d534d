//! Map versions over zenoh: the message with which a daemon hands the newest version of
//! a map it serves to another daemon that follows it (`cliffd --follow NAME=ENDPOINT`,
//! `docs/zenoh-protocol.md`, "Map versions").
//!
//! The follower sends a query on [`map_key_for`] whose payload is the version it holds
//! (4 bytes, little-endian; no payload: none). The answer is one reply: a
//! [`MAP_HEADER_BYTES`]-byte header, then (status [`MapStatus::Newer`]) the map's
//! snapshot bytes (`cliff::map::MapSet::to_snapshot_bytes`), whose length and FNV-1a
//! checksum the header carries. [`decode_map_reply`] checks both, and the size against the
//! follower's bound, before the snapshot is read.

use std::fmt;

/// The first four bytes of a map reply.
pub const MAP_MAGIC: [u8; 4] = *b"CLMV";

/// The version of the map reply's layout.
pub const MAP_WIRE_VERSION: u32 = 1;

/// Bytes of a map reply's header.
pub const MAP_HEADER_BYTES: usize = 32;

/// What a map reply says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum MapStatus {
    /// A newer version than the one the query holds: its snapshot follows the header.
    Newer = 0,
    /// The query holds the version served (or a newer one): no bytes follow.
    Current = 1,
    /// The daemon serves no map of that name.
    UnknownMap = 2,
}

impl MapStatus {
    fn from_code(c: u32) -> Option<MapStatus> {
        match c {
            0 => Some(MapStatus::Newer),
            1 => Some(MapStatus::Current),
            2 => Some(MapStatus::UnknownMap),
            _ => None,
        }
    }
}

/// The header of a map reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MapReply {
    /// What the reply says.
    pub status: MapStatus,
    /// The version the daemon serves (0: the map as loaded).
    pub version: u32,
    /// Bytes of the snapshot after the header (0 unless [`MapStatus::Newer`]).
    pub len: u64,
    /// FNV-1a (64 bits) of those bytes.
    pub checksum: u64,
}

/// Why a map reply was not taken.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MapWireError {
    /// Shorter than the header.
    TooShort {
        /// Bytes received.
        len: usize,
    },
    /// Not a map reply (magic), or another layout version.
    NotAMapReply,
    /// An unknown status code.
    Status(u32),
    /// The header's length differs from the bytes that follow it.
    Length {
        /// Length in the header.
        header: u64,
        /// Bytes after the header.
        found: usize,
    },
    /// The snapshot is larger than the follower accepts.
    TooLarge {
        /// Its length.
        len: u64,
        /// The bound.
        max: usize,
    },
    /// The bytes' checksum differs from the header's.
    Checksum {
        /// In the header.
        header: u64,
        /// Of the bytes.
        found: u64,
    },
}

impl fmt::Display for MapWireError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MapWireError::TooShort { len } => write!(
                f,
                "map reply of {len} bytes is shorter than its {MAP_HEADER_BYTES}-byte header"
            ),
            MapWireError::NotAMapReply => {
                write!(f, "not a map reply of layout version {MAP_WIRE_VERSION}")
            }
            MapWireError::Status(c) => write!(f, "map reply status {c} unknown"),
            MapWireError::Length { header, found } => write!(
                f,
                "map reply says {header} bytes of snapshot, {found} follow"
            ),
            MapWireError::TooLarge { len, max } => {
                write!(f, "map snapshot of {len} bytes, at most {max} are accepted")
            }
            MapWireError::Checksum { header, found } => write!(
                f,
                "map snapshot checksum {found:016x} differs from the reply's {header:016x}"
            ),
        }
    }
}

impl std::error::Error for MapWireError {}

/// The key a daemon serving the service `service` answers map queries for `map` on.
pub fn map_key_for(service: &str, map: &str) -> String {
    format!("{service}/maps/{map}")
}

/// The key a daemon serving the service `service` takes observations on over zenoh.
pub fn observe_key_for(service: &str) -> String {
    format!("{service}/observe")
}

/// FNV-1a, 64 bits, of `bytes`.
pub fn checksum(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf29ce484222325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x100000001b3);
    }
    h
}

/// The payload of a follower's query: the version it holds (`None`: none yet).
pub fn encode_map_query(held: Option<u32>) -> Vec<u8> {
    held.map(|v| v.to_le_bytes().to_vec()).unwrap_or_default()
}

/// The version a map query holds: `None` for no payload or one that is not 4 bytes.
pub fn decode_map_query(bytes: &[u8]) -> Option<u32> {
    bytes.try_into().ok().map(u32::from_le_bytes)
}

/// Append a map reply to `out` after clearing it: `snapshot` follows the header for
/// [`MapStatus::Newer`] (pass `&[]` otherwise).
pub fn encode_map_reply(status: MapStatus, version: u32, snapshot: &[u8], out: &mut Vec<u8>) {
    out.clear();
    out.reserve(MAP_HEADER_BYTES + snapshot.len());
    out.extend_from_slice(&MAP_MAGIC);
    out.extend_from_slice(&MAP_WIRE_VERSION.to_le_bytes());
    out.extend_from_slice(&(status as u32).to_le_bytes());
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(snapshot.len() as u64).to_le_bytes());
    out.extend_from_slice(&checksum(snapshot).to_le_bytes());
    out.extend_from_slice(snapshot);
}

/// Read a map reply: its header and the snapshot bytes, checked (layout, length, at most
/// `max_bytes` of snapshot, checksum) before anything else reads them.
pub fn decode_map_reply(bytes: &[u8], max_bytes: usize) -> Result<(MapReply, &[u8]), MapWireError> {
    if bytes.len() < MAP_HEADER_BYTES {
        return Err(MapWireError::TooShort { len: bytes.len() });
    }
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    let u64_at = |i: usize| u64::from_le_bytes(bytes[i..i + 8].try_into().expect("8 bytes"));
    if bytes[..4] != MAP_MAGIC || u32_at(4) != MAP_WIRE_VERSION {
        return Err(MapWireError::NotAMapReply);
    }
    let status = MapStatus::from_code(u32_at(8)).ok_or(MapWireError::Status(u32_at(8)))?;
    let reply = MapReply {
        status,
        version: u32_at(12),
        len: u64_at(16),
        checksum: u64_at(24),
    };
    let rest = &bytes[MAP_HEADER_BYTES..];
    if reply.len > max_bytes as u64 {
        return Err(MapWireError::TooLarge {
            len: reply.len,
            max: max_bytes,
        });
    }
    if reply.len != rest.len() as u64 {
        return Err(MapWireError::Length {
            header: reply.len,
            found: rest.len(),
        });
    }
    let found = checksum(rest);
    if found != reply.checksum {
        return Err(MapWireError::Checksum {
            header: reply.checksum,
            found,
        });
    }
    Ok((reply, rest))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_replies_round_trip_and_damage_is_refused() {
        let snapshot: Vec<u8> = (0..1000u32).map(|i| (i * 7 % 251) as u8).collect();
        let mut out = Vec::new();
        encode_map_reply(MapStatus::Newer, 12, &snapshot, &mut out);
        assert_eq!(out.len(), MAP_HEADER_BYTES + 1000);
        let (h, bytes) = decode_map_reply(&out, 1000).unwrap();
        assert_eq!((h.status, h.version, h.len), (MapStatus::Newer, 12, 1000));
        assert_eq!(bytes, &snapshot[..]);
        // the bound holds before the checksum is computed
        assert_eq!(
            decode_map_reply(&out, 999),
            Err(MapWireError::TooLarge {
                len: 1000,
                max: 999
            })
        );
        let mut bad = out.clone();
        bad[MAP_HEADER_BYTES + 500] ^= 1;
        assert!(matches!(
            decode_map_reply(&bad, 1000),
            Err(MapWireError::Checksum { .. })
        ));
        assert!(matches!(
            decode_map_reply(&out[..out.len() - 1], 1000),
            Err(MapWireError::Length { .. })
        ));
        assert_eq!(
            decode_map_reply(&out[..10], 1000),
            Err(MapWireError::TooShort { len: 10 })
        );
        let mut bad = out.clone();
        bad[0] = b'X';
        assert_eq!(
            decode_map_reply(&bad, 1000),
            Err(MapWireError::NotAMapReply)
        );
        let mut bad = out.clone();
        bad[8] = 9;
        assert_eq!(decode_map_reply(&bad, 1000), Err(MapWireError::Status(9)));
        encode_map_reply(MapStatus::Current, 3, &[], &mut out);
        let (h, bytes) = decode_map_reply(&out, 0).unwrap();
        assert_eq!(
            (h.status, h.version, bytes.len()),
            (MapStatus::Current, 3, 0)
        );
        // FNV-1a's published value for "a"
        assert_eq!(checksum(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(decode_map_query(&encode_map_query(Some(7))), Some(7));
        assert_eq!(decode_map_query(&encode_map_query(None)), None);
    }
}
