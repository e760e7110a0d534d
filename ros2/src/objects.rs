//! The predicted people as Autoware's `PredictedObjects` (`cliff/objects`), so that an
//! Autoware stack's planners can take cliff's pedestrians in place of its own
//! prediction. Per person one object:
//!
//! - `object_id`: [`track_uuid`] (a TrackedObjects track keeps its UUID; a People
//!   track gets the name-based UUID of its name);
//! - `existence_probability` 1, `classification` one entry, `PEDESTRIAN` with
//!   probability 1;
//! - `kinematics`: the initial pose at the last observed position, heading along the
//!   observed velocity (the last two observations); the twist in the object's frame as
//!   Autoware's trackers give it (`linear.x` the observed speed); zero acceleration and
//!   covariances (none is estimated);
//! - `predicted_paths`: the best `paths` samples: by score when the samples are scored
//!   (the highest first), else the first `paths` (equally likely draws). A path starts
//!   at the last observed position and has one pose per prediction step
//!   (`time_step` = the step), each heading towards the next pose. Its `confidence` is
//!   the sample's share of the person's `k` samples: `exp(score - best)` over the sum
//!   of it over all `k` samples (scores are log-likelihoods), or `1/k` unscored, so the
//!   confidences of a person's paths sum to at most 1;
//! - `shape`: an upright cylinder of [`PERSON_DIAMETER`] and [`PERSON_HEIGHT`].
//!
//! Filled into reused messages: a steady cycle allocates nothing here.

use crate::msg::{
    Duration, ObjectClassification, Point, Pose, PredictedObject, PredictedPath, Quaternion, Shape,
};
use crate::predictor::Samples;
use crate::uuid::track_uuid;

/// Diameter (m) of the cylinder standing for a person.
pub const PERSON_DIAMETER: f64 = 0.6;
/// Height (m) of the cylinder standing for a person.
pub const PERSON_HEIGHT: f64 = 1.7;

/// One person's state for [`fill_object`].
#[derive(Debug, Clone, Copy)]
pub struct Person<'a> {
    /// The track id.
    pub id: &'a str,
    /// The last observed position (m, map frame).
    pub origin: [f64; 2],
    /// The observed velocity (m/s, map frame).
    pub velocity: [f64; 2],
}

/// The prediction step as a `Duration` (rounded to the nanosecond).
pub fn step_duration(dt: f64) -> Duration {
    let t = crate::msg::Time::from_secs_f64(dt);
    Duration {
        sec: t.sec,
        nanosec: t.nanosec,
    }
}

/// The confidence of each of `scores` (log-likelihoods; not finite: 0):
/// `exp(s - best)` over the sum of it over all of them. Into `out`.
pub fn confidences(scores: &[f32], out: &mut Vec<f32>) {
    out.clear();
    let best = scores
        .iter()
        .copied()
        .filter(|s| s.is_finite())
        .fold(f32::NEG_INFINITY, f32::max);
    if !best.is_finite() {
        out.extend(scores.iter().map(|_| 0.0));
        return;
    }
    let weight = |s: f32| {
        if s.is_finite() {
            ((s - best) as f64).exp()
        } else {
            0.0
        }
    };
    let total: f64 = scores.iter().map(|&s| weight(s)).sum();
    out.extend(scores.iter().map(|&s| (weight(s) / total) as f32));
}

/// Fill `o` with `person`'s object from agent `a` of `samples` (`k` per agent, `dt`
/// seconds apart), keeping its best `paths` samples. `order` and `conf` are scratch.
#[allow(clippy::too_many_arguments)]
pub fn fill_object(
    o: &mut PredictedObject,
    person: Person<'_>,
    samples: &Samples,
    a: usize,
    paths: usize,
    dt: f64,
    order: &mut Vec<usize>,
    conf: &mut Vec<f32>,
) {
    let k = samples.k;
    o.object_id.uuid = track_uuid(person.id);
    o.existence_probability = 1.0;
    o.classification.clear();
    o.classification.push(ObjectClassification {
        label: ObjectClassification::PEDESTRIAN,
        probability: 1.0,
    });
    o.shape.type_ = Shape::CYLINDER;
    o.shape.footprint.points.clear();
    o.shape.dimensions.x = PERSON_DIAMETER;
    o.shape.dimensions.y = PERSON_DIAMETER;
    o.shape.dimensions.z = PERSON_HEIGHT;

    // which samples, how confident
    order.clear();
    order.extend(0..k);
    let scores = samples.scores.get(a * k..(a + 1) * k);
    match scores {
        Some(scores) => {
            confidences(scores, conf);
            // highest confidence first, the first of equals first (no allocation)
            order.sort_unstable_by(|&i, &j| conf[j].total_cmp(&conf[i]).then(i.cmp(&j)));
        }
        None => {
            conf.clear();
            conf.extend((0..k).map(|_| 1.0 / k as f32));
        }
    }
    let n = paths.min(k);
    order.truncate(n);

    let [x0, y0] = person.origin;
    let [vx, vy] = person.velocity;
    let speed = vx.hypot(vy);
    let first_heading = |s: usize| {
        samples
            .sample(a, s)
            .iter()
            .map(|q| (q[0] as f64 - x0, q[1] as f64 - y0))
            .find(|(dx, dy)| dx.hypot(*dy) > 1e-9)
            .map(|(dx, dy)| dy.atan2(dx))
    };
    let yaw = if speed > 1e-9 {
        vy.atan2(vx)
    } else {
        order.first().and_then(|&s| first_heading(s)).unwrap_or(0.0)
    };

    let kin = &mut o.kinematics;
    kin.initial_pose_with_covariance.pose = Pose {
        position: Point {
            x: x0,
            y: y0,
            z: 0.0,
        },
        orientation: Quaternion::from_yaw(yaw),
    };
    kin.initial_pose_with_covariance.covariance.0 = [0.0; 36];
    let tw = &mut kin.initial_twist_with_covariance;
    tw.twist.linear.x = speed;
    tw.twist.linear.y = 0.0;
    tw.twist.linear.z = 0.0;
    tw.twist.angular = Default::default();
    tw.covariance.0 = [0.0; 36];
    kin.initial_acceleration_with_covariance = Default::default();

    let step = step_duration(dt);
    kin.predicted_paths.truncate(n);
    while kin.predicted_paths.len() < n {
        kin.predicted_paths.push(PredictedPath::default());
    }
    for (path, &s) in kin.predicted_paths.iter_mut().zip(order.iter()) {
        path.time_step = step;
        path.confidence = conf[s];
        fill_path(&mut path.path, [x0, y0], samples.sample(a, s), yaw);
    }
}

/// The poses of a path: `origin` then `points`, each heading towards the next (the
/// last, and any pose whose next is at the same place, keeps the heading before it;
/// the first before any is `yaw0`).
pub fn fill_path(out: &mut Vec<Pose>, origin: [f64; 2], points: &[[f32; 2]], yaw0: f64) {
    out.clear();
    let at = |i: usize| -> [f64; 2] {
        if i == 0 {
            origin
        } else {
            let q = points[i - 1];
            [q[0] as f64, q[1] as f64]
        }
    };
    let len = points.len() + 1;
    let mut yaw = yaw0;
    for i in 0..len {
        let p = at(i);
        if i + 1 < len {
            let q = at(i + 1);
            let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
            if dx.hypot(dy) > 1e-9 {
                yaw = dy.atan2(dx);
            }
        }
        out.push(Pose {
            position: Point {
                x: p[0],
                y: p[1],
                z: 0.0,
            },
            orientation: Quaternion::from_yaw(yaw),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn yaw_of(q: Quaternion) -> f64 {
        2.0 * q.z.atan2(q.w)
    }

    #[test]
    fn confidences_are_shares_of_the_likelihood() {
        let mut c = Vec::new();
        let l = |p: f64| p.ln() as f32;
        confidences(&[l(0.2), l(0.6), l(0.1), l(0.1)], &mut c);
        for (got, want) in c.iter().zip([0.2, 0.6, 0.1, 0.1]) {
            assert!((got - want).abs() < 1e-6, "{c:?}");
        }
        confidences(&[f32::NAN, 0.0, f32::NEG_INFINITY], &mut c);
        assert_eq!(c, [0.0, 1.0, 0.0]);
        confidences(&[f32::NAN], &mut c);
        assert_eq!(c, [0.0]);
        // far apart log-likelihoods: no overflow, the best takes it all
        confidences(&[-5000.0, 100.0], &mut c);
        assert_eq!(c, [0.0, 1.0]);
    }

    fn samples(scores: Vec<f32>) -> Samples {
        // agent 0: 3 samples of 2 steps: east, north, west; sample 2 stops after one
        Samples {
            agents: 1,
            k: 3,
            steps: 2,
            positions: vec![
                [1.0, 0.0],
                [2.0, 0.0],
                [0.0, 1.0],
                [0.0, 2.0],
                [-1.0, 0.0],
                [9.0, 9.0],
            ],
            lens: vec![2, 2, 1],
            scores,
        }
    }

    #[test]
    fn best_paths_by_score_with_headings_and_step() {
        let s = samples(vec![(0.25f32).ln(), (0.5f32).ln(), (0.25f32).ln()]);
        let mut o = PredictedObject::default();
        let (mut order, mut conf) = (Vec::new(), Vec::new());
        let person = Person {
            id: "a",
            origin: [0.0, 0.0],
            velocity: [0.0, 1.2],
        };
        fill_object(&mut o, person, &s, 0, 2, 0.4, &mut order, &mut conf);
        let k = &o.kinematics;
        assert_eq!(k.predicted_paths.len(), 2);
        // north (0.5) first, then east (0.25, the first of the equals)
        let north = &k.predicted_paths[0];
        assert!((north.confidence - 0.5).abs() < 1e-6);
        assert_eq!(
            north.time_step,
            Duration {
                sec: 0,
                nanosec: 400_000_000
            }
        );
        let ys: Vec<f64> = north.path.iter().map(|p| p.position.y).collect();
        assert_eq!(ys, [0.0, 1.0, 2.0]);
        for p in &north.path {
            assert!((yaw_of(p.orientation) - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        }
        let east = &k.predicted_paths[1];
        assert!((east.confidence - 0.25).abs() < 1e-6);
        assert_eq!(east.path[2].position.x, 2.0);
        assert!(yaw_of(east.path[0].orientation).abs() < 1e-12);
        let sum: f32 = k.predicted_paths.iter().map(|p| p.confidence).sum();
        assert!(sum <= 1.0);
        // initial state: heading along the velocity, speed forward in the object frame
        assert!(
            (yaw_of(k.initial_pose_with_covariance.pose.orientation) - std::f64::consts::FRAC_PI_2)
                .abs()
                < 1e-12
        );
        assert_eq!(k.initial_twist_with_covariance.twist.linear.x, 1.2);
        assert_eq!(o.classification.len(), 1);
        assert_eq!(o.classification[0].label, ObjectClassification::PEDESTRIAN);
        assert_eq!(o.shape.type_, Shape::CYLINDER);
        assert_eq!(o.object_id.uuid, track_uuid("a"));
        // a second fill with fewer paths reuses the object
        fill_object(&mut o, person, &s, 0, 1, 0.4, &mut order, &mut conf);
        assert_eq!(o.kinematics.predicted_paths.len(), 1);
        assert_eq!(o.classification.len(), 1);
    }

    #[test]
    fn unscored_samples_are_equally_likely() {
        let s = samples(Vec::new());
        let mut o = PredictedObject::default();
        let (mut order, mut conf) = (Vec::new(), Vec::new());
        let person = Person {
            id: "b",
            origin: [0.0, 0.0],
            velocity: [0.0, 0.0],
        };
        fill_object(&mut o, person, &s, 0, 10, 0.5, &mut order, &mut conf);
        let paths = &o.kinematics.predicted_paths;
        assert_eq!(paths.len(), 3);
        for p in paths {
            assert!((p.confidence - 1.0 / 3.0).abs() < 1e-6);
        }
        // the stopped sample: origin and one point, heading west
        assert_eq!(paths[2].path.len(), 2);
        assert!((yaw_of(paths[2].path[1].orientation).abs() - std::f64::consts::PI).abs() < 1e-9);
        // standing still: the heading of the first path
        assert!(yaw_of(o.kinematics.initial_pose_with_covariance.pose.orientation).abs() < 1e-12);
        assert_eq!(
            o.kinematics.initial_twist_with_covariance.twist.linear.x,
            0.0
        );
    }
}
