//! Command-line values of time: durations (`1h`, `30min`, `3600`), clock offsets (`+9h`,
//! `32400`, `-5h`) and times of day (`13`, `13:30`).

/// A duration in seconds: a number with an optional unit `s`, `m`/`min` or `h`
/// (seconds without one).
pub fn duration(s: &str) -> Result<f64, String> {
    let v = signed_duration(s)?;
    if v < 0.0 {
        return Err(format!("'{s}' is negative"));
    }
    Ok(v)
}

/// A duration that may be negative (a clock offset): `+9h`, `-5h`, `32400`.
pub fn signed_duration(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let (num, scale) = if let Some(n) = t.strip_suffix("min") {
        (n, 60.0)
    } else if let Some(n) = t.strip_suffix('h') {
        (n, 3600.0)
    } else if let Some(n) = t.strip_suffix('m') {
        (n, 60.0)
    } else if let Some(n) = t.strip_suffix('s') {
        (n, 1.0)
    } else {
        (t, 1.0)
    };
    match num.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v * scale),
        _ => Err(format!(
            "'{s}' is not a duration (a number of seconds, or with a unit: 90s, 30min, 1h)"
        )),
    }
}

/// A time of day in seconds since midnight: `HH`, `HH:MM` or `HH:MM:SS` (24 h clock).
pub fn time_of_day(s: &str) -> Result<f64, String> {
    let bad = || format!("'{s}' is not a time of day (HH, HH:MM or HH:MM:SS, 00:00 to 23:59:59)");
    let parts: Vec<&str> = s.trim().split(':').collect();
    if parts.len() > 3 {
        return Err(bad());
    }
    let mut total = 0.0;
    for (i, p) in parts.iter().enumerate() {
        let v: u32 = p.parse().map_err(|_| bad())?;
        let limit = if i == 0 { 24 } else { 60 };
        if v >= limit {
            return Err(bad());
        }
        total += v as f64 * [3600.0, 60.0, 1.0][i];
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_offsets_and_times_of_day() {
        assert_eq!(duration("1h"), Ok(3600.0));
        assert_eq!(duration("30min"), Ok(1800.0));
        assert_eq!(duration("30m"), Ok(1800.0));
        assert_eq!(duration(" 90s "), Ok(90.0));
        assert_eq!(duration("3600"), Ok(3600.0));
        assert_eq!(duration("1.5h"), Ok(5400.0));
        assert!(duration("-1h").unwrap_err().contains("negative"));
        assert!(duration("an hour").unwrap_err().contains("not a duration"));
        assert!(duration("nanh").is_err());
        assert_eq!(signed_duration("+9h"), Ok(32400.0));
        assert_eq!(signed_duration("-5h"), Ok(-18000.0));
        assert_eq!(time_of_day("13"), Ok(13.0 * 3600.0));
        assert_eq!(time_of_day("09:30"), Ok(9.5 * 3600.0));
        assert_eq!(time_of_day("23:59:59"), Ok(86399.0));
        assert!(time_of_day("24").is_err());
        assert!(time_of_day("12:60").is_err());
        assert!(time_of_day("noon").is_err());
    }
}
