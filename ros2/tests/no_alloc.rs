//! The node's own steady path allocates nothing per message: applying a People (or
//! TrackedObjects) message of 30 people and running a cycle (prediction in-process on
//! the THÖR1 map, then the predictions message, the line strips and the
//! `PredictedObjects` and the occupancy grid, built into the
//! engine's reused output) makes no heap allocation once the tracks exist and the
//! buffers are sized. Counted by a global allocator that wraps the system one. (Decoding
//! and serializing the CDR bytes are RustDDS's, outside this path.)

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use cliff::predict::Params;
use cliff_ros2::engine::Engine;
use cliff_ros2::grid::{GridBuilder, GridSettings};
use cliff_ros2::markers::MarkerStyle;
use cliff_ros2::msg::{ObjectClassification, TrackedObject, TrackedObjects};
use cliff_ros2::predictor::{PredictSettings, Predictor, Source};
use cliff_ros2::tracks::{Keeper, KeeperSettings};

#[path = "../benches/common/thor30.rs"]
mod thor30;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// The count is process-wide: one test at a time.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn engine() -> Engine {
    let mut e = engine_without_grid();
    e.set_grid(Some(GridBuilder::new(GridSettings::default())));
    e
}

fn engine_without_grid() -> Engine {
    let settings = PredictSettings {
        params: Params {
            k: 20,
            horizon: 12.0,
            dt: 0.4,
            ..Params::default()
        },
        ..PredictSettings::default()
    };
    Engine::new(
        Keeper::new(KeeperSettings::default()),
        Predictor::new(&Source::Local(thor30::MAP.into()), settings).expect("THÖR1 map"),
        MarkerStyle::default(),
        Duration::from_secs(5),
    )
}

#[test]
fn steady_people_cycles_do_not_allocate() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let thor = thor30::Thor30::load();
    let mut e = engine();
    let mut msg = thor.message(0);
    let now = Instant::now();
    // warm-up: tracks created, rings filled, every buffer at its size
    for n in 0..40 {
        thor.update(&mut msg, n);
        e.on_people(&msg, now);
        e.cycle(now);
    }
    let predicted = e.stats().predicted;
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for n in 40..60 {
        thor.update(&mut msg, n);
        e.on_people(&msg, now);
        let out = e.cycle(now);
        assert_eq!(out.predictions().map(|p| p.people.len()), Some(30));
        assert_eq!(out.markers().markers.len(), 30 * 20);
        let objects = out.objects().expect("objects each cycle");
        assert_eq!(objects.objects.len(), 30);
        assert!(
            objects
                .objects
                .iter()
                .all(|o| o.kinematics.predicted_paths.len() == 3)
        );
        let grid = out.grid().expect("a grid each cycle");
        assert_eq!(grid.data.len(), 80 * 80);
        assert!(grid.data.iter().any(|&v| v > 0));
    }
    let allocations = ALLOCATIONS.load(Ordering::Relaxed) - before;
    assert_eq!(e.stats().predicted, predicted + 20);
    assert_eq!(
        allocations, 0,
        "allocations in 20 steady cycles of 30 people"
    );
}

#[test]
fn steady_tracked_objects_cycles_do_not_allocate() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let thor = thor30::Thor30::load();
    let mut e = engine();
    let people = thor.message(0);
    let mut msg = TrackedObjects {
        header: people.header.clone(),
        objects: (0..30u8)
            .map(|j| {
                let mut o = TrackedObject::default();
                o.object_id.uuid[15] = j;
                o.classification.push(ObjectClassification {
                    label: ObjectClassification::PEDESTRIAN,
                    probability: 0.9,
                });
                o
            })
            .collect(),
    };
    let mut people = people;
    let now = Instant::now();
    let mut step = |e: &mut Engine, n: usize| {
        thor.update(&mut people, n);
        msg.header.stamp = people.header.stamp;
        for (o, p) in msg.objects.iter_mut().zip(&people.people) {
            o.kinematics.pose_with_covariance.pose.position = p.position;
        }
        e.on_tracked_objects(&msg, now);
        e.cycle(now).predictions().map(|p| p.people.len())
    };
    for n in 0..40 {
        step(&mut e, n);
    }
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for n in 40..60 {
        assert_eq!(step(&mut e, n), Some(30));
    }
    let allocations = ALLOCATIONS.load(Ordering::Relaxed) - before;
    assert_eq!(
        allocations, 0,
        "allocations in 20 steady cycles of 30 objects"
    );
}
