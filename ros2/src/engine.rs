//! The node without ROS: people messages in, a predictions message and markers out.
//! [`crate::node`] wires it to DDS; tests drive it directly.

use std::time::{Duration, Instant};

use crate::markers::{self, MarkerStyle};
use std::sync::Arc;

use crate::grid::GridBuilder;
use crate::msg::{
    Header, Marker, MarkerArray, OccupancyGrid, People, PersonPrediction, Point2, PredictedObject,
    PredictedObjects, Predictions, Shared, Time, TrackedObjects,
};
use crate::objects;
use crate::observer::Observer;
use crate::predictor::{ObserveError, PredictError, Predictor, method_name};
use crate::tracks::{Keeper, Skip};
use crate::warn::RateLimit;

/// Counters of what the engine did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// People messages applied.
    pub messages: u64,
    /// Cycles that published predictions.
    pub predicted: u64,
    /// Cycles without a prediction because the daemon was away.
    pub unavailable: u64,
    /// Cycles whose request was refused.
    pub refused: u64,
}

/// One cycle's output. The engine owns it and reuses it from cycle to cycle (its
/// strings and lists keep their capacity: a steady cycle allocates nothing); publishers
/// get shared handles ([`Shared`]), not copies.
#[derive(Debug, Default)]
pub struct Output {
    predictions: Arc<Predictions>,
    predicted: bool,
    markers: Arc<MarkerArray>,
    objects: Arc<PredictedObjects>,
    grid: Arc<OccupancyGrid>,
    gridded: bool,
}

impl Output {
    /// The predictions, when this cycle predicted.
    pub fn predictions(&self) -> Option<&Predictions> {
        self.predicted.then_some(&*self.predictions)
    }

    /// Line strips of the samples and deletions of ended tracks (may be empty).
    pub fn markers(&self) -> &MarkerArray {
        &self.markers
    }

    /// The predictions to publish (a handle, not a copy), when this cycle predicted.
    pub fn shared_predictions(&self) -> Option<Shared<Predictions>> {
        self.predicted
            .then(|| Shared(Arc::clone(&self.predictions)))
    }

    /// The markers to publish (a handle, not a copy).
    pub fn shared_markers(&self) -> Shared<MarkerArray> {
        Shared(Arc::clone(&self.markers))
    }

    /// The predictions as Autoware's `PredictedObjects`, when this cycle predicted.
    pub fn objects(&self) -> Option<&PredictedObjects> {
        self.predicted.then_some(&*self.objects)
    }

    /// The occupancy grid, when this cycle predicted and the engine has a grid.
    pub fn grid(&self) -> Option<&OccupancyGrid> {
        self.gridded.then_some(&*self.grid)
    }

    /// The grid to publish (a handle, not a copy), when there is one this cycle.
    pub fn shared_grid(&self) -> Option<Shared<OccupancyGrid>> {
        self.gridded.then(|| Shared(Arc::clone(&self.grid)))
    }

    /// The objects to publish (a handle, not a copy), when this cycle predicted.
    pub fn shared_objects(&self) -> Option<Shared<PredictedObjects>> {
        self.predicted.then(|| Shared(Arc::clone(&self.objects)))
    }
}

/// People in, predictions out.
pub struct Engine {
    keeper: Keeper,
    predictor: Predictor,
    style: MarkerStyle,
    warn: Vec<RateLimit>,
    warn_predict: RateLimit,
    warn_observe: RateLimit,
    observer: Option<Observer>,
    away: bool,
    selected: Vec<usize>,
    ended: Vec<u32>,
    alphas: Vec<f32>,
    hex_ids: Vec<[u8; 32]>,
    header: Header,
    out: Output,
    spare_markers: Vec<Marker>,
    spare_people: Vec<PersonPrediction>,
    spare_objects: Vec<PredictedObject>,
    object_paths: usize,
    order: Vec<usize>,
    confidences: Vec<f32>,
    grid: Option<GridBuilder>,
    warn_grid: RateLimit,
    stats: Stats,
}

/// Paths per object on `cliff/objects` unless set ([`Engine::set_object_paths`]).
pub const DEFAULT_OBJECT_PATHS: usize = 3;

/// At least this many observations make a history (the velocity needs two).
pub const MIN_HISTORY: usize = 2;

impl Engine {
    /// An engine over `keeper` and `predictor`, warning at most once per `warn_period`.
    pub fn new(
        keeper: Keeper,
        predictor: Predictor,
        style: MarkerStyle,
        warn_period: Duration,
    ) -> Self {
        let header = Header {
            stamp: Time::default(),
            frame_id: keeper.settings().frame_id.clone(),
        };
        Engine {
            keeper,
            predictor,
            style,
            warn: vec![RateLimit::new(warn_period); Skip::ALL.len()],
            warn_predict: RateLimit::new(warn_period),
            warn_observe: RateLimit::new(warn_period),
            observer: None,
            away: false,
            selected: Vec::new(),
            ended: Vec::new(),
            alphas: Vec::new(),
            hex_ids: Vec::new(),
            header,
            out: Output::default(),
            spare_markers: Vec::new(),
            spare_people: Vec::new(),
            spare_objects: Vec::new(),
            object_paths: DEFAULT_OBJECT_PATHS,
            order: Vec::new(),
            confidences: Vec::new(),
            grid: None,
            warn_grid: RateLimit::new(warn_period),
            stats: Stats::default(),
        }
    }

    /// Send every track's rows to the daemon as observations too, after each cycle's
    /// prediction (parameter `observe`).
    pub fn with_observer(mut self, observer: Observer) -> Self {
        self.observer = Some(observer);
        self
    }

    /// The observer, when the engine sends observations.
    pub fn observer(&self) -> Option<&Observer> {
        self.observer.as_ref()
    }

    /// Keep the best `n` samples of each person as the paths of its object on
    /// `cliff/objects` (parameter `object_paths`; at most `k` are kept).
    pub fn set_object_paths(&mut self, n: usize) {
        self.object_paths = n;
    }

    /// Publish the predictions as an occupancy grid too ([`crate::grid`]).
    pub fn set_grid(&mut self, grid: Option<GridBuilder>) {
        self.grid = grid;
    }

    /// The grid builder, when the engine makes a grid.
    pub fn grid(&self) -> Option<&GridBuilder> {
        self.grid.as_ref()
    }

    /// The tracks.
    pub fn keeper(&self) -> &Keeper {
        &self.keeper
    }

    /// The predictor.
    pub fn predictor(&self) -> &Predictor {
        &self.predictor
    }

    /// The last cycle's output.
    pub fn output(&self) -> &Output {
        &self.out
    }

    /// The counters.
    pub fn stats(&self) -> Stats {
        self.stats
    }

    /// Apply a people message (`name` is the track id).
    pub fn on_people(&mut self, msg: &People, now: Instant) {
        let people = msg
            .people
            .iter()
            .map(|p| (p.name.as_str(), p.position.x, p.position.y));
        self.apply("people", &msg.header, people, now);
    }

    /// Apply a tracked-objects message: its pedestrians (most probable label 7), the
    /// uuid in hex as the track id; other objects are ignored.
    pub fn on_tracked_objects(&mut self, msg: &TrackedObjects, now: Instant) {
        let mut ids = std::mem::take(&mut self.hex_ids);
        ids.clear();
        ids.extend(
            msg.objects
                .iter()
                .filter(|o| o.is_pedestrian())
                .map(|o| o.object_id.hex()),
        );
        let people = msg
            .objects
            .iter()
            .filter(|o| o.is_pedestrian())
            .zip(&ids)
            .map(|(o, id)| {
                let p = o.kinematics.pose_with_covariance.pose.position;
                // hex digits are ASCII
                (std::str::from_utf8(id).unwrap_or(""), p.x, p.y)
            });
        self.apply("tracked_objects", &msg.header, people, now);
        self.hex_ids = ids;
    }

    fn apply<'a>(
        &mut self,
        input: &str,
        header: &Header,
        people: impl Iterator<Item = (&'a str, f64, f64)>,
        now: Instant,
    ) {
        self.stats.messages += 1;
        let warn = &mut self.warn;
        let keeper = &mut self.keeper;
        let frame = header.frame_id.as_str();
        let stamp = header.stamp.as_secs_f64();
        let mut skipped = [false; Skip::ALL.len()];
        keeper.apply(frame, stamp, people, now, |k| skipped[k.index()] = true);
        for k in Skip::ALL {
            if skipped[k.index()]
                && let Some(held) = warn[k.index()].check(now)
            {
                tracing::warn!(
                    "{input} input skipped: {} (frame '{frame}', stamp {stamp:.3}, map frame '{}'); {} so far, {held} warnings held back",
                    k.name(),
                    keeper.settings().frame_id,
                    keeper.count(k)
                );
            }
        }
    }

    /// Count a message of `input` (a topic key) that could not be decoded.
    pub fn on_malformed(&mut self, input: &str, error: &str, now: Instant) {
        self.keeper.count_skip(Skip::Malformed);
        if let Some(held) = self.warn[Skip::Malformed.index()].check(now) {
            tracing::warn!(
                "{input} input skipped: malformed message ({error}); {} so far, {held} warnings held back",
                self.keeper.count(Skip::Malformed)
            );
        }
    }

    /// The newest input stamp (0 before any) in the map frame.
    fn refresh_header(&mut self) {
        let newest = self.keeper.newest();
        self.header.stamp = Time::from_secs_f64(if newest.is_finite() { newest } else { 0.0 });
    }

    /// Empty the output, taking its messages back into the spare pools (a cycle starts
    /// with this; no allocation).
    pub fn clear_output(&mut self) {
        let markers = Arc::make_mut(&mut self.out.markers);
        self.spare_markers.append(&mut markers.markers);
        let predictions = Arc::make_mut(&mut self.out.predictions);
        self.spare_people.append(&mut predictions.people);
        let objects = Arc::make_mut(&mut self.out.objects);
        self.spare_objects.append(&mut objects.objects);
        self.out.predicted = false;
        self.out.gridded = false;
    }

    /// Forget stale tracks and delete their markers (no prediction): what an idle
    /// on-input node does between messages. Empty when nothing ended.
    pub fn expire(&mut self, now: Instant) -> &MarkerArray {
        self.clear_output();
        self.expire_into_markers(now);
        if !self.ended.is_empty() {
            self.observe(now);
        }
        &self.out.markers
    }

    fn expire_into_markers(&mut self, now: Instant) {
        self.keeper.expire(now);
        self.keeper.take_ended(&mut self.ended);
        if let Some(o) = &mut self.observer {
            o.ended(&self.ended);
        }
        self.refresh_header();
        let k = self.predictor.settings().params.k;
        let markers = Arc::make_mut(&mut self.out.markers);
        for &n in &self.ended {
            for s in 0..k {
                let mut m = self.spare_markers.pop().unwrap_or_default();
                markers::fill_delete(&mut m, &self.header, markers::sample_id(n, k, s));
                markers.markers.push(m);
            }
        }
    }

    /// One cycle: forget stale tracks, predict the others ([`Engine::predict`]), build
    /// the messages ([`Engine::build`]), then send the observations ([`Engine::observe`]).
    pub fn cycle(&mut self, now: Instant) -> &Output {
        self.clear_output();
        self.expire_into_markers(now);
        if self.keeper.newest().is_finite() && self.predict(now) {
            self.build();
        }
        self.observe(now);
        &self.out
    }

    /// The observing step of a cycle (with an observer): the tracks' new rows and ends
    /// to the daemon. A failure leaves them for the next cycle; over budget and refusals
    /// warn (rate-limited).
    pub fn observe(&mut self, now: Instant) {
        let Some(o) = &mut self.observer else {
            return;
        };
        match o.send(&self.keeper, &mut self.predictor) {
            // the daemon's absence is the prediction's warning already; a request of
            // more rows than the daemon takes lowered the observer's rows per request
            Ok(()) | Err(ObserveError::Unavailable(_) | ObserveError::TooManyRows(_)) => {}
            Err(e) => {
                if let Some(held) = self.warn_observe.check(now) {
                    let s = o.stats();
                    tracing::warn!(
                        "observations not taken this cycle: {e} ({} rows taken so far, {} calls over budget, {held} warnings held back)",
                        s.rows,
                        s.over_budget
                    );
                }
            }
        }
    }

    /// The prediction step of a cycle: predict every track with enough history. False
    /// (and a rate-limited warning) when there is no prediction.
    pub fn predict(&mut self, now: Instant) -> bool {
        let newest = self.keeper.newest();
        let seconds = self.keeper.settings().history_seconds;
        self.selected.clear();
        for (i, t) in self.keeper.tracks().iter().enumerate() {
            if t.window(seconds).len() >= MIN_HISTORY {
                self.selected.push(i);
            }
        }
        let tracks = self.keeper.tracks();
        let selected = &self.selected;
        let result = self.predictor.predict(
            selected
                .iter()
                .map(|&i| tracks[i].window(seconds).map(|o| (o.t, o.x, o.y))),
            newest,
        );
        match result {
            Ok(_) => {
                if self.away {
                    tracing::info!("predictions are back");
                    self.away = false;
                    self.warn_predict.reset();
                }
                self.stats.predicted += 1;
                true
            }
            Err(e) => {
                match e {
                    PredictError::Unavailable(_) => {
                        self.stats.unavailable += 1;
                        self.away = true;
                    }
                    PredictError::Refused(_) => self.stats.refused += 1,
                }
                if let Some(held) = self.warn_predict.check(now) {
                    tracing::warn!("no prediction this cycle: {e} ({held} warnings held back)");
                }
                false
            }
        }
    }

    /// The building step of a cycle: [`Engine::build_predictions`],
    /// [`Engine::build_markers`] and [`Engine::build_objects`].
    pub fn build(&mut self) {
        self.build_predictions();
        self.build_markers();
        self.build_objects();
        self.build_grid(Instant::now());
    }

    /// The occupancy grid of the last [`Engine::predict`], when the engine has a grid
    /// ([`Engine::set_grid`]); a failure (not expected from checked settings) skips
    /// this cycle's grid with a rate-limited warning.
    pub fn build_grid(&mut self, now: Instant) {
        let Engine {
            keeper,
            predictor,
            header,
            out,
            selected,
            grid,
            warn_grid,
            ..
        } = self;
        let Some(grid) = grid else {
            return;
        };
        let tracks = keeper.tracks();
        let starts = selected.iter().map(|&i| {
            let last = tracks[i].last().expect("selected tracks have observations");
            [last.x as f32, last.y as f32]
        });
        let dt = predictor.settings().params.dt;
        let msg = Arc::make_mut(&mut out.grid);
        match grid.fill(msg, header, predictor.samples(), starts, dt) {
            Ok(()) => out.gridded = true,
            Err(e) => {
                if let Some(held) = warn_grid.check(now) {
                    tracing::warn!("no occupancy grid this cycle: {e} ({held} warnings held back)");
                }
            }
        }
    }

    /// The `PredictedObjects` message of the last [`Engine::predict`]
    /// ([`crate::objects`]), into the reused output: same stamp and frame as the
    /// predictions.
    pub fn build_objects(&mut self) {
        let Engine {
            keeper,
            predictor,
            header,
            out,
            spare_objects,
            selected,
            object_paths,
            order,
            confidences,
            ..
        } = self;
        let samples = predictor.samples();
        let dt = predictor.settings().params.dt;
        let tracks = keeper.tracks();
        let msg = Arc::make_mut(&mut out.objects);
        spare_objects.append(&mut msg.objects);
        msg.header.stamp = header.stamp;
        msg.header.frame_id.clone_from(&header.frame_id);
        for (a, &i) in selected.iter().enumerate() {
            let t = &tracks[i];
            // selected tracks have at least two observations
            let last = t.last().expect("selected tracks have observations");
            let prev = (t.len() >= 2).then(|| t.get(t.len() - 2));
            let velocity = match prev {
                Some(p) if last.t > p.t => {
                    let d = last.t - p.t;
                    [(last.x - p.x) / d, (last.y - p.y) / d]
                }
                _ => [0.0, 0.0],
            };
            let mut o = spare_objects.pop().unwrap_or_default();
            objects::fill_object(
                &mut o,
                objects::Person {
                    id: &t.id,
                    origin: [last.x, last.y],
                    velocity,
                },
                samples,
                a,
                *object_paths,
                dt,
                order,
                confidences,
            );
            msg.objects.push(o);
        }
    }

    /// The predictions message from the last [`Engine::predict`], into the reused output
    /// ([`Engine::clear_output`] empties it).
    pub fn build_predictions(&mut self) {
        let Engine {
            keeper,
            predictor,
            header,
            out,
            spare_people,
            selected,
            ..
        } = self;
        let samples = predictor.samples();
        let p = predictor.settings().params;
        let k = p.k;
        let seconds = keeper.settings().history_seconds;
        let tracks = keeper.tracks();
        let msg = Arc::make_mut(&mut out.predictions);
        spare_people.append(&mut msg.people);
        msg.header.stamp = header.stamp;
        msg.header.frame_id.clone_from(&header.frame_id);
        msg.dt = p.dt;
        msg.horizon = p.horizon;
        msg.k = k as u32;
        msg.method.clear();
        msg.method.push_str(method_name(p.method));
        msg.map.clear();
        msg.map.push_str(predictor.map_label());
        msg.seed = p.seed;
        for (a, &i) in selected.iter().enumerate() {
            let t = &tracks[i];
            let last = t.last().expect("selected tracks have observations");
            let mut person = spare_people.pop().unwrap_or_default();
            person.track_id.clone_from(&t.id);
            person.stamp = Time::from_secs_f64(last.t);
            person.history = t.window(seconds).len() as u32;
            person.origin = Point2 {
                x: last.x as f32,
                y: last.y as f32,
            };
            person.lengths.clear();
            person.points.clear();
            person.scores.clear();
            if !samples.scores.is_empty() {
                person
                    .scores
                    .extend((0..k).map(|s| samples.score(a, s).unwrap_or(f32::NAN)));
            }
            for s in 0..k {
                let pts = samples.sample(a, s);
                person.lengths.push(pts.len() as u32);
                person
                    .points
                    .extend(pts.iter().map(|q| Point2 { x: q[0], y: q[1] }));
            }
            msg.people.push(person);
        }
        out.predicted = true;
    }

    /// The line strips of the last [`Engine::predict`] (one per sample, shaded by score
    /// when scored), appended to the output's markers after a cycle's deletions.
    pub fn build_markers(&mut self) {
        let Engine {
            keeper,
            predictor,
            style,
            header,
            out,
            spare_markers,
            selected,
            alphas,
            ..
        } = self;
        let samples = predictor.samples();
        let k = predictor.settings().params.k;
        let tracks = keeper.tracks();
        let markers = Arc::make_mut(&mut out.markers);
        let scored = !samples.scores.is_empty();
        for (a, &i) in selected.iter().enumerate() {
            let t = &tracks[i];
            let last = t.last().expect("selected tracks have observations");
            let origin = [last.x as f32, last.y as f32];
            if scored {
                let scores = samples.scores.get(a * k..(a + 1) * k).unwrap_or(&[]);
                markers::score_alphas(scores, alphas);
            }
            let color = markers::track_color(t.number);
            for s in 0..k {
                let mut c = color;
                if scored && let Some(&a) = alphas.get(s) {
                    c.a = a;
                }
                let mut m = spare_markers.pop().unwrap_or_default();
                markers::fill_line_strip(
                    &mut m,
                    header,
                    style,
                    markers::sample_id(t.number, k, s),
                    origin,
                    samples.sample(a, s),
                    c,
                );
                markers.markers.push(m);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Person, Point};
    use crate::predictor::{PredictSettings, Source};
    use crate::tracks::KeeperSettings;
    use cliff::predict::Params;

    fn people(stamp: f64, who: &[(&str, f64, f64)]) -> People {
        People {
            header: Header {
                stamp: Time::from_secs_f64(stamp),
                frame_id: "map".into(),
            },
            people: who
                .iter()
                .map(|&(n, x, y)| Person {
                    name: n.into(),
                    position: Point { x, y, z: 0.0 },
                    ..Person::default()
                })
                .collect(),
        }
    }

    fn engine(scores: bool) -> Engine {
        let settings = PredictSettings {
            params: Params {
                k: 4,
                horizon: 2.0,
                ..Params::default()
            },
            scores,
            ..PredictSettings::default()
        };
        Engine::new(
            Keeper::new(KeeperSettings::default()),
            Predictor::new(&Source::Demo, settings).unwrap(),
            MarkerStyle::default(),
            Duration::from_secs(5),
        )
    }

    #[test]
    fn two_observations_make_a_prediction_with_markers() {
        let mut e = engine(true);
        let now = Instant::now();
        assert!(e.cycle(now).predictions().is_none());
        e.on_people(&people(0.0, &[("a", -10.0, 0.5), ("b", 0.0, 0.0)]), now);
        // one observation each: nothing to predict from yet, but a (empty) message
        let o = e.cycle(now);
        assert_eq!(o.predictions().unwrap().people.len(), 0);
        e.on_people(&people(0.4, &[("a", -9.5, 0.5)]), now);
        let o = e.cycle(now);
        let p = o.predictions().unwrap();
        assert_eq!(
            (p.people.len(), p.k, p.method.as_str(), p.map.as_str()),
            (1, 4, "cliff", "demo")
        );
        let a = &p.people[0];
        assert_eq!(
            (
                a.track_id.as_str(),
                a.history,
                a.lengths.len(),
                a.scores.len()
            ),
            ("a", 2, 4, 4)
        );
        assert_eq!(a.points.len() as u32, a.lengths.iter().sum::<u32>());
        assert_eq!(a.origin, Point2 { x: -9.5, y: 0.5 });
        assert_eq!(p.header.stamp, Time::from_secs_f64(0.4));
        assert_eq!(o.markers().markers.len(), 4);
        // the same person on the objects topic: the best 3 of the 4 scored samples,
        // each path the origin then that sample's points
        let obj = o.objects().unwrap();
        assert_eq!((obj.header.stamp, obj.objects.len()), (p.header.stamp, 1));
        let a_obj = &obj.objects[0];
        assert_eq!(a_obj.object_id.uuid, crate::uuid::track_uuid("a"));
        let paths = &a_obj.kinematics.predicted_paths;
        assert_eq!(paths.len(), 3);
        let total: f32 = paths.iter().map(|q| q.confidence).sum();
        assert!(total <= 1.0 + 1e-6 && paths[0].confidence >= paths[2].confidence);
        let best = (0..4)
            .max_by(|&i, &j| a.scores[i].total_cmp(&a.scores[j]).then(j.cmp(&i)))
            .unwrap();
        let start: usize = a.lengths[..best].iter().sum::<u32>() as usize;
        let pts = &a.points[start..start + a.lengths[best] as usize];
        assert_eq!(paths[0].path.len(), pts.len() + 1);
        assert_eq!(paths[0].path[0].position.x, -9.5);
        for (pose, q) in paths[0].path[1..].iter().zip(pts) {
            assert_eq!((pose.position.x as f32, pose.position.y as f32), (q.x, q.y));
        }
        // the observed velocity: 0.5 m in 0.4 s
        let v = a_obj
            .kinematics
            .initial_twist_with_covariance
            .twist
            .linear
            .x;
        assert!((v - 1.25).abs() < 1e-9, "{v}");
        // ended tracks get their markers deleted
        e.on_people(&people(3.0, &[("b", 0.1, 0.0)]), now);
        let o = e.cycle(now);
        let deletes = o
            .markers()
            .markers
            .iter()
            .filter(|m| m.action == crate::msg::Marker::DELETE)
            .count();
        assert_eq!(deletes, 4);
    }

    #[test]
    fn the_same_histories_and_seed_give_the_same_points() {
        let run = || {
            let mut e = engine(false);
            let now = Instant::now();
            for i in 0..5 {
                let t = i as f64 * 0.4;
                e.on_people(
                    &people(
                        t,
                        &[
                            ("a", -10.0 + 0.5 * i as f64, 0.5),
                            ("b", 2.0, -1.0 + 0.4 * i as f64),
                        ],
                    ),
                    now,
                );
            }
            e.cycle(now).predictions().unwrap().clone()
        };
        let (x, y) = (run(), run());
        assert_eq!(x, y);
        assert!(x.people[0].scores.is_empty());
    }
}
