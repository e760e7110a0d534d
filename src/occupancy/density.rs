//! One person's predicted density at a point: what the log-likelihood of where the
//! person really was is computed from.

use super::kernel::spread;
use super::{OccupancyError, Samples, Settings, Stopped};

/// The density (per square metre) of person `agent`'s occupancy at `time` at `point`:
/// the weighted sum of their samples' kernels there (not cut at `truncate`, so it is
/// never zero), with the weights of [`Settings::stopped`]. `points` is scratch space
/// (reused; at most `k` points). `Ok(None)` when no sample has a position at that time.
pub fn person_density(
    samples: &Samples<'_>,
    agent: usize,
    time: f64,
    point: [f64; 2],
    settings: &Settings,
    points: &mut Vec<[f32; 2]>,
) -> Result<Option<f64>, OccupancyError> {
    settings.validate()?;
    let (agents, k, _) = samples.shape();
    if agent >= agents {
        return Err(OccupancyError::Samples(format!(
            "agent {agent} of {agents}"
        )));
    }
    let ti = samples.time_index(0, time)?;
    points.clear();
    for s in 0..k {
        if let Some(p) = samples.at(agent, s, ti, settings.stopped) {
            points.push(p);
        }
    }
    let n = points.len();
    if n == 0 {
        return Ok(None);
    }
    let w = match settings.stopped {
        Stopped::Renormalise => 1.0 / n as f64,
        Stopped::Drop | Stopped::Hold => 1.0 / k as f64,
    };
    let sigma = settings.sigma(spread(points), n);
    let norm = 1.0 / (2.0 * std::f64::consts::PI * sigma * sigma);
    let mut d = 0.0;
    for p in points.iter() {
        let (dx, dy) = (point[0] - p[0] as f64, point[1] - p[1] as f64);
        d += w * norm * (-(dx * dx + dy * dy) / (2.0 * sigma * sigma)).exp();
    }
    Ok(Some(d))
}
