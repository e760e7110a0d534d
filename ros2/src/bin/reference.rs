//! `cliff-ros2-reference`: the in-process prediction the ROS 2 tests compare the node
//! with. Reads JSON on stdin, writes JSON on stdout; builds each request from the
//! given histories with cliff-client's `Request` and predicts with `LocalPredictor`
//! (exactly as `cliff predict` in-process and cliffd do), in requests of at most 32
//! people seeded `seed + c`, as the node documents.
//!
//! Input: `{"map": FILE|"demo", "method", "k", "horizon", "dt", "seed", "scores",
//! "cycles": [{"stamp": [sec, nanosec], "agents": [[[sec, nanosec, x, y], ...], ...]}]}`
//! Output: `{"cycles": [{"people": [{"lengths": [...], "points": [[x, y], ...],
//! "scores": [...]}]}]}`

use std::io::Read as _;

use anyhow::{Context as _, Result};
use cliff::map::{CliffMap, MapSet};
use cliff::predict::{Method, Params};
use cliff_client::protocol::Limits;
use cliff_client::{LocalPredictor, MapTime, Observation, Request};
use serde::{Deserialize, Serialize};

#[derive(Deserialize)]
struct Input {
    map: String,
    method: String,
    k: usize,
    horizon: f64,
    dt: f64,
    seed: u64,
    scores: bool,
    cycles: Vec<Cycle>,
}

#[derive(Deserialize)]
struct Cycle {
    stamp: (i32, u32),
    agents: Vec<Vec<(i32, u32, f64, f64)>>,
}

#[derive(Serialize)]
struct Person {
    lengths: Vec<u32>,
    points: Vec<[f32; 2]>,
    scores: Vec<f32>,
}

#[derive(Serialize)]
struct CycleOut {
    people: Vec<Person>,
}

#[derive(Serialize)]
struct Output {
    cycles: Vec<CycleOut>,
}

fn secs((sec, nanosec): (i32, u32)) -> f64 {
    sec as f64 + nanosec as f64 * 1e-9
}

fn main() -> Result<()> {
    let mut text = String::new();
    std::io::stdin().read_to_string(&mut text)?;
    let input: Input = serde_json::from_str(&text).context("reference input")?;
    let maps = if input.map == "demo" {
        MapSet::single(CliffMap::demo())
    } else {
        MapSet::load(&input.map).with_context(|| format!("loading {}", input.map))?
    };
    let method: Method = input.method.parse().map_err(anyhow::Error::msg)?;
    let params = Params {
        method,
        k: input.k,
        horizon: input.horizon,
        dt: input.dt,
        seed: input.seed,
        ..Params::default()
    };
    let limits = Limits::default();
    let mut local = LocalPredictor::new(limits);
    let mut out = Output { cycles: Vec::new() };
    for cycle in &input.cycles {
        let when = MapTime::At(secs(cycle.stamp));
        let mut people = Vec::new();
        for (c, chunk) in cycle.agents.chunks(limits.max_agents as usize).enumerate() {
            let mut request = Request::new(
                "local",
                &Params {
                    seed: input.seed.wrapping_add(c as u64),
                    ..params
                },
            )?
            .scores(input.scores);
            request.set_map_time(when);
            for h in chunk {
                request.add_agent(
                    h.iter()
                        .map(|&(s, n, x, y)| Observation::position(secs((s, n)), x, y)),
                );
            }
            let b = local
                .predict(when.map_in(&maps), request.header(), request.rows())
                .map_err(|r| anyhow::anyhow!("refused: {r}"))?;
            for a in 0..chunk.len() {
                let mut p = Person {
                    lengths: Vec::new(),
                    points: Vec::new(),
                    scores: Vec::new(),
                };
                for s in 0..input.k {
                    let pts = b.sample(a, s);
                    p.lengths.push(pts.len() as u32);
                    p.points.extend_from_slice(pts);
                    if input.scores {
                        p.scores.push(b.score(a, s).unwrap_or(f32::NAN));
                    }
                }
                people.push(p);
            }
        }
        out.cycles.push(CycleOut { people });
    }
    serde_json::to_writer(std::io::stdout().lock(), &out)?;
    Ok(())
}
