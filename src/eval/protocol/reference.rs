//! The reference protocol: exactly what the published CLiFF-LHMP code does (observe `n`
//! rows, start at row `n`, horizon floored to whole seconds, 10-row idle filter).

use super::case::Case;
use super::settings::{REFERENCE_IDLE_ROWS, Settings};
use crate::motion::{State, velocity_from_speed_angle};
use crate::tracks::Track;

pub(super) fn prepare_reference(track: &Track, s: &Settings) -> Option<Case> {
    let rows = &track.rows;
    let obs = s.obs_rows();
    if rows.len() < obs + 2 {
        return None;
    }
    let last_t = rows[rows.len() - 1].t;
    if last_t - rows[obs].t < s.dt {
        return None;
    }
    let w = REFERENCE_IDLE_ROWS;
    if rows.len() > w
        && rows
            .windows(w + 1)
            .any(|win| win[0].position.distance(win[w].position) < s.idle_distance)
    {
        return None;
    }
    let observed = rows[..obs].to_vec();
    let speeds: Vec<f64> = observed.iter().map(|r| r.speed).collect();
    let angles: Vec<f64> = observed.iter().map(|r| r.angle).collect();
    let v = velocity_from_speed_angle(&speeds, &angles, s.sigma).ok()?;
    let start_row = rows[obs];
    let horizon = (last_t - start_row.t).floor().min(s.horizon).max(0.0);
    // The reference: int(H / dt) with Python float division.
    let steps = (horizon / s.dt) as usize;
    Some(Case {
        id: track.id,
        observed,
        start: State {
            position: start_row.position,
            speed: v.speed,
            heading: v.heading,
            time: start_row.t,
        },
        future: rows[obs..].to_vec(),
        horizon,
        steps,
        window: 0,
    })
}
