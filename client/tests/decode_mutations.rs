//! Property test of request decoding: random requests, mostly valid and then
//! perturbed field by field, go through `decode_request` with the default limits; none
//! panics, and every accepted one predicts (with its options and scores) on the demo
//! map with the shape it asked for.
//! Seeded, so a failure reproduces; `fuzz/` holds the long-running fuzz target.

use cliff::map::CliffMap;
use cliff::predict::{TrajectoryBatch, predict_with};
use cliff_client::protocol::{
    DecodeScratch, FLAG_SCORES, FLAG_VELOCITY, KIND_PREDICT, Limits, MAX_HISTORY, Observation,
    PROTOCOL_VERSION, RequestHeader, decode_request,
};
use rand::{Rng, RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

const ODD: &[f64] = &[
    0.0,
    -0.0,
    -1.0,
    1e-300,
    1e300,
    -1e300,
    f64::MAX,
    f64::MIN_POSITIVE,
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    1e6,
    1e20,
];

fn odd(rng: &mut impl Rng) -> f64 {
    ODD[rng.random_range(0..ODD.len())]
}

/// A valid request in the demo hall, small enough to predict quickly.
fn valid(rng: &mut impl Rng) -> (RequestHeader, Vec<Observation>) {
    let horizon = rng.random_range(0.0..8.0);
    let h = RequestHeader {
        k: rng.random_range(1..=6),
        agents: rng.random_range(1..=4),
        dt: [0.4, 1.0, 0.1][rng.random_range(0..3)],
        horizon,
        radius: rng.random_range(0.1..3.0),
        beta: rng.random_range(0.0..3.0),
        method: rng.random_range(0..3),
        heading_rule: rng.random_range(0..2),
        seed: rng.random(),
        speed_beta: [0.0, rng.random_range(0.0..4.0)][rng.random_range(0..2)],
        coast: [0.0, rng.random_range(0.0..=horizon)][rng.random_range(0..2)],
        flags: rng.random_range(0..2) * FLAG_SCORES,
        time_mode: rng.random_range(0..3),
        time: rng.random_range(1.0e9..2.0e9),
        ..RequestHeader::default()
    };
    let mut rows = Vec::new();
    for a in 0..h.agents {
        let velocity = rng.random_bool(0.5);
        let n = rng.random_range(if velocity { 1 } else { 2 }..=8);
        let (mut x, mut y) = (rng.random_range(-15.0..15.0), rng.random_range(-10.0..10.0));
        for i in 0..n {
            x += rng.random_range(-0.6..0.6);
            y += rng.random_range(-0.6..0.6);
            let t = 0.4 * i as f64;
            rows.push(Observation {
                agent: a,
                ..if velocity {
                    Observation::with_velocity(t, x, y, rng.random_range(0.0..2.0), rng.random())
                } else {
                    Observation::position(t, x, y)
                }
            });
        }
    }
    (h, rows)
}

/// Perturb one thing of the request.
fn perturb(h: &mut RequestHeader, rows: &mut Vec<Observation>, rng: &mut impl Rng) {
    match rng.random_range(0..18) {
        0 => h.version = rng.random_range(0..4),
        1 => h.kind = rng.random_range(0..3),
        2 => h.method = rng.random_range(0..4),
        3 => h.heading_rule = rng.random_range(0..4),
        4 => h.k = [0, 50, 51, u32::MAX][rng.random_range(0..4)],
        5 => h.agents = [0, 5, 32, 33, u32::MAX][rng.random_range(0..5)],
        6 => h.dt = odd(rng),
        7 => h.horizon = odd(rng),
        8 => h.beta = odd(rng),
        9 => h.radius = odd(rng),
        13 => h.speed_beta = odd(rng),
        14 => h.coast = [odd(rng), h.horizon + 0.5][rng.random_range(0..2)],
        15 => h.flags = [2, 3, u32::MAX][rng.random_range(0..3)],
        16 => {
            h.time_mode = rng.random_range(0..5);
            h.time = odd(rng);
        }
        10 if !rows.is_empty() => {
            let r = rng.random_range(0..rows.len());
            match rng.random_range(0..6) {
                0 => rows[r].t = odd(rng),
                1 => rows[r].x = odd(rng),
                2 => rows[r].y = odd(rng),
                3 => rows[r].speed = odd(rng),
                4 => rows[r].heading = odd(rng),
                _ => rows[r].flags ^= FLAG_VELOCITY,
            }
        }
        11 if !rows.is_empty() => {
            let r = rng.random_range(0..rows.len());
            rows[r].agent = rng.random_range(0..6);
        }
        12 if !rows.is_empty() => {
            let r = rng.random_range(0..rows.len());
            if rng.random_bool(0.5) {
                rows.remove(r);
            } else {
                let copies = [1, MAX_HISTORY as usize][rng.random_range(0..2)];
                let row = rows[r];
                for _ in 0..copies {
                    rows.insert(r, row);
                }
            }
        }
        _ => {
            // a long horizon at a short step
            h.dt = 0.01;
            h.horizon = rng.random_range(0.0..2.0);
        }
    }
}

#[test]
fn random_requests_never_panic_and_accepted_ones_predict() {
    let map = CliffMap::demo();
    let limits = Limits::default();
    let mut scratch = DecodeScratch::new(&limits);
    let mut batch = TrajectoryBatch::new();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(12);
    let (mut accepted, mut rejected) = (0, 0);
    for i in 0..20_000 {
        let (mut h, mut rows) = valid(&mut rng);
        // a fifth stay valid; the rest get up to three perturbations
        if i % 5 != 0 {
            for _ in 0..rng.random_range(1..=3) {
                perturb(&mut h, &mut rows, &mut rng);
            }
        }
        match decode_request(&h, &rows, &limits, &mut scratch) {
            Ok(decoded) => {
                let (params, options) = (decoded.params, decoded.options);
                accepted += 1;
                assert!(options.validate().is_ok() && options.coast <= params.horizon);
                assert_eq!(h.version, PROTOCOL_VERSION);
                assert_eq!(h.kind, KIND_PREDICT);
                assert!(params.k >= 1 && params.k <= limits.max_k as usize);
                let steps = params.steps();
                assert!(steps >= 1 && steps <= limits.max_steps as usize);
                let states = scratch.states();
                assert_eq!(states.len(), h.agents as usize);
                predict_with(&map, states, &params, &options, &mut batch)
                    .unwrap_or_else(|e| panic!("accepted but not predicted: {e:?} {h:?}"));
                assert_eq!(batch.shape(), (states.len(), params.k, steps));
                let samples = if options.scores {
                    batch.lens().len()
                } else {
                    0
                };
                assert_eq!(batch.scores().len(), samples);
                // -inf for absurd speeds (1e308 m/s), never NaN
                assert!(batch.scores().iter().all(|s| !s.is_nan()), "{h:?}");
            }
            Err(_) => rejected += 1,
        }
    }
    assert!(
        accepted > 4000 && rejected > 7500,
        "{accepted} accepted, {rejected} rejected"
    );
}
