//! The node's path from a People message of 30 people (THÖR1) to the published
//! predictions (k 20, 12 s at 0.4 s, in-process on the THÖR1 map), stage by stage:
//!
//! * `decode`: the message's CDR bytes to our struct (RustDDS's adapter, as the
//!   subscription does);
//! * `histories`: applying it to the tracks (`Engine::on_people`; includes stepping the
//!   reused message to its next stamp, 30 writes);
//! * `prediction`: `Engine::predict` (the prediction itself, `LocalPredictor`);
//! * `build`: the predictions message and 600 line strips (`Engine::build`);
//! * `encode`: both messages to CDR bytes (what the publishers serialize).
//!
//! Criterion measures each stage's mean per iteration; then `percentiles` times 300 single
//! runs of each stage and prints p50 and p99 (criterion reports no per-call tails), and
//! the node's share: decode + histories + build + encode.
//!
//!     cargo bench -p cliff-ros2 --bench node

use std::hint::black_box;
use std::time::{Duration, Instant};

use cliff::predict::Params;
use cliff_ros2::engine::Engine;
use cliff_ros2::markers::MarkerStyle;
use cliff_ros2::msg::{MarkerArray, People, Predictions};
use cliff_ros2::predictor::{PredictSettings, Predictor, Source};
use cliff_ros2::tracks::{Keeper, KeeperSettings};
use criterion::{Criterion, criterion_group, criterion_main};
use ros2_client::dds::rustdds::no_key::{DeserializerAdapter, SerializerAdapter};
use ros2_client::dds::rustdds::{
    CDRDeserializerAdapter, CDRSerializerAdapter, RepresentationIdentifier,
};

#[path = "common/thor30.rs"]
mod thor30;

struct Setup {
    thor: thor30::Thor30,
    engine: Engine,
    msg: People,
    bytes: Vec<u8>,
    n: usize,
    now: Instant,
}

fn setup() -> Setup {
    let thor = thor30::Thor30::load();
    let settings = PredictSettings {
        params: Params {
            k: 20,
            horizon: 12.0,
            dt: 0.4,
            ..Params::default()
        },
        ..PredictSettings::default()
    };
    let mut engine = Engine::new(
        Keeper::new(KeeperSettings::default()),
        Predictor::new(&Source::Local(thor30::MAP.into()), settings).expect("THÖR1 map"),
        MarkerStyle::default(),
        Duration::from_secs(5),
    );
    let now = Instant::now();
    let mut msg = thor.message(0);
    for n in 0..40 {
        thor.update(&mut msg, n);
        engine.on_people(&msg, now);
        engine.cycle(now);
    }
    let bytes = CDRSerializerAdapter::<People>::to_bytes(&msg)
        .expect("serializes")
        .to_vec();
    assert_eq!(
        engine.output().predictions().map(|p| p.people.len()),
        Some(30)
    );
    Setup {
        thor,
        engine,
        msg,
        bytes,
        n: 40,
        now,
    }
}

fn decode(s: &mut Setup) -> People {
    CDRDeserializerAdapter::<People>::from_bytes(&s.bytes, RepresentationIdentifier::CDR_LE)
        .expect("decodes")
}

fn histories(s: &mut Setup) {
    s.thor.update(&mut s.msg, s.n);
    s.n += 1;
    s.engine.on_people(&s.msg, s.now);
}

fn prediction(s: &mut Setup) -> bool {
    s.engine.predict(s.now)
}

fn build(s: &mut Setup) {
    s.engine.clear_output();
    s.engine.build();
}

fn encode(s: &mut Setup) -> usize {
    let out = s.engine.output();
    let p = CDRSerializerAdapter::<Predictions>::to_bytes(out.predictions().expect("predicted"))
        .expect("serializes");
    let m = CDRSerializerAdapter::<MarkerArray>::to_bytes(out.markers()).expect("serializes");
    p.len() + m.len()
}

fn stages(c: &mut Criterion) {
    let mut s = setup();
    let mut g = c.benchmark_group("ros2_node_30_people");
    g.sample_size(30).measurement_time(Duration::from_secs(4));
    g.bench_function("decode", |b| b.iter(|| black_box(decode(&mut s))));
    g.bench_function("histories", |b| b.iter(|| histories(&mut s)));
    g.bench_function("prediction", |b| b.iter(|| black_box(prediction(&mut s))));
    g.bench_function("build", |b| b.iter(|| build(&mut s)));
    g.bench_function("encode", |b| b.iter(|| black_box(encode(&mut s))));
    g.finish();
}

fn percentile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn percentiles(_c: &mut Criterion) {
    let mut s = setup();
    const RUNS: usize = 300;
    let mut times: Vec<Vec<f64>> = (0..5).map(|_| Vec::with_capacity(RUNS)).collect();
    for _ in 0..RUNS {
        let t = Instant::now();
        black_box(decode(&mut s));
        let t1 = Instant::now();
        histories(&mut s);
        let t2 = Instant::now();
        black_box(prediction(&mut s));
        let t3 = Instant::now();
        build(&mut s);
        let t4 = Instant::now();
        black_box(encode(&mut s));
        let t5 = Instant::now();
        for (i, (a, b)) in [(t, t1), (t1, t2), (t2, t3), (t3, t4), (t4, t5)]
            .into_iter()
            .enumerate()
        {
            times[i].push((b - a).as_secs_f64() * 1e3);
        }
    }
    let mut node: Vec<f64> = (0..RUNS)
        .map(|r| times[0][r] + times[1][r] + times[3][r] + times[4][r])
        .collect();
    println!("ros2 node, 30 people, k 20, 12 s at 0.4 s: {RUNS} single runs per stage (ms)");
    for (name, v) in ["decode", "histories", "prediction", "build", "encode"]
        .iter()
        .zip(times.iter_mut())
    {
        let p50 = percentile(v, 0.5);
        let p99 = percentile(v, 0.99);
        println!("  {name:<12} p50 {p50:8.4}  p99 {p99:8.4}");
    }
    let p50 = percentile(&mut node, 0.5);
    let p99 = percentile(&mut node, 0.99);
    println!(
        "  {:<12} p50 {p50:8.4}  p99 {p99:8.4}  (decode + histories + build + encode)",
        "node adds"
    );
}

criterion_group!(benches, stages, percentiles);
criterion_main!(benches);
