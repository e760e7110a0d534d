//! The guards between observations and a served map: a track's rows in one update
//! capped ([`thin`]), one client's share of an update capped ([`share_capped`]), and a
//! new version checked on a held-out sample of recent observations before it is served
//! ([`HeldSample`]). Their settings are [`Guards`](crate::settings::Guards).

use std::collections::{HashMap, VecDeque};

use cliff::map::CliffMap;
use cliff::map::build::Observation as MapObservation;
use cliff::map::score::{ScoreParams, score};

use super::intake::{ClientKey, Segment};

/// At most `cap` rows of `rows`, evenly spaced (all of them when there are fewer).
pub(crate) fn thin(rows: &[MapObservation], cap: usize) -> impl Iterator<Item = MapObservation> {
    let n = rows.len();
    let keep = n.min(cap);
    (0..keep).map(move |i| rows[i * n / keep.max(1)])
}

/// The rows of one update from the rows waiting per client: each client's rows thinned
/// evenly to at most `share x max(total, floor)`.
pub(crate) fn share_capped(
    waiting: HashMap<ClientKey, Vec<MapObservation>>,
    share: f64,
    floor: usize,
) -> Vec<MapObservation> {
    let total: usize = waiting.values().map(Vec::len).sum();
    let cap = ((share * total.max(floor) as f64).ceil() as usize).max(1);
    let mut out = Vec::with_capacity(total.min(cap * waiting.len()));
    // in client order, so that an update does not depend on the hash map's order
    let mut clients: Vec<_> = waiting.into_iter().collect();
    clients.sort_by_key(|(c, _)| *c);
    for (_, rows) in clients {
        out.extend(thin(&rows, cap));
    }
    out
}

/// Recent rows held out of learning, on which a new version must not score worse than
/// the served one.
#[derive(Debug)]
pub(crate) struct HeldSample {
    rows: VecDeque<MapObservation>,
    cap: usize,
    every: usize,
    seen: usize,
}

impl HeldSample {
    pub fn new(cap: usize, every: usize) -> Self {
        HeldSample {
            rows: VecDeque::with_capacity(cap),
            cap,
            every: every.max(1),
            seen: 0,
        }
    }

    /// Keep every `every`-th segment (the newest `cap` rows of them) and give back the
    /// others, to be learned.
    pub fn offer(&mut self, s: Segment) -> Option<Segment> {
        self.seen += 1;
        if self.cap == 0 || !self.seen.is_multiple_of(self.every) {
            return Some(s);
        }
        for o in s.observations {
            if self.rows.len() == self.cap {
                self.rows.pop_front();
            }
            self.rows.push_back(o);
        }
        None
    }

    /// Rows held now.
    #[cfg(test)]
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Why `candidate` must not replace `current` (its mean log-likelihood on the held
    /// rows more than `max_drop` below), or `None`.
    pub fn refuses(
        &self,
        current: &CliffMap,
        candidate: &CliffMap,
        max_drop: f64,
    ) -> Option<String> {
        if self.rows.len() < 100 {
            return None; // too few to judge
        }
        let rows: Vec<MapObservation> = self.rows.iter().copied().collect();
        let p = ScoreParams::default();
        let (Ok(a), Ok(b)) = (score(current, &rows, &p), score(candidate, &rows, &p)) else {
            return Some("the held-out rows cannot be scored".into());
        };
        let (a, b) = (a.mean_log_likelihood, b.mean_log_likelihood);
        if !b.is_finite() {
            return Some(format!(
                "it does not explain the {} held-out rows",
                rows.len()
            ));
        }
        (a.is_finite() && b < a - max_drop).then(|| {
            format!(
                "mean log-likelihood {b:.3} on {} held-out rows, the served version's {a:.3} (allowed drop {max_drop})",
                rows.len()
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cliff::glam::DVec2;

    fn obs(n: usize, x: f64) -> Vec<MapObservation> {
        (0..n)
            .map(|i| MapObservation {
                position: DVec2::new(x, i as f64),
                theta: 0.0,
                rho: 1.0,
            })
            .collect()
    }

    #[test]
    fn a_track_and_a_client_are_capped() {
        let t: Vec<_> = thin(&obs(1000, 0.0), 10).collect();
        assert_eq!(t.len(), 10);
        assert_eq!((t[0].position.y, t[9].position.y), (0.0, 900.0));
        assert_eq!(thin(&obs(5, 0.0), 10).count(), 5);
        let mut w = HashMap::new();
        w.insert(1, obs(900, 1.0));
        w.insert(2, obs(100, 2.0));
        // at most half of 1000 rows per client
        let b = share_capped(w.clone(), 0.5, 10);
        let of = |x: f64| b.iter().filter(|o| o.position.x == x).count();
        assert_eq!((of(1.0), of(2.0)), (500, 100));
        // a client alone counts against the floor
        let mut alone = HashMap::new();
        alone.insert(1, obs(900, 1.0));
        assert_eq!(share_capped(alone, 0.5, 1000).len(), 500);
        assert_eq!(share_capped(w, 1.0, 10).len(), 1000);
    }

    #[test]
    fn a_version_that_explains_the_held_rows_worse_is_refused() {
        let mut held = HeldSample::new(1000, 2);
        let seg = |x: f64| Segment {
            map: 0,
            client: 1,
            track: 1,
            observations: (0..100)
                .map(|i| MapObservation {
                    position: DVec2::new(x + (i % 10) as f64 * 0.5, -1.0 + (i / 10) as f64 * 0.2),
                    theta: 0.0,
                    rho: 1.3,
                })
                .collect(),
            times: vec![0.0; 100],
        };
        // every second segment is held
        assert!(held.offer(seg(-5.0)).is_some());
        assert!(held.offer(seg(-5.0)).is_none());
        assert!(held.offer(seg(-4.0)).is_some());
        assert!(held.offer(seg(-4.0)).is_none());
        assert_eq!(held.len(), 200);
        let demo = CliffMap::demo();
        assert_eq!(held.refuses(&demo, &demo, 0.05), None);
        // the demo hall with every direction turned around explains people walking east
        // worse
        let turned: Vec<_> = demo
            .locations()
            .iter()
            .map(|l| {
                let mut l = l.clone();
                for c in &mut l.components {
                    c.theta = cliff::math::wrap_2pi(c.theta + std::f64::consts::PI);
                }
                l
            })
            .collect();
        let turned = CliffMap::with_grid_step(turned, Some(demo.grid().step())).unwrap();
        let why = held.refuses(&demo, &turned, 0.05).expect("refused");
        assert!(why.contains("held-out rows"), "{why}");
    }
}
