//! The rosbag2 recording reader (MCAP, CDR) on arbitrary bytes: it reads tracks whose
//! rows keep their invariants, or fails with an error naming the file (and, for a bad
//! message, the topic, the message and the field); it never panics, and a length field
//! never allocates beyond the input's size or the record limit.
//!
//! The first byte picks the topic (its value modulo 3): 0 none (the recording's one
//! topic of people), 1 `/people`, 2 `/perception/object_recognition/tracking/objects`;
//! the rest is the file.
#![no_main]

use std::collections::HashSet;

use cliff::tracks::{DatasetError, MAX_ANGLE, MAX_POSITION, MAX_SPEED, MAX_TIME, parse_recording};
use libfuzzer_sys::fuzz_target;

const FILE: &str = "fuzz.mcap";

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let topic = match mode % 3 {
        0 => None,
        1 => Some("/people"),
        _ => Some("/perception/object_recognition/tracking/objects"),
    };
    match parse_recording(rest, FILE, topic) {
        Ok(tracks) => {
            let mut ids = HashSet::new();
            for t in &tracks {
                assert!(ids.insert(t.id), "two tracks with id {}", t.id);
                assert!(!t.rows.is_empty());
                assert!(t.rows.windows(2).all(|w| w[0].t < w[1].t));
                for r in &t.rows {
                    assert!(r.t.is_finite() && r.t.abs() <= MAX_TIME, "{r:?}");
                    assert!(r.position.is_finite(), "{r:?}");
                    assert!(r.position.abs().max_element() <= MAX_POSITION, "{r:?}");
                    assert!((0.0..=MAX_SPEED).contains(&r.speed), "{r:?}");
                    assert!(r.angle.is_finite() && r.angle.abs() <= MAX_ANGLE, "{r:?}");
                }
            }
        }
        Err(DatasetError::Message {
            file,
            topic: t,
            index,
            field,
            message,
        }) => {
            assert_eq!(file, FILE);
            assert!(index >= 1 && !field.is_empty() && !message.is_empty());
            if let Some(topic) = topic {
                assert_eq!(t, topic);
            }
        }
        Err(DatasetError::Recording { file, message }) => {
            assert_eq!(file, FILE);
            assert!(!message.is_empty());
        }
        Err(e) => panic!("an error without its place in the recording: {e}"),
    }
});
