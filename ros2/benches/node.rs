//! The node's path from a People message of 30 people (THÖR1) to the published
//! predictions (k 20, 12 s at 0.4 s, in-process on the THÖR1 map), stage by stage:
//!
//! * `decode`: the message's CDR bytes to our struct (RustDDS's adapter, as the
//!   subscription does);
//! * `histories`: applying it to the tracks (`Engine::on_people`; includes stepping the
//!   reused message to its next stamp, 30 writes);
//! * `prediction`: `Engine::predict` (the prediction itself, `LocalPredictor`);
//! * `build_predictions`, `encode_predictions`: the predictions message
//!   (`Engine::build_predictions`) and its CDR bytes (what its publisher serializes);
//! * `build_objects`, `encode_objects`: the same people as Autoware's
//!   `PredictedObjects` (`Engine::build_objects`, 3 paths each) and its CDR bytes;
//! * `build_grid`, `encode_grid`: the occupancy grid (`Engine::build_grid`, the
//!   default 20 x 20 m at 0.25 m, window 0..1.6 s) and its CDR bytes;
//! * `build_markers`, `encode_markers`: the 600 line strips (`Engine::build_markers`)
//!   and the MarkerArray's CDR bytes.
//!
//! Criterion measures each stage's mean per iteration; then `percentiles` times 300 single
//! runs of each stage and prints p50 and p99 (criterion reports no per-call tails), and
//! the node's share on the way to the predictions (decode + histories + build and encode
//! of the predictions), the objects', the grid's and the markers' (their build and
//! encode), and the node's share with and without the objects and the grid.
//!
//!     cargo bench -p cliff-ros2 --bench node

use std::hint::black_box;
use std::time::{Duration, Instant};

use cliff::predict::Params;
use cliff_ros2::engine::Engine;
use cliff_ros2::grid::{GridBuilder, GridSettings};
use cliff_ros2::markers::MarkerStyle;
use cliff_ros2::msg::{MarkerArray, OccupancyGrid, People, PredictedObjects, Predictions};
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
    engine.set_grid(Some(GridBuilder::new(GridSettings::default())));
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

fn build_predictions(s: &mut Setup) {
    s.engine.build_predictions();
}

fn encode_predictions(s: &mut Setup) -> usize {
    let p = s.engine.output().predictions().expect("predicted");
    CDRSerializerAdapter::<Predictions>::to_bytes(p)
        .expect("serializes")
        .len()
}

fn build_objects(s: &mut Setup) {
    s.engine.build_objects();
}

fn encode_objects(s: &mut Setup) -> usize {
    let o = s.engine.output().objects().expect("predicted");
    CDRSerializerAdapter::<PredictedObjects>::to_bytes(o)
        .expect("serializes")
        .len()
}

fn build_grid(s: &mut Setup) {
    s.engine.build_grid(s.now);
}

fn encode_grid(s: &mut Setup) -> usize {
    let g = s.engine.output().grid().expect("a grid");
    CDRSerializerAdapter::<OccupancyGrid>::to_bytes(g)
        .expect("serializes")
        .len()
}

fn build_markers(s: &mut Setup) {
    s.engine.clear_output();
    s.engine.build_markers();
}

fn encode_markers(s: &mut Setup) -> usize {
    CDRSerializerAdapter::<MarkerArray>::to_bytes(s.engine.output().markers())
        .expect("serializes")
        .len()
}

fn stages(c: &mut Criterion) {
    let mut s = setup();
    let mut g = c.benchmark_group("ros2_node_30_people");
    g.sample_size(30).measurement_time(Duration::from_secs(4));
    g.bench_function("decode", |b| b.iter(|| black_box(decode(&mut s))));
    g.bench_function("histories", |b| b.iter(|| histories(&mut s)));
    g.bench_function("prediction", |b| b.iter(|| black_box(prediction(&mut s))));
    g.bench_function("build_predictions", |b| {
        b.iter(|| build_predictions(&mut s))
    });
    g.bench_function("encode_predictions", |b| {
        b.iter(|| black_box(encode_predictions(&mut s)))
    });
    g.bench_function("build_objects", |b| b.iter(|| build_objects(&mut s)));
    g.bench_function("encode_objects", |b| {
        b.iter(|| black_box(encode_objects(&mut s)))
    });
    g.bench_function("build_grid", |b| b.iter(|| build_grid(&mut s)));
    g.bench_function("encode_grid", |b| b.iter(|| black_box(encode_grid(&mut s))));
    g.bench_function("build_markers", |b| b.iter(|| build_markers(&mut s)));
    g.bench_function("encode_markers", |b| {
        b.iter(|| black_box(encode_markers(&mut s)))
    });
    g.finish();
}

fn percentile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn percentiles(_c: &mut Criterion) {
    let mut s = setup();
    const RUNS: usize = 300;
    const STAGES: [&str; 11] = [
        "decode",
        "histories",
        "prediction",
        "build_predictions",
        "encode_predictions",
        "build_objects",
        "encode_objects",
        "build_grid",
        "encode_grid",
        "build_markers",
        "encode_markers",
    ];
    let mut times: Vec<Vec<f64>> = (0..STAGES.len())
        .map(|_| Vec::with_capacity(RUNS))
        .collect();
    for _ in 0..RUNS {
        let mut t = [Instant::now(); STAGES.len() + 1];
        black_box(decode(&mut s));
        t[1] = Instant::now();
        histories(&mut s);
        t[2] = Instant::now();
        black_box(prediction(&mut s));
        t[3] = Instant::now();
        build_predictions(&mut s);
        t[4] = Instant::now();
        black_box(encode_predictions(&mut s));
        t[5] = Instant::now();
        build_objects(&mut s);
        t[6] = Instant::now();
        black_box(encode_objects(&mut s));
        t[7] = Instant::now();
        build_grid(&mut s);
        t[8] = Instant::now();
        black_box(encode_grid(&mut s));
        t[9] = Instant::now();
        build_markers(&mut s);
        t[10] = Instant::now();
        black_box(encode_markers(&mut s));
        t[11] = Instant::now();
        for (i, v) in times.iter_mut().enumerate() {
            v.push((t[i + 1] - t[i]).as_secs_f64() * 1e3);
        }
    }
    let sum = |stages: &[usize]| -> Vec<f64> {
        (0..RUNS)
            .map(|r| stages.iter().map(|&i| times[i][r]).sum())
            .collect()
    };
    let mut to_predictions = sum(&[0, 1, 3, 4]);
    let mut objects = sum(&[5, 6]);
    let mut grid = sum(&[7, 8]);
    let mut with_both = sum(&[0, 1, 3, 4, 5, 6, 7, 8]);
    let mut markers = sum(&[9, 10]);
    println!("ros2 node, 30 people, k 20, 12 s at 0.4 s: {RUNS} single runs per stage (ms)");
    for (name, v) in STAGES.iter().zip(times.iter_mut()) {
        let p50 = percentile(v, 0.5);
        let p99 = percentile(v, 0.99);
        println!("  {name:<20} p50 {p50:8.4}  p99 {p99:8.4}");
    }
    for (name, v) in [
        (
            "node adds, to the predictions (decode, histories, build and encode predictions)",
            &mut to_predictions,
        ),
        ("objects (build and encode)", &mut objects),
        ("grid (build and encode)", &mut grid),
        (
            "node adds, to the predictions, the objects and the grid",
            &mut with_both,
        ),
        ("markers (build and encode)", &mut markers),
    ] {
        let p50 = percentile(v, 0.5);
        let p99 = percentile(v, 0.99);
        println!("  {name}: p50 {p50:.4}  p99 {p99:.4}");
    }
}

criterion_group!(benches, stages, percentiles);
criterion_main!(benches);
