//! The in-process reference predictor ([`LocalPredictor`]): the daemon's validation and
//! prediction without a daemon.

use std::sync::Arc;

use cliff::map::CliffMap;
use cliff::motion::MotionModel;
use cliff::predict::{Rollout, TrajectoryBatch};

use super::limits::Limits;
use super::request::{Observation, RequestHeader};
use super::status::{Field, Rejection, Status};
use super::validate::{DecodeScratch, decode_request};

/// The in-process reference: decodes a request exactly as the daemon does and predicts
/// into a reusable [`TrajectoryBatch`]. The same map, request and seed give the same
/// bytes as the daemon's response.
///
/// ```
/// use cliff::map::CliffMap;
/// use cliff::predict::Params;
/// use cliff_client::protocol::LocalPredictor;
/// use cliff_client::{Observation, Request};
///
/// let map = CliffMap::demo();
/// let mut request = Request::new("demo", &Params { k: 5, horizon: 4.0, ..Params::default() }).unwrap();
/// // one person walking east along the demo hall's corridor, observed at 2.5 Hz
/// request.add_agent((0..4).map(|i| Observation::position(0.4 * i as f64, -10.0 + 0.5 * i as f64, 0.5)));
/// let mut local = LocalPredictor::default();
/// let batch = local.predict(&map, request.header(), request.rows()).unwrap();
/// assert_eq!(batch.shape(), (1, 5, 10)); // 1 agent, 5 samples, 4 s at 0.4 s
/// assert!(batch.sample(0, 0)[0][0] > -8.5); // moving east from x = -8.5
/// ```
#[derive(Debug, Clone)]
pub struct LocalPredictor {
    limits: Limits,
    scratch: DecodeScratch,
    batch: TrajectoryBatch,
    motion: Option<Arc<MotionModel>>,
}

impl Default for LocalPredictor {
    fn default() -> Self {
        Self::new(Limits::default())
    }
}

impl LocalPredictor {
    /// A predictor that applies `limits` (use the daemon's to get the same rejections).
    pub fn new(limits: Limits) -> Self {
        LocalPredictor {
            limits,
            scratch: DecodeScratch::new(&limits),
            batch: TrajectoryBatch::new(),
            motion: None,
        }
    }

    /// The same predictor with the motion model that the methods `motion` and
    /// `improved` start from (as `cliffd --motion-model FILE`; default: the built-in).
    pub fn with_motion_model(mut self, model: Arc<MotionModel>) -> Self {
        self.motion = Some(model);
        self
    }

    /// Decode and predict with the request's options (as [`cliff::predict::predict_with_histories`], from each agent's observed rows); the result
    /// stays in [`batch`](Self::batch), with [`TrajectoryBatch::scores`] when the response would
    /// carry them. The request's [`MapTime`](super::MapTime) is validated and `map` used whatever
    /// it says: for a time-of-day set, pass the map the daemon would pick
    /// ([`MapTime::map_in`](super::MapTime::map_in)).
    pub fn predict(
        &mut self,
        map: &CliffMap,
        header: &RequestHeader,
        rows: &[Observation],
    ) -> Result<&TrajectoryBatch, Rejection> {
        let d = decode_request(header, rows, &self.limits, &mut self.scratch)?;
        let (states, histories) = (self.scratch.states(), self.scratch.histories());
        let internal = |_| Rejection::new(Status::Internal, Field::None);
        let mut rollout = Rollout::new(&d.params)
            .and_then(|r| r.with_options(d.options))
            .map_err(internal)?;
        if let Some(m) = &self.motion {
            rollout = rollout.with_motion_model(m.clone());
        }
        rollout
            .predict_batch(map, states, Some(histories), &mut self.batch)
            .map_err(internal)?;
        Ok(&self.batch)
    }

    /// The last batch.
    pub fn batch(&self) -> &TrajectoryBatch {
        &self.batch
    }
}

#[cfg(test)]
mod tests {
    use cliff::predict::{Options, predict_with};

    use super::*;
    use crate::protocol::map_time::MapTime;
    use crate::protocol::request::fixtures::{header, walk};
    use crate::protocol::validate::DecodeScratch;

    #[test]
    fn local_predictor_matches_the_core_predictor() {
        let map = CliffMap::demo();
        let rows = walk(0, 4);
        let mut lp = LocalPredictor::default();
        let mut h = header(1);
        h.seed = 7;
        let b = lp.predict(&map, &h, &rows).unwrap().clone();
        let mut s = DecodeScratch::new(&Limits::default());
        let p = decode_request(&h, &rows, &Limits::default(), &mut s)
            .unwrap()
            .params;
        let mut direct = TrajectoryBatch::new();
        cliff::predict::predict(&map, s.states(), &p, &mut direct).unwrap();
        let bits = |t: &TrajectoryBatch| {
            t.positions()
                .iter()
                .flatten()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(b.shape(), direct.shape());
        assert_eq!(b.lens(), direct.lens());
        assert_eq!(bits(&b), bits(&direct));
        assert!(b.scores().is_empty());

        // with options and scores: the bytes of predict_with
        let options = Options {
            speed_beta: 2.0,
            coast: 4.0,
            scores: true,
            ..Options::default()
        };
        h.set_options(&options);
        h.set_map_time(MapTime::At(3600.0));
        let b = lp.predict(&map, &h, &rows).unwrap().clone();
        let mut direct = TrajectoryBatch::new();
        predict_with(&map, s.states(), &p, &options, &mut direct).unwrap();
        assert_eq!(b.lens(), direct.lens());
        assert_eq!(bits(&b), bits(&direct));
        assert_eq!(b.scores().len(), 20);
        let score_bits =
            |t: &TrajectoryBatch| t.scores().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(score_bits(&b), score_bits(&direct));
        assert!(b.scores().iter().all(|v| v.is_finite()));
        assert!(b.scores().iter().any(|v| *v != b.scores()[0]));
    }
}
