//! Our binary map snapshot: postcard with a header.
//!
//! Layout: 8 bytes magic `CLIFFMAP`, format version (u32 LE), payload length (u64 LE),
//! CRC-32 of the payload (u32 LE), then the postcard payload. A file whose magic,
//! version, length or checksum does not match is refused whole.
//!
//! Version 1 ([`SNAPSHOT_VERSION`]) holds one map: its grid step and locations.
//! Version 2 ([`SET_SNAPSHOT_VERSION`]) holds a time-of-day [`MapSet`]: the slice
//! length, the clock offset, how the slices were smoothed, the all-day map and one map
//! (or none) per slice, each as a version-1 payload, and the maps' speed prior
//! ([`SpeedPrior`], learned by `cliff map build`). A single map without a speed prior
//! (and such a set without slices) is still written as version 1, which every build
//! reads; a map with a speed prior is written as version 2 without slices. A version-2
//! file read as one map ([`read_snapshot`], [`CliffMap::load`]) gives its all-day map,
//! with the speed prior.

use std::path::Path;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::timeofday::{MapSet, SetParts, Smoothing, slice_label};
use super::{CliffMap, Location, MAX_MAP_FILE_BYTES, MapError};
use crate::bounded_read::read_at_most;
use crate::framed::{decode_all, frame, unframe};
use crate::motion::SpeedPrior;

/// The first eight bytes of every snapshot.
pub const SNAPSHOT_MAGIC: [u8; 8] = *b"CLIFFMAP";
/// The format version of a snapshot holding one map (what [`CliffMap::save`] writes).
pub const SNAPSHOT_VERSION: u32 = 1;
/// The format version of a snapshot holding a time-of-day [`MapSet`] (what
/// [`MapSet::save`] writes for a set with slices).
pub const SET_SNAPSHOT_VERSION: u32 = 2;

#[derive(Serialize, Deserialize)]
struct Payload {
    grid_step: f64,
    locations: Vec<Location>,
}

impl Payload {
    fn of(map: &CliffMap) -> Self {
        Self {
            grid_step: map.grid().step(),
            locations: map.locations().to_vec(),
        }
    }

    fn into_map(self) -> Result<CliffMap, MapError> {
        CliffMap::with_grid_step(self.locations, Some(self.grid_step))
    }
}

/// The payload of a version-2 snapshot.
#[derive(Serialize, Deserialize)]
struct SetPayload {
    slice_length: f64,
    clock_offset: f64,
    smoothing: Option<Smoothing>,
    all_day: Payload,
    /// One entry per slice: its map, or none (the all-day map stands in).
    slices: Vec<Option<Payload>>,
    /// Moving observations of each slice's own data (empty when unknown).
    observations: Vec<u64>,
    /// The speed prior of every map of the set.
    speed_prior: Option<SpeedPrior>,
}

/// Encode a map as snapshot bytes (version 1; version 2 without slices for a map with
/// a speed prior).
pub fn encode(map: &CliffMap) -> Vec<u8> {
    if map.speed_prior().is_some() {
        return encode_v2(&MapSet::single(map.clone()));
    }
    let body = postcard::to_stdvec(&Payload::of(map))
        .expect("serialising plain data to memory cannot fail");
    frame(&SNAPSHOT_MAGIC, SNAPSHOT_VERSION, &body)
}

/// Encode a map set as snapshot bytes: version 2, or version 1 for a set without slices.
pub(crate) fn encode_set(set: &MapSet) -> Vec<u8> {
    if !set.is_sliced() && set.all_day().speed_prior().is_none() {
        return encode(set.all_day());
    }
    encode_v2(set)
}

fn encode_v2(set: &MapSet) -> Vec<u8> {
    let payload = SetPayload {
        slice_length: set.slice_length(),
        clock_offset: set.clock_offset(),
        smoothing: set.smoothing(),
        all_day: Payload::of(set.all_day()),
        slices: set
            .slices()
            .iter()
            .map(|s| s.as_deref().map(Payload::of))
            .collect(),
        observations: set.observations().to_vec(),
        speed_prior: set.all_day().speed_prior(),
    };
    let body = postcard::to_stdvec(&payload).expect("serialising plain data to memory cannot fail");
    frame(&SNAPSHOT_MAGIC, SET_SNAPSHOT_VERSION, &body)
}

/// What a snapshot holds.
enum Decoded {
    Map(Payload),
    Set(SetPayload),
}

/// Decode snapshot bytes as one map (the all-day map of a set); `file` names the
/// source in errors.
pub fn decode(bytes: &[u8], file: &str) -> Result<CliffMap, MapError> {
    match decode_any(bytes, file)? {
        Decoded::Map(p) => p.into_map().map_err(|e| MapError::Snapshot {
            file: file.to_string(),
            message: e.to_string(),
        }),
        Decoded::Set(p) => {
            let bad = |e: MapError| MapError::Snapshot {
                file: file.to_string(),
                message: format!("all-day map: {e}"),
            };
            let mut map = p.all_day.into_map().map_err(bad)?;
            map.set_speed_prior(p.speed_prior).map_err(bad)?;
            Ok(map)
        }
    }
}

/// Decode snapshot bytes as a map set (a version-1 file gives a set without slices).
pub(crate) fn decode_set(bytes: &[u8], file: &str) -> Result<MapSet, MapError> {
    let bad = |message: String| MapError::Snapshot {
        file: file.to_string(),
        message,
    };
    let p = match decode_any(bytes, file)? {
        Decoded::Map(p) => {
            return p
                .into_map()
                .map(MapSet::single)
                .map_err(|e| bad(e.to_string()));
        }
        Decoded::Set(p) => p,
    };
    // The set's own fields first: a slice count that does not fit the slice length
    // is refused before any slice map is built.
    let count = if p.slices.is_empty() {
        0
    } else {
        crate::map::timeofday::slice_count(p.slice_length).map_err(|e| bad(e.to_string()))?
    };
    if p.slices.len() != count {
        return Err(bad(format!(
            "{} slices, a slice length of {} s makes {count}",
            p.slices.len(),
            p.slice_length
        )));
    }
    let mut all_day = p
        .all_day
        .into_map()
        .map_err(|e| bad(format!("all-day map: {e}")))?;
    all_day
        .set_speed_prior(p.speed_prior)
        .map_err(|e| bad(format!("speed prior: {e}")))?;
    let mut slices = Vec::with_capacity(count);
    for (i, s) in p.slices.into_iter().enumerate() {
        slices.push(match s {
            None => None,
            Some(s) => {
                let mut map = s.into_map().map_err(|e| {
                    bad(format!(
                        "slice {i} ({}): {e}",
                        slice_label(i, p.slice_length)
                    ))
                })?;
                map.set_speed_prior(p.speed_prior)
                    .map_err(|e| bad(format!("speed prior: {e}")))?;
                Some(Arc::new(map))
            }
        });
    }
    MapSet::from_parts(SetParts {
        all_day: Arc::new(all_day),
        slices,
        slice_length: p.slice_length,
        clock_offset: p.clock_offset,
        smoothing: p.smoothing,
        observations: p.observations,
    })
    .map_err(|e| bad(e.to_string()))
}

fn decode_any(bytes: &[u8], file: &str) -> Result<Decoded, MapError> {
    let bad = |message: String| MapError::Snapshot {
        file: file.to_string(),
        message,
    };
    let (version, body) = unframe(
        bytes,
        &SNAPSHOT_MAGIC,
        "a cliff snapshot",
        &[SNAPSHOT_VERSION, SET_SNAPSHOT_VERSION],
    )
    .map_err(bad)?;
    if version == SNAPSHOT_VERSION {
        return Ok(Decoded::Map(decode_all(body, "payload").map_err(bad)?));
    }
    Ok(Decoded::Set(
        decode_all(body, "map set payload").map_err(bad)?,
    ))
}

/// Read a snapshot file (at most [`MAX_MAP_FILE_BYTES`]; see [`read_snapshot_bytes`]).
pub fn read_snapshot(path: &Path) -> Result<CliffMap, MapError> {
    let name = path.display().to_string();
    let bytes = read_at_most(path, MAX_MAP_FILE_BYTES).map_err(|source| MapError::Io {
        file: name.clone(),
        source,
    })?;
    decode(&bytes, &name)
}

/// Read a map from snapshot bytes; `file` names the source in errors. A version-2 file
/// (a time-of-day [`MapSet`]) gives its all-day map.
///
/// The header is checked before the payload is decoded (magic, version, the payload
/// length against the bytes present, the checksum); decoding allocates at most in
/// proportion to the payload (a length prefix is never trusted for an allocation), and
/// the map gets the checks of [`CliffMap::with_grid_step`].
pub fn read_snapshot_bytes(bytes: &[u8], file: &str) -> Result<CliffMap, MapError> {
    decode(bytes, file)
}

/// Write a snapshot file.
pub fn write_snapshot(map: &CliffMap, path: &Path) -> Result<(), MapError> {
    std::fs::write(path, encode(map)).map_err(|source| MapError::Io {
        file: path.display().to_string(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_speed_prior_round_trips_as_version_2_and_a_map_without_one_stays_version_1() {
        use crate::motion::SpeedPrior;
        let prior = SpeedPrior {
            mean: 1.18,
            keep: 0.63,
            pairs: 15954,
        };
        let mut map = CliffMap::demo();
        assert_eq!(encode(&map)[8..12], SNAPSHOT_VERSION.to_le_bytes());
        map.set_speed_prior(Some(prior)).unwrap();
        let bytes = encode(&map);
        assert_eq!(bytes[8..12], SET_SNAPSHOT_VERSION.to_le_bytes());
        let back = decode(&bytes, "p").unwrap();
        assert_eq!(back.speed_prior(), Some(prior));
        assert_eq!(back.locations(), map.locations());
        let set = decode_set(&bytes, "p").unwrap();
        assert!(!set.is_sliced());
        assert_eq!(set.all_day().speed_prior(), Some(prior));
        // the set re-encodes to the same bytes
        assert_eq!(encode_set(&set), bytes);
        // a damaged prior is refused with the file's name
        let mut bad = set.clone();
        bad.set_speed_prior(None).unwrap();
        let body = postcard::to_stdvec(&SetPayload {
            slice_length: crate::map::timeofday::DAY_SECONDS,
            clock_offset: 0.0,
            smoothing: None,
            all_day: Payload::of(&CliffMap::demo()),
            slices: vec![],
            observations: vec![],
            speed_prior: Some(SpeedPrior {
                mean: f64::NAN,
                ..prior
            }),
        })
        .unwrap();
        let e = decode(
            &frame(&SNAPSHOT_MAGIC, SET_SNAPSHOT_VERSION, &body),
            "bad.cliff",
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("bad.cliff") && e.to_string().contains("speed prior"),
            "{e}"
        );
    }

    #[test]
    fn round_trip_is_exact() {
        let m = CliffMap::demo();
        let back = decode(&encode(&m), "x").unwrap();
        assert_eq!(back.locations(), m.locations());
        assert_eq!(back.grid().step(), m.grid().step());
    }

    /// A snapshot file around `body`, with a correct header.
    fn wrap(body: &[u8]) -> Vec<u8> {
        let mut out = SNAPSHOT_MAGIC.to_vec();
        out.extend_from_slice(&SNAPSHOT_VERSION.to_le_bytes());
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
        out.extend_from_slice(&crc32fast::hash(body).to_le_bytes());
        out.extend_from_slice(body);
        out
    }

    #[test]
    fn refuses_absurd_steps_and_positions() {
        let one = CliffMap::demo().locations()[0].clone();
        let payload = |grid_step: f64, locations: Vec<Location>| {
            postcard::to_stdvec(&Payload {
                grid_step,
                locations,
            })
            .unwrap()
        };
        // The known case: a one-location snapshot with a grid step of 1e300 was accepted.
        let e = decode(&wrap(&payload(1e300, vec![one.clone()])), "s.cliff")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.cliff") && e.contains("grid step 1e300 m is not in [0.001, 1000] m"),
            "{e}"
        );
        assert!(decode(&wrap(&payload(1.0, vec![one.clone()])), "s").is_ok());
        let mut far = one.clone();
        far.position.x = 1e20;
        let e = decode(&wrap(&payload(1.0, vec![one.clone(), far])), "s")
            .unwrap_err()
            .to_string();
        assert!(e.contains("location 1") && e.contains("beyond"), "{e}");
        let mut wide = one;
        wide.components = vec![wide.components[0]; crate::map::MAX_COMPONENTS + 1];
        let e = decode(&wrap(&payload(1.0, vec![wide])), "s")
            .unwrap_err()
            .to_string();
        assert!(e.contains("65 components, at most 64"), "{e}");
    }

    #[test]
    fn huge_length_prefixes_do_not_allocate() {
        // A location list claiming 2^60 entries (and then one claiming 2^32 components):
        // the decoder runs out of bytes long before it could allocate that much.
        let body = postcard::to_stdvec(&(1.0f64, 1u64 << 60)).unwrap();
        let e = decode(&wrap(&body), "s").unwrap_err().to_string();
        assert!(e.contains("payload"), "{e}");
        let mut body = postcard::to_stdvec(&(1.0f64, 1u64, 0.0f64, 0.0f64)).unwrap();
        body.extend(postcard::to_stdvec(&(1u64 << 32)).unwrap());
        let e = decode(&wrap(&body), "s").unwrap_err().to_string();
        assert!(e.contains("payload"), "{e}");
    }

    /// A set of the demo map (all day) and two slices of one hour cut from it.
    fn demo_set() -> MapSet {
        let day = CliffMap::demo();
        let part = |keep: usize| {
            let locs: Vec<Location> = day
                .locations()
                .iter()
                .filter(|l| (l.position.x.round() as i64).rem_euclid(3) as usize == keep)
                .cloned()
                .collect();
            Arc::new(CliffMap::with_grid_step(locs, Some(day.grid().step())).unwrap())
        };
        let mut slices = vec![None; 24];
        slices[9] = Some(part(0));
        slices[14] = Some(part(1));
        MapSet::from_parts(SetParts {
            all_day: Arc::new(day),
            slices,
            slice_length: 3600.0,
            clock_offset: 32400.0,
            smoothing: Some(Smoothing::default()),
            observations: (0..24).map(|i| i * 100).collect(),
        })
        .unwrap()
    }

    fn same_maps(a: &CliffMap, b: &CliffMap) {
        assert_eq!(a.locations(), b.locations());
        assert_eq!(a.grid().step(), b.grid().step());
    }

    #[test]
    fn sets_round_trip_exactly_as_version_2() {
        let set = demo_set();
        let bytes = encode_set(&set);
        assert_eq!(bytes[8..12], SET_SNAPSHOT_VERSION.to_le_bytes());
        let back = decode_set(&bytes, "s.cliff").unwrap();
        same_maps(back.all_day(), set.all_day());
        assert_eq!(back.slices().len(), 24);
        for (a, b) in back.slices().iter().zip(set.slices()) {
            match (a, b) {
                (Some(a), Some(b)) => same_maps(a, b),
                (None, None) => {}
                _ => panic!("a slice changed from a map to none or back"),
            }
        }
        assert_eq!(back.slice_length(), 3600.0);
        assert_eq!(back.clock_offset(), 32400.0);
        assert_eq!(back.smoothing(), Some(Smoothing::default()));
        assert_eq!(back.observations(), set.observations());
        // Read as one map, a set is its all-day map.
        same_maps(&decode(&bytes, "s.cliff").unwrap(), set.all_day());
        // A set without slices is written as version 1, which every build reads.
        let single = encode_set(&MapSet::single(CliffMap::demo()));
        assert_eq!(single, encode(&CliffMap::demo()));
    }

    /// A version-1 snapshot as the version-1 encoder wrote it (the bytes must keep
    /// loading, as one map and as a set): two locations on a 0.5 m grid: (0, 0) with one component (theta 1, rho 1.25, cov
    /// [0.5, 0.125, 0.125, 0.25], weight 1, observation ratio 1) and (0.5, -1) with two
    /// of the same shape (theta 0.5 and 3, weights 0.75 and 0.25, observation ratio
    /// 0.25); motion ratios 1. Written by the version-1 encoder.
    const V1_FILE: &[u8] = &[
        0x43, 0x4c, 0x49, 0x46, 0x46, 0x4d, 0x41, 0x50, 0x01, 0x00, 0x00, 0x00, 0xf3, 0x00, 0x00,
        0x00, 0x00, 0x00, 0x00, 0x00, 0x84, 0x08, 0x45, 0x52, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
        0xe0, 0x3f, 0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
        0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x3f, 0x00, 0x00,
        0x00, 0x00, 0x00, 0x00, 0xf4, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f, 0x00,
        0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x3f,
        0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xd0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0,
        0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
        0xf0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00,
        0x00, 0xf0, 0xbf, 0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f, 0x00, 0x00, 0x00,
        0x00, 0x00, 0x00, 0xf4, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f, 0x00, 0x00,
        0x00, 0x00, 0x00, 0x00, 0xc0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x3f, 0x00,
        0x00, 0x00, 0x00, 0x00, 0x00, 0xd0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe8, 0x3f,
        0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08, 0x40, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf4,
        0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
        0xc0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00,
        0x00, 0xd0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xd0, 0x3f, 0x00, 0x00, 0x00, 0x00,
        0x00, 0x00, 0xf0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xd0, 0x3f,
    ];

    #[test]
    fn version_1_files_still_load() {
        let map = decode(V1_FILE, "v1.cliff").unwrap();
        assert_eq!(map.locations().len(), 2);
        assert_eq!(map.grid().step(), 0.5);
        let l = &map.locations()[1];
        assert_eq!((l.position.x, l.position.y), (0.5, -1.0));
        assert_eq!(l.components.len(), 2);
        assert_eq!(l.components[1].theta, 3.0);
        assert_eq!(l.observation_ratio, 0.25);
        // the current encoder writes the same bytes
        assert_eq!(encode(&map), V1_FILE);
        let set = decode_set(V1_FILE, "v1.cliff").unwrap();
        assert!(!set.is_sliced());
        assert_eq!(set.all_day().locations(), map.locations());
    }

    #[test]
    fn damaged_sets_are_refused_whole() {
        let bytes = encode_set(&demo_set());
        // truncated, flipped, trailing bytes: refused by the header checks
        let e = decode_set(&bytes[..bytes.len() - 1], "s.cliff")
            .unwrap_err()
            .to_string();
        assert!(e.contains("s.cliff") && e.contains("truncated"), "{e}");
        let mut b = bytes.clone();
        let mid = b.len() / 2;
        b[mid] ^= 0x10;
        assert!(
            decode_set(&b, "s")
                .unwrap_err()
                .to_string()
                .contains("checksum")
        );
        let mut b = bytes.clone();
        b[8] = 3;
        assert!(
            decode_set(&b, "s")
                .unwrap_err()
                .to_string()
                .contains("version 3")
        );
        // a valid header around a payload with a slice count that does not fit
        let set = demo_set();
        let mut payload = SetPayload {
            slice_length: 3600.0,
            clock_offset: 0.0,
            smoothing: None,
            all_day: Payload::of(set.all_day()),
            slices: (0..23).map(|_| None).collect(),
            observations: Vec::new(),
            speed_prior: None,
        };
        let wrap2 = |p: &SetPayload| {
            frame(
                &SNAPSHOT_MAGIC,
                SET_SNAPSHOT_VERSION,
                &postcard::to_stdvec(p).unwrap(),
            )
        };
        let e = decode_set(&wrap2(&payload), "s").unwrap_err().to_string();
        assert!(
            e.contains("23 slices, a slice length of 3600 s makes 24"),
            "{e}"
        );
        payload.slice_length = 1000.0;
        let e = decode_set(&wrap2(&payload), "s").unwrap_err().to_string();
        assert!(e.contains("does not divide the day"), "{e}");
        // a bad map in a slice is named by its slice
        payload.slice_length = 3600.0;
        payload.slices = (0..24).map(|_| None).collect();
        let mut far = Payload::of(set.all_day());
        far.locations[0].position.x = 1e20;
        payload.slices[13] = Some(far);
        let e = decode_set(&wrap2(&payload), "s").unwrap_err().to_string();
        assert!(e.contains("slice 13 (13:00-14:00): location 0"), "{e}");
        // ... and a bad all-day map as the all-day map, also when read as one map
        payload.slices[13] = None;
        payload.all_day.grid_step = 1e300;
        let e = decode_set(&wrap2(&payload), "s").unwrap_err().to_string();
        assert!(
            e.contains("all-day map: ") && e.contains("grid step 1e300"),
            "{e}"
        );
        let e = decode(&wrap2(&payload), "s").unwrap_err().to_string();
        assert!(
            e.contains("all-day map: ") && e.contains("grid step 1e300"),
            "{e}"
        );
        // a clock offset beyond a day
        payload.all_day.grid_step = set.all_day().grid().step();
        payload.clock_offset = 1e9;
        let e = decode_set(&wrap2(&payload), "s").unwrap_err().to_string();
        assert!(e.contains("clock offset"), "{e}");
        // trailing bytes after a valid set payload
        payload.clock_offset = 0.0;
        let mut body = postcard::to_stdvec(&payload).unwrap();
        body.push(0);
        let e = decode_set(&frame(&SNAPSHOT_MAGIC, SET_SNAPSHOT_VERSION, &body), "s")
            .unwrap_err()
            .to_string();
        assert!(e.contains("1 trailing bytes"), "{e}");
    }

    #[test]
    fn refuses_damaged_files_whole() {
        let bytes = encode(&CliffMap::demo());
        let e = decode(&bytes[..bytes.len() - 3], "f.cliff")
            .unwrap_err()
            .to_string();
        assert!(e.contains("f.cliff") && e.contains("truncated"), "{e}");
        let e = decode(&bytes[..10], "f").unwrap_err().to_string();
        assert!(e.contains("header"), "{e}");
        let mut b = bytes.clone();
        let mid = b.len() / 2;
        b[mid] ^= 0x40;
        assert!(
            decode(&b, "f")
                .unwrap_err()
                .to_string()
                .contains("checksum")
        );
        let mut b = bytes.clone();
        b[0] = b'X';
        assert!(decode(&b, "f").unwrap_err().to_string().contains("magic"));
        let mut b = bytes.clone();
        b[8] = 9;
        assert!(
            decode(&b, "f")
                .unwrap_err()
                .to_string()
                .contains("version 9")
        );
    }
}
