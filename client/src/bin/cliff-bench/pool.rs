//! The requests every client cycles through ([`request_pool`]).

use cliff::map::CliffMap;
use cliff::predict::Params;
use cliff_client::{Observation, Request};

use crate::args::Args;

/// Distinct requests cycled through by every client.
const POOL: usize = 64;

/// Requests with `agents` people each, walking along the map's main flow at
/// well-observed locations (so that samples run their full length).
pub(crate) fn request_pool(map: &CliffMap, a: &Args) -> Result<Vec<Request>, String> {
    let params = Params {
        method: a.method,
        k: a.k,
        dt: a.dt,
        horizon: a.steps as f64 * a.dt,
        ..Params::default()
    };
    let mut locs: Vec<_> = map
        .locations()
        .iter()
        .filter(|l| !l.components.is_empty())
        .collect();
    if locs.is_empty() {
        return Err("the map has no location with a component".into());
    }
    locs.sort_by(|x, y| y.observation_ratio.total_cmp(&x.observation_ratio));
    let locs = &locs[..locs.len().div_ceil(2)];
    let mut pool = Vec::with_capacity(POOL);
    for i in 0..POOL {
        let mut r = Request::new(&a.map, &params)
            .map_err(|e| e.to_string())?
            .scores(a.scores);
        r.set_seed(i as u64 * 7919 + 1);
        for ag in 0..a.agents {
            let l = locs[(i * 131 + ag * 17) % locs.len()];
            let c = l
                .components
                .iter()
                .max_by(|x, y| x.weight.total_cmp(&y.weight))
                .expect("non-empty");
            let (speed, heading) = (c.rho.clamp(0.3, 2.0), c.theta);
            let (dx, dy) = (heading.cos() * speed, heading.sin() * speed);
            let with_velocity = (i + ag) % 2 == 0;
            r.add_agent((0..5).map(|j| {
                let back = (4 - j) as f64 * 0.4;
                let (t, x, y) = (
                    10.0 - back,
                    l.position.x - dx * back,
                    l.position.y - dy * back,
                );
                if with_velocity {
                    Observation::with_velocity(t, x, y, speed, heading)
                } else {
                    Observation::position(t, x, y)
                }
            }));
        }
        pool.push(r);
    }
    Ok(pool)
}
