//! Displacement errors of sampled trajectories against the ground truth.
//!
//! For one person and step `j` (horizon `j * dt`), over the samples counted at step
//! `j`: ADE is the mean over samples of the mean error over steps `1..=j`, FDE the mean
//! error at step `j`; minADE and minFDE (top-k) are the smallest per-sample values;
//! top-1 ADE and FDE are those of the best-ranked sample (highest score, see
//! [`crate::predict::Options::scores`]) among the samples counted at step `j`.
//!
//! Which samples count at step `j` ([`Counting`]): with [`Counting::Everyone`] every
//! sample, one that stopped before `j` (the paper's method stops where its map has no
//! data) standing where it stopped (at the start when it never moved), so methods are
//! compared over the same people at every horizon where ground truth exists; with
//! [`Counting::Reached`] (the published code's rule, kept for parity) only the samples
//! that reached step `j`. `reaching` counts the samples that reached `j` either way.

use glam::DVec2;

use super::protocol::case::Case;
use crate::predict::Point;

/// Errors of one person at one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepErrors {
    /// Mean over reaching samples of the average displacement up to this step.
    pub ade: f64,
    /// Mean over reaching samples of the displacement at this step.
    pub fde: f64,
    /// Smallest average displacement of a reaching sample.
    pub min_ade: f64,
    /// Smallest final displacement of a reaching sample.
    pub min_fde: f64,
    /// Average displacement of the best-scored reaching sample (NaN without scores).
    pub top1_ade: f64,
    /// Final displacement of the best-scored reaching sample (NaN without scores).
    pub top1_fde: f64,
    /// How many samples reached this step (fewer than those counted, with
    /// [`Counting::Everyone`], when some stopped).
    pub reaching: u32,
}

/// Which samples count at a step (see the [module documentation](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Counting {
    /// Only the samples that reached the step (the published code's rule).
    Reached,
    /// Every sample: one that stopped counts where it stopped, so that methods are
    /// compared over the same people (the default).
    #[default]
    Everyone,
}

impl std::str::FromStr for Counting {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "reached" => Ok(Counting::Reached),
            "everyone" | "all" => Ok(Counting::Everyone),
            other => Err(format!(
                "unknown counting '{other}' (expected everyone or reached)"
            )),
        }
    }
}

impl std::fmt::Display for Counting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Counting::Reached => "reached",
            Counting::Everyone => "everyone",
        })
    }
}

/// Reusable scratch space for [`person_errors`].
#[derive(Debug, Default, Clone)]
pub struct Scratch {
    truth: Vec<Option<DVec2>>,
    sum_ade: Vec<f64>,
    sum_fde: Vec<f64>,
    min_ade: Vec<f64>,
    min_fde: Vec<f64>,
    reaching: Vec<u32>,
    counted: Vec<u32>,
    top_score: Vec<f32>,
    top_ade: Vec<f64>,
    top_fde: Vec<f64>,
}

/// Ground truth at each predicted step of `case` (`None` past the last row).
pub fn truth_per_step(case: &Case, dt: f64, out: &mut Vec<Option<DVec2>>) {
    out.clear();
    out.extend((1..=case.steps).map(|j| case.truth_at(case.start.time + j as f64 * dt)));
}

/// Errors at every step `1..=case.steps` of `k` samples, given as `k` slices of valid
/// positions, with their scores (one per sample; empty when not scored: top-1 errors are
/// NaN then), counted as `counting` says. Writes one entry per step into `out` (`None`
/// where no sample counts at the step or the ground truth has ended).
pub fn person_errors<'a>(
    case: &Case,
    dt: f64,
    counting: Counting,
    samples: impl Iterator<Item = &'a [Point]>,
    scores: &[f32],
    scratch: &mut Scratch,
    out: &mut Vec<Option<StepErrors>>,
) {
    let n = case.steps;
    truth_per_step(case, dt, &mut scratch.truth);
    for v in [&mut scratch.sum_ade, &mut scratch.sum_fde] {
        v.clear();
        v.resize(n, 0.0);
    }
    for v in [&mut scratch.min_ade, &mut scratch.min_fde] {
        v.clear();
        v.resize(n, f64::INFINITY);
    }
    for v in [&mut scratch.reaching, &mut scratch.counted] {
        v.clear();
        v.resize(n, 0);
    }
    scratch.top_score.clear();
    scratch.top_score.resize(n, f32::NEG_INFINITY);
    for v in [&mut scratch.top_ade, &mut scratch.top_fde] {
        v.clear();
        v.resize(n, f64::NAN);
    }
    for (i, sample) in samples.enumerate() {
        let score = scores.get(i).copied();
        let mut cum = 0.0;
        let counted = match counting {
            Counting::Reached => sample.len().min(n),
            Counting::Everyone => n,
        };
        let start = [case.start.position.x as f32, case.start.position.y as f32];
        for j in 0..counted {
            // A predicted time after the last row ends this sample's error list.
            let Some(truth) = scratch.truth[j] else { break };
            // past its end a sample stands where it stopped
            let p = sample.get(j).or(sample.last()).unwrap_or(&start);
            let e = DVec2::new(p[0] as f64, p[1] as f64).distance(truth);
            cum += e;
            let ade = cum / (j + 1) as f64;
            scratch.sum_ade[j] += ade;
            scratch.sum_fde[j] += e;
            scratch.min_ade[j] = scratch.min_ade[j].min(ade);
            scratch.min_fde[j] = scratch.min_fde[j].min(e);
            scratch.counted[j] += 1;
            if j < sample.len() {
                scratch.reaching[j] += 1;
            }
            if let Some(sc) = score
                && (sc > scratch.top_score[j] || scratch.top_ade[j].is_nan())
            {
                scratch.top_score[j] = sc;
                scratch.top_ade[j] = ade;
                scratch.top_fde[j] = e;
            }
        }
    }
    out.clear();
    out.extend((0..n).map(|j| {
        let c = scratch.counted[j];
        (c > 0).then(|| StepErrors {
            ade: scratch.sum_ade[j] / c as f64,
            fde: scratch.sum_fde[j] / c as f64,
            min_ade: scratch.min_ade[j],
            min_fde: scratch.min_fde[j],
            top1_ade: scratch.top_ade[j],
            top1_fde: scratch.top_fde[j],
            reaching: scratch.reaching[j],
        })
    }));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::State;
    use crate::tracks::Row;

    /// Truth walking east at 1 m/s from the origin, 5 steps of 1 s.
    fn walking_east() -> Case {
        let future: Vec<Row> = (0..6)
            .map(|i| Row {
                t: i as f64,
                position: DVec2::new(i as f64, 0.0),
                speed: 1.0,
                angle: 0.0,
            })
            .collect();
        Case {
            id: 1,
            observed: vec![],
            start: State {
                position: DVec2::ZERO,
                speed: 1.0,
                heading: 0.0,
                time: 0.0,
            },
            future,
            horizon: 5.0,
            steps: 5,
            window: 0,
        }
    }

    #[test]
    fn errors_of_two_samples() {
        // truth walks east 1 m/s; sample A is exact, sample B is 1 m north, and stops after 2 steps
        let case = walking_east();
        let a: Vec<Point> = (1..=5).map(|i| [i as f32, 0.0]).collect();
        let b: Vec<Point> = (1..=2).map(|i| [i as f32, 1.0]).collect();
        let mut out = vec![];
        person_errors(
            &case,
            1.0,
            Counting::Reached,
            [a.as_slice(), b.as_slice()].into_iter(),
            &[],
            &mut Scratch::default(),
            &mut out,
        );
        let s1 = out[0].unwrap();
        assert_eq!(
            (s1.ade, s1.fde, s1.min_ade, s1.min_fde, s1.reaching),
            (0.5, 0.5, 0.0, 0.0, 2)
        );
        let s3 = out[2].unwrap();
        assert_eq!((s3.ade, s3.reaching), (0.0, 1));
        assert!(s1.top1_ade.is_nan() && s1.top1_fde.is_nan());
        // ranked: B (off by 1 m) scores higher; where B has stopped, A is the best left
        let mut ranked = vec![];
        person_errors(
            &case,
            1.0,
            Counting::Reached,
            [a.as_slice(), b.as_slice()].into_iter(),
            &[-3.0, -1.0],
            &mut Scratch::default(),
            &mut ranked,
        );
        let r1 = ranked[0].unwrap();
        assert_eq!((r1.top1_ade, r1.top1_fde, r1.ade), (1.0, 1.0, s1.ade));
        assert_eq!(
            (ranked[2].unwrap().top1_ade, ranked[2].unwrap().top1_fde),
            (0.0, 0.0)
        );
        // ground truth ends at t = 5: step 5 has a value, nothing beyond
        assert!(out[4].is_some());
        assert_eq!(out.len(), 5);
        // no sample reached: None
        person_errors(
            &case,
            1.0,
            Counting::Reached,
            std::iter::empty(),
            &[],
            &mut Scratch::default(),
            &mut out,
        );
        assert!(out.iter().all(Option::is_none));
    }

    #[test]
    fn counting_everyone_keeps_a_stopped_sample_where_it_stopped() {
        // truth walks east 1 m/s; A is exact, B stops after 2 steps at (2, 1)
        let case = walking_east();
        let a: Vec<Point> = (1..=5).map(|i| [i as f32, 0.0]).collect();
        let b: Vec<Point> = (1..=2).map(|i| [i as f32, 1.0]).collect();
        let never: Vec<Point> = vec![];
        let mut out = vec![];
        person_errors(
            &case,
            1.0,
            Counting::Everyone,
            [a.as_slice(), b.as_slice(), never.as_slice()].into_iter(),
            &[-3.0, -1.0, -2.0],
            &mut Scratch::default(),
            &mut out,
        );
        // step 4: B stands at (2, 1), 2.24 m from (4, 0); the sample that never moved
        // stands at the start, 4 m away
        let s4 = out[3].unwrap();
        let b_err = DVec2::new(2.0, 1.0).distance(DVec2::new(4.0, 0.0));
        assert!((s4.fde - (0.0 + b_err + 4.0) / 3.0).abs() < 1e-9, "{s4:?}");
        assert_eq!(s4.reaching, 1);
        // B ranks best and counts at every step
        let b_ade4 = (1.0 + 1.0 + 2f64.sqrt() + b_err) / 4.0;
        assert!((s4.top1_fde - b_err).abs() < 1e-9 && (s4.top1_ade - b_ade4).abs() < 1e-9);
        assert_eq!((s4.min_fde, s4.min_ade), (0.0, 0.0));
    }
}
