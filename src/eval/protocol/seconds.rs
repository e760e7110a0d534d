//! The seconds protocol: the reference protocol's ideas stated in time, for data at any
//! rate.

use glam::DVec2;

use super::case::{Case, interpolate};
use super::settings::Settings;
use crate::motion::{State, velocity_from_speed_angle};
use crate::predict::steps_for;
use crate::tracks::{Row, Track};

pub(crate) fn prepare_seconds(track: &Track, s: &Settings) -> Option<Case> {
    let rows = &track.rows;
    let first = rows.first()?;
    let last_t = rows.last()?.t;
    // Start at the first row at least `obs` seconds after the first.
    let si = rows.iter().position(|r| r.t >= first.t + s.obs - 1e-6)?;
    let start_row = rows[si];
    if last_t - start_row.t < s.dt {
        return None;
    }
    // Idle: less than idle_distance within any idle_window seconds.
    for r in rows {
        if r.t + s.idle_window > last_t + 1e-9 {
            break;
        }
        if let Some(p) = interpolate(rows, r.t + s.idle_window)
            && p.distance(r.position) < s.idle_distance
        {
            return None;
        }
    }
    // Observed velocity from the speed and angle columns resampled at dt before the start.
    let n = steps_for(s.obs, s.dt).max(1);
    let mut speeds = Vec::with_capacity(n);
    let mut angles = Vec::with_capacity(n);
    for m in (1..=n).rev() {
        let t = start_row.t - m as f64 * s.dt;
        if t < first.t - 1e-9 {
            continue;
        }
        let (sp, an) = resample_velocity(&rows[..=si], t)?;
        speeds.push(sp);
        angles.push(an);
    }
    if speeds.is_empty() {
        return None;
    }
    let v = velocity_from_speed_angle(&speeds, &angles, s.sigma).ok()?;
    let horizon = (last_t - start_row.t).min(s.horizon);
    Some(Case {
        id: track.id,
        observed: rows[..si].to_vec(),
        start: State {
            position: start_row.position,
            speed: v.speed,
            heading: v.heading,
            time: start_row.t,
        },
        future: rows[si..].to_vec(),
        horizon,
        steps: steps_for(horizon, s.dt),
        window: 0,
    })
}

/// Speed (linear) and angle (circular, along the shorter arc) interpolated at `t`.
fn resample_velocity(rows: &[Row], t: f64) -> Option<(f64, f64)> {
    let i = rows.partition_point(|r| r.t < t);
    if i == 0 {
        return rows.first().map(|r| (r.speed, r.angle));
    }
    if i >= rows.len() {
        return rows.last().map(|r| (r.speed, r.angle));
    }
    let (a, b) = (&rows[i - 1], &rows[i]);
    let w = (t - a.t) / (b.t - a.t);
    let u = DVec2::from_angle(a.angle).lerp(DVec2::from_angle(b.angle), w);
    let angle = if u.length_squared() > 1e-24 {
        u.to_angle()
    } else {
        a.angle
    };
    Some((a.speed + w * (b.speed - a.speed), angle))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn circular_resampling_takes_the_short_arc() {
        let rows = [
            Row {
                t: 0.0,
                position: DVec2::ZERO,
                speed: 1.0,
                angle: 3.0,
            },
            Row {
                t: 1.0,
                position: DVec2::X,
                speed: 2.0,
                angle: -3.0,
            },
        ];
        let (sp, an) = resample_velocity(&rows, 0.5).unwrap();
        assert!((sp - 1.5).abs() < 1e-12);
        assert!((an.abs() - std::f64::consts::PI).abs() < 1e-9, "{an}");
    }
}
