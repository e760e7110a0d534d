//! The chance that a robot's timed path meets each person.

use super::{OccupancyError, Samples, Settings, Stopped};

/// The most points a plan may have (bounds the cost of a plan from a request).
pub const MAX_PLAN_POINTS: usize = 1 << 16;

/// A point of a robot's plan: where the robot will be, and when (seconds after the
/// prediction's start, the same clock as the samples').
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanPoint {
    /// Position in the map's frame (m).
    pub position: [f64; 2],
    /// Time (s).
    pub time: f64,
}

/// For each person, the probability that the robot's plan meets them: the fraction of
/// the person's samples that come within `robot_radius + settings.person_radius` of
/// the robot at the same time, written to `out` (one value per agent).
///
/// The robot moves in straight lines between the plan's points (times non-decreasing),
/// and a sample in straight lines between its steps. The plan's times and the samples'
/// steps within them cut the plan into intervals in which both move linearly; a sample
/// meets the robot when the least distance between the two within an interval is
/// below the reach, wherever the samples cover the time ([`Samples::span`]; the part
/// of a plan outside it is not checked). Under [`Stopped::Renormalise`] the
/// fraction is over the samples that have a position at some checked time (0 when
/// none has); under [`Stopped::Drop`] over all `k`, a stopped sample meeting no one
/// after it stops; under [`Stopped::Hold`] over all `k`, a stopped sample standing at
/// its last position.
pub fn path_meets(
    samples: &Samples<'_>,
    plan: &[PlanPoint],
    robot_radius: f64,
    settings: &Settings,
    out: &mut [f32],
) -> Result<(), OccupancyError> {
    settings.validate()?;
    let (agents, k, steps) = samples.shape();
    if out.len() != agents {
        return Err(OccupancyError::Samples(format!(
            "an output of {} values for {agents} agents",
            out.len()
        )));
    }
    if !(robot_radius.is_finite() && robot_radius >= 0.0) {
        return Err(OccupancyError::Setting {
            name: "robot_radius",
            why: format!("{robot_radius} is not a non-negative number"),
        });
    }
    let bad = |index: usize, why: String| Err(OccupancyError::Plan { index, why });
    if plan.is_empty() {
        return bad(0, "the plan is empty".into());
    }
    if plan.len() > MAX_PLAN_POINTS {
        return bad(
            MAX_PLAN_POINTS,
            format!("{} points is more than {MAX_PLAN_POINTS}", plan.len()),
        );
    }
    for (i, p) in plan.iter().enumerate() {
        if !(p.position[0].is_finite() && p.position[1].is_finite() && p.time.is_finite()) {
            return bad(i, "not finite".into());
        }
        if i > 0 && p.time < plan[i - 1].time {
            return bad(
                i,
                format!("time {} s is before the previous point's", p.time),
            );
        }
    }
    let reach = (robot_radius + settings.person_radius) as f32;
    let reach2 = reach * reach;
    let (t_first, t_last) = (plan[0].time, plan[plan.len() - 1].time);
    let dt = samples.dt();
    let robot_at = |t: f64| -> [f32; 2] {
        let i = plan.partition_point(|p| p.time <= t);
        if i == 0 {
            return [plan[0].position[0] as f32, plan[0].position[1] as f32];
        }
        if i == plan.len() {
            let p = plan[i - 1].position;
            return [p[0] as f32, p[1] as f32];
        }
        let (a, b) = (plan[i - 1], plan[i]);
        let f = if b.time > a.time {
            (t - a.time) / (b.time - a.time)
        } else {
            0.0
        };
        [
            (a.position[0] + (b.position[0] - a.position[0]) * f) as f32,
            (a.position[1] + (b.position[1] - a.position[1]) * f) as f32,
        ]
    };
    // the checked times: the plan's points and the steps within the plan, in order;
    // between two of them both the robot and a sample move in straight lines
    let checks = CheckTimes {
        plan,
        steps,
        dt,
        next_plan: 0,
        next_step: 0,
        from: t_first,
        to: t_last,
    };
    for (a, o) in out.iter_mut().enumerate() {
        let (mut met, mut seen) = (0usize, 0usize);
        for s in 0..k {
            let (mut any, mut hit) = (false, false);
            let mut prev: Option<[f32; 2]> = None;
            for t in checks.clone() {
                let here = samples
                    .find_time(t)
                    .and_then(|ti| samples.at(a, s, ti, settings.stopped));
                let Some(p) = here else {
                    prev = None;
                    continue;
                };
                any = true;
                let r = robot_at(t);
                let rel = [p[0] - r[0], p[1] - r[1]];
                if closest_squared(prev.unwrap_or(rel), rel) < reach2 {
                    hit = true;
                    break;
                }
                prev = Some(rel);
            }
            seen += any as usize;
            met += hit as usize;
        }
        let denominator = match settings.stopped {
            Stopped::Renormalise => seen,
            Stopped::Drop | Stopped::Hold => k,
        };
        *o = if denominator == 0 {
            0.0
        } else {
            met as f32 / denominator as f32
        };
    }
    Ok(())
}

/// The times a plan is checked at: its points' times and the samples' step times
/// within `[from, to]`, merged in order (a time in both comes twice, harmlessly).
#[derive(Clone)]
struct CheckTimes<'p> {
    plan: &'p [PlanPoint],
    steps: usize,
    dt: f64,
    next_plan: usize,
    next_step: usize,
    from: f64,
    to: f64,
}

impl Iterator for CheckTimes<'_> {
    type Item = f64;
    fn next(&mut self) -> Option<f64> {
        // skip the steps before the plan starts
        while self.next_step < self.steps && ((self.next_step + 1) as f64 * self.dt) < self.from {
            self.next_step += 1;
        }
        let step = (self.next_step < self.steps)
            .then(|| (self.next_step + 1) as f64 * self.dt)
            .filter(|&t| t <= self.to);
        let point = self.plan.get(self.next_plan).map(|p| p.time);
        match (point, step) {
            (Some(p), Some(s)) if s < p => {
                self.next_step += 1;
                Some(s)
            }
            (Some(p), _) => {
                self.next_plan += 1;
                Some(p)
            }
            (None, Some(s)) => {
                self.next_step += 1;
                Some(s)
            }
            (None, None) => None,
        }
    }
}

/// The least squared length of the segment from `a` to `b` (the relative position of
/// sample and robot moving linearly between two checked times) from the origin.
fn closest_squared(a: [f32; 2], b: [f32; 2]) -> f32 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let dd = d[0] * d[0] + d[1] * d[1];
    let u = if dd > 0.0 {
        (-(a[0] * d[0] + a[1] * d[1]) / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let c = [a[0] + u * d[0], a[1] + u * d[1]];
    c[0] * c[0] + c[1] * c[1]
}
