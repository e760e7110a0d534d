//! The clock of a set: the day, slice lengths that divide it, clock offsets and the
//! labels slices are shown with.

use crate::map::MapError;

/// Seconds in a day.
pub const DAY_SECONDS: f64 = 86_400.0;
/// Shortest slice (s): one minute.
pub const MIN_SLICE_SECONDS: f64 = 60.0;
/// Largest clock offset magnitude (s): a day (a time of day needs no more).
pub const MAX_CLOCK_OFFSET: f64 = DAY_SECONDS;

/// The number of slices of `slice_length` seconds in a day: the length must be at
/// least [`MIN_SLICE_SECONDS`], at most a day, and divide the day.
pub fn slice_count(slice_length: f64) -> Result<usize, MapError> {
    let bad = || {
        MapError::TimeOfDay(format!(
            "a slice length of {slice_length} s does not divide the day into whole slices of {MIN_SLICE_SECONDS} s to {DAY_SECONDS} s"
        ))
    };
    if !(slice_length.is_finite() && (MIN_SLICE_SECONDS..=DAY_SECONDS).contains(&slice_length)) {
        return Err(bad());
    }
    let n = (DAY_SECONDS / slice_length).round();
    if (n * slice_length - DAY_SECONDS).abs() > 1e-6 {
        return Err(bad());
    }
    Ok(n as usize)
}

/// `HH:MM` (or `HH:MM:SS` when the seconds are not zero) of a time of day in seconds.
pub fn clock_label(seconds: f64) -> String {
    let s = seconds.round() as i64;
    let (h, m, sec) = (s / 3600, s / 60 % 60, s % 60);
    if sec == 0 {
        format!("{h:02}:{m:02}")
    } else {
        format!("{h:02}:{m:02}:{sec:02}")
    }
}

/// `HH:MM-HH:MM`: the local times slice `index` covers.
pub fn slice_label(index: usize, slice_length: f64) -> String {
    let from = index as f64 * slice_length;
    format!("{}-{}", clock_label(from), clock_label(from + slice_length))
}

/// Check a clock offset: finite and within a day.
pub(crate) fn check_clock_offset(offset: f64) -> Result<(), MapError> {
    if offset.is_finite() && offset.abs() <= MAX_CLOCK_OFFSET {
        Ok(())
    } else {
        Err(MapError::TimeOfDay(format!(
            "clock offset {offset} s is not within a day (+-{MAX_CLOCK_OFFSET} s)"
        )))
    }
}
