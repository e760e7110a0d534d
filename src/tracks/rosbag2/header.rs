//! What every message type cliff reads shares: `std_msgs/msg/Header` (its stamp is the
//! time of the rows), the decoded person ([`Seen`]), the field error ([`FieldError`])
//! and the value checks.

use glam::DVec2;

use super::cdr::{Cdr, CdrError};
use crate::tracks::track::{MAX_POSITION, MAX_SPEED};

/// One person in one message: the tracker's id, position and velocity.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Seen<'a> {
    /// The tracker's id of the person, as text.
    pub(crate) id: std::borrow::Cow<'a, str>,
    /// Position (m).
    pub(crate) position: DVec2,
    /// Velocity (m/s).
    pub(crate) velocity: DVec2,
}

/// A bad field of a message: its path (`people[2].position.x`) and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct FieldError {
    /// The field.
    pub(crate) field: String,
    /// What is wrong.
    pub(crate) message: String,
}

impl FieldError {
    /// An error of `field`.
    pub(crate) fn new(field: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            field: field.into(),
            message: message.into(),
        }
    }
}

/// The CDR error of reading `field` (the path is built only on error).
pub(crate) fn at<T>(
    r: Result<T, CdrError>,
    field: impl FnOnce() -> String,
) -> Result<T, FieldError> {
    r.map_err(|e| FieldError::new(field(), e.to_string()))
}

/// Largest time in nanoseconds that converts to `f64` exactly (2^53 ns: 104 days).
const EXACT_NS: i64 = 1 << 53;

/// The time (s) of a `builtin_interfaces/msg/Time` (`int32 sec`, `uint32 nanosec`
/// below 10^9) at `field`. Times within 104 days of zero are the nearest `f64` to the
/// decimal time `sec.nanosec` (as a CSV reader gets it); later ones are
/// `sec + nanosec / 1e9`.
pub(crate) fn time(r: &mut Cdr, field: &str) -> Result<f64, FieldError> {
    let sec = at(r.i32(), || format!("{field}.sec"))?;
    let nanosec = at(r.u32(), || format!("{field}.nanosec"))?;
    if nanosec >= 1_000_000_000 {
        return Err(FieldError::new(
            format!("{field}.nanosec"),
            format!("{nanosec} is not below 1000000000"),
        ));
    }
    let ns = sec as i64 * 1_000_000_000 + nanosec as i64;
    Ok(if ns.abs() <= EXACT_NS {
        ns as f64 / 1e9
    } else {
        sec as f64 + nanosec as f64 / 1e9
    })
}

/// A `std_msgs/msg/Header` at `field`: the time of its stamp (its frame is not used).
pub(crate) fn header(r: &mut Cdr, field: &str) -> Result<f64, FieldError> {
    let t = time(r, &format!("{field}.stamp"))?;
    at(r.string(), || format!("{field}.frame_id"))?;
    Ok(t)
}

/// A `geometry_msgs/msg/Point` (or `Vector3`) at `field`: x and y (z is read, not used).
pub(crate) fn point(r: &mut Cdr, field: &dyn Fn() -> String) -> Result<DVec2, FieldError> {
    let x = at(r.f64(), || format!("{}.x", field()))?;
    let y = at(r.f64(), || format!("{}.y", field()))?;
    at(r.f64(), || format!("{}.z", field()))?;
    Ok(DVec2::new(x, y))
}

/// Check a person's position and velocity: finite, |x|, |y| <= [`MAX_POSITION`], speed
/// <= [`MAX_SPEED`]; `position` and `velocity` name the fields.
pub(crate) fn check(
    seen: &Seen,
    position: &dyn Fn() -> String,
    velocity: &dyn Fn() -> String,
) -> Result<(), FieldError> {
    for (v, axis) in [(seen.position.x, "x"), (seen.position.y, "y")] {
        if !v.is_finite() {
            return Err(FieldError::new(
                format!("{}.{axis}", position()),
                format!("{v} is not a finite number"),
            ));
        }
        if v.abs() > MAX_POSITION {
            return Err(FieldError::new(
                format!("{}.{axis}", position()),
                format!("coordinate {v:?} is beyond {MAX_POSITION} in magnitude"),
            ));
        }
    }
    for (v, axis) in [(seen.velocity.x, "x"), (seen.velocity.y, "y")] {
        if !v.is_finite() {
            return Err(FieldError::new(
                format!("{}.{axis}", velocity()),
                format!("{v} is not a finite number"),
            ));
        }
    }
    let speed = seen.velocity.length();
    if speed > MAX_SPEED {
        return Err(FieldError::new(
            velocity(),
            format!("speed {speed:?} is beyond {MAX_SPEED}"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamps_are_the_decimal_time_and_nanoseconds_are_checked() {
        // sec 227, nanosec 150000000, little-endian
        let mut b = vec![0u8, 1, 0, 0];
        b.extend(227i32.to_le_bytes());
        b.extend(150_000_000u32.to_le_bytes());
        assert_eq!(time(&mut Cdr::new(&b).unwrap(), "stamp").unwrap(), 227.15);
        let mut b = vec![0u8, 0, 0, 0];
        b.extend((-2i32).to_be_bytes());
        b.extend(1_000_000_000u32.to_be_bytes());
        let e = time(&mut Cdr::new(&b).unwrap(), "header.stamp").unwrap_err();
        assert_eq!(e.field, "header.stamp.nanosec");
        assert_eq!(e.message, "1000000000 is not below 1000000000");
        // a unix time: sec + nanosec / 1e9
        let mut b = vec![0u8, 1, 0, 0];
        b.extend(1_351_065_600i32.to_le_bytes());
        b.extend(500_000_000u32.to_le_bytes());
        assert_eq!(
            time(&mut Cdr::new(&b).unwrap(), "s").unwrap(),
            1_351_065_600.5
        );
    }
}
