//! Request decoding: arbitrary header fields and rows into `decode_request`, then, when
//! the request is accepted, `predict_with` (its options, scores) on the demo map, which
//! must succeed; an observe request (kind 2, local or on the zenoh observe key) into
//! `validate_observe` too, and every request through the zenoh byte encoding
//! (`wire::encode_request`, `wire::decode_request`), which must give it back.
//!
//! Limits are smaller than the daemon's defaults (4 agents, 8 samples, 25 steps) so that
//! an accepted request predicts in microseconds; the code paths are the same.
#![no_main]

use std::sync::LazyLock;

use arbitrary::Arbitrary;
use cliff::map::CliffMap;
use cliff::predict::{TrajectoryBatch, predict_with};
use cliff_client::protocol::{
    DecodeScratch, KIND_OBSERVE, Limits, MAP_NAME_BYTES, Observation, PROTOCOL_VERSION,
    RequestHeader, decode_request, validate_observe,
};
use cliff_client::wire;
use libfuzzer_sys::fuzz_target;

/// A number the fuzzer can make plausible (a small multiple of 1/16) or anything.
#[derive(Debug, Arbitrary)]
enum Num {
    Small(i16),
    Raw(f64),
}

impl Num {
    fn get(&self) -> f64 {
        match *self {
            Num::Small(i) => i as f64 / 16.0,
            Num::Raw(v) => v,
        }
    }
}

/// A small code (mostly valid) or any `u32`.
#[derive(Debug, Arbitrary)]
enum Code {
    Small(u8),
    Raw(u32),
}

impl Code {
    fn get(&self) -> u32 {
        match *self {
            Code::Small(c) => (c % 4) as u32,
            Code::Raw(v) => v,
        }
    }
}

/// A small count (0 to 15: across the limits) or any `u32`.
#[derive(Debug, Arbitrary)]
enum Count {
    Small(u8),
    Raw(u32),
}

impl Count {
    fn get(&self) -> u32 {
        match *self {
            Count::Small(c) => (c % 16) as u32,
            Count::Raw(v) => v,
        }
    }
}

#[derive(Debug, Arbitrary)]
struct Row {
    agent: Code,
    velocity: bool,
    t: Num,
    x: Num,
    y: Num,
    speed: Num,
    heading: Num,
}

#[derive(Debug, Arbitrary)]
struct Input {
    version_ok: bool,
    version: u32,
    kind: Code,
    request_id: u64,
    method: Code,
    heading_rule: Code,
    k: Count,
    agents: Count,
    dt: Num,
    horizon: Num,
    beta: Num,
    radius: Num,
    seed: u64,
    speed_beta: Num,
    coast: Num,
    flags: Code,
    time_mode: Code,
    time: Num,
    rows: Vec<Row>,
}

static MAP: LazyLock<CliffMap> = LazyLock::new(CliffMap::demo);

const LIMITS: Limits = Limits {
    max_agents: 4,
    max_k: 8,
    max_steps: 25,
    max_history: 64,
};

fuzz_target!(|input: Input| {
    let header = RequestHeader {
        version: if input.version_ok {
            PROTOCOL_VERSION
        } else {
            input.version
        },
        kind: input.kind.get(),
        request_id: input.request_id,
        listener_id: [0, 0],
        map: [0; MAP_NAME_BYTES],
        method: input.method.get(),
        heading_rule: input.heading_rule.get(),
        k: input.k.get(),
        agents: input.agents.get(),
        dt: input.dt.get(),
        horizon: input.horizon.get(),
        beta: input.beta.get(),
        radius: input.radius.get(),
        seed: input.seed,
        speed_beta: input.speed_beta.get(),
        coast: input.coast.get(),
        flags: input.flags.get(),
        time_mode: input.time_mode.get(),
        time: input.time.get(),
    };
    let rows: Vec<Observation> = input
        .rows
        .iter()
        .take(512)
        .map(|r| Observation {
            agent: r.agent.get(),
            flags: r.velocity as u32,
            t: r.t.get(),
            x: r.x.get(),
            y: r.y.get(),
            speed: r.speed.get(),
            heading: r.heading.get(),
        })
        .collect();
    let mut bytes = Vec::new();
    wire::encode_request(&header, &rows, &mut bytes);
    let mut back = Vec::new();
    match wire::decode_request(&bytes, 512, &mut back) {
        Ok(h) => {
            assert_eq!(back.len(), rows.len());
            assert_eq!(
                (h.kind, h.request_id, h.seed),
                (header.kind, header.request_id, header.seed)
            );
        }
        Err(e) => assert!(
            header.version != PROTOCOL_VERSION,
            "an encoded request of this version does not decode: {e}"
        ),
    }
    if header.kind == KIND_OBSERVE {
        let _ = validate_observe(&header, &rows, 64);
        return;
    }
    let mut scratch = DecodeScratch::new(&LIMITS);
    let Ok(decoded) = decode_request(&header, &rows, &LIMITS, &mut scratch) else {
        return;
    };
    let (params, options) = (decoded.params, decoded.options);
    let states = scratch.states();
    assert_eq!(states.len(), header.agents as usize);
    let mut batch = TrajectoryBatch::new();
    if let Err(e) = predict_with(&MAP, states, &params, &options, &mut batch) {
        panic!("an accepted request does not predict: {e:?}\n{header:?}\n{decoded:?}");
    }
    assert_eq!(batch.scores().len(), if options.scores { batch.lens().len() } else { 0 });
});
