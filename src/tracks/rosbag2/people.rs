//! `people_msgs/msg/People`: what leg trackers publish and nav2's social layers read
//! (usually on `/people`).
//!
//! ```text
//! std_msgs/Header header          # its stamp: the time of every person in the message
//! people_msgs/Person[] people
//!   string name                   # the track id
//!   geometry_msgs/Point position  # x, y (m); z unused
//!   geometry_msgs/Point velocity  # x, y (m/s): the row's speed and motion angle
//!   float64 reliability           # not used
//!   string[] tagnames             # not used
//!   string[] tags                 # not used
//! ```
//!
//! Every person of a message is a row of the track of its `name`.

use std::borrow::Cow;

use super::cdr::Cdr;
use super::header::{FieldError, Seen, at, check, header, point};

/// The type's name in a recording.
pub(crate) const NAME: &str = "people_msgs/msg/People";

/// Fewest bytes a `Person` takes (a one-byte name, 7 float64, two empty arrays),
/// to bound the count of people before reading them.
const MIN_PERSON_BYTES: usize = 5 + 7 * 8 + 4 + 4;

/// Decode a `People` message: its time, and its people appended to `out`.
pub(crate) fn decode<'a>(bytes: &'a [u8], out: &mut Vec<Seen<'a>>) -> Result<f64, FieldError> {
    let mut r = at(Cdr::new(bytes), || "(encapsulation)".into())?;
    let t = header(&mut r, "header")?;
    let n = at(r.count(MIN_PERSON_BYTES), || "people".into())?;
    for i in 0..n {
        let name = at(r.string(), || format!("people[{i}].name"))?;
        let position = point(&mut r, &|| format!("people[{i}].position"))?;
        let velocity = point(&mut r, &|| format!("people[{i}].velocity"))?;
        at(r.f64(), || format!("people[{i}].reliability"))?;
        for list in ["tagnames", "tags"] {
            let m = at(r.count(5), || format!("people[{i}].{list}"))?;
            for j in 0..m {
                at(r.string(), || format!("people[{i}].{list}[{j}]"))?;
            }
        }
        let seen = Seen {
            id: Cow::Borrowed(name),
            position,
            velocity,
        };
        check(&seen, &|| format!("people[{i}].position"), &|| {
            format!("people[{i}].velocity")
        })?;
        out.push(seen);
    }
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A People message laid out by hand (little-endian): stamp 2.5 s, frame "map", one
    /// person "p7" at (1, -2) moving (0.5, 0) with reliability 1, tag "leg"="l".
    fn message() -> Vec<u8> {
        let mut b = vec![0u8, 1, 0, 0];
        b.extend(2i32.to_le_bytes()); // body 0: sec
        b.extend(500_000_000u32.to_le_bytes()); // body 4: nanosec
        b.extend(4u32.to_le_bytes()); // body 8: "map"
        b.extend(b"map\0");
        b.extend(1u32.to_le_bytes()); // body 16: one person
        b.extend(3u32.to_le_bytes()); // body 20: "p7"
        b.extend(b"p7\0");
        b.extend([0u8; 5]); // body 27: padding to 32
        for v in [1.0f64, -2.0, 0.0, 0.5, 0.0, 0.0, 1.0] {
            b.extend(v.to_le_bytes()); // body 32..88
        }
        for s in ["leg", "l"] {
            while !(b.len() - 4).is_multiple_of(4) {
                b.push(0); // padding before a count
            }
            b.extend(1u32.to_le_bytes());
            b.extend((s.len() as u32 + 1).to_le_bytes());
            b.extend(s.as_bytes());
            b.push(0);
        }
        b
    }

    #[test]
    fn decodes_a_message_laid_out_by_hand() {
        let b = message();
        let mut out = Vec::new();
        assert_eq!(decode(&b, &mut out).unwrap(), 2.5);
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].id, "p7");
        assert_eq!(out[0].position, glam::DVec2::new(1.0, -2.0));
        assert_eq!(out[0].velocity, glam::DVec2::new(0.5, 0.0));
    }

    #[test]
    fn bad_fields_are_named() {
        let mut out = Vec::new();
        // NaN position y
        let mut b = message();
        b[36 + 8..36 + 16].copy_from_slice(&f64::NAN.to_le_bytes());
        let e = decode(&b, &mut out).unwrap_err();
        assert_eq!(
            (e.field.as_str(), e.message.as_str()),
            ("people[0].position.y", "NaN is not a finite number")
        );
        // a name longer than the message
        let mut b = message();
        b[24..28].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = decode(&b, &mut out).unwrap_err();
        assert_eq!(e.field, "people[0].name");
        assert!(
            e.message.starts_with("length 4294967295 at byte 24"),
            "{}",
            e.message
        );
        // four billion people in a short message
        let mut b = message();
        b[20..24].copy_from_slice(&u32::MAX.to_le_bytes());
        assert_eq!(decode(&b, &mut out).unwrap_err().field, "people");
        // cut inside the tags
        let b = message();
        let e = decode(&b[..b.len() - 1], &mut out).unwrap_err();
        assert_eq!(e.field, "people[0].tags[0]");
        // every shorter cut is an error, never a panic
        for n in 0..b.len() {
            assert!(decode(&b[..n], &mut Vec::new()).is_err(), "cut at {n}");
        }
    }
}
